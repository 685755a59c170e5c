//! A simulated NI data acquisition device: what its analogue inputs carry, its sample clock,
//! its ADC, and whether it is still plugged in.

use fringe_rig::HostTime;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

/// What the device's analogue inputs carry.
pub trait DaqSignals: Send {
    /// Fills `out[i]` with the volts on analogue input `channels[i]` at scan `index`, taken at
    /// host time `t` (scans come in order; `index` starts again at each start).
    fn scan(&mut self, index: u64, t: HostTime, channels: &[u32], out: &mut [f64]);

    /// The acquisition started again: scan 0 is taken at host time `start` on a clock of
    /// `rate_hz` (`drift_ppm` fast); the device's ground truth.
    fn started(&mut self, _start: HostTime, _rate_hz: f64, _drift_ppm: f64) {}
}

/// A function of the scan is a device's signals (nothing happens at a start).
impl<F: FnMut(u64, HostTime, &[u32], &mut [f64]) + Send> DaqSignals for F {
    fn scan(&mut self, index: u64, t: HostTime, channels: &[u32], out: &mut [f64]) {
        self(index, t, channels, out)
    }
}

/// The device's fixed properties.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceModel {
    /// NI's product type ("USB-6218").
    pub product: String,
    /// Analogue inputs (single-ended count; differential pairs are ai0-7 and ai16-23).
    pub ai_channels: u32,
    /// Counters ("ctr0", "ctr1").
    pub counters: u32,
    /// Largest sum of scan rate times channels, S/s (one multiplexed ADC).
    pub max_aggregate_rate_hz: f64,
    /// Input ranges, +- volts.
    pub ranges_v: Vec<f64>,
    pub bits: u32,
}

impl DeviceModel {
    /// An NI USB-6218 (NI USB-621x User Manual: 32 single-ended / 16 differential inputs,
    /// +-10, 5, 1, 0.2 V, 16 bits, two counters; 250 kS/s aggregate).
    pub fn usb_6218() -> DeviceModel {
        DeviceModel {
            product: "USB-6218".into(),
            ai_channels: 32,
            counters: 2,
            max_aggregate_rate_hz: 250_000.0,
            ranges_v: vec![10.0, 5.0, 1.0, 0.2],
            bits: 16,
        }
    }

    /// Whether `channel` can be the positive input of a differential pair.
    pub fn differential_positive(&self, channel: u32) -> bool {
        channel % 16 < 8 && channel < self.ai_channels
    }

    /// The smallest range holding `min..max`, if any.
    pub fn range_for(&self, min: f64, max: f64) -> Option<f64> {
        let need = min.abs().max(max.abs());
        self.ranges_v
            .iter()
            .copied()
            .filter(|r| *r >= need)
            .min_by(|a, b| a.total_cmp(b))
    }

    /// `volts` as the ADC gives it in range +-`range`: clipped, on a step of 2 range / 2^bits.
    pub fn quantise(&self, volts: f64, range: f64) -> f64 {
        let lsb = 2.0 * range / 2f64.powi(self.bits as i32);
        ((volts / lsb).round() * lsb).clamp(-range, range)
    }
}

/// How the device's own behaviour departs from the ideal.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceTiming {
    /// Sample clock rate error, ppm.
    pub clock_drift_ppm: f64,
    /// Scans per transfer to the host buffer (USB packets), at most.
    pub transfer_scans: usize,
    /// Extra delay of each transfer, uniform in [0, this] ms (a busy bus or host).
    pub transfer_jitter_ms: f64,
    pub seed: u64,
    /// The cable is pulled this long after the first analogue start, if set.
    pub unplug_after: Option<std::time::Duration>,
}

impl Default for DeviceTiming {
    fn default() -> Self {
        DeviceTiming {
            clock_drift_ppm: 0.0,
            transfer_scans: 10,
            transfer_jitter_ms: 0.0,
            seed: 1,
            unplug_after: None,
        }
    }
}

/// The camera trigger pulses a counter generates, on the analogue input's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseTrain {
    /// Host time of pulse 0's rising edge.
    pub first: HostTime,
    pub frequency_hz: f64,
    /// The sample clock's rate error, ppm (the counter shares the timebase).
    pub drift_ppm: f64,
}

impl PulseTrain {
    /// Host time of pulse `n`'s rising edge.
    pub fn edge(&self, n: u64) -> HostTime {
        let period_ns = 1e9 / (self.frequency_hz * (1.0 + self.drift_ppm * 1e-6));
        HostTime(self.first.0 + (n as f64 * period_ns).round() as u64)
    }
}

/// A device on the simulated bus.
pub struct SimDevice {
    pub name: String,
    pub model: DeviceModel,
    pub timing: DeviceTiming,
    pub(crate) signals: Mutex<Box<dyn DaqSignals>>,
    unplugged: AtomicBool,
    /// When the cable is pulled ([`DeviceTiming::unplug_after`] from the first start).
    unplug_at: OnceLock<Instant>,
    /// Whether an analogue input task is running (one at a time: a second is "reserved").
    pub(crate) ai_busy: AtomicBool,
    pulses: Mutex<Option<PulseTrain>>,
    /// A counter armed on the analogue input's start trigger: frequency and initial delay.
    armed: Mutex<Option<(f64, f64)>>,
}

impl SimDevice {
    pub fn new(
        name: &str,
        model: DeviceModel,
        timing: DeviceTiming,
        signals: Box<dyn DaqSignals>,
    ) -> Arc<SimDevice> {
        Arc::new(SimDevice {
            name: name.to_string(),
            model,
            timing,
            signals: Mutex::new(signals),
            unplugged: AtomicBool::new(false),
            unplug_at: OnceLock::new(),
            ai_busy: AtomicBool::new(false),
            pulses: Mutex::new(None),
            armed: Mutex::new(None),
        })
    }

    /// Pulls the cable (`true`) or plugs it in again.
    pub fn set_unplugged(&self, unplugged: bool) {
        self.unplugged.store(unplugged, Ordering::SeqCst);
    }

    pub fn unplugged(&self) -> bool {
        self.unplugged.load(Ordering::SeqCst)
            || self.unplug_at.get().is_some_and(|at| Instant::now() >= *at)
    }

    /// An analogue acquisition started: the timed unplug counts from the first.
    pub(crate) fn note_start(&self) {
        if let Some(after) = self.timing.unplug_after {
            let _ = self.unplug_at.set(Instant::now() + after);
        }
    }

    /// The camera trigger's pulses, once a counter armed on the analogue start has started.
    pub fn pulses(&self) -> Option<PulseTrain> {
        *self.pulses.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(crate) fn arm(&self, frequency_hz: f64, initial_delay_s: f64) {
        *self.armed.lock().unwrap_or_else(|e| e.into_inner()) =
            Some((frequency_hz, initial_delay_s));
    }

    pub(crate) fn take_armed(&self) -> Option<(f64, f64)> {
        self.armed.lock().unwrap_or_else(|e| e.into_inner()).take()
    }

    pub(crate) fn set_pulses(&self, p: Option<PulseTrain>) {
        *self.pulses.lock().unwrap_or_else(|e| e.into_inner()) = p;
    }
}
