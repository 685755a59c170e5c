//! Room on disk for a scan: what its run will take, said before it starts (dry runs, the Scan
//! screen), and the refusal of a scan whose run will not fit, before anything moves. A new run
//! and a resumed one pass the same check ([`check_room`], called by the scan session).
//!
//! The frames are most of a run, and their size follows the camera frame's pixel count, which
//! a real camera tells only once it is opened: the estimate takes it from [`camera_frame`], the
//! one place that chooses it.

use crate::rig::file::RigConfig;
use crate::session::disc_cutout::{disc_cutout, RecordingError};
use fringe_calibration::{load_checked, profile_path, Expectation, Profile, MAX_AGE_DAYS};
use fringe_rig::format_name;
use fringe_rig::store::FrameStorage;
use fringe_rig::store::ProfileRef;
use fringe_rig::store::RunReader;
use fringe_rig::store::StoredPart;
use fringe_rig::store::{available_bytes, human_bytes as human};
use fringe_rig::store::{mean_stored_frame_bytes, RecordingTime, RunSize};
use fringe_rig::Hertz;
use fringe_rig::{BenchLimits, Plan, ScanProgram};
use fringe_rig::{RunTarget, ScanSetup};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// A camera frame's size, px.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSize {
    pub width: u32,
    pub height: u32,
}

impl FrameSize {
    pub fn px(self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }
}

/// The reference camera's frame: a Basler daA1920-160uc.
pub(crate) const REFERENCE_FRAME: FrameSize = FrameSize {
    width: 1920,
    height: 1200,
};

/// A scan starts only with its expected size times this free, plus [`SPARE_BYTES`]: room for
/// frames busier than the estimate assumes, and for everything else on the disk.
pub(crate) const MARGIN: f64 = 1.2;

/// Bytes left free beyond [`MARGIN`] times the expected size.
pub(crate) const SPARE_BYTES: u64 = 1_000_000_000;

/// The camera frame's size a size estimate assumes, chosen here only:
///
/// 1. the calibration profile's image size, when the scan has a profile (the camera's frame when
///    the sensor was calibrated; on the simulated bench without one, the session records the
///    simulated sensor's design geometry as its profile, which gives its image size too);
/// 2. else, on the simulated bench, the simulated sensor's image (`[sim] sensor` and
///    `image_scale`);
/// 3. else the reference camera's 1920x1200 ([`REFERENCE_FRAME`]).
pub(crate) fn camera_frame(profile: Option<&Profile>, config: &RigConfig) -> FrameSize {
    if let Some(p) = profile {
        return FrameSize {
            width: p.image.width,
            height: p.image.height,
        };
    }
    #[cfg(feature = "sim")]
    if config.is_simulated() {
        if let Ok(sim) = crate::rig::simulated::config(config) {
            let g = &sim.sensor.geometry;
            return FrameSize {
                width: g.width,
                height: g.height,
            };
        }
    }
    #[cfg(not(feature = "sim"))]
    let _ = config;
    REFERENCE_FRAME
}

/// What a refusal for want of disk space adds when the scan stores whole frames but could store
/// only the disc's square.
pub(crate) const STORE_DISC_ADVICE: &str = ", or store only the square around the sensor's disc \
     ([recording] store = \"disc\" in the rig file or the plan)";

/// What a run of a plan will take on disk and what the disk it goes to has free, told before a
/// scan (its dry run), from the rig file and the profile directory only (the devices stay
/// closed).
#[derive(Debug)]
pub struct RoomForecast {
    pub recording: Recording,
    pub size: RunSize,
    /// The run whose stored frames gave the bytes of a frame (the newest run of this sensor
    /// stored the same way under the same directory); `None`: the codec's measured bytes per
    /// pixel ([`FrameStorage::expected_frame_bytes`]).
    pub measured_on: Option<PathBuf>,
    /// Free bytes on the filesystem holding the run's directory.
    pub free: Result<u64, RoomError>,
}

