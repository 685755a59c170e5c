//! Tangential traction under an indenter pushed sideways: where the contact sticks, where it
//! slips, and how the tangential force spreads over it.
//!
//! **Full stick.** A rigid indenter displaced sideways while its whole contact sticks carries
//! the traction of a rigid punch of the contact's outline; for a nearly incompressible layer
//! (nu -> 1/2) tangential and normal problems uncouple and that traction has the shape of the
//! rigid flat punch's normal pressure over the same outline (Johnson, *Contact Mechanics*, 1985,
//! sections 3.8 and 7.1): q ~ (d + eps)^(-1/2) near a straight edge at inside distance d, and
//! 1 / sqrt(a^2 - r^2) on a circle of radius a ([`stick_shape`], regularised like the pressure
//! maps with eps = half a cell).
//!
//! **Friction limit.** Coulomb friction bounds the traction by mu p. Where the stick traction
//! would exceed it the contact slips and carries mu p; elsewhere it sticks. This module takes
//! the traction as q = min(mu p_f, lambda s) with s the stick shape and lambda set so that the
//! traction carries the tangential force Q ([`TractionMap::new`]): the slip zone grows from where
//! p_f is small against s, the stick zone shrinks as Q grows, and at Q = mu P the whole contact
//! slips with q = mu p_f (gross slip). It is exact in both limits. Between them it approximates
//! Cattaneo and Mindlin's partial slip (Johnson section 7.2: for a Hertz sphere the stick radius
//! is c = a (1 - Q / mu P)^(1/3)); the tests hold the stick radius of a sphere within 0.12 a of
//! theirs.
//!
//! **Which pressure bounds the traction.** For the sphere, p_f is its Hertz pressure, which falls
//! to zero at the edge where the stick traction is largest, so slip starts at the rim and spreads
//! inwards. A perfectly sharp flat punch would press exactly as it sticks (p and s have one
//! shape) and go from full stick to gross slip at once; real punches have rounded edges, whose
//! pressure falls to zero over the rounding. p_f of a flat punch is therefore its pressure map
//! times sqrt(min(1, d / r_e)) with r_e the edge radius (0.5 mm by default,
//! [`DEFAULT_EDGE_RADIUS_MM`]), renormalised to the same force: a slip band of up to r_e opens at
//! the edges before the punch slides. The rendered normal stress keeps the sharp punch's map
//! (docs/photoelastic-sim.md, "Shear and slip").

use crate::physics::indenter::{PressureMap, Shape, SUBSAMPLES};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Edge rounding of the flat punches, mm: the width over which their pressure falls to zero at
/// the outline, and so the widest slip band before gross slip.
pub(crate) const DEFAULT_EDGE_RADIUS_MM: f64 = 0.5;

/// Bisection steps for lambda (the result is good to 2^-60 of its bracket).
const BISECTION_STEPS: usize = 80;

/// The stick traction's shape at (x, y) mm of `shape`'s contact (unnormalised), `eps_mm` the
/// regularisation: the rigid punch law over the contact outline.
fn stick_shape(shape: &Shape, x: f64, y: f64, eps_mm: f64) -> f64 {
    let d = shape.inside_distance_mm(x, y);
    if d <= 0.0 {
        return 0.0;
    }
    match *shape {
        Shape::Pentagon { .. } | Shape::Rectangle { .. } => 1.0 / (d + eps_mm).sqrt(),
        Shape::Circle { radius_mm } => 1.0 / ((d + eps_mm) * (2.0 * radius_mm - d)).sqrt(),
        Shape::Sphere {
            contact_radius_mm, ..
        } => 1.0 / ((d + eps_mm) * (2.0 * contact_radius_mm - d)).sqrt(),
    }
}

/// The factor that rounds a flat punch's edge pressure off over `edge_radius_mm`; 1 for the
/// sphere, whose Hertz pressure already falls to zero at its rim.
fn edge_rounding(shape: &Shape, x: f64, y: f64, edge_radius_mm: f64) -> f64 {
    match shape {
        Shape::Sphere { .. } => 1.0,
        _ if edge_radius_mm <= 0.0 => 1.0,
        _ => {
            let d = shape.inside_distance_mm(x, y).max(0.0);
            (d / edge_radius_mm).min(1.0).sqrt()
        }
    }
}

/// Tangential traction magnitude per unit tangential force (1/mm^2) on the grid of a pressure
/// map, all of it along the tangential force, for one ratio Q / (mu P).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TractionMap {
    n: usize,
    cell_mm: f64,
    values: Vec<f64>,
    /// Share of the contact's cells that stick.
    stick_fraction: f64,
}

