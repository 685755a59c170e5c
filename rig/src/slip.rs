//! How a contact holds (stick, partial slip, gross slip), labelled frame by frame from what the
//! bench records: the tangential force in the sensor frame ([`FrameRecord::shear`]), the normal
//! force and where the slide had taken the indenter mid-exposure ([`FrameRecord::commanded`]).
//! No sensor of the bench sees slip itself; it shows in how the force follows the motion.
//!
//! The rule, per press (the frames of one grid point, in order):
//! - **Gross slip**: the indenter is moving and the tangential force has stopped growing with
//!   the motion. While the contact sticks, the force grows with every step of the indenter
//!   (the gel is sheared); once it slides the force stays at the kinetic friction (or falls to
//!   it from the static peak). The first moving frame whose share of the normal force
//!   (Q / P along the slide) no later moving frame exceeds by more than [`RISE_TOLERANCE`],
//!   with at least [`PLATEAU_TRAVEL`] of the slide still to go, is where the force stopped
//!   growing. Gross slip starts after the static peak, when the force rose above the kinetic
//!   share (the median of the moving frames after that one) by more than the tolerance and
//!   fell back; otherwise at the first frame within half the tolerance of the kinetic share.
//!   The static friction share mu_s is the peak's, or the largest share up to the start. Gross slip lasts while the
//!   indenter moves. At rest afterwards the contact sticks again, and slides again when the
//!   normal force falls under what static friction needs to hold the push it carries (the
//!   previous frame's Q over P above mu_s), as when the indenter lifts.
//! - **Partial slip**: otherwise, while the contact's share of the friction limit
//!   (Q / (mu_s P)) is at or past the outline's [`partial_slip_onset`], where a tenth of the
//!   contact slips.
//! - **Stick**: otherwise (every frame of a press without a slide).
//!
//! A frame without contact, or without a trusted tangential force (a run recorded without the
//! F/T's axes, [`crate::force::FtAxes`]), has no slip label. A slide that never reaches gross
//! slip leaves mu_s unknown: its frames take the run's mu_s for that outline (from its other
//! slides), else they are left without a label while they move and push.

use crate::reference_layout::{in_contact, NO_CONTACT};
use crate::store::FrameRecord;

/// How a contact holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Slip {
    /// All, or all but a tenth, of the contact sticks.
    Stick,
    /// A slipping zone covers a tenth or more of the contact; the rest sticks.
    PartialSlip,
    /// The whole contact slides.
    GrossSlip,
}

impl Slip {
    /// Every state, in order of how much slides.
    pub const ALL: [Slip; 3] = [Slip::Stick, Slip::PartialSlip, Slip::GrossSlip];

