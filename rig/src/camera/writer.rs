//! Saving frames losslessly: one PNG per frame plus a CSV of frame timing.
//!
//! Mono8 frames are 8-bit grey PNGs and Rgb8 frames 8-bit RGB PNGs. Bayer frames are stored
//! as-is (the raw mosaic, not demosaiced) in an 8-bit grey PNG; the CSV and camera traces note
//! the format so a reader knows to demosaic.

use super::{Frame, PixelFormat};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::ImageEncoder;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Errors from writing or reading frame files, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameFileError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{path}: {source}")]
    Image {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{path}: {message}")]
    Content { path: PathBuf, message: String },
}

impl FrameFileError {
    /// What is wrong, without the file's path (for a caller that names the file itself).
    pub fn reason(&self) -> String {
        match self {
            FrameFileError::Io { source, .. } => source.to_string(),
            FrameFileError::Image { source, .. } => source.to_string(),
            FrameFileError::Content { message, .. } => message.clone(),
        }
    }
}

/// Name used in CSV files and camera traces for a pixel format.
pub fn format_name(format: PixelFormat) -> &'static str {
    match format {
        PixelFormat::Mono8 => "mono8",
        PixelFormat::Rgb8 => "rgb8",
        PixelFormat::BayerRg8 => "bayerrg8",
    }
}

/// Parses a name written by [`format_name`].
pub fn parse_format_name(name: &str) -> Option<PixelFormat> {
    match name {
        "mono8" => Some(PixelFormat::Mono8),
        "rgb8" => Some(PixelFormat::Rgb8),
        "bayerrg8" => Some(PixelFormat::BayerRg8),
        _ => None,
    }
}

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
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Sub)
        .write_image(
            &frame.data,
            frame.width,
            frame.height,
            colour_type(frame.format),
        )
        .map_err(|source| FrameFileError::Image {
            path: path.to_path_buf(),
            source,
        })?;
    out.flush().map_err(io)
}

/// Reads the pixels of a PNG written by [`save_png`], checking its size and colour type.
pub fn load_png(
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
pub fn open_image(path: &Path) -> Result<image::DynamicImage, FrameFileError> {
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
pub fn read_pixels(
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

/// Saves frames as `frame-NNNNNN.png` (NNNNNN = order of arrival) in a directory, with
/// `frames.csv`: `seq,id,device_timestamp,host_arrival_ns,width,height,format,file`.
///
/// `host_arrival_ns` is [`crate::clock::HostTime`] in nanoseconds (the process-wide monotonic
/// epoch), `device_timestamp` the camera's timestamp as delivered.
pub struct FrameWriter {
    dir: PathBuf,
    csv: BufWriter<File>,
    csv_path: PathBuf,
    count: u64,
}

impl FrameWriter {
    /// Creates `dir` if needed and starts `dir/frames.csv` (replacing an existing one).
    pub fn create(dir: &Path) -> Result<FrameWriter, FrameFileError> {
        std::fs::create_dir_all(dir).map_err(|source| FrameFileError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let csv_path = dir.join("frames.csv");
        let file = File::create(&csv_path).map_err(|source| FrameFileError::Io {
            path: csv_path.clone(),
            source,
        })?;
        let mut csv = BufWriter::new(file);
        writeln!(
            csv,
            "seq,id,device_timestamp,host_arrival_ns,width,height,format,file"
        )
        .map_err(|source| FrameFileError::Io {
            path: csv_path.clone(),
            source,
        })?;
        Ok(FrameWriter {
            dir: dir.to_path_buf(),
            csv,
            csv_path,
            count: 0,
        })
    }

    /// Writes one frame's PNG and CSV row; returns the PNG path.
    pub fn write(&mut self, frame: &Frame) -> Result<PathBuf, FrameFileError> {
        let name = format!("frame-{:06}.png", self.count);
        let path = self.dir.join(&name);
        save_png(frame, &path)?;
        writeln!(
            self.csv,
            "{},{},{},{},{},{},{},{}",
            self.count,
            frame.id,
            frame.device_timestamp,
            frame.host_arrival.nanos(),
            frame.width,
            frame.height,
            format_name(frame.format),
            name
        )
        .and_then(|()| self.csv.flush())
        .map_err(|source| FrameFileError::Io {
            path: self.csv_path.clone(),
            source,
        })?;
        self.count += 1;
        Ok(path)
    }

    /// Number of frames written.
    pub fn count(&self) -> u64 {
        self.count
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

    #[test]
    fn writer_refuses_frames_of_the_wrong_size_and_writes_csv_rows() {
        let dir = std::env::temp_dir().join(format!("fringe-writer-csv-{}", std::process::id()));
        let mut w = FrameWriter::create(&dir).expect("create");
        let mut bad = frame(PixelFormat::Mono8);
        bad.data.pop();
        assert!(w.write(&bad).is_err());
        w.write(&frame(PixelFormat::Mono8)).expect("write");
        let csv = std::fs::read_to_string(dir.join("frames.csv")).expect("csv");
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[1], "0,7,123,9,5,3,mono8,frame-000000.png");
        std::fs::remove_dir_all(&dir).ok();
    }
}
