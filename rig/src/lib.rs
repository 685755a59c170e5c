//! `fringe-rig`: everything that talks to the indentation bench.
//!
//! - [`units`], [`clock`]: quantities and the host time base.
//! - [`transport`]: serial, pseudo-terminal, TCP and UDP links behind two small traits.
//! - [`trace`]: recording what crosses a link and replaying it against a driver.
//! - [`axis`], [`force`], [`camera`]: the device traits every real, simulated or replayed device
//!   implements.
//!
//! Protocol codecs are pure (bytes <-> messages, no I/O); drivers combine a codec with a link.

pub mod acquire;
pub mod apt;
pub mod atical;
pub mod axis;
pub mod camera;
pub mod clock;
pub mod config_file;
pub mod devices;
pub mod force;
pub mod ft_units;
pub mod manual;
pub mod modbus;
pub mod netft;
pub mod scan;
pub mod seeded;
pub mod store;
pub mod sync;
pub mod trace;
pub mod transport;
pub mod units;
