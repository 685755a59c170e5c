//! Where the disc is: a first estimate from a two-class (Otsu) split of the grey levels, then
//! sub-pixel edge points along rays from that estimate (the steepest bright-to-dark descent of
//! the radial profile, smoothed with a derivative-of-Gaussian).

use super::grey::{median_f32, GreyImage};

/// The first estimate of the disc and the grey levels of the two classes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Initial {
    pub cx: f64,
    pub cy: f64,
    pub r: f64,
    /// Median grey level of the bright (disc) class, DN.
    pub inside_dn: f64,
    /// Median grey level of the dark class, DN.
    pub outside_dn: f64,
    /// Fraction of the image in the bright class.
    pub bright_fraction: f64,
}

/// Levels above this quantile are clipped before the Otsu split, so hot spots (a few per cent
/// of the frame at most) cannot form the bright class on their own. The disc must cover more
/// than this share of the frame.
const CLIP_QUANTILE: f64 = 0.95;

/// Otsu threshold of the grey levels (256 bins over the range up to the clip quantile).
fn otsu(data: &[f32]) -> f32 {
    let lo = data.iter().fold(f32::MAX, |a, &v| a.min(v));
    let mut sample: Vec<f32> = data.iter().step_by(7).copied().collect();
    let q = ((sample.len() as f64 * CLIP_QUANTILE) as usize).min(sample.len().saturating_sub(1));
    let hi = match sample.is_empty() {
        true => lo,
        false => *sample.select_nth_unstable_by(q, |a, b| a.total_cmp(b)).1,
    };
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return hi;
    }
    let bins = 256usize;
    let scale = (bins - 1) as f32 / (hi - lo);
    let mut hist = vec![0u64; bins];
    for &v in data {
        hist[((v.min(hi) - lo) * scale) as usize] += 1;
    }
    let total = data.len() as f64;
    let sum_all: f64 = hist
        .iter()
        .enumerate()
        .map(|(i, &h)| i as f64 * h as f64)
        .sum();
    let (mut w0, mut sum0, mut best, mut best_t) = (0.0, 0.0, -1.0, 0usize);
    for (t, &h) in hist.iter().enumerate() {
        w0 += h as f64;
        sum0 += t as f64 * h as f64;
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let (m0, m1) = (sum0 / w0, (sum_all - sum0) / w1);
        let between = w0 * w1 * (m0 - m1) * (m0 - m1);
        if between > best {
            best = between;
            best_t = t;
        }
    }
    lo + (best_t as f32 + 0.5) / scale
}

/// The bright class's centroid and equivalent-area radius. The largest connected part is not
/// isolated: hot spots are small next to the disc and only nudge the estimate, which the edge
/// search absorbs.
pub(crate) fn initial_estimate(g: &GreyImage) -> Option<Initial> {
    let t = otsu(&g.data);
    let (mut n, mut su, mut sv) = (0usize, 0.0f64, 0.0f64);
    let mut bright = Vec::new();
    let mut dark = Vec::new();
    for j in 0..g.height {
        for i in 0..g.width {
            let v = g.at(i, j);
            if v > t {
                n += 1;
                su += i as f64 + 0.5;
                sv += j as f64 + 0.5;
                if (i + j) % 3 == 0 {
                    bright.push(v);
                }
            } else if (i + j) % 3 == 0 {
                dark.push(v);
            }
        }
    }
    if n == 0 || bright.is_empty() || dark.is_empty() {
        return None;
    }
    Some(Initial {
        cx: su / n as f64,
        cy: sv / n as f64,
        r: (n as f64 / std::f64::consts::PI).sqrt(),
        inside_dn: median_f32(&mut bright) as f64,
        outside_dn: median_f32(&mut dark) as f64,
        bright_fraction: n as f64 / g.data.len() as f64,
    })
}

/// Radial profile sampling step, px.
pub(crate) const STEP_PX: f64 = 0.5;

/// One ray from a centre: samples at radii `r0 + k STEP_PX`, each the mean over `spread` parallel
/// angles around `angle` (none when any sample leaves the image).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Ray {
    pub angle: f64,
    pub r0: f64,
    pub values: Vec<f64>,
}

impl Ray {
    /// Samples the ray at `angle` (radians, image x right, y down) from `centre` between radii
    /// `r0` and `r1`, averaging `sub` rays spread over `spread_rad`. `None` if it leaves the image.
    pub(crate) fn sample(
        g: &GreyImage,
        centre: [f64; 2],
        angle: f64,
        r0: f64,
        r1: f64,
        sub: usize,
        spread_rad: f64,
    ) -> Option<Ray> {
        let n = ((r1 - r0) / STEP_PX).floor() as usize + 1;
        let sub = sub.max(1);
        let dirs: Vec<(f64, f64)> = (0..sub)
            .map(|s| {
                let off = if sub == 1 {
                    0.0
                } else {
                    spread_rad * (s as f64 / (sub - 1) as f64 - 0.5)
                };
                let (sn, cs) = (angle + off).sin_cos();
                (cs, sn)
            })
            .collect();
        let mut values = Vec::with_capacity(n);
        for k in 0..n {
            let r = r0 + k as f64 * STEP_PX;
            let mut acc = 0.0;
            for &(cs, sn) in &dirs {
                acc += g.sample(centre[0] + r * cs, centre[1] + r * sn)?;
            }
            values.push(acc / sub as f64);
        }
        Some(Ray { angle, r0, values })
    }

