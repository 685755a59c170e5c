//! The paper's Table-2 metrics, one implementation for evaluation, training and live
//! validation: Fz MSE and RMSE (N), contact RMSE (mm, sqrt of the mean squared distance over
//! rows whose label is in contact), shape accuracy, macro precision / recall / F1 (over the
//! classes present in the labels or the predictions, a class never predicted counting 0
//! precision), the confusion matrix; and the same errors broken down by a key (grid cell, force
//! level).

use std::collections::BTreeMap;

/// One prediction against its label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scored {
    /// Measured |Fz|, N.
    pub fz_true: f64,
    pub fz_pred: f64,
    /// Shape class indices ("None" = 0).
    pub shape_true: usize,
    pub shape_pred: usize,
    /// Labelled contact, mm (None without contact).
    pub contact_true: Option<[f64; 2]>,
    /// The contact head's output, mm.
    pub contact_pred: [f64; 2],
    /// The signed shear, labelled (where the data knows it) and predicted (by a model with
    /// shear heads), x and y in the sensor's frame, N.
    pub shear_true: Option<[f64; 2]>,
    pub shear_pred: Option<[f64; 2]>,
    /// How the contact held, labelled and reported (by a model with a slip head, over the
    /// frames of the press up to this one).
    pub slip_true: Option<fringe_rig::Slip>,
    pub slip_pred: Option<fringe_rig::Slip>,
}

/// Running sums of the errors.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Errors {
    pub n: u64,
    pub sum_sq_fz: f64,
    pub n_contact: u64,
    pub sum_sq_contact: f64,
    pub correct: u64,
    /// Rows whose shear was scored, and the sums of squared errors of its x and y.
    pub n_shear: u64,
    pub sum_sq_shear: [f64; 2],
}

impl Errors {
    pub fn add(&mut self, s: &Scored) {
        self.n += 1;
        self.sum_sq_fz += (s.fz_pred - s.fz_true).powi(2);
        if let Some([x, y]) = s.contact_true {
            self.n_contact += 1;
            self.sum_sq_contact +=
                (s.contact_pred[0] - x).powi(2) + (s.contact_pred[1] - y).powi(2);
        }
        self.correct += u64::from(s.shape_pred == s.shape_true);
        if let (Some(t), Some(p)) = (s.shear_true, s.shear_pred) {
            self.n_shear += 1;
            for k in 0..2 {
                self.sum_sq_shear[k] += (p[k] - t[k]).powi(2);
            }
        }
    }

    /// Shear RMSE along x and y, N, over the rows whose shear was scored (`None` when none
    /// was).
    pub fn shear_rmse(&self) -> Option<[f64; 2]> {
        (self.n_shear > 0).then(|| self.sum_sq_shear.map(|s| (s / self.n_shear as f64).sqrt()))
    }

    /// Fz mean squared error, N^2 (NaN before any row).
    pub fn fz_mse(&self) -> f64 {
        self.sum_sq_fz / self.n as f64
    }

    pub fn fz_rmse(&self) -> f64 {
        self.fz_mse().sqrt()
    }

    /// Contact RMSE over rows in contact, mm (NaN when none was).
    pub fn contact_rmse(&self) -> f64 {
        (self.sum_sq_contact / self.n_contact as f64).sqrt()
    }

    pub fn accuracy(&self) -> f64 {
        self.correct as f64 / self.n as f64
    }
}

/// Macro-averaged classification figures.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MacroScores {
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

/// Everything Table 2 reports, plus breakdowns.
#[derive(Debug, Clone, PartialEq)]
pub struct Metrics {
    pub classes: Vec<String>,
    pub all: Errors,
    /// confusion[true][predicted].
    pub confusion: Vec<Vec<u64>>,
    /// Errors by a caller's key (e.g. "x 5.0 y 0.0 mm" or "4 N").
    pub by_key: BTreeMap<String, Errors>,
}

