//! Circle fits to edge points: the algebraic (Kasa) fit, RANSAC for a first inlier set, and the
//! geometric least-squares fit (Gauss-Newton on the point-to-circle distances) with its
//! covariance.

use fringe_rig::seeded::SplitMix64;
use nalgebra::{Matrix3, Vector3};

/// A circle in image coordinates, px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Circle {
    pub cx: f64,
    pub cy: f64,
    pub r: f64,
}

impl Circle {
    /// Signed distance of (x, y) from the circle (positive outside).
    #[inline]
    pub(crate) fn distance(&self, x: f64, y: f64) -> f64 {
        (x - self.cx).hypot(y - self.cy) - self.r
    }
}

/// A geometric fit: the circle, the RMS distance of the points used and the 1-sigma
/// uncertainties of centre x, y and radius from the fit covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CircleFit {
    pub circle: Circle,
    pub rms_px: f64,
    pub sigma_cx: f64,
    pub sigma_cy: f64,
    pub sigma_r: f64,
    pub points: usize,
}

/// The algebraic least-squares circle (x^2 + y^2 + D x + E y + F = 0); `None` for fewer than
/// three points or collinear points.
#[cfg(test)]
pub(crate) fn algebraic(points: &[[f64; 2]]) -> Option<Circle> {
    if points.len() < 3 {
        return None;
    }
    // Centre the points for conditioning.
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p[0]).sum::<f64>() / n;
    let my = points.iter().map(|p| p[1]).sum::<f64>() / n;
    let mut a = Matrix3::zeros();
    let mut b = Vector3::zeros();
    for p in points {
        let (x, y) = (p[0] - mx, p[1] - my);
        let row = Vector3::new(x, y, 1.0);
        a += row * row.transpose();
        b += row * -(x * x + y * y);
    }
    let s = a.lu().solve(&b)?;
    let (cx, cy) = (-s[0] / 2.0, -s[1] / 2.0);
    let r2 = cx * cx + cy * cy - s[2];
    if !(r2.is_finite() && r2 > 0.0) {
        return None;
    }
    Some(Circle {
        cx: cx + mx,
        cy: cy + my,
        r: r2.sqrt(),
    })
}

/// The circle through three points; `None` when they are (nearly) collinear.
pub(crate) fn through_three(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Option<Circle> {
    let d = 2.0 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]));
    if d.abs() < 1e-9 {
        return None;
    }
    let sa = a[0] * a[0] + a[1] * a[1];
    let sb = b[0] * b[0] + b[1] * b[1];
    let sc = c[0] * c[0] + c[1] * c[1];
    let cx = (sa * (b[1] - c[1]) + sb * (c[1] - a[1]) + sc * (a[1] - b[1])) / d;
    let cy = (sa * (c[0] - b[0]) + sb * (a[0] - c[0]) + sc * (b[0] - a[0])) / d;
    let r = (a[0] - cx).hypot(a[1] - cy);
    r.is_finite().then_some(Circle { cx, cy, r })
}

/// RANSAC: the circle through three of `points` that has the most points within `tolerance_px`
/// (radius limited to `r_range`). Deterministic (seeded sampling). Returns the circle and its
/// inlier flags.
pub(crate) fn ransac(
    points: &[[f64; 2]],
    tolerance_px: f64,
    r_range: (f64, f64),
    iterations: usize,
) -> Option<(Circle, Vec<bool>)> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let mut rng = SplitMix64::new(0x5EED_C1AC_1E00_0001);
    let mut next = |m: usize| rng.below(m);
    let mut best: Option<(Circle, usize)> = None;
    for _ in 0..iterations {
        let (i, j, k) = (next(n), next(n), next(n));
        if i == j || j == k || i == k {
            continue;
        }
        let Some(c) = through_three(points[i], points[j], points[k]) else {
            continue;
        };
        if !(c.r >= r_range.0 && c.r <= r_range.1) {
            continue;
        }
        let count = points
            .iter()
            .filter(|p| c.distance(p[0], p[1]).abs() <= tolerance_px)
            .count();
        if !matches!(best, Some((_, b)) if b >= count) {
            best = Some((c, count));
        }
    }
    let (c, _) = best?;
    let inliers = points
        .iter()
        .map(|p| c.distance(p[0], p[1]).abs() <= tolerance_px)
        .collect();
    Some((c, inliers))
}

