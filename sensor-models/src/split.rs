//! The train / validation / test split, by physical indentation.
//!
//! Every frame of one press (a run's grid point, or one frame of a dataset that does not say
//! which frames share a press) lands on one side, and so does every augmented copy of it: the
//! split assigns presses, never frames. Presses are stratified by (shape, force level) so that
//! each side holds every shape and force level that has at least three presses. The split is
//! seeded (42 by default), written to `split.json` and read back on resume, so it can be
//! reproduced and inspected. (The reference code splits augmented copies at random, so rotated
//! copies and 50 Hz neighbours of a test frame are trained on.)

use crate::dataset::Sample;
use crate::eval::force_level;
use fringe_rig::reference_layout::NO_CONTACT;
use fringe_rig::seeded::{mix, SplitMix64};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The side of the split a press lands on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Side {
    Train,
    Val,
    Test,
}

impl Side {
    pub const ALL: [Side; 3] = [Side::Train, Side::Val, Side::Test];

    pub fn name(self) -> &'static str {
        match self {
            Side::Train => "train",
            Side::Val => "val",
            Side::Test => "test",
        }
    }
}

/// Seed and fractions of a split.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SplitSpec {
    pub seed: u64,
    /// Train, validation and test fractions (summing to 1).
    pub fractions: [f64; 3],
}

impl Default for SplitSpec {
    fn default() -> SplitSpec {
        SplitSpec {
            seed: 42,
            fractions: [0.8, 0.1, 0.1],
        }
    }
}

/// Why a split cannot be made or read.
#[derive(Debug, thiserror::Error)]
pub enum SplitError {
    #[error("split fractions {0:?} must be three non-negative numbers summing to 1 (the default is 0.8, 0.1, 0.1)")]
    Fractions([f64; 3]),
    #[error("no labelled frames to split")]
    Empty,
    #[error("{path}: {message}")]
    File { path: String, message: String },
}

/// Which side every press is on.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Split {
    pub spec: SplitSpec,
    /// What a press is ("run and grid point", or "frame" for datasets that do not say).
    pub by: String,
    pub train: BTreeSet<String>,
    pub val: BTreeSet<String>,
    pub test: BTreeSet<String>,
    /// Presses per stratum ("pentagon / force 3 N") and side: [train, val, test].
    pub strata: BTreeMap<String, [usize; 3]>,
}

/// The stratum of a press: the indenter shape of its frames in contact (or "None") and the
/// force level of its largest Fz.
fn stratum(frames: &[&Sample]) -> String {
    let shape = frames
        .iter()
        .map(|s| s.shape.as_str())
        .find(|s| *s != NO_CONTACT)
        .unwrap_or(NO_CONTACT);
    let fz = frames.iter().map(|s| s.fz()).fold(0.0, f64::max);
    format!("{shape} / {}", force_level(fz))
}

/// How many of `n` presses go to validation and test: the fractions rounded, at least one each
/// when there are three presses or more, so that every side sees the stratum.
fn counts(n: usize, fractions: [f64; 3]) -> [usize; 3] {
    let round = |f: f64| (n as f64 * f).round() as usize;
    let (mut val, mut test) = (round(fractions[1]), round(fractions[2]));
    if n >= 3 {
        val = val.max(usize::from(fractions[1] > 0.0));
        test = test.max(usize::from(fractions[2] > 0.0));
    } else {
        // Too few to share: training first, then the test side.
        val = 0;
        test = test.min(n.saturating_sub(1));
    }
    while val + test > n {
        if val >= test {
            val -= 1;
        } else {
            test -= 1;
        }
    }
    [n - val - test, val, test]
}

impl Split {
    /// Splits `samples` by press.
    pub fn new(samples: &[Sample], spec: SplitSpec) -> Result<Split, SplitError> {
        let f = spec.fractions;
        if f.iter().any(|v| !(v.is_finite() && *v >= 0.0))
            || (f.iter().sum::<f64>() - 1.0).abs() > 1e-6
        {
            return Err(SplitError::Fractions(f));
        }
        if samples.is_empty() {
            return Err(SplitError::Empty);
        }
        let mut presses: BTreeMap<&str, Vec<&Sample>> = BTreeMap::new();
        for s in samples {
            presses.entry(s.press.as_str()).or_default().push(s);
        }
        let mut strata: BTreeMap<String, Vec<&str>> = BTreeMap::new();
        for (press, frames) in &presses {
            strata.entry(stratum(frames)).or_default().push(press);
        }
        let by = if presses.len() == samples.len() {
            "frame (each frame its own press)"
        } else {
            "press (run and grid point)"
        };
        let mut split = Split {
            spec,
            by: by.to_string(),
            train: BTreeSet::new(),
            val: BTreeSet::new(),
            test: BTreeSet::new(),
            strata: BTreeMap::new(),
        };
        for (k, (name, mut members)) in strata.into_iter().enumerate() {
            // Members come sorted (BTreeMap order); one stream of the seed per stratum.
            SplitMix64::new(mix(spec.seed, k as u64)).shuffle(&mut members);
            let [train, val, _] = counts(members.len(), f);
            for (i, press) in members.iter().enumerate() {
                let side = if i < train {
                    &mut split.train
                } else if i < train + val {
                    &mut split.val
                } else {
                    &mut split.test
                };
                side.insert(press.to_string());
            }
            split.strata.insert(name, counts(members.len(), f));
        }
        Ok(split)
    }

