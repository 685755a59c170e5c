//! The Commission screen: the rig's sensor taken from first light to its verdict, as `fringe
//! commission` does (calibration, rounds of presses where the model errs most, adaptation,
//! acceptance, certificate). The learning curve fills in round by round, each round scored on
//! presses the model had not seen, and the error map shows every press coloured by its error
//! against the spec. `s` stops at the scan (closed resumable), `c` goes on with the newest
//! unfinished commissioning.

use crate::ui::app::App;
use crate::ui::binding::{self, char, Binding, HelpRow, Scope};
use crate::ui::commission::{self as work, FromWorker, Worker};
use crate::ui::scan_events::ScanEnd;
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::session::ModelChoice;
use crate::ui::state::{CommissionPhase, CommissionView, Phase, ScanView, Tab};
use crate::ui::widgets::disc::{self, Glyph, Layer};
use crate::ui::widgets::{panel, ACCENT, BAD, GOOD, WARN};
use fringe_app::commission::unfinished;
use fringe_app::commission::ScanEnded;
use fringe_app::commission::{NewCommissioning, Request};
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;
use std::path::PathBuf;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("commission");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Commission",
    help,
    draw: |f, area, s| draw(f, area, &s.commission, &s.scan),
    hint: |s| key_hint(&s.commission),
    open: |_| Box::<Commissioner>::default(),
};

#[derive(Debug, Clone, Copy)]
enum Action {
    Start,
    Continue,
    Stop,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[char('r')],
        scope: Scope::Shown,
        action: Action::Start,
        label: "r",
        help: "commission the sensor: calibrate, press, adapt, accept",
    },
    Binding {
        keys: &[char('c')],
        scope: Scope::Shown,
        action: Action::Continue,
        label: "c",
        help: "go on with the newest unfinished commissioning",
    },
    Binding {
        keys: &[char('s')],
        scope: Scope::Shown,
        action: Action::Stop,
        label: "s",
        help: "stop commissioning; its scan closes resumable",
    },
];

fn help() -> Vec<HelpRow> {
    binding::help_rows(KEYS, Some(SCREEN.title))
}

/// The commissioning behind the screen.
#[derive(Default)]
struct Commissioner {
    worker: Option<Worker>,
    /// The running scan is the commissioning's (its end is sent to the thread): its run.
    scanning: Option<PathBuf>,
    /// Stop asked while the thread computes: its next scan is refused.
    stop: bool,
}

impl Commissioner {
    fn start(&mut self, app: &mut App, request: Request) {
        if self.worker.is_some() {
            app.state.error = Some("a commissioning is under way (s stops it)".into());
            return;
        }
        if app.scan_active() {
            app.state.error = Some("a scan is running: commission when it ends".into());
            return;
        }
        if let Some(why) = app.scan_refused() {
            app.state.error = Some(why);
            return;
        }
        let ready = work::ready_view(&app.opts.config);
        app.state.commission = CommissionView {
            phase: CommissionPhase::Running("starting".into()),
            ..ready
        };
        self.stop = false;
        self.worker = Some(work::start(request, app.opts.config.clone()));
    }

    fn resume(&mut self, app: &mut App) {
        let v = &app.state.commission;
        let Some(dir) = unfinished(&app.opts.config.profile_dir(), &v.sensor) else {
            app.state.error = Some(format!(
                "no unfinished commissioning of {} under {}: r starts one",
                v.sensor,
                app.opts.config.profile_dir().display()
            ));
            return;
        };
        self.start(
            app,
            Request::Resume {
                dir,
                budget_min: None,
                fine_tune: false,
            },
        );
    }

    fn stop(&mut self, app: &mut App) {
        if self.worker.is_none() {
            app.state.error = Some("no commissioning is under way".into());
            return;
        }
        self.stop = true;
        if let Some(w) = &self.worker {
            w.stop.store(true, std::sync::atomic::Ordering::SeqCst);
        }
        if self.scanning.is_some() {
            app.interrupt();
        }
        app.state.commission.phase = CommissionPhase::Stopping;
    }

