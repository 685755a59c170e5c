//! What every screen acts on: the on-screen state, the scan (its thread, its events, its
//! controls), the bench session that holds the devices when no scan does, and the plans to
//! choose from. Screens and the global keys call these; nothing here knows the screens.

use super::calibration;
use super::commission;
use super::health;
use super::plan_choice::{self, PlanSource};
use super::scan_events::{self, ScanEnd};
use super::session::{self, Event, ModelChoice, Running, ScanRequest};
use super::state::{BenchView, Phase, Picker, RunRow, RunsView, Tab, UiState};
use super::streaming;
use super::units;
use fringe_app::runs::{list_runs, ListedRun};
use fringe_app::session::Recording;
use fringe_app::session::{BenchCommand, BenchPhase, BenchSession};
use fringe_app::stream::Stream;
use fringe_app::{ProfileUse, RigConfig};
use fringe_rig::store::ExitStatus;
use fringe_rig::Reply;
use fringe_rig::RunTarget;
use fringe_rig::{BenchLimits, ScanProgram};
use std::path::{Path, PathBuf};

/// How the UI starts.
pub struct UiOptions {
    pub config: RigConfig,
    /// The rig in a few words (the header).
    pub rig: String,
    /// The rig as the command line says it (with any advice): the Scan screen's first message.
    pub rig_note: String,
    pub plan_text: String,
    pub plan_origin: String,
    pub runs: PathBuf,
    pub model: Option<ModelChoice>,
    /// The model is the rig's choice (the unit's commissioned one, else the shipped one), not
    /// named by the user: a commissioning that passes in the UI replaces it.
    pub model_from_rig: bool,
    pub tab: Tab,
    /// Start the scan at once.
    pub start: bool,
}

/// The UI's state and what acts behind it, shared by every screen.
pub struct App {
    pub state: UiState,
    pub opts: UiOptions,
    program: ScanProgram,
    limits: BenchLimits,
    /// The plans `l` offers.
    plans: Vec<PlanSource>,
    running: Option<Running>,
    /// The bench, open while the Bench screen is shown and no scan holds the devices.
    pub bench: Option<BenchSession>,
    /// The stream (the camera and the unit's model, publishing), started on the Stream screen;
    /// it runs whichever screen is shown until stopped, and holds the camera meanwhile.
    pub stream: Option<Stream>,
    /// How each stream of this session ended, its summary's lines, said when the UI ends.
    pub streamed: Vec<Vec<String>>,
    pub quit: bool,
    /// How each scan of this session ended, a line each, said when the UI ends.
    pub ended: Vec<String>,
    /// The worker threads' panics while the UI ran ([`App::worker_failed`]), said again when it
    /// ends.
    pub worker_failures: Vec<String>,
}

impl App {
    pub fn new(opts: UiOptions, program: &ScanProgram, limits: &BenchLimits) -> App {
        let origin = opts.config.origin().ok();
        // From the rig file and the profiles only; the Scan screen leaves the size out when
        // they cannot tell it (a scan then says why).
        let recording = Recording::from_rig_files(&opts.config, Some(&program.plan)).ok();
        let mut scan = plan_choice::scan_view(
            program,
            limits,
            origin.map_or((0.0, 0.0), |o| (o.x.0, o.y.0)),
            recording.as_ref(),
        );
        // The plan is drawn on the disc before it runs: the unit's profile on file (on the
        // simulated bench, its design's); a scan then sends the geometry it opened with.
        scan.disc_radius_mm = opts
            .config
            .sensor_id()
            .ok()
            .and_then(|id| {
                fringe_app::rig::unit_profile(&opts.config, &id)
                    .ok()
                    .flatten()
            })
            .and_then(|p| p.disc_radius_mm());
        scan.log(format!("rig: {}", opts.rig_note));
        let plans = plan_choice::available(
            PlanSource {
                label: opts.plan_origin.clone(),
                text: opts.plan_text.clone(),
                origin: opts.plan_origin.clone(),
                unreadable: None,
            },
            Path::new("plans"),
        );
        // The model the Runs and Stream screens name: the one given, else the rig's choice.
        let model_shown = opts
            .model
            .clone()
            .unwrap_or_else(|| ModelChoice::for_rig(&opts.config))
            .path
            .display()
            .to_string();
        let state = UiState {
            tab: opts.tab,
            help: false,
            rig: opts.rig.clone(),
            scan,
            scan_whole_disc: false,
            model: opts.model.as_ref().map(|m| m.path.display().to_string()),
            validation: None,
            runs: RunsView {
                root: opts.runs.display().to_string(),
                model: model_shown.clone(),
                ..RunsView::default()
            },
            bench: BenchView::default(),
            stream: streaming::ready_view(&opts.config, &model_shown),
            calibrate: calibration::ready_view(&opts.config),
            commission: commission::ready_view(&opts.config),
            health: health::view(&opts.config),
            units: units::view(&opts.config),
            dialog: None,
            picker: None,
            error: None,
        };
        App {
            state,
            program: program.clone(),
            limits: limits.clone(),
            plans,
            opts,
            running: None,
            bench: None,
            stream: None,
            streamed: Vec::new(),
            quit: false,
            ended: Vec::new(),
            worker_failures: Vec::new(),
        }
    }

