//! The photoelastic frame renderer: a [`Scene`] in, an interleaved RGB8 frame (or the camera's
//! BayerRG8 or Mono8 samples of it, see [`crate::optics::pixel_format`]) out.
//!
//! Follows the recipe of docs/photoelastic-sim.md ("Rendering recipe"). At start-up: the fringe
//! field N_unit and |grad N_unit| of each flat punch ([`FringeField`], packed into `f32` pairs),
//! the blurred colour table over (N, sigma_N), the per-pixel [`Background`] (illumination,
//! vignetting, rim, LED hot spots, residual birefringence), a tile of Gaussian noise and a gamma
//! table. Spheres change their Hertz contact radius with force: their fields are computed on first
//! use and cached by the contact radius rounded to [`SPHERE_RADIUS_STEP_MM`]. A contact pushed
//! sideways is drawn from a field of its own loads, built each frame from the stresses of its
//! press and traction ([`crate::optics::push_stress`], computed ahead of need) and kept while
//! the push is held.
//!
//! Per frame, at half resolution (one sample per 2x2 block of lit pixels, at the block centre):
//! map the point to the indenter frame (inverse of the [`SensorGeometry`], then the contact's
//! offset and rotation), N = F N_unit + N_residual,
//! sigma_N = F |grad N_unit| sigma_blur with sigma_blur the defocus Gaussian (blur / 2) combined
//! with the pixel footprint ([`PIXEL_SIGMA_PX`]), colour from the table; at full resolution that
//! colour times the pixel's illumination plus its glow; then gain drift, LED
//! flicker, offset drift, Poisson-Gaussian noise (variance a I + b, from a random place in the
//! noise tile) and the gamma table. Rows are split across `threads` scoped threads. The same seed,
//! session, scene and frame index give the same bytes.
//!
//! The session ([`Renderer::set_session`], a rig file's `[sim] session`, see [`crate::session`])
//! salts the per-frame noise and flicker and shifts the slow drift by a session-derived number of
//! frames: another session films the same unit with other noise. Session 0 (the default) leaves
//! the seed as it is.
//!
//! BayerRG8 and Mono8 frames go through the same stages but only for the channels they keep
//! (Bayer: one per pixel, so a third of the light and output work), with the same noise samples,
//! so they are exactly the mosaic and the grey of the RGB frame.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use crate::optics::background::{
    channel_light, quantise_light, splitmix64, uniform, Background, PackedColours,
    LIGHT_STEPS_PER_DN,
};
use crate::optics::blurred_colour::BlurredColourTable;
use crate::optics::colour::Polariser;
use crate::optics::fringe_field::FringeField;
use crate::optics::pixel_format::{bayer_channel, grey};
use crate::optics::push_stress::{Grid, PushStress, TractionField, TRACTION_LEVELS};
use crate::optics::sensor::{SensorConfig, SensorConfigError, SensorGeometry};
use crate::physics::indenter::{PressureMap, Shape};
use crate::scene::{Contact, FrameRenderer, Scene, Shear};
use crate::session;
use fringe_rig::PixelFormat;
use rustfft::num_complex::Complex;

/// Sphere fields are cached by contact radius rounded to this step, mm.
pub(crate) const SPHERE_RADIUS_STEP_MM: f64 = 0.05;

/// Standard deviation of a pixel's own footprint (a 1 px box has 0.29 px), px. Keeps dense
/// fringes from aliasing in sharp frames.
pub(crate) const PIXEL_SIGMA_PX: f64 = 0.3;

/// Output table rows: linear light 0..512 DN in 1/4 DN steps.
const LUT_ROWS: usize = 2048;
/// Light steps (1/16 DN) per output table row.
const LUT_ROW_SHIFT: u32 = 2;

/// Noise levels: a tile sample z in 0..32 stands for (z - 15.5) / 4 standard deviations
/// (+-3.9 sigma in quarter-sigma steps, finer than the 8-bit output for every noise level).
const NOISE_LEVELS: usize = 32;
const NOISE_LEVEL_BITS: u32 = 5;

/// The output table: 8-bit value at (light row, noise level). A fixed size, so that indexing it
/// with a clamped row and a masked level needs no bounds check.
type OutputTable = [u8; LUT_ROWS * NOISE_LEVELS];

/// Where the output table row of linear light `q` (1/16 DN steps) starts; the last row holds
/// all brighter light.
#[inline(always)]
fn table_row(q: u16) -> u16 {
    (q >> LUT_ROW_SHIFT).min(LUT_ROWS as u16 - 1) << NOISE_LEVEL_BITS
}

/// Gain, offset, noise and gamma of one value: the light's [`table_row`] and noise level `z` to
/// an 8-bit value.
#[inline(always)]
fn output(lut: &OutputTable, row: u16, z: u8) -> u8 {
    lut[usize::from(row | u16::from(z & (NOISE_LEVELS as u8 - 1)))]
}

/// What the output stage writes per pixel: the camera's pixel format.
trait Layout {
    const FORMAT: PixelFormat;
    const BYTES: usize;
    /// Writes the pixel at (`row`, `col`) into `out` (`BYTES` long): `light(c)` is the
    /// [`table_row`] of channel c's light, `z` the pixel's three noise levels.
    fn pixel(
        lut: &OutputTable,
        row: usize,
        col: usize,
        light: impl Fn(usize) -> u16,
        z: &[u8],
        out: &mut [u8],
    );
}

