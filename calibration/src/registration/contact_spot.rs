//! Where an indenter presses, seen in a frame: the centre of the fringe pattern it raises against
//! the unloaded background.
//!
//! Method ([`ContactBackground::locate`]):
//! 1. every frame is binned into blocks of [`BIN_PX`] x [`BIN_PX`] px (per colour channel);
//!    background and pressed frames are averaged over their frames;
//! 2. the pressed frame's gain and offset are fitted per channel against the background over the
//!    crop circle, away from the contact (gain drift and LED flicker change the whole frame);
//! 3. per bin the colour difference magnitude |pressed - fitted background| (RGB, DN) minus a
//!    threshold of [`THRESHOLD_SIGMAS`] noise sigmas, divided by the relative illumination there
//!    (a smooth degree-4 surface fitted to the background brightness over the crop circle: a
//!    fringe's difference scales with the light behind it, and a vignetting slope across the
//!    pattern would pull a plain centroid towards the brighter side, i.e. shrink the scale);
//! 4. the weighted centroid inside a circular window (cosine-tapered over its outer 20 %) about
//!    the estimate, iterated until it settles. The window radius is 1.5 times the radius holding
//!    90 % of the pattern's weight, shrunk to fit inside the crop circle; when that leaves less
//!    than the radius holding half the pattern, the press is too close to the edge (an error);
//! 5. the outline refinement ([`SpotSettings::boundary_level`]): along 144 rays from the
//!    centroid, the radius inside the window where the profile (colour difference, or its
//!    gradient for the thick gel) falls to a fixed fraction of that ray's own peak (the last
//!    such fall, or the first beyond the peak: [`SpotSettings::outermost`]); the centre is the
//!    area centroid of the polygon through those points, iterated 4 times. More than
//!    [`MAX_CUT_RAYS`] of the rays without an outline point in the window is
//!    [`ContactError::OutlineCut`].
//!
//! Why step 5: the casting's residual birefringence (about 0.1 fringe, varying by +-40 % over
//! 25-80 mm) adds to the contact's fringe order, so at light force the colour change per unit of
//! contact stress varies by tens of per cent across one pattern. A centroid weighted by the
//! difference, however normalised or weighted, moved 4-10 px (layered) and 10-90 px
//! (integrated, whose faint far field covers the whole disc) off the contact on the simulator;
//! without residual birefringence it was within 0.25 px. A per-ray fractional level is
//! unchanged by a smooth scaling of the pattern, and the outline of a pattern with 2-fold or
//! higher rotational symmetry (pentagon, rectangle, disc, sphere) has its area centroid at the
//! contact. Which profile and level suit a sensor: [`SpotSettings::layered`],
//! [`SpotSettings::integrated`].
//!
//! Uncertainty, per axis: the bin noise propagated through the centroid, or (larger as a rule)
//! half the difference between the outline centres from the even and the odd rays. A press with
//! fewer than [`MIN_SPOT_BINS`] bins above the threshold (in the crop circle, and in the final
//! window) is [`ContactError::NoContact`].
//!
//! This file holds the background and the method's steps in order; each step's own work is in a
//! file beside it: [`binning`] (step 1, and the bin noise), `difference` (the gain and offset fit
//! of step 2, the colour difference of step 3), `illumination` (the surface of step 3),
//! [`centroid`] (step 4), [`outline`] (step 5); [`spot`] holds the result and its errors.

pub(crate) mod binning;
pub(crate) mod centroid;
mod difference;
mod illumination;
pub(crate) mod outline;
pub(crate) mod spot;

use binning::{
    bin_centre, bin_frames, crop_bins, noise_between_frames, noise_between_neighbours, Binned,
    BIN_PX,
};
use centroid::{
    centroid_variance, iterate_centroid, radius_holding_within, settle_window, WindowSums,
};
use difference::{dilate_exclusion, gain_offset, gradient, magnitude};
use illumination::illumination_surface;
use image::RgbImage;
use outline::{boundary_centre, MAX_CUT_RAYS};
use spot::{ContactError, ContactSpot};

