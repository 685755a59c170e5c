//! `fringe scan PLAN` (and `fringe` with no command: the built-in short grid on the simulated
//! bench): validate a plan against the rig, print a dry run, or run it into a run directory with
//! a progress bar; Ctrl-C asks for a pause, twice stops now, three times aborts; `--resume RUN`
//! continues a run that a crash or power loss interrupted.

use super::terminal_prompt::TerminalPrompt;
use crate::clock_text::clock;
use crate::global::Global;
use anyhow::bail;
use fringe_app::session::{scan_plan, SHORT_GRID};
use fringe_app::session::{scan_target, ScanTarget};
use fringe_app::session::{Recording, RoomForecast};
use fringe_app::{Note, ProfileUse, RigConfig, ScanSession, SessionEnd};
use fringe_rig::store::human_bytes as human;
use fringe_rig::store::ExitStatus;
use fringe_rig::RunTarget;
use fringe_rig::{scan::Targets, BenchLimits, Plan, ScanProgram};
use fringe_rig::{
    scan::{Request, ScanProgress, Status},
    ScanControl,
};
use fringe_rig::{Operator, Prompt, Reply};
use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

#[derive(clap::Args, Default)]
pub struct ScanArgs {
    /// The scan plan (plan.toml), or a built-in plan's name (`fringe plans`). Without it: the
    /// built-in short grid, or with --resume the plan stored in the run.
    #[arg(value_name = "PLAN")]
    plan: Option<PathBuf>,
    /// The rig file (default: ./rig.toml if present, else the simulated bench).
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    /// Directory that receives the run.
    #[arg(long, value_name = "DIR", default_value = "runs")]
    out: PathBuf,
    /// Print the points, the path and the estimated duration; move nothing.
    #[arg(long)]
    dry_run: bool,
    /// Continue an unfinished run (after a crash or power loss) from its last checkpoint.
    #[arg(long, value_name = "RUN")]
    resume: Option<PathBuf>,
    /// Answer every operator prompt with "continue" (unattended benches, scripts).
    #[arg(long)]
    yes: bool,
}

impl ScanArgs {
    /// What `fringe` with no command runs.
    pub fn main_job() -> ScanArgs {
        ScanArgs {
            out: PathBuf::from("runs"),
            ..ScanArgs::default()
        }
    }
}

/// `fringe` on a terminal: the UI on the Scan screen with the built-in plan, ready to run (r);
/// the Validate screen runs the rig's sensor's commissioned model, else the one that ships with
/// fringe.
pub fn run_ui() -> anyhow::Result<()> {
    let (config, source) = RigConfig::resolve(None)?;
    let model = crate::ui::ModelChoice::for_rig(&config);
    crate::ui::run(crate::ui::UiOptions {
        config,
        rig: source.short(),
        rig_note: source.describe(),
        plan_text: SHORT_GRID.text.to_string(),
        plan_origin: SHORT_GRID.origin(),
        runs: PathBuf::from("runs"),
        model: Some(model),
        model_from_rig: true,
        tab: crate::ui::screens::scan::TAB,
        start: false,
    })
}

