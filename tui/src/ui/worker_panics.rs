//! Panics under the terminal UI. ratatui's panic hook restores the terminal on a panic in any
//! thread and prints over the screen: a worker's panic (live validation, the scan, a Runs
//! screen job) left the UI running in a terminal back in line mode, deaf to `a` and `q` until
//! Enter, while the scan moved on. While the UI runs, the hook installed here tells the threads
//! apart: the UI thread's own panic still restores the terminal and prints (the UI is gone); a
//! worker's is recorded, and the event loop takes it ([`take`]), shows it and stops the scan,
//! the terminal raw and the keys working.

use std::panic::PanicHookInfo;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::thread::ThreadId;

/// The workers' panics not yet taken by the event loop, as text.
static RECORDED: Mutex<Vec<String>> = Mutex::new(Vec::new());
/// Whether the UI holds the terminal (a worker's panic is recorded, not printed).
static ACTIVE: AtomicBool = AtomicBool::new(false);

type Hook = Box<dyn Fn(&PanicHookInfo<'_>) + Sync + Send + 'static>;

/// The hook installed while the UI runs; dropped once the terminal is restored, a worker's panic
/// is printed again (by the hook that was there before: ratatui's, then Rust's).
pub struct Guard(());

/// Installs the hook for the UI on the calling thread (the UI thread), over the one there now
/// (ratatui's, which restores the terminal: call this after `ratatui::init`).
pub fn install() -> Guard {
    let previous: Hook = std::panic::take_hook();
    let ui = std::thread::current().id();
    ACTIVE.store(true, Ordering::SeqCst);
    std::panic::set_hook(Box::new(move |info| hook(ui, &previous, info)));
    Guard(())
}

impl Drop for Guard {
    fn drop(&mut self) {
        ACTIVE.store(false, Ordering::SeqCst);
    }
}

fn hook(ui: ThreadId, previous: &Hook, info: &PanicHookInfo<'_>) {
    if ACTIVE.load(Ordering::SeqCst) && std::thread::current().id() != ui {
        RECORDED
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(describe(info));
    } else {
        previous(info);
    }
}

/// A panic in one line: the thread, where, and its message.
fn describe(info: &PanicHookInfo<'_>) -> String {
    let thread = std::thread::current();
    let name = thread.name().unwrap_or("unnamed");
    let at = info
        .location()
        .map(|l| format!(" at {}:{}", l.file(), l.line()))
        .unwrap_or_default();
    let message = fringe_app::session::panic_text(info.payload());
    format!("thread '{name}' panicked{at}: {message}")
}

/// The workers' panics recorded since the last call, oldest first.
pub fn take() -> Vec<String> {
    std::mem::take(&mut *RECORDED.lock().unwrap_or_else(|p| p.into_inner()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A worker's panic under the UI is recorded with its thread's name and message, not
    /// handed to the hook before (ratatui's, which would restore the terminal and print over
    /// the screen); once the UI is done, panics go to that hook again.
    #[test]
    fn a_workers_panic_is_recorded_for_the_ui_and_not_handed_on() {
        let handed_on = Arc::new(AtomicBool::new(false));
        let seen = handed_on.clone();
        std::panic::set_hook(Box::new(move |_| seen.store(true, Ordering::SeqCst)));
        let guard = install();
        let joined = std::thread::Builder::new()
            .name("live-validation".into())
            .spawn(|| panic!("capacity overflow"))
            .expect("thread")
            .join();
        assert!(joined.is_err(), "the worker panicked");
        // (Other tests' threads may fail meanwhile: only this worker's panic is looked for.)
        let ours = |r: &[String]| -> Vec<String> {
            r.iter()
                .filter(|p| p.starts_with("thread 'live-validation' panicked at "))
                .cloned()
                .collect()
        };
        let recorded = ours(&take());
        assert_eq!(recorded.len(), 1, "{recorded:?}");
        assert!(recorded[0].ends_with(": capacity overflow"), "{recorded:?}");
        assert!(!handed_on.load(Ordering::SeqCst), "handed to the old hook");
        assert!(ours(&take()).is_empty(), "taken once");
        drop(guard);
        let _ = std::thread::spawn(|| panic!("after the UI")).join();
        assert!(handed_on.load(Ordering::SeqCst), "after the UI, handed on");
        let _ = std::panic::take_hook();
    }
}
