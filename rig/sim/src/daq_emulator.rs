//! A simulated DAQ (NI USB-6218-like) sampling the six strain gauges of an ATI sensor and the
//! camera's ExposureActive line, in real time on its own thread.
//!
//! - Gauge volts = C^-1 w, where C is the `.cal` file's volts-to-wrench matrix and w the
//!   [`ForceReading`] (true load + noise, drift, bias) at the sample instant; so a
//!   [`fringe_rig::atical::CalibratedSensor`] over this source gives back w within the quantisation.
//! - Quantisation: `bits` over +-`range_v` (16 bits over +-10 V: 305 uV per step), clipped at the
//!   range.
//! - Sample n is taken at host time start + n / (rate (1 + drift_ppm 1e-6)): the DAQ's sample clock
//!   has its own rate error. Scans arrive in blocks of `block_size` (10 ms at 5 kHz by default),
//!   all stamped with the block's host arrival time, like a driver callback. A block is handed
//!   over `U(0, arrival_jitter_ms)` after its last scan was taken (a busy host; default 0).
//! - The strobe channel reads `strobe_high_v` while the shared [`ExposureSchedule`] says the camera
//!   is exposing, `strobe_low_v` otherwise.
//! - A consumer that stops reading for longer than `buffer_s` overflows the buffer: the next read
//!   fails, as a real DAQ's does.
//! - The acquisition thread runs real-time when the process may ([`fringe_rig::realtime`]): a
//!   DAQ's clock is not held back by the host's other work.

use crate::camera_emulator::ExposureSchedule;
use crate::ground_truth::{TruthRecord, TruthSink};
use crate::scene::ForceReading;
use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, TrySendError};
use fringe_rig::atical::{Calibration, GaugeReading, GaugeSource};
use fringe_rig::clock::HostTime;
use fringe_rig::force::ForceError;
use fringe_rig::units::{Volts, Wrench};
use nalgebra::{Matrix6, Vector6};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// The simulated DAQ's settings.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct SimDaqConfig {
    /// Device name for messages.
    pub device: String,
    /// Scans per second.
    pub rate_hz: f64,
    /// Scans delivered together.
    pub block_size: usize,
    /// Sample clock rate error, ppm.
    pub clock_drift_ppm: f64,
    /// Input range +-volts.
    pub range_v: f64,
    /// ADC resolution, bits.
    pub bits: u32,
    /// Strobe channel level while the camera exposes, V.
    pub strobe_high_v: f64,
    /// Strobe channel level otherwise, V.
    pub strobe_low_v: f64,
    /// Seconds of scans buffered for a slow reader before overflow.
    pub buffer_s: f64,
    /// Extra delay of each block's delivery, uniform in [0, this], ms (host scheduling).
    pub arrival_jitter_ms: f64,
    /// Seed of the arrival jitter.
    pub seed: u64,
}

impl Default for SimDaqConfig {
    fn default() -> Self {
        SimDaqConfig {
            device: "sim-daq Dev1/ai0:6".into(),
            rate_hz: 5000.0,
            block_size: 50,
            clock_drift_ppm: -8.0,
            range_v: 10.0,
            bits: 16,
            strobe_high_v: 3.3,
            strobe_low_v: 0.0,
            buffer_s: 10.0,
            arrival_jitter_ms: 0.0,
            seed: 1,
        }
    }
}

/// The DAQ's sample clock (ground truth of when each scan was taken).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DaqClock {
    pub start: HostTime,
    pub rate_hz: f64,
    pub drift_ppm: f64,
}

impl DaqClock {
    /// Host time at which sample `index` was taken.
    pub fn sample_time(&self, index: u64) -> HostTime {
        let period_ns = 1e9 / (self.rate_hz * (1.0 + self.drift_ppm * 1e-6));
        HostTime(self.start.0 + (index as f64 * period_ns).round() as u64)
    }
}

/// A handle on the DAQ's clock that stays valid after the DAQ is moved into a sensor.
#[derive(Debug, Clone, Default)]
pub struct DaqClockHandle(Arc<Mutex<Option<DaqClock>>>);

