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
//!
//! A tangential point load Q along +x (Cerruti; Johnson, section 2.3) gives, with
//! k = 1 - 2 nu, per unit load,
//!
//! - s_x = (x / 2 pi rho^3) [ -3 x^2 / rho^2 + k / (rho + z)^2 (rho^2 - y^2 - 2 rho y^2 / (rho + z)) ],
//! - s_y = (x / 2 pi rho^3) [ -3 y^2 / rho^2 + k / (rho + z)^2 (3 rho^2 - x^2 - 2 rho x^2 / (rho + z)) ],
//! - t_xy = (y / 2 pi rho^3) [ -3 x^2 / rho^2 - k / (rho + z)^2 (rho^2 - x^2 - 2 rho x^2 / (rho + z)) ].
//!
//! Its field has no axis of symmetry, so the camera sees both secondary stress differences,
//! integral (s_x - s_y) dz and integral 2 t_xy dz ([`tangential_layer_kernel`]), integrated by
//! graded Gauss-Legendre quadrature. The tests derive the stresses afresh from Cerruti's
//! displacements by finite differences and Hooke's law (the same derivation reproduces the
//! Boussinesq closed form above, which fixes the signs), and check the loaded surface is free
//! of traction away from the load.

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

/// In-plane stresses [s_x, s_y, t_xy] (tension positive) at (x, y, z) of a unit tangential
/// point load along +x on the surface of an elastic half-space (Cerruti), z the depth below
/// the surface; 1/mm^2 per N. Requires rho = |(x, y, z)| > 0.
pub(crate) fn cerruti_stress(x: f64, y: f64, z: f64, nu: f64) -> [f64; 3] {
    let rho2 = x * x + y * y + z * z;
    let rho = rho2.sqrt();
    let k = 1.0 - 2.0 * nu;
    let rz = rho + z;
    let a = 1.0 / (2.0 * PI * rho2 * rho);
    let b = k / (rz * rz);
    let s_x = x * a * (-3.0 * x * x / rho2 + b * (rho2 - y * y - 2.0 * rho * y * y / rz));
    let s_y = x * a * (-3.0 * y * y / rho2 + b * (3.0 * rho2 - x * x - 2.0 * rho * x * x / rz));
    let t_xy = y * a * (-3.0 * x * x / rho2 - b * (rho2 - x * x - 2.0 * rho * x * x / rz));
    [s_x, s_y, t_xy]
}

/// Gauss-Legendre nodes and weights on [-1, 1], 10 points.
const GAUSS_10: [(f64, f64); 5] = [
    (0.148_874_338_981_631_2, 0.295_524_224_714_752_87),
    (0.433_395_394_129_247_2, 0.269_266_719_309_996_35),
    (0.679_409_568_299_024_4, 0.219_086_362_515_982_04),
    (0.865_063_366_688_984_5, 0.149_451_349_150_580_6),
    (0.973_906_528_517_171_7, 0.066_671_344_308_688_14),
];

