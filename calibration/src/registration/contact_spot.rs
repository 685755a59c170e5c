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

use image::RgbImage;

/// Bin side, px.
pub const BIN_PX: usize = 4;
/// A bin is part of the pattern when its colour difference exceeds this many noise sigmas.
pub const THRESHOLD_SIGMAS: f64 = 5.0;
/// Least number of bins above the threshold in the window for a visible contact.
pub const MIN_SPOT_BINS: usize = 25;
/// Window radius over the radius holding 90 % of the weight.
pub const WINDOW_OVER_R90: f64 = 1.5;
/// Degree of the illumination surface.
const ILLUMINATION_DEGREE: usize = 4;

/// A press that cannot be located.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContactError {
    #[error("no frames given for the {0}")]
    NoFrames(&'static str),
    #[error(
        "frame {index} of the {what} is {got_w}x{got_h} px, the background is {want_w}x{want_h} px"
    )]
    SizeMismatch {
        what: &'static str,
        index: usize,
        got_w: u32,
        got_h: u32,
        want_w: u32,
        want_h: u32,
    },
    #[error("crop circle (centre ({cu:.1}, {cv:.1}) px, radius {radius:.1} px) holds too few pixels of the {w}x{h} px frame")]
    BadCrop {
        cu: f64,
        cv: f64,
        radius: f64,
        w: u32,
        h: u32,
    },
    #[error("the background is too dark for an illumination estimate (mean {mean_dn:.1} DN above the dark level)")]
    Dark { mean_dn: f64 },
    #[error("no contact visible: {bins} bins of {bin} px above {sigmas} noise sigmas ({noise_dn:.2} DN), need {need}")]
    NoContact {
        bins: usize,
        need: usize,
        bin: usize,
        sigmas: f64,
        noise_dn: f64,
    },
    #[error("the pattern's outline about ({u:.1}, {v:.1}) px is cut on {percent:.0} % of the rays (window {window:.0} px, {room:.0} px of room to the crop edge): press closer to the optical centre")]
    OutlineCut {
        u: f64,
        v: f64,
        percent: f64,
        window: f64,
        room: f64,
    },
    #[error("contact at ({u:.1}, {v:.1}) px is too close to the crop edge: {room:.0} px of room inside the crop circle, the pattern needs {need:.0} px; press within about {limit:.0} px of the optical centre")]
    NearCropEdge {
        u: f64,
        v: f64,
        room: f64,
        need: f64,
        limit: f64,
    },
}

/// A located contact: image px (x right, y down, pixel (i, j) centred at (i + 0.5, j + 0.5)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactSpot {
    pub u_px: f64,
    pub v_px: f64,
    /// 1-sigma from the image noise, px.
    pub sigma_u_px: f64,
    pub sigma_v_px: f64,
    /// Radius of the centroid window, px.
    pub window_px: f64,
    /// Radius holding 90 % of the pattern's weight, px.
    pub r90_px: f64,
    /// Bins above the threshold inside the window.
    pub bins: usize,
    /// Summed weight over its noise (a signal-to-noise ratio of the whole pattern).
    pub snr: f64,
    /// Pressed frames averaged.
    pub frames: usize,
}

impl ContactSpot {
    /// The larger of the two axis sigmas, px.
    pub fn sigma_px(&self) -> f64 {
        self.sigma_u_px.max(self.sigma_v_px)
    }
}

/// Binned per-channel image.
#[derive(Debug, Clone)]
struct Binned {
    bw: usize,
    bh: usize,
    /// [channel][bin], mean DN.
    ch: [Vec<f32>; 3],
}

