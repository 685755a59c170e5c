//! The event loop: keys from the terminal, events from the scan thread, snapshots of the live
//! view and validation, a redraw at most every [`FRAME`]. The terminal is restored on quit, on
//! error, on panic (ratatui's hook) and on SIGTERM / SIGHUP.

use super::calibration;
use super::plan_choice::{self, PlanSource};
use super::session::{self, Event, ModelChoice, Running, ScanRequest};
use super::stage_operator::UiStageOperator;
use super::state::{
    BenchView, CalibrateView, CalibrationPhase, Dialog, Phase, Picker, RunRow, RunsView, Tab,
    UiState, JOG_STEPS_MM,
};
use super::view;
use crossbeam_channel::{unbounded, Receiver, RecvTimeoutError, Sender};
use fringe_app::bench_session::{AxisId, BenchCommand, BenchSession};
use fringe_app::calibration_scan::{
    calibrate_run, spot_settings, CalibrationResult, DEFAULT_MAX_FRAMES,
};
use fringe_app::{Note, ProfileUse, RigConfig};
use fringe_rig::scan::control::{Prompt, Reply, ScanProgress};
use fringe_rig::scan::plan::{BenchLimits, Plan, ScanProgram};
use fringe_rig::store::documents::ExitStatus;
use fringe_rig::store::run_list::list;
use fringe_rig::units::Millimetres;
use ratatui::crossterm::event::{self, Event as TermEvent, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::DefaultTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The longest time between redraws while something moves (30 fps).
const FRAME: Duration = Duration::from_millis(33);

/// Side of the Bench screen's frame picture, px.
const BENCH_PICTURE_PX: u32 = 96;

/// How the UI starts.
pub struct UiOptions {
    pub config: RigConfig,
    pub rig: String,
    pub plan_text: String,
    pub plan_origin: String,
    pub runs: PathBuf,
    pub model: Option<ModelChoice>,
    pub tab: Tab,
    /// Start the scan at once.
    pub start: bool,
}

static TERMINATE: AtomicBool = AtomicBool::new(false);

extern "C" fn on_terminate(_: libc::c_int) {
    TERMINATE.store(true, Ordering::SeqCst);
}

/// Runs the UI until the user quits. Errors that stop the UI are returned after the terminal
/// is restored, so they are printed on the normal screen.
pub fn run(opts: UiOptions) -> anyhow::Result<()> {
    let plan = Plan::parse(&opts.plan_text, &opts.plan_origin)?;
    let limits = opts.config.limits()?;
    let program = plan.program(&limits, &opts.plan_origin)?;
    // SAFETY: the handlers only store to an atomic.
    unsafe {
        libc::signal(
            libc::SIGTERM,
            on_terminate as *const () as libc::sighandler_t,
        );
        libc::signal(
            libc::SIGHUP,
            on_terminate as *const () as libc::sighandler_t,
        );
    }
    let mut app = App::new(opts, &program, &limits);
    let mut terminal = ratatui::init();
    let result = app.run(&mut terminal);
    // A terminal that hung up cannot be restored; nothing is printed about it (stderr is that
    // terminal too).
    let _ = ratatui::try_restore();
    // A scan still running is stopped and waited for, so z retracts and the run is closed:
    // as aborted when the operator quit, as interrupted (resumable) when the terminal hung up
    // or the process was told to end.
    let interrupted = TERMINATE.load(Ordering::SeqCst) || result.is_err();
    app.stop_scan(interrupted);
    app.close_bench();
    result
}

/// Terminal events read on their own thread: the loop below never blocks in a read, so it sees
/// SIGTERM / SIGHUP within one frame even when the terminal has hung up under a read.
fn input_thread() -> anyhow::Result<Receiver<std::io::Result<TermEvent>>> {
    let (tx, rx) = crossbeam_channel::bounded(64);
    std::thread::Builder::new()
        .name("terminal-input".into())
        .spawn(move || loop {
            let e = event::read();
            let failed = e.is_err();
            if tx.send(e).is_err() || failed {
                return;
            }
        })?;
    Ok(rx)
}

/// What the calibration threads report.
enum Calibrated {
    /// The profile fitted from the calibration scan's run, and the screen that shows it.
    Fitted(Box<CalibrationResult>, Box<CalibrateView>),
    /// The profile written (the files, as text).
    Written(String),
    Failed(String),
}

/// A run's name and the verdict of its verification.
type Verdict = (String, String);

struct App {
    state: UiState,
    opts: UiOptions,
    program: ScanProgram,
    limits: BenchLimits,
    /// The plans `l` offers.
    plans: Vec<PlanSource>,
    running: Option<Running>,
    /// The bench, open while the Bench screen is shown and no scan holds the devices.
    bench: Option<BenchSession>,
    /// The running scan is the calibration scan (its end starts the fit).
    calibrating: bool,
    /// The fitted calibration awaiting `w`.
    calibration: Option<Box<CalibrationResult>>,
    calibrated: (Sender<Calibrated>, Receiver<Calibrated>),
    verify: (Sender<Verdict>, Receiver<Verdict>),
    /// Evaluations of a run with the session's model: progress, then the figures.
    evaluate: (Sender<Verdict>, Receiver<Verdict>),
    /// Exports of a run in the reference layout: progress, then where it went.
    export: (Sender<Verdict>, Receiver<Verdict>),
    quit: bool,
}

impl App {
    fn new(opts: UiOptions, program: &ScanProgram, limits: &BenchLimits) -> App {
        let origin = opts.config.origin().ok();
        let scan = plan_choice::scan_view(
            program,
            limits,
            origin.map_or((0.0, 0.0), |o| (o.x.0, o.y.0)),
        );
        let plans = plan_choice::available(
            PlanSource {
                label: opts.plan_origin.clone(),
                text: opts.plan_text.clone(),
                origin: opts.plan_origin.clone(),
                unreadable: None,
            },
            Path::new("plans"),
        );
        let state = UiState {
            tab: opts.tab,
            help: false,
            rig: opts.rig.clone(),
            scan,
            model: opts.model.as_ref().map(|m| m.path.display().to_string()),
            validation: None,
            runs: RunsView {
                root: opts.runs.display().to_string(),
                ..RunsView::default()
            },
            bench: BenchView::default(),
            calibrate: calibration::ready_view(&opts.config),
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
            calibrating: false,
            calibration: None,
            calibrated: unbounded(),
            verify: unbounded(),
            evaluate: unbounded(),
            export: unbounded(),
            quit: false,
        }
    }

    fn run(&mut self, terminal: &mut DefaultTerminal) -> anyhow::Result<()> {
        let input = input_thread()?;
        self.refresh_runs();
        if self.opts.start {
            self.start_scan();
        }
        let mut last_draw = Instant::now() - FRAME;
        let mut dirty = true;
        while !self.quit {
            if TERMINATE.load(Ordering::SeqCst) {
                break;
            }
            self.follow_tab();
            let wait = FRAME.saturating_sub(last_draw.elapsed());
            match input.recv_timeout(wait) {
                Ok(Ok(TermEvent::Key(k))) if k.kind != KeyEventKind::Release => {
                    self.key(k.code, k.modifiers);
                    dirty = true;
                }
                Ok(Ok(TermEvent::Resize(..))) => dirty = true,
                Ok(Ok(_)) | Err(RecvTimeoutError::Timeout) => {}
                // The terminal is gone (hung up) or unreadable: stop, aborting any scan.
                Ok(Err(e)) => return Err(anyhow::anyhow!("reading the terminal: {e}")),
                Err(RecvTimeoutError::Disconnected) => break,
            }
            dirty |= self.pump();
            if dirty && last_draw.elapsed() >= FRAME || last_draw.elapsed() >= 4 * FRAME {
                terminal.draw(|f| view::draw(f, &self.state))?;
                last_draw = Instant::now();
                dirty = false;
            }
        }
        Ok(())
    }

    /// Takes what the threads published; true when anything changed.
    fn pump(&mut self) -> bool {
        let mut changed = false;
        while let Ok((name, verdict)) = self.verify.1.try_recv() {
            if let Some(r) = self.state.runs.rows.iter_mut().find(|r| r.name == name) {
                r.verified = Some(verdict);
            }
            changed = true;
        }
        while let Ok((name, figures)) = self.evaluate.1.try_recv() {
            if let Some(r) = self.state.runs.rows.iter_mut().find(|r| r.name == name) {
                r.evaluated = Some(figures);
            }
            changed = true;
        }
        while let Ok((name, outcome)) = self.export.1.try_recv() {
            if let Some(r) = self.state.runs.rows.iter_mut().find(|r| r.name == name) {
                r.exported = Some(outcome);
            }
            changed = true;
        }
        if let Some(b) = &self.bench {
            self.state.bench.bench = b.state();
            changed = true;
        }
        while let Ok(c) = self.calibrated.1.try_recv() {
            match c {
                Calibrated::Fitted(result, view) => {
                    self.state.calibrate = *view;
                    self.calibration = Some(result);
                }
                Calibrated::Written(files) => {
                    self.state.calibrate.phase = CalibrationPhase::Written(files);
                }
                Calibrated::Failed(why) => {
                    self.state.calibrate.phase = CalibrationPhase::Failed(why.clone());
                    self.state.error = Some(why);
                }
            }
            changed = true;
        }
        let Some(running) = &self.running else {
            return changed;
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
        for e in events {
            changed = true;
            self.event(e);
        }
        changed || moving
    }

    fn event(&mut self, e: Event) {
        let scan = &mut self.state.scan;
        match e {
            Event::Note(Note::Info(t)) => scan.log(t.trim().to_string()),
            Event::Note(Note::Warning(t)) => scan.log(format!("warning: {t}")),
            Event::Geometry {
                origin_mm,
                disc_radius_mm,
            } => {
                scan.origin_mm = origin_mm;
                scan.disc_radius_mm = disc_radius_mm;
            }
            Event::Progress(p) => match p {
                ScanProgress::Message(m) => {
                    if let Some(dir) = m.strip_prefix("run directory ") {
                        scan.run_dir = Some(dir.to_string());
                    }
                    scan.log(m);
                }
                ScanProgress::Phase { point, phase } => {
                    scan.current = Some((point, phase.name()));
                }
                ScanProgress::Status(s) => {
                    scan.done = s.points_done;
                    scan.total = s.points_total;
                    scan.eta = s.eta;
                    scan.force_n = s.force_n;
                    scan.frame_rate_hz = s.frame_rate_hz;
                    scan.frames = s.frames_recorded;
                    scan.dropped = s.dropped_frames;
                }
                ScanProgress::Paused { reason } => {
                    scan.log(format!("paused: {reason}"));
                    scan.phase = Phase::Paused(reason);
                }
                ScanProgress::Resumed => {
                    scan.log("resumed");
                    scan.phase = Phase::Running;
                }
            },
            Event::Prompt(p) => {
                let title = match &p {
                    Prompt::ChangeIndenter { .. } => "change the indenter",
                    Prompt::MoveY { .. } => "move the y stage",
                    Prompt::Resume { .. } => "scan paused",
                };
                if let Prompt::Resume { reason } = &p {
                    scan.phase = Phase::Paused(reason.clone());
                }
                self.state.dialog = Some(Dialog {
                    title: title.to_string(),
                    message: p.message(),
                });
            }
            Event::Ended {
                completed,
                summary,
                run_dir,
            } => {
                if std::mem::take(&mut self.calibrating) {
                    self.fit_calibration(completed, &summary, run_dir);
                }
                let scan = &mut self.state.scan;
                scan.log(summary.clone());
                if completed {
                    scan.done = scan.total;
                }
                scan.current = None;
                scan.phase = Phase::Finished { completed, summary };
                self.state.dialog = None;
                self.refresh_runs();
            }
            Event::Failed(why) => {
                if std::mem::take(&mut self.calibrating) {
                    self.state.calibrate.phase =
                        CalibrationPhase::Failed(format!("the calibration scan failed: {why}"));
                }
                let scan = &mut self.state.scan;
                scan.log(format!("failed: {why}"));
                scan.phase = Phase::Failed(why.clone());
                scan.current = None;
                self.state.dialog = None;
                self.state.error = Some(why);
                self.refresh_runs();
            }
        }
    }

    fn key(&mut self, code: KeyCode, mods: KeyModifiers) {
        self.state.error = None;
        if code == KeyCode::Char('c') && mods.contains(KeyModifiers::CONTROL) {
            self.stop_scan(false);
            self.quit = true;
            return;
        }
        if self.state.help {
            self.state.help = false;
            return;
        }
        if self.state.picker.is_some() {
            self.picker_key(code);
            return;
        }
        if self.state.dialog.is_some() {
            let reply = match code {
                KeyCode::Enter | KeyCode::Char('y' | 'c' | ' ') => Some(Reply::Continue),
                KeyCode::Char('a') | KeyCode::Esc => Some(Reply::Abort),
                _ => None,
            };
            if let (Some(r), Some(running)) = (reply, &self.running) {
                if r == Reply::Abort {
                    running.control.abort();
                    self.state.scan.phase = Phase::Stopping("aborting: z retracts".into());
                } else if matches!(self.state.scan.phase, Phase::Paused(_)) {
                    self.state.scan.phase = Phase::Running;
                }
                let _ = running.replies.send(r);
                self.state.dialog = None;
            }
            return;
        }
        match code {
            KeyCode::Char('?') => self.state.help = true,
            KeyCode::Char('l') => {
                if self.scan_active() {
                    self.state.error = Some("a scan is running: choose a plan when it ends".into());
                } else {
                    let current = self
                        .plans
                        .iter()
                        .position(|p| p.text == self.opts.plan_text)
                        .unwrap_or(0);
                    self.state.tab = Tab::Scan;
                    self.state.picker = Some(Picker {
                        items: self.plans.iter().map(|p| p.label.clone()).collect(),
                        selected: current,
                    });
                }
            }
            KeyCode::Char('q') | KeyCode::Esc => {
                if self.scan_active() {
                    self.state.error = Some(
                        "a scan is running: press a to abort it first (or Ctrl-C to abort and quit)"
                            .into(),
                    );
                } else {
                    self.quit = true;
                }
            }
            KeyCode::Tab => {
                let i = Tab::ALL
                    .iter()
                    .position(|t| *t == self.state.tab)
                    .unwrap_or(0);
                self.state.tab = Tab::ALL[(i + 1) % Tab::ALL.len()];
            }
            KeyCode::BackTab => {
                let i = Tab::ALL
                    .iter()
                    .position(|t| *t == self.state.tab)
                    .unwrap_or(0);
                self.state.tab = Tab::ALL[(i + Tab::ALL.len() - 1) % Tab::ALL.len()];
            }
            KeyCode::Char('1') => self.state.tab = Tab::Scan,
            KeyCode::Char('2') => self.state.tab = Tab::Validate,
            KeyCode::Char('3') => self.state.tab = Tab::Runs,
            KeyCode::Char('4') => self.state.tab = Tab::Bench,
            KeyCode::Char('5') => self.state.tab = Tab::Calibrate,
            KeyCode::Char('r') if self.state.tab == Tab::Calibrate => {
                if self.scan_active() {
                    self.state.error = Some("a scan is already running".into());
                } else {
                    self.start_calibration();
                }
            }
            KeyCode::Char('w') if self.state.tab == Tab::Calibrate => self.write_profile(),
            KeyCode::Char('x') if self.state.tab == Tab::Bench => self.state.bench.axis = AxisId::X,
            KeyCode::Char('y') if self.state.tab == Tab::Bench => self.state.bench.axis = AxisId::Y,
            KeyCode::Char('z') if self.state.tab == Tab::Bench => self.state.bench.axis = AxisId::Z,
            KeyCode::Char('s') if self.state.tab == Tab::Bench => {
                self.state.bench.step = (self.state.bench.step + 1) % JOG_STEPS_MM.len();
            }
            KeyCode::Left | KeyCode::Char('-') if self.state.tab == Tab::Bench => self.jog(-1.0),
            KeyCode::Right | KeyCode::Char('+' | '=') if self.state.tab == Tab::Bench => {
                self.jog(1.0)
            }
            KeyCode::Char('h') if self.state.tab == Tab::Bench => {
                self.bench_command(BenchCommand::Home(self.state.bench.axis))
            }
            KeyCode::Char(' ') if self.state.tab == Tab::Bench => {
                self.bench_command(BenchCommand::Stop)
            }
            KeyCode::Char('t') if self.state.tab == Tab::Bench => {
                self.bench_command(BenchCommand::Tare)
            }
            KeyCode::Char('r') => {
                if self.scan_active() {
                    self.state.error = Some("a scan is already running".into());
                } else {
                    self.start_scan();
                }
            }
            KeyCode::Char('p') => self.pause(false),
            KeyCode::Char('P') => self.pause(true),
            KeyCode::Char('c') => {
                if let Some(r) = &self.running {
                    r.control.resume();
                    // A pause asked for and taken back before the scan reached it: the scan goes
                    // on, and says so (if it had begun to pause, its own report follows).
                    if matches!(&self.state.scan.phase, Phase::Stopping(what) if what.starts_with("pausing"))
                    {
                        self.state.scan.phase = Phase::Running;
                    }
                }
            }
            KeyCode::Char('a') => {
                if let Some(r) = &self.running {
                    if self.scan_active() {
                        r.control.abort();
                        self.state.scan.phase = Phase::Stopping("aborting: z retracts".into());
                    }
                }
            }
            KeyCode::Up if self.state.tab == Tab::Runs => {
                self.state.runs.selected = self.state.runs.selected.saturating_sub(1);
            }
            KeyCode::Down if self.state.tab == Tab::Runs => {
                let n = self.state.runs.rows.len();
                self.state.runs.selected = (self.state.runs.selected + 1).min(n.saturating_sub(1));
            }
            KeyCode::Char('g') => self.refresh_runs(),
            KeyCode::Enter if self.state.tab == Tab::Runs => self.verify_selected(),
            KeyCode::Char('e') if self.state.tab == Tab::Runs => self.evaluate_selected(),
            KeyCode::Char('x') if self.state.tab == Tab::Runs => self.export_selected(),
            _ => {}
        }
    }

    /// Keys while the plan chooser is open.
    fn picker_key(&mut self, code: KeyCode) {
        let Some(picker) = &mut self.state.picker else {
            return;
        };
        match code {
            KeyCode::Up => picker.selected = picker.selected.saturating_sub(1),
            KeyCode::Down => {
                picker.selected = (picker.selected + 1).min(picker.items.len().saturating_sub(1))
            }
            KeyCode::Esc | KeyCode::Char('q' | 'l') => self.state.picker = None,
            KeyCode::Enter => {
                let i = picker.selected;
                self.state.picker = None;
                if let Some(src) = self.plans.get(i).cloned() {
                    self.choose(src);
                }
            }
            _ => {}
        }
    }

    /// Makes `src` the plan `r` runs, or says why it cannot be.
    fn choose(&mut self, src: PlanSource) {
        match plan_choice::load(&src, &self.limits) {
            Ok(program) => {
                let old = &self.state.scan;
                let mut view = plan_choice::scan_view(&program, &self.limits, old.origin_mm);
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

    fn scan_active(&self) -> bool {
        matches!(
            self.state.scan.phase,
            Phase::Running | Phase::Paused(_) | Phase::Stopping(_)
        )
    }

    fn pause(&mut self, now: bool) {
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

    /// Opens the bench when its screen is shown and no scan holds the devices; closes it when
    /// another screen is (so a scan can open them).
    fn follow_tab(&mut self) {
        let want = self.state.tab == Tab::Bench;
        if want && self.scan_active() {
            self.close_bench();
            self.state.bench.held = Some(
                "a scan holds the devices: its state is on the Scan screen; the bench opens \
                 here when it ends"
                    .into(),
            );
            return;
        }
        self.state.bench.held = None;
        if want && self.bench.is_none() {
            self.state.bench.bench = Default::default();
            match BenchSession::open(
                self.opts.config.clone(),
                BENCH_PICTURE_PX,
                Box::new(UiStageOperator),
            ) {
                Ok(b) => self.bench = Some(b),
                Err(e) => self.state.error = Some(format!("cannot start the bench thread: {e}")),
            }
        } else if !want {
            self.close_bench();
        }
    }

    /// Stops any motion and releases the bench's devices (waits for its thread).
    fn close_bench(&mut self) {
        if let Some(b) = self.bench.take() {
            b.close();
            self.state.bench.bench.phase = fringe_app::bench_session::BenchPhase::Closed;
        }
    }

    fn bench_command(&mut self, command: BenchCommand) {
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

    fn jog(&mut self, sign: f64) {
        let by = Millimetres(sign * self.state.bench.step_mm());
        self.bench_command(BenchCommand::Jog {
            axis: self.state.bench.axis,
            by,
        });
    }

    /// Runs the built-in calibration grid; its end fits the profile ([`Self::fit_calibration`]).
    fn start_calibration(&mut self) {
        match calibration::plan(&self.opts.config) {
            Ok((program, text, _sensor, _)) => {
                self.calibration = None;
                let ready = calibration::ready_view(&self.opts.config);
                self.state.calibrate = CalibrateView {
                    phase: CalibrationPhase::Scanning,
                    ..ready
                };
                self.calibrating = true;
                self.start_program(program, text, None, ProfileUse::Ignore);
            }
            Err(e) => {
                self.state.calibrate.phase = CalibrationPhase::Failed(format!("{e:#}"));
            }
        }
    }

    /// After the calibration scan: fits the profile from its run on a thread.
    fn fit_calibration(&mut self, completed: bool, summary: &str, run_dir: PathBuf) {
        if !completed {
            self.state.calibrate.phase = CalibrationPhase::Failed(format!(
                "the calibration scan did not complete ({summary}); no profile"
            ));
            return;
        }
        self.state.calibrate.phase = CalibrationPhase::Fitting;
        let config = self.opts.config.clone();
        let mut view = self.state.calibrate.clone();
        let tx = self.calibrated.0.clone();
        std::thread::spawn(move || {
            let outcome = spot_settings(None, &config)
                .map_err(|e| e.to_string())
                .and_then(|(spot, _)| {
                    calibrate_run(&run_dir, &view.sensor, DEFAULT_MAX_FRAMES, spot)
                        .map_err(|e| e.to_string())
                });
            let _ = tx.send(match outcome {
                Ok(result) => {
                    calibration::show(&mut view, &result);
                    Calibrated::Fitted(Box::new(result), Box::new(view))
                }
                Err(why) => Calibrated::Failed(why),
            });
        });
    }

    /// Writes the fitted profile (and its report images) into the rig's profile folder.
    fn write_profile(&mut self) {
        let Some(result) = self.calibration.take() else {
            self.state.error =
                Some("no fitted calibration to write: run the calibration scan first (r)".into());
            return;
        };
        let dir = self.opts.config.profile_dir();
        let tx = self.calibrated.0.clone();
        self.state.calibrate.phase = CalibrationPhase::Writing;
        std::thread::spawn(move || {
            let _ = tx.send(match result.write(&dir) {
                Ok(w) => {
                    let mut files = vec![
                        w.profile.display().to_string(),
                        w.report.display().to_string(),
                    ];
                    files.extend(
                        w.residuals
                            .iter()
                            .chain(&w.contact)
                            .map(|p| p.display().to_string()),
                    );
                    Calibrated::Written(files.join(", "))
                }
                Err(e) => Calibrated::Failed(e.to_string()),
            });
        });
    }

    fn start_scan(&mut self) {
        if self.state.tab == Tab::Bench {
            self.state.tab = Tab::Scan;
        }
        let model = if self.state.tab == Tab::Validate || self.opts.tab == Tab::Validate {
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

    fn start_program(
        &mut self,
        program: ScanProgram,
        plan_text: String,
        model: Option<ModelChoice>,
        profile: ProfileUse,
    ) {
        self.stop_scan(false);
        self.close_bench();
        self.state.validation = None;
        let scan = &mut self.state.scan;
        scan.phase = Phase::Running;
        scan.done = 0;
        scan.current = None;
        scan.run_dir = None;
        scan.total = program.points.len() as u64;
        scan.log(format!("starting {}", program.plan.name));
        self.running = Some(session::start(ScanRequest {
            config: self.opts.config.clone(),
            program,
            plan_text,
            runs: self.opts.runs.clone(),
            model,
            profile,
        }));
    }

    /// Stops a running scan and waits for its thread (z retracts, the run is closed): aborted,
    /// or `interrupted` (closed resumable: the operator did not decide it).
    fn stop_scan(&mut self, interrupted: bool) {
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

    fn refresh_runs(&mut self) {
        let root = &self.opts.runs;
        let rows = match list(root) {
            Ok((runs, _)) => runs
                .into_iter()
                .map(|r| RunRow {
                    name: r.dir.file_name().map_or_else(
                        || r.dir.display().to_string(),
                        |n| n.to_string_lossy().into_owned(),
                    ),
                    status: match &r.stop {
                        None => "unfinished".into(),
                        Some(s) => match s.exit_status {
                            ExitStatus::Completed => "completed".into(),
                            ExitStatus::Aborted => "aborted".into(),
                            ExitStatus::Failed => "failed".into(),
                        },
                    },
                    frames: r.frames as usize,
                    verified: None,
                    evaluated: None,
                    exported: None,
                })
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

    /// Verifies the chosen run on a thread; the verdict arrives through `verify`.
    fn verify_selected(&mut self) {
        let Some(row) = self.state.runs.rows.get_mut(self.state.runs.selected) else {
            return;
        };
        row.verified = Some("verifying...".into());
        let name = row.name.clone();
        let dir = self.opts.runs.join(&name);
        let tx = self.verify.0.clone();
        std::thread::spawn(move || {
            let verdict = match fringe_rig::store::verify::verify(&dir) {
                Ok(r) if r.ok() => {
                    format!("ok: {} frames, {} force samples", r.frames, r.force_samples)
                }
                Ok(r) => format!("{} problem(s): {}", r.problems.len(), r.problems.join("; ")),
                Err(e) => format!("cannot verify: {e}"),
            };
            let _ = tx.send((name, verdict));
        });
    }

    /// Exports the chosen run in the reference layout (`0.images/`, `0.labels.csv`, as
    /// `fringe export` does) to `exports/<run>` beside the runs directory, on a thread.
    fn export_selected(&mut self) {
        let Some(row) = self.state.runs.rows.get_mut(self.state.runs.selected) else {
            return;
        };
        let name = row.name.clone();
        let dir = self.opts.runs.join(&name);
        let out = export_dir(&self.opts.runs, &name);
        row.exported = Some(format!("exporting to {}...", out.display()));
        let tx = self.export.0.clone();
        std::thread::spawn(move || {
            let options = fringe_rig::store::export::ExportOptions::default();
            let outcome =
                fringe_rig::store::export::export_reference(&[dir], &out, &options, |k| {
                    if k % 250 == 0 {
                        let _ = tx.send((name.clone(), format!("exporting: {k} images")));
                    }
                });
            let text = match outcome {
                Ok(s) => format!("exported {} images to {}", s.images, out.display()),
                Err(e) => format!("cannot export: {e}"),
            };
            let _ = tx.send((name, text));
        });
    }

    /// Evaluates the chosen run with the session's model (the one that ships when none was
    /// named) on a thread: progress, then the Table-2 figures, arrive through `evaluate`.
    fn evaluate_selected(&mut self) {
        let Some(row) = self.state.runs.rows.get_mut(self.state.runs.selected) else {
            return;
        };
        row.evaluated = Some("evaluating...".into());
        let name = row.name.clone();
        let dir = self.opts.runs.join(&name);
        let choice = self.opts.model.clone().unwrap_or_else(ModelChoice::builtin);
        let tx = self.evaluate.0.clone();
        std::thread::spawn(move || {
            let figures = match session::evaluate_run(&dir, &choice, &|done, total| {
                if done % 100 == 0 {
                    let _ = tx.send((
                        name.clone(),
                        format!("evaluating: {done} of {total} frames"),
                    ));
                }
            }) {
                Ok(f) => f,
                Err(e) => format!("cannot evaluate: {e}"),
            };
            let _ = tx.send((name, figures));
        });
    }
}

/// Where the Runs screen exports run `name`: `exports/<name>` beside the runs directory.
fn export_dir(runs: &Path, name: &str) -> PathBuf {
    let base = match runs.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.join("exports"),
        _ => PathBuf::from("exports"),
    };
    base.join(name)
}
