//! The outline refinement: along 144 rays from the centroid, where the profile falls
//! to a fraction of the ray's peak; the area centroid of the polygon through those points.

use super::binning::BIN_PX;

/// Rays for the boundary refinement.
const BOUNDARY_RAYS: usize = 144;

/// Largest fraction of the rays whose outline point is missing or in the outer 10 % of the
/// window (the pattern cut by the window, i.e. by the crop edge).
pub(crate) const MAX_CUT_RAYS: f64 = 0.1;

/// The outline refinement's result.
pub(super) struct Outline {
    pub(super) centre: [f64; 2],
    /// |centroid(even rays) - centroid(odd rays)| per axis, px.
    pub(super) half_diff: [f64; 2],
    /// Fraction of the rays without an outline point or with one beyond 0.9 of the window.
    pub(super) cut_fraction: f64,
}

/// Bilinear sample of the bin map at image position (u, v) px; NaN outside.
fn sample(map: &[f32], bw: usize, bh: usize, u: f64, v: f64) -> f64 {
    let x = u / BIN_PX as f64 - 0.5;
    let y = v / BIN_PX as f64 - 0.5;
    if !(x >= 0.0 && y >= 0.0) {
        return f64::NAN;
    }
    let (i, j) = (x.floor() as usize, y.floor() as usize);
    if i + 1 >= bw || j + 1 >= bh {
        return f64::NAN;
    }
    let (fx, fy) = (x - i as f64, y - j as f64);
    let at = |a: usize, b: usize| f64::from(map[b * bw + a]);
    let top = at(i, j) + (at(i + 1, j) - at(i, j)) * fx;
    let bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * fx;
    top + (bottom - top) * fy
}

/// The centre of the pattern's outline: along rays from `c`, the radius (within `window`) where
/// the profile falls to `level` times the ray's own peak (the outermost such fall, or the first
/// beyond the peak: [`fall_on_ray`]); the area centroid
/// of the polygon through those points. A smooth change of the pattern's strength across it
/// (sensitivity varying with the residual birefringence, uneven light) scales each ray's
/// profile and leaves that radius in place. `None` when fewer than half of the rays find the
/// outline.
pub(super) fn boundary_centre(
    map: &[f32],
    bw: usize,
    bh: usize,
    c: [f64; 2],
    window: f64,
    level: f64,
    outermost: bool,
) -> Option<Outline> {
    let step = 0.5 * BIN_PX as f64;
    let n_steps = (window / step).floor() as usize;
    if n_steps < 4 {
        return None;
    }
    let mut pts: Vec<Option<[f64; 2]>> = Vec::with_capacity(BOUNDARY_RAYS);
    let mut outer = 0usize;
    for r in 0..BOUNDARY_RAYS {
        let t = std::f64::consts::TAU * r as f64 / BOUNDARY_RAYS as f64;
        let (dy, dx) = t.sin_cos();
        let prof: Vec<f64> = (0..=n_steps)
            .map(|k| {
                sample(
                    map,
                    bw,
                    bh,
                    c[0] + dx * step * k as f64,
                    c[1] + dy * step * k as f64,
                )
            })
            .collect();
        let found = fall_on_ray(&prof, level, outermost).map(|at| {
            let rad = step * at;
            if rad > 0.9 * window {
                outer += 1;
            }
            [c[0] + dx * rad, c[1] + dy * rad]
        });
        pts.push(found);
    }
    outline_of(&pts, outer)
}

/// Where the profile `prof` (samples along a ray) falls to `level` times its peak, in samples
/// from its start (linear between samples). Outermost: walking inwards from the window's edge
/// to the first sample at or above the level (dark fringes inside the pattern do not end it);
/// otherwise walking outwards from the peak to the first fall below it (rings further out do
/// not extend it). Samples outside the crop circle (NaN) on the way mean the pattern may go on
/// beyond: `None`.
fn fall_on_ray(prof: &[f64], level: f64, outermost: bool) -> Option<f64> {
    let n_steps = prof.len() - 1;
    let (mut peak, mut at_peak) = (f64::MIN, 0);
    for (k, &p) in prof.iter().enumerate() {
        if p.is_finite() && p > peak {
            peak = p;
            at_peak = k;
        }
    }
    let target = level * peak;
    if outermost {
        first_crossing(prof, target, (at_peak..n_steps).rev())
    } else {
        first_crossing(prof, target, at_peak..n_steps)
    }
}

/// The first step `k` of `steps` where `prof` falls from at or above `target` at `k` to below
/// it at `k + 1`, as `k` plus the fraction of the step; `None` at a non-finite sample at `k + 1`
/// first, or when no step crosses.
fn first_crossing(prof: &[f64], target: f64, steps: impl Iterator<Item = usize>) -> Option<f64> {
    for k in steps {
        if !prof[k + 1].is_finite() {
            return None;
        }
        let (a, b) = (prof[k], prof[k + 1]);
        if a.is_finite() && b.is_finite() && a >= target && b < target {
            let f = (a - target) / (a - b);
            return Some(k as f64 + f);
        }
    }
    None
}

/// The outline from its points on [`BOUNDARY_RAYS`] rays (`None` where a ray found none), of
/// which `outer` lie beyond 0.9 of the window: the centroids of all, even and odd rays'
/// polygons (missing rays skipped, the polygon joining their neighbours). `None` when fewer
/// than half of the rays found the outline or a polygon is degenerate.
fn outline_of(pts: &[Option<[f64; 2]>], outer: usize) -> Option<Outline> {
    let ok = pts.iter().filter(|p| p.is_some()).count();
    if (ok as f64) < 0.5 * BOUNDARY_RAYS as f64 {
        return None;
    }
    let poly = |sel: &dyn Fn(usize) -> bool| -> Option<[f64; 2]> {
        let p: Vec<[f64; 2]> = pts
            .iter()
            .enumerate()
            .filter(|(i, _)| sel(*i))
            .filter_map(|(_, p)| *p)
            .collect();
        polygon_centroid(&p)
    };
    let all = poly(&|_| true)?;
    let even = poly(&|i| i % 2 == 0)?;
    let odd = poly(&|i| i % 2 == 1)?;
    Some(Outline {
        centre: all,
        half_diff: [(even[0] - odd[0]).abs(), (even[1] - odd[1]).abs()],
        cut_fraction: (BOUNDARY_RAYS - ok + outer) as f64 / BOUNDARY_RAYS as f64,
    })
}

/// Area centroid of a simple polygon (shoelace).
fn polygon_centroid(p: &[[f64; 2]]) -> Option<[f64; 2]> {
    if p.len() < 3 {
        return None;
    }
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..p.len() {
        let (x0, y0) = (p[i][0], p[i][1]);
        let (x1, y1) = (p[(i + 1) % p.len()][0], p[(i + 1) % p.len()][1]);
        let cross = x0 * y1 - x1 * y0;
        a += cross;
        cx += (x0 + x1) * cross;
        cy += (y0 + y1) * cross;
    }
    if a.abs() < 1e-9 {
        return None;
    }
    Some([cx / (3.0 * a), cy / (3.0 * a)])
}
