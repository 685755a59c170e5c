//! A worker thread's failure: a panic caught as text, so the thread's owner can report it and
//! go on (a screen shows it, a scan stops), and a panic injected on purpose, so tests can check
//! that a worker's failure is survived.
//!
//! `FRINGE_INJECT_PANIC=NAME` makes the worker that calls [`inject`] with that NAME panic at its
//! first unit of work, once per process (`live-validation`: the live validation's thread, at
//! the first frame it takes).

use std::any::Any;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};

/// The environment variable naming the worker whose panic is injected.
pub(crate) const INJECT_PANIC_VAR: &str = "FRINGE_INJECT_PANIC";

/// The message a panic carried (`panic!("...")`'s text), or a word saying it carried none.
pub fn panic_text(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".to_string()
    }
}

/// Runs `work`; a panic in it comes back as its text, naming the thread `worker` that failed.
pub fn guarded<T>(worker: &str, work: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(work))
        .map_err(|payload| format!("the {worker} thread failed: {}", panic_text(&*payload)))
}

/// Set once an injected panic has fired.
static INJECTED: AtomicBool = AtomicBool::new(false);

/// Panics when [`INJECT_PANIC_VAR`] names `worker`, the first time only.
pub(crate) fn inject(worker: &str) {
    let asked = std::env::var(INJECT_PANIC_VAR).is_ok_and(|v| v == worker);
    if asked && !INJECTED.swap(true, Ordering::SeqCst) {
        panic!("a panic injected into the {worker} thread ({INJECT_PANIC_VAR}={worker})");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_in_guarded_work_comes_back_as_its_text_naming_the_worker() {
        let r: Result<(), String> = guarded("export", || panic!("capacity overflow"));
        assert_eq!(
            r,
            Err("the export thread failed: capacity overflow".to_string())
        );
        let n = 3;
        let r: Result<(), String> = guarded("verify", || panic!("frame {n} is gone"));
        assert_eq!(
            r,
            Err("the verify thread failed: frame 3 is gone".to_string())
        );
        assert_eq!(guarded("x", || 7), Ok(7));
    }
}
