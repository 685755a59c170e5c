//! The figures a check compares with what the unit was accepted with, their thresholds, and the
//! verdict.
//!
//! Every figure has a threshold and the action it calls for when it moves past it:
//!
//! | figure | threshold | when it moves |
//! |---|---|---|
//! | optical centre shift | 5 sigma of the two fits, at least [`Thresholds::centre_share`] of the radius | calibrate again (the camera moved) |
//! | disc radius change | 5 sigma, at least [`Thresholds::radius_share`] of the radius | calibrate again (focus or distance changed) |
//! | turn of the rim's light | [`Thresholds::turn_deg`] | calibrate again (the camera turned) |
//! | F/T zero against the calibration's, largest axis | [`Thresholds::force_offset_n`] | calibrate again (the force offsets) |
//! | darkest rim sector | [`Thresholds::rim_ratio`] | replace or repair (an LED is out) |
//! | sharp local change of the disc | [`Thresholds::surface_cells`] cells | replace (the surface is damaged) |
//! | darkest side of the disc | [`Thresholds::side_ratio`] | replace or repair (the light is uneven) |
//! | disc brightness | [`Thresholds::dimmer`], [`Thresholds::brighter`] | replace (the LEDs are dimming), commission again (brighter) |
//! | force gain of the model | [`Thresholds::gain_change`] | commission again (the material changed) |
//! | Fz RMSE, contact RMSE | [`Thresholds::rmse_ratio`] times the acceptance's and an absolute margin | commission again |
//! | shape accuracy | [`Thresholds::accuracy_drop`] below the acceptance's | commission again |
//!
//! The verdict is the gravest action called for: replace, then calibrate again, then commission
//! again, else ok; the diagnosis is the first moved figure of that action in the table's order.
//! The thresholds were set from repeated checks of unchanged units on the simulated bench
//! (BENCHMARKS.md, "Unit health").

use crate::health::model_errors::ModelErrors;
use fringe_calibration::health::Change;

/// What a check calls for, from least to gravest.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    Ok,
    Recommission,
    Recalibrate,
    Replace,
}

impl Verdict {
    /// What to do, for people.
    pub fn advice(self) -> &'static str {
        match self {
            Verdict::Ok => "ok: the unit is as it was accepted",
            Verdict::Recommission => {
                "commission again: the model no longer fits the unit (fringe commission)"
            }
            Verdict::Recalibrate => {
                "calibrate again: the optics or the force zero moved (fringe calibrate), then check again"
            }
            Verdict::Replace => "replace or repair the unit: its light or its surface is damaged",
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Verdict::Ok => "ok",
            Verdict::Recommission => "recommission",
            Verdict::Recalibrate => "recalibrate",
            Verdict::Replace => "replace",
        }
    }
}

/// Which side of its threshold a figure must stay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Rule {
    /// Moved when above the threshold.
    AtMost,
    /// Moved when below the threshold.
    AtLeast,
}

/// One figure of a check.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Figure {
    /// Stable name, for the history and its plots.
    pub key: String,
    pub value: f64,
    pub threshold: f64,
    pub rule: Rule,
    pub unit: String,
    /// What it calls for when it moved.
    pub action: Verdict,
    pub moved: bool,
    /// What the figure says, with the numbers: what its move means when it moved, that the unit
    /// is fine in that respect when it did not.
    pub finding: String,
}

/// What a figure says when it moved and when it did not.
struct Said {
    moved: String,
    fine: String,
}

impl Figure {
    fn new(
        key: &str,
        value: f64,
        rule: Rule,
        threshold: f64,
        unit: &str,
        action: Verdict,
        said: Said,
    ) -> Figure {
        let moved = match rule {
            Rule::AtMost => value > threshold,
            Rule::AtLeast => value < threshold,
        } || !value.is_finite();
        Figure {
            key: key.to_string(),
            value,
            threshold,
            rule,
            unit: unit.to_string(),
            action,
            moved,
            finding: if moved { said.moved } else { said.fine },
        }
    }

    /// The figure's name and its unit for a reader (`centre shift`, `px`; a ratio, a count or a
    /// share has no unit: empty).
    pub fn name_and_unit(&self) -> (String, &'static str) {
        let (name, unit) = spelled(&self.key, &self.unit);
        match unit {
            "ratio" | "count" | "share" => (name, ""),
            u => (name, u),
        }
    }