/// What the traction maps of one shape share at every ratio Q / (mu P): the friction limit per
/// unit mu P and the stick shape per unit Q, cell by cell (the costly part of a map: sub-samples
/// of every cell).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TractionBasis {
    n: usize,
    cell_mm: f64,
    limit: Vec<f64>,
    stick: Vec<f64>,
}

impl TractionBasis {
    /// The basis of `shape` on an `n` x `n` grid of `cell_mm` cells centred on it, flat punch
    /// edges rounded over `edge_radius_mm`.
    pub(crate) fn new(shape: &Shape, n: usize, cell_mm: f64, edge_radius_mm: f64) -> TractionBasis {
        let pressure = PressureMap::new(shape, n, cell_mm, 1.0);
        let n = pressure.size();
        let half = (n / 2) as f64;
        let eps = 0.5 * cell_mm;
        let area = cell_mm * cell_mm;
        // The friction limit per unit mu P and the stick shape per unit Q, cell by cell, each
        // averaged over the pressure map's sub-samples of the cell.
        let mut limit = Vec::with_capacity(n * n);
        let mut stick = Vec::with_capacity(n * n);
        let sub = |k: usize| (k as f64 + 0.5) / SUBSAMPLES as f64 - 0.5;
        for j in 0..n {
            for i in 0..n {
                let (mut rounding, mut s) = (0.0, 0.0);
                for sj in 0..SUBSAMPLES {
                    for si in 0..SUBSAMPLES {
                        let x = (i as f64 - half + sub(si)) * cell_mm;
                        let y = (j as f64 - half + sub(sj)) * cell_mm;
                        rounding += edge_rounding(shape, x, y, edge_radius_mm);
                        s += stick_shape(shape, x, y, eps);
                    }
                }
                let samples = (SUBSAMPLES * SUBSAMPLES) as f64;
                limit.push(pressure.at(i, j) * rounding / samples);
                stick.push(s / samples);
            }
        }
        normalise(&mut limit, area);
        normalise(&mut stick, area);
        TractionBasis {
            n,
            cell_mm,
            limit,
            stick,
        }
    }