    /// Takes what the scan thread published: whether anything changed (or the scan moves), and
    /// how the scan ended if it did.
    pub fn pump(&mut self) -> (bool, Vec<ScanEnd>) {
        let Some(running) = &self.running else {
            return (false, Vec::new());
        };
        let events: Vec<Event> = running.events.try_iter().collect();
        if let Some(v) = running
            .view
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
        {
            self.state.scan.live = v.state();
        }
        if let Some(v) = running
            .validation
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
        {
            self.state.validation = Some(v.state());
        }
        let moving = matches!(self.state.scan.phase, Phase::Running | Phase::Stopping(_));
        // A scan thread gone without a word (its end told before it returns, its panic caught
        // and told): never a scan shown as running that nothing runs.
        let gone =
            running.thread.as_ref().is_none_or(|t| t.is_finished()) && running.events.is_empty();
        let changed = !events.is_empty();
        let mut ends: Vec<ScanEnd> = events
            .into_iter()
            .filter_map(|e| scan_events::apply(&mut self.state, e))
            .collect();
        if gone && self.scan_active() {
            let why = "the scan thread ended without telling how the scan ended".to_string();
            ends.extend(scan_events::apply(&mut self.state, Event::Failed(why)));
        }
        for end in &ends {
            self.note_end(end);
        }
        if !ends.is_empty() {
            self.refresh_runs();
        }
        (changed || moving, ends)
    }

    pub fn scan_active(&self) -> bool {
        matches!(
            self.state.scan.phase,
            Phase::Running | Phase::Paused(_) | Phase::Stopping(_)
        )
    }

    /// Why a scan cannot start now (another runs, or the stream holds the camera), if it
    /// cannot.
    pub fn scan_refused(&self) -> Option<String> {
        if self.scan_active() {
            Some("a scan is already running".into())
        } else if self.stream.is_some() {
            Some(
                "the stream holds the camera: stop it on the Stream screen (s) before a scan"
                    .into(),
            )
        } else {
            None
        }
    }

    /// Runs the chosen plan (with live validation, the chosen model's, when `validate`).
    pub fn run_scan(&mut self, validate: bool) {
        if let Some(why) = self.scan_refused() {
            self.state.error = Some(why);
            return;
        }
        let model = if validate {
            self.opts.model.clone()
        } else {
            None
        };
        self.start_program(
            self.program.clone(),
            self.opts.plan_text.clone(),
            model,
            ProfileUse::Consume,
        );
    }

    /// Starts `program` on the scan thread as a new run in the runs folder (stopping any scan
    /// and closing the bench first).
    pub fn start_program(
        &mut self,
        program: ScanProgram,
        plan_text: String,
        model: Option<ModelChoice>,
        profile: ProfileUse,
    ) {
        self.start_program_into(program, plan_text, model, profile, None);
    }

    /// Starts `program` on the scan thread into `target` (a new run in the runs folder when
    /// `None`), stopping any scan and closing the bench first.
    pub fn start_program_into(
        &mut self,
        program: ScanProgram,
        plan_text: String,
        model: Option<ModelChoice>,
        profile: ProfileUse,
        target: Option<RunTarget>,
    ) {
        self.stop_scan(false);
        self.close_bench();
        if self.stream.is_some() {
            self.stop_stream();
            self.state
                .scan
                .log("the stream was stopped: the scan needs the camera");
        }
        self.state.validation = None;
        // The Scan screen shows the plan that runs (a calibration or commissioning scan too).
        let recording = Recording::from_rig_files(&self.opts.config, Some(&program.plan)).ok();
        let old = &self.state.scan;
        let mut scan =
            plan_choice::scan_view(&program, &self.limits, old.origin_mm, recording.as_ref());
        scan.disc_radius_mm = old.disc_radius_mm;
        scan.log = old.log.clone();
        scan.phase = Phase::Running;
        scan.log(format!("starting {}", program.plan.name));
        self.state.scan = scan;
        self.running = Some(session::start(ScanRequest {
            config: self.opts.config.clone(),
            program,
            plan_text,
            runs: self.opts.runs.clone(),
            model,
            profile,
            target,
        }));
    }

