//! A scan run for the UI on its own thread: the session opened on the rig, live view and (with
//! a model) live validation attached, the operator's prompts sent to the UI as dialogs and
//! answered from it, progress sent as events. The UI thread never waits on it.

use super::stage_operator::UiStageOperator;
use crate::hint;
use crossbeam_channel::{unbounded, Receiver, Sender};
use fringe_app::models::evaluate_run;
use fringe_app::session::guarded;
use fringe_app::session::LiveValidation;
use fringe_app::session::LiveView;
use fringe_app::{Note, ProfileUse, RigConfig, ScanSession, SessionEnd};
use fringe_rig::store::ExitStatus;
use fringe_rig::ScanProgram;
use fringe_rig::{scan::new_run_id, RunTarget};
use fringe_rig::{scan::ScanProgress, ScanControl};
use fringe_rig::{Operator, Prompt, Reply};
use fringe_sensor_models::BackendKind;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Side of the frame pictures, px.
const PICTURE_PX: u32 = 96;

/// What the scan thread tells the UI.
pub enum Event {
    Note(Note),
    /// The disc as the session knows it: contact origin (stage mm) and radius (mm).
    Geometry {
        origin_mm: (f64, f64),
        disc_radius_mm: Option<f64>,
    },
    Progress(ScanProgress),
    Prompt(Prompt),
    /// The scan ended: completed or not, and a one-line summary.
    Ended {
        completed: bool,
        summary: String,
        run_dir: PathBuf,
    },
    Failed(String),
}

/// A model to validate with.
#[derive(Clone)]
pub struct ModelChoice {
    pub path: PathBuf,
    pub backend: BackendKind,
    pub threads: usize,
}

impl ModelChoice {
    /// The rig's sensor's commissioned model (`fringe commission`), else the model that ships
    /// for its design (else `default`, which live validation then refuses when it is of
    /// another design, saying so); on the default backend.
    pub fn for_rig(config: &fringe_app::RigConfig) -> ModelChoice {
        let unit = config.sensor_id().ok();
        let variant = config.sensor_variant().ok().flatten();
        let path = fringe_app::models::default_model_path(
            &fringe_app::models::ForSensor {
                profiles: &config.profile_dir(),
                unit: unit.as_deref(),
                variant,
                whose: "this sensor",
            },
            &mut |_| {},
        )
        .unwrap_or_else(|_| PathBuf::from(fringe_sensor_models::builtin::DEFAULT));
        ModelChoice {
            path,
            backend: BackendKind::Tract,
            threads: fringe_app::session::THREADS_PER_NETWORK,
        }
    }
}

/// The Table-2 figures of `choice` on the run `dir` (through the run's own profile) as one
/// short line (Fz RMSE, contact RMSE, shape accuracy); `progress` hears (frames done, in all).
pub fn run_figures(
    dir: &std::path::Path,
    choice: &ModelChoice,
    progress: &dyn Fn(usize, usize),
) -> Result<String, String> {
    let eval = evaluate_run(dir, &choice.path, choice.backend, choice.threads, progress)
        .map_err(|e| e.to_string())?;
    let m = &eval.metrics.all;
    Ok(format!(
        "Fz {:.3} N · contact {:.2} mm · shape {:.1} %",
        m.fz_rmse(),
        m.contact_rmse(),
        100.0 * m.accuracy(),
    ))
}

/// What the UI holds of a running scan.
pub struct Running {
    pub events: Receiver<Event>,
    pub replies: Sender<Reply>,
    pub control: ScanControl,
    pub view: Arc<Mutex<Option<LiveView>>>,
    pub validation: Arc<Mutex<Option<LiveValidation>>>,
    pub thread: Option<std::thread::JoinHandle<()>>,
}

struct UiOperator {
    events: Sender<Event>,
    replies: Receiver<Reply>,
}

impl Operator for UiOperator {
    fn ask(&mut self, prompt: &Prompt) -> Reply {
        if self.events.send(Event::Prompt(prompt.clone())).is_err() {
            return Reply::Abort;
        }
        self.replies.recv().unwrap_or(Reply::Abort)
    }
}

/// Everything a scan needs from the UI.
pub struct ScanRequest {
    pub config: RigConfig,
    pub program: ScanProgram,
    pub plan_text: String,
    pub runs: PathBuf,
    pub model: Option<ModelChoice>,
    /// Whether the scan reads the sensor's calibration profile (a calibration scan does not).
    pub profile: ProfileUse,
    /// Where the run goes: a new run in `runs` when `None`.
    pub target: Option<RunTarget>,
}

