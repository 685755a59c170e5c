//! Sequence accounting for an RDT stream: lost records from `rdt_sequence` gaps, late
//! (out-of-order) records dropped and counted, and the meaning of a non-zero status word.

use crate::force::StreamStats;
use std::collections::VecDeque;

/// How many recently missed sequence numbers are remembered, so a record that arrives late is
/// moved from "lost" to "out of order".
const MISSING_MEMORY: usize = 1024;
/// A first record numbered above this joined a running stream (see [`SequenceTracker::accept`]).
const FIRST_RECORD_WINDOW: u32 = 1 << 16;
/// Gaps larger than this are counted but their numbers not remembered.
const MAX_REMEMBERED_GAP: u32 = 64;

/// What to do with a record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Deliver it; `lost_before` records were skipped just before it.
    Deliver { lost_before: u32 },
    /// Drop it: it arrived after a later record (or is a duplicate).
    Drop,
}

/// Tracks `rdt_sequence` over one stream (it restarts at 1 with every start request).
#[derive(Debug, Clone, Default)]
pub(crate) struct SequenceTracker {
    last: Option<u32>,
    missing: VecDeque<u32>,
    stats: StreamStats,
}

impl SequenceTracker {
    pub(crate) fn new() -> SequenceTracker {
        SequenceTracker::default()
    }

    /// Forgets the sequence (a new start request was sent); keeps the counters.
    pub(crate) fn restart(&mut self) {
        self.last = None;
        self.missing.clear();
    }

    /// Resets counters and sequence.
    pub(crate) fn reset(&mut self) {
        *self = SequenceTracker::default();
    }

    /// Accounts for a record with this `rdt_sequence` and `status`.
    pub(crate) fn accept(&mut self, seq: u32, status: u32) -> Verdict {
        // The first record of a stream is number 1; anything before it was lost. A first record
        // far from 1 means the stream was joined midway: nothing is counted lost then.
        let prev = match self.last {
            Some(last) => last,
            None if seq <= FIRST_RECORD_WINDOW => 0,
            None => seq.wrapping_sub(1),
        };
        let ahead = seq.wrapping_sub(prev);
        if ahead == 0 || ahead > u32::MAX / 2 {
            if let Some(i) = self.missing.iter().position(|&m| m == seq) {
                self.missing.remove(i);
                self.stats.lost = self.stats.lost.saturating_sub(1);
            }
            self.stats.out_of_order += 1;
            return Verdict::Drop;
        }
        let gap = ahead - 1;
        if gap > 0 {
            self.stats.lost += u64::from(gap);
            if gap <= MAX_REMEMBERED_GAP {
                for k in 1..=gap {
                    self.missing.push_back(prev.wrapping_add(k));
                }
                while self.missing.len() > MISSING_MEMORY {
                    self.missing.pop_front();
                }
            }
        }
        self.last = Some(seq);
        self.stats.received += 1;
        if status != 0 {
            self.stats.errored += 1;
        }
        Verdict::Deliver { lost_before: gap }
    }

    /// Counters so far.
    pub(crate) fn stats(&self) -> StreamStats {
        self.stats
    }
}

/// A readable meaning of a non-zero RDT status word, listing every bit that is set.
///
/// Bit 31 is the Net F/T summary error flag and bit 30 the Ethernet Axia out-of-range flag; for
/// the other bits the text points to the sensor manual's status table, which differs between
/// models and firmware.
pub(crate) fn status_meaning(status: u32) -> String {
    if status == 0 {
        return "ok".into();
    }
    let parts: Vec<String> = (0..32)
        .rev()
        .filter(|bit| status & (1 << bit) != 0)
        .map(|bit| match bit {
            31 => "bit 31: error flagged by the sensor (Net F/T summary error)".to_string(),
            30 => "bit 30: out of range (Axia: a gauge or axis is saturated; reduce the load)"
                .to_string(),
            b => format!("bit {b}: see the status table in the sensor manual"),
        })
        .collect();
    parts.join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_count_lost_records() {
        let mut t = SequenceTracker::new();
        assert_eq!(t.accept(1, 0), Verdict::Deliver { lost_before: 0 });
        assert_eq!(t.accept(2, 0), Verdict::Deliver { lost_before: 0 });
        assert_eq!(t.accept(5, 0), Verdict::Deliver { lost_before: 2 });
        assert_eq!(
            t.stats(),
            StreamStats {
                received: 3,
                lost: 2,
                out_of_order: 0,
                errored: 0,
                restarts: 0
            }
        );
    }

    #[test]
    fn first_record_after_one_counts_the_ones_before_as_lost() {
        let mut t = SequenceTracker::new();
        assert_eq!(t.accept(3, 0), Verdict::Deliver { lost_before: 2 });
        assert_eq!(t.stats().lost, 2);
    }

    #[test]
    fn late_records_are_dropped_and_no_longer_lost() {
        let mut t = SequenceTracker::new();
        t.accept(1, 0);
        t.accept(3, 0);
        assert_eq!(t.stats().lost, 1);
        assert_eq!(t.accept(2, 0), Verdict::Drop);
        assert_eq!(t.accept(3, 0), Verdict::Drop, "duplicate");
        assert_eq!(
            t.stats(),
            StreamStats {
                received: 2,
                lost: 0,
                out_of_order: 2,
                errored: 0,
                restarts: 0
            }
        );
        assert_eq!(
            t.accept(4, 0x4000_0000),
            Verdict::Deliver { lost_before: 0 }
        );
        assert_eq!(t.stats().errored, 1);
    }

    #[test]
    fn restart_accepts_sequence_one_again() {
        let mut t = SequenceTracker::new();
        t.accept(1, 0);
        t.accept(2, 0);
        t.restart();
        assert_eq!(t.accept(1, 0), Verdict::Deliver { lost_before: 0 });
        assert_eq!(t.stats().received, 3);
    }

    #[test]
    fn sequence_wraps_around() {
        let mut t = SequenceTracker::new();
        t.accept(u32::MAX - 1, 0);
        t.accept(u32::MAX, 0);
        assert_eq!(t.accept(0, 0), Verdict::Deliver { lost_before: 0 });
        assert_eq!(t.accept(1, 0), Verdict::Deliver { lost_before: 0 });
        assert_eq!(t.stats().out_of_order, 0);
    }

    #[test]
    fn status_bits_are_named() {
        assert_eq!(status_meaning(0), "ok");
        let m = status_meaning(0x4000_0000);
        assert!(m.contains("out of range"), "{m}");
        let m = status_meaning(0x8000_0004);
        assert!(m.starts_with("bit 31") && m.contains("bit 2:"), "{m}");
    }
}
