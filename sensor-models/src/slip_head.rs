//! The slip head: stick, partial slip or gross slip from the network's outputs on a frame and
//! the two before it (the paper's "temporal information"). The network reads the signed shear,
//! the normal force and the contact of each frame; the slip head is a small network (one hidden
//! layer of 16 units) over features of three frames' readings (how hard the push is against the normal
//! force, whether it still grows, how the contact moves), fitted after the network on runs'
//! slip labels ([`fringe_rig::slip_labels`]). A model carries it in its card (`slip`).
//!
//! Gross slip is reported once the head has said it on [`SlipHead::confirm_frames`] frames in a
//! row, and left once it has not on as many: its onsets are events a gripper acts on, and a
//! single noisy frame must not make one. [`onsets`] scores the reported onsets against the
//! labels' within a tolerance of frames.

use crate::metrics::Scored;
use fringe_rig::Slip;
use std::collections::VecDeque;

/// Frames the head reads: the current one and the two before it.
pub(crate) const SLIP_FRAMES: usize = 3;

/// The features' names, in order: a card whose head names others is refused.
pub(crate) const FEATURES: [&str; 9] = [
    "shear_n",
    "fz_n",
    "push_ratio",
    "push_ratio_squared",
    "shear_growth_1_n",
    "shear_growth_2_n",
    "fz_change_2_n",
    "contact_travel_2_mm",
    "push_ratio_times_growth",
];

/// The normal force added under the push ratio's divisor, N: a frame at rest (no normal force)
/// has no ratio to speak of.
const RATIO_FLOOR_N: f64 = 0.2;

/// One frame's readings the head uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub fz: f64,
    pub shear: [f64; 2],
    pub contact: [f64; 2],
}

impl Reading {
    /// The readings of a prediction: `None` without contact or without shear heads.
    pub fn of_prediction(p: &crate::prediction::Prediction) -> Option<Reading> {
        let contact = p.contact?;
        let shear = p.shear?;
        Some(Reading {
            fz: p.force.fz.value(),
            shear: shear.map(|v| v.value()),
            contact: contact.map(|v| v.value()),
        })
    }

    /// The readings of a scored row: its predicted force, shear and contact (`None` where the
    /// shape head said no contact, or without a predicted shear).
    pub fn of(s: &Scored) -> Option<Reading> {
        if s.shape_pred == 0 {
            return None;
        }
        Some(Reading {
            fz: s.fz_pred,
            shear: s.shear_pred?,
            contact: s.contact_pred,
        })
    }
}

/// The features of the newest frame of `w` (oldest first, [`SLIP_FRAMES`] readings).
fn features(w: &[Reading; SLIP_FRAMES]) -> [f64; FEATURES.len()] {
    let [a, b, c] = w;
    let norm = |v: [f64; 2]| v[0].hypot(v[1]);
    let q = norm(c.shear);
    let dir = if q > 1e-9 {
        [c.shear[0] / q, c.shear[1] / q]
    } else {
        [0.0, 0.0]
    };
    // The push's growth along its own direction.
    let growth =
        |r: &Reading| (c.shear[0] - r.shear[0]) * dir[0] + (c.shear[1] - r.shear[1]) * dir[1];
    let ratio = q / (c.fz.max(0.0) + RATIO_FLOOR_N);
    let g2 = growth(a);
    [
        q,
        c.fz,
        ratio,
        ratio * ratio,
        growth(b),
        g2,
        c.fz - a.fz,
        norm([c.contact[0] - a.contact[0], c.contact[1] - a.contact[1]]),
        ratio * g2,
    ]
}

/// Hidden units of the slip head's one hidden layer.
const HIDDEN: usize = 16;

/// A fitted slip head: the standardised features through one hidden layer (tanh) to a score per
/// state.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SlipHead {
    /// The features it reads ([`FEATURES`]).
    pub features: Vec<String>,
    /// Each feature's mean and scale over the fitting data (the inputs are standardised).
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    /// The hidden layer: a row of weights per unit (one per feature) and a bias per unit.
    pub hidden_weights: Vec<Vec<f64>>,
    pub hidden_bias: Vec<f64>,
    /// The output layer: a row of weights per state (one per hidden unit), in [`Slip::ALL`]'s
    /// order, and a bias per state.
    pub weights: Vec<Vec<f64>>,
    pub bias: Vec<f64>,
    /// Frames in a row that gross slip must be said on before it is reported (and not said on
    /// before it is left).
    pub confirm_frames: usize,
}