/// Interleaved RGB8.
struct Rgb;
/// The BayerRG8 mosaic: only the pixel's own channel is computed.
struct Bayer;
/// Mono8: the grey of the three output bytes.
struct Grey;

impl Layout for Rgb {
    const FORMAT: PixelFormat = PixelFormat::Rgb8;
    const BYTES: usize = 3;
    #[inline(always)]
    fn pixel(
        lut: &OutputTable,
        _row: usize,
        _col: usize,
        light: impl Fn(usize) -> u16,
        z: &[u8],
        out: &mut [u8],
    ) {
        for (c, (o, &z)) in out.iter_mut().zip(z).enumerate() {
            *o = output(lut, light(c), z);
        }
    }
}

impl Layout for Bayer {
    const FORMAT: PixelFormat = PixelFormat::BayerRg8;
    const BYTES: usize = 1;
    #[inline(always)]
    fn pixel(
        lut: &OutputTable,
        row: usize,
        col: usize,
        light: impl Fn(usize) -> u16,
        z: &[u8],
        out: &mut [u8],
    ) {
        let c = bayer_channel(row, col);
        if let (Some(o), Some(&z)) = (out.first_mut(), z.get(c)) {
            *o = output(lut, light(c), z);
        }
    }
}

impl Layout for Grey {
    const FORMAT: PixelFormat = PixelFormat::Mono8;
    const BYTES: usize = 1;
    #[inline(always)]
    fn pixel(
        lut: &OutputTable,
        row: usize,
        col: usize,
        light: impl Fn(usize) -> u16,
        z: &[u8],
        out: &mut [u8],
    ) {
        let mut rgb = [0u8; 3];
        Rgb::pixel(lut, row, col, light, z, &mut rgb);
        if let Some(o) = out.first_mut() {
            *o = grey(rgb);
        }
    }
}

/// Writes pixels `cols` of row `row` through the output stage: `light` gives each pixel's
/// channel -> [`table_row`] function, `noise` holds the row's noise levels (three per pixel),
/// `line` the row's output bytes.
#[inline(always)]
fn write_span<L: Layout, P: Fn(usize) -> u16>(
    lut: &OutputTable,
    row: usize,
    cols: std::ops::Range<usize>,
    noise: &[u8],
    line: &mut [u8],
    light: impl Iterator<Item = P>,
) {
    let out = line[cols.start * L::BYTES..cols.end * L::BYTES].chunks_exact_mut(L::BYTES);
    let z = noise[3 * cols.start..3 * cols.end].chunks_exact(3);
    for (((px, z), col), light) in out.zip(z).zip(cols).zip(light) {
        L::pixel(lut, row, col, light, z, px);
    }
}

/// Rows per unit of work of the render threads (even: no 2x2 block straddles two bands).
const BAND_ROWS: usize = 16;

/// Gain is applied in fixed point with this many fractional bits.
const GAIN_BITS: u32 = 12;

/// Noise tile length (Gaussian samples).
const NOISE_TILE: usize = 1 << 21;

/// Default `Renderer::skip_below`: 0.002 fringe changes a colour by well under 1 DN.
const SKIP_BELOW_FRINGES: f32 = 0.002;

/// Most fields kept in the cache (flat punches and spheres together).
const FIELD_CACHE_LIMIT: usize = 96;

/// Fringe order per newton and its gradient per mm, packed for the per-pixel loop.
#[derive(Debug, Clone)]
struct PackedField {
    n: usize,
    inv_cell: f32,
    half: f32,
    last: f32,
    /// Row-major [N_unit, |grad N_unit|] at 1 N for this sensor's f_sigma.
    data: Vec<[f32; 2]>,
    cell_mm: f32,
    /// Largest N_unit and largest |grad N_unit| at or beyond k cells from the centre.
    beyond: Vec<[f32; 2]>,
}