    /// The traction carrying a tangential force `ratio` times the friction limit mu P
    /// (`ratio` in 0..=1; 0 gives the full-stick shape, 1 gross slip).
    pub(crate) fn map(&self, ratio: f64) -> TractionMap {
        let ratio = if ratio.is_finite() {
            ratio.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (n, cell_mm) = (self.n, self.cell_mm);
        let area = cell_mm * cell_mm;
        let (limit, stick) = (&self.limit, &self.stick);
        let contact_cells = limit.iter().filter(|&&p| p > 0.0).count().max(1);
        let carried = |lambda: f64| -> f64 {
            limit
                .iter()
                .zip(stick)
                .map(|(&p, &s)| p.min(lambda * s))
                .sum::<f64>()
                * area
        };
        let (values, stick_fraction) = if ratio <= 0.0 {
            (stick.clone(), 1.0)
        } else if ratio >= 1.0 {
            (limit.clone(), 0.0)
        } else {
            // carried(lambda) rises from 0 to 1 with lambda: bracket and bisect.
            let (mut lo, mut hi) = (0.0, ratio.max(1e-12));
            while carried(hi) < ratio && hi < 1e12 {
                hi *= 2.0;
            }
            for _ in 0..BISECTION_STEPS {
                let mid = 0.5 * (lo + hi);
                if carried(mid) < ratio {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let lambda = hi;
            let mut sticking = 0usize;
            let values = limit
                .iter()
                .zip(stick)
                .map(|(&p, &s)| {
                    if p > 0.0 && lambda * s < p {
                        sticking += 1;
                    }
                    p.min(lambda * s) / ratio
                })
                .collect();
            (values, sticking as f64 / contact_cells as f64)
        };
        TractionMap {
            n,
            cell_mm,
            values,
            stick_fraction,
        }
    }
}

impl TractionMap {
    /// The traction of `shape` (on an `n` x `n` grid of `cell_mm` cells centred on it) carrying
    /// a tangential force `ratio` times the friction limit mu P (`ratio` in 0..=1; 0 gives the
    /// full-stick shape, 1 gross slip), flat punch edges rounded over `edge_radius_mm`. The maps
    /// of one shape at several ratios share a [`TractionBasis`].
    pub(crate) fn new(
        shape: &Shape,
        n: usize,
        cell_mm: f64,
        ratio: f64,
        edge_radius_mm: f64,
    ) -> TractionMap {
        TractionBasis::new(shape, n, cell_mm, edge_radius_mm).map(ratio)
    }

    /// A unit tangential force on the one cell (i, j) of an `n` x `n` grid.
    #[cfg(test)]
    pub(crate) fn point(n: usize, cell_mm: f64, i: usize, j: usize) -> TractionMap {
        let mut values = vec![0.0; n * n];
        values[j * n + i] = 1.0 / (cell_mm * cell_mm);
        TractionMap {
            n,
            cell_mm,
            values,
            stick_fraction: 1.0,
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

    /// Traction per unit tangential force at cell (i, j), 1/mm^2.
    pub(crate) fn at(&self, i: usize, j: usize) -> f64 {
        self.values[j * self.n + i]
    }

    /// Share of the contact's cells that stick (1 at full stick, 0 in gross slip).
    pub(crate) fn stick_fraction(&self) -> f64 {
        self.stick_fraction
    }
}

/// Below this share of its cells sticking, a contact is in partial slip.
pub(crate) const PARTIAL_SLIP_BELOW: f64 = 0.9;

/// The share of the friction (Q / mu P) at which `shape` has a tenth of its contact slipping
/// ([`PARTIAL_SLIP_BELOW`]), flat punch edges rounded over [`DEFAULT_EDGE_RADIUS_MM`]: where a
/// contact goes from stick to partial slip. Found by bisection on a 0.1 mm grid, once per
/// outline and process (a sphere's traction has one shape at every radius).
pub(crate) fn partial_slip_onset(shape: &Shape) -> f64 {
    static CACHE: OnceLock<Mutex<HashMap<[u64; 3], f64>>> = OnceLock::new();
    let key = match *shape {
        Shape::Pentagon { circumradius_mm } => [0, circumradius_mm.to_bits(), 0],
        Shape::Rectangle {
            width_mm,
            height_mm,
        } => [1, width_mm.to_bits(), height_mm.to_bits()],
        Shape::Circle { radius_mm } => [2, radius_mm.to_bits(), 0],
        Shape::Sphere { .. } => [3, 0, 0],
    };
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(&found) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return found;
    }
    // The sphere at a 3 mm contact radius; the others as they are. The grid spans the outline.
    let shape = match *shape {
        Shape::Sphere { radius_mm, .. } => Shape::Sphere {
            radius_mm,
            contact_radius_mm: 3.0,
        },
        other => other,
    };
    let cell = 0.1;
    let reach = (0..=200)
        .map(|k| k as f64 * cell)
        .find(|&r| {
            (0..16).all(|a| {
                let (s, c) = (a as f64 * std::f64::consts::PI / 8.0).sin_cos();
                !shape.contains(r * c, r * s)
            })
        })
        .unwrap_or(20.0);
    let n = 2 * ((reach / cell).ceil() as usize + 4);
    let sticking = |ratio: f64| {
        TractionMap::new(&shape, n, cell, ratio, DEFAULT_EDGE_RADIUS_MM).stick_fraction()
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..14 {
        let mid = 0.5 * (lo + hi);
        if sticking(mid) < PARTIAL_SLIP_BELOW {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let onset = 0.5 * (lo + hi);
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, onset);
    onset
}

/// Scales `values` (per cell, `area` mm^2 each) to carry 1 in all; all zero stays zero.
fn normalise(values: &mut [f64], area: f64) {
    let total: f64 = values.iter().sum::<f64>() * area;
    if total > 0.0 {
        values.iter_mut().for_each(|v| *v /= total);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const N: usize = 128;
    const CELL: f64 = 0.125;

    fn total(map: &TractionMap) -> f64 {
        let mut sum = 0.0;
        for j in 0..map.size() {
            for i in 0..map.size() {
                sum += map.at(i, j);
            }
        }
        sum * map.cell_mm() * map.cell_mm()
    }

    /// Radius of the sticking disc of a sphere's traction map: the largest radius r of a cell
    /// whose traction is below the friction limit, scanned along +x from the centre.
    fn stick_radius(shape: &Shape, ratio: f64) -> f64 {
        let map = TractionMap::new(shape, N, CELL, ratio, DEFAULT_EDGE_RADIUS_MM);
        let full = TractionMap::new(shape, N, CELL, 1.0, DEFAULT_EDGE_RADIUS_MM);
        let j = N / 2;
        let mut radius = 0.0;
        for i in N / 2..N {
            // Traction of this ratio against mu p (per unit Q: mu p / ratio).
            if map.at(i, j) * ratio < full.at(i, j) * (1.0 - 1e-9) {
                radius = (i - N / 2) as f64 * CELL;
            }
        }
        radius
    }

    #[test]
    fn every_ratio_carries_the_whole_tangential_force_inside_the_contact() {
        for shape in [
            Shape::DEFAULT_PENTAGON,
            Shape::DEFAULT_RECTANGLE,
            Shape::sphere_hertz(5.0, 9.0, 0.66),
        ] {
            for ratio in [0.0, 0.2, 0.6, 0.95, 1.0] {
                let map = TractionMap::new(&shape, N, CELL, ratio, DEFAULT_EDGE_RADIUS_MM);
                assert!((total(&map) - 1.0).abs() < 1e-9, "{shape:?} at {ratio}");
                let half = (N / 2) as f64;
                for j in 0..N {
                    for i in 0..N {
                        let (x, y) = ((i as f64 - half) * CELL, (j as f64 - half) * CELL);
                        if shape.inside_distance_mm(x, y) < -CELL {
                            assert_eq!(map.at(i, j), 0.0, "{shape:?} outside at ({x}, {y})");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn a_sphere_sticks_inside_a_disc_that_shrinks_as_cattaneo_and_mindlin_say() {
        let shape = Shape::sphere_hertz(5.0, 9.0, 0.66);
        let Shape::Sphere {
            contact_radius_mm: a,
            ..
        } = shape
        else {
            unreachable!("a sphere")
        };
        let mut last = f64::INFINITY;
        for ratio in [0.1, 0.3, 0.5, 0.7, 0.9] {
            let c = stick_radius(&shape, ratio);
            let theory = a * (1.0 - ratio).cbrt();
            assert!(
                (c - theory).abs() < 0.12 * a,
                "Q/muP {ratio}: stick radius {c:.3} mm, Cattaneo-Mindlin {theory:.3} mm (a {a:.3})"
            );
            assert!(c < last, "the stick zone did not shrink at {ratio}");
            last = c;
        }
    }

    #[test]
    fn a_flat_punch_slips_in_its_rounded_edge_band_first_and_then_all_at_once() {
        let shape = Shape::DEFAULT_PENTAGON;
        let mut last = 1.0;
        for ratio in [0.1, 0.5, 0.9, 0.99] {
            let map = TractionMap::new(&shape, N, CELL, ratio, DEFAULT_EDGE_RADIUS_MM);
            let f = map.stick_fraction();
            assert!(f <= last, "stick fraction rose to {f} at {ratio}");
            // The band of 0.5 mm along a 5 mm pentagon's edges is about a fifth of its area;
            // the core sticks until gross slip.
            assert!(f > 0.7, "{ratio}: only {f} sticks");
            last = f;
        }
        let light = TractionMap::new(&shape, N, CELL, 0.1, DEFAULT_EDGE_RADIUS_MM);
        assert!(light.stick_fraction() > 0.95, "{}", light.stick_fraction());
        assert!(last < 0.85, "no band slipped before gross slip: {last}");
        let sliding = TractionMap::new(&shape, N, CELL, 1.0, DEFAULT_EDGE_RADIUS_MM);
        assert_eq!(sliding.stick_fraction(), 0.0);
        // A sharp punch has no band: it sticks everywhere until it slides.
        let sharp = TractionMap::new(&shape, N, CELL, 0.9, 0.0);
        assert!(sharp.stick_fraction() > 0.99, "{}", sharp.stick_fraction());
    }

    #[test]
    fn partial_slip_starts_earlier_on_a_sphere_than_on_a_flat_punch() {
        let sphere = partial_slip_onset(&Shape::sphere_hertz(5.0, 9.0, 0.66));
        let pentagon = partial_slip_onset(&Shape::DEFAULT_PENTAGON);
        let rectangle = partial_slip_onset(&Shape::DEFAULT_RECTANGLE);
        eprintln!("onset of partial slip: sphere {sphere:.3}, pentagon {pentagon:.3}, rectangle {rectangle:.3}");
        // Cattaneo-Mindlin: a tenth of a sphere's contact slips at Q / mu P = 1 - 0.9^1.5 = 0.15.
        assert!(sphere > 0.08 && sphere < 0.3, "{sphere}");
        for flat in [pentagon, rectangle] {
            assert!(flat > sphere && flat < 0.95, "{flat}");
        }
        // The same sphere at another size starts at the same share.
        assert_eq!(
            sphere,
            partial_slip_onset(&Shape::sphere_hertz(5.0, 2.0, 0.66))
        );
    }
}