/// Why a card's slip head cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SlipHeadError {
    #[error(
        "it reads the features {found}, and this fringe computes {ours}: fit it again \
         (`fringe model slip`)"
    )]
    Features { found: String, ours: String },
    #[error("its {what} has {got} numbers where {want} belong")]
    Shape {
        what: &'static str,
        got: usize,
        want: usize,
    },
    #[error("its {0} holds a number that is not finite")]
    NotFinite(&'static str),
    #[error("confirm_frames is {0}: it is 1 to 10")]
    Confirm(usize),
}

impl SlipHead {
    /// Refuses a head this fringe cannot run as it was fitted.
    pub fn check(&self) -> Result<(), SlipHeadError> {
        if self.features.iter().map(String::as_str).ne(FEATURES) {
            return Err(SlipHeadError::Features {
                found: self.features.join(", "),
                ours: FEATURES.join(", "),
            });
        }
        let n = FEATURES.len();
        let k = Slip::ALL.len();
        let h = self.hidden_bias.len();
        let sizes = [
            ("mean", self.mean.len(), n),
            ("scale", self.scale.len(), n),
            ("hidden_weights", self.hidden_weights.len(), h),
            ("bias", self.bias.len(), k),
            ("weights", self.weights.len(), k),
        ];
        for (what, got, want) in sizes {
            if got != want {
                return Err(SlipHeadError::Shape { what, got, want });
            }
        }
        let rows = [
            ("hidden_weights row", &self.hidden_weights, n),
            ("weights row", &self.weights, h),
        ];
        for (what, m, want) in rows {
            for row in m.iter() {
                if row.len() != want {
                    return Err(SlipHeadError::Shape {
                        what,
                        got: row.len(),
                        want,
                    });
                }
            }
        }
        if self.hidden_weights.iter().flatten().any(|x| !x.is_finite()) {
            return Err(SlipHeadError::NotFinite("hidden_weights"));
        }
        let all = [
            ("mean", self.mean.as_slice()),
            ("scale", self.scale.as_slice()),
            ("hidden_bias", self.hidden_bias.as_slice()),
            ("bias", self.bias.as_slice()),
        ];
        for (what, v) in all {
            if v.iter().any(|x| !x.is_finite()) {
                return Err(SlipHeadError::NotFinite(what));
            }
        }
        if self.scale.iter().any(|&s| s <= 0.0) {
            return Err(SlipHeadError::NotFinite("scale"));
        }
        if self.weights.iter().flatten().any(|x| !x.is_finite()) {
            return Err(SlipHeadError::NotFinite("weights"));
        }
        if !(1..=10).contains(&self.confirm_frames) {
            return Err(SlipHeadError::Confirm(self.confirm_frames));
        }
        Ok(())
    }

    /// The state the head finds most probable for the newest frame of `w`.
    fn classify(&self, w: &[Reading; SLIP_FRAMES]) -> Slip {
        let x = standardised(&features(w), &self.mean, &self.scale);
        let hidden = layer(&self.hidden_weights, &self.hidden_bias, &x, true);
        argmax(&layer(&self.weights, &self.bias, &hidden, false))
    }
}

fn standardised(f: &[f64], mean: &[f64], scale: &[f64]) -> Vec<f64> {
    f.iter()
        .zip(mean.iter().zip(scale))
        .map(|(v, (m, s))| (v - m) / s)
        .collect()
}

/// One layer: `weights` (a row per output) times `x` plus `bias`, through tanh when `tanh`.
fn layer(weights: &[Vec<f64>], bias: &[f64], x: &[f64], tanh: bool) -> Vec<f64> {
    weights
        .iter()
        .zip(bias)
        .map(|(w, b)| {
            let v = b + w.iter().zip(x).map(|(a, v)| a * v).sum::<f64>();
            if tanh {
                v.tanh()
            } else {
                v
            }
        })
        .collect()
}

fn argmax(v: &[f64]) -> Slip {
    let k = v
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(i, _)| i);
    Slip::ALL[k.min(Slip::ALL.len() - 1)]
}

