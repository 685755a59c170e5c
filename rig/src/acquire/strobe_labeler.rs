//! Labels frames with the force measured during their exposure, using the exposure strobe
//! recorded beside the force gauges (synchronisation method `strobe`).
//!
//! The strobe channel gives each exposure's window in the force stream's own sample index (no
//! clock model needed for the label itself). Frames are matched to windows by sequence: once one
//! frame is matched, frame id n belongs to window n - offset, so dropped frames (id gaps) keep the
//! match. The first match is found by host arrival (a frame arrives a few milliseconds after its
//! window ends). Once two frames are matched, each further match is checked with the frames'
//! device timestamps (camera ticks against window starts in samples is a straight line), so a
//! host stall cannot break the lock; before that, by arrival, where one frame far off goes
//! unlabelled and three in a row re-match by nearest arrival. A timestamp that disagrees (lost
//! strobe windows) re-matches at once.

use super::labeler::{ExposureLabel, FrameLabeler, LabelOutcome};
use crate::camera::Frame;
use crate::clock::HostTime;
use crate::force::ForceSample;
use crate::sync::method::SyncMethod;
use crate::sync::strobe::{StrobeDetector, StrobeWindow};
use crate::sync::window::mean_over;
use std::collections::VecDeque;
use std::time::Duration;

/// Frames in a row off their locked window before the lock is dropped and frames are matched
/// by arrival again.
const MISSES_TO_UNLOCK: u32 = 3;

#[derive(Debug, Clone, Copy)]
struct Seen {
    seq: u64,
    window: StrobeWindow,
    end_arrival: HostTime,
}

/// Matches frames to strobe windows and averages the force over them.
pub struct StrobeLabeler {
    detector: StrobeDetector,
    samples: VecDeque<(f64, [f64; 6], HostTime)>,
    windows: VecDeque<Seen>,
    next_seq: u64,
    offset: Option<i64>,
    /// Frames in a row whose arrival disagreed with the locked sequence.
    misses: u32,
    /// First and latest (frame device timestamp, window start) matched under the lock.
    anchors: Option<((u64, f64), (u64, f64))>,
    expected_lag_ns: f64,
    tolerance_ns: f64,
    keep_samples: usize,
}

impl StrobeLabeler {
    /// `threshold`: strobe level in volts; `expected_lag`: frame arrival minus the arrival of the
    /// window's last sample, typically a few ms; `tolerance`: how far a match may be off (less
    /// than half a frame period).
    pub fn new(threshold: f64, expected_lag: Duration, tolerance: Duration) -> StrobeLabeler {
        StrobeLabeler {
            detector: StrobeDetector::new(threshold),
            samples: VecDeque::new(),
            windows: VecDeque::new(),
            next_seq: 0,
            offset: None,
            misses: 0,
            anchors: None,
            expected_lag_ns: expected_lag.as_nanos() as f64,
            tolerance_ns: tolerance.as_nanos() as f64,
            keep_samples: 20_000,
        }
    }

    /// Feeds one force sample (in stream order). Samples without a strobe value are kept for
    /// averaging but find no windows.
    pub fn push_sample(&mut self, s: &ForceSample) {
        let tick = s.device_tick;
        if let Some(volts) = s.strobe {
            if let Some(window) = self.detector.push(tick, volts.0) {
                self.windows.push_back(Seen {
                    seq: self.next_seq,
                    window,
                    end_arrival: s.host_time,
                });
                self.next_seq += 1;
                if self.windows.len() > 500 {
                    self.windows.pop_front();
                }
            }
        }
        self.samples
            .push_back((tick as f64, s.wrench.to_array(), s.host_time));
        if self.samples.len() > self.keep_samples {
            self.samples.pop_front();
        }
    }

    /// Sample period on the host time base, ns, from the kept samples.
    fn sample_period_ns(&self) -> Option<f64> {
        let (first, last) = (self.samples.front()?, self.samples.back()?);
        let ticks = last.0 - first.0;
        (ticks >= 100.0).then(|| (last.2 .0 as f64 - first.2 .0 as f64) / ticks)
    }

    /// Time between consecutive exposures on the host time base, ns (median of the windows
    /// kept).
    fn frame_period_ns(&self) -> Option<f64> {
        let per_tick = self.sample_period_ns()?;
        let mut gaps: Vec<f64> = self
            .windows
            .iter()
            .zip(self.windows.iter().skip(1))
            .filter(|(a, b)| b.seq == a.seq + 1)
            .map(|(a, b)| (b.window.start - a.window.start) * per_tick)
            .collect();
        if gaps.is_empty() {
            return None;
        }
        gaps.sort_by(f64::total_cmp);
        Some(gaps[gaps.len() / 2])
    }

