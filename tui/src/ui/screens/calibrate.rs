//! The Calibrate screen: the calibration plan and where the profile goes, the scan's progress,
//! then the fit: the averaged no-contact frame with the fitted disc (green), crop circle (yellow)
//! and centre (red), the optical figures, the registration and its residual per press, the force
//! offsets; `w` writes the profile.

use crate::ui::app::App;
use crate::ui::binding::{self, char, Binding, HelpRow, Scope};
use crate::ui::calibration;
use crate::ui::picture::Picture;
use crate::ui::scan_events::ScanEnd;
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::state::{CalibrateView, CalibrationPhase, Phase, ScanView, Tab};
use crate::ui::widgets::{panel, ACCENT, BAD, GOOD, WARN};
use crate::ui::workers::{self, Calibrated};
use crossbeam_channel::{unbounded, Receiver, Sender};
use fringe_app::session::CalibrationResult;
use fringe_app::ProfileUse;
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

/// A residual over this many px is shown as a warning.
const RESIDUAL_WARN_PX: f64 = 3.0;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("calibrate");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Calibrate",
    help,
    draw: |f, area, s| draw(f, area, &s.calibrate, &s.scan),
    hint: |s| key_hint(&s.calibrate),
    open: |_| Box::<Calibration>::default(),
};

#[derive(Debug, Clone, Copy)]
enum Action {
    Run,
    Write,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[char('r')],
        scope: Scope::Shown,
        action: Action::Run,
        label: "r",
        help: "run the calibration scan, then fit the profile",
    },
    Binding {
        keys: &[char('w')],
        scope: Scope::Shown,
        action: Action::Write,
        label: "w",
        help: "write the fitted profile (profiles/<sensor>.toml)",
    },
];

fn help() -> Vec<HelpRow> {
    binding::help_rows(KEYS, Some(SCREEN.title))
}

/// The calibration behind the screen: its scan, the fit and the writing of the profile.
struct Calibration {
    /// The running scan is the calibration scan (its end starts the fit).
    scanning: bool,
    /// The fitted calibration awaiting `w`.
    fitted: Option<Box<CalibrationResult>>,
    threads: (Sender<Calibrated>, Receiver<Calibrated>),
}

impl Default for Calibration {
    fn default() -> Calibration {
        Calibration {
            scanning: false,
            fitted: None,
            threads: unbounded(),
        }
    }
}

impl Calibration {
    /// Runs the built-in calibration grid; its end fits the profile ([`Screen::scan_ended`]).
    fn run(&mut self, app: &mut App) {
        if let Some(why) = app.scan_refused() {
            app.state.error = Some(why);
            return;
        }
        match calibration::plan(&app.opts.config) {
            Ok((program, text, _sensor, _)) => {
                self.fitted = None;
                let ready = calibration::ready_view(&app.opts.config);
                app.state.calibrate = CalibrateView {
                    phase: CalibrationPhase::Scanning,
                    ..ready
                };
                self.scanning = true;
                app.start_program(program, text, None, ProfileUse::Ignore);
            }
            Err(e) => {
                app.state.calibrate.phase = CalibrationPhase::Failed(format!("{e:#}"));
            }
        }
    }

    /// Writes the fitted profile (and its report images) into the rig's profile folder.
    fn write(&mut self, app: &mut App) {
        let Some(result) = self.fitted.take() else {
            app.state.error =
                Some("no fitted calibration to write: run the calibration scan first (r)".into());
            return;
        };
        app.state.calibrate.phase = CalibrationPhase::Writing;
        workers::write_profile(
            result,
            app.opts.config.profile_dir(),
            self.threads.0.clone(),
        );
    }
}

