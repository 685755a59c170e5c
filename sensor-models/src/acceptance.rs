//! Acceptance of a model on a unit: an evaluation on held-out presses against a spec of the
//! Table-2 figures, with a verdict that says where it fails.
//!
//! A spec is TOML; every key is optional and a missing one is not checked:
//!
//! ```toml
//! fz_rmse_n = 0.49          # Fz RMSE at most, N
//! contact_rmse_mm = 1.47    # contact RMSE at most, mm (frames in contact)
//! shape_accuracy = 0.953    # shape accuracy at least, 0-1
//! macro_f1 = 0.9            # macro F1 at least, 0-1
//!
//! [[force_range]]           # the same keys over the frames whose measured |Fz| is in [from_n, to_n)
//! from_n = 0.0
//! to_n = 3.0
//! fz_rmse_n = 0.3
//! ```
//!
//! The default ([`Spec::paper`]) is the paper's custom-CNN row (Table 2, sensor 1): Fz RMSE under
//! 0.49 N, contact RMSE under 1.47 mm, shape accuracy over 95.3 %. Unknown keys and thresholds no
//! model can meet (an RMSE at or below 0, an accuracy above 1, an empty force range) are refused
//! naming the file and the key, and so is a spec that holds a model to nothing: one without a
//! threshold, or a force range without one (either would pass any model). A group of frames
//! with no frame in it fails its check (nothing shows the model meets it there).

use crate::eval::Evaluation;
use crate::metrics::{Errors, Metrics};
use std::path::Path;

/// Thresholds on the Table-2 figures (the keys of a spec file and of a force range).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct Thresholds {
    /// Fz RMSE at most, N.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fz_rmse_n: Option<f64>,
    /// Contact RMSE at most, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_rmse_mm: Option<f64>,
    /// Shape accuracy at least (0-1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shape_accuracy: Option<f64>,
    /// Macro F1 at least (0-1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub macro_f1: Option<f64>,
}

/// Thresholds over the frames whose measured |Fz| lies in `[from_n, to_n)`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ForceRange {
    pub from_n: f64,
    pub to_n: f64,
    pub thresholds: Thresholds,
}

/// What a unit must meet.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Spec {
    pub all: Thresholds,
    pub force_range: Vec<ForceRange>,
}

/// A spec file as written (serde's `flatten` cannot refuse unknown keys, so the keys are spelt
/// out here).
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    fz_rmse_n: Option<f64>,
    contact_rmse_mm: Option<f64>,
    shape_accuracy: Option<f64>,
    macro_f1: Option<f64>,
    #[serde(default)]
    force_range: Vec<ForceRangeFile>,
}

/// A `[[force_range]]` as written.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ForceRangeFile {
    from_n: f64,
    to_n: f64,
    fz_rmse_n: Option<f64>,
    contact_rmse_mm: Option<f64>,
    shape_accuracy: Option<f64>,
    macro_f1: Option<f64>,
}

/// A spec that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    #[error("cannot read the spec {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("spec {path}: {message}")]
    Parse { path: String, message: String },
    #[error("spec {path}: `{key}` = {value}: {why}")]
    Impossible {
        path: String,
        key: String,
        value: f64,
        why: &'static str,
    },
    #[error(
        "spec {path}: no threshold, so any model would pass it: add at least one of {KEYS} \
         (over all frames, or in a [[force_range]])"
    )]
    NoThreshold { path: String },
    #[error(
        "spec {path}: `force_range[{index}]` ({from_n}-{to_n} N) has no threshold, so it would \
         pass any model: add at least one of {KEYS} to it, or remove it"
    )]
    RangeWithoutThreshold {
        path: String,
        index: usize,
        from_n: f64,
        to_n: f64,
    },
}

/// The threshold keys, as an error lists them.
const KEYS: &str = "`fz_rmse_n`, `contact_rmse_mm`, `shape_accuracy`, `macro_f1`";

impl Thresholds {
    /// The thresholds in words, as a spec reads: `Fz < 0.49 N, contact < 1.47 mm, shape > 95.3 %`
    /// (the ones set only; `none` when none is).
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some(v) = self.fz_rmse_n {
            parts.push(format!("Fz < {v} N"));
        }
        if let Some(v) = self.contact_rmse_mm {
            parts.push(format!("contact < {v} mm"));
        }
        if let Some(v) = self.shape_accuracy {
            parts.push(format!("shape > {} %", percent(v)));
        }
        if let Some(v) = self.macro_f1 {
            parts.push(format!("macro F1 > {v}"));
        }
        if parts.is_empty() {
            "none".into()
        } else {
            parts.join(", ")
        }
    }

    /// No threshold is set.
    pub fn is_empty(&self) -> bool {
        self.fz_rmse_n.is_none()
            && self.contact_rmse_mm.is_none()
            && self.shape_accuracy.is_none()
            && self.macro_f1.is_none()
    }
}

