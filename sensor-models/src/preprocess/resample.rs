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

/// The crop in whole source pixels and the taps of both axes.
struct Plan {
    tx: Vec<Taps>,
    ty: Vec<Taps>,
    cols: (i64, i64),
    rows: (i64, i64),
}

impl Plan {
    fn new(w: &Window) -> Plan {
        let side = 2.0 * w.radius;
        let (left, top) = (w.centre[0] - w.radius, w.centre[1] - w.radius);
        // Crop window in whole source pixels (what a crop to the box keeps).
        let (lo_x, hi_x) = (left.round() as i64, (left + side).round() as i64);
        let (lo_y, hi_y) = (top.round() as i64, (top + side).round() as i64);
        let tx = taps(w.out, left, side, lo_x, hi_x);
        let ty = taps(w.out, top, side, lo_y, hi_y);
        let span = |t: &[Taps]| {
            let lo = t.iter().map(|t| t.start).min().unwrap_or(0);
            let hi = t
                .iter()
                .map(|t| t.start + t.weights.len() as i64)
                .max()
                .unwrap_or(0);
            (lo, hi.max(lo))
        };
        let (cols, rows) = (span(&tx), span(&ty));
        Plan { tx, ty, cols, rows }
    }

    fn n_cols(&self) -> usize {
        (self.cols.1 - self.cols.0) as usize
    }

    /// Reads source row `y` into `row` (the plan's columns, `c` channels): pixels whose centres
    /// lie inside the circle (or the square), within the image; 0 elsewhere. Returns the range of
    /// `row` that was read (empty when nothing was).
    fn read_row(
        &self,
        src: &dyn Pixels,
        w: &Window,
        y: i64,
        row: &mut [f32],
    ) -> std::ops::Range<usize> {
        let c = src.channels().count();
        let (width, height) = src.size();
        row.fill(0.0);
        let dy = y as f64 + 0.5 - w.centre[1];
        let r2 = w.radius * w.radius;
        if y < 0 || y >= height || (w.mask && dy * dy > r2) {
            return 0..0;
        }
        let half = if w.mask {
            (r2 - dy * dy).sqrt()
        } else {
            w.radius
        };
        let a = ((w.centre[0] - half - 0.5).ceil() as i64)
            .max(0)
            .max(self.cols.0);
        let b = ((w.centre[0] + half - 0.5).floor() as i64 + 1)
            .min(width)
            .min(self.cols.1);
        if b <= a {
            return 0..0;
        }
        let off = (a - self.cols.0) as usize * c;
        let range = off..off + (b - a) as usize * c;
        src.row(y, a, &mut row[range.clone()]);
        range
    }

    /// One row across: `dst` (`out` pixels of `c` channels) from `row` (the plan's columns).
    fn across(&self, row: &[f32], c: usize, dst: &mut [f32]) {
        for (u, t) in self.tx.iter().enumerate() {
            let base = (t.start - self.cols.0) as usize * c;
            let o = &mut dst[u * c..(u + 1) * c];
            o.fill(0.0);
            for (i, &wt) in t.weights.iter().enumerate() {
                let p = &row[base + i * c..base + (i + 1) * c];
                for (v, s) in o.iter_mut().zip(p) {
                    *v += wt * s;
                }
            }
        }
    }
}

/// Resamples `src` through `w` into `out` (`w.out * w.out` pixels, channels interleaved).
pub(crate) fn resample(src: &dyn Pixels, w: Window, scratch: &mut Scratch, out: &mut [f32]) {
    let plan = Plan::new(&w);
    if w.quantise {
        across_then_down(src, &w, &plan, scratch, out);
    } else {
        down_then_across(src, &w, &plan, scratch, out);
    }
}

/// PIL's order, rounding to 8 bits after each pass (reference mode): every source row resampled
/// across, then the rows combined.
fn across_then_down(src: &dyn Pixels, w: &Window, plan: &Plan, s: &mut Scratch, out: &mut [f32]) {
    let c = src.channels().count();
    let n_rows = (plan.rows.1 - plan.rows.0) as usize;
    let stride = w.out * c;
    s.row.resize(plan.n_cols() * c, 0.0);
    s.across.resize(n_rows * stride, 0.0);
    for (k, y) in (plan.rows.0..plan.rows.1).enumerate() {
        plan.read_row(src, w, y, &mut s.row);
        let dst = &mut s.across[k * stride..(k + 1) * stride];
        plan.across(&s.row, c, dst);
        dst.iter_mut()
            .for_each(|v| *v = v.round().clamp(0.0, 255.0));
    }
    for (v, t) in plan.ty.iter().enumerate() {
        let o = &mut out[v * stride..(v + 1) * stride];
        o.fill(0.0);
        let first = (t.start - plan.rows.0) as usize;
        for (i, &wt) in t.weights.iter().enumerate() {
            let r = &s.across[(first + i) * stride..(first + i + 1) * stride];
            for (a, b) in o.iter_mut().zip(r) {
                *a += wt * b;
            }
        }
        o.iter_mut().for_each(|v| *v = v.round().clamp(0.0, 255.0));
    }
}

