//! Labels frames with the force measured during their exposure by mapping both device clocks
//! onto host time (synchronisation method `clock-fit`, hardware.md E.3 and E.4).
//!
//! - **Force clock**: the force stream's sample counter (`device_tick`) against each sample's
//!   host arrival, fitted by the one-way lower-hull fit ([`crate::sync::one_way`]). Samples come
//!   in blocks stamped with one arrival time, so only the lower-hull vertices of every run of
//!   [`HULL_BIN`] samples are kept (a vertex of the hull of all points is a vertex of the hull of
//!   its run, so nothing the fit would use is lost). The fitted line gives the host arrival of
//!   the least-delayed sample; that minimum delay (a driver callback's latency) is a constant this
//!   method cannot see ([`ClockFitOptions::force_latency`] takes it from a strobe calibration;
//!   the error estimate leaves it out).
//! - **Camera clock**: frame device timestamps against frame arrivals, calibrated by
//!   timestamp latches when the camera gives them: [`crate::sync::camera_clock`], the one camera
//!   clock (`fringe stream` places exposures with it too).
//! - **Window**: [device timestamp, + exposure time] in camera ticks -> host time (camera map)
//!   -> fractional force sample index (force map), and the six-axis force averaged over it with
//!   [`crate::sync::window::mean_over`] (interpolated at the edges).
//!
//! Fits use the last [`ClockFitOptions::fit_window`] of data and are redone when
//! [`ClockFitOptions::refit_every`] of new data has come in.

use super::labeler::{ExposureLabel, FrameLabeler, LabelOutcome};
use crate::camera::{Frame, TimestampLatch};
use crate::clock::HostTime;
use crate::force::ForceSample;
use crate::sync::camera_clock::{CameraClock, CameraClockOptions};
use crate::sync::clock_map::ClockMap;
use crate::sync::method::SyncMethod;
use crate::sync::one_way::{self, lower_hull, OneWayFit, OneWayOptions};
use crate::sync::window::{mean_over, WindowError, WindowMean};
use crate::units::Microseconds;
use crossbeam_channel::Receiver;
use std::collections::VecDeque;
use std::time::Duration;

/// Force samples per run whose lower-hull vertices are kept for the force clock fit.
pub(crate) const HULL_BIN: usize = 250;

/// Settings of a [`ClockFitLabeler`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ClockFitOptions {
    /// Exposure time set on the camera.
    pub exposure: Microseconds,
    /// Camera device timestamp ticks per second ([`crate::camera::CameraInfo::tick_frequency`]).
    pub camera_tick_hz: f64,
    /// History each fit uses.
    pub fit_window: Duration,
    /// Refit when this much new data has arrived.
    pub refit_every: Duration,
    /// How long after the first frame to wait for three latches before labelling without them
    /// (when a latch channel was given).
    pub latch_wait: Duration,
    /// Exposure end to the least-delayed frame arrival (readout + transfer) assumed when no
    /// latch calibrates it; zero by default (frames placed as if read out at once).
    pub assumed_readout: Duration,
    /// 1-sigma error put on the unseen readout + transfer time when no latch calibrates it.
    pub uncalibrated_latency_error: Duration,
    /// The force path's minimum delivery delay (sample taken -> least-delayed arrival), if known
    /// from a calibration against the strobe; zero otherwise. The one-way fit cannot see it: an
    /// uncorrected delay places windows this much too early in the force stream.
    pub force_latency: Duration,
}

impl ClockFitOptions {
    /// Defaults for a camera with `exposure` and `camera_tick_hz`: 60 s fits redone every 0.5 s,
    /// 3 s wait for latches, 5 ms uncertainty without them.
    pub(crate) fn new(exposure: Microseconds, camera_tick_hz: f64) -> ClockFitOptions {
        ClockFitOptions {
            exposure,
            camera_tick_hz,
            fit_window: Duration::from_secs(60),
            refit_every: Duration::from_millis(500),
            latch_wait: Duration::from_secs(3),
            assumed_readout: Duration::ZERO,
            uncalibrated_latency_error: Duration::from_millis(5),
            force_latency: Duration::ZERO,
        }
    }
}

/// A frame's exposure as the clock fits place it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PlacedWindow {
    /// Exposure start and end in the force stream's fractional sample index.
    pub ticks: [f64; 2],
    /// The same on the host time base, ns.
    pub host_ns: [f64; 2],
    /// 1-sigma error of the placement, ns.
    pub error_ns: f64,
    /// Whether timestamp latches calibrated the camera clock (else the readout is assumed).
    pub calibrated: bool,
}