pub fn run(args: ScanArgs, global: &Global) -> anyhow::Result<()> {
    let (text, origin) = scan_plan(args.plan.as_deref(), args.resume.as_deref())?;
    let plan = Plan::parse(&text, &origin)?;
    let (config, source) = RigConfig::resolve(args.rig.as_deref())?;
    println!(
        "fringe {}: rig: {}",
        env!("CARGO_PKG_VERSION"),
        source.describe()
    );
    let limits = config.limits()?;
    let program = plan.program(&limits, &origin)?;
    println!("plan: {origin}");
    if args.resume.is_none() {
        // Frames a new run could not store are refused before any device opens, by the dry
        // run as by the scan (a resumed run stores its frames as it did).
        Recording::from_rig_files(&config, Some(&program.plan))?;
    }
    if args.dry_run {
        // What the scan checks before it opens a device is checked here too.
        config.check_before_open()?;
        if let Some(w) = config.ft_rating_warning() {
            eprintln!("warning: {w}");
        }
        print_dry_run(&program, &limits);
        // A resumed run is written where it is, and stores its frames as it did.
        print_room(
            &config,
            &program,
            &limits,
            args.resume.as_deref().unwrap_or(&args.out),
        );
        return Ok(());
    }
    let target = match scan_target(args.resume.as_deref(), &args.out, &plan.name)? {
        ScanTarget::Run(target) => target,
        ScanTarget::Closed { run, stop } => {
            let dir = run.display();
            println!(
                "{dir} had ended ({}: {}) but was stopped while writing its manifest; the manifest is now written and the run is whole: fringe verify {dir}",
                format!("{:?}", stop.exit_status).to_lowercase(),
                stop.reason,
            );
            return Ok(());
        }
    };
    let executed = execute(
        &config,
        program,
        text,
        target,
        args.yes,
        ProfileUse::Consume,
        global,
        &mut |_| Ok(()),
    )?;
    let outcome = executed.outcome;
    let dir = outcome.run_dir.display();
    println!("run written to {dir}");
    println!("  check it:   fringe verify {dir}");
    println!("  export it:  fringe export {dir} --format reference --out dataset/");
    match outcome.status {
        ExitStatus::Completed => Ok(()),
        ExitStatus::Aborted => bail!("{}; the run is closed (aborted) at {dir}", outcome.reason),
        ExitStatus::Failed => bail!("{}", outcome.reason),
    }
}

/// Opens the rig, runs `program` into `target` with the progress bar, Ctrl-C handling and the
/// terminal operator, and prints the summary. `attach` sees the opened session before it runs
/// (live validation adds its tap there).
#[allow(clippy::too_many_arguments)]
pub fn execute(
    config: &RigConfig,
    program: ScanProgram,
    plan_text: String,
    target: RunTarget,
    yes: bool,
    profile_use: ProfileUse,
    global: &Global,
    attach: &mut dyn FnMut(&mut ScanSession) -> anyhow::Result<()>,
) -> anyhow::Result<SessionEnd> {
    let mut session = ScanSession::open(
        config,
        program,
        plan_text,
        profile_use,
        global.record_trace.as_deref(),
        Box::new(TerminalPrompt::stdio()),
    )?;
    for note in &session.notes {
        match note {
            Note::Info(text) => println!("{text}"),
            Note::Warning(text) => eprintln!("warning: {text}"),
        }
    }
    attach(&mut session)?;
    let control = ScanControl::new();
    interrupt::install(control.clone());
    let mut operator = TerminalOperator {
        yes,
        control: control.clone(),
        answers: None,
    };
    let bar = Mutex::new(Bar::new(session.setup.program.points.len() as u64));
    let started = Instant::now();
    let end = session.run(target, &control, &mut operator, &|p| {
        bar.lock().unwrap_or_else(|e| e.into_inner()).show(p)
    });
    bar.lock().unwrap_or_else(|e| e.into_inner()).finish();
    let end = end?;
    let outcome = &end.outcome;
    println!(
        "{}: {} of {} points, {} frames ({} dropped by the camera, {} cut from interrupted points), {} force samples ({} lost) in {:.1} s",
        match outcome.status {
            ExitStatus::Completed => "completed",
            ExitStatus::Aborted => "aborted",
            ExitStatus::Failed => "failed",
        },
        outcome.points_done,
        outcome.points_total,
        outcome.frames,
        outcome.dropped_frames,
        outcome.frames_discarded,
        outcome.force_samples,
        outcome.lost_force_samples,
        started.elapsed().as_secs_f64()
    );
    if outcome.points_done > 0 {
        println!(
            "software overhead per point (all but motion, settling, dwell and prompts): mean {:.1} ms, max {:.1} ms",
            outcome.overhead_mean_ms, outcome.overhead_max_ms
        );
    }
    if let Some(s) = &end.truth_score {
        println!(
            "labels against the simulator's ground truth: normal force RMS {:.3} N (max {:.3} N) over {} frames; contact point RMS {:.3} mm over {} frames in contact",
            s.force_rms_n, s.force_max_n, s.frames, s.contact_rms_mm, s.contact_frames
        );
        if s.shear_frames > 0 {
            println!(
                "shear labels: RMS {:.3} N (x), {:.3} N (y) over {} frames; slip state as the truth's on {} of {} frames; gross slip starts in {} presses at most {} frames off ({} missed, {} false)",
                s.shear_rms_n[0],
                s.shear_rms_n[1],
                s.shear_frames,
                s.slip_agree,
                s.slip_frames,
                s.onsets,
                s.onset_max_frames,
                s.onsets_missed,
                s.onsets_false
            );
        }
    }
    Ok(end)
}