    /// Stops a running scan and waits for its thread (z retracts, the run is closed): aborted,
    /// or `interrupted` (closed resumable: the operator did not decide it).
    pub fn stop_scan(&mut self, interrupted: bool) {
        if let Some(mut r) = self.running.take() {
            if interrupted {
                r.control.interrupt();
            } else {
                r.control.abort();
            }
            let _ = r.replies.send(Reply::Abort);
            if let Some(t) = r.thread.take() {
                let _ = t.join();
            }
            // Its end, told as it stopped, is said when the UI ends.
            let events: Vec<Event> = r.events.try_iter().collect();
            for e in events {
                if let Some(end) = scan_events::apply(&mut self.state, e) {
                    self.note_end(&end);
                }
            }
            // The last validation state stays on screen.
            if let Some(v) = r
                .validation
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .as_ref()
            {
                self.state.validation = Some(v.state());
            }
        }
    }

    /// Keeps how a scan ended, for the lines said when the UI ends.
    fn note_end(&mut self, end: &ScanEnd) {
        let plan = &self.state.scan.plan;
        self.ended.push(match end {
            ScanEnd::Ended {
                completed: true,
                summary,
                ..
            } => format!("{plan}: completed: {summary}"),
            ScanEnd::Ended { summary, .. } => format!("{plan}: stopped: {summary}"),
            ScanEnd::Failed(why) => format!("{plan}: failed: {why}"),
        });
    }

    /// Pauses the running scan after the current press, or `now` (z retracts).
    pub fn pause(&mut self, now: bool) {
        let Some(r) = &self.running else { return };
        if !matches!(self.state.scan.phase, Phase::Running) {
            return;
        }
        if now {
            r.control.pause_now();
            self.state.scan.phase = Phase::Stopping("pausing now: z retracts".into());
        } else {
            r.control.pause();
            self.state.scan.phase = Phase::Stopping("pausing after this press".into());
        }
    }

    /// Continues a paused scan.
    pub fn resume(&mut self) {
        if let Some(r) = &self.running {
            r.control.resume();
            // A pause asked for and taken back before the scan reached it: the scan goes on,
            // and says so (if it had begun to pause, its own report follows).
            if matches!(&self.state.scan.phase, Phase::Stopping(what) if what.starts_with("pausing"))
            {
                self.state.scan.phase = Phase::Running;
            }
        }
    }

    /// Stops a running scan as a hang-up or SIGTERM does: z retracts and the run is closed
    /// resumable (not the operator's abort).
    pub fn interrupt(&mut self) {
        if let Some(r) = &self.running {
            if self.scan_active() {
                r.control.interrupt();
                self.state.scan.phase =
                    Phase::Stopping("stopping: z retracts, the run is closed resumable".into());
            }
        }
    }

    /// A worker thread failed (`what`: its panic): said on screen, and a running scan is
    /// stopped as an interruption (z retracts, the run is closed resumable), as nothing says
    /// the scan can go on without it. The keys go on working.
    pub fn worker_failed(&mut self, what: String) {
        self.state.scan.log(format!("failed: {what}"));
        let mut error = what.clone();
        if let Some(r) = &self.running {
            if self.scan_active() {
                r.control.interrupt();
                self.state.scan.phase = Phase::Stopping(
                    "a worker thread failed: stopping, z retracts, the run is closed resumable"
                        .into(),
                );
                error.push_str("; the scan is stopped (z retracts, the run is closed resumable)");
            }
        }
        self.state.error = Some(format!("{error}: a defect in fringe, please report it"));
        self.worker_failures.push(what);
    }

    /// Aborts a running scan (z retracts, the run is closed).
    pub fn abort(&mut self) {
        if let Some(r) = &self.running {
            if self.scan_active() {
                r.control.abort();
                self.state.scan.phase = Phase::Stopping("aborting: z retracts".into());
            }
        }
    }

    /// Answers the scan's dialog.
    pub fn answer(&mut self, reply: Reply) {
        if let Some(running) = &self.running {
            if reply == Reply::Abort {
                running.control.abort();
                self.state.scan.phase = Phase::Stopping("aborting: z retracts".into());
            } else if matches!(self.state.scan.phase, Phase::Paused(_)) {
                self.state.scan.phase = Phase::Running;
            }
            let _ = running.replies.send(reply);
            self.state.dialog = None;
        }
    }

