//! A task of the simulated library: its channels, its timing, and the acquisition that fills its
//! buffer on the device's sample clock.
//!
//! Behaviour follows NI's documentation (`docs/nidaqmx.md`):
//! - scans reach the host buffer in transfers of a few scans, each when its last scan was taken
//!   (plus the device's transfer jitter), so a reader sees them at the hardware's pace;
//! - the buffer holds `max(sampsPerChan, NI's table for the rate)` scans per channel, or what
//!   `DAQmxCfgInputBuffer` set; a reader that falls further behind gets -200279 until the task is
//!   stopped and started again;
//! - a read of N scans waits for them until its timeout, then returns what it has with -200284;
//!   N = -1 reads what is there; a task that was not started is started by the read;
//! - one analogue input task runs on a device at a time (-50103 for a second);
//! - a device that is unplugged fails every call with -201003.

use super::device::{PulseTrain, SimDevice};
use super::texts::{Fault, BUFFER_TOO_SMALL, INVALID_ATTRIBUTE_VALUE};
use fringe_rig::nidaqmx;
use fringe_rig::HostTime;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// An analogue input channel of a task.
pub(super) struct AiChannel {
    pub(super) device: Arc<SimDevice>,
    pub(super) number: u32,
    /// The range chosen for the requested limits, +- volts.
    pub(super) range: f64,
}

/// A counter output generating a pulse train.
pub(super) struct CoChannel {
    pub(super) device: Arc<SimDevice>,
    pub(super) frequency_hz: f64,
    pub(super) initial_delay_s: f64,
    pub(super) terminal: Option<String>,
    /// Starts on this terminal's edge ("/Dev1/ai/StartTrigger"), or when started if `None`.
    pub(super) start_trigger: Option<String>,
}

#[derive(Default)]
struct Ring {
    scans: VecDeque<f64>,
    acquired: u64,
    capacity: usize,
    overwritten: bool,
    device_lost: bool,
}

struct Acquisition {
    shared: Arc<(Mutex<Ring>, Condvar)>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    device: Arc<SimDevice>,
}

impl Drop for Acquisition {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        self.device.ai_busy.store(false, Ordering::SeqCst);
    }
}

/// A task.
#[derive(Default)]
pub(super) struct SimTask {
    pub(super) name: String,
    pub(super) ai: Vec<AiChannel>,
    pub(super) co: Option<CoChannel>,
    pub(super) rate_hz: Option<f64>,
    /// Scans per channel asked for by `DAQmxCfgSampClkTiming` and `DAQmxCfgInputBuffer`.
    pub(super) samps_per_chan: u64,
    pub(super) input_buffer: Option<u64>,
    running: Option<Acquisition>,
    co_running: bool,
}

fn lock(m: &Mutex<Ring>) -> MutexGuard<'_, Ring> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// NI's default buffer per channel for a continuous input at `rate` S/s.
fn default_buffer(rate: f64) -> u64 {
    match rate {
        r if r <= 100.0 => 1_000,
        r if r <= 10_000.0 => 10_000,
        r if r <= 1_000_000.0 => 100_000,
        _ => 1_000_000,
    }
}

impl SimTask {
    pub(super) fn named(name: String) -> SimTask {
        SimTask {
            name,
            ..SimTask::default()
        }
    }

    fn devices(&self) -> impl Iterator<Item = &Arc<SimDevice>> {
        self.ai
            .iter()
            .map(|c| &c.device)
            .chain(self.co.iter().map(|c| &c.device))
    }

    fn check_plugged(&self) -> Result<(), Fault> {
        match self.devices().find(|d| d.unplugged()) {
            Some(d) => Err(Fault::new(
                nidaqmx::DEV_CANNOT_BE_ACCESSED,
                &[format!("Device: {}", d.name)],
            )),
            None => Ok(()),
        }
    }

    /// What a commit checks: a sample clock the device can give.
    pub(super) fn verify(&self) -> Result<(), Fault> {
        self.check_plugged()?;
        if let Some(first) = self.ai.first() {
            let Some(rate) = self.rate_hz else {
                return Err(Fault::new(
                    INVALID_ATTRIBUTE_VALUE,
                    &["Property: DAQmx_SampTimingType".into(),
                      "The simulated library needs a sample clock (DAQmxCfgSampClkTiming) for analogue input.".into()],
                ));
            };
            let model = &first.device.model;
            let most = model.max_aggregate_rate_hz / self.ai.len() as f64;
            if !(rate > 0.0 && rate <= most) {
                return Err(Fault::new(
                    INVALID_ATTRIBUTE_VALUE,
                    &[
                        "Property: DAQmx_SampClk_Rate".into(),
                        format!("Requested Value: {rate}"),
                        format!("Maximum Value: {most}"),
                        format!("Device: {}", first.device.name),
                    ],
                ));
            }
        }
        Ok(())
    }

