//! The camera's clock on the host time base: where a frame's exposure lies in host time.
//!
//! Frame device timestamps (exposure start, Basler chunk timestamp) against frame arrivals are
//! fitted by the one-way lower-hull fit ([`super::one_way`]). That line is late by the constant
//! exposure + readout + transfer time; timestamp-latch exchanges, taken by the camera stream
//! thread between frames ([`crate::CameraStream::spawn_with_latches`]) and fitted by
//! [`super::latch`], calibrate that constant: the one-way line is shifted onto the latch line at
//! the latches' centre, or, when the latches know the clock rate better than the arrivals do (a
//! short history, or delivery delays that vary by many ms), the latch line is used as it is.
//! Without latches the exposure end is placed at the least-delayed arrival less an assumed
//! readout, and the error says so.
//!
//! The scan's `clock-fit` and `strobe` labelers place frames with it (in the force stream as
//! well), and `fringe stream` stamps each frame's exposure with it, with no force sensor at all.
//! Fits use the last [`CameraClockOptions::fit_window`] of frames and are redone when about
//! [`CameraClockOptions::refit_every`] of new frames have come in.

use super::clock_map::ClockMap;
use super::latch::{self, LatchFit};
use super::one_way::{self, OneWayFit, OneWayOptions};
use crate::camera::{Frame, TimestampLatch};
use crate::clock::HostTime;
use crate::units::Microseconds;
use crossbeam_channel::Receiver;
use std::collections::VecDeque;
use std::time::Duration;

/// Frames the first one-way fit needs.
const MIN_FRAMES: usize = 10;

/// Settings of a [`CameraClock`].
#[derive(Debug, Clone, PartialEq)]
pub struct CameraClockOptions {
    /// Exposure time set on the camera.
    pub exposure: Microseconds,
    /// Camera device timestamp ticks per second ([`crate::CameraInfo::tick_frequency`]).
    pub tick_hz: f64,
    /// History each fit uses.
    pub fit_window: Duration,
    /// Refit when this much new data has arrived.
    pub refit_every: Duration,
    /// Exposure end to the least-delayed frame arrival (readout + transfer) assumed when no
    /// latch calibrates it; zero by default (frames placed as if read out at once).
    pub assumed_readout: Duration,
    /// 1-sigma error put on the unseen readout + transfer time when no latch calibrates it.
    pub uncalibrated_latency_error: Duration,
}

impl CameraClockOptions {
    /// Defaults for a camera with `exposure` and `tick_hz`: 60 s fits redone every 0.5 s, 5 ms
    /// uncertainty without latches.
    pub fn new(exposure: Microseconds, tick_hz: f64) -> CameraClockOptions {
        CameraClockOptions {
            exposure,
            tick_hz,
            fit_window: Duration::from_secs(60),
            refit_every: Duration::from_millis(500),
            assumed_readout: Duration::ZERO,
            uncalibrated_latency_error: Duration::from_millis(5),
        }
    }
}

/// The camera clock as currently fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FittedClock {
    /// Camera ticks -> host time of the event they stamp.
    pub map: ClockMap,
    /// 1-sigma error of a mapped time, ns.
    pub error_ns: f64,
    pub calibrated: bool,
}

/// A frame's exposure on the host time base.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    /// Start and end, host ns (fractional).
    pub host_ns: [f64; 2],
    /// 1-sigma error of the placement, ns.
    pub error_ns: f64,
    /// Whether timestamp latches calibrated the clock (else the readout is assumed).
    pub calibrated: bool,
}

impl Exposure {
    /// The end of the exposure, host time (rounded to the ns, clamped at the epoch).
    pub fn end(&self) -> HostTime {
        HostTime(self.host_ns[1].round().max(0.0) as u64)
    }
}