impl PackedField {
    fn new(field: &FringeField, scale: f64) -> PackedField {
        let n = field.size();
        let mut data = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                data.push([
                    (field.at(i, j) * scale) as f32,
                    (field.gradient_at(i, j) * scale) as f32,
                ]);
            }
        }
        let half = n / 2;
        let mut beyond = vec![[0.0f32; 2]; n + 1];
        for j in 0..n {
            for i in 0..n {
                let [v, g] = data[j * n + i];
                let slot = &mut beyond[ring(n, i, j)];
                slot[0] = slot[0].max(v);
                slot[1] = slot[1].max(g);
            }
        }
        for k in (0..n).rev() {
            beyond[k][0] = beyond[k][0].max(beyond[k + 1][0]);
            beyond[k][1] = beyond[k][1].max(beyond[k + 1][1]);
        }
        PackedField {
            n,
            inv_cell: (1.0 / field.cell_mm()) as f32,
            half: half as f32,
            last: (n - 1) as f32,
            data,
            cell_mm: field.cell_mm() as f32,
            beyond,
        }
    }

    /// The field of a press pushed sideways, filled into `self` (its buffers reused): fringe
    /// order 2 |D| / f_sigma (`scale` = 2000 / f_sigma, D in N/mm) of the stress differences
    /// D = P D_n + (1 - w) T(low) + w T(high), T(f) = qx f_x + qy f_y (`loads` = [P, qx, qy, w]),
    /// and its gradient by central differences (one-sided on the grid edges), on an `n` x `n`
    /// grid of `cell_mm`; `rings` holds each cell's [`ring`].
    ///
    /// The same sums as [`FringeField::from_stress`] and [`PackedField::new`] of that field, in
    /// single precision from D on (they went through double precision: the fields differ in
    /// float rounding), in two passes over the grid without allocating.
    #[allow(clippy::too_many_arguments)]
    fn fill_pushed(
        &mut self,
        n: usize,
        cell_mm: f64,
        rings: &[u16],
        [p, qx, qy, w]: [f32; 4],
        scale: f32,
        normal: &[Complex<f32>],
        low: &TractionField,
        high: &TractionField,
    ) {
        let cells = n * n;
        self.n = n;
        self.inv_cell = (1.0 / cell_mm) as f32;
        self.half = (n / 2) as f32;
        self.last = (n - 1) as f32;
        self.cell_mm = cell_mm as f32;
        self.data.clear();
        self.data.resize(cells, [0.0; 2]);
        let data = &mut self.data[..cells];
        let t = |f: &[Complex<f32>; 2]| f[0] * qx + f[1] * qy;
        for (((out, &d_n), lo), hi) in data.iter_mut().zip(normal).zip(low).zip(high) {
            let d = d_n * p + t(lo) * (1.0 - w) + t(hi) * w;
            out[0] = scale * (d.re * d.re + d.im * d.im).sqrt();
        }
        // Per mm over one cell (edges) and over two (inside).
        let (one, two) = ((1.0 / cell_mm) as f32, (1.0 / (2.0 * cell_mm)) as f32);
        for j in 0..n {
            let (j0, j1) = (j.saturating_sub(1), (j + 1).min(n - 1));
            let across = if j1 - j0 == 2 { two } else { one };
            for i in 0..n {
                let (i0, i1) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let along = if i1 - i0 == 2 { two } else { one };
                let gx = (data[j * n + i1][0] - data[j * n + i0][0]) * along;
                let gy = (data[j1 * n + i][0] - data[j0 * n + i][0]) * across;
                data[j * n + i][1] = (gx * gx + gy * gy).sqrt();
            }
        }
        self.beyond.clear();
        self.beyond.resize(n + 1, [0.0; 2]);
        for (&[v, g], &r) in data.iter().zip(rings) {
            let slot = &mut self.beyond[usize::from(r)];
            slot[0] = slot[0].max(v);
            slot[1] = slot[1].max(g);
        }
        for k in (0..n).rev() {
            self.beyond[k][0] = self.beyond[k][0].max(self.beyond[k + 1][0]);
            self.beyond[k][1] = self.beyond[k][1].max(self.beyond[k + 1][1]);
        }
    }

    /// A field of no cells, to be filled.
    fn empty() -> PackedField {
        PackedField {
            n: 0,
            inv_cell: 0.0,
            half: 0.0,
            last: 0.0,
            data: Vec::new(),
            cell_mm: 0.0,
            beyond: Vec::new(),
        }
    }

    /// Distance from the indenter centre (mm) beyond which `force` changes the fringe order and
    /// its spread (`spread` = force * blur sigma) by less than `threshold`; infinite when the
    /// field never falls that low on the grid (it is clamped at the grid edge).
    fn reach_mm(&self, force: f32, spread: f32, threshold: f32) -> f32 {
        let below = |b: &[f32; 2]| force * b[0] < threshold && spread * b[1] < threshold;
        // `beyond` falls with k: find the first k whose tail is below the threshold.
        if !below(&self.beyond[self.n - 1]) {
            return f32::INFINITY;
        }
        let k = self.beyond.partition_point(|b| !below(b));
        (k as f32 + 1.5) * self.cell_mm
    }

    /// Bilinear [N_unit, |grad N_unit|] at (x, y) mm in the indenter frame; the grid edge beyond.
    #[inline]
    fn sample(&self, x: f32, y: f32) -> [f32; 2] {
        let u = (x * self.inv_cell + self.half).clamp(0.0, self.last);
        let v = (y * self.inv_cell + self.half).clamp(0.0, self.last);
        let (i0, j0) = (u as usize, v as usize);
        let i1 = (i0 + 1).min(self.n - 1);
        let j1 = (j0 + 1).min(self.n - 1);
        let (fu, fv) = (u - i0 as f32, v - j0 as f32);
        let a = self.data[j0 * self.n + i0];
        let b = self.data[j0 * self.n + i1];
        let c = self.data[j1 * self.n + i0];
        let d = self.data[j1 * self.n + i1];
        let mut out = [0.0f32; 2];
        for k in 0..2 {
            let top = a[k] + (b[k] - a[k]) * fu;
            let bottom = c[k] + (d[k] - c[k]) * fu;
            out[k] = top + (bottom - top) * fv;
        }
        out
    }
}

/// The ring of cell (i, j) of an `n` x `n` grid: its whole cells of distance from the centre
/// cell, at most n.
fn ring(n: usize, i: usize, j: usize) -> usize {
    let half = n / 2;
    let d = (i as f64 - half as f64)
        .hypot(j as f64 - half as f64)
        .floor() as usize;
    d.min(n)
}

/// Everything a pushed contact's field is a function of (with the renderer's grid, layer and
/// f_sigma): its outline, the lower of the two traction levels it mixes and the exact loads
/// [P, qx, qy, w] it is combined with, as bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct PushKey {
    outline: FieldKey,
    below: usize,
    loads: [u32; 4],
}

