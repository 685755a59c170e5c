//! Force safety of motions outside a scan (the Bench screen): which way a motion goes relative
//! to the sensor, which motions are refused while the force is over the ceiling or the
//! indenter is in contact, and which are stopped when that happens.
//!
//! Conventions (as the scan engine's): z moves towards the sensor with increasing position; x
//! and y move the indenter across it. A move away from the sensor (z up, homing z) is always
//! allowed and never stopped for force: it is how the load comes off. While the force is over
//! the ceiling, moves into the sensor and moves across it are refused; one already running is
//! stopped at the first sample over the ceiling.
//!
//! In contact, a move across the sensor drags the indenter through the gel, and a tare hides
//! the load from the ceiling and from every later check: both are refused while the F/T reads a
//! load, and a move across is stopped at the first reading of one. A load is told from the F/T's
//! no-contact reading by the scan engine's rule ([`Clearance`]), as the F/T may not be tared (a
//! reading of -5 N can be no load, and 0 N a load after a tare under load). That reading is
//! taken, as the scan takes it, where nothing can touch the indenter: with z at its home (the
//! end of its travel away from the sensor) after this session homed it, and followed there;
//! then from the first readings after a tare that was allowed. Until it is known (z not homed
//! since the bench opened, or the F/T restarted and its zero moved) a load cannot be told from
//! a zero, so moves across the sensor and the tare are refused, saying to home z first.

use fringe_rig::scan::Clearance;
use fringe_rig::Newtons;
use std::time::{Duration, Instant};

/// Why a motion or a tare is refused; each says what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum Refused {
    /// A move into or across the sensor while the force is over the ceiling.
    #[error("{axis}: {what} is refused while the force ({force_n:.2} N) is over the ceiling {ceiling_n:.2} N; retract z first (←, or h to home z)")]
    OverCeiling {
        axis: &'static str,
        what: &'static str,
        force_n: f64,
        ceiling_n: f64,
    },
    /// A move across the sensor, or a tare, while the F/T reads a load.
    #[error("{} is refused while the F/T reads a load: {load_n:.2} N in Fz off its no-contact reading (taken {from}; more than {threshold_n:.2} N is a load), so the indenter is in contact and {}; lift it with z first (z, then ←, or h to home z)", act.what(), act.harm())]
    Loaded {
        act: Act,
        load_n: f64,
        threshold_n: f64,
        from: String,
    },
    /// A move across the sensor, or a tare, before the F/T's no-contact reading is known.
    #[error("{} is refused: {}, so a load cannot be told from the F/T's zero; {}", act.what(), why.describe(), why.advice())]
    Unknown { act: Act, why: Unknown },
}

/// What needs the indenter clear of the sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Act {
    /// A move of x or y (a jog or homing).
    Across(AxisId),
    /// Zeroing the F/T (its no-contact offset).
    Tare,
}

impl Act {
    fn what(self) -> String {
        match self {
            Act::Across(axis) => format!("{}: a move across the sensor", axis.name()),
            Act::Tare => "the tare (the F/T's no-contact offset)".to_string(),
        }
    }

    fn harm(self) -> &'static str {
        match self {
            Act::Across(_) => "a move across would drag it through the gel",
            Act::Tare => "a tare would hide that load from the force ceiling and from this check",
        }
    }
}

/// Why the F/T's no-contact reading is not known.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Unknown {
    /// z has not been homed since the bench opened.
    NotHomed,
    /// The F/T restarted since the reading was taken: its zero moved.
    Restarted,
    /// A tare set a new zero, read from the samples that follow it.
    Tared,
    /// No reading has come from the F/T yet.
    NoReading,
}

impl Unknown {
    fn describe(self) -> &'static str {
        match self {
            Unknown::NotHomed => {
                "the F/T's no-contact reading is not known yet (z has not been homed since the bench opened)"
            }
            Unknown::Restarted => {
                "the F/T restarted since its no-contact reading was taken (its zero moved)"
            }
            Unknown::Tared => "the F/T's new zero after the tare is still being read",
            Unknown::NoReading => "the F/T has sent no reading yet",
        }
    }

    fn advice(self) -> &'static str {
        match self {
            Unknown::NotHomed | Unknown::Restarted => {
                "home z first (z, then h): at its home nothing touches the indenter, and the no-contact reading is taken there"
            }
            Unknown::Tared | Unknown::NoReading => "try again in a moment",
        }
    }
}