    /// Radius of sample `k`.
    #[inline]
    pub(crate) fn radius(&self, k: usize) -> f64 {
        self.r0 + k as f64 * STEP_PX
    }

    /// Mean of the samples with radius in [a, b].
    pub(crate) fn mean_between(&self, a: f64, b: f64) -> Option<f64> {
        let (mut s, mut n) = (0.0, 0usize);
        for (k, v) in self.values.iter().enumerate() {
            let r = self.radius(k);
            if r >= a && r <= b {
                s += v;
                n += 1;
            }
        }
        (n > 0).then(|| s / n as f64)
    }
}

/// Derivative-of-Gaussian filter (sigma in samples) of `v`, edges clamped.
pub(crate) fn gaussian_derivative(v: &[f64], sigma: f64) -> Vec<f64> {
    let half = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f64> = (-half..=half)
        .map(|x| {
            let x = x as f64;
            -x * (-0.5 * x * x / (sigma * sigma)).exp()
        })
        .collect();
    let norm: f64 = (-half..=half)
        .zip(&kernel)
        .map(|(x, k)| -(x as f64) * k)
        .sum();
    let n = v.len() as isize;
    (0..n)
        .map(|i| {
            let mut acc = 0.0;
            for (t, k) in (-half..=half).zip(&kernel) {
                let idx = (i - t).clamp(0, n - 1) as usize;
                acc += k * v[idx];
            }
            acc / norm
        })
        .collect()
}

/// An edge found on one ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct EdgePoint {
    pub angle: f64,
    /// Radius of the edge along the ray, px.
    pub radius: f64,
    /// Image position, px.
    pub x: f64,
    pub y: f64,
    /// Mean level just inside minus just outside, DN.
    pub contrast: f64,
}

/// The steepest bright-to-dark descent on `ray` (sub-pixel by a parabola through the three
/// filtered samples around the minimum) and its step contrast.
pub(crate) fn edge_on_ray(ray: &Ray, centre: [f64; 2], smoothing_px: f64) -> Option<EdgePoint> {
    if ray.values.len() < 8 {
        return None;
    }
    let d = gaussian_derivative(&ray.values, (smoothing_px / STEP_PX).max(1.0));
    let margin = 2;
    let (mut k, mut best) = (0usize, f64::MAX);
    for (i, &v) in d.iter().enumerate().take(d.len() - margin).skip(margin) {
        if v < best {
            best = v;
            k = i;
        }
    }
    if best >= 0.0 || k == 0 {
        return None;
    }
    let (a, b, c) = (d[k - 1], d[k], d[k + 1]);
    let denom = a - 2.0 * b + c;
    let frac = if denom.abs() > 1e-12 {
        (0.5 * (a - c) / denom).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let radius = ray.radius(k) + frac * STEP_PX;
    let w = 2.0 * smoothing_px + 2.0;
    let inside = ray.mean_between(radius - w - 8.0, radius - w)?;
    let outside = ray.mean_between(radius + w, radius + w + 8.0)?;
    let (sn, cs) = ray.angle.sin_cos();
    Some(EdgePoint {
        angle: ray.angle,
        radius,
        x: centre[0] + radius * cs,
        y: centre[1] + radius * sn,
        contrast: inside - outside,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_a_blurred_step_to_a_fraction_of_a_pixel() {
        // A disc of radius 40.3 at (60.2, 50.7), edge blurred with sigma 2 px, level 100 on 10.
        let (w, h) = (128, 112);
        let (cx, cy, r) = (60.2, 50.7, 40.3);
        let mut data = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let d = (i as f64 + 0.5 - cx).hypot(j as f64 + 0.5 - cy) - r;
                data.push((10.0 + 90.0 / (1.0 + (1.702 * d / 2.0).exp())) as f32);
            }
        }
        let g = GreyImage::from_values(w, h, data).expect("image");
        let init = initial_estimate(&g).expect("disc");
        assert!(
            (init.cx - cx).abs() < 0.5 && (init.r - r).abs() < 1.0,
            "{init:?}"
        );
        assert!(init.inside_dn > 90.0 && init.outside_dn < 15.0, "{init:?}");
        for a in [0.0f64, 1.0, 2.5, 4.0] {
            let ray = Ray::sample(&g, [cx, cy], a, 25.0, 55.0, 1, 0.0).expect("inside");
            let e = edge_on_ray(&ray, [cx, cy], 1.0).expect("edge");
            assert!((e.radius - r).abs() < 0.1, "angle {a}: {}", e.radius);
            assert!(e.contrast > 80.0, "{e:?}");
        }
    }
}