impl Screen for Calibration {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        match binding::find(KEYS, code, mods, shown) {
            Some(Action::Run) => self.run(app),
            Some(Action::Write) => self.write(app),
            None => return false,
        }
        true
    }

    fn tick(&mut self, app: &mut App, _shown: bool) -> bool {
        let mut changed = false;
        while let Ok(c) = self.threads.1.try_recv() {
            match c {
                Calibrated::Fitted(result, view) => {
                    app.state.calibrate = *view;
                    self.fitted = Some(result);
                }
                Calibrated::Written(files) => {
                    app.state.calibrate.phase = CalibrationPhase::Written(files);
                }
                Calibrated::Failed(why) => {
                    app.state.calibrate.phase = CalibrationPhase::Failed(why.clone());
                    app.state.error = Some(why);
                }
            }
            changed = true;
        }
        changed
    }

    /// After the calibration scan: fits the profile from its run on a thread.
    fn scan_ended(&mut self, app: &mut App, end: &ScanEnd) {
        if !std::mem::take(&mut self.scanning) {
            return;
        }
        let phase = &mut app.state.calibrate.phase;
        match end {
            ScanEnd::Failed(why) => {
                *phase = CalibrationPhase::Failed(format!("the calibration scan failed: {why}"));
            }
            ScanEnd::Ended {
                completed: false,
                summary,
                ..
            } => {
                *phase = CalibrationPhase::Failed(format!(
                    "the calibration scan did not complete ({summary}); no profile"
                ));
            }
            ScanEnd::Ended { run_dir, .. } => {
                *phase = CalibrationPhase::Fitting;
                workers::fit_calibration(
                    app.opts.config.clone(),
                    app.state.calibrate.clone(),
                    run_dir.clone(),
                    self.threads.0.clone(),
                );
            }
        }
    }
}

/// The keys that act on the calibration now.
fn key_hint(v: &CalibrateView) -> &'static str {
    match v.phase {
        CalibrationPhase::Fitted => "w write the profile · r run the calibration scan again",
        CalibrationPhase::Scanning => "a abort the scan",
        CalibrationPhase::Fitting | CalibrationPhase::Writing => "",
        _ => "r run the calibration scan",
    }
}

fn draw(f: &mut Frame, area: Rect, v: &CalibrateView, scan: &ScanView) {
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(55), Constraint::Percentage(45)]).areas(area);
    let (phase, colour) = match &v.phase {
        CalibrationPhase::Ready => (
            "ready: press r to run the calibration scan".to_string(),
            ACCENT,
        ),
        CalibrationPhase::Scanning => {
            let state = match &scan.phase {
                Phase::Paused(why) => format!("paused: {why}"),
                _ => format!("press {} of {}", scan.done.min(scan.total) + 1, scan.total),
            };
            (format!("calibration scan: {state}"), GOOD)
        }
        CalibrationPhase::Fitting => ("fitting the profile from the run...".to_string(), ACCENT),
        CalibrationPhase::Fitted => (
            "fitted: press w to write the profile (r runs the scan again)".to_string(),
            WARN,
        ),
        CalibrationPhase::Writing => ("writing the profile...".to_string(), ACCENT),
        CalibrationPhase::Written(files) => (format!("written: {files}"), GOOD),
        CalibrationPhase::Failed(why) => (format!("failed: {why}"), BAD),
    };
    let mut lines = vec![
        Line::from(Span::styled(phase, Style::new().fg(colour))),
        Line::from(format!("sensor {} · profile {}", v.sensor, v.profile)),
        Line::from(v.plan.clone()),
        Line::from(""),
    ];
    let heading = |t: &str| Line::from(Span::styled(t.to_string(), Style::new().fg(ACCENT)));
    if !v.fit.is_empty() {
        lines.push(heading("optical fit"));
        lines.extend(v.fit.iter().map(|l| Line::from(format!("  {l}"))));
        lines.push(heading("registration (image <-> stage)"));
        lines.push(Line::from(format!("  {}", v.registration)));
        for (i, p) in v.presses.iter().enumerate() {
            let (text, style) = match &p.outcome {
                Ok((px, true)) => (
                    format!("{px:.2} px, left out as an outlier"),
                    Style::new().fg(WARN),
                ),
                Ok((px, false)) if *px > RESIDUAL_WARN_PX => {
                    (format!("{px:.2} px"), Style::new().fg(WARN))
                }
                Ok((px, false)) => (format!("{px:.2} px"), Style::new().fg(GOOD)),
                Err(e) => (format!("not located: {e}"), Style::new().fg(BAD)),
            };
            lines.push(Line::from(vec![
                Span::raw(format!(
                    "  press {:>2} at ({:>8.3}, {:>8.3}) mm: ",
                    i + 1,
                    p.stage_mm.0,
                    p.stage_mm.1
                )),
                Span::styled(text, style),
            ]));
        }
        lines.push(heading("force offsets"));
        lines.extend(v.offsets.iter().map(|l| Line::from(format!("  {l}"))));
    }
    f.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(panel("calibration")),
        left,
    );
    let block = panel("averaged frame: disc green, crop yellow, centre red");
    let inner = block.inner(right);
    f.render_widget(block, right);
    match &v.picture {
        Some(p) => f.render_widget(Picture(p), inner),
        None => f.render_widget(Paragraph::new("no fit yet"), inner),
    }
}
