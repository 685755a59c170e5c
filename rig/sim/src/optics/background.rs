//! The unloaded sensor as the camera sees it, per pixel, built once per sensor.
//!
//! Light reaching a pixel (docs/photoelastic-sim.md, "Camera artefacts"), in linear DN:
//!
//! I_c = illumination(u, v) colour_c(N, sigma_N) + glow(u, v) led_c,
//!
//! - illumination: the LED light that passes the polariser twice, with vignetting
//!   V = (1 + (r / f)^2)^-2, rim-bright shading 1 + k (r / R)^6 and the disc edge, all about the
//!   optical centre. The edge is the disc mask blurred by the defocus Gaussian (sigma = blur / 2,
//!   at least half a pixel), written with the logistic approximation of the normal CDF
//!   1 / (1 + exp(1.702 (r - R) / sigma)).
//! - colour: the blurred colour table at the fringe order N (residual birefringence plus contact).
//! - glow: light added after the polariser: the LED hot spots (Gaussians at `radius_factor` R,
//!   their variance widened by the defocus variance and their peak lowered so their energy is
//!   kept), a thin bright ring at the disc edge (widened the same way in 1-D) and the housing's
//!   ambient light.
//!
//! Residual casting birefringence is a smooth field in the sensor frame: a sum of three random
//! low-frequency plane waves scaled to mean `residual_birefringence` and +-40 % around it,
//! sampled at the centre of each 2x2 pixel block (the renderer's half-resolution grid).
//!
//! A unit's flaws (docs/photoelastic-sim.md, "Ageing of a unit"): dead LEDs (`leds.out`) give no
//! hot spot and take their share of the illumination, most on their side of the disc
//! ([`LedLoss`]); scratches (`[[surface.scratches]]`) add residual order and scattered light along
//! their line ([`crate::optics::scratch`]).

use crate::optics::blurred_colour::BlurredColourTable;
use crate::optics::scratch_canvas::ScratchCanvas;
use crate::optics::sensor::{SensorConfig, SensorGeometry};

/// Colour of the LED light added after the polariser (cool white), R G B.
pub(crate) const LED_COLOUR: [f32; 3] = [0.92, 0.97, 1.0];

/// Logistic slope that makes 1 / (1 + exp(-k x)) a close approximation of the normal CDF.
const LOGISTIC_NORMAL: f64 = 1.702;

/// Light is carried in 1/16 DN steps between the background and the output stage.
pub(crate) const LIGHT_STEPS_PER_DN: f32 = 16.0;

/// `light` (DN) in 1/16 DN steps, as stored for the unloaded sensor.
#[inline]
pub(crate) fn quantise_light(light: f32) -> u16 {
    // `as` saturates: negative light reads 0, overflow 65535.
    (light * LIGHT_STEPS_PER_DN + 0.5) as u16
}

/// The blurred colour table packed for the per-pixel loop: `f32` nodes, bilinear lookup.
#[derive(Debug, Clone)]
pub(crate) struct PackedColours {
    columns: usize,
    rows: usize,
    order_scale: f32,
    sigma_scale: f32,
    /// Row-major RGB at (order column, sigma row).
    data: Vec<[f32; 3]>,
}

impl PackedColours {
    /// Samples `table` at `columns` x `rows` nodes over its full range.
    pub(crate) fn new(table: &BlurredColourTable, columns: usize, rows: usize) -> PackedColours {
        let (columns, rows) = (columns.max(2), rows.max(2));
        let mut data = Vec::with_capacity(columns * rows);
        for j in 0..rows {
            let sigma = table.max_sigma() * j as f64 / (rows - 1) as f64;
            for i in 0..columns {
                let order = table.max_order() * i as f64 / (columns - 1) as f64;
                data.push(table.lookup(order, sigma));
            }
        }
        PackedColours {
            columns,
            rows,
            order_scale: ((columns - 1) as f64 / table.max_order()) as f32,
            sigma_scale: ((rows - 1) as f64 / table.max_sigma()) as f32,
            data,
        }
    }

