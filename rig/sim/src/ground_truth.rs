//! Ground truth of a simulated run (what really happened) and the scores measured against it:
//! the truth records and where they go, the spool that hands them to the run filming them, and
//! the scores of a run's labels and of the three synchronisation methods.

pub(crate) mod label_score;
pub(crate) mod records;
pub(crate) mod sync_score;
pub(crate) mod truth_spool;

pub use label_score::{score as score_labels, LabelScore};
pub use records::{read_frames, FrameFate, FrameTruth, TruthError, TruthRecord, TRUTH_FILE};
pub use sync_score::{
    run as run_sync_bench, MethodScore, SyncBenchConfig, SyncBenchError, SyncBenchReport,
};