/// The slip head run over a sequence of frames (one press, or a live stream): it keeps the
/// readings of the frames before and whether gross slip is being reported.
#[derive(Debug, Clone)]
pub struct SlipTracker {
    head: SlipHead,
    history: VecDeque<Reading>,
    gross: bool,
    /// Frames in a row the head has said the opposite of what is reported.
    against: usize,
}

impl SlipTracker {
    pub fn new(head: SlipHead) -> SlipTracker {
        SlipTracker {
            head,
            history: VecDeque::with_capacity(SLIP_FRAMES),
            gross: false,
            against: 0,
        }
    }

    /// Forgets the frames before (a new press, or contact lost).
    pub fn reset(&mut self) {
        self.history.clear();
        self.gross = false;
        self.against = 0;
    }

    /// The state of the next frame, read `r` (`None` without contact: the sequence starts
    /// again at the next contact). The first frames of a contact repeat the oldest reading.
    pub fn next(&mut self, r: Option<Reading>) -> Option<Slip> {
        let Some(r) = r else {
            self.reset();
            return None;
        };
        if self.history.len() == SLIP_FRAMES {
            self.history.pop_front();
        }
        self.history.push_back(r);
        let first = self.history[0];
        let mut w = [first; SLIP_FRAMES];
        let pad = SLIP_FRAMES - self.history.len();
        for (i, h) in self.history.iter().enumerate() {
            w[pad + i] = *h;
        }
        let said = self.head.classify(&w);
        let says_gross = said == Slip::GrossSlip;
        if says_gross != self.gross {
            self.against += 1;
            if self.against >= self.head.confirm_frames {
                self.gross = says_gross;
                self.against = 0;
            }
        } else {
            self.against = 0;
        }
        Some(match (self.gross, said) {
            (true, _) => Slip::GrossSlip,
            // Gross slip said but not yet confirmed: the contact is at least partly slipping.
            (false, Slip::GrossSlip) => Slip::PartialSlip,
            (false, s) => s,
        })
    }
}

/// One sequence's frames for fitting: the readings (in time order) and their labels.
pub struct Sequence {
    pub readings: Vec<Option<Reading>>,
    pub labels: Vec<Option<Slip>>,
}

/// Why a slip head could not be fitted.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FitError {
    #[error(
        "no frame has both a slip label and a predicted shear: fit on runs of presses that \
         slide (`fringe scan slides`) with a model that has shear heads"
    )]
    NoData,
    #[error("the slip labels never say {0}: fit on runs of slides that slip")]
    MissingState(&'static str),
}

/// Fits a slip head on `sequences`: its two layers on the frames' features and labels (each
/// state weighted by the inverse of its share of the frames);
/// then the confirmation (1 to 3 frames) that gives the most onsets within `tolerance` frames
/// of the labels' with the fewest false ones on the same sequences.
pub fn fit(sequences: &[Sequence], tolerance: usize) -> Result<SlipHead, FitError> {
    let mut xs: Vec<[f64; FEATURES.len()]> = Vec::new();
    let mut ys: Vec<usize> = Vec::new();
    for s in sequences {
        let mut window: VecDeque<Reading> = VecDeque::new();
        for (r, l) in s.readings.iter().zip(&s.labels) {
            let Some(r) = r else {
                window.clear();
                continue;
            };
            if window.len() == SLIP_FRAMES {
                window.pop_front();
            }
            window.push_back(*r);
            let Some(l) = l else { continue };
            let mut w = [window[0]; SLIP_FRAMES];
            let pad = SLIP_FRAMES - window.len();
            for (i, h) in window.iter().enumerate() {
                w[pad + i] = *h;
            }
            xs.push(features(&w));
            ys.push(Slip::ALL.iter().position(|s| s == l).unwrap_or(0));
        }
    }
    if xs.is_empty() {
        return Err(FitError::NoData);
    }
    let k = Slip::ALL.len();
    let n = FEATURES.len();
    let mut counts = vec![0usize; k];
    for &y in &ys {
        counts[y] += 1;
    }
    if let Some(c) = counts.iter().position(|&c| c == 0) {
        return Err(FitError::MissingState(Slip::ALL[c].name()));
    }
    let rows = xs.len() as f64;
    let mean: Vec<f64> = (0..n)
        .map(|j| xs.iter().map(|x| x[j]).sum::<f64>() / rows)
        .collect();
    let scale: Vec<f64> = (0..n)
        .map(|j| {
            let v = xs.iter().map(|x| (x[j] - mean[j]).powi(2)).sum::<f64>() / rows;
            v.sqrt().max(1e-9)
        })
        .collect();
    let z: Vec<Vec<f64>> = xs.iter().map(|x| standardised(x, &mean, &scale)).collect();
    let class_weight: Vec<f64> = counts
        .iter()
        .map(|&c| rows / (k as f64 * c as f64))
        .collect();
    let (hidden_weights, hidden_bias, weights, bias) = train_mlp(&z, &ys, &class_weight, k);
    let mut head = SlipHead {
        features: FEATURES.iter().map(|s| s.to_string()).collect(),
        mean,
        scale,
        hidden_weights,
        hidden_bias,
        weights,
        bias,
        confirm_frames: 1,
    };
    let mut best: Option<(f64, usize)> = None;
    for confirm in 1..=3 {
        head.confirm_frames = confirm;
        let mut score = OnsetScore::default();
        for s in sequences {
            let mut t = SlipTracker::new(head.clone());
            let pred: Vec<Option<Slip>> = s.readings.iter().map(|r| t.next(*r)).collect();
            score.add(&s.labels, &pred, tolerance);
        }
        let f1 = score.f1();
        if best.is_none_or(|(b, _)| f1 > b) {
            best = Some((f1, confirm));
        }
    }
    head.confirm_frames = best.map_or(1, |(_, c)| c);
    Ok(head)
}