/// A bin is part of the pattern when its colour difference exceeds this many noise sigmas.
pub(crate) const THRESHOLD_SIGMAS: f64 = 5.0;

/// Least number of bins above the threshold in the window for a visible contact.
pub(crate) const MIN_SPOT_BINS: usize = 25;

/// The unloaded sensor, prepared for locating presses: the mean of no-contact frames, binned,
/// its noise, the relative illumination and the usable crop circle from the optical fit.
#[derive(Debug, Clone)]
pub struct ContactBackground {
    width: u32,
    height: u32,
    bg: Binned,
    /// Bins whose centre lies inside the crop circle.
    inside: Vec<usize>,
    /// Relative illumination per bin (1 at the optical centre), 0 outside the crop circle.
    illumination: Vec<f32>,
    /// Per-channel noise of one binned frame, DN.
    bin_noise_dn: [f64; 3],
    frames: usize,
    centre_px: [f64; 2],
    crop_radius_px: f64,
    settings: SpotSettings,
}

/// How the pattern is weighted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotSettings {
    /// Weigh by the gradient of the colour difference instead of its magnitude.
    pub gradient: bool,
    /// Refine the centroid by the pattern's outline where each ray falls to this fraction of
    /// its peak (0: centroid only).
    pub boundary_level: f64,
    /// Take the outermost fall to that level along each ray (else the first fall beyond the
    /// ray's peak).
    pub outermost: bool,
}

impl Default for SpotSettings {
    /// [`SpotSettings::layered`].
    fn default() -> Self {
        SpotSettings::layered()
    }
}

impl SpotSettings {
    /// For a thin photoelastic film (fringes hugging the indenter): the outline where the colour
    /// difference falls for the last time to 0.3 of each ray's peak (the pattern is compact, and
    /// its dark fringes inside would end a first-fall search early).
    pub fn layered() -> SpotSettings {
        SpotSettings {
            gradient: false,
            boundary_level: 0.3,
            outermost: true,
        }
    }

    /// For a thick photoelastic gel (rings spreading over the whole disc, a far field that falls
    /// off slowly): the outline where the gradient of the colour difference first falls to half
    /// of each ray's peak beyond it (the gradient is concentrated at the contact; rings further
    /// out would carry an outermost search away).
    pub fn integrated() -> SpotSettings {
        SpotSettings {
            gradient: true,
            boundary_level: 0.5,
            outermost: false,
        }
    }
}

/// Bins above the threshold: (u px, v px, weight, weight noise).
struct Pattern {
    weights: Vec<(f64, f64, f64, f64)>,
    above_total: usize,
    sigma_rms: f64,
    /// Colour difference magnitude over the relative illumination per bin (NaN outside the
    /// crop circle), for the boundary refinement.
    map: Vec<f32>,
}

impl ContactBackground {
    /// The same background with other weighting settings.
    pub fn with_settings(mut self, settings: SpotSettings) -> ContactBackground {
        self.settings = settings;
        self
    }

    /// From no-contact RGB frames (all the same size), the optical centre and crop radius (px)
    /// of the optical fit and the dark level (DN of the unlit housing, e.g. the optical fit's
    /// outside level; 0 if unknown) under the background.
    pub fn new(
        frames: &[RgbImage],
        centre_px: [f64; 2],
        crop_radius_px: f64,
        dark_dn: f64,
    ) -> Result<ContactBackground, ContactError> {
        let size = frames
            .first()
            .map(|f| f.dimensions())
            .ok_or(ContactError::NoFrames("no-contact background"))?;
        let bg = bin_frames(frames, "no-contact background", size)?;
        let inside = crop_bins(&bg, size, centre_px, crop_radius_px)?;
        let bin_noise_dn = if frames.len() >= 2 {
            noise_between_frames(frames, &bg, &inside, size)?
        } else {
            noise_between_neighbours(&bg, &inside)
        };
        let illumination = illumination_surface(&bg, &inside, centre_px, crop_radius_px, dark_dn)?;
        Ok(ContactBackground {
            width: size.0,
            height: size.1,
            bg,
            inside,
            illumination,
            bin_noise_dn,
            frames: frames.len(),
            centre_px,
            crop_radius_px,
            settings: SpotSettings::default(),
        })
    }