/// A fraction as a percentage with no float noise (0.953 -> 95.3).
fn percent(v: f64) -> f64 {
    (v * 1e6).round() / 1e4
}

/// The paper's custom-CNN row (Table 2, sensor 1): Fz RMSE, N.
pub(crate) const PAPER_FZ_RMSE_N: f64 = 0.49;
/// The paper's custom-CNN row: contact RMSE, mm.
pub(crate) const PAPER_CONTACT_RMSE_MM: f64 = 1.47;
/// The paper's custom-CNN row: shape accuracy, 0-1.
pub(crate) const PAPER_SHAPE_ACCURACY: f64 = 0.953;

impl Spec {
    /// The paper's custom-CNN row (Table 2, sensor 1).
    pub fn paper() -> Spec {
        Spec {
            all: Thresholds {
                fz_rmse_n: Some(PAPER_FZ_RMSE_N),
                contact_rmse_mm: Some(PAPER_CONTACT_RMSE_MM),
                shape_accuracy: Some(PAPER_SHAPE_ACCURACY),
                macro_f1: None,
            },
            force_range: Vec::new(),
        }
    }

    /// Reads and checks a spec file.
    pub fn load(path: &Path) -> Result<Spec, SpecError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| SpecError::Read {
            path: shown.clone(),
            source,
        })?;
        Spec::parse(&text, &shown)
    }

    /// Parses and checks a spec; `name` names it in errors.
    pub fn parse(text: &str, name: &str) -> Result<Spec, SpecError> {
        let file: SpecFile = toml::from_str(text).map_err(|e| SpecError::Parse {
            path: name.to_string(),
            message: e.message().to_string(),
        })?;
        let spec = Spec {
            all: Thresholds {
                fz_rmse_n: file.fz_rmse_n,
                contact_rmse_mm: file.contact_rmse_mm,
                shape_accuracy: file.shape_accuracy,
                macro_f1: file.macro_f1,
            },
            force_range: file
                .force_range
                .into_iter()
                .map(|r| ForceRange {
                    from_n: r.from_n,
                    to_n: r.to_n,
                    thresholds: Thresholds {
                        fz_rmse_n: r.fz_rmse_n,
                        contact_rmse_mm: r.contact_rmse_mm,
                        shape_accuracy: r.shape_accuracy,
                        macro_f1: r.macro_f1,
                    },
                })
                .collect(),
        };
        spec.check(name)?;
        Ok(spec)
    }

    /// Refuses thresholds no model can meet.
    fn check(&self, name: &str) -> Result<(), SpecError> {
        let bad = |key: String, value: f64, why| SpecError::Impossible {
            path: name.to_string(),
            key,
            value,
            why,
        };
        let check = |t: &Thresholds, at: &str| -> Result<(), SpecError> {
            for (key, v) in [
                ("fz_rmse_n", t.fz_rmse_n),
                ("contact_rmse_mm", t.contact_rmse_mm),
            ] {
                if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
                    return Err(bad(
                        format!("{at}{key}"),
                        v,
                        "an error limit must be above 0",
                    ));
                }
            }
            for (key, v) in [
                ("shape_accuracy", t.shape_accuracy),
                ("macro_f1", t.macro_f1),
            ] {
                if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0 && *v <= 1.0)) {
                    return Err(bad(
                        format!("{at}{key}"),
                        v,
                        "must be above 0 and at most 1",
                    ));
                }
            }
            Ok(())
        };
        check(&self.all, "")?;
        for (i, r) in self.force_range.iter().enumerate() {
            let at = format!("force_range[{i}].");
            if !(r.from_n.is_finite() && r.from_n >= 0.0) {
                return Err(bad(format!("{at}from_n"), r.from_n, "must be 0 N or more"));
            }
            if !(r.to_n.is_finite() && r.to_n > r.from_n) {
                return Err(bad(format!("{at}to_n"), r.to_n, "must be above from_n"));
            }
            check(&r.thresholds, &at)?;
            if r.thresholds.is_empty() {
                return Err(SpecError::RangeWithoutThreshold {
                    path: name.to_string(),
                    index: i,
                    from_n: r.from_n,
                    to_n: r.to_n,
                });
            }
        }
        if self.all.is_empty() && self.force_range.is_empty() {
            return Err(SpecError::NoThreshold {
                path: name.to_string(),
            });
        }
        Ok(())
    }
}

