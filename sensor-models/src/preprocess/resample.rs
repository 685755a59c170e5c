//! Crop, circular mask and resize in one separable pass pair.
//!
//! The crop is a box in source coordinates (pixel centres at i + 0.5, fractional edges allowed);
//! each output pixel is a triangle-filter (bilinear) average whose support widens with the
//! downscale factor, as PIL's antialiased `resize(..., box=...)` computes it: so a 980 px crop
//! resized to 224 averages about 9 source pixels per axis instead of sampling 4 and aliasing the
//! fringes. Source pixels outside the mask circle or the image read 0 (black).

use super::source::Pixels;

/// One output pixel's source range and weights along one axis.
#[derive(Debug, Clone)]
struct Taps {
    start: i64,
    weights: Vec<f32>,
}

/// The taps of `out` output pixels covering `[box0, box0 + len)`, limited to source pixels in
/// `[lo, hi)`.
fn taps(out: usize, box0: f64, len: f64, lo: i64, hi: i64) -> Vec<Taps> {
    let scale = len / out as f64;
    let filter_scale = scale.max(1.0);
    let support = filter_scale;
    (0..out)
        .map(|u| {
            let centre = box0 + (u as f64 + 0.5) * scale;
            let first = ((centre - support + 0.5).floor() as i64).max(lo);
            let last = ((centre + support + 0.5).floor() as i64).min(hi);
            let mut weights: Vec<f32> = (first..last.max(first))
                .map(|x| {
                    let d = ((x as f64 + 0.5 - centre) / filter_scale).abs();
                    (1.0 - d).max(0.0) as f32
                })
                .collect();
            let sum: f32 = weights.iter().sum();
            if sum > 0.0 {
                weights.iter_mut().for_each(|w| *w /= sum);
            }
            Taps {
                start: first,
                weights,
            }
        })
        .collect()
}

/// The crop box, mask and output size of one resampling.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Window {
    /// Circle centre in the source's pixel coordinates.
    pub(crate) centre: [f64; 2],
    /// Circle radius and half side of the square crop, source pixels.
    pub(crate) radius: f64,
    /// Output side, pixels.
    pub(crate) out: usize,
    /// Round to 8 bits after each pass, as PIL does on 8-bit images (reference mode).
    pub(crate) quantise: bool,
    /// Black outside the circle (the network input); false keeps the whole square (displays).
    pub(crate) mask: bool,
}

/// Reusable buffers.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    row: Vec<f32>,
    across: Vec<f32>,
}

/// Resamples `src` through `w` into `out` (`w.out * w.out` pixels, channels interleaved).
pub(crate) fn resample(src: &dyn Pixels, w: Window, scratch: &mut Scratch, out: &mut [f32]) {
    let c = src.channels().count();
    let (width, height) = src.size();
    let side = 2.0 * w.radius;
    let (left, top) = (w.centre[0] - w.radius, w.centre[1] - w.radius);
    // Crop window in whole source pixels (what a crop to the box keeps).
    let (lo_x, hi_x) = (left.round() as i64, (left + side).round() as i64);
    let (lo_y, hi_y) = (top.round() as i64, (top + side).round() as i64);
    let tx = taps(w.out, left, side, lo_x, hi_x);
    let ty = taps(w.out, top, side, lo_y, hi_y);
    let rows_lo = ty.iter().map(|t| t.start).min().unwrap_or(0);
    let rows_hi = ty
        .iter()
        .map(|t| t.start + t.weights.len() as i64)
        .max()
        .unwrap_or(0);
    let cols_lo = tx.iter().map(|t| t.start).min().unwrap_or(0);
    let cols_hi = tx
        .iter()
        .map(|t| t.start + t.weights.len() as i64)
        .max()
        .unwrap_or(0);
    let n_cols = (cols_hi - cols_lo).max(0) as usize;
    let n_rows = (rows_hi - rows_lo).max(0) as usize;
    scratch.row.resize(n_cols * c, 0.0);
    scratch.across.resize(n_rows * w.out * c, 0.0);
    let r2 = w.radius * w.radius;
    for (k, y) in (rows_lo..rows_hi).enumerate() {
        let row = &mut scratch.row;
        row.fill(0.0);
        let dy = y as f64 + 0.5 - w.centre[1];
        if y >= 0 && y < height && (!w.mask || dy * dy <= r2) {
            // Pixels whose centres lie inside the circle (or the square), within the image and
            // the columns used.
            let half = if w.mask {
                (r2 - dy * dy).sqrt()
            } else {
                w.radius
            };
            let a = ((w.centre[0] - half - 0.5).ceil() as i64)
                .max(0)
                .max(cols_lo);
            let b = ((w.centre[0] + half - 0.5).floor() as i64 + 1)
                .min(width)
                .min(cols_hi);
            if b > a {
                let off = (a - cols_lo) as usize * c;
                src.row(y, a, &mut row[off..off + (b - a) as usize * c]);
            }
        }
        let dst = &mut scratch.across[k * w.out * c..(k + 1) * w.out * c];
        for (u, t) in tx.iter().enumerate() {
            let base = (t.start - cols_lo) as usize * c;
            let o = &mut dst[u * c..(u + 1) * c];
            o.fill(0.0);
            for (i, &wt) in t.weights.iter().enumerate() {
                let p = &row[base + i * c..base + (i + 1) * c];
                for (v, s) in o.iter_mut().zip(p) {
                    *v += wt * s;
                }
            }
            if w.quantise {
                o.iter_mut().for_each(|v| *v = v.round().clamp(0.0, 255.0));
            }
        }
    }
    let stride = w.out * c;
    for (v, t) in ty.iter().enumerate() {
        let o = &mut out[v * stride..(v + 1) * stride];
        o.fill(0.0);
        let first = (t.start - rows_lo) as usize;
        for (i, &wt) in t.weights.iter().enumerate() {
            let r = &scratch.across[(first + i) * stride..(first + i + 1) * stride];
            for (a, b) in o.iter_mut().zip(r) {
                *a += wt * b;
            }
        }
        if w.quantise {
            o.iter_mut().for_each(|v| *v = v.round().clamp(0.0, 255.0));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_sum_to_one_and_widen_with_the_downscale() {
        let t = taps(224, 470.0, 980.0, 470, 1450);
        assert_eq!(t.len(), 224);
        for (u, tap) in t.iter().enumerate() {
            let s: f32 = tap.weights.iter().sum();
            assert!((s - 1.0).abs() < 1e-5);
            // 4.375 source px per output px: a triangle over +-4.375 px, cut at the crop's edge.
            if (2..222).contains(&u) {
                assert!(tap.weights.len() >= 8 && tap.weights.len() <= 10, "{u}");
            }
            assert!(tap.start >= 470 && tap.start + tap.weights.len() as i64 <= 1450);
        }
        // An upscale uses two neighbours.
        let up = taps(10, 0.0, 5.0, 0, 5);
        assert!(up
            .iter()
            .all(|t| t.weights.iter().filter(|w| **w > 0.0).count() <= 2));
    }
}