/// Moves across the sensor stopped because the F/T read a load.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{} stopped: the F/T reads a load, {load_n:.2} N in Fz off its no-contact reading (taken {from}; more than {threshold_n:.2} N is a load): the indenter touched the sensor while moving across it; lift it with z first (z, then ←, or h to home z)", names(axes))]
pub(crate) struct LoadStop {
    pub axes: Vec<AxisId>,
    pub load_n: f64,
    pub threshold_n: f64,
    pub from: String,
}

fn names(axes: &[AxisId]) -> String {
    axes.iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")
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
pub(crate) enum Heading {
    /// Away from the sensor: z up, or homing z.
    Away,
    /// Into the sensor: z down.
    Into,
    /// Across the sensor: x or y.
    Across,
}

impl Heading {
    /// A jog of `axis` by `by_mm`.
    pub(crate) fn of_jog(axis: AxisId, by_mm: f64) -> Heading {
        match axis {
            AxisId::Z if by_mm > 0.0 => Heading::Into,
            AxisId::Z => Heading::Away,
            AxisId::X | AxisId::Y => Heading::Across,
        }
    }

    /// Homing `axis` (z homes up, away from the sensor).
    pub(crate) fn of_home(axis: AxisId) -> Heading {
        match axis {
            AxisId::Z => Heading::Away,
            AxisId::X | AxisId::Y => Heading::Across,
        }
    }
}

/// A status polled this soon after a command may predate the motion (a K-Cube reports every
/// 100 ms): an axis is taken to have finished only when idle after this long.
const STATUS_LAG: Duration = Duration::from_millis(300);

/// z is at its home when it rests this close to where its homing ended, mm.
const AT_HOME_MM: f64 = 0.01;

#[derive(Debug, Clone, Copy)]
struct Motion {
    heading: Heading,
    /// A homing (not a jog).
    homing: bool,
    started: Instant,
}

/// An axis as polled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Polled {
    pub moving: bool,
    pub homed: bool,
    pub position_mm: f64,
}

/// The motions under way and the force they are checked against.
#[derive(Debug, Clone)]
pub(crate) struct JogGuard {
    ceiling_n: f64,
    /// More than this off the no-contact reading is a load.
    contact_threshold: Newtons,
    /// The newest total force, N.
    force_n: Option<f64>,
    /// The newest Fz, a mean of the newest samples, N.
    fz_n: Option<f64>,
    /// The F/T's no-contact reading, or why it is not known.
    reference: Result<Clearance, Unknown>,
    motions: [Option<Motion>; 3],
    /// Where z's homing ended this session (its home, away from the sensor).
    z_home_mm: Option<f64>,
    /// z rests at its home (as last polled, and not moved since).
    z_at_home: bool,
}

impl JogGuard {
    /// Moves are stopped over `ceiling_n` (N); a reading more than `contact_threshold` off the
    /// no-contact reading is a load.
    pub(crate) fn new(ceiling_n: f64, contact_threshold: Newtons) -> JogGuard {
        JogGuard {
            ceiling_n,
            contact_threshold,
            force_n: None,
            fz_n: None,
            reference: Err(Unknown::NotHomed),
            motions: [None; 3],
            z_home_mm: None,
            z_at_home: false,
        }
    }

    /// Whether a motion of `axis` going `heading` may start now; the refusal says why and what
    /// to do. A move away from the sensor always may.
    pub(crate) fn admit(&self, axis: AxisId, heading: Heading) -> Result<(), Refused> {
        if heading == Heading::Away {
            return Ok(());
        }
        if let Some(force_n) = self.force_n.filter(|f| *f > self.ceiling_n) {
            let what = match heading {
                Heading::Into => "a move into the sensor",
                _ => "a move across the sensor",
            };
            return Err(Refused::OverCeiling {
                axis: axis.name(),
                what,
                force_n,
                ceiling_n: self.ceiling_n,
            });
        }
        match heading {
            Heading::Across => self.clear(Act::Across(axis)),
            _ => Ok(()),
        }
    }

    /// Whether the F/T may be tared now (nothing touching the indenter); the refusal says why
    /// and what to do.
    pub(crate) fn admit_tare(&self) -> Result<(), Refused> {
        self.clear(Act::Tare)
    }

