//! Ground truth of a simulated run (what really happened) and the scores measured against it:
//! the truth records and where they go, the spool that hands them to the run filming them, and
//! the scores of a run's labels and of the three synchronisation methods.

pub mod label_score;
pub mod records;
pub mod sync_score;
pub mod truth_spool;