/// The layers' weights and biases: hidden, then output.
type Layers = (Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>);

/// Fits the hidden and output layers on the standardised features `z` and states `ys`: the
/// cross-entropy, each row weighted by its state's `class_weight`, with a small L2 penalty, by
/// full-batch Adam from a seeded start.
fn train_mlp(z: &[Vec<f64>], ys: &[usize], class_weight: &[f64], k: usize) -> Layers {
    const STEPS: usize = 1500;
    const RATE: f64 = 0.02;
    const L2: f64 = 1e-4;
    let n = FEATURES.len();
    let mut rng = fringe_rig::seeded::SplitMix64::new(0x5_11b);
    let mut init = |fan_in: usize| rng.normal() / (fan_in as f64).sqrt();
    // Parameters in one vector: hidden weights, hidden bias, output weights, output bias.
    let (hw, hb, ow) = (HIDDEN * n, HIDDEN, k * HIDDEN);
    let mut p = vec![0.0; hw + hb + ow + k];
    for v in &mut p[..hw] {
        *v = init(n);
    }
    for v in &mut p[hw + hb..hw + hb + ow] {
        *v = init(HIDDEN);
    }
    let (mut m, mut v2) = (vec![0.0; p.len()], vec![0.0; p.len()]);
    let total: f64 = ys.iter().map(|&y| class_weight[y]).sum();
    let mut g = vec![0.0; p.len()];
    let mut hidden = [0.0; HIDDEN];
    let mut dh = [0.0; HIDDEN];
    for step in 1..=STEPS {
        g.iter_mut().for_each(|x| *x = 0.0);
        for (x, &y) in z.iter().zip(ys) {
            for j in 0..HIDDEN {
                let w = &p[j * n..(j + 1) * n];
                hidden[j] = (p[hw + j] + w.iter().zip(x).map(|(a, b)| a * b).sum::<f64>()).tanh();
            }
            let mut out = [0.0f64; 3];
            for (c, o) in out.iter_mut().enumerate().take(k) {
                let w = &p[hw + hb + c * HIDDEN..hw + hb + (c + 1) * HIDDEN];
                *o = p[hw + hb + ow + c] + w.iter().zip(&hidden).map(|(a, b)| a * b).sum::<f64>();
            }
            let max = out[..k].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let e: Vec<f64> = out[..k].iter().map(|o| (o - max).exp()).collect();
            let sum: f64 = e.iter().sum();
            let cw = class_weight[y] / total;
            dh.iter_mut().for_each(|d| *d = 0.0);
            for c in 0..k {
                let d = (e[c] / sum - f64::from(u8::from(c == y))) * cw;
                g[hw + hb + ow + c] += d;
                for j in 0..HIDDEN {
                    g[hw + hb + c * HIDDEN + j] += d * hidden[j];
                    dh[j] += d * p[hw + hb + c * HIDDEN + j];
                }
            }
            for j in 0..HIDDEN {
                let d = dh[j] * (1.0 - hidden[j] * hidden[j]);
                g[hw + j] += d;
                for (i, xi) in x.iter().enumerate() {
                    g[j * n + i] += d * xi;
                }
            }
        }
        let (b1, b2) = (0.9f64, 0.999f64);
        for i in 0..p.len() {
            let gi = g[i] + L2 * p[i];
            m[i] = b1 * m[i] + (1.0 - b1) * gi;
            v2[i] = b2 * v2[i] + (1.0 - b2) * gi * gi;
            let mh = m[i] / (1.0 - b1.powi(step as i32));
            let vh = v2[i] / (1.0 - b2.powi(step as i32));
            p[i] -= RATE * mh / (vh.sqrt() + 1e-8);
        }
    }
    let rows = |from: usize, count: usize, len: usize| -> Vec<Vec<f64>> {
        (0..count)
            .map(|r| p[from + r * len..from + (r + 1) * len].to_vec())
            .collect()
    };
    (
        rows(0, HIDDEN, n),
        p[hw..hw + hb].to_vec(),
        rows(hw + hb, k, HIDDEN),
        p[hw + hb + ow..].to_vec(),
    )
}

