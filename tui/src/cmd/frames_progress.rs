//! Progress over the frames of a dataset, on stderr: one line rewritten in place on a terminal,
//! a line every quarter otherwise (logs, pipes).

use std::io::{IsTerminal, Write};

/// Shows "<what>: N of M frames (P %)".
pub struct FramesProgress {
    what: &'static str,
    tty: bool,
    last_pct: usize,
}

impl FramesProgress {
    /// Progress of `what` ("evaluating", "reading features", ...).
    pub fn new(what: &'static str) -> FramesProgress {
        FramesProgress {
            what,
            tty: std::io::stderr().is_terminal(),
            last_pct: 0,
        }
    }

    /// `done` of `total` frames.
    pub fn show(&mut self, done: usize, total: usize) {
        let pct = 100 * done / total.max(1);
        let what = self.what;
        if self.tty {
            eprint!("\r{what}: {done} of {total} frames ({pct} %)");
            let _ = std::io::stderr().flush();
        } else if pct >= self.last_pct + 25 || done == total {
            eprintln!("{what}: {done} of {total} frames ({pct} %)");
            self.last_pct = pct;
        }
    }

    /// Ends the line rewritten in place.
    pub fn finish(&self) {
        if self.tty {
            eprintln!();
        }
    }
}