fn print_dry_run(program: &ScanProgram, limits: &BenchLimits) {
    let plan = &program.plan;
    let targets = match &program.targets {
        Targets::Force(t) => format!(
            "force targets {} N (closed loop on the F/T, ramp {} N/s)",
            join(t.iter().map(|t| t.0)),
            plan.indentation.ramp_rate
        ),
        Targets::Depth(t) => format!(
            "depth targets {} mm past contact (ramp {} mm/s)",
            join(t.iter().map(|t| t.0)),
            plan.indentation.ramp_rate
        ),
    };
    println!(
        "dry run: nothing moves. {} points; {targets}; dwell {} s; force ceiling {} N; safe z {} mm",
        program.points.len(),
        plan.indentation.dwell,
        plan.safety.force_ceiling,
        plan.approach.safe_z
    );
    if let Some(slide) = &plan.slide {
        println!(
            "slides: each force target pressed once per direction and speed, slid {} mm at {} mm/s with z holding the force, then held {} s; tangential ceiling {} N",
            slide.distance,
            join(slide.speeds.iter().copied()),
            slide.dwell,
            plan.safety.tangential().0
        );
    }
    println!(
        "{:>5}  {:>9}  {:>9}  {:<10} {:>4}  notes",
        "point", "x mm", "y mm", "indenter", "rep"
    );
    for p in &program.points {
        let mut notes = Vec::new();
        if p.change_indenter {
            notes.push(format!("prompt: mount the {} indenter", p.shape));
        }
        if p.new_row && limits.manual_y {
            notes.push(format!("prompt: move y to {:.3} mm", p.y.0));
        }
        if let Some(s) = &p.slide {
            notes.push(format!(
                "{} N, slide {} mm at {} degrees at {} mm/s",
                s.force.0, s.distance.0, s.direction_deg, s.speed.0
            ));
        }
        println!(
            "{:>5}  {:>9.3}  {:>9.3}  {:<10} {:>4}  {}",
            p.index + 1,
            p.x.0,
            p.y.0,
            p.shape,
            p.repetition + 1,
            notes.join("; ")
        );
    }
    let e = program.estimate(limits);
    println!(
        "path: {:.1} mm of lateral moves; {} indenter change(s); {} manual y row(s); estimated duration {}, of which homing and the move to the first point {} (operator prompts not counted)",
        e.lateral_path_mm,
        e.indenter_changes,
        e.manual_rows,
        clock(e.total),
        clock(e.homing)
    );
}

