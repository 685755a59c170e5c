//! The weighted centroid of the pattern inside a circular window (cosine-tapered over its outer
//! 20 %): the window seeded and settled, the centroid iterated, its variance, and the radii that
//! hold a fraction of the weight.

use super::binning::BIN_PX;

/// Window radius over the radius holding 90 % of the weight.
pub(crate) const WINDOW_OVER_R90: f64 = 1.5;

/// The centroid window: seeded at the densest spot (weight over an 80 px box) with
/// [`WINDOW_OVER_R90`] times the radius holding 90 % of all the weight, then three times the
/// centroid iterated in it and the window re-set from the weight within it. (centre, window) px.
pub(super) fn settle_window(weights: &[(f64, f64, f64, f64)]) -> ([f64; 2], f64) {
    let seed = densest(weights, 80.0);
    let r90 = radius_holding(weights, seed, 0.9);
    let mut window = WINDOW_OVER_R90 * r90;
    let mut c = seed;
    for _ in 0..3 {
        c = iterate_centroid(weights, c, window);
        let r90_now = radius_holding_within(weights, c, 0.9, window);
        window = WINDOW_OVER_R90 * r90_now.max(2.0 * BIN_PX as f64);
    }
    (c, window)
}

/// The sums over the weights in a tapered window.
pub(super) struct WindowSums {
    /// Summed tapered weight.
    pub(super) sw: f64,
    /// Summed tapered weight times u and v, px.
    pub(super) su: f64,
    pub(super) sv: f64,
    /// Summed variance of the tapered weights.
    pub(super) noise2: f64,
    /// Bins inside the window.
    pub(super) bins: usize,
}

impl WindowSums {
    /// The sums over `weights` in the taper of `window` about `c`.
    pub(super) fn new(weights: &[(f64, f64, f64, f64)], c: [f64; 2], window: f64) -> WindowSums {
        let (mut sw, mut su, mut sv, mut noise2, mut bins) = (0.0, 0.0, 0.0, 0.0, 0usize);
        for &(u, v, w, s) in weights {
            let t = taper((u - c[0]).hypot(v - c[1]), window);
            if t <= 0.0 {
                continue;
            }
            bins += 1;
            sw += t * w;
            su += t * w * u;
            sv += t * w * v;
            noise2 += t * t * s * s;
        }
        WindowSums {
            sw,
            su,
            sv,
            noise2,
            bins,
        }
    }
}

/// The noise variance of the centroid `c` per axis, times the summed weight squared: the
/// weights' noise, tapered by `window` about `c`, times their distance from it.
pub(super) fn centroid_variance(
    weights: &[(f64, f64, f64, f64)],
    c: [f64; 2],
    window: f64,
) -> [f64; 2] {
    let (cu, cv) = (c[0], c[1]);
    let (mut vu, mut vv) = (0.0, 0.0);
    for &(u, v, _, s) in weights {
        let t = taper((u - cu).hypot(v - cv), window);
        vu += (t * s * (u - cu)).powi(2);
        vv += (t * s * (v - cv)).powi(2);
    }
    [vu, vv]
}

/// Window weight at distance `r` from the centre: 1 inside 0.8 R, a cosine taper to 0 at R.
fn taper(r: f64, window: f64) -> f64 {
    let inner = 0.8 * window;
    if r <= inner {
        1.0
    } else if r >= window {
        0.0
    } else {
        0.5 * (1.0 + (std::f64::consts::PI * (r - inner) / (window - inner)).cos())
    }
}

/// The weighted centroid inside `window` about `start`, iterated until it moves less than
/// 0.005 px (at most 100 steps).
pub(super) fn iterate_centroid(
    weights: &[(f64, f64, f64, f64)],
    start: [f64; 2],
    window: f64,
) -> [f64; 2] {
    let mut c = start;
    for _ in 0..100 {
        let (mut sw, mut su, mut sv) = (0.0, 0.0, 0.0);
        for &(u, v, w, _) in weights {
            let t = taper((u - c[0]).hypot(v - c[1]), window) * w;
            sw += t;
            su += t * u;
            sv += t * v;
        }
        if sw <= 0.0 {
            return c;
        }
        let next = [su / sw, sv / sw];
        let moved = (next[0] - c[0]).hypot(next[1] - c[1]);
        c = next;
        if moved < 0.005 {
            break;
        }
    }
    c
}

/// The position with the most weight within a `box_px` square (coarse grid search).
fn densest(weights: &[(f64, f64, f64, f64)], box_px: f64) -> [f64; 2] {
    let cell = box_px / 2.0;
    let mut grid: std::collections::HashMap<(i64, i64), f64> = std::collections::HashMap::new();
    for &(u, v, w, _) in weights {
        *grid
            .entry(((u / cell).floor() as i64, (v / cell).floor() as i64))
            .or_default() += w;
    }
    let mut best = (f64::MIN, (0i64, 0i64));
    for &(i, j) in grid.keys() {
        let s: f64 = (-1..=1)
            .flat_map(|di| (-1..=1).map(move |dj| (i + di, j + dj)))
            .filter_map(|k| grid.get(&k))
            .sum();
        if s > best.0 || (s == best.0 && (i, j) < best.1) {
            best = (s, (i, j));
        }
    }
    let (i, j) = best.1;
    // Centroid of the 3x3 cells about the best one.
    let (mut sw, mut su, mut sv) = (0.0, 0.0, 0.0);
    for &(u, v, w, _) in weights {
        let (ci, cj) = ((u / cell).floor() as i64, (v / cell).floor() as i64);
        if (ci - i).abs() <= 1 && (cj - j).abs() <= 1 {
            sw += w;
            su += w * u;
            sv += w * v;
        }
    }
    if sw > 0.0 {
        [su / sw, sv / sw]
    } else {
        [(i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell]
    }
}

/// Radius about `c` holding `fraction` of all the weight.
fn radius_holding(weights: &[(f64, f64, f64, f64)], c: [f64; 2], fraction: f64) -> f64 {
    radius_holding_within(weights, c, fraction, f64::INFINITY)
}

/// Radius about `c` holding `fraction` of the weight within `limit` of `c`.
pub(super) fn radius_holding_within(
    weights: &[(f64, f64, f64, f64)],
    c: [f64; 2],
    fraction: f64,
    limit: f64,
) -> f64 {
    let mut rw: Vec<(f64, f64)> = weights
        .iter()
        .map(|&(u, v, w, _)| ((u - c[0]).hypot(v - c[1]), w))
        .filter(|&(r, _)| r <= limit)
        .collect();
    rw.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = rw.iter().map(|x| x.1).sum();
    let mut acc = 0.0;
    for &(r, w) in &rw {
        acc += w;
        if acc >= fraction * total {
            return r;
        }
    }
    rw.last().map(|x| x.0).unwrap_or(0.0)
}
