//! Grey frames: any image converted to linear-ish grey levels on a 0-255 scale, averaged over
//! frames, with the pixels that were saturated in any frame marked.

use image::DynamicImage;

/// A grey image in DN on a 0-255 scale (16-bit images are scaled down), row-major.
///
/// Pixel (i, j) covers u in [i, i + 1), v in [j, j + 1): its centre is at (i + 0.5, j + 0.5).
#[derive(Debug, Clone, PartialEq)]
pub struct GreyImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
    /// Pixels that reached full scale in any channel of any averaged frame.
    pub saturated: Vec<bool>,
    /// Frames averaged into `data`.
    pub frames: usize,
}

/// A colour channel at or above this fraction of full scale counts as saturated.
const SATURATION_FRACTION: f32 = 0.998;

impl GreyImage {
    /// A grey image from a buffer of `width * height` values (DN, 0-255 scale); values of 255 and
    /// above count as saturated.
    pub fn from_values(width: usize, height: usize, data: Vec<f32>) -> Option<GreyImage> {
        if width == 0 || height == 0 || data.len() != width * height {
            return None;
        }
        let saturated = data
            .iter()
            .map(|&v| v >= 255.0 * SATURATION_FRACTION)
            .collect();
        Some(GreyImage {
            width,
            height,
            data,
            saturated,
            frames: 1,
        })
    }

    /// The mean of the colour channels of `image`, scaled to 0-255.
    pub fn from_image(image: &DynamicImage) -> GreyImage {
        let rgb = image.to_rgb32f();
        let (w, h) = (rgb.width() as usize, rgb.height() as usize);
        let mut data = Vec::with_capacity(w * h);
        let mut saturated = Vec::with_capacity(w * h);
        for p in rgb.pixels() {
            let [r, g, b] = p.0;
            data.push(255.0 * (r + g + b) / 3.0);
            saturated.push(r.max(g).max(b) >= SATURATION_FRACTION);
        }
        GreyImage {
            width: w,
            height: h,
            data,
            saturated,
            frames: 1,
        }
    }

    /// Value at pixel (i, j).
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> f32 {
        self.data[j * self.width + i]
    }

    /// Bilinear sample at image position (u, v) (pixel centres at half-integers); `None` outside
    /// the pixel centres' hull.
    #[inline]
    pub fn sample(&self, u: f64, v: f64) -> Option<f64> {
        let (x, y) = (u - 0.5, v - 0.5);
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (i, j) = (x.floor() as usize, y.floor() as usize);
        if i + 1 >= self.width || j + 1 >= self.height {
            return None;
        }
        let (fx, fy) = (x - i as f64, y - j as f64);
        let k = j * self.width + i;
        let a = self.data[k] as f64;
        let b = self.data[k + 1] as f64;
        let c = self.data[k + self.width] as f64;
        let d = self.data[k + self.width + 1] as f64;
        let top = a + (b - a) * fx;
        let bottom = c + (d - c) * fx;
        Some(top + (bottom - top) * fy)
    }

    /// Robust noise sigma (DN): median absolute difference of horizontal neighbours, scaled to a
    /// Gaussian sigma per pixel.
    pub fn noise_sigma(&self) -> f64 {
        let mut diffs: Vec<f32> = Vec::with_capacity(self.data.len() / 4);
        for j in (0..self.height).step_by(2) {
            let row = &self.data[j * self.width..(j + 1) * self.width];
            for i in (0..self.width.saturating_sub(1)).step_by(2) {
                diffs.push((row[i + 1] - row[i]).abs());
            }
        }
        if diffs.is_empty() {
            return 0.0;
        }
        let m = median_f32(&mut diffs) as f64;
        // |a - b| of two N(0, s) has median 0.6745 * sqrt(2) s.
        m / (0.6745 * std::f64::consts::SQRT_2)
    }
}

/// Median of `v` (reorders it); NaN-free input expected. 0 for an empty slice.
pub(crate) fn median_f32(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m
}

/// Median of `v` (reorders it). 0 for an empty slice.
pub(crate) fn median_f64(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m
}

/// Frames of different sizes cannot be averaged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("frame {index} is {got_w}x{got_h} px but the first frame is {want_w}x{want_h} px")]
pub struct SizeMismatch {
    pub index: usize,
    pub got_w: usize,
    pub got_h: usize,
    pub want_w: usize,
    pub want_h: usize,
}

/// The pixel-wise mean of `frames` (all the same size); saturation marks are OR-ed. `None` for
/// no frames.
pub(crate) fn average(frames: &[GreyImage]) -> Result<Option<GreyImage>, SizeMismatch> {
    let Some(first) = frames.first() else {
        return Ok(None);
    };
    let mut sum: Vec<f64> = first.data.iter().map(|&v| v as f64).collect();
    let mut saturated = first.saturated.clone();
    for (index, f) in frames.iter().enumerate().skip(1) {
        if f.width != first.width || f.height != first.height {
            return Err(SizeMismatch {
                index,
                got_w: f.width,
                got_h: f.height,
                want_w: first.width,
                want_h: first.height,
            });
        }
        for (s, &v) in sum.iter_mut().zip(&f.data) {
            *s += v as f64;
        }
        for (s, &v) in saturated.iter_mut().zip(&f.saturated) {
            *s |= v;
        }
    }
    let n = frames.len() as f64;
    Ok(Some(GreyImage {
        width: first.width,
        height: first.height,
        data: sum.into_iter().map(|s| (s / n) as f32).collect(),
        saturated,
        frames: frames.iter().map(|f| f.frames).sum(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_sampling_uses_pixel_centres_and_averaging_checks_sizes() {
        let g = GreyImage::from_values(2, 2, vec![0.0, 10.0, 20.0, 30.0]).expect("2x2");
        assert_eq!(g.sample(0.5, 0.5), Some(0.0));
        assert_eq!(g.sample(1.0, 0.5), Some(5.0));
        assert_eq!(g.sample(1.0, 1.0), Some(15.0));
        assert_eq!(g.sample(0.2, 0.5), None);
        let h = GreyImage::from_values(2, 2, vec![10.0, 10.0, 10.0, 255.0]).expect("2x2");
        let a = average(&[g.clone(), h]).expect("same size").expect("two");
        assert_eq!(a.data, vec![5.0, 10.0, 15.0, 142.5]);
        assert_eq!(a.saturated, vec![false, false, false, true]);
        assert_eq!(a.frames, 2);
        let wide = GreyImage::from_values(4, 1, vec![0.0; 4]).expect("4x1");
        let e = average(&[g, wide]).expect_err("sizes differ");
        assert_eq!(e.index, 1);
    }
}