    /// Acts on what the thread sent.
    fn apply(&mut self, app: &mut App, event: FromWorker) {
        let v = &mut app.state.commission;
        match event {
            FromWorker::Started { dir, thresholds } => {
                v.dir = Some(dir.display().to_string());
                v.thresholds = thresholds;
            }
            FromWorker::Scan(order) => {
                let Some(worker) = &self.worker else { return };
                let refused = if self.stop {
                    Some("stopped by the operator before its next scan".to_string())
                } else if app.scan_active() {
                    Some("another scan is running".to_string())
                } else {
                    app.scan_refused()
                };
                if let Some(why) = refused {
                    let _ = worker.ends.send(Err(why));
                    return;
                }
                let run_dir = order.run_dir();
                app.state
                    .commission
                    .log(format!("scan {}", run_dir.display()));
                let order = *order;
                app.start_program_into(
                    order.program,
                    order.plan_text,
                    None,
                    order.profile,
                    Some(order.target),
                );
                self.scanning = Some(run_dir);
            }
            FromWorker::Line(line) => {
                if !self.stop && (line.starts_with("step ") || line.starts_with("round ")) {
                    v.phase = CommissionPhase::Running(line.clone());
                }
                v.log(line);
            }
            FromWorker::Progress(line) => v.progress = line,
            FromWorker::Learnt {
                curve,
                pressed,
                disc,
            } => {
                v.curve = curve;
                v.pressed = pressed;
                v.disc = Some(disc);
            }
            FromWorker::Finished(outcome) => {
                v.progress = None;
                let passed = match &outcome {
                    Ok(a) if a.pass => Some(a.model.clone()),
                    _ => None,
                };
                v.phase = match outcome {
                    Ok(a) if a.pass => CommissionPhase::Verdict {
                        pass: true,
                        summary: format!(
                            "sensor {} passes {}: validate and eval use {} for it; certificate {}",
                            a.sensor,
                            a.spec_origin,
                            a.model.display(),
                            a.certificate.display()
                        ),
                    },
                    Ok(a) => CommissionPhase::Verdict {
                        pass: false,
                        summary: format!(
                            "sensor {} fails {}: {}; the certificate says where ({})",
                            a.sensor,
                            a.spec_origin,
                            a.failures.join("; "),
                            a.certificate.display()
                        ),
                    },
                    Err(why) => CommissionPhase::Stopped(why),
                };
                v.resumable = unfinished(&app.opts.config.profile_dir(), &v.sensor)
                    .map(|d| d.display().to_string());
                take_commissioned_model(app, passed);
                self.worker = None;
                self.stop = false;
            }
        }
    }
}

impl Screen for Commissioner {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        match binding::find(KEYS, code, mods, shown) {
            Some(Action::Start) => {
                self.start(app, Request::New(NewCommissioning::default()));
            }
            // While it runs, `c` is the Scan screen's: continue its paused scan.
            Some(Action::Continue) if self.worker.is_some() => return false,
            Some(Action::Continue) => self.resume(app),
            Some(Action::Stop) => self.stop(app),
            None => return false,
        }
        true
    }

    fn tick(&mut self, app: &mut App, _shown: bool) -> bool {
        let mut events = Vec::new();
        if let Some(w) = &self.worker {
            events.extend(w.events.try_iter());
        }
        let changed = !events.is_empty();
        for e in events {
            self.apply(app, e);
        }
        changed
    }

    /// The commissioning's scan ended: its end goes to the thread.
    fn scan_ended(&mut self, _app: &mut App, end: &ScanEnd) {
        let Some(run_dir) = self.scanning.take() else {
            return;
        };
        let Some(worker) = &self.worker else { return };
        let reply = match end {
            ScanEnd::Ended {
                completed,
                summary,
                run_dir,
            } => Ok(ScanEnded {
                completed: *completed,
                reason: summary.clone(),
                run_dir: run_dir.clone(),
            }),
            ScanEnd::Failed(why) => Err(format!("the scan {} failed: {why}", run_dir.display())),
        };
        let _ = worker.ends.send(reply);
    }
}