    /// Colour at fringe order `order` spread over `sigma` orders (both clamped to the table).
    #[inline]
    pub(crate) fn lookup(&self, order: f32, sigma: f32) -> [f32; 3] {
        let u = (order * self.order_scale).clamp(0.0, (self.columns - 1) as f32 - 1e-3);
        let v = (sigma * self.sigma_scale).clamp(0.0, (self.rows - 1) as f32 - 1e-3);
        let (i, j) = (u as usize, v as usize);
        let (fu, fv) = (u - i as f32, v - j as f32);
        let k = j * self.columns + i;
        let (a, b) = (self.data[k], self.data[k + 1]);
        let (c, d) = (self.data[k + self.columns], self.data[k + self.columns + 1]);
        let mut out = [0.0f32; 3];
        for ch in 0..3 {
            let top = a[ch] + (b[ch] - a[ch]) * fu;
            let bottom = c[ch] + (d[ch] - c[ch]) * fu;
            out[ch] = top + (bottom - top) * fv;
        }
        out
    }
}

/// Light below this illumination (DN) is treated as outside the disc.
pub(crate) const DARK_DN: f32 = 0.01;

/// Linear light of a pixel that sees `illumination` times the fringe colour `rgb` plus `glow`.
#[inline]
pub(crate) fn pixel_light(illumination: f32, rgb: [f32; 3], glow: f32) -> [f32; 3] {
    [0, 1, 2].map(|c| channel_light(illumination, rgb[c], glow, c))
}

/// Channel `c` (0 red, 1 green, 2 blue) of [`pixel_light`], with that channel's colour `colour`.
#[inline(always)]
pub(crate) fn channel_light(illumination: f32, colour: f32, glow: f32, c: usize) -> f32 {
    illumination * colour + glow * LED_COLOUR[c]
}

pub(crate) use fringe_rig::seeded::{splitmix64, uniform};

/// The unloaded sensor image and the per-pixel terms the renderer needs for loaded pixels.
#[derive(Debug, Clone)]
pub(crate) struct Background {
    width: usize,
    height: usize,
    /// Light through the polariser at full fringe brightness, DN.
    illumination: Vec<f32>,
    /// Light added after the polariser, DN (times [`LED_COLOUR`]).
    glow: Vec<f32>,
    /// Residual fringe order.
    residual: Vec<f32>,
    /// Per row, the columns [start, end) with illumination above [`DARK_DN`].
    spans: Vec<(usize, usize)>,
}

impl Background {
    /// Builds the per-pixel terms of `config` seen through `geometry`.
    pub(crate) fn new(config: &SensorConfig, geometry: &SensorGeometry) -> Background {
        let (width, height) = (
            config.geometry.width as usize,
            config.geometry.height as usize,
        );
        let o = &config.optics;
        let radius = config.geometry.disc_radius_px;
        let blur_sigma = (0.5 * o.blur_px).max(0.5);
        let [cu, cv] = geometry.centre_px;
        let focal = o.vignetting_factor * radius;
        let rim_sigma = o.rim_width_px.hypot(blur_sigma);
        let rim_peak = o.rim_glow_dn * o.rim_width_px / rim_sigma;

        let led_loss = LedLoss::new(config, geometry);
        let mut illumination = vec![0.0f32; width * height];
        let mut glow = vec![0.0f32; width * height];
        let mut spans = Vec::with_capacity(height);
        for j in 0..height {
            let v = j as f64 + 0.5 - cv;
            let (mut start, mut end) = (width, 0);
            for i in 0..width {
                let u = i as f64 + 0.5 - cu;
                let r = u.hypot(v);
                let mask = 1.0 / (1.0 + (LOGISTIC_NORMAL * (r - radius) / blur_sigma).exp());
                let q = r / focal;
                let vignetting = 1.0 / ((1.0 + q * q) * (1.0 + q * q));
                let shading = 1.0 + o.rim_shading * (r / radius).powi(6);
                let mut light = o.illumination_dn * mask * vignetting * shading;
                if let Some(loss) = &led_loss {
                    light *= loss.remaining(i as f64 + 0.5, j as f64 + 0.5);
                }
                let light = light as f32;
                let k = j * width + i;
                illumination[k] = light;
                if light > DARK_DN {
                    start = start.min(i);
                    end = i + 1;
                }
                let d = (r - radius) / rim_sigma;
                glow[k] = (o.ambient_dn + rim_peak * (-0.5 * d * d).exp()) as f32;
            }
            spans.push((start.min(end), end));
        }
        add_hot_spots(config, geometry, blur_sigma, width, height, &mut glow);

        let mut residual = residual_field(config, geometry, width, height, &spans);
        let canvas = ScratchCanvas {
            geometry,
            blur_sigma_px: blur_sigma,
            width,
            height,
        };
        canvas.add(&config.surface.scratches, &mut residual, &mut glow);
        Background {
            width,
            height,
            illumination,
            glow,
            residual,
            spans,
        }
    }

