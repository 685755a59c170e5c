//! Frames binned into blocks of [`BIN_PX`] x [`BIN_PX`] px per colour channel and averaged over
//! frames, the bins inside the crop circle, and the noise of one binned frame.

use super::spot::ContactError;
use image::RgbImage;

/// Bin side, px.
pub(crate) const BIN_PX: usize = 4;

/// Binned per-channel image.
#[derive(Debug, Clone)]
pub(super) struct Binned {
    pub(super) bw: usize,
    pub(super) bh: usize,
    /// [channel][bin], mean DN.
    pub(super) ch: [Vec<f32>; 3],
}

pub(super) fn bin_frames(
    frames: &[RgbImage],
    what: &'static str,
    size: (u32, u32),
) -> Result<Binned, ContactError> {
    if frames.is_empty() {
        return Err(ContactError::NoFrames(what));
    }
    let (w, h) = size;
    let (bw, bh) = (w as usize / BIN_PX, h as usize / BIN_PX);
    let mut ch = [
        vec![0f32; bw * bh],
        vec![0f32; bw * bh],
        vec![0f32; bw * bh],
    ];
    for (index, f) in frames.iter().enumerate() {
        if f.dimensions() != size {
            return Err(ContactError::SizeMismatch {
                what,
                index,
                got_w: f.width(),
                got_h: f.height(),
                want_w: w,
                want_h: h,
            });
        }
        add_binned(f, bw, bh, &mut ch);
    }
    let scale = 1.0 / (frames.len() * BIN_PX * BIN_PX) as f32;
    for c in ch.iter_mut() {
        c.iter_mut().for_each(|v| *v *= scale);
    }
    Ok(Binned { bw, bh, ch })
}

/// Adds the block sums of `f` to `ch`.
fn add_binned(f: &RgbImage, bw: usize, bh: usize, ch: &mut [Vec<f32>; 3]) {
    let raw = f.as_raw();
    let w = f.width() as usize;
    let mut row_sums = vec![[0u32; 3]; bw];
    for bj in 0..bh {
        row_sums.iter_mut().for_each(|s| *s = [0; 3]);
        for j in bj * BIN_PX..(bj + 1) * BIN_PX {
            let row = &raw[j * w * 3..(j * w + bw * BIN_PX) * 3];
            for (bi, block) in row.chunks_exact(3 * BIN_PX).enumerate() {
                let s = &mut row_sums[bi];
                for px in block.chunks_exact(3) {
                    s[0] += u32::from(px[0]);
                    s[1] += u32::from(px[1]);
                    s[2] += u32::from(px[2]);
                }
            }
        }
        for (bi, s) in row_sums.iter().enumerate() {
            for c in 0..3 {
                ch[c][bj * bw + bi] += s[c] as f32;
            }
        }
    }
}

/// Centre of bin (bi, bj), px.
pub(super) fn bin_centre(bi: usize, bj: usize) -> [f64; 2] {
    let h = 0.5 * BIN_PX as f64;
    [(bi * BIN_PX) as f64 + h, (bj * BIN_PX) as f64 + h]
}

/// The bins of `bg` (from frames of `size` px) whose centre lies inside the crop circle; an
/// error for a crop circle that is not finite and positive or holds fewer than 400 bins.
pub(super) fn crop_bins(
    bg: &Binned,
    size: (u32, u32),
    centre_px: [f64; 2],
    crop_radius_px: f64,
) -> Result<Vec<usize>, ContactError> {
    let bad_crop = || ContactError::BadCrop {
        cu: centre_px[0],
        cv: centre_px[1],
        radius: crop_radius_px,
        w: size.0,
        h: size.1,
    };
    let crop_ok = crop_radius_px.is_finite()
        && crop_radius_px > 0.0
        && centre_px.iter().all(|c| c.is_finite());
    if !crop_ok {
        return Err(bad_crop());
    }
    let mut inside = Vec::new();
    for bj in 0..bg.bh {
        for bi in 0..bg.bw {
            let [u, v] = bin_centre(bi, bj);
            if (u - centre_px[0]).hypot(v - centre_px[1]) <= crop_radius_px {
                inside.push(bj * bg.bw + bi);
            }
        }
    }
    if inside.len() < 400 {
        return Err(bad_crop());
    }
    Ok(inside)
}

/// Robust sigma of `v` (MAD about the median, scaled to a Gaussian sigma); reorders `v`.
pub(super) fn robust_sigma(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let m = crate::optical::grey::median_f64(v);
    v.iter_mut().for_each(|x| *x = (*x - m).abs());
    crate::optical::grey::median_f64(v) / 0.6745
}

/// Per-channel noise of one binned frame from two or more `frames`: the robust spread of each
/// frame's bins (every third of `inside`) about their mean `bg`, DN.
pub(super) fn noise_between_frames(
    frames: &[RgbImage],
    bg: &Binned,
    inside: &[usize],
    size: (u32, u32),
) -> Result<[f64; 3], ContactError> {
    let mut bin_noise_dn = [0.0; 3];
    let n = frames.len() as f64;
    let mut dev: [Vec<f64>; 3] = Default::default();
    for f in frames {
        let one = bin_frames(std::slice::from_ref(f), "no-contact background", size)?;
        for (c, d) in dev.iter_mut().enumerate() {
            d.extend(
                inside
                    .iter()
                    .step_by(3)
                    .map(|&k| f64::from(one.ch[c][k] - bg.ch[c][k])),
            );
        }
    }
    for c in 0..3 {
        // Deviations from the mean of n frames have variance (n - 1) / n of a frame's.
        bin_noise_dn[c] = robust_sigma(&mut dev[c]) * (n / (n - 1.0)).sqrt();
    }
    Ok(bin_noise_dn)
}

/// Per-channel noise of one binned frame from a single frame `bg`: the robust spread of the
/// differences between horizontally neighbouring bins of `inside`, DN.
pub(super) fn noise_between_neighbours(bg: &Binned, inside: &[usize]) -> [f64; 3] {
    let bw = bg.bw;
    let mut bin_noise_dn = [0.0; 3];
    for (c, noise) in bin_noise_dn.iter_mut().enumerate() {
        let mut d: Vec<f64> = inside
            .iter()
            .filter(|&&k| k % bw + 1 < bw)
            .map(|&k| f64::from(bg.ch[c][k + 1] - bg.ch[c][k]))
            .collect();
        *noise = robust_sigma(&mut d) / std::f64::consts::SQRT_2;
    }
    bin_noise_dn
}
