//! [`TruthSpool`]: the simulated bench's ground truth on its way into the runs it films, held in
//! memory only until the run takes it. A scan drains it into the run's `truth.jsonl` after every
//! point and when the run closes, so an unattended scan of hours holds seconds of truth, not all
//! of it (the in-memory [`TruthLog`](crate::ground_truth::records::TruthLog) grew by about 12 MB an hour at
//! 25 fps), and two runs of one session each get their own records once.

use crate::ground_truth::records::{TruthRecord, TruthSink, TRUTH_FILE};
use fringe_rig::Wrench;
use std::sync::Mutex;

/// Records held at most while no run takes them (the bench idles between scans, filming for the
/// Bench screen): about 1.4 hours of frames at 50 fps, 30 MB. Past it, the frame and bench
/// records, which no run filmed, are passed over; the few clock and bias records are kept.
pub(crate) const MAX_PENDING: usize = 250_000;

#[derive(Debug, Default)]
struct Spooled {
    pending: Vec<TruthRecord>,
    /// The F/T sensor's power-up bias in effect (the newest `FtBias` record).
    bias: Option<Wrench>,
    /// Frame and bench records passed over because no run took them.
    passed_over: u64,
}

/// Ground truth waiting for a run to take it.
#[derive(Debug, Default)]
pub struct TruthSpool {
    inner: Mutex<Spooled>,
}

impl TruthSpool {
    pub fn new() -> std::sync::Arc<TruthSpool> {
        std::sync::Arc::new(TruthSpool::default())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Spooled> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Takes every record gathered since the last call.
    pub fn take(&self) -> Vec<TruthRecord> {
        std::mem::take(&mut self.lock().pending)
    }

    /// Records waiting to be taken.
    pub fn pending(&self) -> usize {
        self.lock().pending.len()
    }

    /// The F/T sensor's power-up bias in effect, kept after its record is taken.
    pub fn bias(&self) -> Option<Wrench> {
        self.lock().bias
    }

    /// Frame and bench records passed over since the bench started (see [`MAX_PENDING`] and
    /// [`TruthSpool::pass_over_unfilmed`]).
    pub fn passed_over(&self) -> u64 {
        self.lock().passed_over
    }

    /// Passes over the frame and bench records waiting now (filmed while no run was open, e.g.
    /// for the Bench screen), keeping the clock and bias records, which hold for later runs too.
    /// Called as a scan starts.
    pub fn pass_over_unfilmed(&self) {
        let mut s = self.lock();
        let before = s.pending.len();
        s.pending
            .retain(|r| !matches!(r, TruthRecord::Frame(_) | TruthRecord::Bench { .. }));
        s.passed_over += (before - s.pending.len()) as u64;
    }
}

impl TruthSink for TruthSpool {
    fn record(&self, record: TruthRecord) {
        let mut s = self.lock();
        if let TruthRecord::FtBias { bias, .. } = &record {
            s.bias = Some(*bias);
        }
        s.pending.push(record);
        let overflow = s.pending.len() > MAX_PENDING;
        drop(s);
        if overflow {
            self.pass_over_unfilmed();
        }
    }
}

/// A simulated run keeps its ground truth as `truth.jsonl` (frames matched by device timestamps).
impl fringe_rig::scan::RunSidecar for TruthSpool {
    fn file_name(&self) -> &str {
        TRUTH_FILE
    }

    fn take_lines(&self) -> Vec<String> {
        self.take().iter().map(TruthRecord::to_json).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground_truth::records::{FrameFate, FrameTruth};
    use fringe_rig::scan::RunSidecar;
    use fringe_rig::HostTime;

    fn frame(id: u64) -> TruthRecord {
        TruthRecord::Frame(FrameTruth {
            id,
            exposure_start: HostTime(id * 20_000_000),
            exposure_end: HostTime(id * 20_000_000 + 2_000_000),
            exposure_start_ticks: id * 1000,
            exposure_end_ticks: id * 1000 + 100,
            arrival: Some(HostTime(id * 20_000_000 + 9_000_000)),
            fate: FrameFate::Delivered,
            contact: Some((2.5, -1.25, 3.0)),
            shear: None,
        })
    }

    #[test]
    fn each_record_is_taken_once_and_memory_does_not_keep_it() {
        let spool = TruthSpool::new();
        for id in 0..3 {
            spool.record(frame(id));
        }
        let first = spool.take_lines();
        assert_eq!(first.len(), 3);
        assert_eq!(spool.pending(), 0);
        spool.record(frame(3));
        let second = spool.take_lines();
        assert_eq!(second.len(), 1);
        assert!(second[0].contains("\"id\":3"), "{}", second[0]);
        assert!(spool.take_lines().is_empty());
    }

    #[test]
    fn records_no_run_takes_are_bounded_but_clock_and_bias_records_kept() {
        let spool = TruthSpool::new();
        spool.record(TruthRecord::DaqClock {
            start: HostTime(0),
            rate_hz: 5000.0,
            drift_ppm: 3.0,
        });
        for id in 0..MAX_PENDING as u64 + 10 {
            spool.record(frame(id));
            assert!(spool.pending() <= MAX_PENDING);
        }
        assert_eq!(spool.passed_over(), MAX_PENDING as u64);
        let kept = spool.take();
        assert!(
            matches!(kept[0], TruthRecord::DaqClock { .. }),
            "{:?}",
            kept[0]
        );
        assert_eq!(
            kept.len(),
            11,
            "the clock record and the 10 frames after the cut"
        );
    }

    #[test]
    fn a_scan_starting_passes_over_what_was_filmed_before_it() {
        let spool = TruthSpool::new();
        spool.record(frame(0));
        spool.record(TruthRecord::CameraClock {
            t: HostTime(5),
            ticks_at_ref: 100,
            reference: HostTime(0),
            drift_ppm: 25.0,
        });
        spool.record(frame(1));
        spool.pass_over_unfilmed();
        assert_eq!(spool.passed_over(), 2);
        spool.record(frame(2));
        let kept = spool.take();
        assert_eq!(kept.len(), 2);
        assert!(matches!(kept[0], TruthRecord::CameraClock { .. }));
        assert!(matches!(
            kept[1],
            TruthRecord::Frame(FrameTruth { id: 2, .. })
        ));
    }

    #[test]
    fn the_bias_in_effect_outlives_its_record() {
        let spool = TruthSpool::new();
        assert!(spool.bias().is_none());
        let bias = Wrench::from_array([0.5, -0.25, 1.5, 0.01, 0.02, 0.03]);
        spool.record(TruthRecord::FtBias {
            t: HostTime(1),
            power_cycle: 0,
            bias,
        });
        spool.take();
        assert_eq!(spool.bias(), Some(bias));
    }
}