    /// Per-channel noise of one binned frame ([`BIN_PX`]^2 px), DN.
    pub fn bin_noise_dn(&self) -> [f64; 3] {
        self.bin_noise_dn
    }

    /// Frames averaged into the background.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The pattern's weight per bin of the mean of `pressed`: colour difference above the
    /// threshold over the relative illumination, as an 8-bit image of the binned frame
    /// (`BIN_PX` px per pixel) scaled so that the largest weight is 255. For looking at what
    /// [`ContactBackground::locate`] sees.
    pub fn pattern_image(&self, pressed: &[RgbImage]) -> Result<image::GrayImage, ContactError> {
        let pat = self.pattern(pressed)?;
        let max = pat.weights.iter().map(|w| w.2).fold(0.0f64, f64::max);
        let mut img = image::GrayImage::new(self.bg.bw as u32, self.bg.bh as u32);
        for &(u, v, w, _) in &pat.weights {
            let (i, j) = ((u / BIN_PX as f64) as u32, (v / BIN_PX as f64) as u32);
            let level = if max > 0.0 { 255.0 * w / max } else { 0.0 };
            img.put_pixel(i, j, image::Luma([level.round() as u8]));
        }
        Ok(img)
    }

    /// The pattern in the mean of `pressed`: per bin the colour difference (or its gradient)
    /// above the threshold over the relative illumination, and its map for the outline.
    fn pattern(&self, pressed: &[RgbImage]) -> Result<Pattern, ContactError> {
        let p = bin_frames(pressed, "pressed frames", (self.width, self.height))?;
        let noise_scale = (1.0 / pressed.len() as f64 + 1.0 / self.frames as f64).sqrt();
        let sig: [f64; 3] = std::array::from_fn(|c| self.bin_noise_dn[c] * noise_scale);
        let sigma_rms = ((sig[0] * sig[0] + sig[1] * sig[1] + sig[2] * sig[2]) / 3.0).sqrt();
        let threshold = THRESHOLD_SIGMAS * sigma_rms;
        let diff = self.fitted_difference(&p, sigma_rms);
        let grid = self.difference_grid(&diff);
        let (weights, above_total) = self.weights(&diff, &grid, threshold, sigma_rms);
        let map = self.outline_map(&diff, &grid);
        Ok(Pattern {
            weights,
            above_total,
            sigma_rms,
            map,
        })
    }

    /// Per channel and bin of `inside`, the pressed frame `p` minus the background with its
    /// gain and offset fitted: first an offset from the median difference (robust to the
    /// pattern covering less than half the crop), then least squares away from the pattern,
    /// three times.
    fn fitted_difference(&self, p: &Binned, sigma_rms: f64) -> [Vec<f32>; 3] {
        let mut diff: [Vec<f32>; 3] = std::array::from_fn(|c| {
            let mut d: Vec<f64> = self
                .inside
                .iter()
                .map(|&k| f64::from(p.ch[c][k] - self.bg.ch[c][k]))
                .collect();
            let o = crate::optical::grey::median_f64(&mut d) as f32;
            self.inside
                .iter()
                .map(|&k| p.ch[c][k] - self.bg.ch[c][k] - o)
                .collect()
        });
        for _ in 0..3 {
            let use_bin = self.gain_fit_bins(&diff, sigma_rms);
            for (c, d) in diff.iter_mut().enumerate() {
                let (g, o) = gain_offset(&self.bg.ch[c], &p.ch[c], &self.inside, &use_bin);
                *d = self
                    .inside
                    .iter()
                    .map(|&k| p.ch[c][k] - (g * self.bg.ch[c][k] + o))
                    .collect();
            }
        }
        diff
    }

