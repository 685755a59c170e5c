//! The usable crop radius: the largest radius about the fitted centre inside which the image is
//! free of rim reflections and hot spots.
//!
//! Criterion (measured on the averaged frame): along every ray (the mean of 5 rays over 1 degree,
//! smoothed over 4 px of radius), a straight-line trend is fitted to the profile between 0.55 R
//! and 0.80 R. The ray is clean out to the first radius beyond 0.80 R where the profile leaves
//! that trend by more than T = max(15 % of the disc's inside-outside contrast, 6 times the
//! profile noise, 5 times the ray's own RMS about its trend): the rim glow and hot spots raise it,
//! the edge roll-off lowers it. The crop radius is the smallest clean radius over all rays,
//! further limited to stay clear (by 2 px) of any pixel saturated in any averaged frame.

use super::edges::{Ray, STEP_PX};
use super::grey::GreyImage;

/// Rays used for the crop radius.
const RAYS: usize = 720;

/// The crop radius (px, rounded down) about `centre` for a disc of radius `r`, with `contrast`
/// the inside-minus-outside level and `noise` the per-pixel noise sigma (DN).
pub(crate) fn crop_radius(
    g: &GreyImage,
    centre: [f64; 2],
    r: f64,
    contrast: f64,
    noise: f64,
) -> f64 {
    let (a0, a1, start) = (0.55 * r, 0.80 * r, 0.80 * r);
    // 5 rays x 8 samples (4 px) averaged.
    let profile_noise = noise / (5.0f64 * 4.0 / STEP_PX).sqrt();
    let base_t = (0.15 * contrast).max(6.0 * profile_noise);
    let mut crop = r;
    for n in 0..RAYS {
        let angle = std::f64::consts::TAU * n as f64 / RAYS as f64;
        let Some(ray) = Ray::sample(g, centre, angle, a0, 1.1 * r, 5, 1f64.to_radians()) else {
            // A ray leaving the image before 1.1 R: use what is inside.
            crop = crop.min(clean_limit_partial(g, centre, angle, r, base_t));
            continue;
        };
        if let Some(limit) = clean_limit(&ray, a0, a1, start, base_t) {
            crop = crop.min(limit);
        }
    }
    // Saturated pixels.
    let reach = crop + 2.0;
    for j in 0..g.height {
        let v = j as f64 + 0.5 - centre[1];
        if v.abs() > reach {
            continue;
        }
        for i in 0..g.width {
            if g.saturated[j * g.width + i] {
                let d = (i as f64 + 0.5 - centre[0]).hypot(v);
                if d < reach {
                    crop = crop.min(d - 2.0);
                }
            }
        }
    }
    crop.max(0.0).floor()
}

/// A ray that leaves the image before 1.1 R: clean out to where it leaves, unless the criterion
/// stops it earlier.
fn clean_limit_partial(g: &GreyImage, centre: [f64; 2], angle: f64, r: f64, t: f64) -> f64 {
    let (a0, start) = (0.55 * r, 0.80 * r);
    let mut end = 1.1 * r;
    while end > start + 4.0 {
        end -= 4.0;
        if let Some(ray) = Ray::sample(g, centre, angle, a0, end, 5, 1f64.to_radians()) {
            return clean_limit(&ray, a0, start, start, t).unwrap_or(end);
        }
    }
    start
}

/// First radius beyond `start` where the smoothed ray leaves its [a0, a1] trend by more than the
/// threshold; `None` when it never does.
fn clean_limit(ray: &Ray, a0: f64, a1: f64, start: f64, base_t: f64) -> Option<f64> {
    let half = (2.0 / STEP_PX) as usize; // 4 px box
    let n = ray.values.len();
    let smooth: Vec<f64> = (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(half), (k + half).min(n - 1));
            ray.values[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64
        })
        .collect();
    // Linear trend over [a0, a1].
    let pts: Vec<(f64, f64)> = (0..n)
        .map(|k| (ray.radius(k), smooth[k]))
        .filter(|(r, _)| *r >= a0 && *r <= a1)
        .collect();
    let m = pts.len() as f64;
    if m < 4.0 {
        return None;
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / m;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / m;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let trend = |r: f64| my + slope * (r - mx);
    let rms = (pts.iter().map(|p| (p.1 - trend(p.0)).powi(2)).sum::<f64>() / m).sqrt();
    let t = base_t.max(5.0 * rms);
    (0..n)
        .map(|k| (ray.radius(k), smooth[k]))
        .filter(|(r, _)| *r > start)
        .find(|(r, v)| (v - trend(*r)).abs() > t)
        .map(|(r, _)| r)
}