/// Geometric least squares: minimises the sum of squared distances of `points` to the circle by
/// Gauss-Newton from `start`. The covariance is s^2 (J^T J)^-1 with s^2 = RSS / (n - 3).
pub(crate) fn geometric(points: &[[f64; 2]], start: Circle) -> Option<CircleFit> {
    let n = points.len();
    if n < 4 {
        return None;
    }
    let mut c = start;
    let mut jtj = Matrix3::zeros();
    for _ in 0..50 {
        jtj = Matrix3::zeros();
        let mut jtr = Vector3::zeros();
        for p in points {
            let (dx, dy) = (p[0] - c.cx, p[1] - c.cy);
            let rho = dx.hypot(dy).max(1e-12);
            let res = rho - c.r;
            // d(res)/d(cx, cy, r)
            let j = Vector3::new(-dx / rho, -dy / rho, -1.0);
            jtj += j * j.transpose();
            jtr += j * res;
        }
        let step = jtj.lu().solve(&(-jtr))?;
        c = Circle {
            cx: c.cx + step[0],
            cy: c.cy + step[1],
            r: c.r + step[2],
        };
        if !(c.cx.is_finite() && c.cy.is_finite() && c.r.is_finite() && c.r > 0.0) {
            return None;
        }
        if step.norm() < 1e-9 {
            break;
        }
    }
    let rss: f64 = points.iter().map(|p| c.distance(p[0], p[1]).powi(2)).sum();
    let s2 = rss / (n - 3) as f64;
    let cov = jtj.try_inverse()? * s2;
    Some(CircleFit {
        circle: c,
        rms_px: (rss / n as f64).sqrt(),
        sigma_cx: cov[(0, 0)].max(0.0).sqrt(),
        sigma_cy: cov[(1, 1)].max(0.0).sqrt(),
        sigma_r: cov[(2, 2)].max(0.0).sqrt(),
        points: n,
    })
}

/// Robust fit: RANSAC inliers, then the geometric fit repeated with the inlier band re-set to
/// three robust sigmas of the residuals (at least `min_band_px`) until the inlier set settles.
/// Returns the fit and the final inlier flags.
pub(crate) fn robust(
    points: &[[f64; 2]],
    ransac_tolerance_px: f64,
    min_band_px: f64,
    r_range: (f64, f64),
) -> Option<(CircleFit, Vec<bool>)> {
    let (start, mut inliers) = ransac(points, ransac_tolerance_px, r_range, 400)?;
    let mut fit = geometric(&select(points, &inliers), start)?;
    for _ in 0..10 {
        let mut abs: Vec<f64> = points
            .iter()
            .zip(&inliers)
            .filter(|(_, &k)| k)
            .map(|(p, _)| fit.circle.distance(p[0], p[1]).abs())
            .collect();
        // Median absolute residual -> Gaussian sigma.
        let sigma = super::grey::median_f64(&mut abs) / 0.6745;
        let band = (3.0 * sigma).max(min_band_px);
        let next: Vec<bool> = points
            .iter()
            .map(|p| fit.circle.distance(p[0], p[1]).abs() <= band)
            .collect();
        if next == inliers {
            break;
        }
        inliers = next;
        fit = geometric(&select(points, &inliers), fit.circle)?;
    }
    let used = select(points, &inliers);
    let residuals: Vec<f64> = used
        .iter()
        .map(|p| fit.circle.distance(p[0], p[1]))
        .collect();
    let k = correlation_inflation(&residuals).sqrt();
    fit.sigma_cx *= k;
    fit.sigma_cy *= k;
    fit.sigma_r *= k;
    Some((fit, inliers))
}