impl RoomForecast {
    /// The forecast of a run of `program` (within `limits`) on the rig `config` describes,
    /// written under `out`.
    pub fn new(
        config: &RigConfig,
        program: &ScanProgram,
        limits: &BenchLimits,
        out: &Path,
    ) -> Result<RoomForecast, RecordingError> {
        let recording = Recording::from_rig_files(config, Some(&program.plan))?;
        let time = program.estimate(limits).recording_time();
        let measured = config
            .sensor_id()
            .ok()
            .and_then(|id| measured_frame_bytes(out, &id, &recording.storage));
        let size = match &measured {
            Some((bytes, _)) => RunSize::with_frame_bytes(time, recording.frame_rate, *bytes),
            None => recording.expected(time),
        };
        Ok(RoomForecast {
            recording,
            size,
            measured_on: measured.map(|(_, run)| run),
            free: free_bytes(out),
        })
    }

    /// When the scan would be refused: the bytes it needs free (with the margin) and the
    /// advice to store only the disc when it stores whole frames ("" otherwise).
    pub fn refusal(&self) -> Option<(u64, &'static str)> {
        let free = *self.free.as_ref().ok()?;
        let need = needed_bytes(self.size.total_bytes());
        (need > free).then_some((
            need,
            if self.recording.storage.cutout.is_none() {
                STORE_DISC_ADVICE
            } else {
                ""
            },
        ))
    }
}

/// How a scan records its frames: all its expected size needs besides its duration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Recording {
    pub storage: FrameStorage,
    /// The camera frame (`camera_frame`).
    pub frame: FrameSize,
    pub frame_rate: Hertz,
}

impl Recording {
    /// How a new run of `plan` (or of any plan that leaves `[recording]` to the rig file) on the
    /// rig `config` describes would record, read from the rig file and the profile directory only
    /// (no device is opened): the camera's pixel format and frame rate, `[recording] store` with
    /// the disc of the sensor's calibration profile (on the simulated bench without one, of its
    /// design geometry, as a scan would), and `camera_frame`.
    pub fn from_rig_files(
        config: &RigConfig,
        plan: Option<&Plan>,
    ) -> Result<Recording, RecordingError> {
        let camera = config.camera_settings()?;
        let sensor_id = config.sensor_id()?;
        let profile = profile_on_file(config, &sensor_id);
        let cutout = match config.stored_part(plan)? {
            StoredPart::Frame => None,
            StoredPart::Disc { margin_px } => Some(disc_cutout(
                profile.as_ref(),
                &sensor_id,
                margin_px,
                config,
            )?),
        };
        let codec = config.frame_codec(plan)?;
        let storage = FrameStorage::new(camera.pixel_format, cutout)
            .and_then(|s| s.with_codec(codec))
            .map_err(|e| RecordingError::Disc(format!("storing frames: {e}")))?;
        Ok(Recording {
            storage,
            frame: camera_frame(parsed(profile.as_ref()).as_ref(), config),
            frame_rate: camera.frame_rate,
        })
    }

    /// The expected size of a run recording for `time` (a plan's
    /// [`Estimate::recording_time`](fringe_rig::scan::Estimate::recording_time)).
    pub fn expected(&self, time: RecordingTime) -> RunSize {
        RunSize::expected(time, self.frame_rate, &self.storage, self.frame.px())
    }

    /// `size` for a person: "3.4 GB (frames 3.3 GB: 1900 of 1920x1200 bayerrg8, 1.73 MB each;
    /// force log 12 MB; records 2 MB)".
    pub fn describe(&self, size: &RunSize) -> String {
        let format = format_name(self.storage.pixel_format);
        let frames = match self.storage.cutout {
            None => format!("{}x{} {format}", self.frame.width, self.frame.height),
            Some(c) => format!(
                "{}x{} disc squares of {}x{} {format}",
                c.roi.width, c.roi.height, c.frame_width, c.frame_height
            ),
        };
        format!(
            "{} (frames {}: {} of {}, {} each; force log {}; records {})",
            human(size.total_bytes()),
            human(size.frames_bytes),
            size.frames,
            frames,
            frame_bytes(size.frame_bytes_each),
            human(size.force_log_bytes),
            human(size.records_bytes)
        )
    }
}

