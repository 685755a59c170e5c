//! Fringe order per newton, N_unit(x, y), seen through the sensor for one indenter.
//!
//! By superposition of Boussinesq point loads (Johnson, *Contact Mechanics*, 3.2) and linear
//! integrated photoelasticity (Aben), a pressure p(x, y) gives the depth-integrated secondary stress
//! differences
//!
//! D1 = p (*) (G cos 2 phi),  D2 = p (*) (G sin 2 phi),
//!
//! with G the through-layer kernel of [`crate::physics::stress::layer_kernel`], phi the direction from the load
//! point and r regularised to sqrt(r^2 + (cell / 2)^2). Light crosses the layer twice after the
//! mirror, so N = 2 sqrt(D1^2 + D2^2) / f_sigma (docs/photoelastic-sim.md, "Optics").
//!
//! Both convolutions are done at once: with K = G e^(2 i phi), p (*) K = D1 + i D2. The convolution is
//! linear (zero-padded to twice the grid) and computed by FFT. A flat punch keeps its contact area,
//! so N = F N_unit for every force.

use crate::physics::indenter::PressureMap;
use crate::physics::stress::Layer;
use crate::physics::traction::TractionMap;
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// Fringe order per newton on the grid of the pressure map it was computed from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FringeField {
    n: usize,
    cell_mm: f64,
    /// Row-major fringe order per newton.
    values: Vec<f64>,
    /// Row-major |grad N_unit|, fringe orders per newton per mm.
    gradient: Vec<f64>,
}

/// |grad| of a row-major `n` x `n` grid with cell side `cell_mm`, per mm: central differences inside,
/// one-sided differences on the edges.
fn gradient_magnitude(values: &[f64], n: usize, cell_mm: f64) -> Vec<f64> {
    let at = |i: usize, j: usize| values[j * n + i];
    let diff = |lo: usize, hi: usize, a: f64, b: f64| (b - a) / ((hi - lo) as f64 * cell_mm);
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        let (j0, j1) = (j.saturating_sub(1), (j + 1).min(n - 1));
        for i in 0..n {
            let (i0, i1) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let gx = diff(i0, i1, at(i0, j), at(i1, j));
            let gy = diff(j0, j1, at(i, j0), at(i, j1));
            out.push(gx.hypot(gy));
        }
    }
    out
}

/// In-place 2-D FFT of an `m` x `m` row-major complex array (rows, then columns).
fn fft_2d(data: &mut [Complex<f64>], m: usize, inverse: bool) {
    fft_2d_part(data, m, inverse, m, m);
}

/// [`fft_2d`] of an array whose rows from `rows` on are zero, of which only the first
/// `columns` columns are wanted: the zero rows' transforms (zero) and the other columns' are
/// skipped; the wanted values are those of the whole transform.
fn fft_2d_part(data: &mut [Complex<f64>], m: usize, inverse: bool, rows: usize, columns: usize) {
    let mut planner = FftPlanner::<f64>::new();
    let fft = if inverse {
        planner.plan_fft_inverse(m)
    } else {
        planner.plan_fft_forward(m)
    };
    fft.process(&mut data[..rows * m]); // those rows
    let mut column = vec![Complex::new(0.0, 0.0); m];
    for i in 0..columns {
        for (j, c) in column.iter_mut().enumerate() {
            *c = data[j * m + i];
        }
        fft.process(&mut column);
        for (j, c) in column.iter().enumerate() {
            data[j * m + i] = *c;
        }
    }
}

/// The spectrum (2-D FFT on the zero-padded `2n` x `2n` periodic grid) of a kernel given at
/// cell offsets (dx, dy) in -(n-1)..=(n-1); the load's own cell (0, 0) contributes 0.
fn kernel_spectrum(n: usize, kernel: impl Fn(isize, isize) -> Complex<f64>) -> Vec<Complex<f64>> {
    let m = 2 * n;
    let mut k = vec![Complex::new(0.0, 0.0); m * m];
    let span = n as isize - 1;
    for dy in -span..=span {
        for dx in -span..=span {
            if dx == 0 && dy == 0 {
                continue;
            }
            let iu = dx.rem_euclid(m as isize) as usize;
            let ju = dy.rem_euclid(m as isize) as usize;
            k[ju * m + iu] = kernel(dx, dy);
        }
    }
    fft_2d(&mut k, m, false);
    k
}