/// The same filter in the cheaper order (no rounding between the passes, so the result differs
/// from [`across_then_down`] only by float rounding): each source row is read once and added,
/// weighted, into the output rows whose taps hold it (whole rows at a time, which vectorise),
/// then each of the `out` rows is resampled across. A 980 px crop to 224 px resamples 224 rows
/// across instead of 980.
fn down_then_across(src: &dyn Pixels, w: &Window, plan: &Plan, s: &mut Scratch, out: &mut [f32]) {
    let c = src.channels().count();
    let width = plan.n_cols() * c;
    let stride = w.out * c;
    s.row.resize(width, 0.0);
    s.across.clear();
    s.across.resize(w.out * width, 0.0);
    // Output rows by source row: the taps of consecutive output rows start in order.
    let mut first_v = 0;
    for y in plan.rows.0..plan.rows.1 {
        while first_v < plan.ty.len()
            && plan.ty[first_v].start + plan.ty[first_v].weights.len() as i64 <= y
        {
            first_v += 1;
        }
        let read = plan.read_row(src, w, y, &mut s.row);
        if read.is_empty() {
            continue;
        }
        let row = &s.row[read.clone()];
        for (v, t) in plan.ty.iter().enumerate().skip(first_v) {
            if t.start > y {
                break;
            }
            let Some(&wt) = t.weights.get((y - t.start) as usize) else {
                continue;
            };
            let acc = &mut s.across[v * width + read.start..v * width + read.end];
            for (a, p) in acc.iter_mut().zip(row) {
                *a += wt * p;
            }
        }
    }
    for v in 0..w.out {
        plan.across(
            &s.across[v * width..(v + 1) * width],
            c,
            &mut out[v * stride..(v + 1) * stride],
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preprocess::source::{pixels, Channels, FrameRef};
    use fringe_rig::PixelFormat;

    /// Rows read once and combined down first give the filter's own value at every output pixel:
    /// the sum over both axes' taps of weight x weight x pixel (inside the circle), computed
    /// directly.
    #[test]
    fn rows_read_once_give_the_separable_filter_itself() {
        let (width, height) = (97usize, 61usize);
        let data: Vec<u8> = (0..width * height * 3)
            .map(|i| ((i * 7919 + (i / 3) * 104_729) % 251) as u8)
            .collect();
        let frame = FrameRef {
            width: width as u32,
            height: height as u32,
            format: PixelFormat::Rgb8,
            data: &data,
            cutout: None,
        };
        for (channels, mask, centre, radius, n) in [
            (Channels::Luma, true, [48.3, 30.1], 26.7, 11),
            (Channels::Rgb, true, [40.0, 35.5], 30.0, 16),
            (Channels::Rgb, false, [50.0, 30.0], 28.0, 9),
            // Reaching past the image's edges, and an upscale.
            (Channels::Luma, true, [10.0, 55.0], 20.0, 50),
        ] {
            let src = pixels(frame, channels, false);
            let c = channels.count();
            let w = Window {
                centre,
                radius,
                out: n,
                quantise: false,
                mask,
            };
            let mut out = vec![0.0f32; n * n * c];
            resample(src.as_ref(), w, &mut Scratch::default(), &mut out);
            let plan = Plan::new(&w);
            let mut px = vec![0.0f32; c];
            for (v, ty) in plan.ty.iter().enumerate() {
                for (u, tx) in plan.tx.iter().enumerate() {
                    for k in 0..c {
                        let mut want = 0.0f64;
                        for (j, wy) in ty.weights.iter().enumerate() {
                            let y = ty.start + j as i64;
                            for (i, wx) in tx.weights.iter().enumerate() {
                                let x = tx.start + i as i64;
                                let (dx, dy) =
                                    (x as f64 + 0.5 - centre[0], y as f64 + 0.5 - centre[1]);
                                let inside_circle = !mask || dx * dx + dy * dy <= radius * radius;
                                let inside_image =
                                    x >= 0 && y >= 0 && x < width as i64 && y < height as i64;
                                if inside_circle && inside_image {
                                    src.row(y, x, &mut px);
                                    want += f64::from(*wy) * f64::from(*wx) * f64::from(px[k]);
                                }
                            }
                        }
                        let got = out[(v * n + u) * c + k];
                        assert!(
                            (f64::from(got) - want).abs() < 1e-3,
                            "{channels:?} mask {mask} at ({u}, {v}) channel {k}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }

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
