//! A scan session: the rig opened, the sensor's calibration profile turned into the contact
//! origin and the zero-load check, the scan run with a caller's operator and progress, and (on
//! the simulated bench) the labels scored against the ground truth. The command line's progress
//! bar and the terminal UI drive the same session.

use crate::rig::error::RigError;
use crate::rig::file::RigConfig;
#[cfg(feature = "sim")]
use crate::rig::simulated::{score_run, SimBench};
use crate::session::disc_cutout::{disc_cutout, RecordingError};
use crate::session::disk_space::{camera_frame, check_room, parsed, FrameSize, RoomError};
use crate::session::live_validation::{FrameSource, LiveValidation, BACKLOG_FRAMES};
use crate::session::model_pace::{keeping_up, Pace, Setting, TIMING_RUNS};
use crate::session::truth_score::TruthScore;
use fringe_calibration::{
    load_checked, profile_path, Expectation, Profile, ProfileWarning, MAX_AGE_DAYS,
};
use fringe_calibration::{ProfileOffsetCheck, ZeroTolerance};
use fringe_rig::reference_layout::NO_CONTACT;
use fringe_rig::scan::OffsetCheck;
use fringe_rig::scan::PressSettings;
use fringe_rig::scan::RunSidecar;
use fringe_rig::scan::WatchSettings;
use fringe_rig::store::ProfileRef;
use fringe_rig::store::StoreError;
use fringe_rig::store::StoredPart;
use fringe_rig::CameraSettings;
use fringe_rig::ConfigError;
use fringe_rig::ContactOrigin;
use fringe_rig::Devices;
use fringe_rig::Millimetres;
use fringe_rig::Operator;
use fringe_rig::ScanError;
use fringe_rig::{run_scan, RunTarget, ScanOutcome, ScanSetup};
use fringe_rig::{scan::ScanProgress, ScanControl};
use fringe_rig::{BenchLimits, ScanProgram};
#[cfg(feature = "sim")]
use fringe_rig::{Prompt, Reply};
use fringe_sensor_models::{Model, ModelError};
use fringe_sensor_models::{PredictError, Predictor};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::SystemTime;

/// How a scan treats the sensor's calibration profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProfileUse {
    /// Contact origin from the profile (warn when missing, stale or mismatched).
    Consume,
    /// The calibration scan that makes the profile: the rig file's origin.
    Ignore,
}

/// Something the session tells the person running it before the scan starts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Note {
    Info(String),
    Warning(String),
}

