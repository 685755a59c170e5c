//! The simulated bench's DAQ: an NI USB-6218 of the simulated NI-DAQmx library
//! ([`crate::emulators::daqmx_library`]) sampling the six strain gauges of an ATI sensor and the camera's
//! ExposureActive line, read by the real NI-DAQmx driver ([`fringe_rig::nidaqmx::NiDaq`]).
//!
//! - Gauge volts (ai0:5) = C^-1 w, where C is the `.cal` file's volts-to-wrench matrix and w the
//!   [`ForceReading`] (true load + noise, drift, bias) at the sample instant; so a
//!   [`fringe_rig::atical::CalibratedSensor`] over this source gives back w within the
//!   quantisation (`bits` over +-`range_v`: 16 bits over +-10 V is 305 uV a step, clipped).
//! - Sample n is taken at host time start + n / (rate (1 + drift_ppm 1e-6)): the DAQ's sample clock
//!   has its own rate error. Scans reach the driver's buffer in transfers of `block_size` scans
//!   (10 ms at 5 kHz by default), each `U(0, arrival_jitter_ms)` after its last scan was taken (a
//!   busy host; default 0); the driver reads them in 10 ms blocks, stamped with their arrival.
//! - The strobe channel (ai7) reads `strobe_high_v` while the shared [`ExposureSchedule`] says the
//!   camera is exposing, `strobe_low_v` otherwise.
//! - A reader that falls `buffer_s` behind overflows the driver's buffer: NI's -200279, which the
//!   driver recovers from by restarting the task.
//! - Each [`SimDaq`] is its own device on the simulated bus (`SimDAQ<n>`), so benches in one
//!   process do not share one.

use crate::emulators::camera_emulator::{ExposureSchedule, ExposureWindow, TriggerInput};
use crate::emulators::daqmx_library::{c_api, DaqSignals, DeviceModel, DeviceTiming, SimDevice};
use crate::ground_truth::records::{TruthRecord, TruthSink};
use crate::scene::ForceReading;
use fringe_rig::atical::{Calibration, GaugeReading, GaugeSource};
use fringe_rig::nidaqmx::{CameraTrigger, DaqSettings, Library, NiDaq, Terminal};
use fringe_rig::ForceError;
use fringe_rig::HostTime;
use fringe_rig::{Hertz, Volts, Wrench};
use nalgebra::{Matrix6, Vector6};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
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

/// The analogue inputs the simulated bench wires: the gauges on ai0:5 (differential), the
/// exposure strobe on ai7.
const GAUGE_CHANNELS: &str = "ai0:5";
const STROBE_CHANNEL: &str = "ai7";

/// The simulated library, shared by every simulated DAQ of the process.
fn library() -> Result<Arc<Library>, ForceError> {
    static LIBRARY: std::sync::OnceLock<Arc<Library>> = std::sync::OnceLock::new();
    if let Some(l) = LIBRARY.get() {
        return Ok(l.clone());
    }
    // SAFETY: `c_api::lookup` gives the simulated library's functions, declared with NI's C
    // signatures, for the life of the program.
    let l = unsafe { Library::in_process("the simulated NI-DAQmx library", c_api::lookup) }
        .map_err(|e| ForceError::Config {
            origin: "simulated NI-DAQmx".into(),
            message: e.to_string(),
        })?;
    Ok(LIBRARY.get_or_init(|| l).clone())
}

/// What the simulated bench wires to the DAQ's inputs.
struct BenchSignals {
    to_volts: Matrix6<f64>,
    reading: Box<dyn ForceReading>,
    schedule: Option<Arc<ExposureSchedule>>,
    strobe_v: (f64, f64),
    windows: Vec<ExposureWindow>,
    windows_at: Option<HostTime>,
    truth: Option<Arc<dyn TruthSink>>,
    clock: DaqClockHandle,
}

