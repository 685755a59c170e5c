//! The manual y stage: the operator moves the stage by hand (micrometer screw) and confirms.
//!
//! Every motion becomes a question to the operator through the engine's [`Operator`]
//! ([`Operator::answer`]: a typed line). The front end supplies the operator: the command line's
//! reads lines from stdin, the UI's answers through the UI, and tests script the answers.

use crate::axis::{Axis, AxisError, AxisStatus, Kinematics, SoftLimits, StopMode};
use crate::operator::Operator;
use crate::units::Millimetres;
use std::io;
use std::time::Duration;

/// How many unreadable answers are tolerated before a question fails.
const MAX_ATTEMPTS: usize = 3;

/// A y stage moved by hand.
pub struct ManualStage {
    axis: String,
    operator: Box<dyn Operator>,
    limits: Option<SoftLimits>,
    position: Option<Millimetres>,
    homed: bool,
}

impl ManualStage {
    /// A manual axis named `axis`, asking `operator`.
    pub fn new(axis: &str, operator: Box<dyn Operator>, limits: Option<SoftLimits>) -> ManualStage {
        ManualStage {
            axis: axis.to_string(),
            operator,
            limits,
            position: None,
            homed: false,
        }
    }

    fn cancelled(&self) -> AxisError {
        AxisError::Cancelled {
            axis: self.axis.clone(),
        }
    }

    fn io_error(&self, source: io::Error) -> AxisError {
        if source.kind() == io::ErrorKind::Unsupported {
            return AxisError::Device {
                axis: self.axis.clone(),
                endpoint: self.endpoint(),
                message: format!("moved by hand, but {source}"),
            };
        }
        AxisError::Io {
            axis: self.axis.clone(),
            endpoint: self.endpoint(),
            source,
        }
    }

    /// Asks until the answer is a number of millimetres (or, when `default` is given, empty).
    fn ask_mm(
        &mut self,
        question: &str,
        default: Option<Millimetres>,
    ) -> Result<Millimetres, AxisError> {
        let mut q = question.to_string();
        for _ in 0..MAX_ATTEMPTS {
            let answer = self.operator.answer(&q).map_err(|e| self.io_error(e))?;
            let Some(answer) = answer else {
                return Err(self.cancelled());
            };
            let text = answer.trim().trim_end_matches("mm").trim();
            if text.eq_ignore_ascii_case("q") {
                return Err(self.cancelled());
            }
            match (text.is_empty(), default) {
                (true, Some(d)) => return Ok(d),
                _ => match text.parse::<f64>() {
                    Ok(v) if v.is_finite() => match self.limits {
                        Some(l) if l.check(&self.axis, Millimetres(v)).is_err() => {
                            q = format!(
                                "{v} mm is outside the soft limits {:.3} .. {:.3} mm of {}: check the reading. {question}",
                                l.min.0, l.max.0, self.axis
                            )
                        }
                        _ => return Ok(Millimetres(v)),
                    },
                    _ => q = format!("\"{answer}\" is not a number of millimetres. {question}"),
                },
            }
        }
        Err(AxisError::Device {
            axis: self.axis.clone(),
            endpoint: self.endpoint(),
            message: format!("no readable position after {MAX_ATTEMPTS} answers"),
        })
    }

    fn current(&mut self) -> Result<Millimetres, AxisError> {
        match self.position {
            Some(p) => Ok(p),
            None => {
                let q = format!(
                    "type the current {} reading in mm and press Enter (q to cancel):",
                    self.axis
                );
                let p = self.ask_mm(&q, None)?;
                self.position = Some(p);
                Ok(p)
            }
        }
    }

    fn snapshot(&self, position: Millimetres) -> AxisStatus {
        AxisStatus {
            position,
            moving: false,
            homed: self.homed,
            flags: if self.homed {
                vec!["referenced by the operator"]
            } else {
                Vec::new()
            },
            faults: Vec::new(),
        }
    }
}

impl Axis for ManualStage {
    fn name(&self) -> &str {
        &self.axis
    }

    fn endpoint(&self) -> String {
        "manual (operator)".to_string()
    }

    fn begin_home(&mut self) -> Result<(), AxisError> {
        let q = format!(
            "type the current {} reading in mm to reference the axis (q to cancel):",
            self.axis
        );
        let p = self.ask_mm(&q, None)?;
        self.position = Some(p);
        self.homed = true;
        Ok(())
    }

    fn begin_move_to(&mut self, target: Millimetres) -> Result<(), AxisError> {
        let limits = self.limits.unwrap_or(SoftLimits::UNBOUNDED);
        limits.check(&self.axis, target)?;
        let q = format!(
            "move {} to {target:.3} and press Enter (or type the reading in mm if it differs; q to cancel):",
            self.axis
        );
        let reached = self.ask_mm(&q, Some(target))?;
        self.position = Some(reached);
        Ok(())
    }

    fn begin_move_by(&mut self, delta: Millimetres) -> Result<(), AxisError> {
        let from = self.current()?;
        self.begin_move_to(from + delta)
    }

    fn begin_move_to_at(
        &mut self,
        _target: Millimetres,
        _motion: Kinematics,
    ) -> Result<(), AxisError> {
        Err(AxisError::Motion {
            axis: self.axis.clone(),
            message: "moved by hand: it cannot move at a chosen speed under force control; slide along a motorised axis".into(),
        })
    }

    fn wait_idle(&mut self, _timeout: Duration) -> Result<AxisStatus, AxisError> {
        // The operator confirmed the motion before begin_* returned.
        let p = self.current()?;
        Ok(self.snapshot(p))
    }

    fn stop(&mut self, _mode: StopMode) -> Result<(), AxisError> {
        // Nothing moves unless the operator moves it; there is nothing to stop.
        Ok(())
    }

    fn status(&mut self) -> Result<AxisStatus, AxisError> {
        let p = self.current()?;
        Ok(self.snapshot(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::{Prompt, Reply};

    /// An operator that takes no typed answers (the trait's default).
    struct Untyped;

    impl Operator for Untyped {
        fn ask(&mut self, _prompt: &Prompt) -> Reply {
            Reply::Abort
        }
    }

    #[test]
    fn an_operator_without_typed_answers_is_a_clear_error_not_a_cancel() {
        let mut y = ManualStage::new("y", Box::new(Untyped), None);
        let e = y.status().expect_err("no typed answers");
        let m = e.to_string();
        assert!(
            m.starts_with("axis y (manual (operator)): moved by hand, but this front end takes no typed answers"),
            "{m}"
        );
    }
}
