//! Frame files (PNG or TIFF) read for calibration: one loader for the image folders of
//! `fringe calibrate --images` and the frames of a calibration scan's run.

use crate::optical::grey::{self, GreyImage};
use fringe_rig::store;
use fringe_rig::store::FrameStorage;
use std::path::{Path, PathBuf};

/// A frame file that could not be used, naming it.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("cannot read image {path} (not a readable PNG or TIFF): {source}")]
    Read {
        path: PathBuf,
        source: image::ImageError,
    },
    #[error(
        "mixed image sizes: {path} is {got_w}x{got_h} px but {first} is {want_w}x{want_h} px; calibrate one camera setting at a time"
    )]
    Size {
        path: PathBuf,
        first: PathBuf,
        got_w: usize,
        got_h: usize,
        want_w: usize,
        want_h: usize,
    },
    #[error("no frames to read")]
    Empty,
    #[error("cannot read frame {path}: {message}")]
    Stored { path: PathBuf, message: String },
}

/// Reads one frame file: as its run stored it when `storage` is given (a BayerRG8 mosaic
/// demosaiced by fringe's one demosaicing), else as an ordinary image. Calibration needs whole
/// frames: a run that stored only the disc's square is refused.
pub(crate) fn read(
    path: &Path,
    storage: Option<&FrameStorage>,
) -> Result<image::DynamicImage, FrameError> {
    let (image, cutout) = decode(path, storage)?;
    if cutout.is_some() {
        return Err(FrameError::Stored {
            path: path.to_path_buf(),
            message: "the run stored only the square around the disc: calibration needs whole \
                      frames (run a calibration scan, which stores them)"
                .into(),
        });
    }
    Ok(image)
}

/// Reads one frame file as [`read`] does, but a run's cutout (the square around the disc) is
/// placed where it lies in the camera's frame, black around it: for measurements inside the
/// disc and just around it (the health check), which the cutout's margin holds.
pub(crate) fn read_placed(path: &Path, storage: &FrameStorage) -> Result<GreyImage, FrameError> {
    let (image, cutout) = decode(path, Some(storage))?;
    let grey = GreyImage::from_image(&image);
    let Some(c) = cutout else {
        return Ok(grey);
    };
    let (w, h) = (c.frame_width as usize, c.frame_height as usize);
    let (x0, y0) = (c.roi.x as usize, c.roi.y as usize);
    if x0 + grey.width > w || y0 + grey.height > h {
        return Err(FrameError::Stored {
            path: path.to_path_buf(),
            message: format!(
                "its {}x{} px cutout at ({x0}, {y0}) does not fit the {w}x{h} px frame the run \
                 names",
                grey.width, grey.height
            ),
        });
    }
    let mut data = vec![0.0f32; w * h];
    for (j, row) in grey.data.chunks(grey.width).enumerate() {
        let at = (y0 + j) * w + x0;
        data[at..at + grey.width].copy_from_slice(row);
    }
    GreyImage::from_values(w, h, data).ok_or(FrameError::Empty)
}

/// A frame file's pixels as an image, and the part of the camera's frame they are.
fn decode(
    path: &Path,
    storage: Option<&FrameStorage>,
) -> Result<(image::DynamicImage, Option<fringe_rig::Cutout>), FrameError> {
    let Some(storage) = storage else {
        return image::open(path)
            .map(|i| (i, None))
            .map_err(|source| FrameError::Read {
                path: path.to_path_buf(),
                source,
            });
    };
    let stored = storage.read(path).map_err(|e| FrameError::Stored {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let (w, h) = (stored.width, stored.height);
    let image = store::pixels_to_image(w, h, stored.format, stored.data);
    let image = image.ok_or_else(|| FrameError::Stored {
        path: path.to_path_buf(),
        message: format!("{w}x{h} pixels do not match the file's bytes"),
    })?;
    Ok((image, stored.cutout))
}

/// At most `max` of `paths`, spread evenly over them (first one included).
pub fn spread<T: Clone>(paths: &[T], max: usize) -> Vec<T> {
    let step = paths.len().div_ceil(max.max(1)).max(1);
    paths.iter().step_by(step).cloned().collect()
}

/// The grey mean of the frame files `paths` (all the same size), read as [`read`] does.
pub fn grey_average(
    paths: &[PathBuf],
    storage: Option<&FrameStorage>,
) -> Result<GreyImage, FrameError> {
    let first = paths.first().ok_or(FrameError::Empty)?;
    let mut frames = Vec::with_capacity(paths.len());
    for path in paths {
        let g = GreyImage::from_image(&read(path, storage)?);
        check_size(path, first, &frames, g.width, g.height)?;
        frames.push(g);
    }
    match grey::average(&frames) {
        Ok(Some(avg)) => Ok(avg),
        Ok(None) => Err(FrameError::Empty),
        Err(e) => Err(FrameError::Size {
            path: paths[e.index].clone(),
            first: first.clone(),
            got_w: e.got_w,
            got_h: e.got_h,
            want_w: e.want_w,
            want_h: e.want_h,
        }),
    }
}

/// The RGB mean of the frame files `paths` (all the same size), as f32 DN row-major RGB.
#[cfg(test)]
pub(crate) fn rgb_average(
    paths: &[PathBuf],
    storage: Option<&FrameStorage>,
) -> Result<(usize, usize, Vec<f32>), FrameError> {
    let first = paths.first().ok_or(FrameError::Empty)?;
    let mut sum: Vec<f32> = Vec::new();
    let (mut w, mut h) = (0, 0);
    for (k, path) in paths.iter().enumerate() {
        let img = read(path, storage)?.to_rgb8();
        let (iw, ih) = (img.width() as usize, img.height() as usize);
        if k == 0 {
            (w, h) = (iw, ih);
            sum = vec![0.0; w * h * 3];
        } else if (iw, ih) != (w, h) {
            return Err(FrameError::Size {
                path: path.clone(),
                first: first.clone(),
                got_w: iw,
                got_h: ih,
                want_w: w,
                want_h: h,
            });
        }
        for (s, &v) in sum.iter_mut().zip(img.as_raw()) {
            *s += v as f32;
        }
    }
    let n = paths.len() as f32;
    sum.iter_mut().for_each(|s| *s /= n);
    Ok((w, h, sum))
}

fn check_size(
    path: &Path,
    first: &Path,
    frames: &[GreyImage],
    w: usize,
    h: usize,
) -> Result<(), FrameError> {
    match frames.first() {
        Some(f) if (f.width, f.height) != (w, h) => Err(FrameError::Size {
            path: path.to_path_buf(),
            first: first.to_path_buf(),
            got_w: w,
            got_h: h,
            want_w: f.width,
            want_h: f.height,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_keeps_at_most_max_evenly() {
        let v: Vec<u32> = (0..10).collect();
        assert_eq!(spread(&v, 3), vec![0, 4, 8]);
        assert_eq!(spread(&v, 20), v);
        assert_eq!(spread(&v, 1), vec![0]);
    }

    #[test]
    fn mixed_sizes_name_both_files() {
        let dir = std::env::temp_dir().join(format!("fringe-frames-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let a = dir.join("a.png");
        let b = dir.join("b.png");
        image::RgbImage::new(8, 6).save(&a).expect("a");
        image::RgbImage::new(6, 6).save(&b).expect("b");
        let e = grey_average(&[a.clone(), b.clone()], None).expect_err("sizes differ");
        let text = e.to_string();
        assert!(text.contains("b.png") && text.contains("a.png"), "{text}");
        let e = rgb_average(&[a, b], None).expect_err("sizes differ");
        assert!(e.to_string().contains("6x6 px"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