/// The mean bytes of a stored frame in the newest run under `root` that filmed sensor
/// `sensor_id` and stored its frames as `storage` says (pixel format, codec, cutout): what this
/// sensor and camera take, measured, with the run; `None` when there is no such run with frames.
pub(crate) fn measured_frame_bytes(
    root: &Path,
    sensor_id: &str,
    storage: &FrameStorage,
) -> Option<(u64, PathBuf)> {
    let mut newest: Option<(String, PathBuf)> = None;
    for entry in std::fs::read_dir(root).ok()?.flatten() {
        let dir = entry.path();
        let Ok(start) = RunReader::at(&dir).start() else {
            continue;
        };
        if start.sensor_id != sensor_id || start.frame_storage() != *storage {
            continue;
        }
        if newest.as_ref().is_none_or(|(t, _)| start.started_utc > *t) {
            newest = Some((start.started_utc, dir));
        }
    }
    let (_, dir) = newest?;
    let bytes = mean_stored_frame_bytes(&dir).ok()??;
    Some((bytes, dir))
}

/// One frame's bytes: "1.73 MB", "350 kB".
fn frame_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1e6 {
        format!("{:.2} MB", b / 1e6)
    } else {
        format!("{:.0} kB", (b / 1e3).ceil())
    }
}

/// The profile a scan of `config` would record, from files only: the sensor's calibration
/// profile in the profile directory when it is usable, else on the simulated bench its design
/// geometry.
fn profile_on_file(config: &RigConfig, sensor_id: &str) -> Option<ProfileRef> {
    let dir = config.profile_dir();
    let want = Expectation {
        sensor_id,
        image: None,
        max_age_days: MAX_AGE_DAYS,
    };
    if load_checked(&dir, &want, SystemTime::now()).0.is_some() {
        let path = profile_path(&dir, sensor_id).ok()?;
        let content = std::fs::read_to_string(&path).ok()?;
        return Some(ProfileRef {
            path: path.display().to_string(),
            content,
        });
    }
    #[cfg(feature = "sim")]
    if config.is_simulated() {
        let design = crate::rig::simulated::design_profile(
            &crate::rig::simulated::config(config).ok()?,
            sensor_id,
        );
        return Some(ProfileRef {
            path: format!("(no file: {})", design.source),
            content: toml::to_string_pretty(&design).ok()?,
        });
    }
    None
}

/// A recorded profile's content, when it reads as a profile.
pub(crate) fn parsed(profile: Option<&ProfileRef>) -> Option<Profile> {
    profile.and_then(|p| toml::from_str(&p.content).ok())
}

/// The bytes that must be free for a run expected to take `expected_bytes`.
pub(crate) fn needed_bytes(expected_bytes: u64) -> u64 {
    ((expected_bytes as f64 * MARGIN) as u64).saturating_add(SPARE_BYTES)
}