    /// Whether the F/T reads no load now, against its no-contact reading.
    fn clear(&self, act: Act) -> Result<(), Refused> {
        // Nothing touches the indenter with z at its home (even before a reading there).
        if self.z_at_home {
            return Ok(());
        }
        let reference = self
            .reference
            .as_ref()
            .map_err(|why| Refused::Unknown { act, why: *why })?;
        let Some(fz) = self.fz_n else {
            return Err(Refused::Unknown {
                act,
                why: Unknown::NoReading,
            });
        };
        if reference.loaded(fz) {
            return Err(Refused::Loaded {
                act,
                load_n: reference.load(fz).0,
                threshold_n: reference.threshold().0,
                from: reference.from().to_string(),
            });
        }
        Ok(())
    }

    /// A motion of `axis` going `heading` was started (replacing any before it).
    pub(crate) fn begun(&mut self, axis: AxisId, heading: Heading) {
        self.start(axis, heading, false);
    }

    /// The homing of `axis` was started.
    pub(crate) fn homing_begun(&mut self, axis: AxisId) {
        self.start(axis, Heading::of_home(axis), true);
    }

    fn start(&mut self, axis: AxisId, heading: Heading, homing: bool) {
        self.motions[axis.index()] = Some(Motion {
            heading,
            homing,
            started: Instant::now(),
        });
        if axis == AxisId::Z {
            self.z_at_home = false;
        }
    }

    /// Every axis was stopped.
    pub(crate) fn stopped_all(&mut self) {
        self.motions = [None; 3];
    }

    /// A status poll of `axis`: an idle axis has finished its motion (unless the status may
    /// predate it); z's homing, finished, tells where its home is.
    pub(crate) fn polled(&mut self, axis: AxisId, status: Polled) {
        let slot = &mut self.motions[axis.index()];
        let finished = !status.moving && slot.is_some_and(|m| m.started.elapsed() >= STATUS_LAG);
        if finished {
            if axis == AxisId::Z && status.homed && slot.is_some_and(|m| m.homing) {
                self.z_home_mm = Some(status.position_mm);
            }
            *slot = None;
        }
        if axis == AxisId::Z {
            self.z_at_home = slot.is_none()
                && !status.moving
                && status.homed
                && self
                    .z_home_mm
                    .is_some_and(|h| (status.position_mm - h).abs() <= AT_HOME_MM);
        }
    }

    /// Whether a motion that the force can stop is under way (the bench then checks the force
    /// at every sample instead of every poll).
    pub(crate) fn guarding(&self) -> bool {
        self.motions
            .iter()
            .flatten()
            .any(|m| m.heading != Heading::Away)
    }

    /// A force sample (total |F|, N): the axes to stop now, those moving into or across the
    /// sensor while the force is over the ceiling (forgotten here once returned).
    pub(crate) fn sample(&mut self, total_n: f64) -> Vec<AxisId> {
        self.force_n = Some(total_n);
        if total_n <= self.ceiling_n {
            return Vec::new();
        }
        self.stop(|h| h != Heading::Away)
    }

    /// The F/T was tared: its zero moved, and its no-contact reading is read again from the
    /// samples that follow.
    pub(crate) fn tared(&mut self) {
        self.reference = Err(Unknown::Tared);
        self.fz_n = None;
    }

    /// A reading of the F/T (`fz_n`, the mean of the newest
    /// [`fringe_rig::scan::LOAD_SAMPLES`], N) after `restarts` restarts of the device:
    /// the no-contact reading taken or followed where it can be, and the moves across the sensor
    /// to stop now when it reads a load (forgotten here once returned).
    pub(crate) fn reading(&mut self, fz_n: f64, restarts: u64) -> Option<LoadStop> {
        self.fz_n = Some(fz_n);
        let clear_here = if self.z_at_home {
            Some("with z at its home")
        } else if matches!(self.reference, Err(Unknown::Tared)) {
            Some("after the tare")
        } else {
            None
        };
        match (&mut self.reference, clear_here) {
            (Ok(r), Some(from)) if !fz_n.is_nan() => r.follow(fz_n, restarts, from.into()),
            (Err(_), Some(from)) if !fz_n.is_nan() => {
                self.reference = Ok(Clearance::new(
                    fz_n,
                    restarts,
                    from.into(),
                    self.contact_threshold,
                ));
            }
            (Ok(r), None) if r.outdated(restarts) => self.reference = Err(Unknown::Restarted),
            _ => {}
        }
        let Ok(r) = &self.reference else {
            return None;
        };
        if !r.loaded(fz_n) {
            return None;
        }
        let (load_n, threshold_n, from) = (r.load(fz_n).0, r.threshold().0, r.from().to_string());
        let axes = self.stop(|h| h == Heading::Across);
        (!axes.is_empty()).then_some(LoadStop {
            axes,
            load_n,
            threshold_n,
            from,
        })
    }

