//! A scratch on the sensor's contact surface: a groove along a line segment in the sensor frame.
//!
//! A sensor file lists the scratches a unit came with under `[[surface.scratches]]`; a rig file's
//! `[[sim.ageing.scratches]]` adds those it got since (see [`crate::ageing`]). Keys:
//!
//! - `from_mm = [x, y]`, `to_mm = [x, y]`: the ends of the groove in the sensor frame, mm (finite,
//!   within 40 mm of the disc centre; required);
//! - `width_mm`: its full width at half maximum, mm (0 < width <= 5, default 0.3);
//! - `stress_fringes`: residual fringe order the groove leaves in the photoelastic layer along its
//!   line, Gaussian across it (0-5, default 0.4);
//! - `scatter_dn`: peak light the groove scatters past the analyser, DN, added after the polariser
//!   like the rim ring (0-255, default 30).
//!
//! With d the distance (mm) of a point from the segment (its ends rounded) and
//! sigma = `width_mm` / 2.35482:
//!
//! - residual order += `stress_fringes` exp(-d^2 / (2 sigma^2)), at the centre of each pixel's 2x2
//!   block as the casting residual is (it is not blurred: the renderer looks the unloaded colour
//!   up sharp);
//! - glow += peak exp(-(d k)^2 / (2 s^2)) with k = px per mm, s = sqrt((sigma k)^2 + sigma_b^2)
//!   the groove widened by the defocus and peak = `scatter_dn` sigma k / s (its 1-D energy kept),
//!   at each pixel centre.
//!
//! Both are cut off 4 widths (plus 2 px) from the segment.

use serde::{Deserialize, Serialize};

/// FWHM of a Gaussian in units of its sigma.
pub(crate) const FWHM_PER_SIGMA: f64 = 2.354_82;

/// Farthest a scratch's end may lie from the disc centre, mm.
pub(crate) const MAX_REACH_MM: f64 = 40.0;

/// One groove on the contact surface. See the module documentation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scratch {
    /// One end in the sensor frame, mm.
    pub from_mm: [f64; 2],
    /// The other end, mm.
    pub to_mm: [f64; 2],
    /// Full width at half maximum, mm (default 0.3).
    #[serde(default = "default_width_mm")]
    pub width_mm: f64,
    /// Residual fringe order along the line (default 0.4).
    #[serde(default = "default_stress_fringes")]
    pub stress_fringes: f64,
    /// Peak scattered light after the polariser, DN (default 30).
    #[serde(default = "default_scatter_dn")]
    pub scatter_dn: f64,
}

fn default_width_mm() -> f64 {
    0.3
}

fn default_stress_fringes() -> f64 {
    0.4
}

fn default_scatter_dn() -> f64 {
    30.0
}

/// A scratch's value that cannot be used: the field, its value and what is allowed.
#[derive(Debug, Clone, PartialEq)]
pub struct BadScratch {
    pub field: &'static str,
    pub value: String,
    pub allowed: &'static str,
}

impl Scratch {
    /// Checks every field's range (see the module documentation).
    pub fn check(&self) -> Result<(), BadScratch> {
        for (field, p) in [("from_mm", self.from_mm), ("to_mm", self.to_mm)] {
            if !(p.iter().all(|v| v.is_finite()) && p[0].hypot(p[1]) <= MAX_REACH_MM) {
                return Err(BadScratch {
                    field,
                    value: format!("{p:?}"),
                    allowed: "must be finite, within 40 mm of the disc centre",
                });
            }
        }
        let ranges: [(&'static str, f64, bool, &'static str); 3] = [
            (
                "width_mm",
                self.width_mm,
                self.width_mm > 0.0 && self.width_mm <= 5.0,
                "must be in (0, 5] mm",
            ),
            (
                "stress_fringes",
                self.stress_fringes,
                (0.0..=5.0).contains(&self.stress_fringes),
                "must be in 0..=5 fringes",
            ),
            (
                "scatter_dn",
                self.scatter_dn,
                (0.0..=255.0).contains(&self.scatter_dn),
                "must be in 0..=255 DN",
            ),
        ];
        for (field, value, ok, allowed) in ranges {
            if !(value.is_finite() && ok) {
                return Err(BadScratch {
                    field,
                    value: value.to_string(),
                    allowed,
                });
            }
        }
        Ok(())
    }

    /// Distance of the sensor-frame point `p` from the groove's line segment, mm.
    pub fn distance_mm(&self, p: [f64; 2]) -> f64 {
        let [ax, ay] = self.from_mm;
        let (dx, dy) = (self.to_mm[0] - ax, self.to_mm[1] - ay);
        let (px, py) = (p[0] - ax, p[1] - ay);
        let length2 = dx * dx + dy * dy;
        let s = if length2 > 0.0 {
            ((px * dx + py * dy) / length2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (px - s * dx).hypot(py - s * dy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch() -> Scratch {
        Scratch {
            from_mm: [-5.0, 0.0],
            to_mm: [5.0, 0.0],
            width_mm: default_width_mm(),
            stress_fringes: default_stress_fringes(),
            scatter_dn: default_scatter_dn(),
        }
    }

    #[test]
    fn distance_is_to_the_segment_with_rounded_ends() {
        let s = scratch();
        assert_eq!(s.distance_mm([0.0, 2.0]), 2.0);
        assert_eq!(s.distance_mm([8.0, 4.0]), 5.0);
        assert_eq!(s.distance_mm([-5.0, -1.0]), 1.0);
        let dot = Scratch {
            to_mm: s.from_mm,
            ..s
        };
        assert_eq!(dot.distance_mm([-2.0, 4.0]), 5.0);
    }

    #[test]
    fn check_names_the_field_out_of_range() {
        assert_eq!(scratch().check(), Ok(()));
        for (bad, field) in [
            (
                Scratch {
                    width_mm: 0.0,
                    ..scratch()
                },
                "width_mm",
            ),
            (
                Scratch {
                    to_mm: [50.0, 0.0],
                    ..scratch()
                },
                "to_mm",
            ),
            (
                Scratch {
                    from_mm: [f64::NAN, 0.0],
                    ..scratch()
                },
                "from_mm",
            ),
            (
                Scratch {
                    stress_fringes: -0.1,
                    ..scratch()
                },
                "stress_fringes",
            ),
            (
                Scratch {
                    scatter_dn: 300.0,
                    ..scratch()
                },
                "scatter_dn",
            ),
        ] {
            assert_eq!(bad.check().map_err(|b| b.field), Err(field));
        }
    }
}
