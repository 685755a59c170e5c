//! Saving what a camera delivers: one PNG per frame plus a CSV of frame timing
//! (`fringe camera --save`).
//!
//! Mono8 frames are 8-bit grey PNGs and Rgb8 frames 8-bit RGB PNGs. Bayer frames are stored
//! as-is (the raw mosaic, not demosaiced) in an 8-bit grey PNG; the CSV and camera traces note
//! the format so a reader knows to demosaic.

use super::{format_name, Frame};
use crate::store::frames::error::FrameFileError;
use crate::store::frames::png::save_png;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

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
    use crate::camera::PixelFormat;

    fn frame(format: PixelFormat) -> Frame {
        crate::camera::test_frame(format, 5, 3)
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
