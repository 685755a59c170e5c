//! Labels frames with the force measured during their exposure, using the exposure strobe
//! recorded beside the force gauges (synchronisation method `strobe`).
//!
//! The strobe channel gives each exposure's window in the force stream's own sample index: the
//! label needs no clock model. What the strobe cannot say is which frame a window belongs to.
//! That is decided with the one clock model of the project: the [`ClockFitLabeler`]'s fits
//! (camera timestamps calibrated by timestamp latches, force sample counter by the one-way
//! lower-hull fit) place the frame's exposure in the force stream, and the frame takes the
//! strobe window that starts nearest to that place, if it is within [`MATCH_FRACTION`] of a
//! frame period. Host delays (a slow renderer, a busy machine, a late force block) only add
//! delay, which the lower-hull fits ignore, and latches do not depend on delivery at all; so
//! frames delivered later than a frame period still get their own window.
//!
//! Once a frame is matched, frame id n belongs to window n - offset (dropped frames leave id
//! gaps, not window gaps), and each further match is only checked against the clock placement;
//! a check that fails (lost strobe windows) matches afresh.

use super::clock_fit_labeler::{ClockFitLabeler, ClockFitOptions, Placement};
use super::labeler::{ExposureLabel, FrameLabeler, LabelOutcome};
use crate::camera::{Frame, TimestampLatch};
use crate::force::ForceSample;
use crate::sync::method::SyncMethod;
use crate::sync::strobe::{StrobeDetector, StrobeWindow};
use crate::sync::trigger::{PulseSchedule, TriggerTiming};
use crossbeam_channel::Receiver;
use std::collections::VecDeque;

/// A strobe window is a frame's only if it starts within this fraction of a frame period of
/// where the clock fits place the frame's exposure start.
pub(crate) const MATCH_FRACTION: f64 = 0.3;

#[derive(Debug, Clone, Copy)]
struct Seen {
    seq: u64,
    window: StrobeWindow,
}

/// With the camera triggered by the DAQ, a strobe window further than this many samples from the
/// trigger's window says the trigger's wiring or delay is wrong (the strobe's edges are placed
/// within a sample).
pub(crate) const TRIGGER_CHECK_SAMPLES: f64 = 2.0;

/// Where the exposure windows come from.
enum Source {
    /// The strobe channel's edges (`strobe`).
    Strobe,
    /// The DAQ's trigger pulses (`trigger`); strobe windows, when the strobe is wired, check
    /// them.
    Trigger {
        schedule: PulseSchedule,
        strobe: VecDeque<StrobeWindow>,
        found: Vec<StrobeWindow>,
    },
}

/// Matches frames to exposure windows in the force stream (from the strobe channel, or from the
/// DAQ's trigger pulses) and averages the force over them.
pub(crate) struct StrobeLabeler {
    source: Source,
    detector: StrobeDetector,
    windows: VecDeque<Seen>,
    next_seq: u64,
    /// Frame id minus window sequence number, once a frame is matched.
    offset: Option<i64>,
    /// Places frames in the force stream by clock, to pick their window; keeps the samples the
    /// windows are averaged over.
    clock: ClockFitLabeler,
    /// Spans of sample indices that never arrived (the force reader fell behind and the device
    /// restarted, or the link lost them), newest last.
    gaps: VecDeque<(u64, u64)>,
    last_tick: Option<u64>,
}

impl StrobeLabeler {
    /// `threshold`: strobe level in volts; `clock`: the camera's exposure and tick rate and how
    /// the clock fits run; `latches`: timestamp-latch exchanges of the camera, when it offers
    /// them (without, the readout time is assumed: `clock.assumed_readout`).
    pub(crate) fn new(
        threshold: f64,
        clock: ClockFitOptions,
        latches: Option<Receiver<TimestampLatch>>,
    ) -> StrobeLabeler {
        StrobeLabeler {
            source: Source::Strobe,
            detector: StrobeDetector::new(threshold),
            windows: VecDeque::new(),
            next_seq: 0,
            offset: None,
            clock: ClockFitLabeler::new(clock, latches),
            gaps: VecDeque::new(),
            last_tick: None,
        }
    }

