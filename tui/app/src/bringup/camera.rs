//! Bringing up a camera (`fringe camera grab`): frames grabbed into a folder with their
//! `frames.csv`, software-triggered when asked, the frame ids' gaps counted; and any opened
//! camera wrapped by the trace recorder.

use fringe_rig::store::FrameFileError;
use fringe_rig::FrameGaps;
use fringe_rig::FrameWriter;
use fringe_rig::{
    Camera, CameraError, CameraInfo, CameraSettings, Frame, TimestampLatch, TriggerMode,
};
use std::path::Path;
use std::time::Duration;

/// Why a grab failed.
#[derive(Debug, thiserror::Error)]
pub enum GrabError {
    #[error("{0}")]
    Camera(#[source] CameraError),
    #[error("{0}")]
    Frames(#[source] FrameFileError),
    #[error("camera {camera}: no frame within {} ms after {got} of {wanted} frames (check the trigger mode, cable and frame rate)", timeout.as_millis())]
    NoFrame {
        camera: String,
        timeout: Duration,
        got: u64,
        wanted: u64,
    },
}

/// A grab's frames.
#[derive(Debug)]
pub struct Grabbed {
    /// The camera's id.
    pub camera: String,
    /// Frames written.
    pub frames: u64,
    /// Frame ids missing between the first and the last (frames the camera dropped).
    pub dropped: u64,
    /// Whether the camera stopped cleanly after them.
    pub stopped: Result<(), CameraError>,
}

/// Grabs `count` frames from `camera` set up with `settings` into `out` (with `frames.csv`),
/// waiting at most `timeout` for each; the camera is stopped whatever happened.
pub fn grab(
    camera: &mut dyn Camera,
    settings: &CameraSettings,
    out: &Path,
    count: u64,
    timeout: Duration,
) -> Result<Grabbed, GrabError> {
    let info = camera.info();
    camera.configure(settings).map_err(GrabError::Camera)?;
    let mut writer = FrameWriter::create(out).map_err(GrabError::Frames)?;
    camera.start().map_err(GrabError::Camera)?;
    let mut gaps = FrameGaps::default();
    let result = (|| -> Result<(), GrabError> {
        while writer.count() < count {
            if settings.trigger == TriggerMode::Software {
                camera.trigger().map_err(GrabError::Camera)?;
            }
            let Some(frame) = camera.next_frame(timeout).map_err(GrabError::Camera)? else {
                return Err(GrabError::NoFrame {
                    camera: info.id.clone(),
                    timeout,
                    got: writer.count(),
                    wanted: count,
                });
            };
            gaps.observe(frame.id);
            writer.write(&frame).map_err(GrabError::Frames)?;
        }
        Ok(())
    })();
    let stopped = camera.stop();
    result?;
    Ok(Grabbed {
        camera: info.id,
        frames: writer.count(),
        dropped: gaps.dropped(),
        stopped,
    })
}

/// A boxed camera as a camera, so that the trace recorder can wrap whichever source was opened.
pub struct Boxed(pub Box<dyn Camera>);

impl Camera for Boxed {
    fn info(&self) -> CameraInfo {
        self.0.info()
    }
    fn configure(&mut self, s: &CameraSettings) -> Result<(), CameraError> {
        self.0.configure(s)
    }
    fn start(&mut self) -> Result<(), CameraError> {
        self.0.start()
    }
    fn trigger(&mut self) -> Result<(), CameraError> {
        self.0.trigger()
    }
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        self.0.next_frame(timeout)
    }
    fn stop(&mut self) -> Result<(), CameraError> {
        self.0.stop()
    }
    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError> {
        self.0.latch_timestamp()
    }
}
