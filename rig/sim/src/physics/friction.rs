//! Coulomb friction between the indenters and the sensor's contact surface: a property of the
//! sensor unit (its file's `[surface]` keys), used by the tangential contact
//! ([`crate::physics::sliding`]).

/// Coulomb friction between the indenters and the sensor's contact surface (the sensor file's
/// `[surface]` keys `friction_static`, `friction_kinetic`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Friction {
    /// Static coefficient mu_s: sliding starts at |Q| = mu_s P.
    pub static_coefficient: f64,
    /// Kinetic coefficient mu_k (at most mu_s): a sliding contact carries |Q| = mu_k P.
    pub kinetic_coefficient: f64,
}

impl Default for Friction {
    /// Soft silicone or polyurethane against a machined or printed indenter: about 1 static,
    /// 0.8 sliding.
    fn default() -> Self {
        Friction {
            static_coefficient: 1.0,
            kinetic_coefficient: 0.8,
        }
    }
}
