//! What the terminal UI shows, as plain data: the event loop fills it from what the scan and
//! validation threads publish, the views draw it, and the snapshot tests build it by hand.

use fringe_app::session::ValidationState;
use fringe_app::session::ViewState;
use fringe_app::session::{AxisId, BenchState};
use fringe_app::stream::StreamState;
use std::collections::VecDeque;
use std::time::Duration;

/// Messages kept in the scan log.
pub const LOG_LINES: usize = 200;

/// A screen by name: each screen file owns its own as `TAB` (`screens::scan::TAB`, ...), by
/// which the command line and other code choose it; their order and titles are `screens::ALL`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tab(&'static str);

impl Tab {
    /// The tab of the screen named `name` (its module's name; one screen each, as a test of
    /// `screens::ALL` checks).
    pub const fn named(name: &'static str) -> Tab {
        Tab(name)
    }
}

/// Where the scan is.
#[derive(Debug, Clone, PartialEq)]
pub enum Phase {
    /// Planned, not started: the dry run is shown.
    Ready,
    Running,
    Paused(String),
    /// Asked to pause or abort, not yet done.
    Stopping(String),
    Finished {
        completed: bool,
        summary: String,
    },
    Failed(String),
}

impl Phase {
    /// The keys that act on the scan now: the footer of the screens that show the scan (Scan,
    /// Validate, Runs), whose keys act on every screen.
    pub fn key_hint(&self) -> &'static str {
        match self {
            Phase::Ready => "r run the scan · l choose the plan",
            Phase::Running => "p pause after this press · P pause now · a abort",
            Phase::Paused(_) => "c continue · a abort",
            Phase::Stopping(_) => "a abort",
            Phase::Finished { .. } | Phase::Failed(_) => "r run again · l choose the plan",
        }
    }
}

/// A point of the plan on the stage, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanPoint {
    pub x_mm: f64,
    pub y_mm: f64,
}

/// The scan screen.
#[derive(Debug, Clone)]
pub struct ScanView {
    pub plan: String,
    pub points: Vec<PlanPoint>,
    /// Stage position that presses the sensor centre, mm.
    pub origin_mm: (f64, f64),
    /// The sensor disc's radius, mm, when the geometry is known.
    pub disc_radius_mm: Option<f64>,
    /// Force (N) or depth (mm) targets, as text.
    pub targets: String,
    pub estimate: Duration,
    /// The run's expected size on disk, bytes, when the rig's recording is known.
    pub expected_bytes: Option<u64>,
    pub phase: Phase,
    pub done: u64,
    pub total: u64,
    pub eta: Duration,
    pub force_n: f64,
    pub frame_rate_hz: f64,
    pub frames: u64,
    pub dropped: u64,
    /// The point now being pressed (index) and what it does.
    pub current: Option<(u64, String)>,
    pub log: VecDeque<String>,
    pub live: ViewState,
    pub run_dir: Option<String>,
}

impl ScanView {
    pub fn log(&mut self, line: impl Into<String>) {
        keep_line(&mut self.log, line.into());
    }
}

/// Adds `line` to a log of at most [`LOG_LINES`], the oldest going first.
fn keep_line(log: &mut VecDeque<String>, line: String) {
    if log.len() == LOG_LINES {
        log.pop_front();
    }
    log.push_back(line);
}

/// One run in the runs directory.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRow {
    pub name: String,
    /// completed, aborted, failed or unfinished.
    pub status: String,
    pub frames: usize,
    /// Bytes the run takes on disk (`None`: it could not be read).
    pub bytes: Option<u64>,
    /// The verdict of the last verification, if the user asked for one.
    pub verified: Option<String>,
    /// The model's figures on this run (or the evaluation's progress), if the user asked.
    pub evaluated: Option<String>,
    /// Where the run was exported in the reference layout (or the export's progress).
    pub exported: Option<String>,
}

/// The runs screen.
#[derive(Debug, Clone, Default)]
pub struct RunsView {
    pub root: String,
    /// The model `e` evaluates with: the one named, else the unit's commissioned one, else the
    /// one that ships for the sensor's design.
    pub model: String,
    pub rows: Vec<RunRow>,
    pub selected: usize,
}

/// Jog steps offered, mm (`s` cycles through them).
pub const JOG_STEPS_MM: [f64; 4] = [0.01, 0.1, 1.0, 5.0];

/// The bench screen.
#[derive(Debug, Clone)]
pub struct BenchView {
    /// What the bench session published (phase Closed while a scan holds the devices).
    pub bench: BenchState,
    /// The axis the jog keys move.
    pub axis: AxisId,
    /// Index into [`JOG_STEPS_MM`].
    pub step: usize,
    /// Why the bench is not open (a scan holds the devices), when it is not.
    pub held: Option<String>,
}

impl Default for BenchView {
    fn default() -> BenchView {
        BenchView {
            bench: BenchState::default(),
            axis: AxisId::Z,
            step: 1,
            held: None,
        }
    }
}

impl BenchView {
    pub fn step_mm(&self) -> f64 {
        JOG_STEPS_MM[self.step % JOG_STEPS_MM.len()]
    }
}

/// The Stream screen.
#[derive(Debug, Clone, Default)]
pub struct StreamView {
    /// The stream's state: the running one's, or the last one's when it stopped.
    pub state: Option<StreamState>,
    /// Whether a stream runs now.
    pub running: bool,
    /// The model a stream runs (before one starts: the one it would run).
    pub model: String,
    /// Where it would publish: the node, its domain and endpoints, from the rig file.
    pub node: String,
    /// Why a stream cannot start now (a scan holds the camera), when it cannot.
    pub held: Option<String>,
    /// What the stream said: what it opened, its warnings, its summary.
    pub log: VecDeque<String>,
}