/// Cache key of a field: shape kind and its sizes (sphere: rounded contact radius).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum FieldKey {
    Pentagon(u64),
    Rectangle(u64, u64),
    Circle(u64),
    Sphere(u64),
}

/// The key of `shape` and the shape whose field is computed for it.
fn field_key(shape: &Shape) -> (FieldKey, Shape) {
    match *shape {
        Shape::Pentagon { circumradius_mm } => {
            (FieldKey::Pentagon(circumradius_mm.to_bits()), *shape)
        }
        Shape::Rectangle {
            width_mm,
            height_mm,
        } => (
            FieldKey::Rectangle(width_mm.to_bits(), height_mm.to_bits()),
            *shape,
        ),
        Shape::Circle { radius_mm } => (FieldKey::Circle(radius_mm.to_bits()), *shape),
        Shape::Sphere {
            radius_mm,
            contact_radius_mm,
        } => {
            let steps = (contact_radius_mm / SPHERE_RADIUS_STEP_MM).round().max(1.0);
            (
                FieldKey::Sphere(steps as u64),
                Shape::Sphere {
                    radius_mm,
                    contact_radius_mm: steps * SPHERE_RADIUS_STEP_MM,
                },
            )
        }
    }
}

/// Slow gain and offset drift and frame-to-frame flicker, pure functions of the frame index.
#[derive(Debug, Clone)]
struct Drift {
    seed: u64,
    gain_amplitude: f64,
    offset_amplitude: f64,
    flicker: f64,
    /// [angular frequency per frame, phase] of three waves each for gain and offset.
    gain_waves: [[f64; 2]; 3],
    offset_waves: [[f64; 2]; 3],
}

impl Drift {
    fn new(config: &SensorConfig) -> Drift {
        let mut state = config.seed ^ 0xD1F7_0000_0000_0001;
        let mut wave = || {
            // Periods 300-6000 frames (6 s to 2 min at 50 Hz).
            let period = 300.0 * (20.0f64).powf(uniform(&mut state));
            let phase = std::f64::consts::TAU * uniform(&mut state);
            [std::f64::consts::TAU / period, phase]
        };
        let gain_waves = [wave(), wave(), wave()];
        let offset_waves = [wave(), wave(), wave()];
        Drift {
            seed: config.seed,
            gain_amplitude: config.noise.gain_drift,
            offset_amplitude: config.noise.offset_drift_dn,
            flicker: config.noise.flicker,
            gain_waves,
            offset_waves,
        }
    }

    fn smooth(waves: &[[f64; 2]; 3], t: f64) -> f64 {
        waves.iter().map(|w| (w[0] * t + w[1]).sin()).sum::<f64>() / 3.0
    }

    /// (gain including flicker, offset in DN) of frame `frame` of session `session`.
    fn at(&self, frame: u64, session: u64) -> (f32, f32) {
        let t = frame.wrapping_add(session::drift_frames(session)) as f64;
        let seed = session::salted(self.seed, session);
        let mut state = seed ^ frame.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xF11C;
        let flicker = (self.flicker * standard_normal(&mut state)).clamp(-0.05, 0.05);
        // Clamped so the fixed-point gain of the output stage cannot overflow.
        let gain = ((1.0 + self.gain_amplitude * Self::smooth(&self.gain_waves, t))
            * (1.0 + flicker))
            .clamp(0.0, 3.9);
        let offset = self.offset_amplitude * Self::smooth(&self.offset_waves, t);
        (gain as f32, offset as f32)
    }
}

/// Standard normal sample (Box-Muller).
fn standard_normal(state: &mut u64) -> f64 {
    let u1 = uniform(state).max(1e-300);
    let u2 = uniform(state);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A contact mapped onto the image for one frame.
#[derive(Clone, Copy)]
struct ContactMap<'a> {
    field: &'a PackedField,
    /// Indenter-frame mm = a (u, v) + b for image position (u, v) px.
    a: [[f32; 2]; 2],
    b: [f32; 2],
    force: f32,
    /// force * sigma_blur (mm): sigma_N = this * |grad N_unit|.
    spread: f32,
    /// Image position of the indenter centre, px, and the radius beyond which the contact
    /// changes nothing visible (see `Renderer::skip_below`).
    centre_px: [f32; 2],
    reach_px: f32,
}

impl ContactMap<'_> {
    /// [F N_unit, sigma_N] at image position (u, v) px.
    #[inline]
    fn at_point(&self, u: f32, v: f32) -> [f32; 2] {
        let x = self.a[0][0] * u + self.a[0][1] * v + self.b[0];
        let y = self.a[1][0] * u + self.a[1][1] * v + self.b[1];
        let [n, g] = self.field.sample(x, y);
        [self.force * n, self.spread * g]
    }
}

/// Per-frame settings shared by the worker threads.
struct FrameParams<'a> {
    contact: Option<ContactMap<'a>>,
    /// This frame's output table: (light row before gain and offset, noise level) to 8 bits.
    lut: &'a OutputTable,
    noise_seed: u64,
}

