//! What a screen is: its entry in the list ([`ScreenDef`]: name, help, drawing, footer hint)
//! and what runs behind it while the UI runs ([`Screen`]: its keys, its threads, what it does
//! when a scan ends). Each screen is one file under `screens/` (its `TAB` and its `SCREEN`) and
//! one name in the list of `screens.rs`.

use super::app::App;
use super::binding::HelpRow;
use super::scan_events::ScanEnd;
use super::state::{Tab, UiState};
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::Rect;
use ratatui::Frame;

/// A screen as the list names it.
pub struct ScreenDef {
    /// The screen's own `TAB`.
    pub tab: Tab,
    /// Its name on the tab bar and in the help.
    pub title: &'static str,
    /// Its keys as help lines: the table its [`Screen::key`] reads.
    pub help: fn() -> Vec<HelpRow>,
    /// Draws it from the state (pure; snapshot-tested).
    pub draw: fn(&mut Frame, Rect, &UiState),
    /// The keys that act now, for the footer.
    pub hint: fn(&UiState) -> &'static str,
    /// What runs behind it, made once when the UI starts.
    pub open: fn(&App) -> Box<dyn Screen>,
}

/// A screen while the UI runs.
pub trait Screen {
    /// Acts on the key if the screen's table binds it (when it is not `shown`, only its keys
    /// that act everywhere); false when it does not.
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool;

    /// Once a frame: takes what its threads published; true when anything changed.
    fn tick(&mut self, _app: &mut App, _shown: bool) -> bool {
        false
    }

    /// A scan ended (the screen may have started it).
    fn scan_ended(&mut self, _app: &mut App, _end: &ScanEnd) {}
}

/// A screen without keys of its own and nothing running behind it.
pub struct Plain;

impl Screen for Plain {
    fn key(&mut self, _: &mut App, _: KeyCode, _: KeyModifiers, _: bool) -> bool {
        false
    }
}