/// What a run of `program` will take on disk and what the disk holding `out` has free, from the
/// rig file and the profile directory only (the devices stay closed); says so when the scan
/// would be refused.
fn print_room(config: &RigConfig, program: &ScanProgram, limits: &BenchLimits, out: &Path) {
    let forecast = match RoomForecast::new(config, program, limits, out) {
        Ok(f) => f,
        Err(e) => {
            println!("expected on disk: cannot be estimated: {e}");
            return;
        }
    };
    let measured = forecast
        .measured_on
        .as_ref()
        .map(|run| format!(" (a frame's bytes as stored by {})", run.display()))
        .unwrap_or_default();
    println!(
        "expected on disk: {}{measured}",
        forecast.recording.describe(&forecast.size)
    );
    match &forecast.free {
        Ok(free) => {
            println!(
                "free on the filesystem holding {}: {}",
                out.display(),
                human(*free)
            );
            if let Some((need, disc)) = forecast.refusal() {
                eprintln!(
                    "warning: the scan would be refused: with a margin it needs {} free; free space there, write the run elsewhere (--out DIR), or run a smaller plan{disc}",
                    human(need)
                );
            }
        }
        Err(e) => eprintln!("warning: {e}"),
    }
}

fn join(v: impl Iterator<Item = f64>) -> String {
    v.map(|x| format!("{x}")).collect::<Vec<_>>().join(", ")
}

/// The operator at the terminal (on the simulated bench the session mounts indenters itself).
struct TerminalOperator {
    yes: bool,
    /// Watched while a prompt waits: Ctrl-C (an abort) answers the prompt.
    control: ScanControl,
    /// Lines typed on standard input (`None` at its end), read by a thread of their own so
    /// that a waiting prompt still sees Ctrl-C.
    answers: Option<crossbeam_channel::Receiver<Option<String>>>,
}

impl TerminalOperator {
    fn answers(&mut self) -> &crossbeam_channel::Receiver<Option<String>> {
        self.answers.get_or_insert_with(|| {
            let (tx, rx) = crossbeam_channel::unbounded();
            let _ = std::thread::Builder::new()
                .name("stdin".into())
                .spawn(move || {
                    let stdin = std::io::stdin();
                    loop {
                        let mut line = String::new();
                        let read = stdin.lock().read_line(&mut line);
                        let end = matches!(read, Ok(0) | Err(_));
                        if tx.send((!end).then_some(line)).is_err() || end {
                            break;
                        }
                    }
                });
            rx
        })
    }

    /// Waits for a line on standard input; `None` at its end or when Ctrl-C aborts the scan.
    fn read_answer(&mut self) -> Option<String> {
        let control = self.control.clone();
        let answers = self.answers().clone();
        interrupt::prompt_open(true);
        let answer = loop {
            if control.request() == Request::Abort {
                break None;
            }
            match answers.recv_timeout(Duration::from_millis(50)) {
                Ok(line) => break line,
                Err(crossbeam_channel::RecvTimeoutError::Timeout) => {}
                Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break None,
            }
        };
        interrupt::prompt_open(false);
        answer
    }
}

impl Operator for TerminalOperator {
    fn ask(&mut self, prompt: &Prompt) -> Reply {
        if self.yes {
            println!("{} (--yes: continuing)", prompt.message());
            return Reply::Continue;
        }
        let choices = match prompt {
            Prompt::Resume { .. } => "[r]esume or [a]bort",
            _ => "Enter to continue, [a]bort",
        };
        eprint!("\n>>> {} — {choices}: ", prompt.message());
        let _ = std::io::stderr().flush();
        match self.read_answer() {
            None if self.control.request() == Request::Abort => Reply::Abort,
            None => {
                eprintln!("(no answer on standard input: aborting)");
                Reply::Abort
            }
            Some(line) if line.trim().eq_ignore_ascii_case("a") => Reply::Abort,
            Some(_) => Reply::Continue,
        }
    }
}

/// The progress display: a bar redrawn in place on a terminal, a line every few seconds
/// otherwise.
struct Bar {
    total: u64,
    tty: bool,
    phase: String,
    last_line: Instant,
    drawn: bool,
    /// The newest status line not yet printed as a line of its own (a pipe prints one every
    /// few seconds).
    unprinted: Option<String>,
}