/// The linear convolution of a load map (`load(i, j)`: N per cell on an `n` x `n` grid) with
/// the kernel whose [`kernel_spectrum`] is `spectrum`, on the `n` x `n` grid.
fn convolve(
    n: usize,
    load: impl Fn(usize, usize) -> f64,
    spectrum: &[Complex<f64>],
) -> Vec<Complex<f64>> {
    let [out] = convolve_each(n, load, [spectrum]);
    out
}

/// The linear convolutions of one load map with each of `K` kernels given by their spectra (see
/// [`convolve`]): the load is transformed once for all of them.
fn convolve_each<const K: usize>(
    n: usize,
    load: impl Fn(usize, usize) -> f64,
    spectra: [&[Complex<f64>]; K],
) -> [Vec<Complex<f64>>; K] {
    let m = 2 * n;
    let mut p = vec![Complex::new(0.0, 0.0); m * m];
    for j in 0..n {
        for i in 0..n {
            p[j * m + i] = Complex::new(load(i, j), 0.0);
        }
    }
    // The load fills the first n rows; the result is wanted on the first n columns.
    fft_2d_part(&mut p, m, false, n, m);
    let norm = 1.0 / (m * m) as f64;
    spectra.map(|spectrum| {
        let mut q: Vec<Complex<f64>> = p.iter().zip(spectrum).map(|(a, b)| *a * *b).collect();
        fft_2d_part(&mut q, m, true, m, n);
        let mut out = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                out.push(q[j * m + i] * norm);
            }
        }
        out
    })
}

/// D1 + i D2 in N/mm per cell for `pressure` (N/mm^2) seen through `layer`.
pub(crate) fn integrated_stress(pressure: &PressureMap, layer: &Layer) -> Vec<Complex<f64>> {
    let n = pressure.size();
    let cell = pressure.cell_mm();
    let area = cell * cell;
    let spectrum = normal_spectrum(layer, n, cell);
    convolve(n, |i, j| pressure.at(i, j) * area, &spectrum)
}

/// The spectrum of the through-layer Boussinesq kernel G e^(2 i phi) of a layer on a grid,
/// computed once per process for each (layer, grid): every press field of the grid (each
/// outline, each sphere radius) uses it.
fn normal_spectrum(layer: &Layer, n: usize, cell: f64) -> Arc<Vec<Complex<f64>>> {
    static CACHE: GridCache<Vec<Complex<f64>>> = OnceLock::new();
    per_layer_and_grid(&CACHE, layer, n, cell, || {
        normal_spectrum_of(layer, n, cell)
    })
}

/// A cache of what is computed once per process for each (layer, grid).
type GridCache<T> = OnceLock<Mutex<HashMap<(u64, u64, u64, usize, u64), Arc<T>>>>;

/// The value `cache` holds for `layer` on an `n` x `n` grid of `cell` mm, made by `make` the
/// first time.
fn per_layer_and_grid<T>(
    cache: &GridCache<T>,
    layer: &Layer,
    n: usize,
    cell: f64,
    make: impl FnOnce() -> T,
) -> Arc<T> {
    let key = (
        layer.z0_mm.to_bits(),
        layer.z1_mm.to_bits(),
        layer.nu.to_bits(),
        n,
        cell.to_bits(),
    );
    let cache = cache.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(found) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return Arc::clone(found);
    }
    let made = Arc::new(make());
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, Arc::clone(&made));
    made
}

fn normal_spectrum_of(layer: &Layer, n: usize, cell: f64) -> Vec<Complex<f64>> {
    let reg2 = 0.25 * cell * cell;
    // e^(2 i phi) averages to zero over the load's own cell.
    kernel_spectrum(n, |dx, dy| {
        let (x, y) = (dx as f64 * cell, dy as f64 * cell);
        let r2 = x * x + y * y;
        let g = layer.kernel((r2 + reg2).sqrt());
        // cos 2 phi = (x^2 - y^2) / r^2, sin 2 phi = 2 x y / r^2.
        Complex::new(g * (x * x - y * y) / r2, g * 2.0 * x * y / r2)
    })
}

/// Spectra of the through-layer Cerruti kernels (unit tangential load along +x, along +y) of a
/// layer on a grid, computed once per process for each (layer, grid): the quadrature behind
/// them takes a fraction of a second.
type TangentialSpectra = Arc<[Vec<Complex<f64>>; 2]>;