    /// `name value unit (at most / at least threshold unit)`, then `ok`, or `MOVED:` and what
    /// its move means: `centre shift  0.0008 px  (at most 0.4906 px)  ok`. The unit is said once
    /// (the key's own suffix is not repeated); a ratio, a count and a share have none.
    pub fn describe(&self) -> String {
        let (name, unit) = self.name_and_unit();
        let threshold = format!("{:.4} {unit}", self.threshold);
        format!(
            "{:<22} {:>9.4} {:<4} ({} {}){}",
            name,
            self.value,
            unit,
            match self.rule {
                Rule::AtMost => "at most",
                Rule::AtLeast => "at least",
            },
            threshold.trim_end(),
            if self.moved {
                format!("  MOVED: {}", self.finding)
            } else {
                "  ok".to_string()
            }
        )
    }
}

/// A figure's key without its unit ("centre_shift_px" -> "centre shift"), and the unit spelled
/// for a reader ("deg" -> "°", a ratio's "x" -> "ratio", a count's "" -> "count", a drop in
/// accuracy's "" -> "share").
pub(crate) fn spelled(key: &str, unit: &str) -> (String, &'static str) {
    let name = key
        .trim_end_matches("_px")
        .trim_end_matches("_deg")
        .trim_end_matches("_n")
        .replace('_', " ")
        .replace("fz rmse", "Fz RMSE")
        .replace("contact rmse", "contact RMSE");
    let unit = match unit {
        "deg" => "°",
        "x" => "ratio",
        "" if key.ends_with("_cells") => "count",
        // An accuracy's drop: a share of the frames.
        "" => "share",
        "px" => "px",
        "N" => "N",
        "mm" => "mm",
        _ => "as measured",
    };
    (name, unit)
}

/// The thresholds of the figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    /// Least centre shift that counts, as a share of the disc radius (on top of 5 sigma).
    pub centre_share: f64,
    /// Least radius change that counts, as a share of the radius (on top of 5 sigma).
    pub radius_share: f64,
    pub turn_deg: f64,
    pub force_offset_n: f64,
    pub rim_ratio: f64,
    pub side_ratio: f64,
    pub surface_cells: usize,
    pub dimmer: f64,
    pub brighter: f64,
    pub gain_change: f64,
    pub rmse_ratio: f64,
    /// Fz RMSE must also grow by this much, N ...
    pub fz_margin_n: f64,
    /// ... and contact RMSE by this much, mm.
    pub contact_margin_mm: f64,
    pub accuracy_drop: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            centre_share: 0.002,
            radius_share: 0.002,
            turn_deg: 2.0,
            force_offset_n: 0.04,
            rim_ratio: 0.75,
            side_ratio: 0.92,
            surface_cells: 6,
            dimmer: 0.85,
            brighter: 1.15,
            gain_change: 0.03,
            rmse_ratio: 1.8,
            fz_margin_n: 0.1,
            contact_margin_mm: 0.3,
            accuracy_drop: 0.05,
        }
    }
}

/// What a check measured.
#[derive(Debug, Clone)]
pub struct Measured<'a> {
    pub change: &'a Change,
    /// The reference disc radius, px.
    pub radius_px: f64,
    /// Combined 1-sigma of the radius change, px.
    pub radius_sigma_px: f64,
    /// The F/T zero (Fx, Fy, Fz) at the check's first no-contact window minus the one when the
    /// unit was calibrated, N (the figure is its largest axis).
    pub force_offset_n: Option<[f64; 3]>,
    /// The model's errors at the check's positions now and at the acceptance.
    pub model_now: Option<&'a ModelErrors>,
    pub model_then: Option<&'a ModelErrors>,
}

/// A check's outcome.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Assessment {
    pub verdict: Verdict,
    /// The finding behind the verdict (empty when ok).
    pub diagnosis: String,
    /// The key of the figure behind it (empty when ok).
    #[serde(default)]
    pub cause: String,
    pub figures: Vec<Figure>,
}

impl Assessment {
    /// The figures that moved.
    pub fn moved(&self) -> impl Iterator<Item = &Figure> {
        self.figures.iter().filter(|f| f.moved)
    }
}

