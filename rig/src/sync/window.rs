//! The force acting during an exposure: the six-axis signal averaged over the window.
//!
//! The force stream is a piecewise-linear signal through its samples; the label of a frame is its
//! mean over the exposure window [start, end], with values interpolated at the window edges — not
//! the nearest sample (the reference pipeline's choice). Times are in one base chosen by the caller:
//! fractional sample indices (strobe) or host nanoseconds (clock fits).

/// Why a window could not be averaged.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum WindowError {
    #[error("exposure window {start}..{end} is not covered by force samples {first}..{last}")]
    NotCovered {
        start: f64,
        end: f64,
        first: f64,
        last: f64,
    },
    #[error("exposure window {start}..{end} is empty or reversed")]
    Reversed { start: f64, end: f64 },
}

/// The mean over a window and what it was made from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowMean {
    /// Mean of each channel over the window.
    pub mean: [f64; 6],
    /// Samples strictly inside the window.
    pub samples_inside: usize,
    /// Largest spacing between consecutive samples that touch the window, in time units: a gap
    /// from lost samples shows here.
    pub max_spacing: f64,
}

/// Averages `samples` (time, six channels), sorted by time, over [start, end].
pub fn mean_over(
    samples: &[(f64, [f64; 6])],
    start: f64,
    end: f64,
) -> Result<WindowMean, WindowError> {
    if end.is_nan() || start.is_nan() || end < start {
        return Err(WindowError::Reversed { start, end });
    }
    let (first, last) = match (samples.first(), samples.last()) {
        (Some(f), Some(l)) => (f.0, l.0),
        _ => {
            return Err(WindowError::NotCovered {
                start,
                end,
                first: f64::NAN,
                last: f64::NAN,
            })
        }
    };
    if start < first || end > last {
        return Err(WindowError::NotCovered {
            start,
            end,
            first,
            last,
        });
    }
    // Index of the last sample at or before `start`.
    let i0 = samples.partition_point(|s| s.0 <= start).saturating_sub(1);
    let lerp = |a: &(f64, [f64; 6]), b: &(f64, [f64; 6]), t: f64| -> [f64; 6] {
        let span = b.0 - a.0;
        let u = if span > 0.0 { (t - a.0) / span } else { 0.0 };
        std::array::from_fn(|c| a.1[c] + u * (b.1[c] - a.1[c]))
    };
    let mut integral = [0.0; 6];
    let mut max_spacing: f64 = 0.0;
    let mut inside = 0;
    let mut k = i0;
    while k + 1 < samples.len() && samples[k].0 < end {
        let (a, b) = (&samples[k], &samples[k + 1]);
        max_spacing = max_spacing.max(b.0 - a.0);
        if b.0 > start && b.0 < end {
            inside += 1;
        }
        let lo = a.0.max(start);
        let hi = b.0.min(end);
        if hi > lo {
            let va = lerp(a, b, lo);
            let vb = lerp(a, b, hi);
            for c in 0..6 {
                integral[c] += 0.5 * (va[c] + vb[c]) * (hi - lo);
            }
        }
        k += 1;
    }
    let mean = if end > start {
        integral.map(|v| v / (end - start))
    } else {
        let j = (i0 + 1).min(samples.len() - 1);
        lerp(&samples[i0], &samples[j], start)
    };
    Ok(WindowMean {
        mean,
        samples_inside: inside,
        max_spacing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(n: usize, period: f64) -> Vec<(f64, [f64; 6])> {
        (0..n)
            .map(|k| {
                let t = k as f64 * period;
                (t, [t, 2.0 * t, -t, 1.0, 0.0, t * t])
            })
            .collect()
    }

    #[test]
    fn mean_of_a_ramp_is_its_value_at_the_window_middle() {
        let s = ramp(100, 1.0);
        let m = mean_over(&s, 10.3, 12.7).expect("covered");
        assert!((m.mean[0] - 11.5).abs() < 1e-12, "{m:?}");
        assert!((m.mean[1] - 23.0).abs() < 1e-12);
        assert!((m.mean[2] + 11.5).abs() < 1e-12);
        assert!((m.mean[3] - 1.0).abs() < 1e-12);
        assert_eq!(m.samples_inside, 2);
        assert_eq!(m.max_spacing, 1.0);
    }

    #[test]
    fn a_step_inside_the_window_is_weighted_by_the_time_on_each_side() {
        // 0 until sample 10, 6 from sample 11 on: the linear signal crosses in 10..11.
        let s: Vec<(f64, [f64; 6])> = (0..30)
            .map(|k| (k as f64, [if k <= 10 { 0.0 } else { 6.0 }; 6]))
            .collect();
        let m = mean_over(&s, 8.0, 14.0).expect("covered");
        // 2 samples of 0, half a sample of ramp (mean 3), 3 samples of 6 -> (0 + 3 + 18) / 6
        assert!((m.mean[0] - 3.5).abs() < 1e-12, "{m:?}");
    }

    #[test]
    fn windows_outside_the_stream_and_gaps_are_reported() {
        let mut s = ramp(50, 1.0);
        assert!(matches!(
            mean_over(&s, -1.0, 3.0),
            Err(WindowError::NotCovered { .. })
        ));
        assert!(matches!(
            mean_over(&s, 48.0, 50.0),
            Err(WindowError::NotCovered { .. })
        ));
        assert!(matches!(
            mean_over(&s, 5.0, 4.0),
            Err(WindowError::Reversed { .. })
        ));
        s.drain(20..25);
        let m = mean_over(&s, 18.5, 27.5).expect("covered");
        assert_eq!(m.max_spacing, 6.0);
        assert!((m.mean[0] - 23.0).abs() < 1e-12);
    }

    #[test]
    fn a_zero_length_window_interpolates() {
        let s = ramp(10, 2.0);
        let m = mean_over(&s, 5.0, 5.0).expect("covered");
        assert!((m.mean[0] - 5.0).abs() < 1e-12);
    }
}
