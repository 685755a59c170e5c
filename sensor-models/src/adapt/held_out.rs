//! How a candidate adaptation does on presses it never saw, in one figure: the worst of Fz RMSE,
//! contact RMSE and shape error, each in units of the paper's custom-CNN row. The adaptations
//! that train more than the heads (the last block, full fine-tuning) are kept only when this
//! figure beats the heads alone on the same held-out presses.

use crate::acceptance::{PAPER_CONTACT_RMSE_MM, PAPER_FZ_RMSE_N, PAPER_SHAPE_ACCURACY};
use crate::metrics::Errors;

/// The spec's units: the paper's custom-CNN row.
pub(crate) const FZ_UNIT: f64 = PAPER_FZ_RMSE_N;
pub(crate) const CONTACT_UNIT: f64 = PAPER_CONTACT_RMSE_MM;
const SHAPE_UNIT: f64 = PAPER_SHAPE_ACCURACY;

/// Held-out figures of one candidate.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HeldOut {
    pub fz_rmse_n: f64,
    pub contact_rmse_mm: f64,
    pub shape_accuracy: f64,
    /// The worst of the three in the spec's units (1 = at the paper's row).
    pub spec_units: f64,
}

impl HeldOut {
    /// The figures of `e` (a contact error of 0 when no frame was in contact).
    pub fn of(e: &Errors) -> HeldOut {
        let (fz, contact, acc) = (e.fz_rmse(), e.contact_rmse(), e.accuracy());
        let contact_units = if e.n_contact > 0 {
            contact / CONTACT_UNIT
        } else {
            0.0
        };
        HeldOut {
            fz_rmse_n: fz,
            contact_rmse_mm: contact,
            shape_accuracy: acc,
            spec_units: (fz / FZ_UNIT)
                .max(contact_units)
                .max((1.0 - acc) / (1.0 - SHAPE_UNIT)),
        }
    }

    /// The three figures in words.
    pub fn describe(&self) -> String {
        format!(
            "Fz RMSE {:.3} N, contact RMSE {:.2} mm, shape accuracy {:.1} %",
            self.fz_rmse_n,
            self.contact_rmse_mm,
            100.0 * self.shape_accuracy
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::Scored;

    #[test]
    fn the_worst_figure_in_the_rows_units_decides() {
        let mut e = Errors::default();
        // Fz off by 0.98 N (2 units), contact off by 0.735 mm (0.5 unit), shape right.
        e.add(&Scored {
            fz_true: 5.0,
            fz_pred: 5.98,
            shape_true: 1,
            shape_pred: 1,
            contact_true: Some([0.0, 0.0]),
            contact_pred: [0.735, 0.0],
            shear_true: None,
            shear_pred: None,
            slip_true: None,
            slip_pred: None,
        });
        let h = HeldOut::of(&e);
        assert!((h.fz_rmse_n - 0.98).abs() < 1e-9);
        assert!((h.spec_units - 2.0).abs() < 1e-9, "{h:?}");
        assert!(h.describe().contains("0.980 N"), "{}", h.describe());
    }
}
