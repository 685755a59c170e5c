//! Scoring a simulated run's labels against the simulator's ground truth: the normal force of
//! each frame's label against the true force at mid-exposure, and its contact point against the
//! true one; where the run labels shear, its tangential force (sensor frame) against the true
//! push, and its slip labels against the true slip state, with where each press's gross slip
//! starts. Frames are matched by device timestamp (exposure start in camera ticks).

use crate::ground_truth::records::FrameTruth;
use fringe_rig::reference_layout::in_contact;
use fringe_rig::store::FrameRecord;
use fringe_rig::{slip_labels, Slip};
use std::collections::HashMap;

/// How well the labels of a run match the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelScore {
    /// Labelled frames matched with a truth record.
    pub frames: usize,
    /// RMS of (label normal force - true normal force), N.
    pub force_rms_n: f64,
    pub force_max_n: f64,
    /// Frames labelled in contact whose contact point was compared.
    pub contact_frames: usize,
    /// RMS distance between the labelled and the true contact point, mm.
    pub contact_rms_mm: f64,
    /// Frames in contact with a shear label, and its RMS off the true push per axis, N.
    pub shear_frames: usize,
    pub shear_rms_n: [f64; 2],
    /// Frames in contact with a slip label, and how many say what the truth says.
    pub slip_frames: usize,
    pub slip_agree: usize,
    /// Presses whose gross slip starts in both the labels and the truth, and the largest
    /// distance between the two starts, frames.
    pub onsets: usize,
    pub onset_max_frames: usize,
    /// Presses that slide in the truth but not in the labels, and the other way round.
    pub onsets_missed: usize,
    pub onsets_false: usize,
}

/// Scores `records` against `truths`; `None` when no labelled frame has a truth record.
pub fn score(records: &[FrameRecord], truths: &[FrameTruth]) -> Option<LabelScore> {
    let by_ticks: HashMap<u64, &FrameTruth> =
        truths.iter().map(|t| (t.exposure_start_ticks, t)).collect();
    let (mut n, mut sum2, mut max) = (0usize, 0.0, 0.0f64);
    let (mut nc, mut sumc) = (0usize, 0.0);
    let (mut ns, mut sums) = (0usize, [0.0f64; 2]);
    let (mut nslip, mut agree) = (0usize, 0usize);
    // Per press: the first labelled and the first true gross slip (frames in contact).
    let mut presses: Vec<(u64, usize, Option<usize>, Option<usize>)> = Vec::new();
    let slips = slip_labels(records);
    for (r, slip) in records.iter().zip(&slips) {
        let (Some(w), Some(t)) = (r.wrench, by_ticks.get(&r.device_timestamp)) else {
            continue;
        };
        let true_force = t.contact.map_or(0.0, |c| c.0);
        // The F/T reads the reaction: pressing gives a negative Fz.
        let e = -w.fz.0 - true_force;
        n += 1;
        sum2 += e * e;
        max = max.max(e.abs());
        if let (Some(c), Some((_, tx, ty))) = (r.contact, t.contact) {
            if in_contact(w.fz) {
                nc += 1;
                sumc += (c[0] - tx).powi(2) + (c[1] - ty).powi(2);
            }
        }
        if let (Some(_), Some((q, true_slip))) = (r.contact, t.shear) {
            if let Some(shear) = r.shear {
                ns += 1;
                for k in 0..2 {
                    sums[k] += (shear[k] - q[k]).powi(2);
                }
            }
            if let Some(slip) = slip {
                nslip += 1;
                agree += usize::from(*slip == true_slip);
                if presses.last().is_none_or(|p| p.0 != r.point) {
                    presses.push((r.point, 0, None, None));
                }
                if let Some(p) = presses.last_mut() {
                    if *slip == Slip::GrossSlip && p.2.is_none() {
                        p.2 = Some(p.1);
                    }
                    if true_slip == Slip::GrossSlip && p.3.is_none() {
                        p.3 = Some(p.1);
                    }
                    p.1 += 1;
                }
            }
        }
    }
    let (mut onsets, mut onset_max, mut missed, mut false_onsets) = (0, 0, 0, 0);
    for (_, _, labelled, truly) in &presses {
        match (labelled, truly) {
            (Some(a), Some(b)) => {
                onsets += 1;
                onset_max = onset_max.max(a.abs_diff(*b));
            }
            (None, Some(_)) => missed += 1,
            (Some(_), None) => false_onsets += 1,
            (None, None) => {}
        }
    }
    (n > 0).then(|| LabelScore {
        frames: n,
        force_rms_n: (sum2 / n as f64).sqrt(),
        force_max_n: max,
        contact_frames: nc,
        contact_rms_mm: if nc > 0 {
            (sumc / nc as f64).sqrt()
        } else {
            f64::NAN
        },
        shear_frames: ns,
        shear_rms_n: sums.map(|s| {
            if ns > 0 {
                (s / ns as f64).sqrt()
            } else {
                f64::NAN
            }
        }),
        slip_frames: nslip,
        slip_agree: agree,
        onsets,
        onset_max_frames: onset_max,
        onsets_missed: missed,
        onsets_false: false_onsets,
    })
}
