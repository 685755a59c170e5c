//! Options of the command line shared by every command that opens devices (and `--no-tui`,
//! which any command takes).

use std::path::PathBuf;

/// Options shared by every command that opens devices.
pub struct Global {
    /// Record everything that crosses each device link to DIR/<device>.trace.
    pub record_trace: Option<PathBuf>,
    /// `--no-tui`: plain output instead of the terminal UI (given before or after the command).
    pub no_tui: bool,
}