/// A passing commissioning's model becomes the session's (the Validate and Runs screens'),
/// unless the user named a model; nothing changes for `None` (no pass).
fn take_commissioned_model(app: &mut App, model: Option<PathBuf>) {
    let (Some(model), true) = (model, app.opts.model_from_rig) else {
        return;
    };
    let mut choice = app
        .opts
        .model
        .clone()
        .unwrap_or_else(|| ModelChoice::for_rig(&app.opts.config));
    choice.path = model;
    let shown = choice.path.display().to_string();
    app.state.model = Some(shown.clone());
    app.state.runs.model = shown.clone();
    app.state
        .commission
        .log(format!("the Validate and Runs screens now use {shown}"));
    app.opts.model = Some(choice);
}

/// The keys that act now.
fn key_hint(v: &CommissionView) -> &'static str {
    match (&v.phase, v.resumable.is_some()) {
        (CommissionPhase::Running(_), _) => "s stop (resumable)",
        (CommissionPhase::Stopping, _) => "",
        (_, true) => "r commission the sensor · c go on with the unfinished one",
        (_, false) if v.existing.as_ref().is_some_and(|e| e.0) => {
            "r commission it again (it has a passing certificate)"
        }
        (_, false) => "r commission the sensor",
    }
}

/// Green within the threshold, red over it (plain without one).
fn against(value: f64, limit: Option<f64>, within: fn(f64, f64) -> bool) -> Style {
    match limit {
        Some(l) if within(value, l) => Style::new().fg(GOOD),
        Some(_) => Style::new().fg(BAD),
        None => Style::new(),
    }
}

/// A press's error against the spec (1 = at the threshold) as a colour.
fn error_colour(e: f64) -> Color {
    if e <= 1.0 {
        GOOD
    } else if e <= 2.0 {
        WARN
    } else {
        BAD
    }
}

