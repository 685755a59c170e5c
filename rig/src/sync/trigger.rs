//! Exposure windows of a camera triggered by the DAQ (synchronisation method `trigger`).
//!
//! A counter of the DAQ pulses at the frame rate on the analogue input's sample clock, started
//! by the analogue input's start trigger: pulse n rises at scan n x (scan rate / frame rate) of
//! the acquisition. The camera, in hardware-trigger mode, starts exposing its documented exposure
//! start delay after each rising edge and exposes for the exposure time. So exposure n occupies a
//! known span of the force stream's own sample index: no clock model, no strobe (hardware.md
//! E.2). When the acquisition restarts (the reader fell behind and the driver restarted both
//! tasks), pulse 0 falls on the first scan after the gap in the sample index.

use super::strobe::StrobeWindow;
use crate::units::{Hertz, Microseconds};

/// The DAQ-triggered camera's timing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriggerTiming {
    /// The analogue input's scan rate (the force stream's sample rate).
    pub scan_rate: Hertz,
    /// The pulse rate (the frame rate).
    pub frame_rate: Hertz,
    /// Rising edge to exposure start: the camera's exposure start delay plus its input line's
    /// response time (the camera's manual).
    pub delay: Microseconds,
    pub exposure: Microseconds,
}

impl TriggerTiming {
    /// Scans between pulses.
    pub fn scans_per_frame(&self) -> f64 {
        self.scan_rate.0 / self.frame_rate.0
    }

    /// Exposure `n` of an acquisition that started at scan `base`, in sample index.
    pub fn window(&self, base: u64, n: u64) -> StrobeWindow {
        let start = base as f64
            + n as f64 * self.scans_per_frame()
            + self.delay.0 * 1e-6 * self.scan_rate.0;
        StrobeWindow {
            start,
            end: start + self.exposure.0 * 1e-6 * self.scan_rate.0,
        }
    }
}

/// Gives each exposure window once the force stream has passed its end.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PulseSchedule {
    timing: TriggerTiming,
    /// The scan pulse 0 of the current acquisition fell on.
    base: u64,
    next_pulse: u64,
    last_tick: Option<u64>,
}

impl PulseSchedule {
    /// The schedule of an acquisition whose scan 0 is sample index 0.
    pub(crate) fn new(timing: TriggerTiming) -> PulseSchedule {
        PulseSchedule {
            timing,
            base: 0,
            next_pulse: 0,
            last_tick: None,
        }
    }

    /// Scans between pulses.
    pub(crate) fn spacing(&self) -> f64 {
        self.timing.scans_per_frame()
    }

    /// Feeds the sample at `tick`; returns the windows that ended at or before it. A gap in the
    /// ticks is a restarted acquisition: its pulse 0 is on `tick`.
    pub(crate) fn push(&mut self, tick: u64, out: &mut Vec<StrobeWindow>) {
        match self.last_tick {
            Some(last) if tick != last + 1 => {
                self.base = tick;
                self.next_pulse = 0;
            }
            Some(_) => {}
            // The first sample seen: exposures that began before it are not reported.
            None => {
                while self.timing.window(self.base, self.next_pulse).start < tick as f64 {
                    self.next_pulse += 1;
                }
            }
        }
        self.last_tick = Some(tick);
        loop {
            let w = self.timing.window(self.base, self.next_pulse);
            if w.end > tick as f64 {
                return;
            }
            self.next_pulse += 1;
            out.push(w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timing() -> TriggerTiming {
        TriggerTiming {
            scan_rate: Hertz(5000.0),
            frame_rate: Hertz(50.0),
            delay: Microseconds(19.12),
            exposure: Microseconds(2000.0),
        }
    }

    #[test]
    fn exposure_n_starts_the_delay_after_scan_100_n() {
        let mut s = PulseSchedule::new(timing());
        let mut out = Vec::new();
        for tick in 0..1000 {
            s.push(tick, &mut out);
        }
        assert_eq!(out.len(), 10);
        for (n, w) in out.iter().enumerate() {
            let start = 100.0 * n as f64 + 19.12e-6 * 5000.0;
            assert!((w.start - start).abs() < 1e-9, "{n}: {w:?}");
            assert!((w.end - (start + 10.0)).abs() < 1e-9, "{n}: {w:?}");
        }
    }

    #[test]
    fn after_a_gap_pulse_0_is_on_the_first_scan_after_it() {
        let mut s = PulseSchedule::new(timing());
        let mut out = Vec::new();
        for tick in 0..250 {
            s.push(tick, &mut out);
        }
        assert_eq!(out.len(), 3);
        out.clear();
        // 1234 scans lost: the tasks restarted, the counter's pulse 0 is on scan 1484.
        for tick in 1484..1700 {
            // Windows end 10.1 scans after their start: the third ends at 1694.1.
            s.push(tick, &mut out);
        }
        let starts: Vec<f64> = out.iter().map(|w| w.start.floor()).collect();
        assert_eq!(starts, vec![1484.0, 1584.0, 1684.0]);
    }

    #[test]
    fn a_stream_first_seen_mid_acquisition_reports_only_what_follows() {
        let mut s = PulseSchedule::new(timing());
        let mut out = Vec::new();
        for tick in 5050..5300 {
            s.push(tick, &mut out);
        }
        let starts: Vec<f64> = out.iter().map(|w| w.start.floor()).collect();
        assert_eq!(starts, vec![5100.0, 5200.0]);
    }
}
