//! The indenter pushed along the surface: the tangential force the gel puts up, how it relaxes,
//! and when the indenter slides (docs/photoelastic-sim.md, "Shear and slip").
//!
//! **Stick.** While the contact sticks, the gel under the indenter is sheared by the indenter's
//! displacement delta from where it first touched (the anchor). A rigid circular punch of radius
//! a bonded to a half-space needs Q = k_t delta with k_t = 8 G a / (2 - nu), G = E / (2 (1 + nu))
//! (Johnson, *Contact Mechanics*, 1985, section 7.1, after Mindlin 1949); the other outlines use
//! the radius of the circle of their area, the sphere its contact radius sqrt(R d), as the
//! normal law does ([`crate::physics::contact`]). The micro-slip of partial slip softens this
//! law (Mindlin's load-displacement curve reaches 1.5 times the stick compliance at the onset
//! of gross slip); it is left out, so the tangential force is linear in delta up to the limit.
//!
//! **Relaxation.** The tangential force relaxes with the same Prony series as the normal force
//! (quasi-linear viscoelasticity, each term advanced exactly for a linear change in a step):
//! held still, a push falls to g_inf of its elastic value.
//!
//! **Slip.** Coulomb friction: the contact sticks while |Q| <= mu_s P and slides at
//! |Q| = mu_k P once it has started (mu_k <= mu_s, the usual stick-slip drop). Sliding moves
//! the anchor along the force, by the amount that brings |Q| back to mu_k P. The contact sticks
//! again as soon as a step needs no anchor move (the indenter stopped or turned back).
//!
//! **What the camera is told** ([`TangentialState::friction_used`]): |Q| / (mu_s P) while it
//! sticks, 1 while it slides; the renderer spreads the traction with it
//! ([`crate::physics::traction`]).

use crate::physics::contact::ContactMaterial;
#[cfg(test)]
use crate::physics::friction::Friction;

/// The tangential load at an instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct TangentialState {
    /// Force the indenter applies to the surface, sensor frame [x, y], N.
    pub(crate) force: [f64; 2],
    /// Share of the friction limit used: |Q| / (mu_s P) while sticking, 1 while sliding.
    pub(crate) friction_used: f64,
    /// The indenter slides over the surface (gross slip).
    pub(crate) sliding: bool,
}

/// The stateful tangential contact, advanced in steps with the indenter's position and the
/// normal force.
#[derive(Debug, Clone)]
pub(crate) struct Tangential {
    /// Where the indenter centre would sit with the gel unstrained (sensor frame, mm); `None`
    /// while lifted.
    anchor: Option<[f64; 2]>,
    /// k_t delta after the last step, N.
    elastic: [f64; 2],
    /// The Prony terms' internal forces, N.
    internal: Vec<[f64; 2]>,
    state: TangentialState,
    /// Scratch of [`Tangential::advance`], one entry per Prony term, kept so that a step
    /// allocates nothing: each term's (decay, ramp) over the step, and its internal force
    /// after the step being tried.
    factors: Vec<(f64, f64)>,
    trial: Vec<[f64; 2]>,
}

/// The state, not the scratch.
impl PartialEq for Tangential {
    fn eq(&self, other: &Tangential) -> bool {
        self.anchor == other.anchor
            && self.elastic == other.elastic
            && self.internal == other.internal
            && self.state == other.state
    }
}

impl Tangential {
    /// A lifted indenter.
    pub(crate) fn new(material: &ContactMaterial) -> Tangential {
        let terms = material.relaxation.len();
        Tangential {
            anchor: None,
            elastic: [0.0; 2],
            internal: vec![[0.0; 2]; terms],
            state: TangentialState::default(),
            factors: Vec::with_capacity(terms),
            trial: Vec::with_capacity(terms),
        }
    }

    /// Lifts the indenter: forgets the anchor, the forces and the relaxation (what
    /// [`Tangential::new`] starts from), keeping the buffers.
    fn lift(&mut self, material: &ContactMaterial) {
        self.anchor = None;
        self.elastic = [0.0; 2];
        self.internal.clear();
        self.internal.resize(material.relaxation.len(), [0.0; 2]);
        self.state = TangentialState::default();
    }