    pub(super) fn start(&mut self) -> Result<(), Fault> {
        self.verify()?;
        if let Some(co) = &self.co {
            if !self.co_running {
                let device = &co.device;
                match &co.start_trigger {
                    Some(t) if t.ends_with("ai/StartTrigger") => {
                        device.arm(co.frequency_hz, co.initial_delay_s)
                    }
                    _ => device.set_pulses(Some(PulseTrain {
                        first: HostTime(
                            HostTime::now().0 + (co.initial_delay_s * 1e9).round() as u64,
                        ),
                        frequency_hz: co.frequency_hz,
                        drift_ppm: device.timing.clock_drift_ppm,
                    })),
                }
                self.co_running = true;
            }
        }
        if self.ai.is_empty() || self.running.is_some() {
            return Ok(());
        }
        let device = self.ai[0].device.clone();
        if device
            .ai_busy
            .compare_exchange(false, true, Ordering::SeqCst, Ordering::SeqCst)
            .is_err()
        {
            return Err(Fault::new(
                nidaqmx::RESOURCE_RESERVED,
                &[format!("Device: {}", device.name)],
            ));
        }
        device.note_start();
        let rate = self.rate_hz.unwrap_or(1000.0);
        let capacity = self
            .input_buffer
            .unwrap_or_else(|| self.samps_per_chan.max(default_buffer(rate)))
            as usize;
        let shared = Arc::new((
            Mutex::new(Ring {
                capacity: capacity.max(1),
                ..Ring::default()
            }),
            Condvar::new(),
        ));
        let stop = Arc::new(AtomicBool::new(false));
        let channels: Vec<u32> = self.ai.iter().map(|c| c.number).collect();
        let ranges: Vec<f64> = self.ai.iter().map(|c| c.range).collect();
        let start = HostTime(HostTime::now().0 + 1_000_000);
        let drift = device.timing.clock_drift_ppm;
        if let Some((frequency_hz, delay)) = device.take_armed() {
            device.set_pulses(Some(PulseTrain {
                first: HostTime(start.0 + (delay * 1e9).round() as u64),
                frequency_hz,
                drift_ppm: drift,
            }));
        }
        device
            .signals
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .started(start, rate, drift);
        let sampler = Sampler {
            device: device.clone(),
            shared: shared.clone(),
            stop: stop.clone(),
            channels,
            ranges,
            start,
            rate,
        };
        let thread = std::thread::Builder::new()
            .name("sim-nidaqmx".into())
            .spawn(move || sampler.run())
            .map_err(|e| {
                device.ai_busy.store(false, Ordering::SeqCst);
                Fault::new(0, &[format!("cannot start the acquisition thread: {e}")])
            })?;
        self.running = Some(Acquisition {
            shared,
            stop,
            thread: Some(thread),
            device,
        });
        Ok(())
    }

    pub(super) fn stop(&mut self) {
        self.running = None;
        if self.co_running {
            if let Some(co) = &self.co {
                co.device.set_pulses(None);
                co.device.take_armed();
            }
            self.co_running = false;
        }
    }

    pub(super) fn total_acquired(&self) -> Result<u64, Fault> {
        match &self.running {
            Some(a) => Ok(lock(&a.shared.0).acquired),
            None => Err(Fault::new(
                -200983,
                &["Property: DAQmx_Read_TotalSampPerChanAcquired".into()],
            )),
        }
    }