    /// Bins of `inside` for the gain fit: those more than 4 bins from any whose difference
    /// magnitude exceeds both 3 noise sigmas and the median (or, when that leaves fewer than a
    /// quarter, just those not above it).
    fn gain_fit_bins(&self, diff: &[Vec<f32>; 3], sigma_rms: f64) -> Vec<bool> {
        let mags: Vec<f64> = (0..self.inside.len()).map(|n| magnitude(diff, n)).collect();
        let median = crate::optical::grey::median_f64(&mut mags.clone());
        let cut = (3.0 * sigma_rms).max(median);
        let above: Vec<bool> = mags.iter().map(|m| *m > cut).collect();
        let use_bin = dilate_exclusion(&self.inside, &above, self.bg.bw, self.bg.bh, 4);
        if use_bin.iter().filter(|&&u| u).count() < self.inside.len() / 4 {
            return above.iter().map(|&a| !a).collect();
        }
        use_bin
    }

    /// The difference of `inside`'s bins laid out on the full bin grid (NaN outside the crop).
    fn difference_grid(&self, diff: &[Vec<f32>; 3]) -> [Vec<f32>; 3] {
        let mut grid: [Vec<f32>; 3] =
            std::array::from_fn(|_| vec![f32::NAN; self.bg.bw * self.bg.bh]);
        for (n, &k) in self.inside.iter().enumerate() {
            for c in 0..3 {
                grid[c][k] = diff[c][n];
            }
        }
        grid
    }

    /// The pattern's weights: colour difference (or its gradient) above `threshold` over the
    /// relative illumination, (u px, v px, weight, weight noise) per bin; and the number of
    /// bins whose colour difference is above the threshold.
    fn weights(
        &self,
        diff: &[Vec<f32>; 3],
        grid: &[Vec<f32>; 3],
        threshold: f64,
        sigma_rms: f64,
    ) -> (Vec<(f64, f64, f64, f64)>, usize) {
        let bw = self.bg.bw;
        let mut weights = Vec::new(); // (u, v, weight, weight noise)
        let mut above_total = 0usize;
        for (n, &k) in self.inside.iter().enumerate() {
            let e = magnitude(diff, n);
            if e > threshold {
                above_total += 1;
            }
            let ill = f64::from(self.illumination[k]);
            let [u, v] = bin_centre(k % bw, k / bw);
            if self.settings.gradient {
                let Some(g) = gradient(grid, k, bw, self.bg.bh) else {
                    continue;
                };
                // NaN (a neighbour outside the crop) fails the comparison.
                if g.is_nan() || g <= threshold {
                    continue;
                }
                weights.push((u, v, (g - threshold) / ill, sigma_rms / ill));
            } else if e > threshold {
                weights.push((u, v, (e - threshold) / ill, sigma_rms / ill));
            }
        }
        (weights, above_total)
    }

    /// The colour difference magnitude (or its gradient) over the relative illumination per
    /// bin, NaN outside the crop circle: the map the outline refinement samples.
    fn outline_map(&self, diff: &[Vec<f32>; 3], grid: &[Vec<f32>; 3]) -> Vec<f32> {
        let bw = self.bg.bw;
        let mut map = vec![f32::NAN; bw * self.bg.bh];
        for (n, &k) in self.inside.iter().enumerate() {
            let ill = f64::from(self.illumination[k]);
            let value = if self.settings.gradient {
                let Some(g) = gradient(grid, k, bw, self.bg.bh) else {
                    continue;
                };
                g
            } else {
                magnitude(diff, n)
            };
            map[k] = (value / ill) as f32;
        }
        map
    }

