//! Exposure windows from a sampled exposure-active channel.
//!
//! The camera's ExposureActive output, wired into a spare DAQ channel, is high while a frame is
//! exposed. Its edges, found by linear interpolation between the two samples that straddle the
//! threshold, give each exposure's start and end in the force stream's own sample index
//! (hardware.md E.1): no clock fit is needed to label a frame.

/// One exposure, in fractional sample indices of the stream that carried the strobe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrobeWindow {
    pub start: f64,
    pub end: f64,
}

impl StrobeWindow {
    /// Midpoint, in samples.
    pub fn mid(&self) -> f64 {
        0.5 * (self.start + self.end)
    }
}

/// Finds exposure windows sample by sample, as the stream arrives.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct StrobeDetector {
    threshold: f64,
    last: Option<(u64, f64)>,
    rise: Option<f64>,
    /// The first window is only reported if the strobe was seen low before it.
    seen_low: bool,
}

impl StrobeDetector {
    /// A detector switching at `threshold` (volts; half the logic level is a good choice).
    pub(crate) fn new(threshold: f64) -> StrobeDetector {
        StrobeDetector {
            threshold,
            last: None,
            rise: None,
            seen_low: false,
        }
    }

    /// Feeds the sample at `index` with value `value`; returns a window when one closes. A gap in
    /// `index` (lost samples) abandons a window that was open across it.
    pub(crate) fn push(&mut self, index: u64, value: f64) -> Option<StrobeWindow> {
        let previous = self.last.replace((index, value));
        let high = value >= self.threshold;
        let Some((i0, v0)) = previous else {
            self.seen_low = !high;
            return None;
        };
        if index != i0 + 1 {
            self.rise = None;
            self.seen_low = !high;
            return None;
        }
        let was_high = v0 >= self.threshold;
        let crossing = || i0 as f64 + (self.threshold - v0) / (value - v0);
        match (was_high, high) {
            (false, true) => {
                if self.seen_low {
                    self.rise = Some(crossing());
                }
                None
            }
            (true, false) => {
                self.seen_low = true;
                let end = crossing();
                self.rise.take().map(|start| StrobeWindow { start, end })
            }
            (false, false) => {
                self.seen_low = true;
                None
            }
            (true, true) => None,
        }
    }
}

/// All complete windows in `values`, the first of which has sample index `first_index`.
#[cfg(test)]
pub(crate) fn windows(values: &[f64], first_index: u64, threshold: f64) -> Vec<StrobeWindow> {
    let mut detector = StrobeDetector::new(threshold);
    values
        .iter()
        .enumerate()
        .filter_map(|(k, &v)| detector.push(first_index + k as u64, v))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 0/5 V strobe sampled at 5 kHz with a linear edge of `rise` samples.
    fn sampled(starts: &[f64], width: f64, n: usize, rise: f64) -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = k as f64;
                starts
                    .iter()
                    .map(|&s| {
                        let up = ((t - s) / rise + 0.5).clamp(0.0, 1.0);
                        let down = ((s + width - t) / rise + 0.5).clamp(0.0, 1.0);
                        5.0 * up.min(down)
                    })
                    .fold(0.0, f64::max)
            })
            .collect()
    }

    #[test]
    fn edges_are_found_to_a_fraction_of_a_sample() {
        // 50 Hz frames at 5 kHz: every 100 samples, 2 ms = 10 samples exposure.
        let starts: Vec<f64> = (0..5).map(|i| 20.37 + 100.0 * i as f64).collect();
        let values = sampled(&starts, 10.0, 520, 1.5);
        let found = windows(&values, 1000, 2.5);
        assert_eq!(found.len(), 5);
        for (w, s) in found.iter().zip(&starts) {
            assert!((w.start - (1000.0 + s)).abs() < 0.05, "{w:?} vs {s}");
            assert!((w.end - (1000.0 + s + 10.0)).abs() < 0.05, "{w:?}");
        }
    }

    #[test]
    fn a_window_open_at_the_start_or_across_a_gap_is_not_reported() {
        let mut d = StrobeDetector::new(2.5);
        assert_eq!(d.push(0, 5.0), None); // already high: partial exposure
        assert_eq!(d.push(1, 0.0), None);
        assert_eq!(d.push(2, 5.0), None);
        assert_eq!(d.push(10, 5.0), None); // lost samples 3..=9
        assert_eq!(d.push(11, 0.0), None);
        assert_eq!(d.push(12, 5.0), None);
        let w = d.push(13, 0.0).expect("complete window");
        assert!(
            (w.start - 11.5).abs() < 1e-12 && (w.end - 12.5).abs() < 1e-12,
            "{w:?}"
        );
    }
}
