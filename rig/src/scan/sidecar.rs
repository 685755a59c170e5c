//! Files a caller adds to a run beside the scan's own records: whatever the caller gathers while
//! the scan runs (the simulated bench's ground truth is one), appended to a file in the run
//! directory after every point and when the run closes, so the caller holds only what came since
//! the last point. The engine knows only this trait, never where the lines come from.

/// Lines of JSON gathered during a scan, appended to a file of the run as they are taken (a
/// resumed run appends each session's lines).
pub trait RunSidecar: Send + Sync + std::fmt::Debug {
    /// The file inside the run directory, e.g. `truth.jsonl`.
    fn file_name(&self) -> &str;
    /// The lines gathered since the last call (each is handed over once), each one JSON object
    /// without its newline.
    fn take_lines(&self) -> Vec<String>;
}
