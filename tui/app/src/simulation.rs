//! The simulator's own jobs, outside a rig (cargo feature `sim`): what `fringe sim ...` runs.
//!
//! - [`dataset`]: a synthetic training dataset in the reference layout, rendered straight from
//!   the simulator (`fringe sim dataset`).
//! - [`selfcheck`]: the Net F/T driver against the simulated box on loopback (the self-check of
//!   `fringe` with no command).

pub mod dataset;
pub mod selfcheck;
