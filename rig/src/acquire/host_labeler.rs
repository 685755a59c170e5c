//! Labels frames from host arrival times only (synchronisation method `host`): the reference
//! pipeline's way, kept as a baseline to measure the other methods against.
//!
//! The reference knew when a frame and a block of force samples reached the host, the exposure
//! time and the sample rate, and nothing about the device clocks. So here:
//!
//! - a frame's exposure is taken to end when the frame arrived: [arrival - exposure, arrival];
//! - force samples that arrived together (one block, one callback) are spread back from their
//!   arrival at the sample period measured on the host clock (samples received per host second),
//!   the block's last sample at the arrival time;
//! - the force is averaged over the window with [`crate::sync::window::mean_over`], on host time.
//!
//! What it cannot see: the camera's readout and transfer time and the host's jitter, so its
//! labels lag the exposure by several milliseconds (hardware.md E, the reference's lag). Unlike
//! the reference it does not stamp blocks forward from the callback (its 100 ms lag) and does
//! average over the window instead of taking the nearest sample: only the time base is the
//! reference's. Its error estimate is the arrival jitter it can see in the frame intervals; the
//! constant readout delay is invisible to it, so the estimate is a lower bound.

use super::labeler::{ExposureLabel, FrameLabeler, LabelOutcome};
use crate::camera::Frame;
use crate::clock::HostTime;
use crate::force::ForceSample;
use crate::sync::method::SyncMethod;
use crate::sync::window::mean_over;
use crate::units::Microseconds;
use std::collections::VecDeque;

/// Host-time labels: the baseline.
pub(crate) struct HostLabeler {
    exposure_ns: f64,
    /// (host ns, six channels, sample index), spread as described, oldest first.
    samples: VecDeque<(f64, [f64; 6], u64)>,
    /// Samples that arrived at `block_arrival` and are not yet placed.
    block: Vec<(u64, [f64; 6])>,
    block_arrival: Option<HostTime>,
    /// First arrival and samples received after it, for the sample period.
    first_arrival: Option<HostTime>,
    received: u64,
    keep_samples: usize,
    /// Recent frame arrivals, for the jitter estimate.
    arrivals: VecDeque<HostTime>,
}

impl HostLabeler {
    /// A labeler for a camera exposing for `exposure`.
    pub(crate) fn new(exposure: Microseconds) -> HostLabeler {
        HostLabeler {
            exposure_ns: exposure.0 * 1e3,
            samples: VecDeque::new(),
            block: Vec::new(),
            block_arrival: None,
            first_arrival: None,
            received: 0,
            keep_samples: 40_000,
            arrivals: VecDeque::new(),
        }
    }

    /// Host nanoseconds per sample, from arrivals (`None` before 0.1 s of data).
    fn period_ns(&self) -> Option<f64> {
        let first = self.first_arrival?;
        let last = self.block_arrival?;
        let span = last.0.saturating_sub(first.0) as f64;
        (span >= 1e8 && self.received > 0).then(|| span / self.received as f64)
    }

    fn place_block(&mut self) {
        let (Some(arrival), Some(period)) = (self.block_arrival, self.period_ns()) else {
            return;
        };
        let n = self.block.len();
        for (k, (tick, w)) in self.block.drain(..).enumerate() {
            let t = arrival.0 as f64 - (n - 1 - k) as f64 * period;
            // Keep host times increasing even when a block arrived early.
            let t = self.samples.back().map_or(t, |s| t.max(s.0 + 1.0));
            self.samples.push_back((t, w, tick));
        }
        while self.samples.len() > self.keep_samples {
            self.samples.pop_front();
        }
    }

    /// Feeds one force sample, in stream order.
    pub(crate) fn push_sample(&mut self, s: &ForceSample) {
        self.first_arrival.get_or_insert(s.host_time);
        if self.block_arrival != Some(s.host_time) {
            self.place_block();
            // Before the period is known, blocks are dropped (the first 0.1 s only).
            self.block.clear();
            self.block_arrival = Some(s.host_time);
        }
        // Samples after the first arrival: those taken between it and the newest arrival.
        if Some(s.host_time) != self.first_arrival {
            self.received += 1;
        }
        self.block.push((s.device_tick, s.wrench.to_array()));
    }

    /// Notes a frame's arrival (for the jitter estimate).
    pub(crate) fn observe_frame(&mut self, frame: &Frame) {
        self.arrivals.push_back(frame.host_arrival);
        if self.arrivals.len() > 500 {
            self.arrivals.pop_front();
        }
    }

