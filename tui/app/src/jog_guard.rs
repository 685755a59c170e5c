//! Force safety of motions outside a scan (the Bench screen): which way a motion goes relative
//! to the sensor, which motions are refused while the force is over the ceiling, and which are
//! stopped when it gets there.
//!
//! Conventions (as the scan engine's): z moves towards the sensor with increasing position; x
//! and y move the indenter across it. A move away from the sensor (z up, homing z) is always
//! allowed and never stopped for force: it is how the load comes off. While the force is over
//! the ceiling, moves into the sensor and moves across it (which drag a pressed indenter through
//! the gel) are refused; one already running is stopped at the first sample over the ceiling.

use std::time::{Duration, Instant};

/// A move into or across the sensor refused while the force is over the ceiling.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{axis}: {what} is refused while the force ({force_n:.2} N) is over the ceiling {ceiling_n:.2} N; retract z first (←, or h to home z)")]
pub struct OverCeiling {
    pub axis: &'static str,
    pub what: &'static str,
    pub force_n: f64,
    pub ceiling_n: f64,
}

/// An axis of the bench.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisId {
    X,
    Y,
    Z,
}

impl AxisId {
    pub const ALL: [AxisId; 3] = [AxisId::X, AxisId::Y, AxisId::Z];

    pub fn name(self) -> &'static str {
        match self {
            AxisId::X => "x",
            AxisId::Y => "y",
            AxisId::Z => "z",
        }
    }

    pub fn index(self) -> usize {
        self as usize
    }
}

/// Which way a motion goes relative to the sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Heading {
    /// Away from the sensor: z up, or homing z.
    Away,
    /// Into the sensor: z down.
    Into,
    /// Across the sensor: x or y.
    Across,
}

impl Heading {
    /// A jog of `axis` by `by_mm`.
    pub fn of_jog(axis: AxisId, by_mm: f64) -> Heading {
        match axis {
            AxisId::Z if by_mm > 0.0 => Heading::Into,
            AxisId::Z => Heading::Away,
            AxisId::X | AxisId::Y => Heading::Across,
        }
    }

    /// Homing `axis` (z homes up, away from the sensor).
    pub fn of_home(axis: AxisId) -> Heading {
        match axis {
            AxisId::Z => Heading::Away,
            AxisId::X | AxisId::Y => Heading::Across,
        }
    }
}

/// A status polled this soon after a command may predate the motion (a K-Cube reports every
/// 100 ms): an axis is taken to have finished only when idle after this long.
const STATUS_LAG: Duration = Duration::from_millis(300);

#[derive(Debug, Clone, Copy)]
struct Motion {
    heading: Heading,
    started: Instant,
}

/// The motions under way and the force they are checked against.
#[derive(Debug, Clone)]
pub struct JogGuard {
    ceiling_n: f64,
    /// The newest total force, N.
    force_n: Option<f64>,
    motions: [Option<Motion>; 3],
}

impl JogGuard {
    pub fn new(ceiling_n: f64) -> JogGuard {
        JogGuard {
            ceiling_n,
            force_n: None,
            motions: [None; 3],
        }
    }

    pub fn ceiling_n(&self) -> f64 {
        self.ceiling_n
    }

    /// Whether a motion of `axis` going `heading` may start now; the refusal says why and what
    /// to do.
    pub fn admit(&self, axis: AxisId, heading: Heading) -> Result<(), OverCeiling> {
        let Some(force_n) = self.force_n.filter(|f| *f > self.ceiling_n) else {
            return Ok(());
        };
        let what = match heading {
            Heading::Away => return Ok(()),
            Heading::Into => "a move into the sensor",
            Heading::Across => "a move across the sensor",
        };
        Err(OverCeiling {
            axis: axis.name(),
            what,
            force_n,
            ceiling_n: self.ceiling_n,
        })
    }

    /// A motion of `axis` going `heading` was started (replacing any before it).
    pub fn begun(&mut self, axis: AxisId, heading: Heading) {
        self.motions[axis.index()] = Some(Motion {
            heading,
            started: Instant::now(),
        });
    }

    /// Every axis was stopped.
    pub fn stopped_all(&mut self) {
        self.motions = [None; 3];
    }

    /// A status poll of `axis`: an idle axis has finished its motion (unless the status may
    /// predate it).
    pub fn polled(&mut self, axis: AxisId, moving: bool) {
        let slot = &mut self.motions[axis.index()];
        if !moving && slot.is_some_and(|m| m.started.elapsed() >= STATUS_LAG) {
            *slot = None;
        }
    }

    /// Whether a motion that the force can stop is under way (the bench then checks the force
    /// at every sample instead of every poll).
    pub fn guarding(&self) -> bool {
        self.motions
            .iter()
            .flatten()
            .any(|m| m.heading != Heading::Away)
    }

    /// A force sample (total |F|, N): the axes to stop now, those moving into or across the
    /// sensor while the force is over the ceiling (forgotten here once returned).
    pub fn sample(&mut self, total_n: f64) -> Vec<AxisId> {
        self.force_n = Some(total_n);
        if total_n <= self.ceiling_n {
            return Vec::new();
        }
        AxisId::ALL
            .into_iter()
            .filter(|a| {
                let slot = &mut self.motions[a.index()];
                let stop = slot.is_some_and(|m| m.heading != Heading::Away);
                if stop {
                    *slot = None;
                }
                stop
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn over_the_ceiling_only_moves_away_from_the_sensor_are_admitted() {
        let mut g = JogGuard::new(20.0);
        assert!(g.admit(AxisId::Z, Heading::Into).is_ok(), "no force yet");
        g.sample(19.0);
        assert!(g.admit(AxisId::Z, Heading::Into).is_ok());
        g.sample(20.5);
        let refused = g.admit(AxisId::Z, Heading::Into).unwrap_err().to_string();
        assert!(refused.contains("into the sensor") && refused.contains("20.50 N"));
        assert!(g.admit(AxisId::X, Heading::Across).is_err());
        assert!(g.admit(AxisId::Z, Heading::of_jog(AxisId::Z, -0.1)).is_ok());
        assert!(g.admit(AxisId::Z, Heading::of_home(AxisId::Z)).is_ok());
        g.sample(3.0);
        assert!(g.admit(AxisId::Z, Heading::Into).is_ok());
    }

    #[test]
    fn a_sample_over_the_ceiling_stops_moves_into_and_across_but_not_a_retract() {
        let mut g = JogGuard::new(20.0);
        g.begun(AxisId::Z, Heading::Into);
        g.begun(AxisId::X, Heading::Across);
        assert!(g.guarding());
        assert!(g.sample(10.0).is_empty());
        assert_eq!(g.sample(20.2), vec![AxisId::X, AxisId::Z]);
        assert!(!g.guarding());
        assert!(g.sample(20.3).is_empty(), "stopped once");
        g.begun(AxisId::Z, Heading::Away);
        assert!(!g.guarding());
        assert!(
            g.sample(25.0).is_empty(),
            "a retract goes on over the ceiling"
        );
    }

    #[test]
    fn a_motion_ends_with_an_idle_status_polled_after_it_began() {
        let mut g = JogGuard::new(20.0);
        g.begun(AxisId::Z, Heading::Into);
        g.polled(AxisId::Z, false);
        assert!(g.guarding(), "a status this early may predate the motion");
        g.motions[AxisId::Z.index()] = Some(Motion {
            heading: Heading::Into,
            started: Instant::now() - STATUS_LAG,
        });
        g.polled(AxisId::Z, true);
        assert!(g.guarding());
        g.polled(AxisId::Z, false);
        assert!(!g.guarding());
    }
}
