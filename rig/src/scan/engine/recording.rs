//! The recorder's wiring: the force and camera streams started for the scan, the labeler of the
//! run's synchronisation method, the recorder that labels and writes their frames, its end, and
//! the sidecar files appended to the run.

use crate::acquire::camera_stream::CameraStream;
use crate::acquire::clock_fit_labeler::{ClockFitLabeler, ClockFitOptions};
use crate::acquire::force_stream::ForceStream;
use crate::acquire::host_labeler::HostLabeler;
use crate::acquire::labeler::FrameLabeler;
use crate::acquire::recorder::{FrameContext, Recorder, RecorderFailure, RecorderStats};
use crate::acquire::strobe_labeler::StrobeLabeler;
use crate::camera::{Camera, CameraSettings};
use crate::force::ForceSensor;
use crate::scan::failure::ScanError;
use crate::scan::setup::ScanSetup;
use crate::scan::sidecar::RunSidecar;
use crate::store::error::StoreError;
use crate::store::run_writer::RunWriter;
use crate::sync::method::SyncMethod;
use crate::sync::trigger::TriggerTiming;
use std::path::Path;
use std::time::Duration;

/// How often the camera clock is latched (on the camera stream thread), for the methods that
/// place frames by clock (`strobe` to pick each frame's window, `clock-fit` for the window).
pub const LATCH_PERIOD: Duration = Duration::from_millis(250);

/// Exposure end to frame arrival assumed by `strobe` for a camera that gives no timestamp
/// latches (sensor readout and transfer of a USB3 camera: a few ms).
pub(crate) const ASSUMED_READOUT: Duration = Duration::from_millis(5);

/// Strobe level of the ExposureActive channel, V (half the 3.3 V logic level).
pub(crate) const STROBE_THRESHOLD_V: f64 = 1.65;

/// The labeler of synchronisation method `sync` for a camera with `settings` whose timestamps
/// tick at `tick_hz`, taking latches from `cameras` (started with
/// [`CameraStream::spawn_with_latches`]) for `strobe`, `trigger` and `clock-fit`; `trigger`
/// needs the DAQ-triggered camera's timing.
pub fn labeler_for(
    sync: SyncMethod,
    trigger: Option<TriggerTiming>,
    settings: &CameraSettings,
    tick_hz: f64,
    cameras: &CameraStream,
) -> Result<Box<dyn FrameLabeler>, ScanError> {
    Ok(match sync {
        SyncMethod::Strobe => {
            let mut options = ClockFitOptions::new(settings.exposure, tick_hz);
            options.assumed_readout = ASSUMED_READOUT;
            Box::new(StrobeLabeler::new(
                STROBE_THRESHOLD_V,
                options,
                Some(cameras.subscribe_latches()),
            ))
        }
        SyncMethod::ClockFit => Box::new(ClockFitLabeler::new(
            ClockFitOptions::new(settings.exposure, tick_hz),
            Some(cameras.subscribe_latches()),
        )),
        SyncMethod::Trigger => {
            let timing = trigger.ok_or_else(|| {
                ScanError::Setup(
                    "sync \"trigger\" needs the camera triggered by the DAQ ([camera] trigger = \"daq\")"
                        .into(),
                )
            })?;
            let mut options = ClockFitOptions::new(settings.exposure, tick_hz);
            options.assumed_readout = ASSUMED_READOUT;
            Box::new(StrobeLabeler::triggered(
                timing,
                STROBE_THRESHOLD_V,
                options,
                Some(cameras.subscribe_latches()),
            ))
        }
        SyncMethod::Host => Box::new(HostLabeler::new(settings.exposure)),
    })
}

/// The threads that read the devices for the whole scan.
pub(super) struct Streams {
    pub(super) force: ForceStream,
    pub(super) cameras: CameraStream,
}

/// Starts the force and camera streams and the recorder that labels and writes their frames
/// into `writer`'s run.
pub(super) fn start_recording(
    setup: &ScanSetup,
    force: Box<dyn ForceSensor>,
    camera: Box<dyn Camera>,
    writer: RunWriter,
) -> Result<(Streams, Recorder, FrameContext), ScanError> {
    // The camera delivers the pixel format the run stores: a resumed run's, not today's default.
    let settings = CameraSettings {
        pixel_format: writer.frame_storage().pixel_format,
        ..setup.camera.clone()
    };
    let stream = ForceStream::spawn(force)?;
    let tick_hz = camera.info().tick_frequency as f64;
    let cameras = match setup.sync {
        SyncMethod::ClockFit | SyncMethod::Strobe | SyncMethod::Trigger => {
            CameraStream::spawn_with_latches(camera, &settings, LATCH_PERIOD)?
        }
        SyncMethod::Host => CameraStream::spawn(camera, &settings)?,
    };
    let context = FrameContext::default();
    let labeler = labeler_for(setup.sync, setup.trigger, &settings, tick_hz, &cameras)?;
    let recorder = Recorder::spawn(
        writer,
        stream.samples().clone(),
        cameras.frames().clone(),
        labeler,
        context.clone(),
        setup.taps.clone(),
    )?;
    if let Some(refused) = stream.priority_refused() {
        // Not an error: most machines keep the pace without it. The run says so, for when
        // the watchers stop it for F/T silence.
        recorder.event("priority", None, &refused.to_string());
    }
    let streams = Streams {
        force: stream,
        cameras,
    };
    Ok((streams, recorder, context))
}

/// Stops the recorder: its run writer and counts, with the error that stopped it early (its
/// unfinished point's records then cut, so that a full disk gets back the space of their images,
/// enough to close the run).
pub(super) fn finish_recorder(
    recorder: Recorder,
) -> Result<(RunWriter, RecorderStats, Option<StoreError>), ScanError> {
    let last_counts = recorder.stats();
    match recorder.finish() {
        Ok((writer, counts)) => Ok((writer, counts, None)),
        Err(RecorderFailure {
            error,
            writer: Some(writer),
        }) => {
            let mut writer = *writer;
            let _ = writer.rollback();
            Ok((writer, last_counts, Some(error)))
        }
        Err(RecorderFailure {
            error,
            writer: None,
        }) => Err(error.into()),
    }
}

/// Appends the lines a sidecar gathered since it was last taken to its file in the run; `sync`
/// makes them durable (when the run closes; after a point they reach the OS only, a crash of the
/// process loses nothing of them).
pub(super) fn append_sidecar(
    dir: &Path,
    sidecar: &dyn RunSidecar,
    sync: bool,
) -> Result<(), StoreError> {
    use std::io::Write;
    let path = dir.join(sidecar.file_name());
    let mut lines = String::new();
    for line in sidecar.take_lines() {
        lines.push_str(&line);
        lines.push('\n');
    }
    if lines.is_empty() && !sync {
        return Ok(());
    }
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .map_err(|e| StoreError::Io {
            path: path.clone(),
            source: e,
        })?;
    file.write_all(lines.as_bytes())
        .and_then(|_| if sync { file.sync_all() } else { Ok(()) })
        .map_err(|e| StoreError::Io { path, source: e })
}
