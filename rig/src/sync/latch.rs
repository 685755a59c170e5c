//! Fitting a [`ClockMap`] from timestamp-latch exchanges.
//!
//! Each exchange brackets the device clock read between two host times: the latch happened at
//! some host instant in [before, after], estimated as the midpoint with an error of at most half
//! the round trip (hardware.md E.3). Short round trips carry the most information, so only the
//! shortest ones are kept and weighted by 1 / (round trip)^2 in a straight-line fit of host time
//! against device ticks, which also gives the drift.

use super::clock_map::ClockMap;
use super::one_way::FitError;
use crate::camera::TimestampLatch;

/// A latch fit and its error bound.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LatchFit {
    pub map: ClockMap,
    /// Exchanges kept (shortest round trips) out of those given.
    pub used: usize,
    /// Median half round trip of the kept exchanges, ns: a bound on each one's error.
    pub half_round_trip_ns: f64,
    /// RMS residual of the kept midpoints about the fitted line, ns.
    pub rms_residual_ns: f64,
}

/// Fits device ticks -> host time; keeps exchanges whose round trip is at most twice the shortest
/// (at least three, the shortest ones). `clock` names the device for errors.
pub(crate) fn fit(latches: &[TimestampLatch], clock: &str) -> Result<LatchFit, FitError> {
    let need = 3;
    let mut kept: Vec<&TimestampLatch> = latches
        .iter()
        .filter(|l| l.host_after >= l.host_before)
        .collect();
    if kept.len() < need {
        return Err(FitError::TooFewPoints {
            clock: clock.to_string(),
            got: kept.len(),
            need,
        });
    }
    let rtt = |l: &TimestampLatch| (l.host_after.0 - l.host_before.0) as f64;
    kept.sort_by(|a, b| rtt(a).total_cmp(&rtt(b)));
    let shortest = rtt(kept[0]).max(1.0);
    let keep = kept
        .iter()
        .take_while(|l| rtt(l) <= 2.0 * shortest)
        .count()
        .max(need);
    kept.truncate(keep);
    kept.sort_by_key(|l| l.device_ticks);
    let d0 = kept[0].device_ticks;
    let h0 = kept[0].host_before.0 as f64;
    // Weighted least squares of y = host midpoint - h0 on x = ticks - d0.
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let samples: Vec<(f64, f64, f64)> = kept
        .iter()
        .map(|l| {
            let x = (l.device_ticks - d0) as f64;
            let y = 0.5 * (l.host_before.0 as f64 + l.host_after.0 as f64) - h0;
            let w = 1.0 / rtt(l).max(1.0).powi(2);
            (x, y, w)
        })
        .collect();
    for &(x, y, w) in &samples {
        sw += w;
        sx += w * x;
        sy += w * y;
        sxx += w * x * x;
        sxy += w * x * y;
    }
    let det = sw * sxx - sx * sx;
    if det.abs() < f64::EPSILON * sw * sxx.max(1.0) {
        return Err(FitError::NoSpan {
            clock: clock.to_string(),
        });
    }
    let slope = (sw * sxy - sx * sy) / det;
    let intercept = (sy - slope * sx) / sw;
    let rms = (samples
        .iter()
        .map(|&(x, y, _)| (y - intercept - slope * x).powi(2))
        .sum::<f64>()
        / samples.len() as f64)
        .sqrt();
    let mut halves: Vec<f64> = kept.iter().map(|l| 0.5 * rtt(l)).collect();
    halves.sort_by(f64::total_cmp);
    Ok(LatchFit {
        map: ClockMap {
            tick_origin: d0,
            host_at_origin_ns: h0 + intercept,
            ns_per_tick: slope,
        },
        used: kept.len(),
        half_round_trip_ns: halves[halves.len() / 2],
        rms_residual_ns: rms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::HostTime;
    use crate::seeded::SplitMix64;

    #[test]
    fn shortest_round_trips_give_offset_and_drift() {
        let mut rng = SplitMix64::new(7);
        let rate = 1.0 - 80e-6; // host ns per device tick
        let latches: Vec<TimestampLatch> = (0..200)
            .map(|i| {
                let before = 1e9 + i as f64 * 0.5e9;
                let rtt = 50_000.0 + rng.range(0.0..2e6);
                let at = before + rng.range(0.0..rtt);
                let ticks = 3_000_000_000 + ((at - 1e9) / rate) as u64;
                TimestampLatch {
                    host_before: HostTime(before as u64),
                    device_ticks: ticks,
                    host_after: HostTime((before + rtt) as u64),
                }
            })
            .collect();
        let fit = fit(&latches, "camera").expect("fit");
        assert!(fit.used >= 3 && fit.used < 200, "{fit:?}");
        assert!((fit.map.drift_ppm(1.0) + 80.0).abs() < 2.0, "{fit:?}");
        for l in &latches {
            let truth = 1e9 + (l.device_ticks - 3_000_000_000) as f64 * rate;
            let err = fit.map.host_ns(l.device_ticks) - truth;
            assert!(err.abs() < 100_000.0, "error {err} ns");
        }
    }

    #[test]
    fn too_few_exchanges_name_the_clock() {
        let l = TimestampLatch {
            host_before: HostTime(1),
            device_ticks: 5,
            host_after: HostTime(2),
        };
        let err = fit(&[l, l], "basler").expect_err("two");
        assert!(err.to_string().contains("basler"));
    }
}
