//! Files a caller adds to a run beside the scan's own records: whatever the caller gathered while
//! the scan ran (the simulated bench's ground truth is one), written into the run directory before
//! it is closed. The engine knows only this trait, never where the lines come from.

/// Lines of JSON gathered during a scan session, appended to a file of the run when it closes
/// (a resumed run appends each session's lines).
pub trait RunSidecar: Send + Sync + std::fmt::Debug {
    /// The file inside the run directory, e.g. `truth.jsonl`.
    fn file_name(&self) -> &str;
    /// Every line gathered in this session, each one JSON object without its newline.
    fn lines(&self) -> Vec<String>;
}