/// One figure against its threshold.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Check {
    /// Where: "all frames", "force 0-3 N", ...
    pub over: String,
    /// Which figure: the spec's key.
    pub figure: &'static str,
    pub value: f64,
    pub limit: f64,
    /// `true` when the value must be at most the limit (errors), else at least (accuracies).
    pub at_most: bool,
    pub frames: u64,
    pub pass: bool,
}

impl Check {
    /// The check in words: `fz_rmse_n over all frames: 0.4100 (at most 0.4900, 812 frames)`, or
    /// `... : no frames (at most 0.4900)` when the group held none (it fails: nothing shows the
    /// model meets the threshold there).
    pub fn describe(&self) -> String {
        let rule = if self.at_most { "at most" } else { "at least" };
        if self.frames == 0 {
            let which = if self.figure == "contact_rmse_mm" {
                "no frames in contact"
            } else {
                "no frames"
            };
            return format!(
                "{} over {}: {which} ({rule} {:.4})",
                self.figure, self.over, self.limit
            );
        }
        format!(
            "{} over {}: {:.4} ({rule} {:.4}, {} frames)",
            self.figure, self.over, self.value, self.limit, self.frames
        )
    }
}

/// A group of frames (a grid cell, a force level, a shape) that misses a threshold the whole
/// set is held to: where to look when the verdict is fail.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Weak {
    pub group: String,
    pub figure: &'static str,
    pub value: f64,
    pub limit: f64,
    pub frames: u64,
}

/// The outcome of an acceptance.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Verdict {
    pub pass: bool,
    pub checks: Vec<Check>,
    /// Groups that miss a whole-set threshold, worst first.
    pub weak: Vec<Weak>,
}

impl Verdict {
    /// The checks that failed, one line each.
    pub fn failures(&self) -> Vec<String> {
        self.checks
            .iter()
            .filter(|c| !c.pass)
            .map(Check::describe)
            .collect()
    }
}

/// The figures of `errors` and the macro F1 `f1` against `t` (an empty group fails).
fn checks(over: &str, t: &Thresholds, errors: &Errors, f1: Option<f64>, out: &mut Vec<Check>) {
    let mut add = |figure, value: f64, limit: Option<f64>, at_most: bool, frames: u64| {
        if let Some(limit) = limit {
            let pass = frames > 0
                && value.is_finite()
                && if at_most {
                    value <= limit
                } else {
                    value >= limit
                };
            out.push(Check {
                over: over.to_string(),
                figure,
                value,
                limit,
                at_most,
                frames,
                pass,
            });
        }
    };
    add("fz_rmse_n", errors.fz_rmse(), t.fz_rmse_n, true, errors.n);
    add(
        "contact_rmse_mm",
        errors.contact_rmse(),
        t.contact_rmse_mm,
        true,
        errors.n_contact,
    );
    add(
        "shape_accuracy",
        errors.accuracy(),
        t.shape_accuracy,
        false,
        errors.n,
    );
    if let Some(f1) = f1 {
        add("macro_f1", f1, t.macro_f1, false, errors.n);
    }
}

/// The groups of the evaluation's breakdown (grid cells, force levels) and the shapes whose
/// figures miss the whole set's thresholds.
fn weak_groups(metrics: &Metrics, t: &Thresholds) -> Vec<Weak> {
    let mut weak = Vec::new();
    for (group, e) in &metrics.by_key {
        if let Some(limit) = t.fz_rmse_n.filter(|l| e.fz_rmse() > *l) {
            weak.push((
                e.fz_rmse() / limit,
                group.clone(),
                "fz_rmse_n",
                e.fz_rmse(),
                limit,
                e.n,
            ));
        }
        if let Some(limit) = t.contact_rmse_mm.filter(|l| e.contact_rmse() > *l) {
            let v = e.contact_rmse();
            weak.push((
                v / limit,
                group.clone(),
                "contact_rmse_mm",
                v,
                limit,
                e.n_contact,
            ));
        }
    }
    if let Some(limit) = t.shape_accuracy {
        for (c, row) in metrics.confusion.iter().enumerate() {
            let n: u64 = row.iter().sum();
            let recall = row[c] as f64 / n.max(1) as f64;
            if n > 0 && recall < limit {
                let group = format!("shape {}", metrics.classes[c]);
                weak.push((
                    limit / recall.max(1e-9),
                    group,
                    "shape_accuracy",
                    recall,
                    limit,
                    n,
                ));
            }
        }
    }
    weak.sort_by(|a, b| b.0.total_cmp(&a.0));
    weak.into_iter()
        .map(|(_, group, figure, value, limit, frames)| Weak {
            group,
            figure,
            value,
            limit,
            frames,
        })
        .collect()
}