impl Metrics {
    pub fn new(classes: Vec<String>) -> Metrics {
        let n = classes.len();
        Metrics {
            classes,
            all: Errors::default(),
            confusion: vec![vec![0; n]; n],
            by_key: BTreeMap::new(),
        }
    }

    /// Adds one row, under the breakdown `keys`.
    pub fn add(&mut self, s: &Scored, keys: &[String]) {
        self.all.add(s);
        let n = self.classes.len();
        if s.shape_true < n && s.shape_pred < n {
            self.confusion[s.shape_true][s.shape_pred] += 1;
        }
        for k in keys {
            self.by_key.entry(k.clone()).or_default().add(s);
        }
    }

    /// Macro precision, recall and F1 over the classes present in labels or predictions.
    pub fn macro_scores(&self) -> MacroScores {
        let n = self.classes.len();
        let (mut p, mut r, mut f, mut k) = (0.0, 0.0, 0.0, 0.0);
        for c in 0..n {
            let tp = self.confusion[c][c] as f64;
            let labelled: f64 = self.confusion[c].iter().sum::<u64>() as f64;
            let predicted: f64 = self.confusion.iter().map(|row| row[c]).sum::<u64>() as f64;
            if labelled == 0.0 && predicted == 0.0 {
                continue;
            }
            let prec = if predicted > 0.0 { tp / predicted } else { 0.0 };
            let rec = if labelled > 0.0 { tp / labelled } else { 0.0 };
            let f1 = if prec + rec > 0.0 {
                2.0 * prec * rec / (prec + rec)
            } else {
                0.0
            };
            p += prec;
            r += rec;
            f += f1;
            k += 1.0;
        }
        MacroScores {
            precision: p / k,
            recall: r / k,
            f1: f / k,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(fz: (f64, f64), shape: (usize, usize), contact: Option<[f64; 2]>) -> Scored {
        Scored {
            fz_true: fz.0,
            fz_pred: fz.1,
            shape_true: shape.0,
            shape_pred: shape.1,
            contact_true: contact,
            contact_pred: [1.0, 1.0],
            shear_true: None,
            shear_pred: None,
            slip_true: None,
            slip_pred: None,
        }
    }

    #[test]
    fn table_two_figures_by_hand() {
        let mut m = Metrics::new(vec!["None".into(), "pentagon".into(), "rectangle".into()]);
        m.add(&row((0.0, 0.1), (0, 0), None), &["a".into()]);
        m.add(&row((2.0, 2.3), (1, 1), Some([1.0, 4.0])), &["a".into()]);
        m.add(&row((4.0, 3.6), (2, 1), Some([4.0, 5.0])), &["b".into()]);
        m.add(&row((4.0, 4.0), (2, 2), Some([1.0, 1.0])), &["b".into()]);
        assert!((m.all.fz_mse() - (0.01 + 0.09 + 0.16) / 4.0).abs() < 1e-12);
        // Contact over the three rows in contact: 3^2, 3^2 + 4^2, 0.
        assert!((m.all.contact_rmse() - ((9.0 + 25.0) / 3.0f64).sqrt()).abs() < 1e-12);
        assert_eq!(m.all.accuracy(), 0.75);
        // Precision: None 1, pentagon 1/2, rectangle 1; recall: 1, 1, 1/2.
        let s = m.macro_scores();
        assert!((s.precision - 2.5 / 3.0).abs() < 1e-12);
        assert!((s.recall - 2.5 / 3.0).abs() < 1e-12);
        let f1 = (1.0 + 2.0 * 0.5 / 1.5 + 2.0 * 0.5 / 1.5) / 3.0;
        assert!((s.f1 - f1).abs() < 1e-12);
        assert_eq!(m.confusion[2][1], 1);
        assert_eq!(m.by_key["b"].n, 2);
        assert!((m.by_key["b"].fz_rmse() - (0.16f64 / 2.0).sqrt()).abs() < 1e-12);
    }
}