    /// Error of an edge placed by interpolation between two samples: uniform over at most one
    /// sample period.
    fn edge_error_ns(&self) -> f64 {
        self.sample_period_ns().unwrap_or(f64::NAN) / 12f64.sqrt()
    }

    fn lag_error(&self, seen: &Seen, arrival: HostTime) -> f64 {
        arrival.0 as f64 - seen.end_arrival.0 as f64 - self.expected_lag_ns
    }

    fn label_of(&self, seen: &Seen) -> LabelOutcome {
        let newest = self.samples.back().map_or(f64::NEG_INFINITY, |s| s.0);
        if newest < seen.window.end + 1.0 {
            return LabelOutcome::NotYet;
        }
        let span: Vec<(f64, [f64; 6])> = self
            .samples
            .iter()
            .filter(|s| s.0 >= seen.window.start - 2.0 && s.0 <= seen.window.end + 2.0)
            .map(|s| (s.0, s.1))
            .collect();
        match mean_over(&span, seen.window.start, seen.window.end) {
            Ok(mean) => LabelOutcome::Ready(ExposureLabel {
                window_ticks: [seen.window.start, seen.window.end],
                window_host_ns: None,
                error_ns: self.edge_error_ns(),
                mean,
            }),
            Err(e) => LabelOutcome::Unmatched(format!("strobe window: {e}")),
        }
    }

    /// The label of frame `frame_id` that arrived at `arrival`.
    pub fn label(&mut self, frame_id: u64, arrival: HostTime) -> LabelOutcome {
        self.label_stamped(frame_id, None, arrival)
    }

    /// Whether window `seen` is where frame device timestamp `stamp` belongs, judged from the
    /// frames already matched under the current lock (camera ticks -> strobe samples is a
    /// straight line: two clocks with a steady rate ratio). `None` until two frames a few
    /// periods apart are matched.
    fn stamp_agrees(&self, stamp: u64, seen: &Seen) -> Option<bool> {
        let ((d0, w0), (d1, w1)) = (self.anchors?.0, self.anchors?.1);
        if d1 <= d0 {
            return None;
        }
        let per_tick = (w1 - w0) / (d1 - d0) as f64;
        let predicted = w1 + (stamp as f64 - d1 as f64) * per_tick;
        let spacing = self.frame_period_ns()? / self.sample_period_ns()?;
        Some((seen.window.start - predicted).abs() < 0.25 * spacing)
    }

    fn note_anchor(&mut self, stamp: Option<u64>, seen: &Seen) {
        if let Some(d) = stamp {
            let here = (d, seen.window.start);
            self.anchors = Some(match self.anchors {
                Some((first, _)) if d > first.0 => (first, here),
                _ => (here, here),
            });
        }
    }