/// What [`ClockFitLabeler::place`] found.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Placement {
    Window(PlacedWindow),
    /// The fits need more data (or are waiting for latches): ask again later.
    NotYet,
    /// The fits cannot be made; the reason.
    Unavailable(String),
}

/// Maps both clocks to host time and averages the force over each frame's exposure window.
pub(crate) struct ClockFitLabeler {
    options: ClockFitOptions,
    /// (sample index, six channels), newest last, for the window means.
    samples: VecDeque<(u64, [f64; 6])>,
    keep_samples: usize,
    /// Lower-hull vertices of past runs of samples (tick, arrival), oldest first.
    force_points: VecDeque<(u64, HostTime)>,
    /// The current run of samples, not yet reduced to its hull.
    force_run: Vec<(u64, HostTime)>,
    force_fit: Option<OneWayFit>,
    force_fit_at: Option<HostTime>,
    newest_arrival: Option<HostTime>,
    camera: CameraClock,
    last_error_ns: Option<f64>,
}

impl ClockFitLabeler {
    /// A labeler; `latches` brings timestamp-latch exchanges when the camera offers them.
    pub(crate) fn new(
        options: ClockFitOptions,
        latches: Option<Receiver<TimestampLatch>>,
    ) -> ClockFitLabeler {
        let camera = CameraClock::new(
            CameraClockOptions {
                exposure: options.exposure,
                tick_hz: options.camera_tick_hz,
                fit_window: options.fit_window,
                refit_every: options.refit_every,
                assumed_readout: options.assumed_readout,
                uncalibrated_latency_error: options.uncalibrated_latency_error,
            },
            latches,
        );
        ClockFitLabeler {
            options,
            samples: VecDeque::new(),
            keep_samples: 40_000,
            force_points: VecDeque::new(),
            force_run: Vec::with_capacity(HULL_BIN),
            force_fit: None,
            force_fit_at: None,
            newest_arrival: None,
            camera,
            last_error_ns: None,
        }
    }

    fn window_ns(&self) -> u64 {
        self.options.fit_window.as_nanos() as u64
    }

    /// Feeds one force sample, in stream order.
    pub(crate) fn push_sample(&mut self, s: &ForceSample) {
        self.samples.push_back((s.device_tick, s.wrench.to_array()));
        if self.samples.len() > self.keep_samples {
            self.samples.pop_front();
        }
        self.newest_arrival = Some(
            self.newest_arrival
                .map_or(s.host_time, |t| t.max(s.host_time)),
        );
        // A counter that went backwards (a restarted device) starts the fit afresh.
        if self
            .force_run
            .last()
            .or(self.force_points.back())
            .is_some_and(|&(t, _)| s.device_tick <= t)
        {
            self.force_points.clear();
            self.force_run.clear();
            self.force_fit = None;
            self.samples.clear();
            self.samples.push_back((s.device_tick, s.wrench.to_array()));
        }
        self.force_run.push((s.device_tick, s.host_time));
        if self.force_run.len() >= HULL_BIN {
            let run = std::mem::take(&mut self.force_run);
            self.force_points.extend(hull_vertices(&run));
            let horizon = s.host_time.0.saturating_sub(self.window_ns());
            while self.force_points.front().is_some_and(|p| p.1 .0 < horizon) {
                self.force_points.pop_front();
            }
        }
    }

    /// Notes a frame's device timestamp and arrival for the camera clock fit.
    pub(crate) fn observe_frame(&mut self, frame: &Frame) {
        self.camera.observe(frame);
    }

    fn refit_force(&mut self) {
        let Some(newest) = self.newest_arrival else {
            return;
        };
        let fresh = self.force_fit_at.is_some_and(|at| {
            newest.0.saturating_sub(at.0) < self.options.refit_every.as_nanos() as u64
        });
        if fresh && self.force_fit.is_some() {
            return;
        }
        let mut pairs: Vec<(u64, HostTime)> = self.force_points.iter().copied().collect();
        pairs.extend(hull_vertices(&self.force_run));
        let (Some(first), Some(last)) = (pairs.first(), pairs.last()) else {
            return;
        };
        let ticks = last.0.saturating_sub(first.0);
        let span_ns = last.1 .0 as f64 - first.1 .0 as f64;
        // A second of data before the first fit.
        if ticks == 0 || span_ns < 1e9 {
            return;
        }
        let options = OneWayOptions {
            clock: "force sample counter".into(),
            nominal_ns_per_tick: span_ns / ticks as f64,
            max_early_ns: 5e6,
        };
        if let Ok(fit) = one_way::fit(&pairs, &options) {
            self.force_fit = Some(fit);
            self.force_fit_at = Some(newest);
        }
    }