impl Bar {
    fn new(total: u64) -> Bar {
        Bar {
            total,
            tty: std::io::stderr().is_terminal(),
            phase: String::new(),
            last_line: Instant::now(),
            drawn: false,
            unprinted: None,
        }
    }

    fn clear(&mut self) {
        if self.drawn {
            eprint!("\r\x1b[2K");
            self.drawn = false;
        }
    }

    fn show(&mut self, p: ScanProgress) {
        match p {
            ScanProgress::Message(m) => {
                self.clear();
                println!("{m}");
            }
            ScanProgress::Phase { point, phase } => {
                self.phase = format!("point {}/{}: {}", point + 1, self.total, phase.name());
            }
            ScanProgress::Paused { reason } => {
                // The status as it was when the scan paused stays shown above the reason (the
                // engine sends it with the same counts the reason gives).
                if self.drawn {
                    eprintln!();
                    self.drawn = false;
                } else if let Some(line) = self.unprinted.take() {
                    eprintln!("{line}");
                }
                println!("paused: {reason}");
            }
            ScanProgress::Resumed => {
                self.clear();
                println!("resumed");
            }
            ScanProgress::Status(s) => self.status(&s),
        }
    }

    fn status(&mut self, s: &Status) {
        let width = 24usize;
        let filled = (s.points_done as usize * width) / s.points_total.max(1) as usize;
        let line = format!(
            "[{}{}] {}/{} points  ETA {}  F {:5.2} N  {:4.1} fps  {} frames  {} dropped  {}",
            "#".repeat(filled),
            "-".repeat(width - filled),
            s.points_done,
            s.points_total,
            clock(s.eta),
            s.force_n,
            s.frame_rate_hz,
            s.frames_recorded,
            s.dropped_frames,
            self.phase
        );
        if self.tty {
            eprint!("\r\x1b[2K{line}");
            let _ = std::io::stderr().flush();
            self.drawn = true;
        } else if self.last_line.elapsed() >= Duration::from_secs(5) {
            eprintln!("{line}");
            self.last_line = Instant::now();
            self.unprinted = None;
        } else {
            self.unprinted = Some(line);
        }
    }

    fn finish(&mut self) {
        if self.drawn {
            eprintln!();
            self.drawn = false;
        }
    }
}

/// Ctrl-C: once asks for a pause after the current indentation, twice stops now, three times
/// aborts.
mod interrupt {
    use super::*;

    use crate::signals::{self, Again, Signal};

    /// An operator prompt is waiting for an answer.
    static AT_PROMPT: AtomicBool = AtomicBool::new(false);

    pub fn prompt_open(open: bool) {
        AT_PROMPT.store(open, Ordering::SeqCst);
    }

    pub fn install(control: ScanControl) {
        signals::catch(&[Signal::Interrupt], Again::Counts);
        let _ = std::thread::Builder::new()
            .name("ctrl-c".into())
            .spawn(move || {
                let mut seen = 0;
                loop {
                    let n = signals::received();
                    while seen < n {
                        seen += 1;
                        if AT_PROMPT.load(Ordering::SeqCst) {
                            // Motion has already stopped at a prompt: Ctrl-C answers it.
                            control.abort();
                            eprintln!("\nCtrl-C at the prompt: aborting (motion is stopped; the run is closed as aborted with the points done kept)");
                            continue;
                        }
                        match control.request() {
                            Request::Run => {
                                control.pause();
                                eprintln!("\nCtrl-C: pausing after the current indentation (again: stop now)");
                            }
                            Request::PauseAfterIndentation => {
                                control.pause_now();
                                eprintln!("\nCtrl-C: stopping now (again: abort)");
                            }
                            _ => {
                                control.abort();
                                eprintln!("\nCtrl-C: aborting (z retracts, the run is closed)");
                            }
                        }
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
            });
    }
}
