//! Fitting a [`ClockMap`] from one-way messages: device timestamps and host arrival times.
//!
//! Every message leaves the device at its timestamp and arrives after an unknown, non-negative
//! delay, so o_i = r_i - d_i (host arrival minus nominal device time) is an upper bound of the
//! clock offset at d_i. The lower convex hull of the points (d_i, o_i) hugs the least-delayed
//! messages; the hull segment spanning the middle of the data is the estimate, its slope the drift
//! (TICSync: Harrison & Newman, ICRA 2011). Delayed messages lie above the hull and do not matter;
//! a message stamped impossibly early (a host clock step, a corrupted timestamp) would pull the hull
//! down, so hull vertices that sit far below their neighbours' line are rejected first.
//!
//! The fitted map gives the arrival time of a message with the minimum transport delay; that
//! minimum is a constant the method cannot see (calibrate it with the strobe or the latch).

use super::clock_map::ClockMap;
use crate::clock::HostTime;

/// What went wrong with a fit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum FitError {
    #[error("clock fit for {clock}: {got} usable timestamp pairs, need at least {need}")]
    TooFewPoints {
        clock: String,
        got: usize,
        need: usize,
    },
    #[error("clock fit for {clock}: device timestamps span no time (all equal)")]
    NoSpan { clock: String },
}

/// Options of a one-way fit.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OneWayOptions {
    /// Name of the clock for messages ("camera", "netft").
    pub clock: String,
    /// Nominal host nanoseconds per device tick (1.0 for a 1 GHz camera clock, 200_000.0 for a
    /// 5 kHz sample counter).
    pub nominal_ns_per_tick: f64,
    /// A hull vertex more than this far below the line through its hull neighbours is an
    /// impossible (too early) point and is rejected.
    pub max_early_ns: f64,
}

/// A one-way fit and how well the data supported it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OneWayFit {
    pub map: ClockMap,
    /// Points used / rejected as impossibly early.
    pub used: usize,
    pub rejected: usize,
    /// Mean delay of all messages above the fitted line (transport jitter), ns.
    pub mean_delay_ns: f64,
    /// Mean over ten equal spans of the data of the smallest delay above the line, ns: how
    /// closely the least-delayed messages approach the line, an indication of its error.
    pub hull_gap_ns: f64,
}