impl DaqClockHandle {
    /// The clock of the current (or last) acquisition, if one was started.
    pub fn get(&self) -> Option<DaqClock> {
        *self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

struct Running {
    stop: Arc<AtomicBool>,
    overflow: Arc<AtomicBool>,
    scans: Receiver<GaugeReading>,
    thread: JoinHandle<Box<dyn ForceReading>>,
}

/// The simulated DAQ, a [`GaugeSource`].
pub struct SimDaq {
    config: SimDaqConfig,
    to_volts: Matrix6<f64>,
    reading: Option<Box<dyn ForceReading>>,
    schedule: Option<Arc<ExposureSchedule>>,
    truth: Option<Arc<dyn TruthSink>>,
    clock: DaqClockHandle,
    running: Option<Running>,
}

impl SimDaq {
    /// A DAQ whose gauges carry `reading` through the inverse of `calibration`'s matrix.
    pub fn new(
        config: SimDaqConfig,
        calibration: &Calibration,
        reading: Box<dyn ForceReading>,
    ) -> Result<SimDaq, ForceError> {
        let to_volts = calibration
            .matrix
            .try_inverse()
            .ok_or_else(|| ForceError::Config {
                origin: calibration.source.clone(),
                message: "the calibration matrix is singular, so no gauge voltages give a wrench; use another .cal file".into(),
            })?;
        if config.rate_hz.is_nan()
            || config.rate_hz <= 0.0
            || config.block_size == 0
            || config.bits == 0
            || config.range_v.is_nan()
            || config.range_v <= 0.0
        {
            return Err(ForceError::Config {
                origin: config.device.clone(),
                message: format!(
                    "rate {} Hz, block {} scans, {} bits, range {} V: all must be positive",
                    config.rate_hz, config.block_size, config.bits, config.range_v
                ),
            });
        }
        Ok(SimDaq {
            config,
            to_volts,
            reading: Some(reading),
            schedule: None,
            truth: None,
            clock: DaqClockHandle::default(),
            running: None,
        })
    }

    /// Samples the camera's exposure-active line from `schedule` as the strobe channel.
    pub fn with_strobe(mut self, schedule: Arc<ExposureSchedule>) -> SimDaq {
        self.schedule = Some(schedule);
        self
    }

    /// Records the sample clock into `sink` at each start.
    pub fn with_truth(mut self, sink: Arc<dyn TruthSink>) -> SimDaq {
        self.truth = Some(sink);
        self
    }

    /// A handle on the sample clock (ground truth).
    pub fn clock(&self) -> DaqClockHandle {
        self.clock.clone()
    }

    /// One ADC step, V.
    pub fn lsb_volts(&self) -> f64 {
        2.0 * self.config.range_v / 2f64.powi(self.config.bits as i32)
    }

    /// The quantised gauge voltages that carry wrench `w`.
    pub fn gauge_volts(&self, w: &Wrench) -> [f64; 6] {
        gauge_volts(&self.to_volts, w, self.lsb_volts(), self.config.range_v)
    }
}

fn gauge_volts(to_volts: &Matrix6<f64>, w: &Wrench, lsb: f64, range: f64) -> [f64; 6] {
    let v = to_volts * Vector6::from_row_slice(&w.to_array());
    std::array::from_fn(|i| ((v[i] / lsb).round() * lsb).clamp(-range, range))
}

struct Acquisition {
    config: SimDaqConfig,
    to_volts: Matrix6<f64>,
    clock: DaqClock,
    schedule: Option<Arc<ExposureSchedule>>,
    stop: Arc<AtomicBool>,
    overflow: Arc<AtomicBool>,
}

impl Acquisition {
    fn run(
        self,
        mut reading: Box<dyn ForceReading>,
        out: crossbeam_channel::Sender<GaugeReading>,
    ) -> Box<dyn ForceReading> {
        // A DAQ samples on its own clock whatever the host runs: the emulator's thread is
        // real-time when allowed (the F/T reader says so when it is not).
        let _ = fringe_rig::realtime::raise_current_thread("simulated DAQ");
        let lsb = 2.0 * self.config.range_v / 2f64.powi(self.config.bits as i32);
        let block = self.config.block_size as u64;
        let mut n = 0u64;
        let mut scans = Vec::with_capacity(block as usize);
        let mut jitter = StdRng::seed_from_u64(self.config.seed ^ 0xda0_1177);
        let jitter_ns = self.config.arrival_jitter_ms.max(0.0) * 1e6;
        loop {
            let taken = self.clock.sample_time(n + block - 1);
            let extra = if jitter_ns > 0.0 {
                (jitter.gen::<f64>() * jitter_ns) as u64
            } else {
                0
            };
            let due = HostTime(taken.0 + extra);
            loop {
                if self.stop.load(Ordering::Relaxed) {
                    return reading;
                }
                let now = HostTime::now();
                if now >= due {
                    break;
                }
                std::thread::sleep(due.since(now).min(Duration::from_millis(5)));
            }
            let windows = self.schedule.as_ref().map(|s| s.snapshot().1);
            scans.clear();
            for index in n..n + block {
                let t = self.clock.sample_time(index);
                let w = reading.reading_at(t);
                let v = gauge_volts(&self.to_volts, &w, lsb, self.config.range_v);
                let strobe = windows.as_ref().map(|ws| {
                    Volts(if ExposureSchedule::exposing(ws, t) {
                        self.config.strobe_high_v
                    } else {
                        self.config.strobe_low_v
                    })
                });
                scans.push((index, v.map(Volts), strobe));
            }
            n += block;
            let arrival = HostTime::now();
            for &(index, gauges, strobe) in &scans {
                let r = GaugeReading {
                    index,
                    host_time: arrival,
                    gauges,
                    strobe,
                    lost_before: 0,
                };
                match out.try_send(r) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_)) => {
                        self.overflow.store(true, Ordering::Relaxed);
                    }
                    Err(TrySendError::Disconnected(_)) => return reading,
                }
            }
        }
    }
}

