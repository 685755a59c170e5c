//! The model's errors over a set of evaluated frames, and by position: what a check compares
//! with the same positions of the acceptance scan.

use fringe_sensor_models::eval::Row;

/// Frames whose measured |Fz| is below this, N, count for neither the force gain nor the
/// contact error: at a touch the fringes barely show, so a frame's relative force error and its
/// contact point are noise, and the few such frames a press has would otherwise decide whether
/// the contact error grew.
pub(crate) const PRESSED_MIN_FZ_N: f64 = 1.0;
/// Two presses at positions closer than this, mm, are at the same position.
pub(crate) const SAME_POSITION_MM: f64 = 0.5;
/// Frames of a run the model is evaluated on at most: every k-th, spread evenly over its
/// presses (a press's neighbouring frames differ by little; a few hundred give the errors to a
/// few per cent).
pub(crate) const EVAL_FRAMES: usize = 300;

/// Every k-th of `items` so that at most `max` remain, the first one kept.
pub(crate) fn thinned<T>(items: Vec<T>, max: usize) -> Vec<T> {
    let step = items.len().div_ceil(max.max(1)).max(1);
    items.into_iter().step_by(step).collect()
}

/// The model's errors over some frames.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModelErrors {
    pub frames: usize,
    pub fz_rmse_n: f64,
    /// Over the frames in contact pressed at least `PRESSED_MIN_FZ_N`.
    pub contact_rmse_mm: f64,
    pub shape_accuracy: f64,
    /// Predicted over measured Fz, least squares through zero, over frames pressed at least
    /// `PRESSED_MIN_FZ_N`: a unit whose material changed reads a force too high or too low.
    pub force_gain: f64,
}

impl ModelErrors {
    /// The errors of `rows`; `None` without a pressed frame.
    pub fn of(rows: &[&Row]) -> Option<ModelErrors> {
        let pressed: Vec<&&Row> = rows
            .iter()
            .filter(|r| r.scored.fz_true >= PRESSED_MIN_FZ_N)
            .collect();
        if rows.is_empty() || pressed.is_empty() {
            return None;
        }
        let n = rows.len() as f64;
        let fz_rmse_n = (rows
            .iter()
            .map(|r| (r.scored.fz_pred - r.scored.fz_true).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        let contact: Vec<f64> = pressed
            .iter()
            .filter_map(|r| {
                let t = r.scored.contact_true?;
                let p = r.scored.contact_pred;
                Some((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2))
            })
            .collect();
        let contact_rmse_mm = if contact.is_empty() {
            0.0
        } else {
            (contact.iter().sum::<f64>() / contact.len() as f64).sqrt()
        };
        let correct = rows
            .iter()
            .filter(|r| r.scored.shape_pred == r.scored.shape_true)
            .count();
        let (sxy, sxx) = pressed.iter().fold((0.0, 0.0), |(sxy, sxx), r| {
            (
                sxy + r.scored.fz_pred * r.scored.fz_true,
                sxx + r.scored.fz_true * r.scored.fz_true,
            )
        });
        Some(ModelErrors {
            frames: rows.len(),
            fz_rmse_n,
            contact_rmse_mm,
            shape_accuracy: correct as f64 / n,
            force_gain: sxy / sxx,
        })
    }
}

/// A press at `stage_mm` (when known) was made at one of `positions` (within
/// [`SAME_POSITION_MM`]).
pub(crate) fn at_any(stage_mm: Option<[f64; 2]>, positions: &[[f64; 2]]) -> bool {
    stage_mm.is_some_and(|s| {
        positions
            .iter()
            .any(|p| (s[0] - p[0]).hypot(s[1] - p[1]) < SAME_POSITION_MM)
    })
}

/// The rows pressed at any of `positions`.
pub(crate) fn at_positions<'a>(rows: &'a [Row], positions: &[[f64; 2]]) -> Vec<&'a Row> {
    rows.iter()
        .filter(|r| at_any(r.stage_mm, positions))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_sensor_models::Scored;

    fn row(fz_true: f64, contact_true: [f64; 2], contact_pred: [f64; 2]) -> Row {
        Row {
            scored: Scored {
                fz_true,
                fz_pred: fz_true,
                shape_true: 1,
                shape_pred: 1,
                contact_true: Some(contact_true),
                contact_pred,
                shear_true: None,
                shear_pred: None,
                slip_true: None,
                slip_pred: None,
            },
            stage_mm: Some([10.0, 20.0]),
            press: "p".into(),
        }
    }

    #[test]
    fn the_contact_error_leaves_out_the_frames_of_a_touch() {
        // A press: frames at 1-4 N placed within 0.5 mm, and two frames at the first touch
        // (0.1 N) whose contact the model cannot see and puts 15 mm away.
        let mut rows: Vec<Row> = (0..40)
            .map(|k| row(1.0 + 3.0 * f64::from(k) / 39.0, [5.0, 5.0], [5.5, 5.0]))
            .collect();
        let pressed_only = ModelErrors::of(&rows.iter().collect::<Vec<_>>()).expect("errors");
        rows.push(row(0.1, [5.0, 5.0], [-10.0, 5.0]));
        rows.push(row(0.1, [5.0, 5.0], [5.0, -10.0]));
        let with_touch = ModelErrors::of(&rows.iter().collect::<Vec<_>>()).expect("errors");
        assert!((pressed_only.contact_rmse_mm - 0.5).abs() < 1e-9);
        assert_eq!(with_touch.contact_rmse_mm, pressed_only.contact_rmse_mm);
        // The frames still count for the force and the shape.
        assert_eq!(with_touch.frames, 42);
    }

    #[test]
    fn a_contact_error_at_pressed_frames_counts() {
        let rows: Vec<Row> = (0..10)
            .map(|k| row(2.0 + f64::from(k) * 0.1, [0.0, 0.0], [3.0, 4.0]))
            .collect();
        let e = ModelErrors::of(&rows.iter().collect::<Vec<_>>()).expect("errors");
        assert!((e.contact_rmse_mm - 5.0).abs() < 1e-9, "{e:?}");
    }
}
