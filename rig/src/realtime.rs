//! Real-time scheduling for the threads that keep the bench's time: the F/T reader and the
//! watchers that stop motion when its data stop.
//!
//! At normal priority such a thread waits behind whatever else the machine runs. Other
//! processes' system calls (writing files, reading `/dev/urandom`) are the worst: measured on
//! the 2-core bench machine with a debug `fringe check` (BENCHMARKS.md, "F/T data under load"),
//! two processes copying to files on a tmpfs held the simulated DAQ's 10 ms blocks back by up to
//! 150 ms and the 50 ms F/T watchdog stopped the scan 8 times a minute; with the DAQ, F/T reader
//! and watcher threads real-time (this module) the longest gap was 23 ms and nothing stopped.
//! It does not help against the disk's own writeback: the same copies to a disk still delayed
//! the real-time threads by up to 71 ms.
//!
//! A thread asks with [`raise_current_thread`]. Linux grants it to root, to a process with
//! `CAP_SYS_NICE`, or within the `RLIMIT_RTPRIO` limit (`ulimit -r`, `rtprio` in
//! `/etc/security/limits.conf`); otherwise the thread stays at normal priority and the refusal
//! says how to allow it. A real-time thread must block between its work (every caller here
//! waits on a device, a channel or a sleep): one that spun would hold a core.

/// The `SCHED_FIFO` priority asked for (1-99; above the kernel's threaded interrupts' 50 would
/// be too much for a reader that only needs to beat normal threads).
pub(crate) const PRIORITY: i32 = 20;

/// Real-time scheduling was refused; the thread runs at normal priority.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the {thread} thread runs at normal priority (real-time scheduling refused: {reason}); on a \
     busy machine its data can arrive late. Allow it with rtprio {PRIORITY} for the user \
     (/etc/security/limits.conf: `USER - rtprio {PRIORITY}`, or `ulimit -r {PRIORITY}`) or \
     CAP_SYS_NICE"
)]
pub struct RealtimeRefused {
    /// The thread's name.
    pub thread: String,
    /// The system's reason.
    pub reason: String,
}

/// Puts the calling thread under `SCHED_FIFO` at [`PRIORITY`]; `thread` names it in the
/// refusal.
#[cfg(unix)]
pub fn raise_current_thread(thread: &str) -> Result<(), RealtimeRefused> {
    let param = libc::sched_param {
        sched_priority: PRIORITY,
    };
    // SAFETY: pthread_self() is the calling thread, alive for the call; param is a valid
    // sched_param for SCHED_FIFO.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(RealtimeRefused {
            thread: thread.to_string(),
            reason: std::io::Error::from_raw_os_error(rc).to_string(),
        })
    }
}

/// Puts the calling thread under real-time scheduling (not done on this platform).
#[cfg(not(unix))]
pub fn raise_current_thread(thread: &str) -> Result<(), RealtimeRefused> {
    Err(RealtimeRefused {
        thread: thread.to_string(),
        reason: "not supported on this platform".into(),
    })
}

/// Whether the calling thread runs under `SCHED_FIFO` or `SCHED_RR`.
#[cfg(all(unix, test))]
pub(crate) fn current_thread_is_realtime() -> bool {
    let mut policy = 0;
    let mut param = libc::sched_param { sched_priority: 0 };
    // SAFETY: pthread_self() is the calling thread; both out-pointers are valid.
    let rc = unsafe { libc::pthread_getschedparam(libc::pthread_self(), &mut policy, &mut param) };
    rc == 0 && (policy == libc::SCHED_FIFO || policy == libc::SCHED_RR)
}

/// Whether the calling thread runs under real-time scheduling (never on this platform).
#[cfg(all(not(unix), test))]
pub(crate) fn current_thread_is_realtime() -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_is_raised_when_allowed_and_told_how_to_allow_it_otherwise() {
        let outcome = std::thread::spawn(|| {
            let r = raise_current_thread("test");
            (r, current_thread_is_realtime())
        })
        .join()
        .expect("thread");
        match outcome {
            (Ok(()), realtime) => assert!(realtime, "raised but not real-time"),
            (Err(refused), realtime) => {
                assert!(!realtime);
                let text = refused.to_string();
                assert!(
                    text.contains("test thread runs at normal priority"),
                    "{text}"
                );
                assert!(text.contains("rtprio 20"), "{text}");
            }
        }
        // The calling thread is not changed by another's request.
        assert!(!current_thread_is_realtime());
    }
}