fn bin_frames(
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

/// Robust sigma of `v` (MAD about the median, scaled to a Gaussian sigma); reorders `v`.
fn robust_sigma(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let m = crate::optical::grey::median_f64(v);
    v.iter_mut().for_each(|x| *x = (*x - m).abs());
    crate::optical::grey::median_f64(v) / 0.6745
}

/// The bins of `bg` (from frames of `size` px) whose centre lies inside the crop circle; an
/// error for a crop circle that is not finite and positive or holds fewer than 400 bins.
fn crop_bins(
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

/// Per-channel noise of one binned frame from two or more `frames`: the robust spread of each
/// frame's bins (every third of `inside`) about their mean `bg`, DN.
fn noise_between_frames(
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
fn noise_between_neighbours(bg: &Binned, inside: &[usize]) -> [f64; 3] {
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

/// The centroid window: seeded at the densest spot (weight over an 80 px box) with
/// [`WINDOW_OVER_R90`] times the radius holding 90 % of all the weight, then three times the
/// centroid iterated in it and the window re-set from the weight within it. (centre, window) px.
fn settle_window(weights: &[(f64, f64, f64, f64)]) -> ([f64; 2], f64) {
    let seed = densest(weights, 80.0);
    let r90 = radius_holding(weights, seed, 0.9);
    let mut window = WINDOW_OVER_R90 * r90;
    let mut c = seed;
    for _ in 0..3 {
        c = iterate_centroid(weights, c, window);
        let r90_now = radius_holding_within(weights, c, 0.9, window);
        window = WINDOW_OVER_R90 * r90_now.max(2.0 * BIN_PX as f64);
    }
    (c, window)
}

/// The sums over the weights in a tapered window.
struct WindowSums {
    /// Summed tapered weight.
    sw: f64,
    /// Summed tapered weight times u and v, px.
    su: f64,
    sv: f64,
    /// Summed variance of the tapered weights.
    noise2: f64,
    /// Bins inside the window.
    bins: usize,
}

impl WindowSums {
    /// The sums over `weights` in the taper of `window` about `c`.
    fn new(weights: &[(f64, f64, f64, f64)], c: [f64; 2], window: f64) -> WindowSums {
        let (mut sw, mut su, mut sv, mut noise2, mut bins) = (0.0, 0.0, 0.0, 0.0, 0usize);
        for &(u, v, w, s) in weights {
            let t = taper((u - c[0]).hypot(v - c[1]), window);
            if t <= 0.0 {
                continue;
            }
            bins += 1;
            sw += t * w;
            su += t * w * u;
            sv += t * w * v;
            noise2 += t * t * s * s;
        }
        WindowSums {
            sw,
            su,
            sv,
            noise2,
            bins,
        }
    }
}

/// The noise variance of the centroid `c` per axis, times the summed weight squared: the
/// weights' noise, tapered by `window` about `c`, times their distance from it.
fn centroid_variance(weights: &[(f64, f64, f64, f64)], c: [f64; 2], window: f64) -> [f64; 2] {
    let (cu, cv) = (c[0], c[1]);
    let (mut vu, mut vv) = (0.0, 0.0);
    for &(u, v, _, s) in weights {
        let t = taper((u - cu).hypot(v - cv), window);
        vu += (t * s * (u - cu)).powi(2);
        vv += (t * s * (v - cv)).powi(2);
    }
    [vu, vv]
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

/// Rays for the boundary refinement.
const BOUNDARY_RAYS: usize = 144;
/// Largest fraction of the rays whose outline point is missing or in the outer 10 % of the
/// window (the pattern cut by the window, i.e. by the crop edge).
pub const MAX_CUT_RAYS: f64 = 0.1;

/// The outline refinement's result.
struct Outline {
    centre: [f64; 2],
    /// |centroid(even rays) - centroid(odd rays)| per axis, px.
    half_diff: [f64; 2],
    /// Fraction of the rays without an outline point or with one beyond 0.9 of the window.
    cut_fraction: f64,
}

/// Bilinear sample of the bin map at image position (u, v) px; NaN outside.
fn sample(map: &[f32], bw: usize, bh: usize, u: f64, v: f64) -> f64 {
    let x = u / BIN_PX as f64 - 0.5;
    let y = v / BIN_PX as f64 - 0.5;
    if !(x >= 0.0 && y >= 0.0) {
        return f64::NAN;
    }
    let (i, j) = (x.floor() as usize, y.floor() as usize);
    if i + 1 >= bw || j + 1 >= bh {
        return f64::NAN;
    }
    let (fx, fy) = (x - i as f64, y - j as f64);
    let at = |a: usize, b: usize| f64::from(map[b * bw + a]);
    let top = at(i, j) + (at(i + 1, j) - at(i, j)) * fx;
    let bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * fx;
    top + (bottom - top) * fy
}

/// The centre of the pattern's outline: along rays from `c`, the radius (within `window`) where
/// the profile falls to `level` times the ray's own peak (the outermost such fall, or the first
/// beyond the peak: [`fall_on_ray`]); the area centroid
/// of the polygon through those points. A smooth change of the pattern's strength across it
/// (sensitivity varying with the residual birefringence, uneven light) scales each ray's
/// profile and leaves that radius in place. `None` when fewer than half of the rays find the
/// outline.
fn boundary_centre(
    map: &[f32],
    bw: usize,
    bh: usize,
    c: [f64; 2],
    window: f64,
    level: f64,
    outermost: bool,
) -> Option<Outline> {
    let step = 0.5 * BIN_PX as f64;
    let n_steps = (window / step).floor() as usize;
    if n_steps < 4 {
        return None;
    }
    let mut pts: Vec<Option<[f64; 2]>> = Vec::with_capacity(BOUNDARY_RAYS);
    let mut outer = 0usize;
    for r in 0..BOUNDARY_RAYS {
        let t = std::f64::consts::TAU * r as f64 / BOUNDARY_RAYS as f64;
        let (dy, dx) = t.sin_cos();
        let prof: Vec<f64> = (0..=n_steps)
            .map(|k| {
                sample(
                    map,
                    bw,
                    bh,
                    c[0] + dx * step * k as f64,
                    c[1] + dy * step * k as f64,
                )
            })
            .collect();
        let found = fall_on_ray(&prof, level, outermost).map(|at| {
            let rad = step * at;
            if rad > 0.9 * window {
                outer += 1;
            }
            [c[0] + dx * rad, c[1] + dy * rad]
        });
        pts.push(found);
    }
    outline_of(&pts, outer)
}

/// Where the profile `prof` (samples along a ray) falls to `level` times its peak, in samples
/// from its start (linear between samples). Outermost: walking inwards from the window's edge
/// to the first sample at or above the level (dark fringes inside the pattern do not end it);
/// otherwise walking outwards from the peak to the first fall below it (rings further out do
/// not extend it). Samples outside the crop circle (NaN) on the way mean the pattern may go on
/// beyond: `None`.
fn fall_on_ray(prof: &[f64], level: f64, outermost: bool) -> Option<f64> {
    let n_steps = prof.len() - 1;
    let (mut peak, mut at_peak) = (f64::MIN, 0);
    for (k, &p) in prof.iter().enumerate() {
        if p.is_finite() && p > peak {
            peak = p;
            at_peak = k;
        }
    }
    let target = level * peak;
    if outermost {
        first_crossing(prof, target, (at_peak..n_steps).rev())
    } else {
        first_crossing(prof, target, at_peak..n_steps)
    }
}

/// The first step `k` of `steps` where `prof` falls from at or above `target` at `k` to below
/// it at `k + 1`, as `k` plus the fraction of the step; `None` at a non-finite sample at `k + 1`
/// first, or when no step crosses.
fn first_crossing(prof: &[f64], target: f64, steps: impl Iterator<Item = usize>) -> Option<f64> {
    for k in steps {
        if !prof[k + 1].is_finite() {
            return None;
        }
        let (a, b) = (prof[k], prof[k + 1]);
        if a.is_finite() && b.is_finite() && a >= target && b < target {
            let f = (a - target) / (a - b);
            return Some(k as f64 + f);
        }
    }
    None
}

/// The outline from its points on [`BOUNDARY_RAYS`] rays (`None` where a ray found none), of
/// which `outer` lie beyond 0.9 of the window: the centroids of all, even and odd rays'
/// polygons (missing rays skipped, the polygon joining their neighbours). `None` when fewer
/// than half of the rays found the outline or a polygon is degenerate.
fn outline_of(pts: &[Option<[f64; 2]>], outer: usize) -> Option<Outline> {
    let ok = pts.iter().filter(|p| p.is_some()).count();
    if (ok as f64) < 0.5 * BOUNDARY_RAYS as f64 {
        return None;
    }
    let poly = |sel: &dyn Fn(usize) -> bool| -> Option<[f64; 2]> {
        let p: Vec<[f64; 2]> = pts
            .iter()
            .enumerate()
            .filter(|(i, _)| sel(*i))
            .filter_map(|(_, p)| *p)
            .collect();
        polygon_centroid(&p)
    };
    let all = poly(&|_| true)?;
    let even = poly(&|i| i % 2 == 0)?;
    let odd = poly(&|i| i % 2 == 1)?;
    Some(Outline {
        centre: all,
        half_diff: [(even[0] - odd[0]).abs(), (even[1] - odd[1]).abs()],
        cut_fraction: (BOUNDARY_RAYS - ok + outer) as f64 / BOUNDARY_RAYS as f64,
    })
}

/// Area centroid of a simple polygon (shoelace).
fn polygon_centroid(p: &[[f64; 2]]) -> Option<[f64; 2]> {
    if p.len() < 3 {
        return None;
    }
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..p.len() {
        let (x0, y0) = (p[i][0], p[i][1]);
        let (x1, y1) = (p[(i + 1) % p.len()][0], p[(i + 1) % p.len()][1]);
        let cross = x0 * y1 - x1 * y0;
        a += cross;
        cx += (x0 + x1) * cross;
        cy += (y0 + y1) * cross;
    }
    if a.abs() < 1e-9 {
        return None;
    }
    Some([cx / (3.0 * a), cy / (3.0 * a)])
}

/// Centre of bin (bi, bj), px.
fn bin_centre(bi: usize, bj: usize) -> [f64; 2] {
    let h = 0.5 * BIN_PX as f64;
    [(bi * BIN_PX) as f64 + h, (bj * BIN_PX) as f64 + h]
}

/// Magnitude of the colour difference's gradient at bin `k` of a `bw` x `bh` grid (central
/// differences over the three channels); `None` on the grid's border. NaN when a neighbour lies
/// outside the crop.
fn gradient(grid: &[Vec<f32>; 3], k: usize, bw: usize, bh: usize) -> Option<f64> {
    let (bi, bj) = (k % bw, k / bw);
    if bi == 0 || bj == 0 || bi + 1 >= bw || bj + 1 >= bh {
        return None;
    }
    let mut g2 = 0.0;
    for ch in grid {
        let dx = 0.5 * f64::from(ch[k + 1] - ch[k - 1]);
        let dy = 0.5 * f64::from(ch[k + bw] - ch[k - bw]);
        g2 += dx * dx + dy * dy;
    }
    Some(g2.sqrt())
}

fn magnitude(diff: &[Vec<f32>; 3], n: usize) -> f64 {
    let (r, g, b) = (
        f64::from(diff[0][n]),
        f64::from(diff[1][n]),
        f64::from(diff[2][n]),
    );
    (r * r + g * g + b * b).sqrt()
}

/// Least-squares gain and offset of `p` against `b` over the used bins of `inside`.
fn gain_offset(b: &[f32], p: &[f32], inside: &[usize], use_bin: &[bool]) -> (f32, f32) {
    let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&k, _) in inside.iter().zip(use_bin).filter(|(_, &u)| u) {
        let (x, y) = (f64::from(b[k]), f64::from(p[k]));
        n += 1.0;
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    let det = n * sxx - sx * sx;
    if n < 2.0 || det.abs() < 1e-9 * n * sxx.max(1.0) {
        // A flat background: offset only.
        return (1.0, if n > 0.0 { ((sy - sx) / n) as f32 } else { 0.0 });
    }
    let g = (n * sxy - sx * sy) / det;
    let o = (sy - g * sx) / n;
    (g as f32, o as f32)
}

/// Bins of `inside` usable for the gain fit: not within `radius` bins of an `above` bin.
fn dilate_exclusion(
    inside: &[usize],
    above: &[bool],
    bw: usize,
    bh: usize,
    radius: usize,
) -> Vec<bool> {
    let mut near = vec![false; bw * bh];
    for (&k, _) in inside.iter().zip(above).filter(|(_, &a)| a) {
        let (bi, bj) = (k % bw, k / bw);
        for j in bj.saturating_sub(radius)..(bj + radius + 1).min(bh) {
            for i in bi.saturating_sub(radius)..(bi + radius + 1).min(bw) {
                near[j * bw + i] = true;
            }
        }
    }
    inside.iter().map(|&k| !near[k]).collect()
}

/// Fits a degree-4 polynomial surface to the background brightness (mean of the channels minus
/// `dark_dn`) over the crop circle; returns it per bin relative to its value at the centre.
fn illumination_surface(
    bg: &Binned,
    inside: &[usize],
    centre: [f64; 2],
    crop: f64,
    dark_dn: f64,
) -> Result<Vec<f32>, ContactError> {
    let b = Brightness {
        bg,
        centre,
        crop,
        dark_dn,
    };
    let mean = inside.iter().map(|&k| b.grey(k)).sum::<f64>() / inside.len() as f64;
    if mean.is_nan() || mean <= 1.0 {
        return Err(ContactError::Dark { mean_dn: mean });
    }
    let mut keep = vec![true; inside.len()];
    let mut coef = nalgebra::DVector::<f64>::zeros(ILLUMINATION_TERMS);
    for _ in 0..2 {
        coef = fit_surface(&b, inside, &keep).ok_or(ContactError::Dark { mean_dn: mean })?;
        keep = without_specks(&b, inside, &coef);
    }
    let centre_level = surface_at(&coef, 0.0, 0.0);
    if centre_level.is_nan() || centre_level <= 1.0 {
        return Err(ContactError::Dark {
            mean_dn: centre_level,
        });
    }
    let mut out = vec![0f32; bg.ch[0].len()];
    for &k in inside {
        let (x, y) = b.xy(k);
        out[k] = (surface_at(&coef, x, y) / centre_level).max(0.05) as f32;
    }
    Ok(out)
}

/// Terms of the illumination surface.
const ILLUMINATION_TERMS: usize = (ILLUMINATION_DEGREE + 1) * (ILLUMINATION_DEGREE + 2) / 2;

/// The background's brightness as the illumination surface is fitted to it.
struct Brightness<'a> {
    bg: &'a Binned,
    /// Optical centre, px.
    centre: [f64; 2],
    /// Crop radius, px.
    crop: f64,
    dark_dn: f64,
}

impl Brightness<'_> {
    /// Mean of the channels minus the dark level at bin `k`, DN.
    fn grey(&self, k: usize) -> f64 {
        let ch = &self.bg.ch;
        (f64::from(ch[0][k]) + f64::from(ch[1][k]) + f64::from(ch[2][k])) / 3.0 - self.dark_dn
    }

    /// Position of bin `k` relative to the centre, in crop radii.
    fn xy(&self, k: usize) -> (f64, f64) {
        let [u, v] = bin_centre(k % self.bg.bw, k / self.bg.bw);
        (
            (u - self.centre[0]) / self.crop,
            (v - self.centre[1]) / self.crop,
        )
    }
}

/// The monomials x^(d-i) y^i of the surface, by degree d up to [`ILLUMINATION_DEGREE`].
fn surface_terms(x: f64, y: f64) -> Vec<f64> {
    let mut t = Vec::new();
    for d in 0..=ILLUMINATION_DEGREE {
        for i in 0..=d {
            t.push(x.powi((d - i) as i32) * y.powi(i as i32));
        }
    }
    t
}

/// The surface with coefficients `coef` at (x, y) (crop radii).
fn surface_at(coef: &nalgebra::DVector<f64>, x: f64, y: f64) -> f64 {
    surface_terms(x, y)
        .iter()
        .zip(coef.iter())
        .map(|(a, b)| a * b)
        .sum::<f64>()
}

/// Least-squares coefficients of the surface over the kept bins of `inside` (normal equations,
/// Cholesky); `None` when they are singular.
fn fit_surface(b: &Brightness, inside: &[usize], keep: &[bool]) -> Option<nalgebra::DVector<f64>> {
    let n_terms = ILLUMINATION_TERMS;
    let mut ata = nalgebra::DMatrix::<f64>::zeros(n_terms, n_terms);
    let mut atb = nalgebra::DVector::<f64>::zeros(n_terms);
    for (&k, _) in inside.iter().zip(keep).filter(|(_, &q)| q) {
        let (x, y) = b.xy(k);
        let t = surface_terms(x, y);
        let g = b.grey(k);
        for a in 0..n_terms {
            atb[a] += t[a] * g;
            for c in a..n_terms {
                ata[(a, c)] += t[a] * t[c];
            }
        }
    }
    for a in 0..n_terms {
        for c in 0..a {
            ata[(a, c)] = ata[(c, a)];
        }
    }
    Some(ata.cholesky()?.solve(&atb))
}

/// Bins of `inside` to keep for the next fit: all but specks (dust, hot pixels) beyond 4
/// robust sigmas of the residuals from the surface `coef`.
fn without_specks(b: &Brightness, inside: &[usize], coef: &nalgebra::DVector<f64>) -> Vec<bool> {
    let res: Vec<f64> = inside
        .iter()
        .map(|&k| {
            let (x, y) = b.xy(k);
            b.grey(k) - surface_at(coef, x, y)
        })
        .collect();
    let s = robust_sigma(&mut res.clone());
    res.iter().map(|r| r.abs() <= 4.0 * s.max(1e-6)).collect()
}

/// Window weight at distance `r` from the centre: 1 inside 0.8 R, a cosine taper to 0 at R.
fn taper(r: f64, window: f64) -> f64 {
    let inner = 0.8 * window;
    if r <= inner {
        1.0
    } else if r >= window {
        0.0
    } else {
        0.5 * (1.0 + (std::f64::consts::PI * (r - inner) / (window - inner)).cos())
    }
}

/// The weighted centroid inside `window` about `start`, iterated until it moves less than
/// 0.005 px (at most 100 steps).
fn iterate_centroid(weights: &[(f64, f64, f64, f64)], start: [f64; 2], window: f64) -> [f64; 2] {
    let mut c = start;
    for _ in 0..100 {
        let (mut sw, mut su, mut sv) = (0.0, 0.0, 0.0);
        for &(u, v, w, _) in weights {
            let t = taper((u - c[0]).hypot(v - c[1]), window) * w;
            sw += t;
            su += t * u;
            sv += t * v;
        }
        if sw <= 0.0 {
            return c;
        }
        let next = [su / sw, sv / sw];
        let moved = (next[0] - c[0]).hypot(next[1] - c[1]);
        c = next;
        if moved < 0.005 {
            break;
        }
    }
    c
}

/// The position with the most weight within a `box_px` square (coarse grid search).
fn densest(weights: &[(f64, f64, f64, f64)], box_px: f64) -> [f64; 2] {
    let cell = box_px / 2.0;
    let mut grid: std::collections::HashMap<(i64, i64), f64> = std::collections::HashMap::new();
    for &(u, v, w, _) in weights {
        *grid
            .entry(((u / cell).floor() as i64, (v / cell).floor() as i64))
            .or_default() += w;
    }
    let mut best = (f64::MIN, (0i64, 0i64));
    for &(i, j) in grid.keys() {
        let s: f64 = (-1..=1)
            .flat_map(|di| (-1..=1).map(move |dj| (i + di, j + dj)))
            .filter_map(|k| grid.get(&k))
            .sum();
        if s > best.0 || (s == best.0 && (i, j) < best.1) {
            best = (s, (i, j));
        }
    }
    let (i, j) = best.1;
    // Centroid of the 3x3 cells about the best one.
    let (mut sw, mut su, mut sv) = (0.0, 0.0, 0.0);
    for &(u, v, w, _) in weights {
        let (ci, cj) = ((u / cell).floor() as i64, (v / cell).floor() as i64);
        if (ci - i).abs() <= 1 && (cj - j).abs() <= 1 {
            sw += w;
            su += w * u;
            sv += w * v;
        }
    }
    if sw > 0.0 {
        [su / sw, sv / sw]
    } else {
        [(i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell]
    }
}

/// Radius about `c` holding `fraction` of all the weight.
fn radius_holding(weights: &[(f64, f64, f64, f64)], c: [f64; 2], fraction: f64) -> f64 {
    radius_holding_within(weights, c, fraction, f64::INFINITY)
}

/// Radius about `c` holding `fraction` of the weight within `limit` of `c`.
fn radius_holding_within(
    weights: &[(f64, f64, f64, f64)],
    c: [f64; 2],
    fraction: f64,
    limit: f64,
) -> f64 {
    let mut rw: Vec<(f64, f64)> = weights
        .iter()
        .map(|&(u, v, w, _)| ((u - c[0]).hypot(v - c[1]), w))
        .filter(|&(r, _)| r <= limit)
        .collect();
    rw.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = rw.iter().map(|x| x.1).sum();
    let mut acc = 0.0;
    for &(r, w) in &rw {
        acc += w;
        if acc >= fraction * total {
            return r;
        }
    }
    rw.last().map(|x| x.0).unwrap_or(0.0)
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