/// `eval` against `spec`.
pub fn judge(eval: &Evaluation, spec: &Spec) -> Verdict {
    let m = &eval.metrics;
    let mut all = Vec::new();
    checks(
        "all frames",
        &spec.all,
        &m.all,
        Some(m.macro_scores().f1),
        &mut all,
    );
    for r in &spec.force_range {
        let mut range = Metrics::new(m.classes.clone());
        for row in eval
            .rows
            .iter()
            .filter(|row| row.scored.fz_true >= r.from_n && row.scored.fz_true < r.to_n)
        {
            range.add(&row.scored, &[]);
        }
        let over = format!("force {}-{} N", r.from_n, r.to_n);
        let f1 = range.macro_scores().f1;
        checks(&over, &r.thresholds, &range.all, Some(f1), &mut all);
    }
    Verdict {
        pass: all.iter().all(|c| c.pass),
        weak: weak_groups(m, &spec.all),
        checks: all,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::Row;
    use crate::metrics::Scored;

    #[test]
    fn thresholds_read_in_words_as_set() {
        assert_eq!(
            Spec::paper().all.describe(),
            "Fz < 0.49 N, contact < 1.47 mm, shape > 95.3 %"
        );
        let spec = Spec::parse("contact_rmse_mm = 0.8\nmacro_f1 = 0.9\n", "t.toml").expect("spec");
        assert_eq!(spec.all.describe(), "contact < 0.8 mm, macro F1 > 0.9");
        assert_eq!(Thresholds::default().describe(), "none");
    }

    fn evaluation(rows: &[(f64, f64, usize, usize, f64)]) -> Evaluation {
        let classes: Vec<String> = ["None", "pentagon", "rectangle"].map(String::from).to_vec();
        let mut metrics = Metrics::new(classes);
        let mut out = Vec::new();
        for &(fz_true, fz_pred, shape_true, shape_pred, dx) in rows {
            let scored = Scored {
                fz_true,
                fz_pred,
                shape_true,
                shape_pred,
                contact_true: (shape_true > 0).then_some([0.0, 0.0]),
                contact_pred: [dx, 0.0],
                shear_true: None,
                shear_pred: None,
                slip_true: None,
                slip_pred: None,
            };
            metrics.add(&scored, &[crate::eval::force_level(fz_true)]);
            out.push(Row {
                scored,
                stage_mm: None,
                press: "p".into(),
            });
        }
        Evaluation {
            metrics,
            rows: out,
            skipped: 0,
            skipped_busy: 0,
            labels_know_shear: false,
        }
    }

    #[test]
    fn the_paper_row_passes_a_good_model_and_names_where_a_bad_one_fails() {
        let good = evaluation(&[
            (0.0, 0.1, 0, 0, 0.0),
            (2.0, 2.2, 1, 1, 0.5),
            (6.0, 5.7, 2, 2, -1.0),
            (8.0, 8.3, 1, 1, 1.0),
        ]);
        let v = judge(&good, &Spec::paper());
        assert!(v.pass, "{:?}", v.failures());
        assert_eq!(v.checks.len(), 3);

        // Right everywhere but at 8 N, where it reads 6 N and the wrong shape.
        let bad = evaluation(&[
            (0.0, 0.1, 0, 0, 0.0),
            (2.0, 2.2, 1, 1, 0.5),
            (2.1, 2.0, 2, 2, 0.5),
            (8.0, 6.0, 1, 2, 0.5),
        ]);
        let v = judge(&bad, &Spec::paper());
        assert!(!v.pass);
        let failures = v.failures();
        assert!(
            failures
                .iter()
                .any(|f| f.starts_with("fz_rmse_n over all frames")),
            "{failures:?}"
        );
        assert!(
            failures.iter().any(|f| f.starts_with("shape_accuracy")),
            "{failures:?}"
        );
        assert_eq!(v.weak[0].group, "force 8 N", "{:?}", v.weak);
        assert!(
            v.weak.iter().any(|w| w.group == "shape pentagon"),
            "{:?}",
            v.weak
        );
        assert!(
            !v.weak.iter().any(|w| w.group == "force 2 N"),
            "{:?}",
            v.weak
        );
    }

    #[test]
    fn force_ranges_are_judged_on_their_own_frames() {
        let spec = Spec::parse(
            "[[force_range]]\nfrom_n = 5.0\nto_n = 10.0\nfz_rmse_n = 0.5\n",
            "s.toml",
        )
        .expect("valid");
        let e = evaluation(&[(2.0, 4.0, 1, 1, 0.0), (8.0, 8.1, 1, 1, 0.0)]);
        let v = judge(&e, &spec);
        assert!(v.pass, "{:?}", v.failures());
        assert_eq!(v.checks.len(), 1);
        assert_eq!(v.checks[0].frames, 1);
        assert_eq!(v.checks[0].over, "force 5-10 N");
    }

    #[test]
    fn unknown_keys_and_impossible_thresholds_are_refused_naming_the_key() {
        let e = Spec::parse("fz_rmse = 0.4\n", "s.toml").expect_err("unknown key");
        let t = e.to_string();
        assert!(
            t.starts_with("spec s.toml:") && t.contains("fz_rmse"),
            "{t}"
        );
        for (text, key) in [
            ("fz_rmse_n = 0.0\n", "`fz_rmse_n` = 0"),
            ("shape_accuracy = 95.3\n", "`shape_accuracy` = 95.3"),
            ("contact_rmse_mm = -1\n", "`contact_rmse_mm` = -1"),
            (
                "[[force_range]]\nfrom_n = 4.0\nto_n = 2.0\n",
                "`force_range[0].to_n` = 2",
            ),
            (
                "[[force_range]]\nfrom_n = 0.0\nto_n = 2.0\nmacro_f1 = 1.5\n",
                "`force_range[0].macro_f1` = 1.5",
            ),
        ] {
            let e = Spec::parse(text, "s.toml").expect_err(text).to_string();
            assert!(e.contains(key), "{text}: {e}");
        }
    }

    #[test]
    fn a_spec_that_holds_a_model_to_nothing_is_refused_naming_the_file_and_what_to_add() {
        // An empty spec would pass any model.
        for text in ["", "# nothing yet\n"] {
            let e = Spec::parse(text, "empty.toml").expect_err(text).to_string();
            assert!(
                e.starts_with("spec empty.toml: no threshold")
                    && e.contains("`fz_rmse_n`")
                    && e.contains("`shape_accuracy`"),
                "{e}"
            );
        }
        // So would a force range without a threshold, even beside thresholds of its own.
        let e = Spec::parse(
            "fz_rmse_n = 0.5\n[[force_range]]\nfrom_n = 0.0\nto_n = 3.0\n",
            "r.toml",
        )
        .expect_err("range without threshold")
        .to_string();
        assert!(
            e.starts_with("spec r.toml: `force_range[0]` (0-3 N) has no threshold")
                && e.contains("`contact_rmse_mm`"),
            "{e}"
        );
        // A spec of force ranges alone holds the model to them.
        let only_ranges = Spec::parse(
            "[[force_range]]\nfrom_n = 0.0\nto_n = 3.0\nfz_rmse_n = 0.3\n",
            "s.toml",
        )
        .expect("ranges alone");
        assert!(only_ranges.all.is_empty());
    }

    #[test]
    fn a_range_without_frames_fails_saying_so_not_nan() {
        let spec = Spec::parse(
            "fz_rmse_n = 5.0\n[[force_range]]\nfrom_n = 20.0\nto_n = 30.0\nfz_rmse_n = 0.5\ncontact_rmse_mm = 1.0\nshape_accuracy = 0.5\n",
            "s.toml",
        )
        .expect("valid");
        // A perfect model, but no frame in 20-30 N: nothing shows it meets the range.
        let e = evaluation(&[(2.0, 2.0, 1, 1, 0.0), (8.0, 8.0, 1, 1, 0.0)]);
        let v = judge(&e, &spec);
        assert!(!v.pass, "{v:?}");
        let failures = v.failures();
        assert_eq!(failures.len(), 3, "{failures:?}");
        assert_eq!(
            failures[0],
            "fz_rmse_n over force 20-30 N: no frames (at most 0.5000)"
        );
        assert_eq!(
            failures[1],
            "contact_rmse_mm over force 20-30 N: no frames in contact (at most 1.0000)"
        );
        assert!(failures.iter().all(|f| !f.contains("NaN")), "{failures:?}");
        // Frames, none in contact: the contact check fails saying so; the others are judged.
        let no_contact = evaluation(&[(25.0, 25.0, 0, 0, 0.0), (8.0, 8.0, 1, 1, 0.0)]);
        let v = judge(&no_contact, &spec);
        assert_eq!(
            v.failures(),
            ["contact_rmse_mm over force 20-30 N: no frames in contact (at most 1.0000)"]
        );
    }
}