/// Renders frames of one simulated sensor build.
pub struct Renderer {
    config: SensorConfig,
    geometry: SensorGeometry,
    colours: PackedColours,
    background: Background,
    fields: HashMap<FieldKey, Arc<PackedField>>,
    /// Per outline: D1 + i D2 of a 1 N press and of the tangential traction at each level (for
    /// contacts pushed sideways), computed ahead of need.
    push: PushStress<FieldKey>,
    /// The field of the last pushed contact drawn and what it is a function of: a held push
    /// draws it again; another push refills its buffers.
    pushed: Option<(PushKey, Arc<PackedField>)>,
    /// Each field cell's [`ring`], row-major.
    rings: Vec<u16>,
    /// 1 / f_sigma scale applied to fields computed at f_sigma = 1 N/m.
    f_sigma_n_per_m: f64,
    blur_sigma_mm: f64,
    /// Noise levels 0..NOISE_LEVELS (the middle two are +-1/8 sigma).
    noise: Vec<u8>,
    /// 8-bit output for (light row, noise level): noise sigma^2 = a I + b, then gamma.
    lut: Vec<u8>,
    /// The unloaded sensor's light as [`table_row`]s, interleaved RGB.
    unloaded: Vec<u16>,
    /// `lut` with this frame's gain and offset folded in (rebuilt per frame).
    frame_lut: Box<OutputTable>,
    drift: Drift,
    /// Pixels where the contact changes the fringe order and its spread by less than this many
    /// fringes keep the unloaded background (0 = compute every lit pixel).
    skip_below: f32,
    /// Session of the bench filming ([`crate::session`]): salts noise, flicker and drift.
    session: u64,
}

impl Renderer {
    /// Builds the renderer of `config` (validated first): fields of the configured pentagon and
    /// rectangle, colour table, background, noise tile and gamma table.
    pub fn new(config: SensorConfig) -> Result<Renderer, SensorConfigError> {
        config.validate(&format!("sensor `{}`", config.id))?;
        let geometry = config.geometry();
        let polariser = if config.optics.quarter_wave_nm > 0.0 {
            Polariser::Film {
                design_wavelength_nm: config.optics.quarter_wave_nm,
            }
        } else {
            Polariser::Ideal
        };
        let table = colour_table(polariser);
        let colours = PackedColours::new(&table, 1024, 65);
        let background = Background::new(&config, &geometry);
        let unloaded = background.unloaded_light(&colours).map(table_row).collect();

        let rectangle_unit = unit_field(&config, &config.rectangle());
        let f_sigma_n_per_m = if config.layer.target_fringes > 0.0 {
            rectangle_unit.max() * config.layer.target_force_n / config.layer.target_fringes
        } else {
            config.layer.f_sigma_n_per_m
        };
        let blur_sigma_px = (0.5 * config.optics.blur_px).hypot(PIXEL_SIGMA_PX);

        let mut state = config.seed ^ 0x4E01_5E00;
        let (w, h) = (
            config.geometry.width as usize,
            config.geometry.height as usize,
        );
        let noise_len = (3 * w * h).min(NOISE_TILE) + 3 * w + 1;
        let noise = (0..noise_len)
            .map(|_| {
                let z = standard_normal(&mut state) * 4.0 + 16.0;
                z.clamp(0.0, (NOISE_LEVELS - 1) as f64) as u8
            })
            .collect();
        let (a, b) = (config.noise.poisson_a, config.noise.gaussian_b);
        let inv_gamma = 1.0 / config.optics.gamma;
        let row_dn = f64::from(1u32 << LUT_ROW_SHIFT) / f64::from(LIGHT_STEPS_PER_DN);
        let mut lut = Vec::with_capacity(LUT_ROWS * NOISE_LEVELS);
        for row in 0..LUT_ROWS {
            let light = row as f64 * row_dn;
            let sigma = (a * light + b).sqrt();
            for level in 0..NOISE_LEVELS {
                let z = (level as f64 - 15.5) / 4.0;
                let linear = ((light + sigma * z) / 255.0).clamp(0.0, 1.0);
                lut.push((255.0 * linear.powf(inv_gamma)).round() as u8);
            }
        }
        let mut renderer = Renderer {
            geometry,
            colours,
            background,
            unloaded,
            fields: HashMap::new(),
            push: PushStress::new(
                Grid {
                    cells: config.field.cells,
                    cell_mm: config.field.cell_mm,
                    layer: config.layer(),
                },
                true,
            ),
            pushed: None,
            rings: (0..config.field.cells * config.field.cells)
                .map(|k| {
                    let n = config.field.cells;
                    // n <= 2048 (SensorConfig::validate), so a ring fits.
                    u16::try_from(ring(n, k % n, k / n)).unwrap_or(u16::MAX)
                })
                .collect(),
            f_sigma_n_per_m,
            blur_sigma_mm: blur_sigma_px / config.geometry.px_per_mm,
            noise,
            lut,
            frame_lut: Box::new([0; LUT_ROWS * NOISE_LEVELS]),
            drift: Drift::new(&config),
            skip_below: SKIP_BELOW_FRINGES,
            session: 0,
            config,
        };
        let (key, _) = field_key(&renderer.config.rectangle());
        let packed = PackedField::new(&rectangle_unit, 1.0 / f_sigma_n_per_m);
        renderer.fields.insert(key, Arc::new(packed));
        let pentagon = renderer.config.pentagon();
        renderer.field(&pentagon);
        Ok(renderer)
    }

    /// The configuration this renderer was built from.
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    /// Films session `session` of the bench from now on (0, the default, is the sensor seed's own
    /// noise): the noise, flicker and drift phase of every frame follow the session too.
    pub fn set_session(&mut self, session: u64) {
        self.session = session;
    }