/// The first frames of gross slip in a sequence of states (a frame of gross slip after one that
/// is not, or the first frame).
pub(crate) fn onset_frames(states: &[Option<Slip>]) -> Vec<usize> {
    let gross = |s: &Option<Slip>| *s == Some(Slip::GrossSlip);
    (0..states.len())
        .filter(|&i| gross(&states[i]) && (i == 0 || !gross(&states[i - 1])))
        .collect()
}

/// Slip onsets reported against the labels', and the frames' states.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OnsetScore {
    /// Onsets in the labels, those reported within the tolerance, and reported onsets that
    /// match none.
    pub labelled: usize,
    pub found: usize,
    pub false_onsets: usize,
    /// Frames from each found onset's label to its report (positive: late).
    pub offsets: Vec<i64>,
    /// Frames with a label and a reported state, and how many agree.
    pub frames: usize,
    pub agree: usize,
}

impl OnsetScore {
    /// Adds one sequence (one press): its labels and the reported states, frame by frame. A
    /// reported onset matches the nearest labelled one within `tolerance` frames that no other
    /// has matched.
    pub fn add(&mut self, labels: &[Option<Slip>], reported: &[Option<Slip>], tolerance: usize) {
        for (l, r) in labels.iter().zip(reported) {
            if let (Some(l), Some(r)) = (l, r) {
                self.frames += 1;
                self.agree += usize::from(l == r);
            }
        }
        let truth = onset_frames(labels);
        let said = onset_frames(reported);
        let mut used = vec![false; said.len()];
        self.labelled += truth.len();
        for &t in &truth {
            let nearest = said
                .iter()
                .enumerate()
                .filter(|(k, &s)| !used[*k] && s.abs_diff(t) <= tolerance)
                .min_by_key(|(_, &s)| s.abs_diff(t));
            if let Some((k, &s)) = nearest {
                used[k] = true;
                self.found += 1;
                self.offsets.push(s as i64 - t as i64);
            }
        }
        self.false_onsets += used.iter().filter(|u| !**u).count();
    }

    /// Onset F1: 2 found / (labelled + reported); 1 when there was nothing to find and nothing
    /// was reported.
    pub fn f1(&self) -> f64 {
        let reported = self.found + self.false_onsets;
        if self.labelled + reported == 0 {
            1.0
        } else {
            2.0 * self.found as f64 / (self.labelled + reported) as f64
        }
    }

    /// The largest distance of a found onset from its label, frames.
    pub fn max_offset(&self) -> Option<u64> {
        self.offsets.iter().map(|o| o.unsigned_abs()).max()
    }