    /// Locates the contact in the mean of `pressed` (frames of one dwell).
    pub fn locate(&self, pressed: &[RgbImage]) -> Result<ContactSpot, ContactError> {
        let Pattern {
            weights,
            above_total,
            sigma_rms,
            map,
        } = self.pattern(pressed)?;
        if above_total < MIN_SPOT_BINS {
            return Err(no_contact(above_total, sigma_rms));
        }
        let (c, window) = settle_window(&weights);
        let r50 = radius_holding_within(&weights, c, 0.5, window);
        let r90 = radius_holding_within(&weights, c, 0.9, window);
        let (c, window) = self.fit_window_in_crop(&weights, c, window, r50)?;
        let sums = WindowSums::new(&weights, c, window);
        let (sw, noise2, bins) = (sums.sw, sums.noise2, sums.bins);
        if bins < MIN_SPOT_BINS || sw <= 0.0 {
            return Err(no_contact(bins, sigma_rms));
        }
        let (mut cu, mut cv) = (sums.su / sw, sums.sv / sw);
        let [mut vu, mut vv] = centroid_variance(&weights, [cu, cv], window);
        if self.settings.boundary_level > 0.0 {
            let (c, spread) = self.outline_centre(&map, [cu, cv], window)?;
            cu = c[0];
            cv = c[1];
            // Sigma from the two halves of the rays (even and odd) as well as the noise.
            vu = vu.max((0.5 * spread[0] * sw).powi(2));
            vv = vv.max((0.5 * spread[1] * sw).powi(2));
        }
        Ok(ContactSpot {
            u_px: cu,
            v_px: cv,
            sigma_u_px: vu.sqrt() / sw,
            sigma_v_px: vv.sqrt() / sw,
            window_px: window,
            r90_px: r90,
            bins,
            snr: sw / noise2.sqrt().max(f64::MIN_POSITIVE),
            frames: pressed.len(),
        })
    }

    /// Room between `c` (px) and the crop edge, px (negative outside the crop circle).
    fn room(&self, c: [f64; 2]) -> f64 {
        self.crop_radius_px - (c[0] - self.centre_px[0]).hypot(c[1] - self.centre_px[1])
    }

    /// The centroid `c` and its `window` shrunk to fit inside the crop circle (the centroid
    /// iterated in each smaller window); [`ContactError::NearCropEdge`] when that leaves less
    /// room than the radius `r50` holding half the pattern.
    fn fit_window_in_crop(
        &self,
        weights: &[(f64, f64, f64, f64)],
        mut c: [f64; 2],
        mut window: f64,
        r50: f64,
    ) -> Result<([f64; 2], f64), ContactError> {
        let mut room = self.room(c);
        if room < window {
            for _ in 0..3 {
                room = self.room(c);
                if room < r50.max(2.0 * BIN_PX as f64) {
                    break;
                }
                window = room;
                c = iterate_centroid(weights, c, window);
            }
            room = self.room(c);
            if room < r50.max(2.0 * BIN_PX as f64) {
                return Err(ContactError::NearCropEdge {
                    u: c[0],
                    v: c[1],
                    room: room.max(0.0),
                    need: r50,
                    limit: self.crop_radius_px - r50,
                });
            }
            window = window.min(room);
        }
        Ok((c, window))
    }

    /// The centre of the pattern's outline about `start` in `window` (4 iterations of
    /// [`boundary_centre`]) and the half difference of its even and odd rays per axis, px;
    /// [`ContactError::OutlineCut`] when more than [`MAX_CUT_RAYS`] of the rays are cut.
    fn outline_centre(
        &self,
        map: &[f32],
        start: [f64; 2],
        window: f64,
    ) -> Result<([f64; 2], [f64; 2]), ContactError> {
        let mut c = start;
        let mut spread = [0.0, 0.0];
        let mut cut = 1.0;
        for _ in 0..4 {
            let Some(o) = boundary_centre(
                map,
                self.bg.bw,
                self.bg.bh,
                c,
                window,
                self.settings.boundary_level,
                self.settings.outermost,
            ) else {
                cut = 1.0;
                break;
            };
            c = o.centre;
            spread = o.half_diff;
            cut = o.cut_fraction;
        }
        if cut > MAX_CUT_RAYS {
            return Err(ContactError::OutlineCut {
                u: c[0],
                v: c[1],
                percent: 100.0 * cut,
                window,
                room: self.room(c).max(0.0),
            });
        }
        Ok((c, spread))
    }
}