    /// The label of the frame that arrived at `arrival`.
    pub(crate) fn label(&mut self, arrival: HostTime) -> LabelOutcome {
        let end = arrival.0 as f64;
        let start = end - self.exposure_ns;
        let newest = self.samples.back().map_or(f64::NEG_INFINITY, |s| s.0);
        if newest <= end {
            return LabelOutcome::NotYet;
        }
        // From the last sample at or before the start to the first at or after the end (blocks
        // delivered late leave gaps on the host time base).
        let first = self
            .samples
            .partition_point(|s| s.0 <= start)
            .saturating_sub(1);
        let last = self.samples.partition_point(|s| s.0 < end);
        let span: Vec<(f64, [f64; 6])> = self
            .samples
            .range(first..=last.min(self.samples.len() - 1))
            .map(|s| (s.0, s.1))
            .collect();
        let tick_at = |t: f64| -> f64 {
            let i = self.samples.partition_point(|s| s.0 <= t);
            match (
                i.checked_sub(1).and_then(|j| self.samples.get(j)),
                self.samples.get(i),
            ) {
                (Some(a), Some(b)) if b.0 > a.0 => {
                    a.2 as f64 + (t - a.0) / (b.0 - a.0) * (b.2 as f64 - a.2 as f64)
                }
                (Some(a), _) => a.2 as f64,
                (None, Some(b)) => b.2 as f64,
                (None, None) => f64::NAN,
            }
        };
        match mean_over(&span, start, end) {
            Ok(mean) => LabelOutcome::Ready(ExposureLabel {
                window_ticks: [tick_at(start), tick_at(end)],
                window_host_ns: Some([start, end]),
                error_ns: self.jitter_ns().unwrap_or(f64::NAN),
                mean,
            }),
            Err(e) => LabelOutcome::Unmatched(format!("host window: {e}")),
        }
    }

    /// Arrival jitter seen in the frame intervals: the RMS deviation of consecutive intervals
    /// from their median, over sqrt(2) (two arrivals per interval), ns.
    fn jitter_ns(&self) -> Option<f64> {
        let mut gaps: Vec<f64> = self
            .arrivals
            .iter()
            .zip(self.arrivals.iter().skip(1))
            .map(|(a, b)| b.0 as f64 - a.0 as f64)
            .collect();
        if gaps.len() < 10 {
            return None;
        }
        gaps.sort_by(f64::total_cmp);
        let median = gaps[gaps.len() / 2];
        // Dropped frames make intervals of several periods: leave them out.
        let near: Vec<f64> = gaps
            .iter()
            .filter(|g| (*g - median).abs() < 0.5 * median)
            .map(|g| (g - median).powi(2))
            .collect();
        Some((near.iter().sum::<f64>() / near.len().max(1) as f64).sqrt() / 2f64.sqrt())
    }
}

impl FrameLabeler for HostLabeler {
    fn method(&self) -> SyncMethod {
        SyncMethod::Host
    }

    fn push_sample(&mut self, sample: &ForceSample) {
        HostLabeler::push_sample(self, sample);
    }

    fn observe_frame(&mut self, frame: &Frame) {
        HostLabeler::observe_frame(self, frame);
    }

    fn label(&mut self, frame: &Frame) -> LabelOutcome {
        HostLabeler::label(self, frame.host_arrival)
    }

    fn estimated_error_ns(&self) -> Option<f64> {
        self.jitter_ns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::Wrench;

    /// 5 kHz samples in blocks of 50 arriving exactly when the block's last sample is taken;
    /// Fz is the sample's true time in ms.
    fn sample(k: u64) -> ForceSample {
        let block_end = (k / 50) * 50 + 49;
        ForceSample {
            device_tick: k,
            transport_seq: None,
            host_time: HostTime(block_end * 200_000),
            wrench: Wrench::from_array([0.0, 0.0, k as f64 * 0.2, 0.0, 0.0, 0.0]),
            status: 0,
            strobe: None,
        }
    }

    #[test]
    fn the_window_ends_at_the_arrival_and_blocks_are_spread_back_from_theirs() {
        let mut l = HostLabeler::new(Microseconds(2000.0));
        for k in 0..5000 {
            l.push_sample(&sample(k));
        }
        // A frame arriving at 600 ms: window 598..600 ms, whose mean time is 599 ms.
        let LabelOutcome::Ready(label) = l.label(HostTime(600_000_000)) else {
            panic!("not ready");
        };
        assert_eq!(label.window_host_ns, Some([598e6, 600e6]));
        assert!((label.mean.mean[2] - 599.0).abs() < 0.01, "{label:?}");
        assert!((label.window_ticks[0] - 2990.0).abs() < 0.1, "{label:?}");
        assert!((label.window_ticks[1] - 3000.0).abs() < 0.1, "{label:?}");
        // Not before the samples after the arrival are in.
        assert_eq!(l.label(HostTime(999_000_000)), LabelOutcome::NotYet);
    }
}