    /// The state's name in labels and ground-truth files.
    pub fn name(self) -> &'static str {
        match self {
            Slip::Stick => "stick",
            Slip::PartialSlip => "partial_slip",
            Slip::GrossSlip => "gross_slip",
        }
    }

    /// The state named `name` ([`Slip::name`]).
    pub fn named(name: &str) -> Option<Slip> {
        Slip::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// A later moving frame's Q / P above this over a frame's means the force was still growing.
pub(crate) const RISE_TOLERANCE: f64 = 0.03;
/// Gross slip is only called with this much of the slide (mm) still to come, to see that the
/// force has stopped growing.
pub(crate) const PLATEAU_TRAVEL: f64 = 0.1;
/// A frame whose stage position differs from the one before by more than this (mm) is moving.
const MOVING: f64 = 1e-6;

/// The share of the friction limit (Q / mu_s P) at which a tenth of the contact of the bench's
/// indenter `shape` slips: 0.18 for a sphere (Cattaneo and Mindlin's annulus; 1 - 0.9^1.5 =
/// 0.15 for an exactly Hertzian pressure), later for the flat punches, whose slip starts in a
/// band along their rounded edges (0.5 mm): the 5 mm pentagon 0.65, the 10 x 6 mm rectangle
/// 0.51, the circle of 4 mm radius 0.64. From the traction model of docs/photoelastic-sim.md ("Shear
/// and slip"), which the simulator's ground truth uses too (a test there checks these). `None`
/// for an outline not listed.
pub fn partial_slip_onset(shape: &str) -> Option<f64> {
    match shape {
        "sphere" => Some(0.18),
        "pentagon" => Some(0.65),
        "rectangle" => Some(0.51),
        "circle" => Some(0.64),
        _ => None,
    }
}

/// A frame's signals for the rule.
struct Reading {
    at: [f64; 2],
    /// Normal force, N (> 0 in contact), and the size of the tangential force, N.
    normal: f64,
    push: f64,
    shear: [f64; 2],
}

fn reading(r: &FrameRecord) -> Option<Reading> {
    let w = r.wrench.filter(|_| r.valid)?;
    let shear = r.shear?;
    in_contact(w.fz).then_some(Reading {
        at: [r.commanded.x.0, r.commanded.y.0],
        normal: w.fz.0.abs(),
        push: shear[0].hypot(shear[1]),
        shear,
    })
}

/// What one press's slide showed.
struct PressSlip {
    /// Frame indices (within the press) of the moving frames, in order.
    moving: Vec<usize>,
    /// Where gross slip started (index within the press) and the static friction share.
    gross: Option<(usize, f64)>,
}

fn press_slip(frames: &[Option<Reading>]) -> PressSlip {
    let mut moving = Vec::new();
    let mut last: Option<[f64; 2]> = None;
    let mut first: Option<[f64; 2]> = None;
    let mut end = None;
    for (k, f) in frames.iter().enumerate() {
        let Some(f) = f else { continue };
        if let Some(p) = last {
            if (f.at[0] - p[0]).hypot(f.at[1] - p[1]) > MOVING {
                moving.push(k);
                end = Some(f.at);
            }
        }
        first.get_or_insert(f.at);
        last = Some(f.at);
    }
    let (Some(a), Some(b)) = (first, end) else {
        return PressSlip {
            moving,
            gross: None,
        };
    };
    let d = [b[0] - a[0], b[1] - a[1]];
    let length = d[0].hypot(d[1]);
    let unit = [d[0] / length, d[1] / length];
    // (frame, distance along the slide, Q / P along it) of each moving frame.
    let signals: Vec<(usize, f64, f64)> = moving
        .iter()
        .filter_map(|&k| {
            let f = frames[k].as_ref()?;
            let s = f.at[0] * unit[0] + f.at[1] * unit[1];
            let q = f.shear[0] * unit[0] + f.shear[1] * unit[1];
            Some((k, s, q / f.normal))
        })
        .collect();
    // The largest share still to come after each moving frame.
    let mut later_max = vec![f64::NEG_INFINITY; signals.len()];
    for i in (0..signals.len().saturating_sub(1)).rev() {
        later_max[i] = later_max[i + 1].max(signals[i + 1].2);
    }
    let Some(&(_, s_end, _)) = signals.last() else {
        return PressSlip {
            moving,
            gross: None,
        };
    };
    let stopped_growing = signals
        .iter()
        .enumerate()
        .take_while(|(_, &(_, s, _))| s_end - s >= PLATEAU_TRAVEL)
        .find(|(i, &(_, _, r))| later_max[*i] <= r + RISE_TOLERANCE)
        .map(|(i, _)| i);
    let gross = stopped_growing.map(|i| {
        let rest = &signals[i..];
        let mut after: Vec<f64> = rest[1..].iter().map(|x| x.2).collect();
        after.sort_by(f64::total_cmp);
        let kinetic = after.get(after.len() / 2).copied().unwrap_or(rest[0].2);
        let (top, peak) = rest
            .iter()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |best, (j, x)| {
                if x.2 > best.1 {
                    (j, x.2)
                } else {
                    best
                }
            });
        if peak > kinetic + RISE_TOLERANCE {
            // A static peak above the kinetic friction: still stuck there, sliding after it.
            let onset = rest.get(top + 1).map_or(rest[top].0, |x| x.0);
            (onset, peak)
        } else {
            // No drop: sliding from the first frame at the kinetic friction.
            let j = rest
                .iter()
                .position(|x| x.2 >= kinetic - RISE_TOLERANCE / 2.0)
                .unwrap_or(0);
            let mu = rest[..=j].iter().map(|x| x.2).fold(kinetic, f64::max);
            (rest[j].0, mu)
        }
    });
    PressSlip { moving, gross }
}

