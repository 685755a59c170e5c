//! The keys of the whole UI: Ctrl-C first, then the overlay that is open (help, plan chooser,
//! dialog), then the shown screen's table, then every screen's keys that act everywhere, then
//! the keys for moving between screens, the help and quitting. The `?` help is made from the
//! same tables ([`help_rows`]).

use super::app::App;
use super::binding::{self, char, code, ctrl, Binding, HelpRow, Scope};
use super::screen::Screen;
use super::screens;
use fringe_rig::Reply;
use ratatui::crossterm::event::{KeyCode, KeyModifiers};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Action {
    /// The screen with this number (1 the first).
    Numbered,
    Next,
    Previous,
    Help,
    Quit,
    AbortAndQuit,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[
            char('1'),
            char('2'),
            char('3'),
            char('4'),
            char('5'),
            char('6'),
            char('7'),
            char('8'),
            char('9'),
        ],
        scope: Scope::Everywhere,
        action: Action::Numbered,
        // Listed by `help_rows` with the screens' names.
        label: "",
        help: "",
    },
    Binding {
        keys: &[code(KeyCode::Tab)],
        scope: Scope::Everywhere,
        action: Action::Next,
        label: "",
        help: "",
    },
    Binding {
        keys: &[code(KeyCode::BackTab)],
        scope: Scope::Everywhere,
        action: Action::Previous,
        label: "",
        help: "",
    },
    Binding {
        keys: &[char('?')],
        scope: Scope::Everywhere,
        action: Action::Help,
        label: "?",
        help: "show or hide these keys",
    },
    Binding {
        keys: &[char('q'), code(KeyCode::Esc)],
        scope: Scope::Everywhere,
        action: Action::Quit,
        label: "q / Esc",
        help: "quit (asks to abort a running scan first)",
    },
    Binding {
        keys: &[ctrl('c')],
        scope: Scope::Everywhere,
        action: Action::AbortAndQuit,
        label: "Ctrl-C",
        help: "abort a running scan and quit",
    },
];

/// The scan's question, shown over every screen.
const DIALOG: &[Binding<Reply>] = &[
    Binding {
        keys: &[code(KeyCode::Enter), char('y'), char('c'), char(' ')],
        scope: Scope::Everywhere,
        action: Reply::Continue,
        label: "Enter",
        help: "answer a dialog: continue",
    },
    // The dialog names its other answer.
    Binding {
        keys: &[char('a'), code(KeyCode::Esc)],
        scope: Scope::Everywhere,
        action: Reply::Abort,
        label: "",
        help: "",
    },
];

#[derive(Debug, Clone, Copy, PartialEq)]
enum Pick {
    Up,
    Down,
    Close,
    Choose,
}

/// The plan chooser (its title names its keys).
const PICKER: &[Binding<Pick>] = &[
    Binding {
        keys: &[code(KeyCode::Up)],
        scope: Scope::Everywhere,
        action: Pick::Up,
        label: "",
        help: "",
    },
    Binding {
        keys: &[code(KeyCode::Down)],
        scope: Scope::Everywhere,
        action: Pick::Down,
        label: "",
        help: "",
    },
    Binding {
        keys: &[code(KeyCode::Esc), char('q'), char('l')],
        scope: Scope::Everywhere,
        action: Pick::Close,
        label: "",
        help: "",
    },
    Binding {
        keys: &[code(KeyCode::Enter)],
        scope: Scope::Everywhere,
        action: Pick::Choose,
        label: "",
        help: "",
    },
];

/// Acts on a key. `screens` are the running screens, in the order of [`screens::ALL`].
pub fn dispatch(app: &mut App, screens: &mut [Box<dyn Screen>], code: KeyCode, mods: KeyModifiers) {
    app.state.error = None;
    let global = binding::find(KEYS, code, mods, true);
    if global == Some(Action::AbortAndQuit) {
        app.stop_scan(false);
        app.quit = true;
        return;
    }
    if app.state.help {
        app.state.help = false;
        return;
    }
    if app.state.picker.is_some() {
        choose(app, binding::find(PICKER, code, mods, true));
        return;
    }
    if app.state.dialog.is_some() {
        if let Some(reply) = binding::find(DIALOG, code, mods, true) {
            app.answer(reply);
        }
        return;
    }
    let shown = screens::index(app.state.tab);
    if let Some(s) = screens.get_mut(shown) {
        if s.key(app, code, mods, true) {
            return;
        }
    }
    for (i, s) in screens.iter_mut().enumerate() {
        if i != shown && s.key(app, code, mods, false) {
            return;
        }
    }
    let n = screens::ALL.len();
    match global {
        Some(Action::Numbered) => {
            let chosen = match code {
                KeyCode::Char(c) => c.to_digit(10).map_or(0, |d| d as usize),
                _ => 0,
            };
            if let Some(s) = chosen.checked_sub(1).and_then(|i| screens::ALL.get(i)) {
                app.state.tab = s.tab;
            }
        }
        Some(Action::Next) => app.state.tab = screens::ALL[(shown + 1) % n].tab,
        Some(Action::Previous) => app.state.tab = screens::ALL[(shown + n - 1) % n].tab,
        Some(Action::Help) => app.state.help = true,
        Some(Action::Quit) => {
            if app.scan_active() {
                app.state.error = Some(
                    "a scan is running: press a to abort it first (or Ctrl-C to abort and quit)"
                        .into(),
                );
            } else {
                app.quit = true;
            }
        }
        Some(Action::AbortAndQuit) | None => {}
    }
}

