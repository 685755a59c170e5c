//! Where commissioning presses next: candidate positions on a lattice over the usable disc (in
//! stage mm, from the unit's profile), and a greedy choice that weighs each candidate's distance
//! from every press made so far (coverage) by the error the model showed near it (need).

use fringe_calibration::Profile;
use fringe_rig::BenchLimits;
use fringe_rig::Millimetres;

/// The part of the disc presses may reach, in stage coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UsableDisc {
    /// Stage x, y (mm) that put the indenter on the disc's centre.
    pub centre_mm: [f64; 2],
    /// Largest distance of a press from the centre, mm.
    pub reach_mm: f64,
}

/// Why the usable disc is unknown.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiscError {
    #[error(
        "profile of {0} has no image-to-stage registration: the calibration located too few \
         presses; check the unit sits under the indenter and calibrate again (fringe calibrate \
         --sensor {0})"
    )]
    NoRegistration(String),
    #[error(
        "profile of {sensor}: the usable disc ({reach:.1} mm reach about stage x {x:.2} y \
         {y:.2} mm) leaves no press inside the rig's soft limits"
    )]
    OutOfReach {
        sensor: String,
        reach: f64,
        x: f64,
        y: f64,
    },
}

/// Spacing of the lattice commissioning presses are chosen from (and, shifted half of it, of
/// the acceptance scan's held-out positions), mm.
pub const LATTICE_MM: f64 = 2.0;

/// Distance beyond which a place counts as unvisited when choosing presses, mm.
pub const COVERAGE_MM: f64 = 6.0;

/// Fraction of the crop radius that press centres may reach (the indenter must stay on the
/// disc and clear of the rim's glow).
pub const REACH_FRACTION: f64 = 0.7;

impl UsableDisc {
    /// The disc of `profile`'s unit: its contact origin on the stage and its crop radius in mm.
    pub fn from_profile(profile: &Profile) -> Result<UsableDisc, DiscError> {
        let r = profile
            .registration
            .as_ref()
            .ok_or_else(|| DiscError::NoRegistration(profile.sensor_id.clone()))?;
        Ok(UsableDisc {
            centre_mm: r.contact_origin_stage_mm,
            reach_mm: REACH_FRACTION * profile.optical.crop_radius_px / r.px_per_mm.max(1e-9),
        })
    }

    /// Points of a triangular lattice of `spacing_mm` over the disc that lie within the soft
    /// limits of x and y, row by row; `phase` (0-1) shifts the lattice by that fraction of a
    /// spacing along x and y (held-out points sit between the adaptation's).
    pub fn lattice(
        &self,
        spacing_mm: f64,
        phase: f64,
        limits: &BenchLimits,
        sensor: &str,
    ) -> Result<Vec<[f64; 2]>, DiscError> {
        let s = spacing_mm.max(0.1);
        let row_height = s * 3f64.sqrt() / 2.0;
        let rows = (self.reach_mm / row_height).ceil() as i64 + 1;
        let cols = (self.reach_mm / s).ceil() as i64 + 1;
        let mut points = Vec::new();
        for j in -rows..=rows {
            let stagger = if j.rem_euclid(2) == 1 { 0.5 } else { 0.0 };
            for i in -cols..=cols {
                let dx = (i as f64 + stagger + phase) * s;
                let dy = (j as f64 + phase) * row_height;
                if dx.hypot(dy) > self.reach_mm {
                    continue;
                }
                let (x, y) = (self.centre_mm[0] + dx, self.centre_mm[1] + dy);
                let inside = limits.x.check("x", Millimetres(x)).is_ok()
                    && limits.y.check("y", Millimetres(y)).is_ok();
                if inside {
                    points.push([round_um(x), round_um(y)]);
                }
            }
        }
        if points.is_empty() {
            return Err(DiscError::OutOfReach {
                sensor: sensor.to_string(),
                reach: self.reach_mm,
                x: self.centre_mm[0],
                y: self.centre_mm[1],
            });
        }
        Ok(points)
    }
}

/// Stage positions to the micrometre (plans are text; the same choice writes the same plan).
fn round_um(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// A press made, with the model's error on it before it was adapted on (in units of the spec:
/// 1 is at the threshold).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PressedPoint {
    pub stage_mm: [f64; 2],
    pub error: f64,
}

/// Chooses up to `n` of `candidates` to press next: each pick maximises its distance from every
/// press made or picked (capped at `scale_mm`: beyond it a place counts as unvisited) times the
/// error expected there (pressed points' errors weighted by inverse squared distance; 1 where
/// nothing is known), ties going to the farther candidate, then to the earlier one.
pub fn choose(
    candidates: &[[f64; 2]],
    pressed: &[PressedPoint],
    n: usize,
    scale_mm: f64,
) -> Vec<[f64; 2]> {
    let scale = scale_mm.max(1e-6);
    let worst = pressed.iter().map(|p| p.error).fold(0.0, f64::max);
    let mut taken: Vec<[f64; 2]> = pressed.iter().map(|p| p.stage_mm).collect();
    let mut left: Vec<[f64; 2]> = candidates.to_vec();
    let mut chosen = Vec::with_capacity(n);
    while chosen.len() < n && !left.is_empty() {
        let score = |c: &[f64; 2]| -> (f64, f64) {
            let d = taken
                .iter()
                .map(|t| dist(c, t))
                .fold(f64::INFINITY, f64::min);
            let need = if worst > 0.0 {
                expected_error(c, pressed, scale) / worst
            } else {
                1.0
            };
            ((d / scale).min(1.0) * (0.25 + need), d)
        };
        let best = (0..left.len()).map(|i| (i, score(&left[i]))).fold(
            None::<(usize, (f64, f64))>,
            |best, (i, s)| match best {
                Some((_, b)) if (b.0, b.1) >= (s.0, s.1) => best,
                _ => Some((i, s)),
            },
        );
        let Some((i, (s, _))) = best else { break };
        if s <= 0.0 {
            break;
        }
        let c = left.remove(i);
        taken.push(c);
        chosen.push(c);
    }
    chosen
}