impl StreamView {
    pub fn log(&mut self, line: impl Into<String>) {
        keep_line(&mut self.log, line.into());
    }
}

/// Where the calibration is.
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationPhase {
    /// Nothing run yet: `r` runs the calibration scan.
    Ready,
    /// The calibration scan runs (its progress is the Scan screen's).
    Scanning,
    /// The scan ended; the profile is being fitted from its run.
    Fitting,
    /// Fitted: `w` writes the profile.
    Fitted,
    /// `w` pressed: the profile and its images are being written.
    Writing,
    /// Written to these files.
    Written(String),
    Failed(String),
}

/// A press of the calibration scan as located.
#[derive(Debug, Clone, PartialEq)]
pub struct PressRow {
    /// Stage position, mm.
    pub stage_mm: (f64, f64),
    /// Registration residual, px (and whether the fit left it out), or why the contact was
    /// not located.
    pub outcome: Result<(f64, bool), String>,
}

/// The calibration screen.
#[derive(Debug, Clone)]
pub struct CalibrateView {
    pub sensor: String,
    /// The calibration plan, described.
    pub plan: String,
    /// Where the profile goes.
    pub profile: String,
    pub phase: CalibrationPhase,
    /// The optical fit, one line each (centre, shift, radius, crop radius, residual).
    pub fit: Vec<String>,
    /// The registration, one line (scale, rotation, RMS residual) or why there is none.
    pub registration: String,
    pub presses: Vec<PressRow>,
    /// The force offsets, one line per channel group.
    pub offsets: Vec<String>,
    /// The averaged no-contact frame with the fitted disc, crop circle and centre drawn.
    pub picture: Option<image::RgbImage>,
}

/// The Health screen: the unit's checks against its commissioning certificate.
#[derive(Debug, Clone, Default)]
pub struct HealthView {
    pub sensor: String,
    /// The certificate checks compare with (its directory and date), or what to do without one.
    pub certificate: String,
    /// The history file.
    pub history: String,
    /// Every check, oldest first.
    pub checks: Vec<fringe_app::health::Entry>,
    /// Lines of the history passed over (damaged, newer), and why the history cannot be read.
    pub notes: Vec<String>,
    /// The check whose figures are shown.
    pub selected: usize,
}

/// The Units screen: every unit known with its certificate, checks and model
/// (`fringe_app::units::list`, as `fringe units` prints it).
#[derive(Debug, Clone, Default)]
pub struct UnitsView {
    /// Where the units' profiles, certificates and histories are.
    pub profiles: String,
    /// The rig's sensor, when it names one.
    pub on_rig: Option<String>,
    pub units: Vec<fringe_app::units::UnitView>,
    /// What could not be read.
    pub notes: Vec<String>,
    /// The unit whose details are shown.
    pub selected: usize,
}

/// Where the Commission screen's commissioning is.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum CommissionPhase {
    /// Nothing started from this screen yet.
    #[default]
    Ready,
    /// Under way: the step, in words.
    Running(String),
    /// Asked to stop; the scan closes its run resumable.
    Stopping,
    /// The verdict: passed or not, and the certificate.
    Verdict { pass: bool, summary: String },
    /// Stopped before its verdict (an error, a stopped scan): why, and how to go on.
    Stopped(String),
}

/// The Commission screen: a unit taken from first light to its verdict (`fringe commission`).
#[derive(Debug, Clone, Default)]
pub struct CommissionView {
    pub sensor: String,
    /// What `r` starts (base, budget, spec), in words.
    pub plan: String,
    pub phase: CommissionPhase,
    /// The commissioning's directory, once it has one.
    pub dir: Option<String>,
    /// The newest unfinished commissioning of the unit, which `c` goes on with.
    pub resumable: Option<String>,
    /// The unit's newest certificate, made here or on the command line, in words; whether it
    /// passed.
    pub existing: Option<(bool, String)>,
    /// What the commissioning said, newest last.
    pub log: VecDeque<String>,
    /// The computation under way (features, evaluation), as a line.
    pub progress: Option<String>,
    /// The spec's thresholds: Fz RMSE (N), contact RMSE (mm), shape accuracy (share).
    pub thresholds: (Option<f64>, Option<f64>, Option<f64>),
    pub curve: Vec<fringe_app::commission::CurvePoint>,
    pub pressed: Vec<fringe_app::commission::PressedPoint>,
    pub disc: Option<fringe_app::commission::UsableDisc>,
}

impl CommissionView {
    pub fn log(&mut self, line: impl Into<String>) {
        keep_line(&mut self.log, line.into());
    }
}

/// A question the scan asks, shown over every screen until answered.
#[derive(Debug, Clone, PartialEq)]
pub struct Dialog {
    pub title: String,
    pub message: String,
}

/// The plan chooser (`l`).
#[derive(Debug, Clone, PartialEq)]
pub struct Picker {
    pub items: Vec<String>,
    pub selected: usize,
}

/// Everything on screen.
#[derive(Debug, Clone)]
pub struct UiState {
    pub tab: Tab,
    pub help: bool,
    /// The rig, described.
    pub rig: String,
    pub scan: ScanView,
    /// The Scan screen draws the whole disc even for a plan small on it (`d`).
    pub scan_whole_disc: bool,
    /// The model chosen for validation (none: the Validate screen says how to choose one).
    pub model: Option<String>,
    pub validation: Option<ValidationState>,
    pub runs: RunsView,
    pub bench: BenchView,
    pub stream: StreamView,
    pub calibrate: CalibrateView,
    pub commission: CommissionView,
    pub health: HealthView,
    pub units: UnitsView,
    pub dialog: Option<Dialog>,
    pub picker: Option<Picker>,
    /// The newest error, shown until the next key.
    pub error: Option<String>,
}
