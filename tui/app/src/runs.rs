//! The run store's jobs as a person sees them (`fringe runs`, the Runs screen).
//!
//! - `listing`: the runs in a directory, each with the name the other commands take and the
//!   bytes it takes on disk.

pub(crate) mod listing;

pub use listing::{list_runs, ListedRun};