/// `points` in the order of a short path: from the one nearest `start`, always on to the
/// nearest left (the stages move slowly; the choice's order would cross the disc each time).
pub(crate) fn tour(points: &[[f64; 2]], start: [f64; 2]) -> Vec<[f64; 2]> {
    let mut left = points.to_vec();
    let mut at = start;
    let mut out = Vec::with_capacity(left.len());
    while !left.is_empty() {
        let next = (0..left.len())
            .min_by(|&a, &b| dist(&left[a], &at).total_cmp(&dist(&left[b], &at)))
            .unwrap_or(0);
        at = left.remove(next);
        out.push(at);
    }
    out
}

/// The error expected at `c` from the pressed points near it (inverse squared distance
/// weights, softened by `scale`).
fn expected_error(c: &[f64; 2], pressed: &[PressedPoint], scale: f64) -> f64 {
    let (mut w_sum, mut e_sum) = (0.0, 0.0);
    for p in pressed {
        let w = 1.0 / (dist(c, &p.stage_mm).powi(2) + 0.25 * scale * scale);
        w_sum += w;
        e_sum += w * p.error;
    }
    if w_sum > 0.0 {
        e_sum / w_sum
    } else {
        1.0
    }
}

fn dist(a: &[f64; 2], b: &[f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::{Kinematics, SoftLimits};
    use fringe_rig::{MillimetresPerSecond, MillimetresPerSecondSquared, Newtons};

    fn limits(max: f64) -> BenchLimits {
        let soft = SoftLimits::new(Millimetres(0.0), Millimetres(max)).expect("limits");
        let k = Kinematics {
            velocity: MillimetresPerSecond(2.0),
            acceleration: MillimetresPerSecondSquared(4.0),
        };
        BenchLimits {
            x: soft,
            y: soft,
            z: soft,
            x_motion: k,
            y_motion: k,
            z_motion: k,
            manual_y: false,
            max_force: Newtons(20.0),
            ft_rating: None,
            contact_z: Millimetres(15.0),
            start: None,
        }
    }

    const DISC: UsableDisc = UsableDisc {
        centre_mm: [25.0, 25.0],
        reach_mm: 10.0,
    };

    #[test]
    fn the_lattice_covers_the_disc_inside_the_soft_limits_only() {
        let all = DISC.lattice(2.0, 0.0, &limits(50.0), "u").expect("points");
        assert!(all.len() > 70, "{} points", all.len());
        assert!(all.iter().all(|p| dist(p, &DISC.centre_mm) <= 10.0 + 1e-9));
        // x travel ending at 25 mm cuts the disc in half.
        let half = DISC.lattice(2.0, 0.0, &limits(25.0), "u").expect("points");
        assert!(half.iter().all(|p| p[0] <= 25.0 && p[1] <= 25.0));
        assert!(half.len() < all.len() / 2);
        let held_out = DISC.lattice(2.0, 0.5, &limits(50.0), "u").expect("points");
        assert!(held_out
            .iter()
            .all(|h| all.iter().all(|a| dist(a, h) > 0.4)));
        let far = UsableDisc {
            centre_mm: [200.0, 200.0],
            ..DISC
        };
        assert!(matches!(
            far.lattice(2.0, 0.0, &limits(50.0), "u"),
            Err(DiscError::OutOfReach { .. })
        ));
    }

    #[test]
    fn first_picks_spread_over_the_disc() {
        let cands = DISC.lattice(1.0, 0.0, &limits(50.0), "u").expect("points");
        let picks = choose(&cands, &[], 7, 6.0);
        assert_eq!(picks.len(), 7);
        for (i, a) in picks.iter().enumerate() {
            for b in &picks[i + 1..] {
                assert!(dist(a, b) > 5.0, "{a:?} and {b:?} are close");
            }
        }
        assert_eq!(picks, choose(&cands, &[], 7, 6.0), "deterministic");
    }

    #[test]
    fn a_tour_is_shorter_than_the_choice_order() {
        let cands = DISC.lattice(1.0, 0.0, &limits(50.0), "u").expect("points");
        let picks = choose(&cands, &[], 8, 6.0);
        let length = |p: &[[f64; 2]]| p.windows(2).map(|w| dist(&w[0], &w[1])).sum::<f64>();
        let toured = tour(&picks, DISC.centre_mm);
        assert_eq!(toured.len(), picks.len());
        assert!(picks.iter().all(|p| toured.contains(p)));
        assert!(
            length(&toured) < 0.8 * length(&picks),
            "{} vs {}",
            length(&toured),
            length(&picks)
        );
    }

    #[test]
    fn later_picks_go_where_the_error_was_largest() {
        let cands = DISC.lattice(1.0, 0.0, &limits(50.0), "u").expect("points");
        // Presses all over the disc; the one at the right edge was badly predicted.
        let mut pressed: Vec<PressedPoint> = choose(&cands, &[], 12, 6.0)
            .into_iter()
            .map(|p| PressedPoint {
                stage_mm: p,
                error: 0.2,
            })
            .collect();
        pressed.push(PressedPoint {
            stage_mm: [34.0, 25.0],
            error: 3.0,
        });
        let next = choose(&cands, &pressed, 3, 6.0);
        let near_bad = next.iter().filter(|p| dist(p, &[34.0, 25.0]) < 6.0).count();
        assert!(near_bad >= 2, "{next:?}");
    }
}
