//! The disc radius from the azimuthal median radial profile: a blurred step (normal CDF) with a
//! scattering ring (Gaussian) centred on the edge, on a constant outside level, fitted by damped
//! Gauss-Newton (Levenberg-Marquardt). The steepest-descent edge is pulled outwards by the ring
//! when the image is blurred; the model fit is not. The centre is unaffected (the ring is
//! concentric), so only the radius is refined.

use nalgebra::{DMatrix, DVector};

/// erf with |error| < 1.5e-7 (Abramowitz and Stegun 7.1.26).
fn erf(x: f64) -> f64 {
    let s = x.signum();
    let x = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    s * y
}

/// Parameters: radius, blur sigma, step height, ring height, ring sigma, outside level,
/// inside slope (DN per px).
fn model(p: &[f64], r: f64) -> f64 {
    let (rad, sigma, a, b, s, c, g) = (
        p[0],
        p[1].abs().max(0.05),
        p[2],
        p[3],
        p[4].abs().max(0.3),
        p[5],
        p[6],
    );
    let step = 0.5 * (1.0 + erf((rad - r) / (sigma * std::f64::consts::SQRT_2)));
    c + (a + g * (r - rad)) * step + b * (-0.5 * ((r - rad) / s).powi(2)).exp()
}

/// The fitted radius and its 1-sigma uncertainty, px, and the blur sigma of the edge, px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct EdgeModelFit {
    pub radius: f64,
    pub sigma_radius: f64,
    pub blur_sigma: f64,
}

/// Fits the model to samples (radius, level) around `r_start`. `None` when it does not converge.
pub(crate) fn fit(
    samples: &[(f64, f64)],
    r_start: f64,
    inside: f64,
    outside: f64,
) -> Option<EdgeModelFit> {
    let n = samples.len();
    if n < 12 {
        return None;
    }
    let mut p = start(samples, r_start, inside, outside);
    let m = p.len();
    let mut lambda = 1e-3;
    let mut current = cost(samples, &p);
    let mut jtj = DMatrix::<f64>::zeros(m, m);
    for _ in 0..200 {
        let (jac, res) = linearise(samples, &p);
        jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &res;
        let Some((q, c)) = damped_step(samples, &p, &jtj, &jtr, current, &mut lambda) else {
            break;
        };
        let gain = current - c;
        p = q;
        current = c;
        let improved = gain > 1e-12 * current.max(1e-12);
        if !improved {
            break;
        }
    }
    let dof = n.saturating_sub(m).max(1) as f64;
    let cov = jtj.try_inverse()? * (current / dof);
    let sigma_radius = cov[(0, 0)].max(0.0).sqrt();
    (p[0].is_finite() && sigma_radius.is_finite()).then_some(EdgeModelFit {
        radius: p[0],
        sigma_radius,
        blur_sigma: p[1].abs(),
    })
}

/// Starting parameters: the edge at `r_start`, 1.5 px blur, the step between the class levels,
/// the ring from the highest sample within 6 px of `r_start` (5 px wide), no inside slope.
fn start(samples: &[(f64, f64)], r_start: f64, inside: f64, outside: f64) -> Vec<f64> {
    let peak = samples
        .iter()
        .filter(|(r, _)| (r - r_start).abs() < 6.0)
        .map(|&(_, v)| v)
        .fold(f64::MIN, f64::max);
    vec![
        r_start,
        1.5,
        inside - outside,
        (peak - inside).max(1.0),
        5.0,
        outside,
        0.0,
    ]
}

/// Sum of squared differences between the model with `p` and the samples.
fn cost(samples: &[(f64, f64)], p: &[f64]) -> f64 {
    samples
        .iter()
        .map(|&(r, v)| (model(p, r) - v).powi(2))
        .sum()
}

/// The model's Jacobian in the parameters at `p` (forward differences) and the residuals
/// (sample minus model), one row per sample.
fn linearise(samples: &[(f64, f64)], p: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
    let (n, m) = (samples.len(), p.len());
    let mut jac = DMatrix::<f64>::zeros(n, m);
    let mut res = DVector::<f64>::zeros(n);
    for (i, &(r, v)) in samples.iter().enumerate() {
        let f0 = model(p, r);
        res[i] = v - f0;
        for k in 0..m {
            let h = 1e-6 * p[k].abs().max(1e-3);
            let mut q = p.to_vec();
            q[k] += h;
            jac[(i, k)] = (model(&q, r) - f0) / h;
        }
    }
    (jac, res)
}

/// One Levenberg-Marquardt step from `p`: the damping `lambda` raised tenfold until the cost
/// falls below `current` (at most 12 tries), then eased by 0.3. The new parameters and their
/// cost; `None` when no try lowered it.
fn damped_step(
    samples: &[(f64, f64)],
    p: &[f64],
    jtj: &DMatrix<f64>,
    jtr: &DVector<f64>,
    current: f64,
    lambda: &mut f64,
) -> Option<(Vec<f64>, f64)> {
    for _ in 0..12 {
        let mut a = jtj.clone();
        for k in 0..p.len() {
            a[(k, k)] += *lambda * jtj[(k, k)].max(1e-9);
        }
        let Some(step) = a.lu().solve(jtr) else {
            *lambda *= 10.0;
            continue;
        };
        let q: Vec<f64> = p.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
        let c = cost(samples, &q);
        if c.is_finite() && c < current {
            *lambda = (*lambda * 0.3).max(1e-9);
            return Some((q, c));
        }
        *lambda *= 10.0;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_the_edge_under_a_ring_that_biases_the_steepest_descent() {
        let truth = [490.0, 5.0, 26.0, 17.0, 7.0, 4.0, 0.02];
        let samples: Vec<(f64, f64)> = (0..200)
            .map(|k| {
                let r = 440.0 + 0.5 * k as f64;
                (r, model(&truth, r))
            })
            .collect();
        // Steepest descent of the same profile lies well outside the edge.
        let (mut best, mut at) = (f64::MAX, 0.0);
        for w in samples.windows(2) {
            let d = w[1].1 - w[0].1;
            if d < best {
                best = d;
                at = w[0].0;
            }
        }
        assert!(at - 490.0 > 1.0, "steepest descent at {at}");
        let f = fit(&samples, at, 30.0, 4.0).expect("fit");
        assert!((f.radius - 490.0).abs() < 0.01, "{f:?}");
        assert!((f.blur_sigma - 5.0).abs() < 0.01, "{f:?}");
    }
}