/// The figures of `m` against `t`, and the verdict.
pub fn assess(m: &Measured<'_>, t: &Thresholds) -> Assessment {
    let c = m.change;
    let r = m.radius_px;
    let mut figures = Vec::new();
    let sigma = c.centre_sigma_px[0].hypot(c.centre_sigma_px[1]);
    figures.push(Figure::new(
        "centre_shift_px",
        c.centre_shift(),
        Rule::AtMost,
        (5.0 * sigma).max(t.centre_share * r),
        "px",
        Verdict::Recalibrate,
        Said {
            moved: format!(
                "the camera moved: the optical centre shifted by ({:+.1}, {:+.1}) px",
                c.centre_shift_px[0], c.centre_shift_px[1]
            ),
            fine: format!(
                "the camera is where it was: the optical centre is within ({:+.1}, {:+.1}) px",
                c.centre_shift_px[0], c.centre_shift_px[1]
            ),
        },
    ));
    figures.push(Figure::new(
        "radius_change_px",
        c.radius_change_px.abs(),
        Rule::AtMost,
        (5.0 * m.radius_sigma_px).max(t.radius_share * r),
        "px",
        Verdict::Recalibrate,
        Said {
            moved: format!(
                "the disc's radius in the image changed by {:+.1} px (focus or camera distance)",
                c.radius_change_px
            ),
            fine: format!(
                "the disc's radius in the image is as it was ({:+.1} px)",
                c.radius_change_px
            ),
        },
    ));
    figures.push(Figure::new(
        "turn_deg",
        c.turn_deg.abs(),
        Rule::AtMost,
        t.turn_deg,
        "deg",
        Verdict::Recalibrate,
        Said {
            moved: format!("the camera turned by about {:+.0} degrees", c.turn_deg),
            fine: format!("the camera has not turned ({:+.0} degrees)", c.turn_deg),
        },
    ));
    if let Some(o) = m.force_offset_n {
        let moved = o.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        figures.push(Figure::new(
            "force_zero_n",
            moved,
            Rule::AtMost,
            t.force_offset_n,
            "N",
            Verdict::Recalibrate,
            Said {
                moved: format!(
                    "the F/T zero moved by ({:+.3}, {:+.3}, {:+.3}) N (Fx, Fy, Fz) since the unit was calibrated",
                    o[0], o[1], o[2]
                ),
                fine: format!(
                    "the F/T zero is where it was: ({:+.3}, {:+.3}, {:+.3}) N (Fx, Fy, Fz) since the unit was calibrated",
                    o[0], o[1], o[2]
                ),
            },
        ));
    }
    figures.push(Figure::new(
        "darkest_rim",
        c.darkest_rim_ratio,
        Rule::AtLeast,
        t.rim_ratio,
        "x",
        Verdict::Replace,
        {
            let (from, to) = (
                c.darkest_rim_deg,
                c.darkest_rim_deg + fringe_calibration::health::RIM_SECTOR_DEG as f64,
            );
            let light = 100.0 * c.darkest_rim_ratio;
            Said {
                moved: format!(
                    "an LED is out: the rim at {from:.0}-{to:.0} degrees gives {light:.0} % of its light"
                ),
                fine: format!(
                    "every LED is lit: the darkest part of the rim, at {from:.0}-{to:.0} degrees, gives {light:.0} % of its light"
                ),
            }
        },
    ));
    figures.push(Figure::new(
        "surface_cells",
        c.surface_cells as f64,
        Rule::AtMost,
        t.surface_cells as f64,
        "",
        Verdict::Replace,
        Said {
            moved: format!(
                "the surface is damaged (a scratch): {} of {} places of the disc changed sharply, by up to {:.1} DN",
                c.surface_cells, c.cells_compared, c.surface_peak_dn
            ),
            fine: format!(
                "the surface is unchanged: {} of {} places of the disc changed sharply (at most {} may), by up to {:.1} DN",
                c.surface_cells, c.cells_compared, t.surface_cells, c.surface_peak_dn
            ),
        },
    ));
    figures.push(Figure::new(
        "darkest_side",
        c.darkest_side_ratio,
        Rule::AtLeast,
        t.side_ratio,
        "x",
        Verdict::Replace,
        Said {
            moved: format!(
                "the light is uneven: the disc's side at {:.0} degrees gives {:.0} % of its light",
                c.darkest_side_deg,
                100.0 * c.darkest_side_ratio
            ),
            fine: format!(
                "the light is even: the darkest side of the disc, at {:.0} degrees, gives {:.0} % of its light",
                c.darkest_side_deg,
                100.0 * c.darkest_side_ratio
            ),
        },
    ));
    figures.push(Figure::new(
        "dimming",
        c.brightness_ratio,
        Rule::AtLeast,
        t.dimmer,
        "x",
        Verdict::Replace,
        Said {
            moved: format!(
                "the LEDs are dimming: the disc gives {:.0} % of its light",
                100.0 * c.brightness_ratio
            ),
            fine: format!(
                "the LEDs are not dimming: the disc gives {:.0} % of its light",
                100.0 * c.brightness_ratio
            ),
        },
    ));
    figures.push(Figure::new(
        "brightening",
        c.brightness_ratio,
        Rule::AtMost,
        t.brighter,
        "x",
        Verdict::Recommission,
        Said {
            moved: format!(
                "the disc is brighter: {:.0} % of its light",
                100.0 * c.brightness_ratio
            ),
            fine: format!(
                "the disc is no brighter than it was: {:.0} % of its light",
                100.0 * c.brightness_ratio
            ),
        },
    ));
    if let (Some(now), Some(then)) = (m.model_now, m.model_then) {
        model_figures(&mut figures, now, then, t);
    }
    let verdict = figures
        .iter()
        .filter(|f| f.moved)
        .map(|f| f.action)
        .max()
        .unwrap_or(Verdict::Ok);
    let (diagnosis, cause) = figures
        .iter()
        .find(|f| f.moved && f.action == verdict)
        .map(|f| (f.finding.clone(), f.key.clone()))
        .unwrap_or_default();
    Assessment {
        verdict,
        diagnosis,
        cause,
        figures,
    }
}

