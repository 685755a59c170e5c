//! What the terminal UI shows, as plain data: the event loop fills it from what the scan and
//! validation threads publish, the views draw it, and the snapshot tests build it by hand.

use fringe_app::live_validation::ValidationState;
use fringe_app::live_view::ViewState;
use std::collections::VecDeque;
use std::time::Duration;

/// Messages kept in the scan log.
pub const LOG_LINES: usize = 200;

/// The screens, in tab order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tab {
    Scan,
    Validate,
    Runs,
}

impl Tab {
    pub const ALL: [Tab; 3] = [Tab::Scan, Tab::Validate, Tab::Runs];

    pub fn title(self) -> &'static str {
        match self {
            Tab::Scan => "Scan",
            Tab::Validate => "Validate",
            Tab::Runs => "Runs",
        }
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
        if self.log.len() == LOG_LINES {
            self.log.pop_front();
        }
        self.log.push_back(line.into());
    }
}

/// One run in the runs directory.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRow {
    pub name: String,
    /// completed, aborted, failed or unfinished.
    pub status: String,
    pub frames: usize,
    /// The verdict of the last verification, if the user asked for one.
    pub verified: Option<String>,
    /// The model's figures on this run (or the evaluation's progress), if the user asked.
    pub evaluated: Option<String>,
}

/// The runs screen.
#[derive(Debug, Clone, Default)]
pub struct RunsView {
    pub root: String,
    pub rows: Vec<RunRow>,
    pub selected: usize,
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
    /// The model chosen for validation (none: the Validate screen says how to choose one).
    pub model: Option<String>,
    pub validation: Option<ValidationState>,
    pub runs: RunsView,
    pub dialog: Option<Dialog>,
    pub picker: Option<Picker>,
    /// The newest error, shown until the next key.
    pub error: Option<String>,
}