/// Starts the scan thread.
pub fn start(req: ScanRequest) -> Running {
    let (events, events_rx) = unbounded();
    let (replies, replies_rx) = unbounded();
    let control = ScanControl::new();
    let view = Arc::new(Mutex::new(None));
    let validation = Arc::new(Mutex::new(None));
    let thread = {
        let control = control.clone();
        let view = view.clone();
        let validation = validation.clone();
        std::thread::Builder::new()
            .name("scan".into())
            .spawn(move || {
                let tx = events.clone();
                // A panic ends the scan as an error does: the UI hears why.
                let outcome = guarded("scan", || {
                    run(req, events, replies_rx, &control, &view, &validation)
                })
                .and_then(|r| r);
                if let Err(why) = outcome {
                    let _ = tx.send(Event::Failed(why));
                }
            })
            .ok()
    };
    Running {
        events: events_rx,
        replies,
        control,
        view,
        validation,
        thread,
    }
}

/// The scan thread: the session opened, the live view and validation attached, the scan run
/// and its end told.
fn run(
    req: ScanRequest,
    events: Sender<Event>,
    replies: Receiver<Reply>,
    control: &ScanControl,
    view: &Mutex<Option<LiveView>>,
    validation: &Mutex<Option<LiveValidation>>,
) -> Result<(), String> {
    let target = req.target.unwrap_or_else(|| RunTarget::New {
        root: req.runs,
        run_id: new_run_id(&req.program.plan.name),
    });
    let run_id = target.run_id();
    let mut session = ScanSession::open(
        &req.config,
        req.program,
        req.plan_text,
        req.profile,
        None,
        Box::new(UiStageOperator),
    )
    .map_err(hint::describe)?;
    for note in &session.notes {
        let _ = events.send(Event::Note(note.clone()));
    }
    send_geometry(&session, &events);
    let (live, tap) = LiveView::start(PICTURE_PX).map_err(|e| format!("live view: {e}"))?;
    session.setup.taps.push(tap);
    *view.lock().unwrap_or_else(|p| p.into_inner()) = Some(live);
    if let Some(m) = &req.model {
        let v = attach_model(&mut session, m, &run_id, &events)?;
        *validation.lock().unwrap_or_else(|p| p.into_inner()) = Some(v);
    }
    let mut operator = UiOperator {
        events: events.clone(),
        replies,
    };
    let progress_events = Mutex::new(events.clone());
    let end = session
        .run(target, control, &mut operator, &|p| {
            let _ = progress_events
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .send(Event::Progress(p));
        })
        .map_err(hint::describe)?;
    let o = &end.outcome;
    let _ = events.send(Event::Ended {
        completed: o.status == ExitStatus::Completed,
        summary: summary(&end),
        run_dir: o.run_dir.clone(),
    });
    Ok(())
}

/// Tells the UI the disc: the contact origin and, with a registration, the disc's radius.
fn send_geometry(session: &ScanSession, events: &Sender<Event>) {
    let geometry = session.geometry_profile();
    let disc_radius_mm = geometry.as_ref().and_then(|(p, _)| p.disc_radius_mm());
    let origin = &session.setup.origin;
    let _ = events.send(Event::Geometry {
        origin_mm: (origin.x.0, origin.y.0),
        disc_radius_mm,
    });
}

/// Opens model `m` on its backend and attaches live validation to the session, sending the
/// UI what it warns of.
fn attach_model(
    session: &mut ScanSession,
    m: &ModelChoice,
    run_id: &str,
    events: &Sender<Event>,
) -> Result<LiveValidation, String> {
    let model = fringe_sensor_models::builtin::open(&m.path).map_err(|e| e.to_string())?;
    if let Some(w) = model.missing_card_warning() {
        let _ = events.send(Event::Note(Note::Warning(w)));
    }
    let predictor = fringe_sensor_models::Predictor::new(&model, m.backend, m.threads)
        .map_err(|e| e.to_string())?;
    let (v, notes) = session
        .attach_validation(model, predictor, run_id)
        .map_err(|e| e.to_string())?;
    for note in notes {
        let _ = events.send(Event::Note(note));
    }
    Ok(v)
}

/// The scan's end in one line: points, frames, the run, why it stopped and (simulated) the
/// labels against the truth.
fn summary(end: &SessionEnd) -> String {
    let o = &end.outcome;
    let mut summary = format!(
        "{} of {} points, {} frames ({} dropped) in {}",
        o.points_done,
        o.points_total,
        o.frames,
        o.dropped_frames,
        o.run_dir.display()
    );
    if o.status != ExitStatus::Completed {
        summary = format!("{}; {summary}", o.reason);
    }
    if let Some(s) = &end.truth_score {
        summary.push_str(&format!(
            "; labels vs the simulator's truth: Fz RMS {:.3} N, contact RMS {:.3} mm",
            s.force_rms_n, s.contact_rms_mm
        ));
    }
    summary
}