fn tangential_spectra(layer: &Layer, n: usize, cell: f64) -> TangentialSpectra {
    static CACHE: GridCache<[Vec<Complex<f64>>; 2]> = OnceLock::new();
    per_layer_and_grid(&CACHE, layer, n, cell, || {
        tangential_spectra_of(layer, n, cell)
    })
}

fn tangential_spectra_of(layer: &Layer, n: usize, cell: f64) -> [Vec<Complex<f64>>; 2] {
    // The +x kernel on one quadrant (D1 is odd in x and even in y, D2 even in x and odd in
    // y), at the cell offset pushed out to the regularised radius sqrt(r^2 + (cell / 2)^2).
    let span = n - 1;
    let reg2 = 0.25 * cell * cell;
    let mut quadrant = vec![[0.0f64; 2]; n * n];
    for dy in 0..=span {
        for dx in 0..=span {
            if dx == 0 && dy == 0 {
                continue;
            }
            let (x, y) = (dx as f64 * cell, dy as f64 * cell);
            let r2 = x * x + y * y;
            let stretch = ((r2 + reg2) / r2).sqrt();
            quadrant[dy * n + dx] = layer.tangential_kernel(x * stretch, y * stretch);
        }
    }
    let along_x = |dx: isize, dy: isize| {
        let [d1, d2] = quadrant[dy.unsigned_abs() * n + dx.unsigned_abs()];
        Complex::new(d1 * dx.signum() as f64, d2 * dy.signum() as f64)
    };
    // A load along +y is the +x load with x and y exchanged: D1 changes sign, D2 does not.
    let along_y = |dx: isize, dy: isize| {
        let c = along_x(dy, dx);
        Complex::new(-c.re, c.im)
    };
    [kernel_spectrum(n, along_x), kernel_spectrum(n, along_y)]
}

/// Computes the Cerruti kernel spectra of `layer` on an `n` x `n` grid of `cell` mm now, if
/// this process has not yet: the first [`tangential_stress`] on that grid then does not.
pub(crate) fn prepare_tangential(layer: &Layer, n: usize, cell: f64) {
    tangential_spectra(layer, n, cell);
}

/// D1 + i D2 in N/mm per cell of `traction` (per unit tangential force) seen through `layer`,
/// for the force along the indenter frame's +x and along its +y.
pub(crate) fn tangential_stress(traction: &TractionMap, layer: &Layer) -> [Vec<Complex<f64>>; 2] {
    let n = traction.size();
    let cell = traction.cell_mm();
    let area = cell * cell;
    let spectra = tangential_spectra(layer, n, cell);
    let load = |i: usize, j: usize| traction.at(i, j) * area;
    convolve_each(n, load, [&spectra[0], &spectra[1]])
}

impl FringeField {
    /// N_unit for the pressure map of a 1 N load (use [`PressureMap::new`] with force 1), seen
    /// through `layer` with material fringe value `f_sigma_n_per_m` (N/m per fringe).
    pub(crate) fn new(
        unit_pressure: &PressureMap,
        layer: &Layer,
        f_sigma_n_per_m: f64,
    ) -> FringeField {
        let d = integrated_stress(unit_pressure, layer);
        // D is in N/mm = 1000 N/m.
        let scale = 2.0 * 1000.0 / f_sigma_n_per_m;
        let values: Vec<f64> = d.iter().map(|c| scale * c.norm()).collect();
        FringeField::from_values(unit_pressure.size(), unit_pressure.cell_mm(), values)
    }

    /// The fringe order of depth-integrated stress differences `stress` (D1 + i D2, N/mm per
    /// cell, row-major on an `n` x `n` grid of `cell_mm`) through material fringe value
    /// `f_sigma_n_per_m`, with its gradient: a field of one load, not per newton. (The renderer
    /// builds its pushed fields in one pass of its own; the tests hold them to this.)
    #[cfg(test)]
    pub(crate) fn from_stress(
        n: usize,
        cell_mm: f64,
        stress: impl Iterator<Item = Complex<f64>>,
        f_sigma_n_per_m: f64,
    ) -> FringeField {
        let scale = 2.0 * 1000.0 / f_sigma_n_per_m;
        let values = stress.map(|c| scale * c.norm()).collect();
        FringeField::from_values(n, cell_mm, values)
    }

    /// Field from row-major values on an `n` x `n` grid (n at least 2), with its gradient.
    fn from_values(n: usize, cell_mm: f64, values: Vec<f64>) -> FringeField {
        let gradient = gradient_magnitude(&values, n, cell_mm);
        FringeField {
            n,
            cell_mm,
            values,
            gradient,
        }
    }