    /// The session being filmed.
    pub fn session(&self) -> u64 {
        self.session
    }

    /// The exact sensor-frame to image map used for every frame.
    pub fn geometry(&self) -> SensorGeometry {
        self.geometry
    }

    /// Material fringe value in use (from the file, or from `target_fringes`), N/m per fringe.
    pub fn f_sigma_n_per_m(&self) -> f64 {
        self.f_sigma_n_per_m
    }

    /// Computes now, on this thread, everything a push of `shape` is drawn from (the stresses
    /// of its press and of its traction at every level), for instance for the mounted
    /// indenter before filming: no frame of its pushes computes them. Otherwise a flat punch
    /// has them computed in the background from the first frame it presses in, and a frame
    /// that needs one not computed yet computes it itself.
    pub fn prepare_push(&mut self, shape: &Shape) {
        let (key, quantised) = field_key(shape);
        self.push.compute_now(key, &quantised);
    }

    /// The field of `shape`, computed on first use.
    fn field(&mut self, shape: &Shape) -> Arc<PackedField> {
        let (key, quantised) = field_key(shape);
        if let Some(f) = self.fields.get(&key) {
            return Arc::clone(f);
        }
        if self.fields.len() >= FIELD_CACHE_LIMIT {
            // Keep the configured flat punches, drop the spheres and other one-offs.
            self.fields
                .retain(|k, _| matches!(k, FieldKey::Pentagon(_) | FieldKey::Rectangle(..)));
        }
        let unit = unit_field(&self.config, &quantised);
        let packed = Arc::new(PackedField::new(&unit, 1.0 / self.f_sigma_n_per_m));
        self.fields.insert(key, Arc::clone(&packed));
        packed
    }

    /// The field `contact` is drawn with and the factor on it: a press alone scales the field of
    /// a 1 N press of its shape by its force; a press pushed sideways gets a field of its own
    /// loads (factor 1). A pressing flat punch has its push fields prepared in the background
    /// (a sphere's outline changes with its force: its are computed once it is pushed).
    fn contact_field(&mut self, contact: &Contact) -> (Arc<PackedField>, f64) {
        match contact.shear {
            Some(shear) if shear.force.0 > 0.0 && contact.force.0 > 0.0 => {
                (self.sheared_field(contact, &shear), 1.0)
            }
            _ => {
                if contact.force.0 > 0.0 && !matches!(contact.shape, Shape::Sphere { .. }) {
                    let (key, quantised) = field_key(&contact.shape);
                    self.push.prepare(key, &quantised);
                }
                (self.field(&contact.shape), contact.force.0)
            }
        }
    }

    /// The field of a press of `contact.force` pushed sideways by `shear`: the stress
    /// differences of the press, and of the tangential traction interpolated between the two
    /// nearest levels of the friction used, added before the fringe order is taken (the two
    /// load systems superpose in stress, not in fringe order). The same push as the last
    /// frame's (a held push) reuses its field.
    fn sheared_field(&mut self, contact: &Contact, shear: &Shear) -> Arc<PackedField> {
        let (key, quantised) = field_key(&contact.shape);
        let level = shear.friction_used.clamp(0.0, 1.0) * TRACTION_LEVELS as f64;
        let below = (level.floor() as usize).min(TRACTION_LEVELS - 1);
        let w = (level - below as f64) as f32;
        // The push's direction in the indenter frame (turned by the indenter's angle).
        let (s, c) = (shear.direction_deg - contact.angle_deg)
            .to_radians()
            .sin_cos();
        let (p, q) = (contact.force.0 as f32, shear.force.0 as f32);
        let loads = [p, q * c as f32, q * s as f32, w];
        let push = PushKey {
            outline: key,
            below,
            loads: loads.map(f32::to_bits),
        };
        if let Some((held, field)) = &self.pushed {
            if *held == push {
                return Arc::clone(field);
            }
        }
        let outline = self.push.outline(key, &quantised);
        // The last field's buffers, unless a caller still holds it.
        let mut packed = match self.pushed.take().map(|(_, field)| Arc::try_unwrap(field)) {
            Some(Ok(field)) => field,
            _ => PackedField::empty(),
        };
        packed.fill_pushed(
            self.config.field.cells,
            self.config.field.cell_mm,
            &self.rings,
            loads,
            (2.0 * 1000.0 / self.f_sigma_n_per_m) as f32,
            outline.press(),
            outline.level(below),
            outline.level(below + 1),
        );
        let field = Arc::new(packed);
        self.pushed = Some((push, Arc::clone(&field)));
        field
    }

    /// The affine pixel -> indenter-frame map of `contact`.
    fn contact_affine(&self, contact: &Contact) -> ([[f32; 2]; 2], [f32; 2]) {
        let (s, c) = contact.angle_deg.to_radians().sin_cos();
        let (cx, cy) = (contact.x.0, contact.y.0);
        let to_indenter = |u: f64, v: f64| {
            let [x, y] = self.geometry.to_sensor(u, v);
            let (dx, dy) = (x - cx, y - cy);
            // Rotate by -angle.
            [c * dx + s * dy, -s * dx + c * dy]
        };
        let o = to_indenter(0.0, 0.0);
        let eu = to_indenter(1.0, 0.0);
        let ev = to_indenter(0.0, 1.0);
        (
            [
                [(eu[0] - o[0]) as f32, (ev[0] - o[0]) as f32],
                [(eu[1] - o[1]) as f32, (ev[1] - o[1]) as f32],
            ],
            [o[0] as f32, o[1] as f32],
        )
    }