/// The slip label of every record (`None`: no contact, or no trusted tangential force), in the
/// order given; records of one press are those of one point, taken in order.
pub fn slip_labels(records: &[FrameRecord]) -> Vec<Option<Slip>> {
    let mut labels = vec![None; records.len()];
    // Presses: runs of records of one point.
    let mut presses: Vec<std::ops::Range<usize>> = Vec::new();
    for (i, r) in records.iter().enumerate() {
        match presses.last_mut() {
            Some(p) if records[p.start].point == r.point => p.end = i + 1,
            _ => presses.push(i..i + 1),
        }
    }
    let readings: Vec<Option<Reading>> = records.iter().map(reading).collect();
    let slides: Vec<PressSlip> = presses
        .iter()
        .map(|p| press_slip(&readings[p.clone()]))
        .collect();
    // The run's static friction share per outline, from the slides that slipped (median).
    let run_mu = |shape: &str| -> Option<f64> {
        let mut mus: Vec<f64> = presses
            .iter()
            .zip(&slides)
            .filter(|(p, _)| records[p.start..p.end].iter().any(|r| r.shape == shape))
            .filter_map(|(_, s)| s.gross.map(|(_, mu)| mu))
            .collect();
        mus.sort_by(f64::total_cmp);
        (!mus.is_empty()).then(|| mus[mus.len() / 2])
    };
    for (p, slide) in presses.iter().zip(&slides) {
        let Some(&last_moving) = slide.moving.last() else {
            // A press without a slide sticks (its push, if any, is the noise of the F/T).
            for i in p.clone() {
                if readings[i].is_some() {
                    labels[i] = Some(Slip::Stick);
                }
            }
            continue;
        };
        // The indenter's name, from a frame in contact (the others say "None").
        let shape = p
            .clone()
            .find(|&i| readings[i].is_some())
            .map_or(NO_CONTACT, |i| records[i].shape.as_str());
        let mu = slide.gross.map(|(_, mu)| mu).or_else(|| run_mu(shape));
        let onset = partial_slip_onset(shape);
        let mut carried: Option<f64> = None;
        for k in 0..p.len() {
            let i = p.start + k;
            let Some(f) = &readings[i] else {
                carried = None;
                continue;
            };
            let label = match (slide.gross, mu) {
                (Some((start, _)), _) if k >= start && slide.moving.binary_search(&k).is_ok() => {
                    Some(Slip::GrossSlip)
                }
                (_, Some(mu)) if k > last_moving && carried.is_some_and(|q| q > mu * f.normal) => {
                    Some(Slip::GrossSlip)
                }
                (_, Some(mu)) if mu > 0.0 => onset.map(|onset| {
                    if f.push / (mu * f.normal) >= onset {
                        Slip::PartialSlip
                    } else {
                        Slip::Stick
                    }
                }),
                _ => None,
            };
            labels[i] = label;
            carried = Some(f.push);
        }
    }
    labels
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::Position;
    use crate::units::{Millimetres, Newtons, Wrench};

    /// A frame of point 0 at stage x `x`, pressing `p` N, pushed `q` N along +x.
    fn frame(index: u64, x: f64, p: f64, q: Option<f64>) -> FrameRecord {
        let at = Position {
            x: Millimetres(x),
            y: Millimetres(0.0),
            z: Millimetres(0.0),
        };
        FrameRecord {
            index,
            frame_id: index,
            file: format!("frames/{index:06}.png"),
            device_timestamp: index,
            host_arrival_ns: index,
            exposure: None,
            exposure_ticks: None,
            point: 0,
            commanded: at,
            measured: at,
            wrench: Some(Wrench {
                fz: Newtons(-p),
                ..Wrench::default()
            }),
            shear: q.map(|q| [q, 0.0]),
            shape: "pentagon".into(),
            contact: Some([x, 0.0]),
            valid: true,
            notes: Vec::new(),
        }
    }

    /// A press at 3 N: 10 frames at rest, a slide of `steps` frames 0.02 mm apart whose push
    /// follows `push(step)`, then 10 frames at rest and 3 lifting.
    fn slide(steps: usize, push: impl Fn(usize) -> f64) -> Vec<FrameRecord> {
        let mut out = Vec::new();
        let mut i = 0;
        let mut add = |x: f64, p: f64, q: f64| {
            out.push(frame(i, x, p, Some(q)));
            i += 1;
        };
        for _ in 0..10 {
            add(0.0, 3.0, 0.01);
        }
        for k in 1..=steps {
            add(0.02 * k as f64, 3.0, push(k));
        }
        let end = 0.02 * steps as f64;
        let held = push(steps);
        for _ in 0..10 {
            add(end, 3.0, held);
        }
        for p in [2.0, 1.2, 0.6] {
            add(end, p, held.min(0.8 * p));
        }
        out
    }

    #[test]
    fn a_press_without_a_slide_sticks_and_without_contact_has_no_label() {
        let mut records: Vec<FrameRecord> =
            (0..5).map(|i| frame(i, 0.0, 3.0, Some(0.05))).collect();
        records.push(frame(5, 0.0, 0.05, Some(0.0)));
        let labels = slip_labels(&records);
        assert_eq!(&labels[..5], &[Some(Slip::Stick); 5]);
        assert_eq!(labels[5], None);
    }

    #[test]
    fn gross_slip_starts_where_the_push_stops_growing() {
        // Stick up to step 40 (push 0.06 N a step), then the kinetic friction 0.8 * 3 N.
        let records = slide(100, |k| (0.06 * k as f64).min(2.4));
        let labels = slip_labels(&records);
        let first_gross = labels.iter().position(|l| *l == Some(Slip::GrossSlip));
        // Step k is frame 9 + k: step 40 is the first at the plateau.
        assert_eq!(first_gross, Some(9 + 40));
        // Partial slip from 0.65 of the friction limit (2.4 N): push 1.56 N at step 26.
        assert_eq!(
            labels.iter().position(|l| *l == Some(Slip::PartialSlip)),
            Some(9 + 26)
        );
        // Every moving frame from there slides; at rest it sticks again (in partial slip,
        // its push near the limit); lifting, it slides again.
        assert!(labels[49..110].iter().all(|l| *l == Some(Slip::GrossSlip)));
        assert!(labels[110..120]
            .iter()
            .all(|l| *l == Some(Slip::PartialSlip)));
        assert!(labels[120..].iter().all(|l| *l == Some(Slip::GrossSlip)));
    }

    #[test]
    fn a_static_peak_is_still_stuck_and_sliding_starts_after_it() {
        // Up to 2.7 N (static 0.9) at step 45, then 2.4 N (kinetic 0.8).
        let records = slide(100, |k| if k <= 45 { 0.06 * k as f64 } else { 2.4 });
        let labels = slip_labels(&records);
        assert_eq!(labels[9 + 45], Some(Slip::PartialSlip));
        assert_eq!(labels[9 + 46], Some(Slip::GrossSlip));
    }

    #[test]
    fn a_slide_that_never_slips_has_no_gross_slip_and_borrows_the_runs_friction() {
        // Alone, a slide that only sticks cannot say how near the limit it came.
        let stuck = slide(30, |k| 0.06 * k as f64);
        let labels = slip_labels(&stuck);
        assert!(!labels[..50].contains(&Some(Slip::GrossSlip)));
        assert_eq!(
            labels[12], None,
            "no friction known: no label while it pushes"
        );
        // With a slide that slipped (static 0.8) in the same run, it has one.
        let mut run = slide(100, |k| (0.06 * k as f64).min(2.4));
        let n = run.len() as u64;
        run.extend(stuck.into_iter().map(|mut r| {
            r.point = 1;
            r.index += n;
            r
        }));
        let labels = slip_labels(&run);
        let second = &labels[n as usize..];
        // Pushed to 1.8 N (0.75 of the 2.4 N limit): partial slip at the end, never sliding
        // while it moves or rests; lifting, the limit falls under the push and it slides.
        assert!(!second[..50].contains(&Some(Slip::GrossSlip)));
        assert_eq!(second[12], Some(Slip::Stick));
        assert_eq!(second[9 + 30], Some(Slip::PartialSlip));
        assert_eq!(second[50], Some(Slip::GrossSlip));
    }

    #[test]
    fn frames_without_the_shear_of_the_f_t_have_no_slip_label() {
        let records: Vec<FrameRecord> = (0..5).map(|i| frame(i, 0.0, 3.0, None)).collect();
        assert_eq!(slip_labels(&records), vec![None; 5]);
    }

    #[test]
    fn slip_states_are_named_as_in_the_ground_truth() {
        for s in Slip::ALL {
            assert_eq!(Slip::named(s.name()), Some(s));
            let json = serde_json::to_string(&s).expect("json");
            assert_eq!(json, format!("\"{}\"", s.name()));
        }
        assert_eq!(Slip::named("sliding"), None);
    }
}