    /// Cells per side.
    pub(crate) fn size(&self) -> usize {
        self.n
    }

    /// Cell side, mm.
    pub(crate) fn cell_mm(&self) -> f64 {
        self.cell_mm
    }

    /// Fringe order per newton at cell (i, j).
    pub(crate) fn at(&self, i: usize, j: usize) -> f64 {
        self.values[j * self.n + i]
    }

    /// Largest fringe order per newton on the grid.
    pub(crate) fn max(&self) -> f64 {
        self.values.iter().copied().fold(0.0, f64::max)
    }

    /// |grad N_unit| at cell (i, j), fringe orders per newton per mm.
    pub(crate) fn gradient_at(&self, i: usize, j: usize) -> f64 {
        self.gradient[j * self.n + i]
    }

    /// Fringe order per newton at (x_mm, y_mm) in the indenter frame, bilinear between cell centres.
    /// Points beyond the grid take the value at the nearest grid edge.
    #[cfg(test)]
    pub(crate) fn sample(&self, x_mm: f64, y_mm: f64) -> f64 {
        self.bilinear(&self.values, x_mm, y_mm)
    }

    /// |grad N_unit| (fringe orders per newton per mm) at (x_mm, y_mm), sampled like
    /// [`FringeField::sample`]. For a force F the blur spread is sigma_N = F |grad N_unit| sigma_blur.
    #[cfg(test)]
    pub(crate) fn sample_gradient(&self, x_mm: f64, y_mm: f64) -> f64 {
        self.bilinear(&self.gradient, x_mm, y_mm)
    }