impl DaqSignals for BenchSignals {
    fn scan(&mut self, _index: u64, t: HostTime, channels: &[u32], out: &mut [f64]) {
        let w = self.reading.reading_at(t);
        let v = self.to_volts * Vector6::from_row_slice(&w.to_array());
        let exposing = match &self.schedule {
            Some(schedule) => {
                // The camera publishes its windows ahead: a copy a millisecond old will do.
                if self.windows_at.is_none_or(|at| t.0 > at.0 + 1_000_000) {
                    self.windows = schedule.snapshot().1;
                    self.windows_at = Some(t);
                }
                ExposureSchedule::exposing(&self.windows, t)
            }
            None => false,
        };
        for (o, &ch) in out.iter_mut().zip(channels) {
            *o = match ch {
                0..=5 => v[ch as usize],
                7 if self.schedule.is_some() => {
                    if exposing {
                        self.strobe_v.0
                    } else {
                        self.strobe_v.1
                    }
                }
                _ => 0.0,
            };
        }
    }

    fn started(&mut self, start: HostTime, rate_hz: f64, drift_ppm: f64) {
        let clock = DaqClock {
            start,
            rate_hz,
            drift_ppm,
        };
        *self.clock.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(clock);
        self.windows_at = None;
        if let Some(sink) = &self.truth {
            sink.record(TruthRecord::DaqClock {
                start,
                rate_hz,
                drift_ppm,
            });
        }
    }
}

/// The camera's trigger line wired to the DAQ's counter output (PFI12 to Line1): the pulses of
/// the device named `device`, while its counter runs.
struct CounterOutput {
    device: String,
}

impl TriggerInput for CounterOutput {
    fn next_edge(&self, t: HostTime) -> Option<HostTime> {
        let pulses = c_api::device(&self.device)?.pulses()?;
        let period_ns = 1e9 / (pulses.frequency_hz * (1.0 + pulses.drift_ppm * 1e-6));
        let n = if t <= pulses.first {
            0
        } else {
            ((t.0 - pulses.first.0) as f64 / period_ns).ceil() as u64
        };
        Some(pulses.edge(n))
    }
}

/// The counter pulsing the camera's trigger and the terminal it leaves on.
const TRIGGER_COUNTER: &str = "ctr0";
const TRIGGER_TERMINAL: &str = "PFI12";