/// Why a session could not run.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("cannot open the rig: {0}")]
    Rig(#[from] RigError),
    #[error("the scan stopped: {0}")]
    Scan(#[from] ScanError),
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error(
        "no calibration profile for sensor {sensor_id} in {}: the model's preprocessing needs \
         the sensor's optical centre and crop radius; run `fringe calibrate` first",
        dir.display()
    )]
    NoGeometry { sensor_id: String, dir: PathBuf },
    #[error(transparent)]
    Recording(#[from] RecordingError),
    #[error(
        "{model}: the model's shape classes ({classes}) do not include {missing}, which this scan's frames will be labelled with: it cannot be scored on them (use a model trained for these indenters, or a plan that presses only those it knows)"
    )]
    ClassesMissing {
        model: String,
        classes: String,
        missing: String,
    },
    #[error("the simulated sensor {sensor_id}'s design geometry cannot be written into the run: {message}")]
    DesignProfile { sensor_id: String, message: String },
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error("the model could not be timed before the scan: {0}")]
    Predict(#[from] PredictError),
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Room(#[from] RoomError),
}

/// A rig opened and a scan set up, ready to run.
pub struct ScanSession {
    pub setup: ScanSetup,
    devices: Devices,
    #[cfg(feature = "sim")]
    sim: Option<SimBench>,
    /// What the front end should show before the scan starts (devices, origin, profile warnings).
    pub notes: Vec<Note>,
    /// Where the sensor's calibration profile was looked for.
    profile_dir: PathBuf,
    /// The camera frame the expected size of the run assumes ([`camera_frame`]).
    camera_frame: FrameSize,
    /// How the scan treats the profile (a calibration scan stores whole frames).
    profile_use: ProfileUse,
}

/// A finished session.
pub struct SessionEnd {
    pub outcome: ScanOutcome,
    /// The labels against the ground truth (simulated rigs).
    pub truth_score: Option<TruthScore>,
    /// The simulated bench that ran it, with its ground truth (simulated rigs).
    #[cfg(feature = "sim")]
    pub sim: Option<SimBench>,
}

impl ScanSession {
    /// Opens the rig `config` describes and sets up `program`. `stage_operator` is the front
    /// end's operator for a stage moved by hand (the scan itself asks through the operator given
    /// to [`ScanSession::run`]).
    pub fn open(
        config: &RigConfig,
        program: ScanProgram,
        plan_text: String,
        profile_use: ProfileUse,
        record_trace: Option<&Path>,
        stage_operator: Box<dyn Operator>,
    ) -> Result<ScanSession, SessionError> {
        let rig = config.open(record_trace, stage_operator)?;
        let mut notes: Vec<Note> = rig
            .devices
            .description
            .iter()
            .map(|d| Note::Info(format!("  {d}")))
            .collect();
        notes.extend(config.ft_rating_warning().map(Note::Warning));
        let (origin, profile, offset_check) = match profile_use {
            ProfileUse::Consume => {
                calibration_profile(config, &rig.sensor_id, rig.origin.clone(), &mut notes)
            }
            ProfileUse::Ignore => (rig.origin.clone(), None, None),
        };
        notes.push(Note::Info(format!(
            "contact labels in mm from the sensor centre; origin x {:.3} mm, y {:.3} mm from {}",
            origin.x.0, origin.y.0, origin.source
        )));
        // A simulated bench without a calibration profile: the run records the simulated
        // sensor's design geometry (exact, and the one its contact labels were made with), so
        // that evaluation and training preprocess its frames without being told a profile.
        #[cfg(feature = "sim")]
        let profile = match (profile, &rig.sim) {
            (None, Some(sim)) => Some(design_profile(sim, &rig.sensor_id, &mut notes)?),
            (p, _) => p,
        };
        #[cfg(feature = "sim")]
        let (seed, sidecars) = sim_record(rig.sim.as_ref());
        #[cfg(not(feature = "sim"))]
        let (seed, sidecars): (Option<u64>, Vec<Arc<dyn RunSidecar>>) = (None, Vec::new());
        let cutout = match (
            config
                .stored_part(Some(&program.plan))
                .map_err(RigError::from)?,
            profile_use,
        ) {
            (StoredPart::Frame, _) | (_, ProfileUse::Ignore) => None,
            (StoredPart::Disc { margin_px }, ProfileUse::Consume) => Some(disc_cutout(
                profile.as_ref(),
                &rig.sensor_id,
                margin_px,
                config,
            )?),
        };
        let codec = config
            .frame_codec(Some(&program.plan))
            .map_err(RigError::from)?;
        let camera_frame = camera_frame(parsed(profile.as_ref()).as_ref(), config);
        let disc_radius = parsed(profile.as_ref())
            .and_then(|p| p.disc_radius_mm())
            .map(Millimetres);
        // How the F/T's axes sit: the simulated mount's, else the rig file's.
        #[cfg(feature = "sim")]
        let ft_axes = match &rig.sim {
            Some(sim) => Some(sim.config().bench.mount.axes()),
            None => config.file.force.ft_axes(),
        };
        #[cfg(not(feature = "sim"))]
        let ft_axes = config.file.force.ft_axes();
        if ft_axes.is_none() && program.points.iter().any(|p| p.slide.is_some()) {
            notes.push(Note::Warning(
                "the plan slides, but the rig file does not say how the F/T's axes sit on the bench: frames will carry no shear (tangential force in the sensor's frame) or slip label; add `x_axis_deg` (and `z_toward_tool` if its z points up) to [force]".into(),
            ));
        }
        let setup = ScanSetup {
            program,
            plan_text,
            limits: rig.limits.clone(),
            origin,
            disc_radius,
            sync: rig.sync,
            ft_axes,
            trigger: rig.trigger,
            sensor_id: rig.sensor_id.clone(),
            variant: config.sensor_variant().ok().flatten().map(str::to_string),
            rig_text: rig.text.clone(),
            seed,
            profile,
            camera: rig.camera_settings.clone(),
            cutout,
            codec,
            press: PressSettings::default(),
            watch: WatchSettings::default(),
            sidecars,
            offset_check,
            taps: Vec::new(),
        };
        Ok(ScanSession {
            setup,
            devices: rig.devices,
            #[cfg(feature = "sim")]
            sim: rig.sim,
            notes,
            profile_dir: config.profile_dir(),
            camera_frame,
            profile_use,
        })
    }

    pub fn limits(&self) -> &BenchLimits {
        &self.setup.limits
    }

    pub fn camera(&self) -> &CameraSettings {
        &self.setup.camera
    }

    /// The calibration profile whose geometry a model's preprocessing uses for this scan: the
    /// sensor's profile the session consumes, else on the simulated bench its design geometry;
    /// with a line saying which. None on a real rig without a profile.
    pub fn geometry_profile(&self) -> Option<(Profile, String)> {
        if let Some(p) = &self.setup.profile {
            if let Ok(profile) = toml::from_str::<Profile>(&p.content) {
                return Some((profile, format!("profile {}", p.path)));
            }
        }
        #[cfg(feature = "sim")]
        if let Some(sim) = &self.sim {
            let profile = sim.design_profile(&self.setup.sensor_id);
            let why = format!(
                "no calibration profile for {}: {}",
                self.setup.sensor_id, profile.source
            );
            return Some((profile, why));
        }
        None
    }

    /// Live validation of `model` on every frame this scan records (the newest one whenever the
    /// network is free), through the preprocessing geometry of [`Self::geometry_profile`]: the
    /// validation to read, and notes: which geometry it uses, and a warning when the frames show
    /// the sensor coarser than the model was trained on.
    pub fn attach_validation(
        &mut self,
        model: Model,
        mut predictor: Predictor,
        run_id: &str,
    ) -> Result<(LiveValidation, Vec<Note>), SessionError> {
        // A model of another sensor design reads these frames wrongly, with no error.
        model.check_design(self.setup.variant.as_deref(), "this sensor")?;
        // Every label this scan makes (no contact, and each indenter the plan presses) must be
        // one of the model's classes: refused up front, not left unscored frame by frame.
        let labels = std::iter::once(NO_CONTACT).chain(
            self.setup
                .program
                .plan
                .indenters
                .shapes
                .iter()
                .map(String::as_str),
        );
        let missing: Vec<&str> = labels
            .filter(|l| !model.classes.iter().any(|c| c == l))
            .collect();
        if !missing.is_empty() {
            return Err(SessionError::ClassesMissing {
                model: model.path.display().to_string(),
                classes: model.classes.join(", "),
                missing: missing.join(", "),
            });
        }
        let Some((profile, why)) = self.geometry_profile() else {
            return Err(SessionError::NoGeometry {
                sensor_id: self.setup.sensor_id.clone(),
                dir: self.profile_dir.clone(),
            });
        };
        let mut notes = vec![Note::Info(format!("preprocessing geometry: {why}"))];
        if let Some(w) = model
            .preprocessing(Some(&profile), None)
            .ok()
            .and_then(|pre| model.scale_warning(&pre))
        {
            notes.push(Note::Warning(w));
        }
        // Whether the model keeps up with the camera, before anything moves.
        let per_frame = predictor.time_per_frame(TIMING_RUNS)?;
        let pace = keeping_up(
            per_frame,
            self.setup.camera.frame_rate,
            Setting {
                threads: predictor.threads(),
                cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
                input_size: model.input_size,
                simulated: self.simulated(),
            },
        );
        let source = FrameSource {
            run_id: run_id.to_string(),
            profile,
        };
        let (validation, tap) = LiveValidation::start(model, predictor, source, BACKLOG_FRAMES)?;
        notes.push(match pace {
            Pace::KeepsUp(line) => Note::Info(line),
            Pace::Behind { full, short } => {
                validation.set_behind(short);
                Note::Warning(full)
            }
        });
        self.setup.taps.push(tap);
        Ok((validation, notes))
    }

    /// True when the rig is the simulated bench.
    pub fn simulated(&self) -> bool {
        #[cfg(feature = "sim")]
        return self.sim.is_some();
        #[cfg(not(feature = "sim"))]
        false
    }

    /// Runs the scan into `target`. `operator` answers the prompts (on the simulated bench
    /// indenters are mounted without asking); `progress` receives what the scan reports.
    pub fn run(
        self,
        target: RunTarget,
        control: &ScanControl,
        operator: &mut dyn Operator,
        progress: &(dyn Fn(ScanProgress) + Sync),
    ) -> Result<SessionEnd, SessionError> {
        // Before anything homes or moves: a run that will not fit on its disk is refused.
        check_room(
            &self.setup,
            self.camera_frame,
            &target,
            self.profile_use == ProfileUse::Consume,
        )?;
        #[cfg(feature = "sim")]
        let bench = self
            .sim
            .as_ref()
            .map(|s| (s.bench().clone(), s.config().sensor.clone()));
        // What the bench filmed before this scan (the Bench screen, an earlier run's end) is no
        // part of this run's truth.
        #[cfg(feature = "sim")]
        {
            if let Some(sim) = &self.sim {
                sim.truth.pass_over_unfilmed();
            }
        }
        #[cfg(feature = "sim")]
        let mut operator = BenchOperator {
            bench,
            inner: operator,
            progress,
        };
        #[cfg(feature = "sim")]
        let operator: &mut dyn Operator = &mut operator;
        let outcome = run_scan(
            &self.setup,
            self.devices,
            target,
            control,
            operator,
            progress,
        )?;
        #[cfg(feature = "sim")]
        {
            let truth_score = match &self.sim {
                Some(_) => score_run(&outcome.run_dir)?,
                None => None,
            };
            Ok(SessionEnd {
                outcome,
                truth_score,
                sim: self.sim,
            })
        }
        #[cfg(not(feature = "sim"))]
        Ok(SessionEnd {
            outcome,
            truth_score: None,
        })
    }
}

/// The simulated sensor's design geometry, recorded by a run on the simulated bench without a
/// calibration profile; a note says so.
#[cfg(feature = "sim")]
fn design_profile(
    sim: &SimBench,
    sensor_id: &str,
    notes: &mut Vec<Note>,
) -> Result<ProfileRef, SessionError> {
    let design = sim.design_profile(sensor_id);
    let content = toml::to_string_pretty(&design).map_err(|e| SessionError::DesignProfile {
        sensor_id: sensor_id.to_string(),
        message: e.to_string(),
    })?;
    notes.push(Note::Info(format!(
        "the run records {} in place of a calibration profile",
        design.source
    )));
    Ok(ProfileRef {
        path: format!("(no file: {})", design.source),
        content,
    })
}

/// The seed and the ground truth a run on the simulated bench records (none on a real rig).
#[cfg(feature = "sim")]
fn sim_record(sim: Option<&SimBench>) -> (Option<u64>, Vec<Arc<dyn RunSidecar>>) {
    match sim {
        Some(s) => (
            Some(s.config().seed),
            vec![s.truth.clone() as Arc<dyn RunSidecar>],
        ),
        None => (None, Vec::new()),
    }
}

/// On the simulated bench the indenter a plan asks for is mounted at once, in the sizes of the
/// sensor build under its camera (those its training frames show); every other prompt goes to
/// the caller's operator.
#[cfg(feature = "sim")]
struct BenchOperator<'a> {
    bench: Option<(Arc<fringe_sim::Bench>, fringe_sim::SensorConfig)>,
    inner: &'a mut dyn Operator,
    progress: &'a (dyn Fn(ScanProgress) + Sync),
}