/// [integral (s_x - s_y) dz, integral 2 t_xy dz] over depths `z0_mm`..`z1_mm` of a unit
/// tangential point load along +x, seen at (`x_mm`, `y_mm`) from it: the secondary stress
/// differences a camera looking along z integrates, 1/mm per N (as [`layer_kernel`]).
/// Requires (x, y) != 0 (regularise before calling) and `0 <= z0_mm <= z1_mm`.
///
/// The stresses vary on the scale of the distance r from the load near the surface and more
/// slowly below, so the depth is cut at z0 + r/8, z0 + r/4, ... (doubling) and each piece
/// integrated with 10-point Gauss-Legendre.
pub(crate) fn tangential_layer_kernel(
    x_mm: f64,
    y_mm: f64,
    z0_mm: f64,
    z1_mm: f64,
    nu: f64,
) -> [f64; 2] {
    let r = x_mm.hypot(y_mm);
    let mut sum = [0.0f64; 2];
    let mut lo = z0_mm;
    let mut step = r / 8.0;
    while lo < z1_mm {
        let hi = (lo + step).min(z1_mm);
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        for &(t, w) in &GAUSS_10 {
            for z in [mid - half * t, mid + half * t] {
                let [s_x, s_y, t_xy] = cerruti_stress(x_mm, y_mm, z, nu);
                sum[0] += w * half * (s_x - s_y);
                sum[1] += w * half * 2.0 * t_xy;
            }
        }
        lo = hi;
        step *= 2.0;
    }
    sum
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

    /// [`tangential_layer_kernel`] for this layer.
    pub(crate) fn tangential_kernel(&self, x_mm: f64, y_mm: f64) -> [f64; 2] {
        tangential_layer_kernel(x_mm, y_mm, self.z0_mm, self.z1_mm, self.nu)
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

    /// Displacement per unit load (shear modulus 1) at (x, y, z) of a point load on the surface
    /// of a half-space: `tangential` along +x (Cerruti) or normal, into the solid
    /// (Boussinesq); Johnson, sections 2.2-2.3, with k = 1 - 2 nu.
    fn displacement(tangential: bool, p: [f64; 3], nu: f64) -> [f64; 3] {
        let [x, y, z] = p;
        let rho = (x * x + y * y + z * z).sqrt();
        let (k, c) = (1.0 - 2.0 * nu, 1.0 / (4.0 * PI));
        let rz = rho + z;
        if tangential {
            [
                c * (1.0 / rho + x * x / rho.powi(3) + k * (1.0 / rz - x * x / (rho * rz * rz))),
                c * (x * y / rho.powi(3) - k * x * y / (rho * rz * rz)),
                c * (x * z / rho.powi(3) + k * x / (rho * rz)),
            ]
        } else {
            [
                c * (x * z / rho.powi(3) - k * x / (rho * rz)),
                c * (y * z / rho.powi(3) - k * y / (rho * rz)),
                c * (z * z / rho.powi(3) + 2.0 * (1.0 - nu) / rho),
            ]
        }
    }

    /// The stress tensor from [`displacement`] by central differences and Hooke's law (shear
    /// modulus 1), independent of the stress formulas under test.
    fn stress_from_displacement(tangential: bool, p: [f64; 3], nu: f64) -> [[f64; 3]; 3] {
        let h = 1e-5 * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        let mut grad = [[0.0; 3]; 3]; // grad[i][j] = d u_i / d x_j
        for j in 0..3 {
            let (mut a, mut b) = (p, p);
            a[j] += h;
            b[j] -= h;
            let (ua, ub) = (
                displacement(tangential, a, nu),
                displacement(tangential, b, nu),
            );
            for i in 0..3 {
                grad[i][j] = (ua[i] - ub[i]) / (2.0 * h);
            }
        }
        let lambda = 2.0 * nu / (1.0 - 2.0 * nu);
        let trace = grad[0][0] + grad[1][1] + grad[2][2];
        let mut s = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] = grad[i][j] + grad[j][i] + if i == j { lambda * trace } else { 0.0 };
            }
        }
        s
    }

    #[test]
    fn cerruti_stresses_are_those_of_its_displacements_and_leave_the_surface_free() {
        for &nu in &[0.3, 0.49] {
            for &p in &[
                [1.3, 0.7, 0.9],
                [-2.0, 0.4, 0.2],
                [0.3, -1.1, 3.0],
                [4.0, 3.0, 0.05],
            ] {
                let s = stress_from_displacement(true, p, nu);
                let got = cerruti_stress(p[0], p[1], p[2], nu);
                let scale = s.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
                for (g, want) in got.iter().zip([s[0][0], s[1][1], s[0][1]]) {
                    assert!(
                        (g - want).abs() < 1e-6 * scale,
                        "{p:?} nu={nu}: {got:?} vs {:?}",
                        [s[0][0], s[1][1], s[0][1]]
                    );
                }
            }
            // Just below the surface, away from the load: s_zz, s_xz, s_yz vanish.
            for &(x, y) in &[(1.3, 0.7), (-0.4, 2.0)] {
                let s = stress_from_displacement(true, [x, y, 1e-4], nu);
                let inside = stress_from_displacement(true, [x, y, 1.0], nu);
                let scale = inside.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
                for v in [s[2][0], s[2][1], s[2][2]] {
                    assert!(v.abs() < 1e-3 * scale, "({x}, {y}): surface traction {v}");
                }
            }
        }
    }

    #[test]
    fn boussinesq_through_the_same_derivation_is_the_closed_form_kernel() {
        // Fixes the signs: the stresses derived from displacements, integrated through the layer,
        // give G(r) of the closed form (tension positive, load pressing in).
        for &(z0, z1) in &[(0.0, 1.0), (0.0, 20.0)] {
            for &r in &[0.3, 2.5, 8.0] {
                let f = |z: f64| {
                    let s = stress_from_displacement(false, [r, 0.0, z], 0.49);
                    s[0][0] - s[1][1]
                };
                let numeric = adaptive(&f, z0, z1, simpson(&f, z0, z1), 1e-11, 40);
                let closed = layer_kernel(r, z0, z1, 0.49);
                assert!(
                    ((numeric - closed) / closed).abs() < 1e-5,
                    "r={r} z={z0}..{z1}: {numeric} vs {closed}"
                );
            }
        }
    }

    #[test]
    fn tangential_kernel_matches_adaptive_quadrature_and_has_the_load_symmetries() {
        for layer in [Layer::LAYERED, Layer::INTEGRATED] {
            for &(x, y) in &[
                (0.125, 0.0),
                (0.3, 0.2),
                (-1.0, 2.5),
                (6.0, -4.0),
                (0.0, 0.7),
            ] {
                let got = layer.tangential_kernel(x, y);
                let scale = got[0].abs().max(got[1].abs());
                for (c, g) in got.iter().enumerate() {
                    let f = |z: f64| {
                        let [sx, sy, txy] = cerruti_stress(x, y, z, layer.nu);
                        if c == 0 {
                            sx - sy
                        } else {
                            2.0 * txy
                        }
                    };
                    let (a, b) = (layer.z0_mm, layer.z1_mm);
                    let want = adaptive(&f, a, b, simpson(&f, a, b), 1e-13, 50);
                    assert!(
                        (g - want).abs() < 1e-7 * scale.max(1e-12),
                        "({x}, {y}) component {c}: {g} vs {want}"
                    );
                }
                // Odd in x and even in y (s_x - s_y); even in x and odd in y (t_xy).
                let mx = layer.tangential_kernel(-x, y);
                let my = layer.tangential_kernel(x, -y);
                assert!(
                    (mx[0] + got[0]).abs() < 1e-12 * scale
                        && (mx[1] - got[1]).abs() < 1e-12 * scale
                );
                assert!(
                    (my[0] - got[0]).abs() < 1e-12 * scale
                        && (my[1] + got[1]).abs() < 1e-12 * scale
                );
            }
        }
    }
}