/// Fits the camera's clock onto host time from the frames and latches it is given.
pub struct CameraClock {
    options: CameraClockOptions,
    /// (device timestamp, arrival) of every frame seen, oldest first.
    frames: VecDeque<(u64, HostTime)>,
    first_frame: Option<HostTime>,
    frames_at_fit: usize,
    one_way: Option<OneWayFit>,
    latch_source: Option<Receiver<TimestampLatch>>,
    latches: VecDeque<TimestampLatch>,
    latch_fit: Option<LatchFit>,
    fitted: Option<FittedClock>,
}

impl std::fmt::Debug for CameraClock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CameraClock")
            .field("frames", &self.frames.len())
            .field("latches", &self.latches.len())
            .field("fitted", &self.fitted)
            .finish()
    }
}

/// The spread of the latch `ticks` about their mean, in ns at `ns_per_tick`: the root of the
/// sum of squared distances.
fn tick_spread_ns(ticks: &[u64], ns_per_tick: f64) -> f64 {
    let mean_tick = ticks.iter().map(|&t| t as f64).sum::<f64>() / ticks.len() as f64;
    ticks
        .iter()
        .map(|&t| ((t as f64 - mean_tick) * ns_per_tick).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The one-way line `ow` shifted onto the latch line `lf` at the latches' centre (`ticks`);
/// what is left between the two lines at the latches adds to the latch line's error `line`.
fn one_way_on_latch_line(ow: &OneWayFit, lf: &LatchFit, ticks: &[u64], line: f64) -> FittedClock {
    let diffs: Vec<f64> = ticks
        .iter()
        .map(|&t| ow.map.host_ns(t) - lf.map.host_ns(t))
        .collect();
    let offset = diffs.iter().sum::<f64>() / diffs.len().max(1) as f64;
    let disagreement = (diffs.iter().map(|d| (d - offset).powi(2)).sum::<f64>()
        / diffs.len().max(1) as f64)
        .sqrt();
    let mut map = ow.map;
    map.host_at_origin_ns -= offset;
    FittedClock {
        map,
        error_ns: (line * line + disagreement * disagreement).sqrt(),
        calibrated: true,
    }
}

impl CameraClock {
    /// A camera clock; `latches` brings timestamp-latch exchanges when the camera offers them.
    pub fn new(
        options: CameraClockOptions,
        latches: Option<Receiver<TimestampLatch>>,
    ) -> CameraClock {
        CameraClock {
            options,
            frames: VecDeque::new(),
            first_frame: None,
            frames_at_fit: 0,
            one_way: None,
            latch_source: latches,
            latches: VecDeque::new(),
            latch_fit: None,
            fitted: None,
        }
    }

    fn window_ns(&self) -> u64 {
        self.options.fit_window.as_nanos() as u64
    }

    /// Notes a frame's device timestamp and arrival.
    pub fn observe(&mut self, frame: &Frame) {
        self.first_frame.get_or_insert(frame.host_arrival);
        if self
            .frames
            .back()
            .is_some_and(|&(d, _)| frame.device_timestamp <= d)
        {
            // The camera clock restarted: the old pairs belong to another clock.
            self.frames.clear();
            self.one_way = None;
            self.fitted = None;
        }
        self.frames
            .push_back((frame.device_timestamp, frame.host_arrival));
        let horizon = frame.host_arrival.0.saturating_sub(self.window_ns());
        while self.frames.front().is_some_and(|p| p.1 .0 < horizon) {
            self.frames.pop_front();
        }
    }

    /// True before the first frame is observed.
    pub(crate) fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The arrival of the first frame observed.
    pub(crate) fn first_frame(&self) -> Option<HostTime> {
        self.first_frame
    }

    /// True when a latch channel was given and no latch fit has been made yet.
    pub(crate) fn awaits_latches(&self) -> bool {
        self.latch_source.is_some() && self.latch_fit.is_none()
    }

    /// The clock as fitted now, refitted first when frames or latches came in since the last
    /// fit.
    pub(crate) fn fitted(&mut self) -> Option<FittedClock> {
        self.refit();
        self.fitted
    }

    /// Where `frame`'s exposure lies on the host time base ([`Self::observe`] it first); `None`
    /// until ten frames have been seen.
    pub fn exposure(&mut self, frame: &Frame) -> Option<Exposure> {
        let clock = self.fitted()?;
        Some(self.place(&clock, frame))
    }

    /// `frame`'s exposure on the host time base by `clock`.
    pub(crate) fn place(&self, clock: &FittedClock, frame: &Frame) -> Exposure {
        let start_ticks = frame.device_timestamp;
        let exposure_ticks = self.options.exposure.0 * 1e-6 * self.options.tick_hz;
        Exposure {
            host_ns: [
                clock.map.host_ns(start_ticks),
                clock.map.host_ns_f(start_ticks as f64 + exposure_ticks),
            ],
            error_ns: clock.error_ns,
            calibrated: clock.calibrated,
        }
    }

    fn drain_latches(&mut self) -> bool {
        let Some(source) = &self.latch_source else {
            return false;
        };
        let mut got = false;
        while let Ok(l) = source.try_recv() {
            self.latches.push_back(l);
            got = true;
        }
        let newest = self.latches.back().map_or(0, |l| l.host_after.0);
        let horizon = newest.saturating_sub(self.window_ns());
        while self
            .latches
            .front()
            .is_some_and(|l| l.host_before.0 < horizon)
        {
            self.latches.pop_front();
        }
        got
    }

    /// Refits the clock when frames or latches came in since the last fit.
    fn refit(&mut self) {
        let new_latches = self.drain_latches();
        let stale = self.frames.len() != self.frames_at_fit;
        if !(stale || new_latches) && self.fitted.is_some() {
            return;
        }
        self.refit_one_way();
        if new_latches || self.latch_fit.is_none() {
            let all: Vec<TimestampLatch> = self.latches.iter().copied().collect();
            self.latch_fit = latch::fit(&all, "camera").ok();
        }
        let Some(ow) = &self.one_way else {
            return;
        };
        self.fitted = Some(match &self.latch_fit {
            Some(lf) => self.latch_calibrated(ow, lf),
            None => self.uncalibrated(ow),
        });
    }

    /// Refits the one-way line of the frames when enough new frames came in (about every
    /// `refit_every`), the frames were cut back, or there is no fit yet; at least ten frames.
    fn refit_one_way(&mut self) {
        let refit_frames = self.one_way.is_none()
            || self.frames.len() < self.frames_at_fit
            || self.frames.len() >= self.frames_at_fit + self.frames_per_refit();
        if refit_frames && self.frames.len() >= MIN_FRAMES {
            let pairs: Vec<(u64, HostTime)> = self.frames.iter().copied().collect();
            let options = OneWayOptions {
                clock: "camera".into(),
                nominal_ns_per_tick: 1e9 / self.options.tick_hz,
                max_early_ns: 5e6,
            };
            if let Ok(fit) = one_way::fit(&pairs, &options) {
                self.one_way = Some(fit);
                self.frames_at_fit = self.frames.len();
            }
        }
    }

    /// The clock from the latch line `lf`, or from the one-way line `ow` moved onto it when the
    /// frames know the rate better than the latches.
    fn latch_calibrated(&self, ow: &OneWayFit, lf: &LatchFit) -> FittedClock {
        // The latch line's own error at its centre: each kept midpoint is uniform within
        // its half round trip, or scattered as the residuals say, whichever is larger.
        let per_latch = lf.rms_residual_ns.max(lf.half_round_trip_ns / 3f64.sqrt());
        let line = per_latch / (lf.used as f64).sqrt();
        let ticks: Vec<u64> = self.latches.iter().map(|l| l.device_ticks).collect();
        // Which line knows the rate better: the one-way line (frames over a long span
        // with steady delays) or the latch line (latches over a short one, or frames
        // delivered with widely varying delays)?
        let latch_rate_error = per_latch / tick_spread_ns(&ticks, lf.map.ns_per_tick).max(1.0);
        let frames_span_ns = match (self.frames.front(), self.frames.back()) {
            (Some(a), Some(b)) => (b.0 - a.0) as f64 * ow.map.ns_per_tick,
            _ => 0.0,
        };
        let one_way_rate_error = 2.0 * ow.hull_gap_ns / frames_span_ns.max(1.0);
        if latch_rate_error < one_way_rate_error {
            FittedClock {
                map: lf.map,
                error_ns: line,
                calibrated: true,
            }
        } else {
            one_way_on_latch_line(ow, lf, &ticks, line)
        }
    }

    /// The clock from the one-way line `ow` alone: the least-delayed frame arrived the assumed
    /// readout after its exposure ended.
    fn uncalibrated(&self, ow: &OneWayFit) -> FittedClock {
        let exposure_ns =
            self.options.exposure.0 * 1e3 + self.options.assumed_readout.as_nanos() as f64;
        let mut map = ow.map;
        map.host_at_origin_ns -= exposure_ns;
        let unseen = self.options.uncalibrated_latency_error.as_nanos() as f64;
        FittedClock {
            map,
            error_ns: (ow.hull_gap_ns.powi(2) + unseen * unseen).sqrt(),
            calibrated: false,
        }
    }

    /// Frames between refits (about `refit_every` at the observed frame rate).
    fn frames_per_refit(&self) -> usize {
        let (Some(a), Some(b)) = (self.frames.front(), self.frames.back()) else {
            return 1;
        };
        let span = b.1 .0.saturating_sub(a.1 .0) as f64;
        if span <= 0.0 {
            return 1;
        }
        let rate = (self.frames.len() - 1) as f64 / span;
        ((rate * self.options.refit_every.as_nanos() as f64) as usize).max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::PixelFormat;

    fn frame(id: u64, device_timestamp: u64, arrival_ns: u64) -> Frame {
        Frame {
            id,
            device_timestamp,
            host_arrival: HostTime(arrival_ns),
            width: 1,
            height: 1,
            format: PixelFormat::Mono8,
            data: vec![0],
        }
    }

    /// A 50 fps camera whose clock runs 40 ppm fast from tick 7e9 at host 1 s; exposures of
    /// 2 ms; each frame arrives 3 ms after its exposure ends plus up to 4 ms of delay (a few
    /// frames arrive with none).
    #[test]
    fn exposures_are_placed_on_the_host_clock_once_ten_frames_are_seen() {
        let options = CameraClockOptions {
            assumed_readout: Duration::from_millis(3),
            ..CameraClockOptions::new(Microseconds(2000.0), 1e9)
        };
        let mut clock = CameraClock::new(options, None);
        let start_host = |i: u64| 1e9 + i as f64 * 20e6;
        let mut placed = Vec::new();
        for i in 0..100u64 {
            let ticks = 7_000_000_000 + (i as f64 * 20e6 * (1.0 + 40e-6)) as u64;
            let delay = if i % 7 == 0 {
                0.0
            } else {
                (i * 7919 % 4000) as f64 * 1e3
            };
            let arrival = start_host(i) + 2e6 + 3e6 + delay;
            let f = frame(i, ticks, arrival as u64);
            clock.observe(&f);
            match clock.exposure(&f) {
                None => assert!(i < 9, "frame {i} not placed"),
                Some(e) => placed.push((i, e)),
            }
        }
        assert!(placed.len() >= 90);
        for (i, e) in placed.iter().filter(|(i, _)| *i >= 30) {
            let true_end = start_host(*i) + 2e6;
            assert!(
                (e.host_ns[1] - true_end).abs() < 0.2e6,
                "frame {i}: end {} ns, true {true_end}",
                e.host_ns[1]
            );
            assert!((e.host_ns[1] - e.host_ns[0] - 2e6).abs() < 1e3);
            assert!(!e.calibrated);
            assert!(
                e.error_ns >= 5e6,
                "{e:?}: the unseen readout's error is said"
            );
        }
    }
}
