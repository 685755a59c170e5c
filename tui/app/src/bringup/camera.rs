//! Bringing up a camera (`fringe camera grab`): the camera opened (a GenICam camera or a
//! recorded camera trace) and wrapped by the trace recorder when a trace is asked for; frames
//! grabbed into a folder with their `frames.csv`, software-triggered when asked, the frame ids'
//! gaps counted.

use crate::rig::device_open::{open_camera, DeviceError};
use crate::rig::device_spec::CameraSpec;
use fringe_rig::store::FrameFileError;
use fringe_rig::FrameGaps;
use fringe_rig::FrameWriter;
use fringe_rig::{
    Camera, CameraError, CameraInfo, CameraSettings, Frame, PixelFormat, TimestampLatch,
    TriggerMode,
};
use fringe_rig::{CameraTraceError, RecordingCamera, ReplayCamera, ReplayPace};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where the frames come from.
pub enum CameraSource<'a> {
    /// A GenICam camera (Aravis) by id or address.
    Aravis(&'a str),
    /// A camera trace that `--record-trace` wrote, replayed as fast as it can be.
    Replay(&'a Path),
}

/// A camera that could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum CameraOpenError {
    #[error(transparent)]
    Device(#[from] DeviceError),
    #[error(
        "cannot open the camera trace {} (give a directory that --record-trace wrote)",
        .dir.display()
    )]
    Replay {
        dir: PathBuf,
        #[source]
        source: CameraTraceError,
    },
    #[error("{0}")]
    Record(#[source] CameraError),
}

/// The camera of `source`, its traffic recorded under `trace/camera` when `trace` is given, and
/// the pixel format a replayed trace offers first (`None`: the camera's own).
pub fn open_source(
    source: &CameraSource<'_>,
    trace: Option<&Path>,
) -> Result<(Box<dyn Camera>, Option<PixelFormat>), CameraOpenError> {
    let mut native = None;
    let camera: Box<dyn Camera> = match source {
        CameraSource::Aravis(id) => open_camera(&CameraSpec::Aravis {
            id: Some(id.to_string()),
        })?,
        CameraSource::Replay(dir) => {
            let replay =
                ReplayCamera::open(dir, ReplayPace::AsFastAsPossible).map_err(|source| {
                    CameraOpenError::Replay {
                        dir: dir.to_path_buf(),
                        source,
                    }
                })?;
            native = replay.offered_formats().first().copied();
            Box::new(replay)
        }
    };
    let camera: Box<dyn Camera> = match trace {
        Some(dir) => Box::new(
            RecordingCamera::new(Boxed(camera), &dir.join("camera"), "camera")
                .map_err(CameraOpenError::Record)?,
        ),
        None => camera,
    };
    Ok((camera, native))
}

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
pub(crate) struct Boxed(pub Box<dyn Camera>);

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