    fn waiting_for_latches(&self, now: HostTime) -> bool {
        self.camera.awaits_latches()
            && self.camera.first_frame().is_some_and(|t| {
                now.0.saturating_sub(t.0) < self.options.latch_wait.as_nanos() as u64
            })
    }

    /// Where `frame`'s exposure lies in the force stream and on the host time base, as the
    /// clock fits place it now.
    pub(crate) fn place(&mut self, frame: &Frame) -> Placement {
        if self.camera.is_empty() {
            self.observe_frame(frame);
        }
        self.refit_force();
        let camera = self.camera.fitted();
        let now = self.newest_arrival.unwrap_or(frame.host_arrival);
        let (Some(force), Some(camera)) = (&self.force_fit, camera) else {
            // Fits need a second of force data and ten frames.
            return if now.0.saturating_sub(frame.host_arrival.0) < 10_000_000_000 {
                Placement::NotYet
            } else {
                Placement::Unavailable("clock-fit: not enough data for the clock fits".into())
            };
        };
        if !camera.calibrated && self.waiting_for_latches(now) {
            return Placement::NotYet;
        }
        let exposure = self.camera.place(&camera, frame);
        let [start_host, end_host] = exposure.host_ns;
        let latency = self.options.force_latency.as_nanos() as f64;
        let force_error = force.hull_gap_ns;
        Placement::Window(PlacedWindow {
            ticks: [
                force.map.ticks_at(start_host + latency),
                force.map.ticks_at(end_host + latency),
            ],
            host_ns: [start_host, end_host],
            error_ns: (force_error * force_error + camera.error_ns * camera.error_ns).sqrt(),
            calibrated: camera.calibrated,
        })
    }

    /// The label of `frame`.
    pub(crate) fn label(&mut self, frame: &Frame) -> LabelOutcome {
        let placed = match self.place(frame) {
            Placement::Window(w) => w,
            Placement::NotYet => return LabelOutcome::NotYet,
            Placement::Unavailable(why) => return LabelOutcome::Unmatched(why),
        };
        let [start, end] = placed.ticks;
        let Some(mean) = self.mean_of_window(start, end) else {
            return LabelOutcome::NotYet;
        };
        self.last_error_ns = Some(placed.error_ns);
        match mean {
            Ok(mean) => LabelOutcome::Ready(ExposureLabel {
                window_ticks: [start, end],
                window_host_ns: Some(placed.host_ns),
                error_ns: placed.error_ns,
                mean,
            }),
            Err(e) => LabelOutcome::Unmatched(format!("clock-fit window: {e}")),
        }
    }

    /// Index of the newest force sample kept (-inf before the first).
    pub(crate) fn newest_tick(&self) -> f64 {
        self.samples
            .back()
            .map_or(f64::NEG_INFINITY, |s| s.0 as f64)
    }

    /// The six-axis force averaged over the fractional sample indices [`start`, `end`] of the
    /// force stream (interpolated at the edges); `None` while the stream has not passed `end`.
    pub(crate) fn mean_of_window(
        &self,
        start: f64,
        end: f64,
    ) -> Option<Result<WindowMean, WindowError>> {
        if self.newest_tick() < end + 1.0 {
            return None;
        }
        // From the last sample at or before the start to the first at or after the end (a gap
        // of lost samples is bridged; the recorder notes it from the spacing).
        let first = self
            .samples
            .partition_point(|s| s.0 as f64 <= start)
            .saturating_sub(1);
        let last = self
            .samples
            .partition_point(|s| (s.0 as f64) < end)
            .min(self.samples.len().saturating_sub(1));
        let span: Vec<(f64, [f64; 6])> = self
            .samples
            .range(first..=last)
            .map(|s| (s.0 as f64, s.1))
            .collect();
        Some(mean_over(&span, start, end))
    }

    /// The current force clock map (sample index -> host ns), if fitted.
    pub(crate) fn force_map(&self) -> Option<ClockMap> {
        self.force_fit.as_ref().map(|f| f.map)
    }
}

/// The lower-hull vertices of `run` (sorted by tick), as (tick, arrival).
fn hull_vertices(run: &[(u64, HostTime)]) -> Vec<(u64, HostTime)> {
    let Some(&(t0, h0)) = run.first() else {
        return Vec::new();
    };
    // The hull is unchanged by adding a linear function of x, so raw coordinates will do.
    let pts: Vec<(f64, f64)> = run
        .iter()
        .map(|&(t, h)| ((t - t0) as f64, h.0 as f64 - h0.0 as f64))
        .collect();
    lower_hull(&pts).into_iter().map(|i| run[i]).collect()
}

impl FrameLabeler for ClockFitLabeler {
    fn method(&self) -> SyncMethod {
        SyncMethod::ClockFit
    }

