//! The terminal UI (ratatui on crossterm): Scan, Validate, Runs, Bench and Calibrate screens
//! over the application layer. The event loop reads what the scan and the screens' threads
//! publish and redraws at most every 33 ms; it never waits on a device, the disk or the network.
//!
//! - [`event_loop`]: the terminal, its input thread, the loop; the terminal restored on every
//!   exit path.
//! - [`keys`]: dispatch of a key (overlays, the shown screen, every screen, the global keys)
//!   and the `?` help, both from the binding tables ([`binding`]).
//! - [`screens`]: the list of screens; each file under `screens/` owns its keys, what runs
//!   behind it ([`screen::Screen`]) and its drawing.
//! - [`app`]: what every screen acts on: the state, the scan, the bench session, the plans.
//! - [`state`]: what is on screen, as plain data; [`view`] draws it (pure; snapshot-tested)
//!   with [`widgets`] and [`picture`] (frames as 24-bit half blocks).
//! - [`workers`]: the threads the screens start (verify, evaluate, export, fit, write);
//!   [`worker_panics`]: a worker's panic shown in the UI (and the scan stopped), not printed
//!   over it.
//! - [`session`]: the scan thread, its operator dialogs and events ([`scan_events`]: what they
//!   change on screen); [`plan_choice`]: the plans
//!   to choose from; [`calibration`]: the built-in calibration plan and its fitted view;
//!   [`stage_operator`]: the operator a stage moved by hand asks under the UI (never stdin).

mod app;
mod binding;
mod calibration;
mod commission;
mod event_loop;
mod health;
mod keys;
mod picture;
mod plan_choice;
mod scan_events;
mod screen;
pub mod screens;
mod session;
mod stage_operator;
mod state;
mod streaming;
mod units;
mod view;
mod widgets;
mod worker_panics;
mod workers;

pub use app::UiOptions;
pub use event_loop::run;
pub use session::ModelChoice;