fn draw(f: &mut Frame, area: Rect, v: &CommissionView, scan: &ScanView) {
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(58), Constraint::Percentage(42)]).areas(area);
    let (phase, colour) = match &v.phase {
        CommissionPhase::Ready => ("ready: r commissions the sensor".to_string(), ACCENT),
        CommissionPhase::Running(step) => {
            let scanning = match &scan.phase {
                Phase::Running => format!(
                    " · point {} of {}",
                    scan.done.min(scan.total) + 1,
                    scan.total
                ),
                Phase::Paused(why) => format!(" · paused: {why}"),
                _ => String::new(),
            };
            (format!("{step}{scanning}"), GOOD)
        }
        CommissionPhase::Stopping => (
            "stopping: the scan is closed resumable, or the next one is not started".to_string(),
            WARN,
        ),
        CommissionPhase::Verdict {
            pass: true,
            summary,
        } => (format!("PASS: {summary}"), GOOD),
        CommissionPhase::Verdict {
            pass: false,
            summary,
        } => (format!("FAIL: {summary}"), BAD),
        CommissionPhase::Stopped(why) => (format!("stopped: {why}"), BAD),
    };
    let mut lines = vec![
        Line::from(Span::styled(phase, Style::new().fg(colour))),
        Line::from(format!(
            "sensor {} · {}",
            v.sensor,
            match (&v.dir, &v.existing) {
                (Some(d), _) => format!("directory {d}"),
                (None, Some(_)) => "commissioned before (below); r commissions it again".to_string(),
                (None, None) => "no commissioning started here yet".to_string(),
            }
        )),
    ];
    if let (Some((pass, said)), CommissionPhase::Ready) = (&v.existing, &v.phase) {
        lines.push(Line::from(Span::styled(
            said.clone(),
            Style::new().fg(if *pass { GOOD } else { BAD }),
        )));
    }
    if matches!(v.phase, CommissionPhase::Ready) {
        lines.push(Line::from(v.plan.clone()));
    }
    if let (Some(d), false) = (&v.resumable, matches!(v.phase, CommissionPhase::Running(_))) {
        lines.push(Line::from(format!("unfinished: {d} (c goes on with it)")));
    }
    lines.push(Line::from(""));
    lines.push(Line::from(Span::styled(
        "learning curve: each round on presses the model had not yet adapted on",
        Style::new().fg(ACCENT),
    )));
    lines.push(Line::from(format!(
        "  {:>5} {:>10} {:>7} {:>10} {:>12} {:>8}",
        "round", "adapted on", "frames", "Fz RMSE N", "contact mm", "shape %"
    )));
    let (fz, contact, shape) = v.thresholds;
    for p in &v.curve {
        lines.push(Line::from(vec![
            Span::raw(format!(
                "  {:>5} {:>10} {:>7} ",
                p.round, p.presses_before, p.frames
            )),
            Span::styled(
                format!("{:>10.3}", p.fz_rmse_n),
                against(p.fz_rmse_n, fz, |a, b| a <= b),
            ),
            Span::raw(" "),
            Span::styled(
                format!("{:>12.2}", p.contact_rmse_mm),
                against(p.contact_rmse_mm, contact, |a, b| a <= b),
            ),
            Span::raw(" "),
            Span::styled(
                format!("{:>8.1}", 100.0 * p.shape_accuracy),
                against(p.shape_accuracy, shape, |a, b| a >= b),
            ),
        ]));
    }
    let limit = |x: Option<f64>, scale: f64, digits: usize| {
        x.map_or_else(|| "-".to_string(), |l| format!("{:.*}", digits, scale * l))
    };
    lines.push(Line::from(format!(
        "  {:>5} {:>10} {:>7} {:>10} {:>12} {:>8}",
        "spec",
        "",
        "",
        format!("< {}", limit(fz, 1.0, 2)),
        format!("< {}", limit(contact, 1.0, 2)),
        format!("> {}", limit(shape, 100.0, 1)),
    )));
    lines.push(Line::from(""));
    if let Some(p) = &v.progress {
        lines.push(Line::from(Span::styled(p.clone(), Style::new().fg(ACCENT))));
    }
    // The newest lines that fit under what is above (inside the panel's border).
    let room = (left.height as usize).saturating_sub(lines.len() + 2);
    let skip = v.log.len().saturating_sub(room);
    lines.extend(v.log.iter().skip(skip).map(|l| Line::from(l.clone())));
    f.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(panel("commissioning")),
        left,
    );
    draw_map(f, right, v);
}

/// Every press on the usable disc, coloured by its error against the spec.
fn draw_map(f: &mut Frame, area: Rect, v: &CommissionView) {
    let block = panel("presses by error: green in spec, yellow to 2x, red over");
    let Some(d) = &v.disc else {
        f.render_widget(
            Paragraph::new("no presses yet: the map fills in after each round").block(block),
            area,
        );
        return;
    };
    let mut by_colour: [(Color, Vec<(f64, f64)>); 3] =
        [(GOOD, Vec::new()), (WARN, Vec::new()), (BAD, Vec::new())];
    for p in &v.pressed {
        let c = error_colour(p.error);
        if let Some((_, pts)) = by_colour.iter_mut().find(|(k, _)| *k == c) {
            pts.push((p.stage_mm[0], p.stage_mm[1]));
        }
    }
    let layers = by_colour
        .iter()
        .map(|(c, pts)| Layer {
            coords: pts,
            color: *c,
            path: false,
            glyph: Glyph::Symbol("●"),
        })
        .collect();
    let inner = block.inner(area);
    f.render_widget(
        disc::canvas(
            block,
            (d.centre_mm[0], d.centre_mm[1]),
            d.reach_mm,
            true,
            layers,
            disc::aspect(inner),
        ),
        area,
    );
}