    fn push_sample(&mut self, sample: &ForceSample) {
        ClockFitLabeler::push_sample(self, sample);
    }

    fn observe_frame(&mut self, frame: &Frame) {
        ClockFitLabeler::observe_frame(self, frame);
    }

    fn label(&mut self, frame: &Frame) -> LabelOutcome {
        ClockFitLabeler::label(self, frame)
    }

    fn estimated_error_ns(&self) -> Option<f64> {
        self.last_error_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acquire::synthetic::{self, sample_at, sample_host, Bench};

    /// Labels of the synthetic bench's frames (strobe not used) whose true exposure starts
    /// after 11 s, with that start (host ns).
    fn run(bench: &Bench, with_latches: bool) -> Vec<(ExposureLabel, f64)> {
        let (tx, rx) = crossbeam_channel::unbounded();
        let mut l = ClockFitLabeler::new(
            ClockFitOptions::new(Microseconds(2000.0), 1e9),
            with_latches.then_some(rx),
        );
        synthetic::run(&mut l, synthetic::events(bench, 11), &tx)
            .into_iter()
            .filter(|f| f.true_start > 11e9)
            .map(|f| match f.outcome {
                LabelOutcome::Ready(label) => (label, f.true_start),
                other => panic!("frame {}: {other:?}", f.id),
            })
            .collect()
    }

    fn quiet() -> Bench {
        let mut bench = Bench::new();
        bench.seconds = 21.0;
        bench.strobe = false;
        bench
    }

    #[test]
    fn windows_land_on_the_true_exposure_in_both_clocks() {
        let labels = run(&quiet(), true);
        assert!(labels.len() > 450, "{} labels", labels.len());
        for (label, start) in &labels {
            let mid_true = start + 1e6;
            let host = label.window_host_ns.expect("host window");
            let err_host = 0.5 * (host[0] + host[1]) - mid_true;
            // The window in the force stream, back to true host time through the true clock.
            let mid_ticks = 0.5 * (label.window_ticks[0] + label.window_ticks[1]);
            let err_force = sample_host(0) + mid_ticks * synthetic::SAMPLE_NS - mid_true;
            assert!(
                err_host.abs() < 100_000.0,
                "camera map off by {err_host} ns"
            );
            assert!(
                err_force.abs() < 100_000.0,
                "force map off by {err_force} ns"
            );
            // Fz is host seconds: its window mean is the window's middle in true time.
            let fz_err_ns = (label.mean.mean[2] - mid_true * 1e-9) * 1e9;
            assert!(
                (fz_err_ns - err_force).abs() < 1_000.0,
                "{fz_err_ns} vs {err_force}"
            );
            assert!(
                label.error_ns > 0.0 && label.error_ns < 200_000.0,
                "{label:?}"
            );
        }
    }

    /// Frames delivered 30-70 ms after their exposure (a busy host, a slow transfer): the
    /// arrivals give a poor rate, the latches a good one, and every window still lands within
    /// 0.5 ms of the exposure, from the first frames on.
    #[test]
    fn widely_varying_delivery_delays_leave_the_latched_clock_right() {
        let mut bench = quiet();
        bench.delivery_ns = Box::new(|_, rng| rng.range(30e6..70e6));
        let (tx, rx) = crossbeam_channel::unbounded();
        let mut l = ClockFitLabeler::new(ClockFitOptions::new(Microseconds(2000.0), 1e9), Some(rx));
        let labelled = synthetic::run(&mut l, synthetic::events(&bench, 12), &tx);
        let ready: Vec<_> = labelled
            .iter()
            .filter_map(|f| match &f.outcome {
                LabelOutcome::Ready(label) => Some((label, f.true_start)),
                _ => None,
            })
            .collect();
        assert!(ready.len() > 900, "{} labelled", ready.len());
        for (label, start) in ready {
            let err_samples = label.window_ticks[0] - sample_at(start);
            assert!(
                err_samples.abs() < 2.5,
                "window off by {err_samples:.1} samples at {:.2} s",
                start * 1e-9
            );
        }
    }

    #[test]
    fn without_latches_the_unseen_readout_shows_in_the_window_and_the_error() {
        let labels = run(&quiet(), false);
        assert!(labels.len() > 450);
        let (label, start) = &labels[labels.len() / 2];
        let host = label.window_host_ns.expect("host window");
        let err = 0.5 * (host[0] + host[1]) - (start + 1e6);
        // Placed as if the frame arrived when its exposure ended: 5 ms of readout late.
        assert!((err - 5e6).abs() < 200_000.0, "{err}");
        assert!(label.error_ns >= 5e6, "{label:?}");
    }
}
