//! PNG frame files: a frame written losslessly as a PNG (Mono8 and Bayer frames as 8-bit grey,
//! the raw mosaic not demosaiced; Rgb8 as 8-bit RGB) and image files read back, checked against
//! the pixel format that should be in them. Camera traces and `fringe camera --save` write their
//! frames here; runs store theirs through [`super::FrameStorage`].

use super::error::FrameFileError;
use crate::camera::{format_name, Frame, PixelFormat};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::ImageEncoder;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

fn colour_type(format: PixelFormat) -> image::ExtendedColorType {
    match format {
        PixelFormat::Mono8 | PixelFormat::BayerRg8 => image::ExtendedColorType::L8,
        PixelFormat::Rgb8 => image::ExtendedColorType::Rgb8,
    }
}

/// Writes `frame` to `path` as a lossless PNG (Bayer frames as the raw mosaic in grey).
pub fn save_png(frame: &Frame, path: &Path) -> Result<(), FrameFileError> {
    let expected = frame.width as usize * frame.height as usize * frame.format.bytes_per_pixel();
    if frame.data.len() != expected {
        return Err(FrameFileError::Content {
            path: path.to_path_buf(),
            message: format!(
                "frame {} has {} bytes but {}x{} {} needs {expected}",
                frame.id,
                frame.data.len(),
                frame.width,
                frame.height,
                format_name(frame.format)
            ),
        });
    }
    // Fast deflate with the Sub filter: about 10 ms for a 1920x1200 RGB frame on this machine's
    // cores, against 0.9 s for the default level, at 3.3 instead of 3.2 MB (BENCHMARKS.md).
    // Still lossless; a 50 Hz camera leaves 20 ms per frame.
    let io = |source: io::Error| FrameFileError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = File::create(path).map_err(io)?;
    let mut out = BufWriter::with_capacity(1 << 20, file);
    write_png(
        &mut out,
        frame.width,
        frame.height,
        frame.format,
        &frame.data,
    )
    .map_err(|source| FrameFileError::Image {
        path: path.to_path_buf(),
        source,
    })?;
    out.flush().map_err(io)
}

/// Writes `width` x `height` pixels of `format` as a PNG to `out`, as the run store writes its
/// PNG frames (fast deflate, the Sub filter; lossless): one channel as grey (a Bayer mosaic as
/// stored), RGB8 as RGB.
pub fn write_png(
    out: impl Write,
    width: u32,
    height: u32,
    format: PixelFormat,
    data: &[u8],
) -> Result<(), image::ImageError> {
    PngEncoder::new_with_quality(out, CompressionType::Fast, FilterType::Sub).write_image(
        data,
        width,
        height,
        colour_type(format),
    )
}

/// Reads the pixels of a PNG written by [`save_png`], checking its size and colour type.
pub(crate) fn load_png(
    path: &Path,
    format: PixelFormat,
    width: u32,
    height: u32,
) -> Result<Vec<u8>, FrameFileError> {
    let (w, h, data) = read_pixels(path, format, "the index says")?;
    if (w, h) != (width, height) {
        return Err(FrameFileError::Content {
            path: path.to_path_buf(),
            message: format!("image is {w}x{h} but the index says {width}x{height}"),
        });
    }
    Ok(data)
}

/// Decodes an image file (PNG, TIFF, ...), naming it in errors.
pub(crate) fn open_image(path: &Path) -> Result<image::DynamicImage, FrameFileError> {
    image::ImageReader::open(path)
        .map_err(|source| FrameFileError::Io {
            path: path.to_path_buf(),
            source,
        })?
        .with_guessed_format()
        .map_err(|source| FrameFileError::Io {
            path: path.to_path_buf(),
            source,
        })?
        .decode()
        .map_err(|source| FrameFileError::Image {
            path: path.to_path_buf(),
            source,
        })
}

/// An image file's width, height and pixels, checked to be 8-bit RGB for RGB8 and 8-bit grey
/// otherwise; `whose` names what says the format in the error ("the index says").
pub(crate) fn read_pixels(
    path: &Path,
    format: PixelFormat,
    whose: &str,
) -> Result<(u32, u32, Vec<u8>), FrameFileError> {
    let img = open_image(path)?;
    let (width, height) = (img.width(), img.height());
    match (format, img) {
        (PixelFormat::Mono8 | PixelFormat::BayerRg8, image::DynamicImage::ImageLuma8(buf)) => {
            Ok((width, height, buf.into_raw()))
        }
        (PixelFormat::Rgb8, image::DynamicImage::ImageRgb8(buf)) => {
            Ok((width, height, buf.into_raw()))
        }
        (format, img) => Err(FrameFileError::Content {
            path: path.to_path_buf(),
            message: format!(
                "image colour type is {:?} but {whose} {} (expected 8-bit {})",
                img.color(),
                format_name(format),
                if format == PixelFormat::Rgb8 {
                    "RGB"
                } else {
                    "grey"
                }
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(format: PixelFormat) -> Frame {
        crate::camera::test_frame(format, 5, 3)
    }

    #[test]
    fn png_round_trip_is_lossless_for_every_format() {
        let dir = std::env::temp_dir().join(format!("fringe-writer-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        for format in [PixelFormat::Mono8, PixelFormat::Rgb8, PixelFormat::BayerRg8] {
            let f = frame(format);
            let path = dir.join(format!("{}.png", format_name(format)));
            save_png(&f, &path).expect("save");
            assert_eq!(
                load_png(&path, format, f.width, f.height).expect("load"),
                f.data
            );
        }
        let err =
            load_png(&dir.join("rgb8.png"), PixelFormat::Mono8, 5, 3).expect_err("colour mismatch");
        assert!(err.to_string().contains("mono8"), "{err}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