    pub(crate) fn width(&self) -> usize {
        self.width
    }

    pub(crate) fn height(&self) -> usize {
        self.height
    }

    /// Light through the polariser at full fringe brightness at pixel index `k`, DN.
    #[inline]
    #[cfg(test)]
    pub(crate) fn illumination(&self, k: usize) -> f32 {
        self.illumination[k]
    }

    /// Light added after the polariser at pixel index `k`, DN.
    #[inline]
    #[cfg(test)]
    pub(crate) fn glow(&self, k: usize) -> f32 {
        self.glow[k]
    }

    /// Row `j`'s illumination and glow, DN.
    #[inline]
    pub(crate) fn row_terms(&self, j: usize) -> (&[f32], &[f32]) {
        let range = j * self.width..(j + 1) * self.width;
        (&self.illumination[range.clone()], &self.glow[range])
    }

    /// Residual fringe order at pixel index `k`.
    #[inline]
    pub(crate) fn residual(&self, k: usize) -> f32 {
        self.residual[k]
    }

    /// Linear light of the unloaded sensor with fringe colours from `colours`, interleaved RGB
    /// in 1/16 DN steps, row by row.
    pub(crate) fn unloaded_light<'a>(
        &'a self,
        colours: &'a PackedColours,
    ) -> impl Iterator<Item = u16> + 'a {
        (0..self.width * self.height).flat_map(move |k| {
            let rgb = colours.lookup(self.residual[k], 0.0);
            pixel_light(self.illumination[k], rgb, self.glow[k]).map(quantise_light)
        })
    }

    /// Row `j`'s lit columns [start, end).
    #[inline]
    pub(crate) fn span(&self, j: usize) -> (usize, usize) {
        self.spans[j]
    }
}

/// Angle of LED `n` of the ring in the sensor frame, radians.
fn led_angle(config: &SensorConfig, n: u32) -> f64 {
    let leds = &config.leds;
    (leds.phase_deg + 360.0 * f64::from(n) / f64::from(leds.count)).to_radians()
}

/// The illumination left when LEDs have failed (`leds.out`). Each LED lights the whole disc, more
/// on its own side: a dead LED k at angle a_k (sensor frame) takes
///
/// ```text
/// (1 / count) (1 + clamp((x cos a_k + y sin a_k) / R, -1, 1))
/// ```
///
/// of the light at sensor-frame point (x, y) mm, R the disc radius in mm: 1 / count at the
/// centre, twice that at the rim next to it, nothing at the opposite rim, and 1 / count averaged
/// over the disc. The light left is 1 minus the sum over the dead LEDs, clamped to 0..=1. Its
/// angles are in the sensor frame, so it turns and mirrors with the image like the hot spots.
#[derive(Debug, Clone)]
pub(crate) struct LedLoss {
    /// Per dead LED: (x cos a_k + y sin a_k) / R as an affine function [a_u, a_v, b] of the pixel
    /// position (u, v) px.
    lobes: Vec<[f64; 3]>,
    /// 1 / count.
    share: f64,
}

impl LedLoss {
    /// The loss of `config`'s dead LEDs seen through `geometry`; `None` when every LED lights.
    pub(crate) fn new(config: &SensorConfig, geometry: &SensorGeometry) -> Option<LedLoss> {
        let dead = config.dead_leds();
        if dead.is_empty() || config.leds.count == 0 {
            return None;
        }
        let radius_mm = config.geometry.disc_radius_px / geometry.px_per_mm;
        let o = geometry.to_sensor(0.0, 0.0);
        let eu = geometry.to_sensor(1.0, 0.0);
        let ev = geometry.to_sensor(0.0, 1.0);
        let lobes = dead
            .iter()
            .map(|&k| {
                let (s, c) = led_angle(config, k).sin_cos();
                let along = |p: [f64; 2]| (p[0] * c + p[1] * s) / radius_mm;
                let b = along(o);
                [along(eu) - b, along(ev) - b, b]
            })
            .collect();
        Some(LedLoss {
            lobes,
            share: 1.0 / f64::from(config.leds.count),
        })
    }

