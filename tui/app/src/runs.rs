//! The run store's jobs as a person sees them (`fringe runs`, the Runs screen, `fringe export
//! --format mcap|webdataset`).
//!
//! - `listing`: the runs in a directory, each with the name the other commands take and the
//!   bytes it takes on disk.
//! - `mcap_export`: a run exported to MCAP as ROS 2 records it (frames, the F/T at full rate,
//!   labels, events), for Foxglove and ROS 2 tools, with its estimate.
//! - `ros_messages`: a run's records as ROS 2 messages on its topics (free of I/O).
//! - `run_clock`: a run's host times on Unix time.
//! - `webdataset_export`: runs as WebDataset tar shards (frames in PNG, labels in JSON), for
//!   training at scale from object storage.

pub(crate) mod listing;
pub(crate) mod mcap_export;
pub(crate) mod ros_messages;
pub(crate) mod run_clock;
pub(crate) mod webdataset_export;

pub use listing::{list_runs, ListedRun};
pub use mcap_export::{
    estimate_mcap_export, export_mcap, ClockMapping, McapCounts, McapExportError,
    McapExportEstimate, McapExportOptions, McapExportSummary, McapProgress,
};
pub use ros_messages::RunTopics;
pub use run_clock::{ClockSource, RunClock};
pub use webdataset_export::{export_shards, ShardError, ShardOptions, ShardSummary, SHARDS_INDEX};