fn model_figures(figures: &mut Vec<Figure>, now: &ModelErrors, then: &ModelErrors, t: &Thresholds) {
    let gain = now.force_gain / then.force_gain - 1.0;
    figures.push(Figure::new(
        "force_gain_change",
        gain.abs(),
        Rule::AtMost,
        t.gain_change,
        "x",
        Verdict::Recommission,
        {
            let by = format!(
                "the model reads {:.0} % {} force than at acceptance",
                100.0 * gain.abs(),
                if gain < 0.0 { "less" } else { "more" }
            );
            Said {
                moved: format!("the material changed: {by}"),
                fine: format!("the material is unchanged: {by}"),
            }
        },
    ));
    let grown = |now: f64, then: f64, margin: f64| {
        if now > then + margin {
            now / then.max(1e-9)
        } else {
            1.0
        }
    };
    figures.push(Figure::new(
        "fz_rmse_growth",
        grown(now.fz_rmse_n, then.fz_rmse_n, t.fz_margin_n),
        Rule::AtMost,
        t.rmse_ratio,
        "x",
        Verdict::Recommission,
        {
            let figures = format!(
                "Fz RMSE {:.3} N, {:.3} N at acceptance",
                now.fz_rmse_n, then.fz_rmse_n
            );
            Said {
                moved: format!("the model's force error grew: {figures}"),
                fine: format!("the model's force error is as it was: {figures}"),
            }
        },
    ));
    figures.push(Figure::new(
        "contact_rmse_growth",
        grown(
            now.contact_rmse_mm,
            then.contact_rmse_mm,
            t.contact_margin_mm,
        ),
        Rule::AtMost,
        t.rmse_ratio,
        "x",
        Verdict::Recommission,
        {
            let figures = format!(
                "contact RMSE {:.2} mm, {:.2} mm at acceptance",
                now.contact_rmse_mm, then.contact_rmse_mm
            );
            Said {
                moved: format!("the model's contact error grew: {figures}"),
                fine: format!("the model's contact error is as it was: {figures}"),
            }
        },
    ));
    figures.push(Figure::new(
        "shape_accuracy_drop",
        then.shape_accuracy - now.shape_accuracy,
        Rule::AtMost,
        t.accuracy_drop,
        "",
        Verdict::Recommission,
        {
            let figures = format!(
                "{:.1} %, {:.1} % at acceptance",
                100.0 * now.shape_accuracy,
                100.0 * then.shape_accuracy
            );
            Said {
                moved: format!("the model's shape accuracy fell: {figures}"),
                fine: format!("the model's shape accuracy is as it was: {figures}"),
            }
        },
    ));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::test_change::unchanged;

    fn errors(gain: f64, fz: f64) -> ModelErrors {
        ModelErrors {
            frames: 900,
            fz_rmse_n: fz,
            contact_rmse_mm: 1.0,
            shape_accuracy: 0.99,
            force_gain: gain,
        }
    }

    fn assessed(change: &Change, zero: [f64; 3], now: &ModelErrors) -> Assessment {
        let then = errors(1.0, 0.3);
        assess(
            &Measured {
                change,
                radius_px: 245.0,
                radius_sigma_px: 0.03,
                force_offset_n: Some(zero),
                model_now: Some(now),
                model_then: Some(&then),
            },
            &Thresholds::default(),
        )
    }

    #[test]
    fn an_unchanged_unit_is_ok_with_nothing_moved() {
        let a = assessed(&unchanged(), [0.01, -0.02, 0.015], &errors(1.01, 0.32));
        assert_eq!(a.verdict, Verdict::Ok);
        assert_eq!(a.moved().count(), 0, "{a:?}");
        assert!(a.cause.is_empty() && a.diagnosis.is_empty());
    }

    #[test]
    fn figures_that_did_not_move_are_worded_as_fine_and_moved_ones_as_faults() {
        let a = assessed(&unchanged(), [0.01, -0.02, 0.015], &errors(1.01, 0.32));
        let finding = |a: &Assessment, key: &str| {
            a.figures
                .iter()
                .find(|f| f.key == key)
                .map(|f| f.finding.clone())
                .unwrap_or_else(|| panic!("no figure {key}"))
        };
        assert_eq!(
            finding(&a, "darkest_rim"),
            "every LED is lit: the darkest part of the rim, at 40-50 degrees, gives 97 % of its light"
        );
        assert_eq!(
            finding(&a, "surface_cells"),
            "the surface is unchanged: 0 of 1400 places of the disc changed sharply (at most 6 may), by up to 0.9 DN"
        );
        // Nothing moved: no finding speaks of a fault.
        for f in &a.figures {
            for fault in [
                "is out",
                "damaged",
                "moved",
                "uneven",
                "are dimming",
                "is brighter",
                "material changed",
                "grew",
                "fell",
                "turned by",
            ] {
                assert!(!f.finding.contains(fault), "{}: {}", f.key, f.finding);
            }
        }
        // The same figures moved say what is wrong.
        let mut led = unchanged();
        led.darkest_rim_ratio = 0.3;
        led.surface_cells = 40;
        let a = assessed(&led, [0.0; 3], &errors(1.0, 0.3));
        assert!(
            finding(&a, "darkest_rim").starts_with("an LED is out: the rim at 40-50 degrees"),
            "{a:?}"
        );
        assert!(
            finding(&a, "surface_cells")
                .starts_with("the surface is damaged (a scratch): 40 of 1400"),
            "{a:?}"
        );
    }

    #[test]
    fn the_gravest_action_wins_and_names_its_first_figure() {
        // A dead LED also worsens the model: the unit is to be repaired, not commissioned again.
        let mut led = unchanged();
        led.darkest_rim_ratio = 0.3;
        led.darkest_side_ratio = 0.85;
        let a = assessed(&led, [0.0; 3], &errors(0.93, 0.7));
        assert_eq!(a.verdict, Verdict::Replace);
        assert_eq!(a.cause, "darkest_rim");
        assert!(a.diagnosis.contains("an LED is out"), "{}", a.diagnosis);
        assert!(a.moved().any(|f| f.key == "force_gain_change"));
        // A knocked camera: calibrate again, before judging the model.
        let mut knocked = unchanged();
        knocked.centre_shift_px = [2.5, 0.0];
        let a = assessed(&knocked, [0.0; 3], &errors(1.0, 0.9));
        assert_eq!(
            (a.verdict, a.cause.as_str()),
            (Verdict::Recalibrate, "centre_shift_px")
        );
        // The F/T zero: the largest axis against its threshold.
        let a = assessed(&unchanged(), [0.0, 0.01, 0.1], &errors(1.0, 0.3));
        assert_eq!(
            (a.verdict, a.cause.as_str()),
            (Verdict::Recalibrate, "force_zero_n")
        );
        assert!(a.diagnosis.contains("+0.100"), "{}", a.diagnosis);
        // The material: the model reads less force.
        let a = assessed(&unchanged(), [0.0; 3], &errors(0.91, 0.45));
        assert_eq!(
            (a.verdict, a.cause.as_str()),
            (Verdict::Recommission, "force_gain_change")
        );
        assert!(a.diagnosis.contains("9 % less"), "{}", a.diagnosis);
    }

    #[test]
    fn a_figure_that_could_not_be_measured_counts_as_moved() {
        let mut c = unchanged();
        c.brightness_ratio = f64::NAN;
        let a = assessed(&c, [0.0; 3], &errors(1.0, 0.3));
        assert_ne!(a.verdict, Verdict::Ok);
    }
}