    /// Fraction of the illumination left at image position (`u`, `v`) px.
    pub(crate) fn remaining(&self, u: f64, v: f64) -> f64 {
        let lost: f64 = self
            .lobes
            .iter()
            .map(|l| self.share * (1.0 + (l[0] * u + l[1] * v + l[2]).clamp(-1.0, 1.0)))
            .sum();
        (1.0 - lost).clamp(0.0, 1.0)
    }
}

/// Adds the LED ring's hot spots to `glow`, but for the dead LEDs (`leds.out`). LED angles are in
/// the sensor frame, so they turn and mirror with the image.
fn add_hot_spots(
    config: &SensorConfig,
    geometry: &SensorGeometry,
    blur_sigma: f64,
    width: usize,
    height: usize,
    glow: &mut [f32],
) {
    let leds = &config.leds;
    if leds.count == 0 || leds.strength_dn == 0.0 {
        return;
    }
    let sigma0 = leds.width_px / 2.354_82;
    let sigma2 = sigma0 * sigma0 + blur_sigma * blur_sigma;
    let peak = leds.strength_dn * sigma0 * sigma0 / sigma2;
    let reach = 4.0 * sigma2.sqrt();
    let ring_mm = leds.radius_factor * config.geometry.disc_radius_px / geometry.px_per_mm;
    let dead = config.dead_leds();
    for n in (0..leds.count).filter(|n| dead.binary_search(n).is_err()) {
        let a = led_angle(config, n);
        let [pu, pv] = geometry.to_pixel(ring_mm * a.cos(), ring_mm * a.sin());
        let j0 = (pv - reach).floor().max(0.0) as usize;
        let j1 = ((pv + reach).ceil().max(0.0) as usize).min(height);
        let i0 = (pu - reach).floor().max(0.0) as usize;
        let i1 = ((pu + reach).ceil().max(0.0) as usize).min(width);
        for j in j0..j1 {
            let dv = j as f64 + 0.5 - pv;
            for i in i0..i1 {
                let du = i as f64 + 0.5 - pu;
                let e = (-0.5 * (du * du + dv * dv) / sigma2).exp();
                glow[j * width + i] += (peak * e) as f32;
            }
        }
    }
}

/// Smooth residual fringe order over the lit pixels, defined in the sensor frame.
fn residual_field(
    config: &SensorConfig,
    geometry: &SensorGeometry,
    width: usize,
    height: usize,
    spans: &[(usize, usize)],
) -> Vec<f32> {
    let mean = config.optics.residual_birefringence;
    let mut out = vec![0.0f32; width * height];
    if mean == 0.0 {
        return out;
    }
    let mut state = config.seed ^ 0x005E_ED0F_B1BE;
    // Three plane waves with wavelengths 25-80 mm, random directions and phases.
    let waves: Vec<[f64; 3]> = (0..3)
        .map(|_| {
            let wavelength = 25.0 + 55.0 * uniform(&mut state);
            let direction = std::f64::consts::TAU * uniform(&mut state);
            let phase = std::f64::consts::TAU * uniform(&mut state);
            let k = std::f64::consts::TAU / wavelength;
            [k * direction.cos(), k * direction.sin(), phase]
        })
        .collect();
    for j in 0..height {
        // Every pixel of a block with a lit pixel: the renderer reads the block's top-left value.
        let top = j & !1;
        let (s0, e0) = spans[top];
        let (s1, e1) = spans[(top + 1).min(height - 1)];
        let (start, end) = (s0.min(s1).saturating_sub(1), (e0.max(e1) + 1).min(width));
        for i in start..end {
            // At the centre of the pixel's 2x2 block: the renderer samples colours per block.
            let (bu, bv) = ((i & !1) as f64 + 1.0, (j & !1) as f64 + 1.0);
            let [x, y] = geometry.to_sensor(bu, bv);
            let s: f64 = waves
                .iter()
                .map(|w| (w[0] * x + w[1] * y + w[2]).cos())
                .sum();
            out[j * width + i] = (mean * (1.0 + 0.4 * s / 3.0)) as f32;
        }
    }
    out
}