    #[cfg(test)]
    fn bilinear(&self, grid: &[f64], x_mm: f64, y_mm: f64) -> f64 {
        let at = |i: usize, j: usize| grid[j * self.n + i];
        let half = (self.n / 2) as f64;
        let last = (self.n - 1) as f64;
        let u = (x_mm / self.cell_mm + half).clamp(0.0, last);
        let v = (y_mm / self.cell_mm + half).clamp(0.0, last);
        let (i0, j0) = (u.floor() as usize, v.floor() as usize);
        let (i1, j1) = ((i0 + 1).min(self.n - 1), (j0 + 1).min(self.n - 1));
        let (fu, fv) = (u - i0 as f64, v - j0 as f64);
        let top = at(i0, j0) * (1.0 - fu) + at(i1, j0) * fu;
        let bottom = at(i0, j1) * (1.0 - fu) + at(i1, j1) * fu;
        top * (1.0 - fv) + bottom * fv
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::indenter::Shape;
    use crate::physics::traction::DEFAULT_EDGE_RADIUS_MM;
    use std::f64::consts::PI;

    const N: usize = 256;
    const CELL: f64 = 0.4;

    #[test]
    fn single_cell_load_reproduces_the_point_load_kernel() {
        let (ci, cj) = (100, 140);
        let map = PressureMap::point(N, CELL, ci, cj, 1.0);
        let d = integrated_stress(&map, &Layer::INTEGRATED);
        let peak = Layer::INTEGRATED.kernel(0.5 * CELL).abs();
        let mut worst: f64 = 0.0;
        for j in (0..N).step_by(7) {
            for i in (0..N).step_by(5) {
                let (x, y) = ((i as f64 - ci as f64) * CELL, (j as f64 - cj as f64) * CELL);
                let r2 = x * x + y * y;
                let expected = if r2 == 0.0 {
                    Complex::new(0.0, 0.0)
                } else {
                    let g = Layer::INTEGRATED.kernel((r2 + 0.25 * CELL * CELL).sqrt());
                    Complex::new(g * (x * x - y * y) / r2, g * 2.0 * x * y / r2)
                };
                worst = worst.max((d[j * N + i] - expected).norm() / peak);
            }
        }
        eprintln!("point-load max error relative to the kernel peak {worst:e}");
        assert!(worst < 1e-10, "{worst}");
    }

    #[test]
    fn single_cell_traction_reproduces_the_cerruti_kernel_both_ways() {
        let (ci, cj) = (60, 75);
        let layer = Layer::LAYERED;
        let d = tangential_stress(&TractionMap::point(N, CELL, ci, cj), &layer);
        let peak = layer.tangential_kernel(0.5 * CELL, 0.0)[0].abs();
        let mut worst: f64 = 0.0;
        for j in (0..N).step_by(7) {
            for i in (0..N).step_by(5) {
                let (x, y) = ((i as f64 - ci as f64) * CELL, (j as f64 - cj as f64) * CELL);
                let r2 = x * x + y * y;
                let (along_x, along_y) = if r2 == 0.0 {
                    (Complex::new(0.0, 0.0), Complex::new(0.0, 0.0))
                } else {
                    let k = ((r2 + 0.25 * CELL * CELL) / r2).sqrt();
                    let [a1, a2] = layer.tangential_kernel(k * x, k * y);
                    // Along +y: the +x kernel seen with x and y exchanged, D1 negated.
                    let [b1, b2] = layer.tangential_kernel(k * y, k * x);
                    (Complex::new(a1, a2), Complex::new(-b1, b2))
                };
                worst = worst.max((d[0][j * N + i] - along_x).norm() / peak);
                worst = worst.max((d[1][j * N + i] - along_y).norm() / peak);
            }
        }
        assert!(worst < 1e-9, "{worst}");
    }

    #[test]
    fn a_push_along_y_is_a_push_along_x_turned_a_quarter() {
        // Stress differences turn with twice the angle: a load turned by +90 degrees gives at P
        // what the unturned load gives at P turned back, times e^(i 180) = -1.
        let traction = TractionMap::new(&Shape::Circle { radius_mm: 3.0 }, N, CELL, 0.5, 0.5);
        let [along_x, along_y] = tangential_stress(&traction, &Layer::INTEGRATED);
        let c = (N / 2) as isize;
        let mut worst: f64 = 0.0;
        let peak = along_x.iter().fold(0.0f64, |m, v| m.max(v.norm()));
        for dy in (-40..=40).step_by(3) {
            for dx in (-40..=40).step_by(4) {
                // (x, y) turned back by 90 degrees is (y, -x).
                let p = ((c + dy) * N as isize + c + dx) as usize;
                let q = ((c - dx) * N as isize + c + dy) as usize;
                worst = worst.max((along_y[p] + along_x[q]).norm() / peak);
            }
        }
        assert!(worst < 1e-9, "{worst}");
    }

    #[test]
    fn a_sideways_push_makes_the_fringes_of_a_press_lopsided() {
        // A 4 N press of a 4 mm circular punch, pushed along +x with 2 N: the stress difference
        // ahead of the punch differs from that behind it, where a press alone is symmetric.
        let shape = Shape::Circle { radius_mm: 4.0 };
        let layer = Layer::LAYERED;
        let normal = integrated_stress(&PressureMap::new(&shape, N, CELL, 1.0), &layer);
        let traction = TractionMap::new(&shape, N, CELL, 0.4, DEFAULT_EDGE_RADIUS_MM);
        let [along_x, _] = tangential_stress(&traction, &layer);
        let at = |v: &[Complex<f64>], x_mm: f64| {
            let i = (N as f64 / 2.0 + x_mm / CELL).round() as usize;
            v[(N / 2) * N + i]
        };
        let combined = |x_mm: f64| (at(&normal, x_mm) * 4.0 + at(&along_x, x_mm) * 2.0).norm();
        let alone = |x_mm: f64| (at(&normal, x_mm) * 4.0).norm();
        for x in [2.8, 4.4, 6.0] {
            assert!(
                (alone(x) - alone(-x)).abs() < 1e-9 * alone(x),
                "{x}: press not symmetric"
            );
            let (ahead, behind) = (combined(x), combined(-x));
            assert!(
                (ahead - behind).abs() > 0.05 * ahead.max(behind),
                "{x} mm: ahead {ahead}, behind {behind}"
            );
        }
    }

    #[test]
    fn circular_punch_field_is_rotationally_symmetric_and_decays() {
        let map = PressureMap::new(&Shape::Circle { radius_mm: 5.0 }, N, CELL, 1.0);
        let field = FringeField::new(&map, &Layer::INTEGRATED, 100.0);
        let peak = field.max();
        let mut worst: f64 = 0.0;
        for &radius in &[2.0, 4.0, 6.0, 10.0, 20.0] {
            let samples: Vec<f64> = (0..72)
                .map(|k| {
                    let a = 2.0 * PI * k as f64 / 72.0;
                    field.sample(radius * a.cos(), radius * a.sin())
                })
                .collect();
            let max = samples.iter().copied().fold(f64::MIN, f64::max);
            let min = samples.iter().copied().fold(f64::MAX, f64::min);
            // Spread around the circle relative to the field's peak (inside the punch N is near 0).
            let spread = (max - min) / peak;
            worst = worst.max(spread);
            eprintln!("radius {radius}: N per newton {min}..{max}");
            assert!(
                spread < 0.02,
                "radius {radius}: spread {spread} of peak {peak}"
            );
        }
        eprintln!("circular punch worst angular spread / peak {worst:e}");
        let near = field.sample(6.0, 0.0);
        let far = field.sample(40.0, 0.0);
        eprintln!(
            "N per newton at 6 mm {near}, at 40 mm {far}, max {}",
            field.max()
        );
        assert!(far < 0.1 * near, "near {near} far {far}");
    }

    #[test]
    fn thin_film_fringes_hug_the_outline_more_than_the_thick_gel() {
        let map = PressureMap::new(&Shape::DEFAULT_RECTANGLE, N, CELL, 1.0);
        let film = FringeField::new(&map, &Layer::LAYERED, 20.0);
        let gel = FringeField::new(&map, &Layer::INTEGRATED, 100.0);
        // Ratio of the value 5 mm beyond the long edge to the value just outside it.
        let film_fall = film.sample(0.0, 8.0) / film.sample(0.0, 3.2);
        let gel_fall = gel.sample(0.0, 8.0) / gel.sample(0.0, 3.2);
        eprintln!(
            "9 N maxima: film {} gel {}; falls {film_fall} {gel_fall}",
            9.0 * film.max(),
            9.0 * gel.max()
        );
        assert!(film_fall < gel_fall, "film {film_fall} gel {gel_fall}");
    }

    #[test]
    fn sampling_interpolates_between_cell_centres() {
        let map = PressureMap::new(&Shape::DEFAULT_PENTAGON, 64, 0.5, 1.0);
        let field = FringeField::new(&map, &Layer::LAYERED, 20.0);
        // Cell (40, 32) is at x = 4 mm, y = 0; (41, 32) at x = 4.5 mm.
        assert_eq!(field.sample(4.0, 0.0), field.at(40, 32));
        let mid = field.sample(4.25, 0.0);
        assert!((mid - 0.5 * (field.at(40, 32) + field.at(41, 32))).abs() < 1e-12);
    }

    #[test]
    fn gradient_of_a_plane_is_its_slope_everywhere() {
        let (n, cell) = (16, 0.5);
        // N = 0.3 x + 0.4 y per mm (plus an offset): |grad N| = 0.5 per mm.
        let values = (0..n * n)
            .map(|k| 2.0 + 0.3 * (k % n) as f64 * cell + 0.4 * (k / n) as f64 * cell)
            .collect();
        let field = FringeField::from_values(n, cell, values);
        for j in 0..n {
            for i in 0..n {
                assert!((field.gradient_at(i, j) - 0.5).abs() < 1e-12);
            }
        }
        assert!((field.sample_gradient(1.23, -2.1) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn gradient_matches_finite_differences_of_the_sampled_field() {
        use rand::{Rng, SeedableRng};
        let (n, cell) = (128, 0.5);
        let map = PressureMap::new(&Shape::Circle { radius_mm: 5.0 }, n, cell, 1.0);
        let field = FringeField::new(&map, &Layer::INTEGRATED, 100.0);
        let steepest = field.gradient.iter().copied().fold(0.0, f64::max);
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            // Interior points clear of the punch edge (r = 5 mm) and of the grid edge (32 mm).
            let r = rng.gen_range(8.0..28.0);
            let a = rng.gen_range(0.0..2.0 * PI);
            let (x, y) = (r * a.cos(), r * a.sin());
            let h = cell;
            let gx = (field.sample(x + h, y) - field.sample(x - h, y)) / (2.0 * h);
            let gy = (field.sample(x, y + h) - field.sample(x, y - h)) / (2.0 * h);
            let err = (field.sample_gradient(x, y) - gx.hypot(gy)).abs() / steepest;
            worst = worst.max(err);
        }
        eprintln!("|grad N_unit| vs finite differences: max error / steepest {worst:e}");
        assert!(worst < 0.01, "{worst}");
        let near = field.sample_gradient(6.0, 0.0);
        let far = field.sample_gradient(28.0, 0.0);
        eprintln!("steepest {steepest}, at 6 mm {near}, at 28 mm {far} per newton per mm");
        assert!(far < 0.02 * steepest, "far {far} steepest {steepest}");
        assert!(near > 10.0 * far, "near {near} far {far}");
    }
}