    /// The mean distance of the found onsets from their labels, frames.
    pub fn mean_offset(&self) -> Option<f64> {
        (!self.offsets.is_empty()).then(|| {
            self.offsets
                .iter()
                .map(|o| o.unsigned_abs() as f64)
                .sum::<f64>()
                / self.offsets.len() as f64
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A press that slides: it loads to `fz`, the push grows at a steady rate up to the
    /// friction limit (`mu` of the normal force), then holds there while the indenter slides
    /// (the contact with it), then rests a little under it.
    fn press(noise_seed: u64, fz: f64, mu: f64) -> Sequence {
        let mut rng = fringe_rig::seeded::SplitMix64::new(noise_seed);
        let mut readings = Vec::new();
        let mut labels = Vec::new();
        for i in 0..80usize {
            let (q, label) = match i {
                0..10 => (0.0, Slip::Stick),
                10..40 => {
                    let q = mu * fz * (i - 10) as f64 / 30.0;
                    let s = if q > 0.6 * mu * fz {
                        Slip::PartialSlip
                    } else {
                        Slip::Stick
                    };
                    (q, s)
                }
                40..60 => (mu * fz, Slip::GrossSlip),
                _ => (mu * fz * 0.97, Slip::PartialSlip),
            };
            // The press loads over its first ten frames.
            let load = fz * (i as f64 / 10.0).min(1.0);
            let noise = 0.01 * (rng.uniform() - 0.5);
            // The indenter slides 0.04 mm a frame, and the contact with it, while it slips.
            let travel = (i.clamp(40, 60) - 40) as f64 * 0.04;
            readings.push(Some(Reading {
                fz: load + noise,
                shear: [q + noise, 0.5 * noise],
                contact: [travel, 0.0],
            }));
            labels.push(Some(label));
        }
        Sequence { readings, labels }
    }

    #[test]
    fn a_fitted_head_reports_each_slide_once_near_its_onset_and_nothing_at_rest() {
        let train: Vec<Sequence> = (0..12)
            .map(|k| press(k, 1.5 + 0.1 * k as f64, 0.7 + 0.02 * k as f64))
            .collect();
        let head = fit(&train, 2).expect("fit");
        head.check().expect("a head it fitted reads back");
        let mut score = OnsetScore::default();
        for k in 0..6 {
            let s = press(100 + k, 1.7 + 0.1 * k as f64, 0.75 + 0.03 * k as f64);
            let mut t = SlipTracker::new(head.clone());
            let said: Vec<Option<Slip>> = s.readings.iter().map(|r| t.next(*r)).collect();
            score.add(&s.labels, &said, 2);
        }
        assert_eq!(score.labelled, 6);
        assert_eq!(score.found, 6, "{score:?}");
        assert_eq!(score.false_onsets, 0, "{score:?}");
        // A press that never pushes sideways reports no slip.
        let mut t = SlipTracker::new(head);
        for i in 0..200 {
            let fz = (i as f64 / 20.0).min(3.0);
            let said = t.next(Some(Reading {
                fz,
                shear: [0.01, -0.01],
                contact: [0.0, 0.0],
            }));
            assert_ne!(said, Some(Slip::GrossSlip), "frame {i}");
        }
    }

    #[test]
    fn onsets_match_within_the_tolerance_once_each() {
        use Slip::{GrossSlip as G, Stick as S};
        let labels: Vec<Option<Slip>> = [S, S, G, G, G, S, S, S, G, G].map(Some).to_vec();
        let said: Vec<Option<Slip>> = [S, S, S, S, G, G, S, G, G, S].map(Some).to_vec();
        let mut score = OnsetScore::default();
        score.add(&labels, &said, 2);
        // Labelled onsets at 2 and 8, reported at 4 and 7: both found (2 late, 1 early).
        assert_eq!((score.labelled, score.found, score.false_onsets), (2, 2, 0));
        assert_eq!(score.offsets, vec![2, -1]);
        let mut strict = OnsetScore::default();
        strict.add(&labels, &said, 1);
        assert_eq!((strict.found, strict.false_onsets), (1, 1));
        assert!((strict.f1() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_head_of_other_features_is_refused() {
        let train: Vec<Sequence> = (0..4).map(|k| press(k, 2.0, 0.8)).collect();
        let mut head = fit(&train, 2).expect("fit");
        head.features[0] = "something_else".into();
        assert!(matches!(head.check(), Err(SlipHeadError::Features { .. })));
    }
}