#[cfg(feature = "sim")]
impl Operator for BenchOperator<'_> {
    fn ask(&mut self, prompt: &Prompt) -> Reply {
        use fringe_sim::MountedIndenter;
        if let (Some((bench, sensor)), Prompt::ChangeIndenter { shape }) = (&self.bench, prompt) {
            return match sensor.indenter_tip(shape) {
                Some(tip) => {
                    bench.set_indenter(MountedIndenter {
                        tip,
                        angle_deg: 0.0,
                    });
                    (self.progress)(ScanProgress::Message(format!(
                        "simulated bench: {shape} indenter mounted"
                    )));
                    Reply::Continue
                }
                None => {
                    (self.progress)(ScanProgress::Message(format!(
                        "simulated bench: no {shape:?} indenter (it has pentagon, rectangle, circle, sphere)"
                    )));
                    Reply::Abort
                }
            };
        }
        self.inner.ask(prompt)
    }

    fn answer(&mut self, question: &str) -> std::io::Result<Option<String>> {
        self.inner.answer(question)
    }
}

/// The sensor's calibration profile, if there is one: its contact origin replaces the rig
/// file's, its force offsets are checked against the scan's first no-contact offset, and the run
/// records which profile it used. Missing, stale or mismatched profiles are warned about, and the
/// scan goes on with the rig file's origin.
fn calibration_profile(
    config: &RigConfig,
    sensor_id: &str,
    fallback: ContactOrigin,
    notes: &mut Vec<Note>,
) -> (
    ContactOrigin,
    Option<ProfileRef>,
    Option<Arc<dyn OffsetCheck>>,
) {
    let dir = config.profile_dir();
    let want = Expectation {
        sensor_id,
        image: None,
        max_age_days: MAX_AGE_DAYS,
    };
    let (profile, warnings) = load_checked(&dir, &want, SystemTime::now());
    notes.extend(warnings.iter().map(|w| {
        Note::Warning(match w {
            ProfileWarning::Missing { sensor_id, .. } => {
                format!("{w}: run `fringe calibrate --sensor {sensor_id}`")
            }
            ProfileWarning::Stale { .. } => format!("{w}: re-run `fringe calibrate`"),
            ProfileWarning::Other(_) => w.to_string(),
        })
    }));
    let Some(p) = profile else {
        return (fallback, None, None);
    };
    let path = profile_path(&dir, sensor_id).unwrap_or_else(|_| dir.join(sensor_id));
    let content = std::fs::read_to_string(&path).unwrap_or_default();
    let origin = match &p.registration {
        Some(r) => ContactOrigin {
            x: Millimetres(r.contact_origin_stage_mm[0]),
            y: Millimetres(r.contact_origin_stage_mm[1]),
            source: format!("profile {}", path.display()),
        },
        None => {
            notes.push(Note::Warning(format!(
                "profile {} has no image-to-stage registration: contact origin from {}",
                path.display(),
                fallback.source
            )));
            fallback
        }
    };
    let check = p.force_offsets.map(|offsets| {
        Arc::new(ProfileOffsetCheck {
            offsets,
            tolerance: ZeroTolerance::default(),
            profile: path.display().to_string(),
        }) as Arc<dyn OffsetCheck>
    });
    (
        origin,
        Some(ProfileRef {
            path: path.display().to_string(),
            content,
        }),
        check,
    )
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;
    use fringe_rig::{Prompt, Reply};
    use fringe_sim::SensorConfig;
    use fringe_sim::{Bench, BenchConfig, IndenterTip};

    /// Nobody at the bench: a prompt that reaches the operator aborts.
    struct Nobody;

    impl Operator for Nobody {
        fn ask(&mut self, _prompt: &Prompt) -> Reply {
            Reply::Abort
        }
    }

    /// The reply, the tip mounted afterwards and what the bench said.
    fn mount_saying(sensor: SensorConfig, shape: &str) -> (Reply, IndenterTip, Vec<String>) {
        let bench = Bench::new(BenchConfig::default());
        let said = std::sync::Mutex::new(Vec::new());
        let progress = |p: ScanProgress| {
            if let ScanProgress::Message(m) = p {
                said.lock().expect("messages").push(m);
            }
        };
        let mut nobody = Nobody;
        let mut operator = BenchOperator {
            bench: Some((bench.clone(), sensor)),
            inner: &mut nobody,
            progress: &progress,
        };
        let reply = operator.ask(&Prompt::ChangeIndenter {
            shape: shape.into(),
        });
        let said = said.into_inner().expect("messages");
        (reply, bench.indenter().tip, said)
    }

    fn mount(sensor: SensorConfig, shape: &str) -> (Reply, IndenterTip) {
        let (reply, tip, _) = mount_saying(sensor, shape);
        (reply, tip)
    }

    #[test]
    fn the_simulated_bench_mounts_the_indenters_its_sensor_build_was_trained_on() {
        for sensor in [SensorConfig::layered(), SensorConfig::integrated()] {
            for shape in ["pentagon", "rectangle", "sphere"] {
                let (reply, tip) = mount(sensor.clone(), shape);
                assert_eq!(reply, Reply::Continue, "{shape}");
                // The tip `fringe sim dataset` renders for this build.
                let rendered = match shape {
                    "pentagon" => sensor.pentagon(),
                    "rectangle" => sensor.rectangle(),
                    _ => sensor.sphere(3.0),
                };
                let mounted = tip.shape_at(fringe_rig::Millimetres(0.5));
                match (mounted, rendered) {
                    (
                        fringe_sim::Shape::Sphere { radius_mm: a, .. },
                        fringe_sim::Shape::Sphere { radius_mm: b, .. },
                    ) => assert_eq!(a, b),
                    (a, b) => assert_eq!(a, b, "{shape}"),
                }
            }
        }
        let mut sensor = SensorConfig::layered();
        sensor.indenters.rectangle_width_mm = 12.0;
        let (_, tip) = mount(sensor, "rectangle");
        assert_eq!(
            tip,
            IndenterTip::Rectangle {
                width_mm: 12.0,
                height_mm: 6.0
            }
        );
    }

    #[test]
    fn an_indenter_the_simulated_bench_lacks_ends_the_scan_naming_those_it_has() {
        let (reply, tip, said) = mount_saying(SensorConfig::layered(), "cone");
        assert_eq!(reply, Reply::Abort);
        assert_eq!(tip, BenchConfig::default().indenter.tip, "nothing mounted");
        let said = said.join("\n");
        assert!(
            said.contains("\"cone\"") && said.contains("pentagon, rectangle, circle, sphere"),
            "{said}"
        );
    }
}