    /// Opens the plan chooser (not while a scan runs); false when it did not.
    pub fn open_picker(&mut self) -> bool {
        if self.scan_active() {
            self.state.error = Some("a scan is running: choose a plan when it ends".into());
            return false;
        }
        let current = self
            .plans
            .iter()
            .position(|p| p.text == self.opts.plan_text)
            .unwrap_or(0);
        self.state.picker = Some(Picker {
            items: self.plans.iter().map(|p| p.label.clone()).collect(),
            selected: current,
        });
        true
    }

    /// Makes the plan chosen in the chooser the one `r` runs, or says why it cannot be.
    pub fn choose(&mut self, i: usize) {
        let Some(src) = self.plans.get(i).cloned() else {
            return;
        };
        match plan_choice::load(&src, &self.limits) {
            Ok(program) => {
                let old = &self.state.scan;
                let recording =
                    Recording::from_rig_files(&self.opts.config, Some(&program.plan)).ok();
                let mut view = plan_choice::scan_view(
                    &program,
                    &self.limits,
                    old.origin_mm,
                    recording.as_ref(),
                );
                view.disc_radius_mm = old.disc_radius_mm;
                view.log = old.log.clone();
                view.log(format!(
                    "plan {} chosen ({})",
                    program.plan.name, src.origin
                ));
                self.state.scan = view;
                self.program = program;
                self.opts.plan_text = src.text;
                self.opts.plan_origin = src.origin;
            }
            Err(e) => self.state.error = Some(format!("{e:#}")),
        }
    }

    /// Stops any motion and releases the bench's devices (waits for its thread).
    pub fn close_bench(&mut self) {
        if let Some(b) = self.bench.take() {
            b.close();
            self.state.bench.bench.phase = BenchPhase::Closed;
        }
    }

    /// Stops the stream, if one runs (the camera is given back, the recording finished); its
    /// summary stays on the Stream screen and is said again when the UI ends.
    pub fn stop_stream(&mut self) {
        let Some(stream) = self.stream.take() else {
            return;
        };
        let view = &mut self.state.stream;
        view.running = false;
        match stream.finish() {
            Ok(summary) => {
                let lines = crate::stream_text::summary_lines(&summary);
                view.state = Some(summary.state);
                view.log("stream stopped");
                for line in &lines {
                    view.log(line.clone());
                }
                self.streamed.push(lines);
            }
            Err(e) => {
                let line = format!("the stream failed as it stopped: {e}");
                view.log(line.clone());
                self.streamed.push(vec![line]);
            }
        }
    }

    /// Sends `command` to the bench, or says why it is not open.
    pub fn bench_command(&mut self, command: BenchCommand) {
        match &self.bench {
            Some(b) => b.send(command),
            None => {
                self.state.error = Some(
                    self.state
                        .bench
                        .held
                        .clone()
                        .unwrap_or_else(|| "the bench is not open".into()),
                )
            }
        }
    }

    /// Lists the runs again, keeping the verdicts already shown.
    pub fn refresh_runs(&mut self) {
        let root = &self.opts.runs;
        let rows = match list_runs(root) {
            Ok((runs, _)) => runs
                .into_iter()
                .map(
                    |ListedRun {
                         run: r,
                         name,
                         bytes,
                     }| RunRow {
                        name,
                        status: match &r.stop {
                            None => "unfinished".into(),
                            Some(s) => match s.exit_status {
                                ExitStatus::Completed => "completed".into(),
                                ExitStatus::Aborted => "aborted".into(),
                                ExitStatus::Failed => "failed".into(),
                            },
                        },
                        frames: r.frames as usize,
                        bytes,
                        verified: None,
                        evaluated: None,
                        exported: None,
                    },
                )
                .collect(),
            Err(e) => {
                self.state.error = Some(format!("{}: {e}", root.display()));
                Vec::new()
            }
        };
        let old: Vec<RunRow> = std::mem::take(&mut self.state.runs.rows);
        self.state.runs.rows = rows
            .into_iter()
            .map(|mut r| {
                if let Some(o) = old.iter().find(|o| o.name == r.name) {
                    r.verified = o.verified.clone();
                    r.evaluated = o.evaluated.clone();
                    r.exported = o.exported.clone();
                }
                r
            })
            .collect();
        let n = self.state.runs.rows.len();
        self.state.runs.selected = self.state.runs.selected.min(n.saturating_sub(1));
    }
}
