//! The terminal UI (ratatui on crossterm): Scan, Validate and Runs screens over the application
//! layer. The event loop reads what the scan and validation threads publish and redraws at most
//! every 33 ms; it never waits on a device, the disk or the network.
//!
//! - [`state`]: what is on screen, as plain data.
//! - [`view`]: drawing the state (pure; snapshot-tested).
//! - [`picture`]: frames as 24-bit half blocks.
//! - [`plan_choice`]: the plans to choose from, loaded for the Scan screen.
//! - [`session`]: the scan thread, its operator dialogs and events.
//! - [`stage_operator`]: the operator a stage moved by hand asks under the UI (never stdin).
//! - [`event_loop`]: keys, events, redraws; the terminal restored on every exit path.

mod calibration;
mod event_loop;
mod picture;
mod plan_choice;
mod session;
mod stage_operator;
mod state;
mod view;

pub use event_loop::{run, UiOptions};
pub use session::ModelChoice;
pub use state::Tab;
