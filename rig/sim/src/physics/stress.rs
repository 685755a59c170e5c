//! Through-layer integral of the Boussinesq point-load stress difference.
//!
//! A normal point load P on an elastic half-space (Johnson, *Contact Mechanics*, 1985, section 3.2)
//! gives, with rho = sqrt(r^2 + z^2),
//!
//! - s_r = (P / 2 pi) [ (1 - 2 nu) / r^2 (1 - z / rho) - 3 z r^2 / rho^5 ],
//! - s_theta = -(P / 2 pi)(1 - 2 nu) [ (1 - z / rho) / r^2 - z / rho^3 ].
//!
//! A camera looking along the load axis integrates the secondary principal stress difference through
//! the photoelastic layer (linear integrated photoelasticity, Aben). For a point load that is
//! integral (s_r - s_theta) dz = P G(r), with the closed form (docs/photoelastic-sim.md)
//!
//! Phi(z) = 2 (1 - 2 nu)(z - rho) / r^2 + (1 - 2 nu) / rho + r^2 / rho^3,
//! G(r) = [Phi(z1) - Phi(z0)] / (2 pi).
//!
//! `z - rho` is evaluated as `-r^2 / (z + rho)` so deep layers lose no precision. The tests check the
//! closed form against adaptive quadrature of the stresses above, the half-space limit
//! -nu / (pi r) and the incompressible-layer form (1 / 2 pi)[r^2 / (r^2 + h^2)^(3/2) - 1 / r].

use std::f64::consts::PI;

/// Antiderivative Phi(z) of 2 pi (s_r - s_theta) / P with respect to depth z.
fn phi(r: f64, z: f64, nu: f64) -> f64 {
    let rho = (r * r + z * z).sqrt();
    let k = 1.0 - 2.0 * nu;
    // 2 k (z - rho) / r^2 == -2 k / (z + rho), free of cancellation for z >> r.
    -2.0 * k / (z + rho) + k / rho + r * r / (rho * rho * rho)
}

/// Integral of (s_r - s_theta) over depth z from `z0_mm` to `z1_mm` (0 = loaded surface), per unit
/// normal load, at radial distance `r_mm` from the load, for Poisson's ratio `nu`.
///
/// Units: with the load in newtons and lengths in millimetres the result is in N/mm per N, i.e. 1/mm.
/// Negative near the load (hoop stress exceeds radial stress in the surface layer). Requires
/// `r_mm > 0` (regularise r before calling) and `0 <= z0_mm <= z1_mm`.
pub(crate) fn layer_kernel(r_mm: f64, z0_mm: f64, z1_mm: f64, nu: f64) -> f64 {
    (phi(r_mm, z1_mm, nu) - phi(r_mm, z0_mm, nu)) / (2.0 * PI)
}

/// A photoelastic layer between two depths below the loaded surface of an elastic half-space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    /// Depth of the top of the photoelastic layer below the contact surface, mm.
    pub z0_mm: f64,
    /// Depth of the bottom of the photoelastic layer, mm (>= `z0_mm`).
    pub z1_mm: f64,
    /// Poisson's ratio of the half-space (0.49 for a nearly incompressible gel).
    pub nu: f64,
}

impl Layer {
    /// The integrated sensor: the whole 20 mm gel is photoelastic.
    pub const INTEGRATED: Layer = Layer {
        z0_mm: 0.0,
        z1_mm: 20.0,
        nu: 0.49,
    };
    /// The layered sensor: a 1 mm photoelastic film at the contact side.
    pub const LAYERED: Layer = Layer {
        z0_mm: 0.0,
        z1_mm: 1.0,
        nu: 0.49,
    };

