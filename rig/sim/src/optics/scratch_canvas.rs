//! Scratches drawn into the unloaded background of a sensor build ([`crate::optics::background`]): each
//! scratch's residual fringe order, Gaussian across its width, at the centre of each 2x2 pixel
//! block like the casting residual, and its scattered light (widened by the defocus, its energy
//! kept), added after the polariser like the rim's glow.

use crate::optics::scratch::{Scratch, FWHM_PER_SIGMA};
use crate::optics::sensor::SensorGeometry;

/// The image of a sensor build the scratches are drawn into.
pub(crate) struct ScratchCanvas<'a> {
    pub(crate) geometry: &'a SensorGeometry,
    /// Defocus Gaussian sigma, px.
    pub(crate) blur_sigma_px: f64,
    pub(crate) width: usize,
    pub(crate) height: usize,
}

impl ScratchCanvas<'_> {
    /// Adds each scratch's residual order to `residual` and its scattered light to `glow`.
    pub(crate) fn add(&self, scratches: &[Scratch], residual: &mut [f32], glow: &mut [f32]) {
        for scratch in scratches {
            self.add_one(scratch, residual, glow);
        }
    }

    fn add_one(&self, scratch: &Scratch, residual: &mut [f32], glow: &mut [f32]) {
        let k = self.geometry.px_per_mm;
        let sigma_mm = scratch.width_mm / FWHM_PER_SIGMA;
        let sigma_px = (sigma_mm * k).hypot(self.blur_sigma_px);
        let peak = scratch.scatter_dn * sigma_mm * k / sigma_px;
        let reach_px = 4.0 * sigma_px.max(sigma_mm * k) + 2.0;
        let [a, b] = [scratch.from_mm, scratch.to_mm].map(|p| self.geometry.to_pixel(p[0], p[1]));
        // Whole 2x2 blocks, so that every pixel of a block gets its block's residual.
        let even_below = |v: f64| ((v.floor().max(0.0)) as usize) & !1;
        let even_above =
            |v: f64, limit: usize| (((v.ceil().max(0.0)) as usize + 2) & !1).min(limit);
        let (i0, i1) = (
            even_below(a[0].min(b[0]) - reach_px),
            even_above(a[0].max(b[0]) + reach_px, self.width),
        );
        let (j0, j1) = (
            even_below(a[1].min(b[1]) - reach_px),
            even_above(a[1].max(b[1]) + reach_px, self.height),
        );
        for j in j0..j1 {
            for i in i0..i1 {
                let idx = j * self.width + i;
                let block = [(i & !1) as f64 + 1.0, (j & !1) as f64 + 1.0];
                let d = scratch.distance_mm(self.geometry.to_sensor(block[0], block[1]));
                let order = scratch.stress_fringes * (-0.5 * (d / sigma_mm).powi(2)).exp();
                residual[idx] += order as f32;
                let d =
                    scratch.distance_mm(self.geometry.to_sensor(i as f64 + 0.5, j as f64 + 0.5));
                glow[idx] += (peak * (-0.5 * (d * k / sigma_px).powi(2)).exp()) as f32;
            }
        }
    }
}