impl GaugeSource for SimDaq {
    fn describe(&self) -> String {
        self.config.device.clone()
    }

    fn start(&mut self) -> Result<(), ForceError> {
        if self.running.is_some() {
            return Ok(());
        }
        let Some(reading) = self.reading.take() else {
            return Err(ForceError::Device {
                device: self.config.device.clone(),
                message:
                    "the force source was lost when acquisition panicked; create the DAQ again"
                        .into(),
            });
        };
        let clock = DaqClock {
            start: HostTime(HostTime::now().0 + 1_000_000),
            rate_hz: self.config.rate_hz,
            drift_ppm: self.config.clock_drift_ppm,
        };
        *self.clock.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(clock);
        if let Some(sink) = &self.truth {
            sink.record(TruthRecord::DaqClock {
                start: clock.start,
                rate_hz: clock.rate_hz,
                drift_ppm: clock.drift_ppm,
            });
        }
        let capacity =
            ((self.config.rate_hz * self.config.buffer_s) as usize).max(self.config.block_size * 2);
        let (tx, rx) = bounded(capacity);
        let stop = Arc::new(AtomicBool::new(false));
        let overflow = Arc::new(AtomicBool::new(false));
        let acq = Acquisition {
            config: self.config.clone(),
            to_volts: self.to_volts,
            clock,
            schedule: self.schedule.clone(),
            stop: stop.clone(),
            overflow: overflow.clone(),
        };
        let thread = std::thread::Builder::new()
            .name("sim-daq".into())
            .spawn(move || acq.run(reading, tx))
            .map_err(|source| ForceError::Io {
                device: self.config.device.clone(),
                source,
            })?;
        self.running = Some(Running {
            stop,
            overflow,
            scans: rx,
            thread,
        });
        Ok(())
    }

    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        let device = self.config.device.clone();
        let Some(run) = &self.running else {
            return Err(ForceError::Device {
                device,
                message: "acquisition is not running; call start first".into(),
            });
        };
        if run.overflow.load(Ordering::Relaxed) {
            return Err(ForceError::Device {
                device,
                message: format!(
                    "acquisition buffer overflowed (scans not read for {} s); stop and start again, and read continuously",
                    self.config.buffer_s
                ),
            });
        }
        match run.scans.recv_timeout(timeout) {
            Ok(r) => Ok(Some(r)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(ForceError::Device {
                device,
                message: "the acquisition thread ended; stop and start again".into(),
            }),
        }
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        let Some(run) = self.running.take() else {
            return Ok(());
        };
        run.stop.store(true, Ordering::Relaxed);
        drop(run.scans);
        match run.thread.join() {
            Ok(reading) => {
                self.reading = Some(reading);
                Ok(())
            }
            Err(_) => Err(ForceError::Device {
                device: self.config.device.clone(),
                message: "the acquisition thread panicked".into(),
            }),
        }
    }
}

impl Drop for SimDaq {
    fn drop(&mut self) {
        let _ = GaugeSource::stop(self);
    }
}
