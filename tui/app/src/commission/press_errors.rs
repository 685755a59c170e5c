//! A round's presses scored by the model as it stood before adapting on them: the round's
//! point of the learning curve, and each press's error in the spec's units (1 = at the
//! threshold) for choosing where to press next.

use super::certificate::CurvePoint;
use super::press_choice::PressedPoint;
use fringe_sensor_models::dataset::Sample;
use fringe_sensor_models::Spec;
use fringe_sensor_models::{Errors, Scored};
use std::collections::BTreeMap;

/// What a round's scores say.
#[derive(Debug, Clone, PartialEq)]
pub struct RoundErrors {
    pub curve: CurvePoint,
    pub presses: Vec<PressedPoint>,
}

/// The thresholds errors are measured against: the spec's, else the paper's.
fn scale(spec: &Spec) -> (f64, f64, f64) {
    let paper = Spec::paper().all;
    let pick = |a: Option<f64>, b: Option<f64>, fallback: f64| a.or(b).unwrap_or(fallback);
    (
        pick(spec.all.fz_rmse_n, paper.fz_rmse_n, 0.49),
        pick(spec.all.contact_rmse_mm, paper.contact_rmse_mm, 1.47),
        1.0 - pick(spec.all.shape_accuracy, paper.shape_accuracy, 0.953),
    )
}

/// A group's error in the spec's units: the worst of its three figures against their
/// thresholds.
fn in_spec_units(e: &Errors, spec: &Spec) -> f64 {
    let (fz, contact, miss) = scale(spec);
    let mut worst = e.fz_rmse() / fz.max(1e-9);
    if e.n_contact > 0 {
        worst = worst.max(e.contact_rmse() / contact.max(1e-9));
    }
    if e.n > 0 {
        worst = worst.max((1.0 - e.accuracy()) / miss.max(1e-3));
    }
    worst
}

/// Scores `rows` (one per sample of `samples`, in order) of round `round`, after
/// `presses_before` presses were adapted on.
pub fn round_errors(
    round: usize,
    presses_before: usize,
    samples: &[Sample],
    rows: &[Scored],
    spec: &Spec,
) -> RoundErrors {
    let mut all = Errors::default();
    let mut by_press: BTreeMap<&str, (Option<[f64; 2]>, Errors)> = BTreeMap::new();
    for (s, r) in samples.iter().zip(rows) {
        all.add(r);
        let entry = by_press
            .entry(s.press.as_str())
            .or_insert((None, Errors::default()));
        entry.0 = entry.0.or(s.stage_mm);
        entry.1.add(r);
    }
    let presses = by_press
        .values()
        .filter_map(|(at, e)| {
            at.map(|stage_mm| PressedPoint {
                stage_mm,
                error: in_spec_units(e, spec),
            })
        })
        .collect();
    RoundErrors {
        curve: CurvePoint {
            round,
            presses_before,
            fz_rmse_n: all.fz_rmse(),
            contact_rmse_mm: all.contact_rmse(),
            shape_accuracy: all.accuracy(),
            frames: all.n,
        },
        presses,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn sample(press: &str, at: [f64; 2]) -> Sample {
        Sample {
            image: PathBuf::from("f.png"),
            storage: None,
            force: [0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 3.0],
            shape: "pentagon".into(),
            contact: Some([0.0, 0.0]),
            shear: None,
            slip: None,
            press: press.into(),
            stage_mm: Some(at),
        }
    }

    fn scored(fz_err: f64, contact_err: f64) -> Scored {
        Scored {
            fz_true: 3.0,
            fz_pred: 3.0 + fz_err,
            shape_true: 1,
            shape_pred: 1,
            contact_true: Some([0.0, 0.0]),
            contact_pred: [contact_err, 0.0],
            shear_true: None,
            shear_pred: None,
            slip_true: None,
            slip_pred: None,
        }
    }

    #[test]
    fn each_press_is_scored_in_the_spec_units() {
        let samples = vec![
            sample("a", [10.0, 20.0]),
            sample("a", [10.0, 20.0]),
            sample("b", [14.0, 20.0]),
        ];
        let rows = vec![scored(0.49, 0.0), scored(0.49, 0.0), scored(0.0, 2.94)];
        let r = round_errors(2, 12, &samples, &rows, &Spec::paper());
        assert_eq!(r.presses.len(), 2);
        assert!((r.presses[0].error - 1.0).abs() < 1e-9, "{:?}", r.presses);
        assert!((r.presses[1].error - 2.0).abs() < 1e-9, "{:?}", r.presses);
        assert_eq!(r.presses[1].stage_mm, [14.0, 20.0]);
        assert_eq!(
            (r.curve.round, r.curve.presses_before, r.curve.frames),
            (2, 12, 3)
        );
        assert!((r.curve.fz_rmse_n - (2.0 * 0.49f64.powi(2) / 3.0).sqrt()).abs() < 1e-9);
    }
}