    /// The force after a step to `position` with the anchor at `anchor`, elastic stiffness
    /// `stiffness` and long-term fraction `g_inf`, the step's factors in `self.factors`: the
    /// elastic force it returns, the Prony terms' internal forces it leaves in `self.trial`.
    fn try_step(
        &mut self,
        material: &ContactMaterial,
        position: [f64; 2],
        anchor: [f64; 2],
        stiffness: f64,
        g_inf: f64,
    ) -> ([f64; 2], [f64; 2]) {
        let elastic = [0, 1].map(|k| stiffness * (position[k] - anchor[k]));
        let last = self.elastic;
        self.trial.clear();
        self.trial.extend(
            self.internal
                .iter()
                .zip(&material.relaxation)
                .zip(&self.factors)
                .map(|((h, term), &(decay, ramp))| {
                    [0, 1].map(|k| decay * h[k] + term.weight * (elastic[k] - last[k]) * ramp)
                }),
        );
        let force =
            [0, 1].map(|k| g_inf * elastic[k] + self.trial.iter().map(|h| h[k]).sum::<f64>());
        (elastic, force)
    }

    /// Advances `dt_s` seconds to the indenter centre at `position` (sensor frame, mm) pressing
    /// with `normal_n` over a contact of (equivalent) radius `radius_mm`.
    pub(crate) fn advance(
        &mut self,
        material: &ContactMaterial,
        dt_s: f64,
        position: [f64; 2],
        normal_n: f64,
        radius_mm: f64,
    ) -> TangentialState {
        if !(normal_n > 0.0 && radius_mm > 0.0) {
            self.lift(material);
            return self.state;
        }
        let anchor = *self.anchor.get_or_insert(position);
        let nu = material.poisson_ratio;
        let shear_modulus = material.youngs_modulus_mpa / (2.0 * (1.0 + nu));
        let stiffness = 8.0 * shear_modulus * radius_mm / (2.0 - nu);
        self.factors.clear();
        self.factors
            .extend(material.relaxation.iter().map(|t| t.step(dt_s)));
        let g_inf = material.long_term_fraction();
        let (mut elastic, mut force) = self.try_step(material, position, anchor, stiffness, g_inf);
        let f = material.friction;
        let limit = if self.state.sliding {
            f.kinetic_coefficient
        } else {
            f.static_coefficient
        } * normal_n;
        let magnitude = force[0].hypot(force[1]);
        let sliding = magnitude > limit;
        let mut anchor = anchor;
        if sliding {
            // The force is linear in the anchor: moving it by s along the force lowers the force
            // by (g_inf + sum g_i ramp_i) k_t s along it.
            let instantaneous = g_inf
                + material
                    .relaxation
                    .iter()
                    .zip(&self.factors)
                    .map(|(t, &(_, ramp))| t.weight * ramp)
                    .sum::<f64>();
            let sliding_limit = f.kinetic_coefficient * normal_n;
            let s = (magnitude - sliding_limit) / (instantaneous * stiffness);
            let u = [force[0] / magnitude, force[1] / magnitude];
            anchor = [anchor[0] + s * u[0], anchor[1] + s * u[1]];
            (elastic, force) = self.try_step(material, position, anchor, stiffness, g_inf);
        }
        self.anchor = Some(anchor);
        self.elastic = elastic;
        std::mem::swap(&mut self.internal, &mut self.trial);
        let used = if sliding {
            1.0
        } else {
            (force[0].hypot(force[1]) / (f.static_coefficient * normal_n)).clamp(0.0, 1.0)
        };
        self.state = TangentialState {
            force,
            friction_used: used,
            sliding,
        };
        self.state
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn material() -> ContactMaterial {
        ContactMaterial::default()
    }

    /// Pushes a 4.35 mm punch at 5 N along +x at `speed` mm/s for `seconds`, in 1 ms steps;
    /// the states every step.
    fn push(speed: f64, seconds: f64) -> Vec<TangentialState> {
        let m = material();
        let mut t = Tangential::new(&m);
        let steps = (seconds * 1000.0) as usize;
        (0..=steps)
            .map(|k| t.advance(&m, 1e-3, [speed * k as f64 * 1e-3, 0.0], 5.0, 4.35))
            .collect()
    }

    #[test]
    fn a_push_sticks_then_slides_at_the_kinetic_limit() {
        let states = push(2.0, 2.0);
        let f = Friction::default();
        let start = states
            .iter()
            .position(|s| s.sliding)
            .expect("it never slid");
        let before = &states[start - 1];
        assert!(!before.sliding && before.force[0] > 0.0 && before.force[1] == 0.0);
        // It slides once the force reaches mu_s P ...
        assert!(
            before.force[0] <= f.static_coefficient * 5.0 + 1e-9
                && before.force[0] > 0.95 * f.static_coefficient * 5.0,
            "{before:?}"
        );
        // ... and then carries mu_k P, all of the friction used.
        for s in &states[start..] {
            assert!(s.sliding && s.friction_used == 1.0);
            assert!(
                (s.force[0] - f.kinetic_coefficient * 5.0).abs() < 1e-9,
                "{s:?}"
            );
        }
        // While it sticks the force grows with the displacement and says how much friction it
        // uses.
        let early = &states[start / 4];
        assert!((early.friction_used - early.force[0] / 5.0).abs() < 1e-12);
        assert!(early.friction_used < 0.5);
    }

    #[test]
    fn a_held_push_relaxes_and_sticks_again_when_the_indenter_stops() {
        let m = material();
        let mut t = Tangential::new(&m);
        let mut x = 0.0;
        let mut last = TangentialState::default();
        // Slide, then stop.
        for _ in 0..2000 {
            x += 2e-3;
            last = t.advance(&m, 1e-3, [x, 0.0], 5.0, 4.35);
        }
        assert!(last.sliding);
        let stopped = t.advance(&m, 1e-3, [x, 0.0], 5.0, 4.35);
        assert!(
            !stopped.sliding,
            "it kept sliding after the indenter stopped"
        );
        for _ in 0..30_000 {
            last = t.advance(&m, 1e-3, [x, 0.0], 5.0, 4.35);
        }
        // Thirty seconds later it has relaxed, towards g_inf of the elastic force it holds (the
        // ten-second term keeps e^-3 of its share).
        let g_inf = m.long_term_fraction();
        assert!(
            last.force[0] < 0.9 * stopped.force[0],
            "{last:?} from {stopped:?}"
        );
        assert!(
            (last.force[0] / (g_inf * t.elastic[0]) - 1.0).abs() < 0.05,
            "{} against g_inf x {}",
            last.force[0],
            t.elastic[0]
        );
        assert!(!last.sliding && last.friction_used < 1.0);
        // Lifting forgets everything.
        let lifted = t.advance(&m, 1e-3, [x, 0.0], 0.0, 0.0);
        assert_eq!(lifted, TangentialState::default());
    }

    #[test]
    fn the_stick_stiffness_is_mindlins_and_the_force_follows_the_push_direction() {
        let m = material();
        let mut t = Tangential::new(&m);
        t.advance(&m, 1e-3, [1.0, 2.0], 9.0, 4.0);
        // An instantaneous push of 0.1 mm at 45 degrees (no time to relax).
        let d = 0.1 / 2f64.sqrt();
        let s = t.advance(&m, 0.0, [1.0 + d, 2.0 + d], 9.0, 4.0);
        let g = m.youngs_modulus_mpa / (2.0 * (1.0 + m.poisson_ratio));
        let k = 8.0 * g * 4.0 / (2.0 - m.poisson_ratio);
        assert!(
            (s.force[0].hypot(s.force[1]) - k * 0.1).abs() < 1e-9,
            "{s:?} vs {}",
            k * 0.1
        );
        assert!((s.force[0] - s.force[1]).abs() < 1e-12);
    }
}
