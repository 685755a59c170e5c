//! The signals fringe catches, in one place for every command and the terminal UI. The handler
//! only touches atomics (async-signal-safe); each caller reads the flag or the count as it goes:
//!
//! - `fringe export`: Ctrl-C, SIGTERM or a hang-up stop it, and it removes what it wrote.
//! - `fringe scan`: each Ctrl-C asks for more (pause, stop now, abort), read on its own thread.
//! - `fringe train`: the first Ctrl-C saves a checkpoint; the next one ends the process.
//! - the terminal UI: SIGTERM or a hang-up stop it (Ctrl-C is a key there).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A signal a command catches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// SIGINT: Ctrl-C at the terminal.
    Interrupt,
    /// SIGTERM: the process is told to end.
    Terminate,
    /// SIGHUP: the terminal hung up.
    HangUp,
}

impl Signal {
    fn number(self) -> libc::c_int {
        match self {
            Signal::Interrupt => libc::SIGINT,
            Signal::Terminate => libc::SIGTERM,
            Signal::HangUp => libc::SIGHUP,
        }
    }
}

/// What a caught signal does when it comes again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Again {
    /// It is counted again ([`received`]).
    Counts,
    /// It does what it would have done uncaught (Ctrl-C ends the process).
    Ends,
}

/// Signals received since the program started.
static RECEIVED: AtomicUsize = AtomicUsize::new(0);
/// Set by the first signal received.
static STOP: AtomicBool = AtomicBool::new(false);
/// The handler gives each signal back its default disposition after the first ([`Again::Ends`]).
static RESTORE: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(number: libc::c_int) {
    RECEIVED.fetch_add(1, Ordering::SeqCst);
    STOP.store(true, Ordering::SeqCst);
    if RESTORE.load(Ordering::SeqCst) {
        // SAFETY: signal() is async-signal-safe.
        unsafe {
            libc::signal(number, libc::SIG_DFL);
        }
    }
}

/// Catches `signals` from now on (again is harmless) and returns the flag the first one sets.
pub fn catch(signals: &[Signal], again: Again) -> &'static AtomicBool {
    RESTORE.store(again == Again::Ends, Ordering::SeqCst);
    let handler: extern "C" fn(libc::c_int) = on_signal;
    for signal in signals {
        // SAFETY: the handler only touches atomics and calls signal() (async-signal-safe).
        unsafe {
            libc::signal(signal.number(), handler as libc::sighandler_t);
        }
    }
    &STOP
}

/// How many caught signals have arrived.
pub fn received() -> usize {
    RECEIVED.load(Ordering::SeqCst)
}

/// Whether a caught signal has arrived.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}
