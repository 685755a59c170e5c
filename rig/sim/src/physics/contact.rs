//! Contact mechanics of an indenter pressing into the soft sensor layer.
//!
//! **Elastic (instantaneous) law**, depth d in mm, force in N, moduli in MPa (N/mm^2),
//! E* = E / (1 - nu^2), layer thickness h:
//! - flat punch of contact radius a (rigid flat punch on a half-space, Johnson, *Contact
//!   Mechanics*, 1985, section 3.8): F = 2 a E* d;
//! - sphere of radius R (Hertz, Johnson section 4.2): F = (4/3) E* R^(1/2) d^(3/2), contact radius
//!   a = sqrt(R d).
//!
//! Both are multiplied by the finite-thickness correction for an incompressible layer bonded to a
//! rigid base, kappa(chi) = 1 + 1.133 chi + 1.283 chi^2 + 0.769 chi^3 + 0.0975 chi^4 with
//! chi = a / h (Dimitriadis et al., Biophys. J. 82, 2798, 2002, derived there for the sphere with
//! chi = sqrt(R d) / h; Garcia and Garcia, Biophys. J. 114, 2923, 2018, use the same form for the
//! cylindrical punch). The coefficients were recalled, not re-read; for the 20 mm layer and 4-5 mm
//! punches (chi about 0.22) the correction is about 1.3, close to the Hayes et al. (J. Biomech. 5,
//! 541, 1972) factor for a/h = 0.2, nu = 0.5. Non-circular flat punches (pentagon, rectangle) use
//! the radius of the circle of the same area, a = sqrt(A / pi), whose stiffness is within a few
//! per cent of the exact one for compact outlines (Johnson section 3.8).
//!
//! **Viscoelasticity**: quasi-linear viscoelasticity (Fung) with a Prony series,
//! F(t) = integral G(t - s) dF_e(d(s)), G(t) = g_inf + sum g_i exp(-t / tau_i), G(0) = 1. Each term
//! keeps one internal force h_i advanced exactly for a piecewise linear F_e:
//! h_i <- exp(-dt / tau_i) h_i + g_i dF_e (tau_i / dt)(1 - exp(-dt / tau_i)).
//! At constant depth the force relaxes from F_e to g_inf F_e (the long-term modulus g_inf E); on a
//! load/unload cycle the unloading force lies below the loading force (hysteresis). The gel never
//! pulls: the reported force is max(0, F).
//!
//! **Default numbers**: E = 0.6 MPa, nu = 0.49, h = 20 mm, g = 0.2 (tau 0.5 s) and 0.1 (tau 10 s),
//! so g_inf = 0.7. A 5 mm pentagon (a = 4.35 mm) needs 1.0 mm for 9 N at once and 1.4 mm once
//! relaxed.
//!
//! **Surface**: the sensor surface is not perfectly flat. [`SurfaceHeight`] is a seeded sum of
//! smooth cosine modes (wavelengths 15-60 mm) with a chosen RMS (default 20 um); first contact
//! happens where the surface under the indenter centre is.

use crate::physics::friction::Friction;
use fringe_rig::HostTime;
use fringe_rig::{Millimetres, Newtons};
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

/// One relaxing term of the Prony series.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PronyTerm {
    /// Fraction of the instantaneous modulus that relaxes with this time constant.
    pub weight: f64,
    /// Relaxation time constant, s.
    pub tau_s: f64,
}

impl PronyTerm {
    /// Over a step of `dt` s with the elastic force changing linearly: the decay of the term's
    /// internal force, e^(-dt / tau), and the share of the change it takes up,
    /// (tau / dt)(1 - e^(-dt / tau)) (1 for an instantaneous change).
    pub(crate) fn step(&self, dt: f64) -> (f64, f64) {
        let tau = self.tau_s.max(1e-9);
        let x = dt / tau;
        let decay = (-x).exp();
        // (1 - e^-x) / x, -> 1 as x -> 0.
        let ramp = if x < 1e-9 {
            1.0 - 0.5 * x
        } else {
            (1.0 - decay) / x
        };
        (decay, ramp)
    }
}

/// The soft layer's material and thickness.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct ContactMaterial {
    /// Instantaneous Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    pub poisson_ratio: f64,
    /// Thickness of the soft layer above the rigid base, mm.
    pub layer_thickness_mm: f64,
    /// Relaxing terms; the long-term fraction is 1 - sum of the weights.
    pub relaxation: Vec<PronyTerm>,
    /// Friction against the indenters: the sensor's own (its file's `[surface]`), set by the
    /// simulated rig when it builds the bench, so not a key of the bench's configuration.
    #[serde(skip)]
    pub friction: Friction,
}