/// Cross product of (b - a) x (c - a): > 0 when a, b, c turn counter-clockwise.
fn cross(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// Indices (into `pts`, sorted by x) of the lower convex hull, left to right.
pub(crate) fn lower_hull(pts: &[(f64, f64)]) -> Vec<usize> {
    let mut hull: Vec<usize> = Vec::new();
    for (i, &p) in pts.iter().enumerate() {
        while hull.len() >= 2 {
            let a = pts[hull[hull.len() - 2]];
            let b = pts[hull[hull.len() - 1]];
            if cross(a, b, p) <= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(i);
    }
    hull
}

/// Height of the line through `a` and `b` at `x`.
fn line_at(a: (f64, f64), b: (f64, f64), x: f64) -> f64 {
    if (b.0 - a.0).abs() < f64::EPSILON {
        return a.1.min(b.1);
    }
    a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
}

/// Fits device ticks -> host time from `(device_ticks, host_arrival)` pairs.
pub(crate) fn fit(
    pairs: &[(u64, HostTime)],
    options: &OneWayOptions,
) -> Result<OneWayFit, FitError> {
    let need = 2;
    if pairs.len() < need {
        return Err(FitError::TooFewPoints {
            clock: options.clock.clone(),
            got: pairs.len(),
            need,
        });
    }
    let d0 = pairs.iter().map(|p| p.0).min().unwrap_or(0);
    let r0 = pairs[0].1 .0 as f64;
    let nominal = options.nominal_ns_per_tick;
    let mut pts = offset_points(pairs, d0, r0, nominal);
    let (x_min, x_max) = (pts[0].0, pts[pts.len() - 1].0);
    if x_max <= x_min {
        return Err(FitError::NoSpan {
            clock: options.clock.clone(),
        });
    }
    let (hull, rejected) = hull_without_early(&mut pts, options.max_early_ns, need);
    let (a, b) = middle_segment(&pts, &hull, 0.5 * (x_min + x_max));
    let slope = if b.0 > a.0 {
        (b.1 - a.1) / (b.0 - a.0)
    } else {
        0.0
    };
    let offset_at = |x: f64| a.1 + slope * (x - a.0);
    let delays: Vec<(f64, f64)> = pts.iter().map(|&(x, y)| (x, y - offset_at(x))).collect();
    let mean_delay_ns = delays.iter().map(|d| d.1).sum::<f64>() / delays.len() as f64;
    Ok(OneWayFit {
        map: ClockMap {
            tick_origin: d0,
            host_at_origin_ns: r0 + offset_at(0.0),
            ns_per_tick: nominal * (1.0 + slope),
        },
        used: pts.len(),
        rejected,
        mean_delay_ns,
        hull_gap_ns: hull_gap(&delays, x_min, x_max),
    })
}

/// The points (x, y), sorted by x, one per device time: x is the nominal device time since
/// `d0` (ns), y the arrival minus the nominal device time, relative to `r0`.
fn offset_points(pairs: &[(u64, HostTime)], d0: u64, r0: f64, nominal: f64) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = pairs
        .iter()
        .map(|&(d, r)| {
            let x = (d - d0) as f64 * nominal;
            (x, r.0 as f64 - r0 - x)
        })
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    // Equal device times: only the least-delayed one can be on the hull.
    pts.dedup_by(|later, earlier| later.0 == earlier.0);
    pts
}

/// The lower hull of `pts` after removing, one at a time and while more than `need` points
/// are left, the hull vertex deepest below its neighbours' line by more than `max_early_ns`;
/// the hull and how many points were removed.
fn hull_without_early(
    pts: &mut Vec<(f64, f64)>,
    max_early_ns: f64,
    need: usize,
) -> (Vec<usize>, usize) {
    let mut rejected = 0;
    loop {
        let hull = lower_hull(pts);
        match deepest_early_vertex(pts, &hull, max_early_ns) {
            Some(index) if pts.len() > need => {
                pts.remove(index);
                rejected += 1;
            }
            _ => return (hull, rejected),
        }
    }
}

/// The index (into `pts`) of the hull vertex lying deepest below the line through its hull
/// neighbours, if it lies more than `max_early_ns` below it.
fn deepest_early_vertex(pts: &[(f64, f64)], hull: &[usize], max_early_ns: f64) -> Option<usize> {
    let mut worst: Option<(usize, f64)> = None;
    for k in 0..hull.len() {
        // Interior vertices against their neighbours; end vertices against the next segment.
        let (a, b) = if k > 0 && k + 1 < hull.len() {
            (hull[k - 1], hull[k + 1])
        } else if k == 0 && hull.len() >= 3 {
            (hull[1], hull[2])
        } else if k + 1 == hull.len() && hull.len() >= 3 {
            (hull[k - 2], hull[k - 1])
        } else {
            continue;
        };
        let p = pts[hull[k]];
        let depth = line_at(pts[a], pts[b], p.0) - p.1;
        if depth > max_early_ns && worst.is_none_or(|(_, d)| depth > d) {
            worst = Some((hull[k], depth));
        }
    }
    worst.map(|(index, _)| index)
}

/// The ends of the hull segment spanning `x_mid`, or of the whole hull when none does.
fn middle_segment(pts: &[(f64, f64)], hull: &[usize], x_mid: f64) -> ((f64, f64), (f64, f64)) {
    hull.windows(2)
        .find(|w| pts[w[0]].0 <= x_mid && x_mid <= pts[w[1]].0)
        .map(|w| (pts[w[0]], pts[w[1]]))
        .unwrap_or((pts[hull[0]], pts[hull[hull.len() - 1]]))
}

/// Mean over ten equal spans of `x_min ..= x_max` of the smallest delay in each span that
/// holds any of `delays` (x, delay).
fn hull_gap(delays: &[(f64, f64)], x_min: f64, x_max: f64) -> f64 {
    let bins = 10usize;
    let mut best = vec![f64::INFINITY; bins];
    for &(x, delay) in delays {
        let k = (((x - x_min) / (x_max - x_min)) * bins as f64).floor() as usize;
        let k = k.min(bins - 1);
        best[k] = best[k].min(delay);
    }
    let filled: Vec<f64> = best.into_iter().filter(|b| b.is_finite()).collect();
    filled.iter().sum::<f64>() / filled.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seeded::SplitMix64;

    /// A 1 GHz device clock running `ppm` fast or slow, messages every 20 ms with delay
    /// `latency + U(0, jitter)`.
    fn messages(
        n: usize,
        ppm: f64,
        latency_ns: f64,
        jitter_ns: f64,
        seed: u64,
    ) -> Vec<(u64, HostTime)> {
        let mut rng = SplitMix64::new(seed);
        let ns_per_tick = 1.0 + ppm * 1e-6;
        let tick0 = 7_000_000_000_000u64;
        (0..n)
            .map(|i| {
                let ticks = tick0 + i as u64 * 20_000_000;
                let true_host = 2e9 + (ticks - tick0) as f64 * ns_per_tick;
                let arrival = true_host + latency_ns + rng.range(0.0..jitter_ns);
                (ticks, HostTime(arrival as u64))
            })
            .collect()
    }

    fn options() -> OneWayOptions {
        OneWayOptions {
            clock: "camera".into(),
            nominal_ns_per_tick: 1.0,
            max_early_ns: 5e6,
        }
    }

    #[test]
    fn recovers_drift_and_offset_under_jitter() {
        // 3000 frames (60 s), 100 ppm drift, 3 ms uniform host jitter.
        let pairs = messages(3000, 100.0, 1e6, 3e6, 1);
        let fit = fit(&pairs, &options()).expect("fit");
        assert!((fit.map.drift_ppm(1.0) - 100.0).abs() < 1.0, "{fit:?}");
        // Time error over the whole window (latency known: 1 ms).
        for &(ticks, _) in pairs.iter().step_by(97) {
            let truth = 2e9 + (ticks - 7_000_000_000_000) as f64 * (1.0 + 100e-6) + 1e6;
            let err = fit.map.host_ns(ticks) - truth;
            assert!(err.abs() < 50_000.0, "error {err} ns at tick {ticks}");
        }
        assert!(
            fit.mean_delay_ns > 1e6 && fit.mean_delay_ns < 2e6,
            "{fit:?}"
        );
        assert_eq!(fit.rejected, 0);
    }

    #[test]
    fn an_impossibly_early_point_is_rejected() {
        let mut pairs = messages(500, -50.0, 1e6, 2e6, 2);
        pairs[250].1 = HostTime(pairs[250].1 .0 - 40_000_000);
        let fit = fit(&pairs, &options()).expect("fit");
        assert_eq!(fit.rejected, 1);
        assert!((fit.map.drift_ppm(1.0) + 50.0).abs() < 5.0, "{fit:?}");
    }

    #[test]
    fn delayed_bursts_do_not_move_the_fit() {
        let clean = messages(1000, 20.0, 1e6, 1e6, 3);
        let mut late = clean.clone();
        for p in late.iter_mut().skip(300).take(200) {
            p.1 = HostTime(p.1 .0 + 30_000_000);
        }
        let a = fit(&clean, &options()).expect("fit");
        let b = fit(&late, &options()).expect("fit");
        let mid = clean[500].0;
        assert!((a.map.host_ns(mid) - b.map.host_ns(mid)).abs() < 20_000.0);
    }

    #[test]
    fn too_few_or_degenerate_points_are_errors_naming_the_clock() {
        let err = fit(&[(5, HostTime(10))], &options()).expect_err("one point");
        assert!(err.to_string().contains("camera"), "{err}");
        let err = fit(&[(5, HostTime(10)), (5, HostTime(20))], &options()).expect_err("no span");
        assert!(matches!(err, FitError::NoSpan { .. }));
    }
}
