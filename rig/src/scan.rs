//! Scans: moving the indenter and pressing under force control.
//!
//! - [`plan`]: scan plans (plan.toml), validation against the bench, point order, estimates.
//! - [`press`]: first contact found by force, closed-loop presses to force targets on the F/T
//!   reading, retract; every step checks the force ceiling and a cancel flag.

pub mod demo;
pub mod plan;
pub mod press;
