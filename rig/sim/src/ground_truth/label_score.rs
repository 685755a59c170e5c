//! Scoring a simulated run's labels against the simulator's ground truth: the normal force of
//! each frame's label against the true force at mid-exposure, and its contact point against the
//! true one. Frames are matched by device timestamp (exposure start in camera ticks).

use crate::ground_truth::records::FrameTruth;
use fringe_rig::reference_layout::in_contact;
use fringe_rig::store::FrameRecord;
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
}

/// Scores `records` against `truths`; `None` when no labelled frame has a truth record.
pub fn score(records: &[FrameRecord], truths: &[FrameTruth]) -> Option<LabelScore> {
    let by_ticks: HashMap<u64, &FrameTruth> =
        truths.iter().map(|t| (t.exposure_start_ticks, t)).collect();
    let (mut n, mut sum2, mut max) = (0usize, 0.0, 0.0f64);
    let (mut nc, mut sumc) = (0usize, 0.0);
    for r in records {
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
    })
}