/// [`ContactError::NoContact`] for `bins` bins above the threshold at noise `noise_dn`.
fn no_contact(bins: usize, noise_dn: f64) -> ContactError {
    ContactError::NoContact {
        bins,
        need: MIN_SPOT_BINS,
        bin: BIN_PX,
        sigmas: THRESHOLD_SIGMAS,
        noise_dn,
    }
}

/// Draws `spot` on a copy of `frame`: a cross at the contact (arms 3 sigma + 12 px), the
/// centroid window as a circle, in `colour`, and a label with the contact and the window in px.
pub fn draw_spot(
    frame: &RgbImage,
    spot: &ContactSpot,
    colour: [u8; 3],
) -> Result<RgbImage, fringe_plot::PlotError> {
    use fringe_plot::Mark;
    let centre = [spot.u_px, spot.v_px];
    let label = format!(
        "contact at ({:.1}, {:.1}) px, centroid window radius {:.0} px",
        spot.u_px, spot.v_px, spot.window_px
    );
    fringe_plot::overlay(
        frame,
        &[
            Mark::Cross {
                centre,
                arm: 12.0 + 3.0 * spot.sigma_px(),
                colour,
            },
            Mark::Circle {
                centre,
                radius: spot.window_px,
                colour,
            },
            Mark::Label {
                at: [16.0, 16.0],
                text: label,
                colour,
            },
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat grey disc image with a symmetric bump of colour at (cu, cv), times a left-right
    /// illumination ramp.
    fn frame(bump: Option<[f64; 2]>, ramp: f64, seed: u32) -> RgbImage {
        let mut state = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
        RgbImage::from_fn(400, 320, |i, j| {
            let (u, v) = (f64::from(i) + 0.5, f64::from(j) + 0.5);
            let ill = 1.0 + ramp * (u - 200.0) / 200.0;
            let mut px = [30.0 * ill, 32.0 * ill, 40.0 * ill];
            if let Some([bu, bv]) = bump {
                let r2 = (u - bu).powi(2) + (v - bv).powi(2);
                let a = 120.0 * ill * (-r2 / (2.0 * 18.0f64.powi(2))).exp();
                px[0] += a;
                px[1] += 0.5 * a;
            }
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let n = f64::from(state % 5) - 2.0;
            image::Rgb(px.map(|x| (x + n).clamp(0.0, 255.0) as u8))
        })
    }

    #[test]
    fn finds_a_symmetric_bump_under_an_illumination_ramp_and_refuses_an_empty_frame() {
        let bg: Vec<RgbImage> = (0..3).map(|s| frame(None, 0.3, s)).collect();
        let b = ContactBackground::new(&bg, [200.0, 160.0], 150.0, 0.0).expect("background");
        let spot = b
            .locate(&[frame(Some([231.3, 140.6]), 0.3, 7)])
            .expect("spot");
        let err = (spot.u_px - 231.3).hypot(spot.v_px - 140.6);
        assert!(err < 0.3, "{spot:?}");
        assert!(spot.sigma_px() < 0.3 && spot.sigma_px() > 0.0, "{spot:?}");
        let e = b.locate(&[frame(None, 0.3, 9)]).expect_err("no contact");
        assert!(matches!(e, ContactError::NoContact { .. }), "{e}");
        let e = b
            .locate(&[RgbImage::new(10, 10)])
            .expect_err("size mismatch");
        assert!(e.to_string().contains("10x10"), "{e}");
    }
}