/// A scan whose run will not fit, or whose disk cannot be measured.
#[derive(Debug, thiserror::Error)]
pub enum RoomError {
    #[error(
        "{}: not enough disk space {what}: it will write about {expected}; with a margin it needs {} free and the filesystem holding {} has {}: {advice}",
        dir.display(),
        human(*need_bytes),
        dir.display(),
        human(*free_bytes)
    )]
    TooSmall {
        dir: PathBuf,
        /// "for this scan", "to resume this run (its 12 points left)".
        what: String,
        /// The expected size, described.
        expected: String,
        need_bytes: u64,
        free_bytes: u64,
        /// What to do.
        advice: String,
    },
    #[error(
        "{}: cannot make the directory for the runs: {source} (choose one you can write, with --out DIR)",
        dir.display()
    )]
    Unwritable {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: cannot tell the free disk space: {source}", dir.display())]
    Unmeasured {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Free bytes of the filesystem that holds (or will hold) `dir`.
pub(crate) fn free_bytes(dir: &Path) -> Result<u64, RoomError> {
    available_bytes(dir).map_err(|source| RoomError::Unmeasured {
        dir: dir.to_path_buf(),
        source,
    })
}

/// What a scan will write and where, for [`check_room`].
#[derive(Debug, Clone, PartialEq)]
struct PlannedRun {
    /// Where the run is written.
    dir: PathBuf,
    recording: Recording,
    size: RunSize,
    /// "for this scan", "to resume this run (12 points left)".
    what: String,
    /// What to do when it does not fit.
    advice: String,
}

/// The run a scan of `setup` into `target` will write: a new run's for the whole plan; a
/// resumed run's for its points left, its frames at the run's own mean so far (when it has
/// frames). `None` when the scan cannot start (frames it cannot store, a resume target that is
/// not a readable run): the scan refuses it, saying why, before anything moves.
fn planned_run(
    setup: &ScanSetup,
    frame: FrameSize,
    target: &RunTarget,
    may_store_disc: bool,
) -> Option<PlannedRun> {
    let rate = setup.camera.frame_rate;
    match target {
        RunTarget::New { root, .. } => {
            let storage = FrameStorage::new(setup.camera.pixel_format, setup.cutout)
                .and_then(|s| s.with_codec(setup.codec))
                .ok()?;
            let recording = Recording {
                storage,
                frame,
                frame_rate: rate,
            };
            let time = setup.program.estimate(&setup.limits).recording_time();
            let size = match measured_frame_bytes(root, &setup.sensor_id, &recording.storage) {
                Some((bytes, _)) => RunSize::with_frame_bytes(time, rate, bytes),
                None => recording.expected(time),
            };
            let mut advice = "free space there, write the run on another disk (--out DIR; --runs DIR of fringe calibrate), or run a smaller plan".to_string();
            if may_store_disc && setup.cutout.is_none() {
                advice.push_str(STORE_DISC_ADVICE);
            }
            Some(PlannedRun {
                dir: root.clone(),
                recording,
                size,
                what: "for this scan".into(),
                advice,
            })
        }
        RunTarget::Resume { dir, .. } => {
            let run = RunReader::at(dir);
            let start = run.start().ok()?;
            let next_point = run.checkpoint().ok().flatten().map_or(0, |c| c.next_point);
            let first = usize::try_from(next_point).unwrap_or(usize::MAX);
            let left = setup.program.points.len().saturating_sub(first);
            let recording = Recording {
                storage: start.frame_storage(),
                frame,
                frame_rate: rate,
            };
            let time = setup
                .program
                .estimate_from(&setup.limits, first)
                .recording_time();
            let size = match mean_stored_frame_bytes(dir) {
                Ok(Some(mean)) => RunSize::with_frame_bytes(time, rate, mean),
                _ => recording.expected(time),
            };
            Some(PlannedRun {
                dir: dir.clone(),
                recording,
                size,
                what: format!("to resume this run ({left} points left)"),
                advice: "free space there, or move the run to a disk with room and resume it there"
                    .into(),
            })
        }
    }
}

/// Refuses a scan of `setup` into `target` whose run will not fit: its expected size (a resumed
/// run's for its points left), times [`MARGIN`] plus [`SPARE_BYTES`], against the free space of
/// the filesystem the run is written on. `frame` is the camera frame ([`camera_frame`]);
/// `may_store_disc`: the scan could store only the disc's square (not a calibration scan),
/// which the refusal then suggests.
pub(crate) fn check_room(
    setup: &ScanSetup,
    frame: FrameSize,
    target: &RunTarget,
    may_store_disc: bool,
) -> Result<(), RoomError> {
    // A directory for new runs that cannot be made is that, not a full disk (/proc, say, has
    // no free space to measure): made here, as the run writer would make it.
    if let RunTarget::New { root, .. } = target {
        std::fs::create_dir_all(root).map_err(|source| RoomError::Unwritable {
            dir: root.clone(),
            source,
        })?;
    }
    let Some(run) = planned_run(setup, frame, target, may_store_disc) else {
        return Ok(());
    };
    let free = free_bytes(&run.dir)?;
    let need = needed_bytes(run.size.total_bytes());
    if need > free {
        return Err(RoomError::TooSmall {
            expected: run.recording.describe(&run.size),
            dir: run.dir,
            what: run.what,
            need_bytes: need,
            free_bytes: free,
            advice: run.advice,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::PixelFormat;
    use std::time::Duration;

    #[cfg(feature = "sim")]
    #[test]
    fn the_frame_comes_from_the_profile_then_the_simulated_sensor_then_the_reference_camera() {
        let sim = RigConfig::parse("[sim]\nimage_scale = 0.25\n", "rig.toml").expect("rig");
        let quarter = FrameSize {
            width: 480,
            height: 300,
        };
        assert_eq!(camera_frame(None, &sim), quarter);
        let real = RigConfig {
            simulated: false,
            ..sim.clone()
        };
        assert_eq!(camera_frame(None, &real), REFERENCE_FRAME);
        let design = crate::rig::simulated::design_profile(
            &crate::rig::simulated::config(&sim).expect("sim"),
            "s1",
        );
        assert_eq!(camera_frame(Some(&design), &real), quarter);
        let mut other = design.clone();
        other.image.width = 640;
        other.image.height = 480;
        assert_eq!(
            camera_frame(Some(&other), &sim),
            FrameSize {
                width: 640,
                height: 480
            }
        );
    }

    #[cfg(feature = "sim")]
    #[test]
    fn the_simulated_bench_records_its_whole_bayer_frames_and_says_so() {
        let rig = RigConfig::simulated();
        let recording = Recording::from_rig_files(&rig, None).expect("recording");
        assert_eq!(recording.storage.pixel_format, PixelFormat::BayerRg8);
        assert_eq!(recording.storage.cutout, None);
        assert_eq!(recording.frame, REFERENCE_FRAME);
        let size = recording.expected(RecordingTime::filming_throughout(Duration::from_secs(60)));
        let text = recording.describe(&size);
        assert!(
            text.contains("3000 of 1920x1200 bayerrg8, 968 kB each")
                && text.contains("force log 25 MB"),
            "{text}"
        );
        let disc = RigConfig::parse("[recording]\nstore = \"disc\"\n", "rig.toml").expect("rig");
        let square = Recording::from_rig_files(&disc, None).expect("disc recording");
        assert!(square.storage.cutout.is_some());
        let minute = RecordingTime::filming_throughout(Duration::from_secs(60));
        assert!(square.expected(minute).total_bytes() < size.total_bytes());
        assert!(square.describe(&size).contains("disc squares of 1920x1200"));
    }

    /// The main job's forecast holds against its measured run (BENCHMARKS.md, "Estimates against
    /// the run": 61 s and 1.442 GB, 1517 frames), and a disk where it fits does not refuse it
    /// (with a frame assumed at 1.21 MB it was refused below 3.4 GB free).
    #[cfg(feature = "sim")]
    #[test]
    fn the_main_job_is_forecast_as_measured_and_not_refused_where_it_fits() {
        let rig = RigConfig::simulated();
        let limits = rig.limits().expect("limits");
        let grid = crate::session::plans::SHORT_GRID;
        let program = Plan::parse(grid.text, "short-grid")
            .and_then(|p| p.program(&limits, "short-grid"))
            .expect("program");
        let empty = std::env::temp_dir().join(format!("fringe-forecast-{}", std::process::id()));
        let mut forecast = RoomForecast::new(&rig, &program, &limits, &empty).expect("forecast");
        assert_eq!(forecast.measured_on, None, "no run there to measure");
        let total = program.estimate(&limits).total.as_secs_f64();
        assert!((total / 61.0 - 1.0).abs() < 0.15, "{total} s against 61 s");
        let bytes = forecast.size.total_bytes() as f64;
        assert!((bytes / 1.442e9 - 1.0).abs() < 0.15, "{bytes} B");
        assert!(
            (forecast.size.frames as f64 / 1517.0 - 1.0).abs() < 0.05,
            "{:?}",
            forecast.size
        );
        forecast.free = Ok(3_000_000_000);
        assert_eq!(forecast.refusal(), None);
        forecast.free = Ok(2_000_000_000);
        assert!(forecast.refusal().is_some());
    }

    /// A scan of the built-in short grid on the simulated bench, whole BayerRG8 frames.
    #[cfg(feature = "sim")]
    fn short_grid() -> ScanSetup {
        use fringe_rig::CameraSettings;
        use fringe_rig::ContactOrigin;
        use fringe_rig::Millimetres;
        use fringe_rig::Plan;
        let limits = RigConfig::simulated().limits().expect("limits");
        let grid = crate::session::plans::SHORT_GRID;
        let program = Plan::parse(grid.text, "short-grid")
            .expect("plan")
            .program(&limits, "short-grid")
            .expect("program");
        ScanSetup {
            program,
            plan_text: grid.text.into(),
            limits,
            origin: ContactOrigin {
                x: Millimetres(0.0),
                y: Millimetres(0.0),
                source: "test".into(),
            },
            disc_radius: None,
            sync: fringe_rig::SyncMethod::Host,
            ft_axes: None,
            trigger: None,
            sensor_id: "s1".into(),
            variant: None,
            rig_text: String::new(),
            seed: None,
            profile: None,
            camera: CameraSettings::default(),
            cutout: None,
            codec: Default::default(),
            press: Default::default(),
            watch: Default::default(),
            sidecars: Vec::new(),
            offset_check: None,
            taps: Vec::new(),
        }
    }

    #[cfg(feature = "sim")]
    #[test]
    fn a_new_run_is_sized_for_the_plan_and_a_resumed_one_for_its_points_left_at_its_own_frames() {
        use fringe_rig::store::RunWriter;
        use fringe_rig::store::{now_utc, StartDocument, LAYOUT_VERSION};
        use fringe_rig::Frame;
        use fringe_rig::HostTime;
        let setup = short_grid();
        let root = std::env::temp_dir().join(format!("fringe-disk-room-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let target = RunTarget::New {
            root: root.clone(),
            run_id: "r".into(),
        };
        let new = planned_run(&setup, REFERENCE_FRAME, &target, true).expect("a new run");
        // A calibration scan stores whole frames whatever the rig file says.
        let calibration = planned_run(&setup, REFERENCE_FRAME, &target, false).expect("new");
        assert!(
            !calibration.advice.contains("disc"),
            "{}",
            calibration.advice
        );
        let whole = Recording {
            storage: FrameStorage::new(PixelFormat::BayerRg8, None).expect("storage"),
            frame: REFERENCE_FRAME,
            frame_rate: Hertz(50.0),
        };
        let time = setup.program.estimate(&setup.limits).recording_time();
        assert_eq!(new.size, whole.expected(time));
        assert_eq!(new.dir, root);
        assert!(new.advice.contains("store = \"disc\""), "{}", new.advice);

        // A run of two 60x40 RGB8 frames, checkpointed before point 2 of 6.
        let start = StartDocument {
            layout_version: LAYOUT_VERSION,
            run_id: "r".into(),
            started_utc: now_utc(),
            software: "test".into(),
            sensor_id: "s1".into(),
            variant: None,
            plan: setup.plan_text.clone(),
            rig: String::new(),
            calibration_profile: None,
            seed: None,
            ft_axes: None,
            sync_method: "host".into(),
            frames: Some(FrameStorage::new(PixelFormat::Rgb8, None).expect("storage")),
        };
        let mut writer = RunWriter::create(&root, &start).expect("run");
        for id in 0..2u64 {
            let frame = Frame {
                id,
                device_timestamp: id,
                host_arrival: HostTime(id),
                width: 60,
                height: 40,
                format: PixelFormat::Rgb8,
                data: (0..60 * 40 * 3)
                    .map(|i| (i * 7 + id as usize) as u8)
                    .collect(),
            };
            writer.save_frame_image(&frame, id).expect("frame");
        }
        writer.checkpoint_at(2).expect("checkpoint");
        let dir = writer.dir().to_path_buf();
        drop(writer);
        let mean = mean_stored_frame_bytes(&dir)
            .expect("frames")
            .expect("two frames");
        let resumed = planned_run(
            &setup,
            REFERENCE_FRAME,
            &RunTarget::Resume {
                dir: dir.clone(),
                held: None,
            },
            true,
        )
        .expect("a resumed run");
        let left = setup
            .program
            .estimate_from(&setup.limits, 2)
            .recording_time();
        assert_eq!(
            resumed.size,
            RunSize::with_frame_bytes(left, Hertz(50.0), mean)
        );
        assert_eq!(resumed.recording.storage.pixel_format, PixelFormat::Rgb8);
        assert_eq!(resumed.what, "to resume this run (4 points left)");
        assert!(resumed.size.frames < new.size.frames, "{resumed:?}");
        // Not a run: the scan says what is wrong with it.
        let nowhere = RunTarget::Resume {
            dir: root.join("absent"),
            held: None,
        };
        assert_eq!(planned_run(&setup, REFERENCE_FRAME, &nowhere, true), None);
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn the_margin_is_a_fifth_and_a_gigabyte() {
        assert_eq!(needed_bytes(0), SPARE_BYTES);
        assert_eq!(needed_bytes(10_000_000_000), 13_000_000_000);
        assert_eq!(needed_bytes(u64::MAX), u64::MAX);
    }
}