    /// [`layer_kernel`] for this layer.
    pub fn kernel(&self, r_mm: f64) -> f64 {
        layer_kernel(r_mm, self.z0_mm, self.z1_mm, self.nu)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Boussinesq s_r - s_theta per unit load (Johnson 3.2), straight from the stress formulas.
    /// `(1 - z / rho) / r^2` is written `1 / (rho (rho + z))` (same value) so that deep, near-axis
    /// points (r = 0.05 mm at z = 20 mm) do not lose digits to cancellation.
    fn stress_difference(r: f64, z: f64, nu: f64) -> f64 {
        let rho = (r * r + z * z).sqrt();
        let k = 1.0 - 2.0 * nu;
        let one_minus_z_over_rho_by_r2 = 1.0 / (rho * (rho + z));
        let s_r = (k * one_minus_z_over_rho_by_r2 - 3.0 * z * r * r / rho.powi(5)) / (2.0 * PI);
        let s_t = -k * (one_minus_z_over_rho_by_r2 - z / rho.powi(3)) / (2.0 * PI);
        s_r - s_t
    }

    fn simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
        (b - a) / 6.0 * (f(a) + 4.0 * f(0.5 * (a + b)) + f(b))
    }

    fn adaptive(f: &dyn Fn(f64) -> f64, a: f64, b: f64, whole: f64, tol: f64, depth: u32) -> f64 {
        let m = 0.5 * (a + b);
        let left = simpson(f, a, m);
        let right = simpson(f, m, b);
        if depth == 0 || (left + right - whole).abs() <= 15.0 * tol {
            return left + right + (left + right - whole) / 15.0;
        }
        adaptive(f, a, m, left, tol / 2.0, depth - 1)
            + adaptive(f, m, b, right, tol / 2.0, depth - 1)
    }

    fn quadrature(r: f64, z0: f64, z1: f64, nu: f64) -> f64 {
        let f = |z: f64| stress_difference(r, z, nu);
        adaptive(&f, z0, z1, simpson(&f, z0, z1), 1e-14, 50)
    }

    #[test]
    fn closed_form_matches_quadrature_of_boussinesq_stresses() {
        let mut worst: f64 = 0.0;
        for &nu in &[0.3, 0.49] {
            for &(z0, z1) in &[(0.0, 20.0), (0.0, 1.0), (19.0, 20.0), (2.0, 7.5)] {
                for &r in &[0.05, 0.3, 1.0, 2.5, 5.0, 12.0, 30.0] {
                    let closed = layer_kernel(r, z0, z1, nu);
                    let numeric = quadrature(r, z0, z1, nu);
                    let rel = (closed - numeric).abs() / numeric.abs().max(1e-12);
                    worst = worst.max(rel);
                    // The worst case (r = 0.05 mm, slab 19..20 mm, about 5e-10) is the closed form
                    // subtracting two nearly equal Phi values; absolutely it is 4e-18 per mm.
                    assert!(
                        rel < 1e-8,
                        "r={r} z={z0}..{z1} nu={nu}: closed {closed} vs quadrature {numeric}"
                    );
                }
            }
        }
        eprintln!("max relative quadrature error {worst:e}");
    }

    #[test]
    fn deep_layer_tends_to_half_space_limit() {
        for &nu in &[0.3, 0.49] {
            for &r in &[0.5, 2.0, 10.0] {
                let deep = layer_kernel(r, 0.0, 1e7, nu);
                let limit = -nu / (PI * r);
                assert!(
                    ((deep - limit) / limit).abs() < 1e-6,
                    "r={r} nu={nu}: {deep} vs -nu/(pi r) = {limit}"
                );
            }
        }
    }

    #[test]
    fn incompressible_layer_matches_its_closed_form() {
        for &h in &[1.0, 20.0] {
            for &r in &[0.2, 3.0, 15.0] {
                let g = layer_kernel(r, 0.0, h, 0.5);
                let expected = (r * r / (r * r + h * h).powf(1.5) - 1.0 / r) / (2.0 * PI);
                assert!(
                    ((g - expected) / expected).abs() < 1e-12,
                    "h={h} r={r}: {g} vs {expected}"
                );
            }
        }
    }

    #[test]
    fn thin_layer_kernel_is_concentrated_near_the_load() {
        // A 1 mm film sees a steeply falling kernel; the 20 mm gel a much broader one.
        let film = Layer::LAYERED;
        let gel = Layer::INTEGRATED;
        let film_ratio = film.kernel(10.0) / film.kernel(1.0);
        let gel_ratio = gel.kernel(10.0) / gel.kernel(1.0);
        assert!(
            film_ratio.abs() < gel_ratio.abs(),
            "{film_ratio} vs {gel_ratio}"
        );
    }
}