impl Default for ContactMaterial {
    fn default() -> Self {
        ContactMaterial {
            youngs_modulus_mpa: 0.6,
            poisson_ratio: 0.49,
            layer_thickness_mm: 20.0,
            relaxation: vec![
                PronyTerm {
                    weight: 0.2,
                    tau_s: 0.5,
                },
                PronyTerm {
                    weight: 0.1,
                    tau_s: 10.0,
                },
            ],
            friction: Friction::default(),
        }
    }
}

impl ContactMaterial {
    /// E* = E / (1 - nu^2), MPa.
    pub fn effective_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa / (1.0 - self.poisson_ratio * self.poisson_ratio)
    }

    /// The fraction of the instantaneous force left after full relaxation (g_inf).
    pub fn long_term_fraction(&self) -> f64 {
        (1.0 - self.relaxation.iter().map(|p| p.weight).sum::<f64>()).max(0.0)
    }
}

/// The indenter as the contact law sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactGeometry {
    /// A flat punch of this (equivalent) radius, mm.
    FlatPunch { radius_mm: f64 },
    /// A sphere of this radius, mm.
    Sphere { radius_mm: f64 },
}

/// Bonded incompressible layer correction kappa(chi), chi = contact radius / layer thickness.
pub(crate) fn layer_correction(chi: f64) -> f64 {
    let c = chi.max(0.0);
    1.0 + 1.133 * c + 1.283 * c * c + 0.769 * c.powi(3) + 0.0975 * c.powi(4)
}

/// The instantaneous elastic force at `depth` (0 when not touching).
pub(crate) fn elastic_force(
    material: &ContactMaterial,
    geometry: ContactGeometry,
    depth: Millimetres,
) -> Newtons {
    let d = depth.0;
    if d <= 0.0 {
        return Newtons(0.0);
    }
    let es = material.effective_modulus_mpa();
    let h = material.layer_thickness_mm.max(1e-9);
    Newtons(match geometry {
        ContactGeometry::FlatPunch { radius_mm } => {
            2.0 * radius_mm * es * d * layer_correction(radius_mm / h)
        }
        ContactGeometry::Sphere { radius_mm } => {
            let a = (radius_mm * d).sqrt();
            4.0 / 3.0 * es * radius_mm.sqrt() * d.powf(1.5) * layer_correction(a / h)
        }
    })
}

/// The contact radius at `depth`: the punch radius, or sqrt(R d) for a sphere (0 when lifted).
pub(crate) fn contact_radius(geometry: ContactGeometry, depth: Millimetres) -> Millimetres {
    if depth.0 <= 0.0 {
        return Millimetres(0.0);
    }
    match geometry {
        ContactGeometry::FlatPunch { radius_mm } => Millimetres(radius_mm),
        ContactGeometry::Sphere { radius_mm } => Millimetres((radius_mm * depth.0).sqrt()),
    }
}

/// The stateful viscoelastic contact: advanced in non-decreasing host time with the depth at each
/// instant; deterministic given the depth history.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ContactModel {
    material: ContactMaterial,
    geometry: ContactGeometry,
    last: Option<HostTime>,
    elastic: f64,
    internal: Vec<f64>,
    depth: f64,
}

impl ContactModel {
    /// A relaxed, unloaded contact.
    pub(crate) fn new(material: ContactMaterial, geometry: ContactGeometry) -> ContactModel {
        let internal = vec![0.0; material.relaxation.len()];
        ContactModel {
            material,
            geometry,
            last: None,
            elastic: 0.0,
            internal,
            depth: f64::NEG_INFINITY,
        }
    }

    #[cfg(test)]
    pub(crate) fn geometry(&self) -> ContactGeometry {
        self.geometry
    }

    /// Changes the indenter; the layer forgets its load history (change indenters while lifted).
    pub(crate) fn set_geometry(&mut self, geometry: ContactGeometry) {
        self.geometry = geometry;
        self.elastic = 0.0;
        self.internal.iter_mut().for_each(|h| *h = 0.0);
    }

    /// Advances to `t` where the depth is `depth` (linear in between from the previous call) and
    /// returns the force then. A `t` earlier than the previous call is treated as the same instant.
    pub(crate) fn advance(&mut self, t: HostTime, depth: Millimetres) -> Newtons {
        let fe = elastic_force(&self.material, self.geometry, depth).0;
        let dt = match self.last {
            Some(last) if t > last => t.since(last).as_secs_f64(),
            _ => 0.0,
        };
        let dfe = fe - self.elastic;
        for (h, term) in self.internal.iter_mut().zip(&self.material.relaxation) {
            let (decay, ramp) = term.step(dt);
            *h = decay * *h + term.weight * dfe * ramp;
        }
        self.elastic = fe;
        self.depth = depth.0;
        if !matches!(self.last, Some(l) if t <= l) {
            self.last = Some(t);
        }
        self.force()
    }