    /// `contact` mapped onto the image with `field` times `factor` (see
    /// [`Renderer::contact_field`]), for one frame.
    fn contact_map<'a>(&self, c: &Contact, field: &'a PackedField, factor: f64) -> ContactMap<'a> {
        let (a, b) = self.contact_affine(c);
        let force = factor.max(0.0) as f32;
        let spread = force * self.blur_sigma_mm as f32;
        let reach = field.reach_mm(force, spread, self.skip_below);
        let [pu, pv] = self.geometry.to_pixel(c.x.0, c.y.0);
        ContactMap {
            field,
            a,
            b,
            force,
            spread,
            centre_px: [pu as f32, pv as f32],
            reach_px: reach * self.geometry.px_per_mm as f32 + 2.0,
        }
    }

    /// Fringe order F N_unit caused by `contact` at every pixel (row-major, no residual
    /// birefringence): the values the frame's colours are looked up at, i.e. at the centre of
    /// each pixel's 2x2 block.
    pub fn fringe_order_map(&mut self, contact: &Contact) -> Vec<f32> {
        let (field, factor) = self.contact_field(contact);
        let (a, b) = self.contact_affine(contact);
        let map = ContactMap {
            field: &field,
            a,
            b,
            force: factor as f32,
            spread: 0.0,
            centre_px: [0.0, 0.0],
            reach_px: f32::INFINITY,
        };
        let (w, h) = (self.background.width(), self.background.height());
        let mut out = Vec::with_capacity(w * h);
        for j in 0..h {
            for i in 0..w {
                let (u, v) = ((i & !1) as f32 + 1.0, (j & !1) as f32 + 1.0);
                out.push(map.at_point(u, v)[0]);
            }
        }
        out
    }

    /// Renders rows `rows` (starting at an even row) into `out` (exactly those rows' bytes, in
    /// layout `L`); `block_rgb` is scratch space.
    fn render_rows<L: Layout>(
        &self,
        params: &FrameParams,
        rows: std::ops::Range<usize>,
        out: &mut [u8],
        block_rgb: &mut Vec<[f32; 3]>,
    ) {
        let w = self.background.width();
        let lut = params.lut;
        // Fringe colours of the 2x2 blocks of the current row pair.
        block_rgb.resize(w.div_ceil(2), [0.0; 3]);
        let h = self.background.height();
        for (r, (j, line)) in rows.zip(out.chunks_exact_mut(w * L::BYTES)).enumerate() {
            let row_light = &self.unloaded[3 * j * w..3 * (j + 1) * w];
            let mut state = params.noise_seed ^ (j as u64).wrapping_mul(0xA24B_AED4_963E_E407);
            let tile_start = (splitmix64(&mut state) % (self.noise.len() - 3 * w) as u64) as usize;
            let noise = &self.noise[tile_start..tile_start + 3 * w];
            // The unloaded pixels of columns `cols`.
            let background = |cols: std::ops::Range<usize>| {
                row_light[3 * cols.start..3 * cols.end]
                    .chunks_exact(3)
                    .map(|rows| move |c: usize| rows[c])
            };
            // The lit columns of row `row` within the contact's reach.
            let reach = |map: &ContactMap, row: usize| {
                let (start, end) = self.background.span(row);
                let dv = (row as f32 + 0.5 - map.centre_px[1]).abs();
                if dv > map.reach_px {
                    return (start, start);
                }
                let du = (map.reach_px * map.reach_px - dv * dv).sqrt();
                let lo = (map.centre_px[0] - du).floor().max(0.0);
                let hi = (map.centre_px[0] + du).ceil().max(0.0);
                let lo = if lo.is_finite() { lo as usize } else { 0 };
                let hi = if hi.is_finite() {
                    hi as usize
                } else {
                    usize::MAX
                };
                let (s, e) = (start.max(lo), end.min(hi));
                (s, e.max(s))
            };
            match params.contact {
                Some(map) => {
                    let (start, end) = reach(&map, j);
                    if j % 2 == 0 || r == 0 {
                        // Half resolution: one field sample and colour per 2x2 block, at its
                        // centre, over the lit columns of both rows of the pair.
                        let top = j & !1;
                        let (s0, e0) = reach(&map, top);
                        let (s1, e1) = reach(&map, (top + 1).min(h - 1));
                        let (first, last) = (s0.min(s1) / 2, e0.max(e1).div_ceil(2));
                        for (b, rgb) in block_rgb.iter_mut().enumerate().take(last).skip(first) {
                            let i = 2 * b;
                            let [n, sigma] = map.at_point(i as f32 + 1.0, top as f32 + 1.0);
                            let residual = self.background.residual(top * w + i);
                            *rgb = self.colours.lookup(n + residual, sigma);
                        }
                    }
                    write_span::<L, _>(lut, j, 0..start, noise, line, background(0..start));
                    let (illumination, glow) = self.background.row_terms(j);
                    let loaded = illumination[start..end]
                        .iter()
                        .zip(&glow[start..end])
                        .zip(start..end)
                        .map(|((&illumination, &glow), col)| {
                            let colour = block_rgb[col / 2];
                            move |c: usize| {
                                let light = channel_light(illumination, colour[c], glow, c);
                                table_row(quantise_light(light))
                            }
                        });
                    write_span::<L, _>(lut, j, start..end, noise, line, loaded);
                    write_span::<L, _>(lut, j, end..w, noise, line, background(end..w));
                }
                None => write_span::<L, _>(lut, j, 0..w, noise, line, background(0..w)),
            }
        }
    }

    /// Folds gain and offset into the output table: row r (light r * 4 / 16 DN before them)
    /// reads the gamma/noise row of the light after them.
    fn fold_gain(&mut self, gain_q: i32, offset_q: i32) {
        let last = (LUT_ROWS - 1) as i32;
        for (r, out) in self.frame_lut.chunks_exact_mut(NOISE_LEVELS).enumerate() {
            // r < 2^11, so q < 2^13 and the product with gain < 2^14 fits in i32.
            let q = (r << LUT_ROW_SHIFT) as i32;
            let v = ((q * gain_q) >> GAIN_BITS) + offset_q;
            let row = (v >> LUT_ROW_SHIFT).clamp(0, last) as usize;
            out.copy_from_slice(&self.lut[row * NOISE_LEVELS..(row + 1) * NOISE_LEVELS]);
        }
    }
}