    /// Labels frames of a camera triggered by the DAQ with `timing` (method `trigger`): the
    /// windows are the trigger's; a strobe channel at `threshold`, when wired, checks them.
    pub(crate) fn triggered(
        timing: TriggerTiming,
        threshold: f64,
        clock: ClockFitOptions,
        latches: Option<Receiver<TimestampLatch>>,
    ) -> StrobeLabeler {
        StrobeLabeler {
            source: Source::Trigger {
                schedule: PulseSchedule::new(timing),
                strobe: VecDeque::new(),
                found: Vec::new(),
            },
            ..StrobeLabeler::new(threshold, clock, latches)
        }
    }

    fn add_window(&mut self, window: StrobeWindow) {
        self.windows.push_back(Seen {
            seq: self.next_seq,
            window,
        });
        self.next_seq += 1;
        if self.windows.len() > 500 {
            self.windows.pop_front();
        }
    }

    /// Feeds one force sample (in stream order). Samples without a strobe value count for
    /// averaging but find no strobe windows.
    pub(crate) fn push_sample(&mut self, s: &ForceSample) {
        self.clock.push_sample(s);
        let tick = s.device_tick;
        if let Some(last) = self.last_tick.replace(tick) {
            if tick > last + 1 {
                self.gaps.push_back((last + 1, tick));
                if self.gaps.len() > 100 {
                    self.gaps.pop_front();
                }
            }
        }
        let strobe = s.strobe.and_then(|volts| self.detector.push(tick, volts.0));
        match &mut self.source {
            Source::Strobe => {
                if let Some(window) = strobe {
                    self.add_window(window);
                }
            }
            Source::Trigger {
                schedule,
                strobe: seen,
                found,
            } => {
                if let Some(window) = strobe {
                    seen.push_back(window);
                    if seen.len() > 500 {
                        seen.pop_front();
                    }
                }
                schedule.push(tick, found);
                let mut new = std::mem::take(found);
                for window in new.drain(..) {
                    self.add_window(window);
                }
                if let Source::Trigger { found, .. } = &mut self.source {
                    *found = new;
                }
            }
        }
    }

    /// With the trigger's windows: the strobe window of `window`'s exposure, when the strobe is
    /// wired, if it disagrees by more than [`TRIGGER_CHECK_SAMPLES`].
    fn strobe_disagrees(&self, window: &StrobeWindow) -> Option<f64> {
        let Source::Trigger {
            schedule, strobe, ..
        } = &self.source
        else {
            return None;
        };
        let half = 0.5 * schedule.spacing();
        strobe
            .iter()
            .map(|s| s.start - window.start)
            .filter(|d| d.abs() < half)
            .min_by(|a, b| a.abs().total_cmp(&b.abs()))
            .filter(|d| d.abs() > TRIGGER_CHECK_SAMPLES)
    }

    /// Notes a delivered frame for the camera clock fit.
    pub(crate) fn observe_frame(&mut self, frame: &Frame) {
        self.clock.observe_frame(frame);
    }

    /// Sample period on the host time base, ns, from the force clock fit.
    fn sample_period_ns(&self) -> Option<f64> {
        self.clock.force_map().map(|m| m.ns_per_tick)
    }

    /// Samples between consecutive exposure starts (the trigger's, or the median over the strobe
    /// windows kept).
    fn spacing(&self) -> Option<f64> {
        if let Source::Trigger { schedule, .. } = &self.source {
            return Some(schedule.spacing());
        }
        let mut gaps: Vec<f64> = self
            .windows
            .iter()
            .zip(self.windows.iter().skip(1))
            .filter(|(a, b)| b.seq == a.seq + 1)
            .map(|(a, b)| b.window.start - a.window.start)
            .collect();
        if gaps.is_empty() {
            return None;
        }
        gaps.sort_by(f64::total_cmp);
        Some(gaps[gaps.len() / 2])
    }

    fn newest_tick(&self) -> f64 {
        self.clock.newest_tick()
    }