/// Variance inflation for residuals correlated along their order (points in angle order):
/// 1 + 2 sum of the lag autocorrelations up to the first that is not positive (at least 1).
/// Independent residuals give about 1; blurred hot spots, which bias runs of neighbouring edge
/// points together, give more, so the uncertainties are not understated.
pub(crate) fn correlation_inflation(residuals: &[f64]) -> f64 {
    let n = residuals.len();
    if n < 8 {
        return 1.0;
    }
    let mean = residuals.iter().sum::<f64>() / n as f64;
    let d: Vec<f64> = residuals.iter().map(|r| r - mean).collect();
    let var: f64 = d.iter().map(|x| x * x).sum::<f64>() / n as f64;
    if var <= 0.0 {
        return 1.0;
    }
    let mut sum = 0.0;
    for lag in 1..n / 4 {
        let rho = d[..n - lag]
            .iter()
            .zip(&d[lag..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / (n as f64 * var);
        if rho <= 0.0 {
            break;
        }
        sum += rho;
    }
    (1.0 + 2.0 * sum).max(1.0)
}

fn select(points: &[[f64; 2]], keep: &[bool]) -> Vec<[f64; 2]> {
    points
        .iter()
        .zip(keep)
        .filter(|(_, &k)| k)
        .map(|(p, _)| *p)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(c: Circle, n: usize, noise: f64) -> Vec<[f64; 2]> {
        let mut rng = SplitMix64::new(7);
        (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                let e = noise * (rng.uniform() - 0.5) * 3.46;
                [c.cx + (c.r + e) * a.cos(), c.cy + (c.r + e) * a.sin()]
            })
            .collect()
    }

    #[test]
    fn robust_fit_ignores_outliers_and_reports_uncertainty() {
        let truth = Circle {
            cx: 990.3,
            cy: 600.7,
            r: 490.2,
        };
        let mut pts = ring(truth, 720, 0.3);
        // 20 % gross outliers 15-25 px outside (hot spots).
        for (k, p) in pts.iter_mut().enumerate() {
            if k % 5 == 0 {
                let (dx, dy) = (p[0] - truth.cx, p[1] - truth.cy);
                let s = (truth.r + 15.0 + (k % 11) as f64) / truth.r;
                *p = [truth.cx + dx * s, truth.cy + dy * s];
            }
        }
        let plain = algebraic(&pts).expect("fit");
        assert!((plain.r - truth.r).abs() > 2.0, "outliers bias a plain fit");
        let (fit, inliers) = robust(&pts, 2.0, 0.5, (100.0, 1000.0)).expect("fit");
        assert!((fit.circle.cx - truth.cx).abs() < 0.05, "{fit:?}");
        assert!((fit.circle.cy - truth.cy).abs() < 0.05, "{fit:?}");
        assert!((fit.circle.r - truth.r).abs() < 0.05, "{fit:?}");
        assert_eq!(inliers.iter().filter(|&&k| k).count(), 576);
        assert!(fit.rms_px > 0.2 && fit.rms_px < 0.4, "{fit:?}");
        // sigma of the radius ~ rms / sqrt(n)
        assert!(fit.sigma_r > 0.005 && fit.sigma_r < 0.03, "{fit:?}");
        assert!(through_three([0.0, 0.0], [1.0, 1.0], [2.0, 2.0]).is_none());
        // Runs of equal residuals (correlated) inflate the variance; alternating ones do not.
        let runs: Vec<f64> = (0..200)
            .map(|k| if (k / 10) % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        assert!(correlation_inflation(&runs) > 5.0);
        let alternating: Vec<f64> = (0..200)
            .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        assert_eq!(correlation_inflation(&alternating), 1.0);
    }
}