    /// Forgets the motions whose heading `stop` names and returns their axes.
    fn stop(&mut self, stop: impl Fn(Heading) -> bool) -> Vec<AxisId> {
        AxisId::ALL
            .into_iter()
            .filter(|a| {
                let slot = &mut self.motions[a.index()];
                let hit = slot.is_some_and(|m| stop(m.heading));
                if hit {
                    *slot = None;
                }
                hit
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bench's contact threshold.
    const LOAD: Newtons = Newtons(0.3);

    fn z_at(position_mm: f64, moving: bool) -> Polled {
        Polled {
            moving,
            homed: true,
            position_mm,
        }
    }

    /// A guard whose z was homed (ending at 0 mm) and polled idle there.
    fn homed(g: &mut JogGuard) {
        g.homing_begun(AxisId::Z);
        g.motions[AxisId::Z.index()] = g.motions[AxisId::Z.index()].map(|m| Motion {
            started: Instant::now() - STATUS_LAG,
            ..m
        });
        g.polled(AxisId::Z, z_at(0.0, false));
    }

    /// A z jog from home into the sensor, finished at `to_mm`.
    fn z_jogged(g: &mut JogGuard, to_mm: f64) {
        g.begun(AxisId::Z, Heading::Into);
        g.motions[AxisId::Z.index()] = g.motions[AxisId::Z.index()].map(|m| Motion {
            started: Instant::now() - STATUS_LAG,
            ..m
        });
        g.polled(AxisId::Z, z_at(to_mm, false));
    }

    #[test]
    fn over_the_ceiling_only_moves_away_from_the_sensor_are_admitted() {
        let mut g = JogGuard::new(20.0, LOAD);
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
        let mut g = JogGuard::new(20.0, LOAD);
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
        let mut g = JogGuard::new(20.0, LOAD);
        g.begun(AxisId::Z, Heading::Into);
        g.polled(AxisId::Z, z_at(1.0, false));
        assert!(g.guarding(), "a status this early may predate the motion");
        g.motions[AxisId::Z.index()] = Some(Motion {
            heading: Heading::Into,
            homing: false,
            started: Instant::now() - STATUS_LAG,
        });
        g.polled(AxisId::Z, z_at(1.0, true));
        assert!(g.guarding());
        g.polled(AxisId::Z, z_at(1.0, false));
        assert!(!g.guarding());
    }

    /// Issue 59: the Bench screen moved x and y while the indenter pressed (only a force over
    /// the ceiling refused them) and tared under load. The F/T here is not tared: it reads
    /// -5.07 N with nothing touching, which a rule on the reading alone would call a load.
    #[test]
    fn in_contact_moves_across_and_the_tare_are_refused_and_a_lift_always_goes() {
        let mut g = JogGuard::new(20.0, LOAD);
        g.sample(5.07);
        g.reading(-5.07, 0);
        // Nothing tells a load from a zero before z was homed.
        let refused = g.admit(AxisId::X, Heading::Across).unwrap_err();
        assert_eq!(
            refused,
            Refused::Unknown {
                act: Act::Across(AxisId::X),
                why: Unknown::NotHomed
            }
        );
        assert!(refused.to_string().contains("home z first (z, then h)"));
        assert!(g.admit(AxisId::Y, Heading::of_home(AxisId::Y)).is_err());
        let tare = g.admit_tare().unwrap_err().to_string();
        assert!(
            tare.starts_with("the tare") && tare.contains("home z first"),
            "{tare}"
        );
        assert!(g.admit(AxisId::Z, Heading::Away).is_ok());
        // With z at its home, the reading there is no contact (untared: -5.07 N).
        homed(&mut g);
        assert!(g.reading(-5.07, 0).is_none());
        assert!(g.admit(AxisId::X, Heading::Across).is_ok());
        assert!(g.admit_tare().is_ok());
        // Pressed 2 N in: the F/T reads -7.07 N, under the ceiling by far.
        z_jogged(&mut g, 16.0);
        g.sample(7.07);
        assert!(g.reading(-7.07, 0).is_none(), "nothing moving across");
        let refused = g.admit(AxisId::X, Heading::Across).unwrap_err();
        let said = refused.to_string();
        assert!(
            said.starts_with(
                "x: a move across the sensor is refused while the F/T reads a load: 2.00 N"
            ) && said.contains("taken with z at its home")
                && said.contains("lift it with z first (z, then ←, or h to home z)"),
            "{said}"
        );
        assert!(g.admit(AxisId::Y, Heading::of_home(AxisId::Y)).is_err());
        let tare = g.admit_tare().unwrap_err().to_string();
        assert!(
            tare.contains("a tare would hide that load") && tare.contains("2.00 N"),
            "{tare}"
        );
        // Pressing further and lifting stay allowed.
        assert!(g.admit(AxisId::Z, Heading::Into).is_ok());
        assert!(g.admit(AxisId::Z, Heading::of_jog(AxisId::Z, -1.0)).is_ok());
        assert!(g.admit(AxisId::Z, Heading::of_home(AxisId::Z)).is_ok());
        // Lifted clear (not home): the reading is back within the threshold.
        z_jogged(&mut g, 10.0);
        g.reading(-5.2, 0);
        assert!(g.admit(AxisId::X, Heading::Across).is_ok());
        assert!(g.admit_tare().is_ok());
        // A reading it cannot trust moves nothing across.
        g.reading(f64::NAN, 0);
        assert!(g.admit(AxisId::X, Heading::Across).is_err());
    }

    #[test]
    fn a_move_across_is_stopped_at_the_first_reading_of_a_load_and_z_moves_are_not() {
        let mut g = JogGuard::new(20.0, LOAD);
        homed(&mut g);
        g.reading(0.4, 0);
        z_jogged(&mut g, 14.0);
        g.begun(AxisId::X, Heading::Across);
        g.begun(AxisId::Z, Heading::Away);
        assert!(g.reading(0.5, 0).is_none(), "0.1 N off: no load");
        let stop = g.reading(-0.6, 0).expect("stopped");
        assert_eq!(stop.axes, vec![AxisId::X]);
        assert!((stop.load_n - 1.0).abs() < 1e-9);
        assert!(
            stop.to_string()
                .starts_with("x stopped: the F/T reads a load, 1.00 N"),
            "{stop}"
        );
        assert!(g.reading(-0.6, 0).is_none(), "stopped once");
        assert!(g.motions[AxisId::Z.index()].is_some(), "the lift goes on");
    }

    #[test]
    fn the_no_contact_reading_is_read_again_after_a_tare_and_lost_when_the_ft_restarts() {
        let mut g = JogGuard::new(20.0, LOAD);
        homed(&mut g);
        g.reading(-5.07, 0);
        z_jogged(&mut g, 10.0);
        g.reading(-5.0, 0);
        assert!(g.admit_tare().is_ok());
        g.tared();
        let settling = g.admit(AxisId::X, Heading::Across).unwrap_err();
        assert_eq!(
            settling,
            Refused::Unknown {
                act: Act::Across(AxisId::X),
                why: Unknown::Tared
            }
        );
        // The first reading after the tare is its zero: -5 N is now a load.
        g.reading(0.02, 0);
        assert!(g.admit(AxisId::X, Heading::Across).is_ok());
        g.reading(-5.0, 0);
        assert!(g.admit(AxisId::X, Heading::Across).is_err());
        // The F/T restarted: its zero moved, nothing tells a load until z is home again.
        g.reading(0.0, 1);
        let lost = g.admit(AxisId::X, Heading::Across).unwrap_err();
        assert_eq!(
            lost,
            Refused::Unknown {
                act: Act::Across(AxisId::X),
                why: Unknown::Restarted
            }
        );
        assert!(g.admit_tare().is_err());
        homed(&mut g);
        g.reading(3.0, 1);
        assert!(g.admit(AxisId::X, Heading::Across).is_ok());
        assert!(g.admit_tare().is_ok());
        // A jog of z leaves its home: the reference is kept, no longer followed.
        g.begun(AxisId::Z, Heading::Into);
        g.reading(4.0, 1);
        assert!(g.admit(AxisId::X, Heading::Across).is_err());
    }
}