fn choose(app: &mut App, action: Option<Pick>) {
    let Some(picker) = &mut app.state.picker else {
        return;
    };
    match action {
        Some(Pick::Up) => picker.selected = picker.selected.saturating_sub(1),
        Some(Pick::Down) => {
            picker.selected = (picker.selected + 1).min(picker.items.len().saturating_sub(1))
        }
        Some(Pick::Close) => app.state.picker = None,
        Some(Pick::Choose) => {
            let i = picker.selected;
            app.state.picker = None;
            app.choose(i);
        }
        None => {}
    }
}

/// The `?` help: moving between screens, each screen's keys in tab order, the dialog's, then
/// the help, quitting and Ctrl-C.
pub fn help_rows() -> Vec<HelpRow> {
    let titles: Vec<&str> = screens::ALL.iter().map(|s| s.title).collect();
    let mut rows = vec![HelpRow {
        keys: format!("1-{} / Tab", titles.len()),
        what: titles.join(", "),
    }];
    for s in screens::ALL {
        rows.extend((s.help)());
    }
    rows.extend(binding::help_rows(DIALOG, None));
    rows.extend(binding::help_rows(KEYS, None));
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_help_lists_every_key_from_the_tables() {
        let rows: Vec<(String, String)> =
            help_rows().into_iter().map(|r| (r.keys, r.what)).collect();
        let expected = [
            (
                "1-9 / Tab",
                "Scan, Validate, Runs, Bench, Calibrate, Commission, Health, Units, Stream",
            ),
            ("l", "choose the scan plan (built in, ./plans/*.toml)"),
            ("r", "run the scan plan (with live validation on Validate)"),
            ("p", "pause after the current press"),
            ("P", "pause now (z retracts)"),
            ("c", "continue a paused scan"),
            ("a", "abort the scan (z retracts, the run is closed)"),
            ("Up / Down (Runs)", "choose a run"),
            ("Enter (Runs)", "verify the chosen run"),
            ("e (Runs)", "evaluate the chosen run with the model"),
            (
                "x (Runs)",
                "export the chosen run to exports/ (reference layout)",
            ),
            ("g", "refresh the runs"),
            ("x y z (Bench)", "choose the axis to jog"),
            (
                "← → (Bench)",
                "jog the axis by the step (within its soft limits)",
            ),
            ("s (Bench)", "next jog step: 0.01, 0.1, 1, 5 mm"),
            ("h (Bench)", "home the chosen axis"),
            ("Space (Bench)", "stop every axis at once"),
            (
                "t (Bench)",
                "tare the F/T (z homed first; refused in contact)",
            ),
            (
                "r (Calibrate)",
                "run the calibration scan, then fit the profile",
            ),
            (
                "w (Calibrate)",
                "write the fitted profile (profiles/<sensor>.toml)",
            ),
            (
                "r (Commission)",
                "commission the sensor: calibrate, press, adapt, accept",
            ),
            (
                "c (Commission)",
                "go on with the newest unfinished commissioning",
            ),
            (
                "s (Commission)",
                "stop commissioning; its scan closes resumable",
            ),
            (
                "Up / Down (Health)",
                "choose a check: its figures against their thresholds",
            ),
            (
                "Up / Down (Units)",
                "choose a unit: its certificate, checks and model",
            ),
            (
                "s (Stream)",
                "start or stop the stream (the camera and the model, over ROS 2)",
            ),
            (
                "m (Stream)",
                "start the stream, recording it to streams/*.mcap",
            ),
            ("Enter", "answer a dialog: continue"),
            ("?", "show or hide these keys"),
            ("q / Esc", "quit (asks to abort a running scan first)"),
            ("Ctrl-C", "abort a running scan and quit"),
        ]
        .map(|(k, w)| (k.to_string(), w.to_string()));
        assert_eq!(rows, expected);
    }

    #[test]
    fn ctrl_c_is_found_before_the_keys_without_ctrl() {
        assert_eq!(
            binding::find(KEYS, KeyCode::Char('c'), KeyModifiers::CONTROL, true),
            Some(Action::AbortAndQuit)
        );
        assert_eq!(
            binding::find(KEYS, KeyCode::Char('c'), KeyModifiers::NONE, true),
            None
        );
    }
}