/// The simulated DAQ, a [`GaugeSource`]: the real driver over a simulated device.
pub struct SimDaq {
    config: SimDaqConfig,
    to_volts: Matrix6<f64>,
    /// The signals, until the device is put on the bus at the first start.
    signals: Option<BenchSignals>,
    /// The device's name on the simulated bus (`SimDAQ<n>`).
    name: String,
    /// Frame rate of the camera trigger pulses, when the DAQ triggers the camera.
    camera_trigger: Option<Hertz>,
    device: Option<String>,
    driver: Option<NiDaq>,
    clock: DaqClockHandle,
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
        let clock = DaqClockHandle::default();
        static NEXT: AtomicU64 = AtomicU64::new(1);
        Ok(SimDaq {
            name: format!("SimDAQ{}", NEXT.fetch_add(1, Ordering::Relaxed)),
            camera_trigger: None,
            signals: Some(BenchSignals {
                to_volts,
                reading,
                schedule: None,
                strobe_v: (config.strobe_high_v, config.strobe_low_v),
                windows: Vec::new(),
                windows_at: None,
                truth: None,
                clock: clock.clone(),
            }),
            config,
            to_volts,
            device: None,
            driver: None,
            clock,
        })
    }

    /// Samples the camera's exposure-active line from `schedule` as the strobe channel.
    pub fn with_strobe(mut self, schedule: Arc<ExposureSchedule>) -> SimDaq {
        if let Some(s) = &mut self.signals {
            s.schedule = Some(schedule);
        }
        self
    }

    /// Records the sample clock into `sink` at each start.
    pub fn with_truth(mut self, sink: Arc<dyn TruthSink>) -> SimDaq {
        if let Some(s) = &mut self.signals {
            s.truth = Some(sink);
        }
        self
    }

    /// Pulses the camera's trigger at `frame_rate` from a counter started with the acquisition
    /// (the driver's camera trigger); wire [`SimDaq::trigger_line`] to the camera.
    pub fn with_camera_trigger(mut self, frame_rate: Hertz) -> SimDaq {
        self.camera_trigger = Some(frame_rate);
        self
    }

    /// The counter's output, for the camera's trigger input.
    pub fn trigger_line(&self) -> Arc<dyn TriggerInput> {
        Arc::new(CounterOutput {
            device: self.name.clone(),
        })
    }

    /// The camera trigger's pulse timing, for the `trigger` labels: scan rate and frame rate.
    pub fn camera_trigger(&self) -> Option<(Hertz, Hertz)> {
        self.camera_trigger.map(|f| (Hertz(self.config.rate_hz), f))
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
        let v = self.to_volts * Vector6::from_row_slice(&w.to_array());
        let model = self.model();
        std::array::from_fn(|i| model.quantise(v[i], self.config.range_v))
    }

    /// The device on the simulated bus, once started (to unplug it).
    pub fn device(&self) -> Option<Arc<SimDevice>> {
        self.device.as_deref().and_then(c_api::device)
    }

    fn model(&self) -> DeviceModel {
        DeviceModel {
            bits: self.config.bits,
            ranges_v: vec![self.config.range_v],
            ..DeviceModel::usb_6218()
        }
    }

    /// Puts the device on the bus and opens the real driver on it.
    fn open(&mut self) -> Result<&mut NiDaq, ForceError> {
        if self.driver.is_none() {
            let Some(signals) = self.signals.take() else {
                return Err(ForceError::Device {
                    device: self.config.device.clone(),
                    message: "the simulated DAQ could not be opened before; create it again".into(),
                });
            };
            let name = self.name.clone();
            let strobe = signals.schedule.is_some();
            let device = SimDevice::new(
                &name,
                self.model(),
                DeviceTiming {
                    clock_drift_ppm: self.config.clock_drift_ppm,
                    transfer_scans: self.config.block_size,
                    transfer_jitter_ms: self.config.arrival_jitter_ms,
                    seed: self.config.seed,
                    unplug_after: None,
                },
                Box::new(signals),
            );
            c_api::install(device);
            self.device = Some(name.clone());
            let settings = DaqSettings {
                device: name,
                gauges: GAUGE_CHANNELS.into(),
                strobe: strobe.then(|| STROBE_CHANNEL.into()),
                terminal: Terminal::Differential,
                range: Volts(self.config.range_v),
                rate: Hertz(self.config.rate_hz),
                buffer_scans: Some(
                    ((self.config.rate_hz * self.config.buffer_s) as u32)
                        .max(self.config.block_size as u32 * 2),
                ),
            };
            let library = library()?;
            let mut driver = NiDaq::open(&library, settings);
            if let Some(frame_rate) = self.camera_trigger {
                driver = driver.and_then(|d| {
                    d.with_camera_trigger(
                        &library,
                        CameraTrigger {
                            counter: TRIGGER_COUNTER.into(),
                            terminal: Some(TRIGGER_TERMINAL.into()),
                            frame_rate,
                            duty: 0.5,
                        },
                    )
                });
            }
            let driver = driver.map_err(|e| ForceError::Device {
                device: self.config.device.clone(),
                message: e.to_string(),
            })?;
            self.driver = Some(driver);
        }
        self.driver.as_mut().ok_or_else(|| ForceError::Device {
            device: String::new(),
            message: "unreachable: the driver was just opened".into(),
        })
    }
}

impl GaugeSource for SimDaq {
    fn describe(&self) -> String {
        match &self.driver {
            Some(d) => format!("{} (simulated)", d.describe()),
            None => self.config.device.clone(),
        }
    }

    fn start(&mut self) -> Result<(), ForceError> {
        self.open()?.start()
    }

    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        match &mut self.driver {
            Some(d) => d.next_reading(timeout),
            None => Err(ForceError::Device {
                device: self.config.device.clone(),
                message: "acquisition is not running; call start first".into(),
            }),
        }
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        match &mut self.driver {
            Some(d) => d.stop(),
            None => Ok(()),
        }
    }
}

impl Drop for SimDaq {
    fn drop(&mut self) {
        // The driver's tasks are cleared first, then the device leaves the bus.
        self.driver = None;
        if let Some(name) = &self.device {
            c_api::remove(name);
        }
    }
}