    /// `DAQmxReadAnalogF64`: returns the scans read and the status.
    pub(super) fn read(
        &mut self,
        num: i32,
        timeout_s: f64,
        fill_mode: u32,
        out: &mut [f64],
    ) -> (usize, Result<(), Fault>) {
        if self.ai.is_empty() {
            return (
                0,
                Err(Fault::new(
                    -200478,
                    &["The task has no analogue input channel to read.".into()],
                )),
            );
        }
        if self.running.is_none() {
            if let Err(f) = self.start() {
                return (0, Err(f));
            }
        }
        let per_scan = self.ai.len();
        if num > 0 && out.len() < num as usize * per_scan {
            return (0, Err(too_small(out.len(), num as usize * per_scan)));
        }
        let Some(acq) = &self.running else {
            return (0, Err(Fault::new(0, &["the task is not running".into()])));
        };
        let deadline =
            (timeout_s >= 0.0).then(|| Instant::now() + Duration::from_secs_f64(timeout_s));
        let (m, cv) = &*acq.shared;
        let mut ring = lock(m);
        let mut timed_out = false;
        loop {
            if ring.device_lost || acq.device.unplugged() {
                let f = Fault::new(
                    nidaqmx::DEV_CANNOT_BE_ACCESSED,
                    &[format!("Device: {}", acq.device.name)],
                );
                return (0, Err(f));
            }
            if ring.overwritten {
                return (0, Err(Fault::new(
                    nidaqmx::SAMPLES_NO_LONGER_AVAILABLE,
                    &["Attempted to read samples that are no longer available. The requested sample was previously available, but has since been overwritten.".into(),
                      "Property: DAQmx_Read_RelativeTo".into(),
                      "Corresponding Value: DAQmx_Val_CurrReadPos".into(),
                      "Property: DAQmx_Read_Offset".into(),
                      "Corresponding Value: 0".into()],
                )));
            }
            let available = ring.scans.len() / per_scan;
            let want = if num < 0 { available } else { num as usize };
            if available >= want {
                break;
            }
            let now = Instant::now();
            match deadline {
                Some(d) if now >= d => {
                    timed_out = true;
                    break;
                }
                Some(d) => {
                    ring = cv
                        .wait_timeout(ring, d - now)
                        .unwrap_or_else(|e| e.into_inner())
                        .0
                }
                None => ring = cv.wait(ring).unwrap_or_else(|e| e.into_inner()),
            }
        }
        let available = ring.scans.len() / per_scan;
        let scans = if num < 0 {
            available
        } else {
            available.min(num as usize)
        };
        if out.len() < scans * per_scan {
            return (0, Err(too_small(out.len(), scans * per_scan)));
        }
        // A channel's block is as long as the scans asked for (or read, for -1).
        let block = if num < 0 { scans } else { num as usize };
        for s in 0..scans {
            for c in 0..per_scan {
                let v = ring.scans.pop_front().unwrap_or(0.0);
                if fill_mode == nidaqmx::VAL_GROUP_BY_SCAN_NUMBER {
                    out[s * per_scan + c] = v;
                } else {
                    out[c * block + s] = v;
                }
            }
        }
        if timed_out {
            let f = Fault::new(nidaqmx::SAMPLES_NOT_YET_AVAILABLE, &[
                format!("Attempted to read {num} samples per channel; {scans} were available before the timeout of {timeout_s} s."),
            ]);
            return (scans, Err(f));
        }
        (scans, Ok(()))
    }
}

fn too_small(size: usize, needed: usize) -> Fault {
    Fault::new(
        BUFFER_TOO_SMALL,
        &[
            format!("Buffer Size: {size}"),
            format!("Required Buffer Size: {needed}"),
        ],
    )
}

/// The device filling a running task's buffer on its sample clock.
struct Sampler {
    device: Arc<SimDevice>,
    shared: Arc<(Mutex<Ring>, Condvar)>,
    stop: Arc<AtomicBool>,
    channels: Vec<u32>,
    ranges: Vec<f64>,
    start: HostTime,
    rate: f64,
}

impl Sampler {
    fn sample_time(&self, index: u64) -> HostTime {
        let period_ns = 1e9 / (self.rate * (1.0 + self.device.timing.clock_drift_ppm * 1e-6));
        HostTime(self.start.0 + (index as f64 * period_ns).round() as u64)
    }

    fn run(self) {
        // A DAQ samples on its own clock whatever the host runs: real-time when allowed.
        let _ = fringe_rig::raise_current_thread("simulated NI-DAQmx device");
        let timing = &self.device.timing;
        let transfer = timing.transfer_scans.max(1) as u64;
        let jitter_ns = timing.transfer_jitter_ms.max(0.0) * 1e6;
        let mut jitter = StdRng::seed_from_u64(timing.seed ^ 0xda0_1177);
        let per_scan = self.channels.len();
        let mut values = vec![0.0; per_scan];
        let mut block = Vec::with_capacity(transfer as usize * per_scan);
        let mut n = 0u64;
        loop {
            let extra = if jitter_ns > 0.0 {
                (jitter.gen::<f64>() * jitter_ns) as u64
            } else {
                0
            };
            let due = HostTime(self.sample_time(n + transfer - 1).0 + extra);
            loop {
                if self.stop.load(Ordering::SeqCst) {
                    return;
                }
                let now = HostTime::now();
                if now >= due {
                    break;
                }
                std::thread::sleep(due.since(now).min(Duration::from_millis(5)));
            }
            if self.device.unplugged() {
                lock(&self.shared.0).device_lost = true;
                self.shared.1.notify_all();
                return;
            }
            block.clear();
            {
                let mut signals = self
                    .device
                    .signals
                    .lock()
                    .unwrap_or_else(|e| e.into_inner());
                for index in n..n + transfer {
                    signals.scan(index, self.sample_time(index), &self.channels, &mut values);
                    for (v, range) in values.iter().zip(&self.ranges) {
                        block.push(self.device.model.quantise(*v, *range));
                    }
                }
            }
            n += transfer;
            let mut ring = lock(&self.shared.0);
            ring.scans.extend(block.iter().copied());
            ring.acquired += transfer;
            let limit = ring.capacity * per_scan;
            if ring.scans.len() > limit {
                let excess = ring.scans.len() - limit;
                ring.scans.drain(..excess);
                ring.overwritten = true;
            }
            drop(ring);
            self.shared.1.notify_all();
        }
    }
}