    /// The label of frame `frame_id` with device timestamp `stamp` (if known) that arrived at
    /// `arrival`. Once locked and two frames are matched, the device timestamp, not the host
    /// arrival, checks each match: host stalls do not matter then.
    pub fn label_stamped(
        &mut self,
        frame_id: u64,
        stamp: Option<u64>,
        arrival: HostTime,
    ) -> LabelOutcome {
        if let Some(offset) = self.offset {
            let seq = frame_id as i64 - offset;
            if seq >= self.next_seq as i64 {
                return LabelOutcome::NotYet;
            }
            let found = self.windows.iter().find(|w| w.seq as i64 == seq).copied();
            let agrees = match (stamp, &found) {
                (Some(d), Some(seen)) => self.stamp_agrees(d, seen),
                _ => None,
            };
            match (agrees, found) {
                (Some(true), Some(seen)) => {
                    self.misses = 0;
                    self.note_anchor(stamp, &seen);
                    return self.label_of(&seen);
                }
                // Timestamps say the sequence slipped (strobe windows lost): match again.
                (Some(false), _) => {
                    self.offset = None;
                    self.anchors = None;
                }
                _ => {}
            }
        }
        if let Some(offset) = self.offset {
            let seq = frame_id as i64 - offset;
            if let Some(seen) = self.windows.iter().find(|w| w.seq as i64 == seq).copied() {
                // Locked on the sequence: a frame delivered late (a busy host) still belongs to
                // its window as long as it cannot be the next one's, i.e. it arrived less than
                // a frame period (minus the tolerance) after the expected time. A force block
                // delivered late makes a frame look early by as much: the same bound applies.
                let lag = self.lag_error(&seen, arrival);
                let limit = self.frame_period_ns().map_or(self.tolerance_ns, |p| {
                    (p - self.tolerance_ns).max(self.tolerance_ns)
                });
                if lag.abs() <= limit {
                    self.misses = 0;
                    self.note_anchor(stamp, &seen);
                    return self.label_of(&seen);
                }
                // One frame held up on the host (or a stalled force block) is not a lost
                // lock: the frame goes unlabelled and the lock is kept until
                // MISSES_TO_UNLOCK frames in a row disagree with it (lost strobe windows).
                self.misses += 1;
                if self.misses < MISSES_TO_UNLOCK {
                    return LabelOutcome::Unmatched(format!(
                        "frame arrived {:.1} ms off its strobe window's expected time (host delay); lock on the frame sequence kept",
                        lag * 1e-6
                    ));
                }
            }
            self.offset = None;
            self.anchors = None;
            self.misses = 0;
        }
        let best = self
            .windows
            .iter()
            .min_by(|a, b| {
                self.lag_error(a, arrival)
                    .abs()
                    .total_cmp(&self.lag_error(b, arrival).abs())
            })
            .copied();
        match best {
            Some(seen) if self.lag_error(&seen, arrival).abs() <= self.tolerance_ns => {
                self.offset = Some(frame_id as i64 - seen.seq as i64);
                self.note_anchor(stamp, &seen);
                self.label_of(&seen)
            }
            // The frame arrived after every window seen so far: its window is still to come.
            Some(seen) if self.lag_error(&seen, arrival) > 0.0 && seen.seq + 1 == self.next_seq => {
                LabelOutcome::NotYet
            }
            None => LabelOutcome::NotYet,
            _ => LabelOutcome::Unmatched(
                "no exposure window in the strobe channel matches the frame's arrival".into(),
            ),
        }
    }
}

impl FrameLabeler for StrobeLabeler {
    fn method(&self) -> SyncMethod {
        SyncMethod::Strobe
    }

    fn push_sample(&mut self, sample: &ForceSample) {
        StrobeLabeler::push_sample(self, sample);
    }

    fn label(&mut self, frame: &Frame) -> LabelOutcome {
        StrobeLabeler::label_stamped(
            self,
            frame.id,
            Some(frame.device_timestamp),
            frame.host_arrival,
        )
    }