    fn label_of(&self, seen: &Seen) -> LabelOutcome {
        if let Some(off) = self.strobe_disagrees(&seen.window) {
            let ms = self.sample_period_ns().unwrap_or(f64::NAN) * 1e-6;
            return LabelOutcome::Unmatched(format!(
                "the strobe puts this exposure {:+.2} ms from where the trigger does: check the trigger's wiring and the camera's trigger delay",
                off * ms
            ));
        }
        let triggered = matches!(self.source, Source::Trigger { .. });
        match self
            .clock
            .mean_of_window(seen.window.start, seen.window.end)
        {
            None => LabelOutcome::NotYet,
            Some(Ok(mean)) => LabelOutcome::Ready(ExposureLabel {
                window_ticks: [seen.window.start, seen.window.end],
                window_host_ns: None,
                // The trigger's window is on the sample clock itself (the camera's delay taken as
                // its manual gives it); an edge placed by interpolation between two samples is
                // uniform over at most one sample period.
                error_ns: if triggered {
                    0.0
                } else {
                    self.sample_period_ns().unwrap_or(f64::NAN) / 12f64.sqrt()
                },
                mean,
            }),
            Some(Err(e)) => LabelOutcome::Unmatched(format!("{} window: {e}", self.method())),
        }
    }

    /// The lost span overlapping `ticks` (within a frame period), if any.
    fn lost_over(&self, ticks: [f64; 2]) -> Option<(u64, u64)> {
        let margin = self.spacing().unwrap_or(0.0);
        self.gaps
            .iter()
            .rev()
            .find(|(from, to)| {
                (*from as f64) < ticks[1] + margin && (*to as f64) > ticks[0] - margin
            })
            .copied()
    }

    /// The label of `frame`.
    pub(crate) fn label(&mut self, frame: &Frame) -> LabelOutcome {
        let placed = match self.clock.place(frame) {
            Placement::Window(w) => w,
            Placement::NotYet => return LabelOutcome::NotYet,
            Placement::Unavailable(why) => {
                return LabelOutcome::Unmatched(format!(
                    "{}: cannot place the frame: {why}",
                    self.method()
                ))
            }
        };
        let Some(spacing) = self.spacing() else {
            // Two windows give the frame period; until then, wait (a while).
            return if self.newest_tick() < placed.ticks[1] + 2000.0 {
                LabelOutcome::NotYet
            } else {
                LabelOutcome::Unmatched(
                    "no exposure windows in the strobe channel: is the camera's ExposureActive \
                     output wired to the DAQ's strobe input and enabled?"
                        .into(),
                )
            };
        };
        let accept = MATCH_FRACTION * spacing;
        let predicted = placed.ticks[0];
        // The window is still to come while the stream has not passed the placed exposure.
        let may_come = self.newest_tick() < placed.ticks[1] + spacing;
        if let Some(offset) = self.offset {
            let seq = frame.id as i64 - offset;
            if seq >= self.next_seq as i64 && may_come {
                return LabelOutcome::NotYet;
            }
            if let Some(seen) = self.windows.iter().find(|w| w.seq as i64 == seq).copied() {
                if (seen.window.start - predicted).abs() <= accept {
                    return self.label_of(&seen);
                }
            }
            // The sequence slipped (strobe windows lost or a restarted camera): match afresh.
            self.offset = None;
        }
        let best = self
            .windows
            .iter()
            .min_by(|a, b| {
                (a.window.start - predicted)
                    .abs()
                    .total_cmp(&(b.window.start - predicted).abs())
            })
            .copied();
        match best {
            Some(seen) if (seen.window.start - predicted).abs() <= accept => {
                self.offset = Some(frame.id as i64 - seen.seq as i64);
                self.label_of(&seen)
            }
            _ if may_come => LabelOutcome::NotYet,
            _ if self.lost_over(placed.ticks).is_some() => {
                let (from, to) = self.lost_over(placed.ticks).unwrap_or_default();
                LabelOutcome::Unmatched(format!(
                    "force samples {from}..{to} were lost over this exposure (the force reader fell behind and the device restarted, or its link lost them)"
                ))
            }
            best => {
                let ms = self.sample_period_ns().unwrap_or(f64::NAN) * 1e-6;
                let nearest = best.map_or(String::new(), |b| {
                    format!(
                        " (nearest {:.1} ms off)",
                        (b.window.start - predicted).abs() * ms
                    )
                });
                let readout = if placed.calibrated {
                    ""
                } else {
                    "; the camera gave no timestamp latches, so its readout time was assumed"
                };
                LabelOutcome::Unmatched(format!(
                    "no {} window within {:.1} ms of where the clock fits place the exposure{nearest}{readout}",
                    match self.source {
                        Source::Strobe => "strobe",
                        Source::Trigger { .. } => "trigger",
                    },
                    accept * ms
                ))
            }
        }
    }
}