    /// The force after the last [`ContactModel::advance`].
    pub(crate) fn force(&self) -> Newtons {
        let f =
            self.material.long_term_fraction() * self.elastic + self.internal.iter().sum::<f64>();
        Newtons(f.max(0.0))
    }
}

/// Configuration of the sensor surface's height variation.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct SurfaceConfig {
    /// RMS height variation, micrometres (0 = perfectly flat).
    pub rms_um: f64,
    /// Shortest and longest wavelength of the smooth modes, mm.
    pub min_wavelength_mm: f64,
    pub max_wavelength_mm: f64,
    /// Number of cosine modes.
    pub modes: usize,
}

impl Default for SurfaceConfig {
    fn default() -> Self {
        SurfaceConfig {
            rms_um: 20.0,
            min_wavelength_mm: 15.0,
            max_wavelength_mm: 60.0,
            modes: 8,
        }
    }
}

/// Height of the sensor surface above its nominal plane, a smooth seeded function of (x, y).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SurfaceHeight {
    /// (kx, ky, phase, amplitude mm) per mode.
    modes: Vec<(f64, f64, f64, f64)>,
}

impl SurfaceHeight {
    /// A surface drawn from `seed`; the RMS over random positions is `config.rms_um`.
    pub(crate) fn new(config: &SurfaceConfig, seed: u64) -> SurfaceHeight {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x0005_eed5_u64.rotate_left(32));
        let n = config.modes.max(1);
        // A sum of n cosines with random phases and amplitude A has RMS A sqrt(n / 2).
        let amp = config.rms_um.max(0.0) * 1e-3 / (n as f64 / 2.0).sqrt();
        let lo = config.min_wavelength_mm.max(1e-3);
        let hi = config.max_wavelength_mm.max(lo);
        let modes = (0..n)
            .map(|_| {
                let wavelength = lo + (hi - lo) * rng.gen::<f64>();
                let dir = 2.0 * PI * rng.gen::<f64>();
                let k = 2.0 * PI / wavelength;
                (
                    k * dir.cos(),
                    k * dir.sin(),
                    2.0 * PI * rng.gen::<f64>(),
                    amp,
                )
            })
            .collect();
        SurfaceHeight { modes }
    }

    /// Height above nominal at sensor-frame (x, y), mm (positive = the surface is higher, so an
    /// indenter touches it earlier).
    pub(crate) fn height(&self, x: Millimetres, y: Millimetres) -> Millimetres {
        Millimetres(
            self.modes
                .iter()
                .map(|&(kx, ky, ph, a)| a * (kx * x.0 + ky * y.0 + ph).cos())
                .sum(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> HostTime {
        HostTime((s * 1e9) as u64)
    }

    const PENTAGON_A: f64 = 4.3494; // sqrt(area / pi) for a 5 mm circumradius pentagon

    #[test]
    fn flat_punch_force_is_linear_in_depth_with_the_closed_form_stiffness() {
        let m = ContactMaterial::default();
        let g = ContactGeometry::FlatPunch {
            radius_mm: PENTAGON_A,
        };
        let es = 0.6 / (1.0 - 0.49f64 * 0.49);
        let chi = PENTAGON_A / 20.0;
        let kappa =
            1.0 + 1.133 * chi + 1.283 * chi * chi + 0.769 * chi.powi(3) + 0.0975 * chi.powi(4);
        for d in [0.1, 0.5, 1.0, 1.5] {
            let f = elastic_force(&m, g, Millimetres(d)).0;
            let want = 2.0 * PENTAGON_A * es * d * kappa;
            assert!((f - want).abs() < 1e-12 * want, "d {d}: {f} vs {want}");
        }
        assert_eq!(elastic_force(&m, g, Millimetres(-0.1)).0, 0.0);
        // 9 N between 0.5 and 1.5 mm, instantaneous and relaxed.
        let f1 = elastic_force(&m, g, Millimetres(1.0)).0;
        assert!(f1 > 8.0 && f1 < 10.5, "{f1}");
        assert!(0.7 * elastic_force(&m, g, Millimetres(1.5)).0 > 9.0);
    }

    #[test]
    fn sphere_follows_hertz_times_the_layer_correction() {
        let m = ContactMaterial::default();
        let g = ContactGeometry::Sphere { radius_mm: 5.0 };
        let es = m.effective_modulus_mpa();
        let d: f64 = 0.8;
        let a = (5.0 * d).sqrt();
        let want = 4.0 / 3.0 * es * 5.0f64.sqrt() * d.powf(1.5) * layer_correction(a / 20.0);
        assert!((elastic_force(&m, g, Millimetres(d)).0 - want).abs() < 1e-12);
        assert!((contact_radius(g, Millimetres(d)).0 - 2.0).abs() < 1e-12);
        // Doubling the depth multiplies Hertz force by 2^1.5 (before the layer correction grows).
        let r = elastic_force(&m, g, Millimetres(2.0 * d)).0 / want;
        assert!(r > 2f64.powf(1.5) && r < 2f64.powf(1.5) * 1.1, "{r}");
    }

    #[test]
    fn constant_depth_relaxes_to_the_long_term_modulus() {
        let m = ContactMaterial::default();
        let g = ContactGeometry::FlatPunch { radius_mm: 4.0 };
        let mut c = ContactModel::new(m.clone(), g);
        c.advance(at(0.0), Millimetres(0.0));
        // 10 ms ramp to 1 mm, then hold.
        for k in 1..=10 {
            c.advance(at(k as f64 * 1e-3), Millimetres(k as f64 * 0.1));
        }
        let fe = elastic_force(&m, g, Millimetres(1.0)).0;
        let f0 = c.force().0;
        assert!(
            f0 > 0.97 * fe && f0 <= fe,
            "just after the ramp: {f0} vs {fe}"
        );
        let f_half = c.advance(at(0.51), Millimetres(1.0)).0;
        // After one tau of the fast term: g_inf + 0.2 e^-1 + 0.1 e^-0.05, within the ramp's error.
        let want = fe * (0.7 + 0.2 * (-1.0f64).exp() + 0.1 * (-0.05f64).exp());
        assert!((f_half - want).abs() < 0.01 * fe, "{f_half} vs {want}");
        let f_end = c.advance(at(200.0), Millimetres(1.0)).0;
        assert!(
            (f_end - 0.7 * fe).abs() < 1e-3 * fe,
            "{f_end} vs {}",
            0.7 * fe
        );
        // Monotonic decay in between.
        assert!(f0 > f_half && f_half > f_end);
    }

    #[test]
    fn load_unload_cycle_has_positive_hysteresis_area() {
        let m = ContactMaterial::default();
        let mut c = ContactModel::new(m, ContactGeometry::FlatPunch { radius_mm: 4.35 });
        let steps = 2000;
        let mut area = 0.0;
        let mut prev = (0.0, 0.0);
        // 2 s down to 1.2 mm, 2 s back up; integral of F dd around the loop.
        for k in 0..=2 * steps {
            let s = k as f64 / steps as f64;
            let d = if s <= 1.0 { 1.2 * s } else { 1.2 * (2.0 - s) };
            let f = c.advance(at(2.0 * s), Millimetres(d)).0;
            if k > 0 {
                area += 0.5 * (f + prev.1) * (d - prev.0);
            }
            prev = (d, f);
        }
        assert!(area > 0.5, "dissipated {area} N mm");
        // Unloading at 0.6 mm reads less than loading at 0.6 mm.
        let mut c2 = ContactModel::new(ContactMaterial::default(), c.geometry());
        let mut load = 0.0;
        let mut unload = 0.0;
        for k in 0..=2 * steps {
            let s = k as f64 / steps as f64;
            let d = if s <= 1.0 { 1.2 * s } else { 1.2 * (2.0 - s) };
            let f = c2.advance(at(2.0 * s), Millimetres(d)).0;
            if k == steps / 2 {
                load = f;
            }
            if k == 3 * steps / 2 {
                unload = f;
            }
        }
        assert!(load > unload + 0.3, "load {load} unload {unload}");
    }

    #[test]
    fn surface_height_is_smooth_seeded_and_has_the_requested_rms() {
        let cfg = SurfaceConfig::default();
        let s1 = SurfaceHeight::new(&cfg, 3);
        let s2 = SurfaceHeight::new(&cfg, 3);
        let s3 = SurfaceHeight::new(&cfg, 4);
        let mut sum2 = 0.0;
        let mut n = 0.0;
        for i in -20..=20 {
            for j in -20..=20 {
                let (x, y) = (Millimetres(i as f64 * 1.5), Millimetres(j as f64 * 1.5));
                let h = s1.height(x, y).0;
                assert_eq!(h, s2.height(x, y).0);
                sum2 += h * h;
                n += 1.0;
                // Smooth: points 0.1 mm apart differ by under 2 um.
                let dh = (s1.height(Millimetres(x.0 + 0.1), y).0 - h).abs();
                assert!(dh < 2e-3, "{dh}");
            }
        }
        let rms_um = (sum2 / n).sqrt() * 1e3;
        assert!(rms_um > 8.0 && rms_um < 40.0, "{rms_um}");
        assert_ne!(
            s1.height(Millimetres(0.0), Millimetres(0.0)),
            s3.height(Millimetres(0.0), Millimetres(0.0))
        );
    }
}
