//! Why a scan could not run or stopped, and what to do when it stops on a device or disk error:
//! the advice that ends the one-line message a user sees (`ScanError::Stopped`).

use super::clearance::UnderLoad;
use super::press::PressError;
use crate::acquire::recorder::RecorderError;
use crate::axis::AxisError;
use crate::force::ForceError;
use crate::store::error::StoreError;
use std::path::Path;

/// Why a scan could not run or stopped on a fault.
#[derive(Debug, thiserror::Error)]
pub enum ScanError {
    #[error(transparent)]
    Axis(#[from] AxisError),
    #[error(transparent)]
    Force(#[from] ForceError),
    #[error(transparent)]
    Camera(#[from] crate::camera::CameraError),
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error(transparent)]
    Press(#[from] PressError),
    #[error(transparent)]
    Recorder(#[from] RecorderError),
    /// A load where there must be none (at the safe height, at a tare, on a lateral move).
    #[error(transparent)]
    UnderLoad(#[from] UnderLoad),
    #[error("{0}")]
    Setup(String),
    /// A scan that stopped on an error once its run was open: the run keeps what was recorded.
    #[error("{source}. The run {} keeps everything recorded before this; {}, then resume it", run.display(), advice(source))]
    Stopped {
        run: std::path::PathBuf,
        source: Box<ScanError>,
    },
}

impl ScanError {
    /// This error as the end of the scan of the run in `run` (an error that already names its
    /// run is kept as it is).
    pub fn stopped(self, run: &Path) -> ScanError {
        match self {
            ScanError::Stopped { .. } => self,
            other => ScanError::Stopped {
                run: run.to_path_buf(),
                source: Box::new(other),
            },
        }
    }

    /// The error that stopped the scan, without the run it stopped.
    pub fn cause(&self) -> &ScanError {
        match self {
            ScanError::Stopped { source, .. } => source.cause(),
            other => other,
        }
    }
}

/// What the user should do about `e` before resuming the run.
pub(crate) fn advice(e: &ScanError) -> String {
    match e.cause() {
        ScanError::Axis(a) => axis_advice(a),
        ScanError::Press(PressError::Axis(a)) => axis_advice(a),
        ScanError::Press(PressError::Force { .. }) => {
            "check the force sensor's power and cable".into()
        }
        ScanError::Press(_) => "check the plan's forces against the sensor and the rig".into(),
        ScanError::Force(f) => force_advice(f),
        ScanError::Camera(_) => {
            "check the camera's cable and power (a camera that stalls: its trigger and frame rate)"
                .into()
        }
        ScanError::Store(s) | ScanError::Recorder(RecorderError::Store(s)) => store_advice(s),
        ScanError::Recorder(_) => {
            "check the disk that holds the runs and the machine's load".into()
        }
        ScanError::UnderLoad(_) => {
            "take away what touches the indenter, or give the plan a safe height (approach.safe_z) clear of the sensor surface and check the rig's contact height (a plan that changes is a new run)".into()
        }
        ScanError::Setup(_) | ScanError::Stopped { .. } => "fix the cause above".into(),
    }
}

fn axis_advice(a: &AxisError) -> String {
    let axis = axis_name(a);
    match a {
        AxisError::Io { .. } => format!(
            "axis {axis}'s controller is gone: plug its cable back in and check its power"
        ),
        AxisError::NotAnswering { .. } => format!(
            "axis {axis}'s controller stopped answering: check its power and cable (power-cycle it if it stays silent)"
        ),
        AxisError::Timeout { .. } => format!(
            "axis {axis} did not finish in time: check that nothing blocks the stage and the rig file's velocity"
        ),
        AxisError::SoftLimit { .. } | AxisError::NotANumber { .. } => {
            "check the plan against the rig file's soft limits".into()
        }
        AxisError::Motion { .. } => {
            "check the plan's [slide] speeds against the rig file's axis kinematics".into()
        }
        _ => format!("check axis {axis}'s controller: its power, its cable and its fault lights"),
    }
}

fn axis_name(a: &AxisError) -> &str {
    match a {
        AxisError::Device { axis, .. }
        | AxisError::Timeout { axis, .. }
        | AxisError::NotAnswering { axis, .. }
        | AxisError::NotANumber { axis, .. }
        | AxisError::SoftLimit { axis, .. }
        | AxisError::Fault { axis, .. }
        | AxisError::Mismatch { axis, .. }
        | AxisError::Io { axis, .. }
        | AxisError::Motion { axis, .. }
        | AxisError::Cancelled { axis } => axis,
    }
}

fn force_advice(f: &ForceError) -> String {
    match f {
        ForceError::NoData { .. } | ForceError::Io { .. } => {
            "check the force sensor's power and cable (a Net F/T: its network link; after a reboot it needs a new bias, which the resume takes)".into()
        }
        ForceError::Status { .. } => {
            "check the force sensor for overload or a broken gauge (its status word is above)".into()
        }
        _ => "check the force sensor".into(),
    }
}

fn store_advice(s: &StoreError) -> String {
    if let StoreError::Busy { .. } = s {
        "let the process that holds the run end (or stop it)".into()
    } else if let StoreError::InsideRun(_) = s {
        "choose a directory for the runs outside every run".into()
    } else if is_disk_full(s) {
        "free space on the disk that holds the runs".into()
    } else {
        "check that the disk holding the runs is mounted and writable".into()
    }
}

/// Whether a store error is a full disk (or quota).
pub(crate) fn is_disk_full(s: &StoreError) -> bool {
    let full = |e: &std::io::Error| matches!(e.raw_os_error(), Some(libc::ENOSPC | libc::EDQUOT));
    match s {
        StoreError::Io { source, .. } => full(source),
        StoreError::Content { message, .. } => {
            message.contains("No space left on device") || message.contains("Disk quota exceeded")
        }
        StoreError::Parse { .. }
        | StoreError::NotARun { .. }
        | StoreError::Busy { .. }
        | StoreError::InsideRun(_)
        | StoreError::Unverified { .. } => false,
    }
}