impl StrobeLabeler {
    fn method(&self) -> SyncMethod {
        match self.source {
            Source::Strobe => SyncMethod::Strobe,
            Source::Trigger { .. } => SyncMethod::Trigger,
        }
    }
}

impl FrameLabeler for StrobeLabeler {
    fn method(&self) -> SyncMethod {
        StrobeLabeler::method(self)
    }

    fn push_sample(&mut self, sample: &ForceSample) {
        StrobeLabeler::push_sample(self, sample);
    }

    fn observe_frame(&mut self, frame: &Frame) {
        StrobeLabeler::observe_frame(self, frame);
    }

    fn label(&mut self, frame: &Frame) -> LabelOutcome {
        StrobeLabeler::label(self, frame)
    }

    fn estimated_error_ns(&self) -> Option<f64> {
        match self.source {
            Source::Strobe => self.sample_period_ns().map(|p| p / 12f64.sqrt()),
            Source::Trigger { .. } => Some(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acquire::synthetic::{self, sample_at, Bench, Labelled, SAMPLE_NS};
    use crate::units::Microseconds;
    use std::time::Duration;

    fn labeler(latches: Option<Receiver<TimestampLatch>>) -> StrobeLabeler {
        let mut options = ClockFitOptions::new(Microseconds(2000.0), 1e9);
        options.assumed_readout = Duration::from_millis(5);
        StrobeLabeler::new(1.65, options, latches)
    }

    fn label(bench: &Bench, with_latches: bool, seed: u64) -> Vec<Labelled> {
        let (tx, rx) = crossbeam_channel::unbounded();
        let mut l = labeler(with_latches.then_some(rx));
        synthetic::run(&mut l, synthetic::events(bench, seed), &tx)
    }

    /// The label's window starts on the frame's true exposure start (the strobe edge is
    /// interpolated between samples: within one sample) and its mean is the force of that
    /// window (Fz = host seconds, so its middle).
    fn assert_own_window(f: &Labelled) {
        let LabelOutcome::Ready(label) = &f.outcome else {
            panic!("frame {}: {:?}", f.id, f.outcome);
        };
        let start = sample_at(f.true_start);
        assert!(
            (label.window_ticks[0] - start).abs() <= 1.0,
            "frame {}: window starts at sample {:.2}, exposure at {start:.2}",
            f.id,
            label.window_ticks[0]
        );
        let mid_ns = (label.mean.mean[2] * 1e9 - f.true_start - 1e6).abs();
        assert!(
            mid_ns < SAMPLE_NS,
            "frame {}: mean off by {mid_ns} ns",
            f.id
        );
    }

    /// Frames delivered 1.5 to 3.5 frame periods after their exposure (a slow renderer, a busy
    /// host, a long transfer), randomly: an arrival says nothing about which window is a
    /// frame's own, yet every frame gets it (the latched camera clock places it).
    #[test]
    fn frames_delivered_periods_late_get_their_own_window() {
        let mut bench = Bench::new();
        bench.delivery_ns = Box::new(|_, rng| rng.range(30e6..70e6));
        let labelled = label(&bench, true, 3);
        assert!(labelled.len() > 900, "{} frames", labelled.len());
        // The fits need a second of data; frames from then on are all labelled.
        for f in labelled.iter().filter(|f| f.true_start > 2.5e9) {
            assert_own_window(f);
        }
        let early = labelled.iter().filter(|f| f.true_start <= 2.5e9);
        assert!(early.clone().all(|f| f.outcome != LabelOutcome::NotYet));
        // Frames waiting for the first fits are labelled too once it is made.
        assert!(early
            .filter(|f| matches!(f.outcome, LabelOutcome::Ready(_)))
            .all(|f| {
                assert_own_window(f);
                true
            }));
    }

    /// Without latches, the camera clock is placed by the least-delayed frames and the assumed
    /// readout; with a readout close to the assumption every frame is matched, and a 60 ms host
    /// stall of a few frames does not move them onto a neighbour's window.
    #[test]
    fn without_latches_the_assumed_readout_places_frames() {
        let mut bench = Bench::new();
        bench.delivery_ns = Box::new(|n, rng| {
            let stall = if (400..404).contains(&n) { 60e6 } else { 0.0 };
            4e6 + rng.range(0.0..3e6) + stall
        });
        let labelled = label(&bench, false, 4);
        let scored: Vec<&Labelled> = labelled.iter().filter(|f| f.true_start > 5e9).collect();
        assert!(scored.len() > 700);
        scored.iter().for_each(|f| assert_own_window(f));
    }

    /// Dropped frames (id gaps) keep the match: the frames after a gap take their own windows.
    #[test]
    fn dropped_frames_leave_the_others_on_their_windows() {
        let mut bench = Bench::new();
        bench.dropped = vec![300, 301, 302, 555];
        let labelled = label(&bench, true, 5);
        assert!(labelled
            .iter()
            .all(|f| ![1300, 1301, 1302, 1555].contains(&f.id)));
        for f in labelled.iter().filter(|f| f.true_start > 5e9) {
            assert_own_window(f);
        }
    }

    /// Strobe pulses lost (a loose wire for 60 ms): those frames have no window and say so;
    /// the frames after them are matched afresh to their own windows, not shifted by three.
    #[test]
    fn lost_strobe_pulses_leave_those_frames_unlabelled_and_no_others() {
        let mut bench = Bench::new();
        bench.strobe_lost = 500..503;
        let labelled = label(&bench, true, 6);
        for f in labelled.iter().filter(|f| f.true_start > 5e9) {
            if (1500..1503).contains(&f.id) {
                let LabelOutcome::Unmatched(why) = &f.outcome else {
                    panic!("frame {} has no strobe pulse but got {:?}", f.id, f.outcome);
                };
                assert!(why.contains("no strobe window within"), "{why}");
            } else {
                assert_own_window(f);
            }
        }
    }

    /// Force samples lost over three exposures (the reader fell behind and the DAQ restarted):
    /// those frames say so, every other frame keeps its own window.
    #[test]
    fn frames_over_lost_force_samples_say_the_samples_were_lost() {
        let mut bench = Bench::new();
        let from = sample_at(bench.exposure_start(500)).floor() as u64 - 5;
        let to = sample_at(bench.exposure_start(503)).floor() as u64 - 5;
        bench.samples_lost = from..to;
        let labelled = label(&bench, true, 8);
        let mut lost = 0;
        for f in labelled.iter().filter(|f| f.true_start > 5e9) {
            if (1500..1503).contains(&f.id) {
                let LabelOutcome::Unmatched(why) = &f.outcome else {
                    panic!(
                        "frame {} has no force samples but got {:?}",
                        f.id, f.outcome
                    );
                };
                assert!(
                    why.contains(&format!("force samples {from}..{to} were lost")),
                    "{why}"
                );
                lost += 1;
            } else {
                assert_own_window(f);
            }
        }
        assert_eq!(lost, 3);
    }

    /// No strobe in the force stream: a clear error naming the wiring, not a label.
    #[test]
    fn a_missing_strobe_is_reported() {
        let mut bench = Bench::new();
        bench.seconds = 6.0;
        bench.strobe = false;
        let labelled = label(&bench, true, 7);
        let late: Vec<&Labelled> = labelled.iter().filter(|f| f.true_start > 2.5e9).collect();
        assert!(!late.is_empty());
        for f in late {
            match &f.outcome {
                LabelOutcome::Unmatched(why) => assert!(why.contains("ExposureActive"), "{why}"),
                LabelOutcome::NotYet => {} // the last frames of the stream
                other => panic!("frame {}: {other:?}", f.id),
            }
        }
    }
}
