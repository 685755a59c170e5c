//! The simulator's own jobs, outside a rig (cargo feature `sim`): what `fringe sim ...` runs.
//!
//! - [`dataset`]: a synthetic training dataset in the reference layout, rendered straight from
//!   the simulator (`fringe sim dataset`).

pub mod dataset;