    /// The side of `press`, when the split knows it.
    pub fn side_of(&self, press: &str) -> Option<Side> {
        if self.train.contains(press) {
            Some(Side::Train)
        } else if self.val.contains(press) {
            Some(Side::Val)
        } else if self.test.contains(press) {
            Some(Side::Test)
        } else {
            None
        }
    }

    /// Indices of `samples` on `side`.
    pub fn indices(&self, samples: &[Sample], side: Side) -> Vec<usize> {
        (0..samples.len())
            .filter(|&i| self.side_of(&samples[i].press) == Some(side))
            .collect()
    }

    /// Writes the split as JSON (through a temporary file renamed into place).
    pub fn save(&self, path: &Path) -> Result<(), SplitError> {
        let err = |message: String| SplitError::File {
            path: path.display().to_string(),
            message,
        };
        let text = serde_json::to_string_pretty(self).map_err(|e| err(e.to_string()))?;
        let temp = path.with_extension("json.tmp");
        std::fs::write(&temp, text + "\n")
            .and_then(|()| std::fs::rename(&temp, path))
            .map_err(|e| err(e.to_string()))
    }

    /// Reads a split written by [`Split::save`].
    pub fn load(path: &Path) -> Result<Split, SplitError> {
        let err = |message: String| SplitError::File {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
        serde_json::from_str(&text).map_err(|e| err(format!("not a split file: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::path::PathBuf;

    fn sample(press: &str, shape: &str, fz: f64) -> Sample {
        Sample {
            image: PathBuf::from(format!("{press}.png")),
            storage: None,
            force: [0.0, 0.0, fz, 0.0, 0.0, 0.0, fz],
            shape: shape.to_string(),
            contact: (shape != "None").then_some([1.0, 2.0]),
            shear: None,
            slip: None,
            press: press.to_string(),
            stage_mm: None,
        }
    }

    /// Presses of 1..6 frames (approach frames without contact, then pressed frames).
    fn dataset(presses: &[(u8, u8, u8)]) -> Vec<Sample> {
        let shapes = ["pentagon", "rectangle", "sphere"];
        let mut out = Vec::new();
        for (i, &(shape, force, frames)) in presses.iter().enumerate() {
            let press = format!("run#{i}");
            for k in 0..=frames {
                if k == 0 {
                    out.push(sample(&press, "None", 0.05));
                } else {
                    let fz = f64::from(force) * f64::from(k) / f64::from(frames);
                    let shape = if fz < 0.2 {
                        "None"
                    } else {
                        shapes[shape as usize % 3]
                    };
                    out.push(sample(&press, shape, fz));
                }
            }
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn no_press_lands_on_two_sides_and_every_side_sees_every_stratum(
            presses in prop::collection::vec((0u8..3, 1u8..9, 1u8..6), 1..120),
            seed in any::<u64>(),
        ) {
            let samples = dataset(&presses);
            let spec = SplitSpec { seed, ..SplitSpec::default() };
            let split = Split::new(&samples, spec).expect("split");
            // Every frame has a side, and all frames of a press share it.
            let mut side_of_press: BTreeMap<&str, Side> = BTreeMap::new();
            for s in &samples {
                let side = split.side_of(&s.press).expect("every press is assigned");
                let first = *side_of_press.entry(&s.press).or_insert(side);
                prop_assert_eq!(first, side, "press {} on two sides", s.press);
            }
            prop_assert!(split.train.is_disjoint(&split.val));
            prop_assert!(split.train.is_disjoint(&split.test));
            prop_assert!(split.val.is_disjoint(&split.test));
            let total = split.train.len() + split.val.len() + split.test.len();
            prop_assert_eq!(total, presses.len());
            // Strata of three presses or more are on every side.
            for (name, n) in &split.strata {
                if n.iter().sum::<usize>() >= 3 {
                    prop_assert!(n.iter().all(|&k| k > 0), "{name}: {n:?}");
                }
            }
            // Indices cover every frame once.
            let mut all: Vec<usize> = Side::ALL.iter().flat_map(|&s| split.indices(&samples, s)).collect();
            all.sort_unstable();
            prop_assert_eq!(all, (0..samples.len()).collect::<Vec<_>>());
            // The same seed gives the same split.
            prop_assert_eq!(&Split::new(&samples, spec).expect("split"), &split);
        }
    }

    #[test]
    fn fractions_hold_on_a_large_set_and_seeds_differ() {
        let presses: Vec<(u8, u8, u8)> = (0..1000)
            .map(|i| ((i % 2) as u8, (i % 8 + 1) as u8, 3))
            .collect();
        let samples = dataset(&presses);
        let a = Split::new(&samples, SplitSpec::default()).expect("split");
        assert!((780..=820).contains(&a.train.len()), "{}", a.train.len());
        assert!((90..=110).contains(&a.val.len()), "{}", a.val.len());
        assert!((90..=110).contains(&a.test.len()), "{}", a.test.len());
        let b = Split::new(
            &samples,
            SplitSpec {
                seed: 7,
                ..SplitSpec::default()
            },
        )
        .expect("split");
        assert_ne!(a.test, b.test);
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("split.json");
        a.save(&path).expect("save");
        assert_eq!(Split::load(&path).expect("load"), a);
    }

    #[test]
    fn bad_fractions_are_refused() {
        let samples = dataset(&[(0, 3, 2)]);
        let spec = SplitSpec {
            seed: 1,
            fractions: [0.9, 0.2, 0.1],
        };
        assert!(matches!(
            Split::new(&samples, spec),
            Err(SplitError::Fractions(_))
        ));
        assert!(matches!(
            Split::new(&[], SplitSpec::default()),
            Err(SplitError::Empty)
        ));
    }
}