    fn estimated_error_ns(&self) -> Option<f64> {
        self.sample_period_ns().map(|p| p / 12f64.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::{Volts, Wrench};

    /// 5 kHz samples; exposures of 10 samples every 100 samples starting at sample 37; Fz equals
    /// the sample index / 1000; samples arrive in blocks of 50 (arrival = end of block).
    fn samples(n: u64) -> Vec<ForceSample> {
        (0..n)
            .map(|k| {
                let phase = (k + 100 - 37) % 100;
                let block_end = (k / 50 + 1) * 50;
                ForceSample {
                    device_tick: k,
                    transport_seq: None,
                    host_time: HostTime(block_end * 200_000),
                    wrench: Wrench::from_array([0.0, 0.0, k as f64 / 1000.0, 0.0, 0.0, 0.0]),
                    status: 0,
                    strobe: Some(Volts(if k >= 37 && phase < 10 { 3.3 } else { 0.0 })),
                }
            })
            .collect()
    }

    /// Frame n's exposure ends at sample 37 + 100 n + 10; it arrives 6 ms later.
    fn arrival(n: u64) -> HostTime {
        HostTime((37 + 100 * n + 10) * 200_000 + 6_000_000)
    }

    #[test]
    fn frames_get_their_own_window_and_dropped_ids_keep_the_match() {
        let mut l = StrobeLabeler::new(1.65, Duration::from_millis(2), Duration::from_millis(9));
        let all = samples(1000);
        // Frame ids start at 500 (the camera ran before); id 503 is dropped.
        let mut fed = 0;
        for n in [0u64, 1, 2, 4, 5, 6, 7, 8] {
            // Feed samples up to the frame's arrival, then ask (and ask again after more samples).
            while fed < all.len() && all[fed].host_time <= arrival(n) {
                l.push_sample(&all[fed]);
                fed += 1;
            }
            let mut outcome = l.label(500 + n, arrival(n));
            while outcome == LabelOutcome::NotYet && fed < all.len() {
                l.push_sample(&all[fed]);
                fed += 1;
                outcome = l.label(500 + n, arrival(n));
            }
            let LabelOutcome::Ready(label) = outcome else {
                panic!("frame {n}: {outcome:?}");
            };
            let start = (37 + 100 * n) as f64;
            // The strobe is high on samples start..start+9: edges half a sample outside.
            assert!(
                (label.window_ticks[0] - (start - 0.5)).abs() < 1e-9,
                "{label:?}"
            );
            assert!(
                (label.window_ticks[1] - (start + 9.5)).abs() < 1e-9,
                "{label:?}"
            );
            // Fz is a ramp: the mean is its value at the window's middle.
            assert!((label.mean.mean[2] - (start + 4.5) / 1000.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_frame_with_no_window_is_unmatched() {
        let mut l = StrobeLabeler::new(1.65, Duration::from_millis(2), Duration::from_millis(9));
        for s in samples(600) {
            l.push_sample(&s);
        }
        // Arrived before the first exposure the strobe shows: no window is its own.
        assert!(matches!(
            l.label(7, HostTime(1_000_000)),
            LabelOutcome::Unmatched(_)
        ));
        // Arrived after every window seen so far: its window is still to come.
        assert_eq!(l.label(8, HostTime(arrival(9).0)), LabelOutcome::NotYet);
    }

    /// A busy host delivers some frames 5-6.6 ms later than usual (beyond the 9 ms tolerance
    /// with the 6 ms lag and the 10 ms force blocks): once locked on the sequence, they keep their own window.
    #[test]
    fn late_frames_keep_their_window_once_locked() {
        let mut l = StrobeLabeler::new(1.65, Duration::from_millis(2), Duration::from_millis(9));
        for s in samples(2000) {
            l.push_sample(&s);
        }
        let start = |n: u64| (37 + 100 * n) as f64 - 0.5;
        for n in 0..15u64 {
            let extra = if n % 3 == 2 {
                5_000_000 + (n % 5) * 400_000
            } else {
                0
            };
            let LabelOutcome::Ready(label) = l.label(900 + n, HostTime(arrival(n).0 + extra))
            else {
                panic!("frame {n} (delayed {extra} ns) lost its label");
            };
            assert!(
                (label.window_ticks[0] - start(n)).abs() < 1e-9,
                "frame {n}: {label:?}"
            );
        }
    }

    /// A force block delivered late makes a frame look 13 ms early, and a 40 ms host stall
    /// delays one frame: the first keeps its window, the second goes unlabelled, and the frames
    /// after it keep the lock (no re-match onto a neighbour's window).
    #[test]
    fn a_stalled_or_early_looking_frame_does_not_break_the_lock() {
        let mut l = StrobeLabeler::new(1.65, Duration::from_millis(2), Duration::from_millis(9));
        for s in samples(2000) {
            l.push_sample(&s);
        }
        let start = |n: u64| (37 + 100 * n) as f64 - 0.5;
        for n in 0..15u64 {
            let arrival = match n {
                4 => HostTime(arrival(n).0 - 13_000_000),
                7 => HostTime(arrival(n).0 + 40_000_000),
                _ => arrival(n),
            };
            match l.label(300 + n, arrival) {
                LabelOutcome::Ready(label) => {
                    assert_ne!(n, 7, "the stalled frame was labelled {label:?}");
                    assert!(
                        (label.window_ticks[0] - start(n)).abs() < 1e-9,
                        "frame {n}: {label:?}"
                    );
                }
                other => assert_eq!((n, matches!(other, LabelOutcome::Unmatched(_))), (7, true)),
            }
        }
    }

    /// With device timestamps, a lock confirmed by two frames survives a 60 ms host stall over
    /// four frames in a row: every frame keeps its own window.
    #[test]
    fn device_timestamps_keep_the_lock_through_a_host_stall() {
        let mut l = StrobeLabeler::new(1.65, Duration::from_millis(2), Duration::from_millis(9));
        for s in samples(2000) {
            l.push_sample(&s);
        }
        let start = |n: u64| (37 + 100 * n) as f64 - 0.5;
        // Camera ticks: ns on its own clock, 50 ppm off and far from the host's.
        let stamp =
            |n: u64| 5_000_000_000_000 + ((37 + 100 * n) as f64 * 200_000.0 * 1.00005) as u64;
        for n in 0..15u64 {
            let stall = if (5..9).contains(&n) { 60_000_000 } else { 0 };
            let outcome = l.label_stamped(40 + n, Some(stamp(n)), HostTime(arrival(n).0 + stall));
            let LabelOutcome::Ready(label) = outcome else {
                panic!("frame {n}: {outcome:?}");
            };
            assert!(
                (label.window_ticks[0] - start(n)).abs() < 1e-9,
                "frame {n}: {label:?}"
            );
        }
    }
}
