//! Options of the command line shared by every command that opens devices.

use std::path::PathBuf;

/// Options shared by every command that opens devices.
pub struct Global {
    /// Record everything that crosses each device link to DIR/<device>.trace.
    pub record_trace: Option<PathBuf>,
}