/// The blurred colour table behind `polariser` (N 0..=20, sigma_N 0..=2), built once per process
/// and shared by every renderer.
fn colour_table(polariser: Polariser) -> Arc<BlurredColourTable> {
    type Tables = Mutex<Vec<(Polariser, Arc<BlurredColourTable>)>>;
    static TABLES: OnceLock<Tables> = OnceLock::new();
    let tables = TABLES.get_or_init(|| Mutex::new(Vec::new()));
    let mut tables = match tables.lock() {
        Ok(t) => t,
        Err(poisoned) => poisoned.into_inner(),
    };
    if let Some((_, t)) = tables.iter().find(|(p, _)| *p == polariser) {
        return Arc::clone(t);
    }
    let table = Arc::new(BlurredColourTable::new(1024, 20.0, 65, 2.0, polariser));
    tables.push((polariser, Arc::clone(&table)));
    table
}

/// N_unit of `shape` at f_sigma = 1 N/m on the configured grid.
fn unit_field(config: &SensorConfig, shape: &Shape) -> FringeField {
    let map = PressureMap::new(shape, config.field.cells, config.field.cell_mm, 1.0);
    FringeField::new(&map, &config.layer(), 1.0)
}

impl FrameRenderer for Renderer {
    fn width(&self) -> u32 {
        self.config.geometry.width
    }

    fn height(&self) -> u32 {
        self.config.geometry.height
    }

    fn render(&mut self, scene: &Scene, frame_index: u64, out: &mut Vec<u8>) {
        self.render_frame::<Rgb>(scene, frame_index, out);
    }

    fn render_as(
        &mut self,
        scene: &Scene,
        frame_index: u64,
        format: PixelFormat,
        out: &mut Vec<u8>,
    ) {
        match format {
            PixelFormat::Rgb8 => self.render_frame::<Rgb>(scene, frame_index, out),
            PixelFormat::BayerRg8 => self.render_frame::<Bayer>(scene, frame_index, out),
            PixelFormat::Mono8 => self.render_frame::<Grey>(scene, frame_index, out),
        }
    }
}

impl Renderer {
    /// Renders `scene` as frame `frame_index` in layout `L` into `out`.
    fn render_frame<L: Layout>(&mut self, scene: &Scene, frame_index: u64, out: &mut Vec<u8>) {
        let (w, h) = (self.background.width(), self.background.height());
        debug_assert_eq!(L::BYTES, L::FORMAT.bytes_per_pixel());
        out.resize(w * h * L::BYTES, 0);
        let field = scene.contact.map(|c| (c, self.contact_field(&c)));
        let (gain, offset) = self.drift.at(frame_index, self.session);
        let gain_q = (f64::from(gain) * f64::from(1u32 << GAIN_BITS)).round() as i32;
        let offset_q = (offset * LIGHT_STEPS_PER_DN).round() as i32;
        self.fold_gain(gain_q, offset_q);
        let contact = field
            .as_ref()
            .map(|(c, (field, factor))| self.contact_map(c, field, *factor));
        let params = FrameParams {
            contact,
            lut: &self.frame_lut,
            noise_seed: session::salted(self.config.seed, self.session)
                ^ frame_index.wrapping_mul(0xD6E8_FEB8_6659_FD93),
        };
        let threads = self.config.threads.min(h.div_ceil(BAND_ROWS)).max(1);
        // Bands of rows go to whichever thread is free: the contact's rows cost more than the
        // others, and a thread that loses its core to another process does fewer of them.
        let bands = Mutex::new(out.chunks_mut(BAND_ROWS * w * L::BYTES).enumerate());
        let this = &*self;
        let work = || {
            let mut block_rgb = Vec::new();
            loop {
                let next = bands.lock().unwrap_or_else(|e| e.into_inner()).next();
                let Some((b, band)) = next else { break };
                let rows = b * BAND_ROWS..((b + 1) * BAND_ROWS).min(h);
                this.render_rows::<L>(&params, rows, band, &mut block_rgb);
            }
        };
        std::thread::scope(|scope| {
            for _ in 1..threads {
                scope.spawn(work);
            }
            work();
        });
    }
}

#[cfg(test)]
mod tests;
