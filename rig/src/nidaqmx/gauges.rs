//! The DAQ as a gauge source: six gauge voltages and the strobe, sampled continuously on the
//! device's own clock, for [`crate::atical::CalibratedSensor`].
//!
//! - Opening configures and commits the task, so a wrong device, channel, range or rate fails
//!   before anything moves.
//! - Reads take a block of scans (10 ms) with a timeout; a timeout returns the scans read so
//!   far, as NI documents. Every scan of a block carries the host time the block arrived.
//! - The scan index is the DAQ's own sample counter: scans acquired since the task started,
//!   carried on across a restart.
//! - A reader that fell behind the buffer gets NI's "samples no longer available" (or the
//!   device's FIFO overflow): the task is stopped and started again, the scans lost in between
//!   (those acquired but never read, and the restart's gap on the host clock) are skipped in the
//!   index and reported with the first scan after them, so the frames they cover get no label.
//! - A device that went away ends the stream with a one-line error.

use super::api::status;
use super::error::{DaqError, DaqmxStatus, Setting};
use super::library::{Library, ReadError, Task};
use super::settings::{CameraTrigger, DaqSettings};
use crate::atical::{GaugeReading, GaugeSource};
use crate::clock::HostTime;
use crate::force::ForceError;
use crate::units::Volts;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Seconds of scans one read asks for.
const BLOCK_S: f64 = 0.01;

/// Counters of the DAQ's acquisition.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DaqStats {
    /// Scans delivered.
    pub scans: u64,
    /// Times the reader fell behind and the task was restarted.
    pub overruns: u64,
    /// Scans lost to those restarts.
    pub lost: u64,
}

/// An NI-DAQmx device reading an ATI transducer's gauges.
pub struct NiDaq {
    settings: DaqSettings,
    /// The counter task triggering the camera, armed on the analogue input's start.
    trigger: Option<(CameraTrigger, Task)>,
    /// Declared after `trigger`: fields drop in order, and the analogue task is cleared last.
    task: Task,
    block: usize,
    running: bool,
    buffer: Vec<f64>,
    pending: VecDeque<GaugeReading>,
    /// Index of the next scan.
    next_index: u64,
    /// Scans read since the task last started.
    read_in_task: u64,
    task_started: Instant,
    lost_before_next: u64,
    stats: DaqStats,
}

impl std::fmt::Debug for NiDaq {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NiDaq")
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

impl NiDaq {
    /// Configures the device (channels, terminal configuration, range, sample clock, buffer)
    /// and commits it; nothing is acquired until [`GaugeSource::start`].
    pub fn open(library: &Arc<Library>, settings: DaqSettings) -> Result<NiDaq, DaqError> {
        settings.check()?;
        let device = settings.device.as_str();
        let sort = |setting, call| move |s: DaqmxStatus| DaqError::sort(device, setting, call, s);
        if let Some(Err(s)) = library.product_type(device) {
            return Err(sort(Setting::Device, "DAQmxGetDevProductType")(s));
        }
        let task = Task::create(library).map_err(sort(Setting::Device, "DAQmxCreateTask"))?;
        let (min, max) = (-settings.range.0, settings.range.0);
        let terminal = settings.terminal.code();
        task.add_voltage_channels(&settings.physical(&settings.gauges), terminal, min, max)
            .map_err(sort(Setting::Gauges, "DAQmxCreateAIVoltageChan"))?;
        if let Some(strobe) = &settings.strobe {
            task.add_voltage_channels(&settings.physical(strobe), terminal, min, max)
                .map_err(sort(Setting::Strobe, "DAQmxCreateAIVoltageChan"))?;
        }
        task.continuous_sample_clock(
            settings.rate.0,
            u64::from(settings.buffer_scans.unwrap_or(0)),
        )
        .map_err(sort(Setting::Rate, "DAQmxCfgSampClkTiming"))?;
        if let Some(scans) = settings.buffer_scans {
            task.input_buffer(scans)
                .map_err(sort(Setting::Buffer, "DAQmxCfgInputBuffer"))?;
        }
        task.commit()
            .map_err(sort(Setting::Rate, "DAQmxTaskControl(commit)"))?;
        let block = ((settings.rate.0 * BLOCK_S).round() as usize).max(1);
        Ok(NiDaq {
            task,
            trigger: None,
            block,
            running: false,
            buffer: Vec::new(),
            pending: VecDeque::new(),
            next_index: 0,
            read_in_task: 0,
            task_started: Instant::now(),
            lost_before_next: 0,
            stats: DaqStats::default(),
            settings,
        })
    }

    /// Also pulses `trigger`'s counter at the frame rate, started by the analogue input's start
    /// trigger so that frame n's exposure begins at a known scan.
    pub fn with_camera_trigger(
        mut self,
        library: &Arc<Library>,
        trigger: CameraTrigger,
    ) -> Result<NiDaq, DaqError> {
        let device = self.settings.device.clone();
        let sort = |call| {
            let device = device.clone();
            move |s: DaqmxStatus| DaqError::sort(&device, Setting::Counter, call, s)
        };
        let frame_rate_ok = trigger.frame_rate.0.is_finite()
            && trigger.frame_rate.0 > 0.0
            && trigger.frame_rate.0 < self.settings.rate.0;
        let duty_ok = trigger.duty > 0.0 && trigger.duty < 1.0;
        if !(frame_rate_ok && duty_ok) {
            return Err(DaqError::Setting {
                setting: Setting::Counter,
                message: format!(
                    "a pulse train at {} Hz with duty {}: the frame rate must be positive and below the sample rate ({} Hz), the duty between 0 and 1",
                    trigger.frame_rate.0, trigger.duty, self.settings.rate.0
                ),
            });
        }
        let task = Task::create(library).map_err(sort("DAQmxCreateTask"))?;
        let counter = trigger.physical_counter(&device);
        task.add_pulse_train(&counter, trigger.frame_rate.0, trigger.duty, 0.0)
            .map_err(sort("DAQmxCreateCOPulseChanFreq"))?;
        if let Some(terminal) = trigger.physical_terminal(&device) {
            task.pulse_terminal(&counter, &terminal)
                .map_err(sort("DAQmxSetCOPulseTerm"))?;
        }
        task.start_on_edge(&format!("/{device}/ai/StartTrigger"))
            .map_err(sort("DAQmxCfgDigEdgeStartTrig"))?;
        task.commit().map_err(sort("DAQmxTaskControl(commit)"))?;
        self.trigger = Some((trigger, task));
        Ok(self)
    }

    pub fn settings(&self) -> &DaqSettings {
        &self.settings
    }

    /// Counters since the device was opened.
    pub fn stats(&self) -> DaqStats {
        self.stats
    }

    fn device_error(&self, e: DaqError) -> ForceError {
        ForceError::Device {
            device: self.describe(),
            message: e.to_string(),
        }
    }

    fn start_tasks(&mut self) -> Result<(), DaqError> {
        let device = self.settings.device.clone();
        if let Some((_, co)) = &self.trigger {
            // Armed first: it starts on the analogue input's start trigger.
            co.start()
                .map_err(|s| DaqError::sort(&device, Setting::Counter, "DAQmxStartTask", s))?;
        }
        self.task
            .start()
            .map_err(|s| DaqError::sort(&device, Setting::Rate, "DAQmxStartTask", s))?;
        self.task_started = Instant::now();
        self.read_in_task = 0;
        Ok(())
    }

    fn stop_tasks(&mut self) -> Result<(), DaqmxStatus> {
        let ai = self.task.stop();
        let co = match &self.trigger {
            Some((_, co)) => co.stop(),
            None => Ok(()),
        };
        ai.and(co)
    }

    /// After the buffer overflowed: restart and skip the lost scans in the index.
    fn recover(&mut self) -> Result<(), ForceError> {
        let fell_behind = Instant::now();
        let rate = self.settings.rate.0;
        let acquired = self
            .task
            .total_acquired()
            .unwrap_or_else(|| (self.task_started.elapsed().as_secs_f64() * rate).round() as u64);
        let unread = acquired.saturating_sub(self.read_in_task);
        // Stopping a task that already failed may report that failure again: it is stopped.
        let _ = self.stop_tasks();
        self.start_tasks().map_err(|e| self.device_error(e))?;
        let gap = (fell_behind.elapsed().as_secs_f64() * rate).round() as u64;
        let lost = unread + gap;
        self.next_index += lost;
        self.lost_before_next += lost;
        self.stats.overruns += 1;
        self.stats.lost += lost;
        Ok(())
    }

    fn take_block(&mut self, scans: usize, arrived: HostTime) {
        let per_scan = self.settings.channels_per_scan();
        let strobe = self.settings.strobe.is_some();
        for scan in self.buffer.chunks_exact(per_scan).take(scans) {
            let gauges = std::array::from_fn(|i| Volts(scan[i]));
            self.pending.push_back(GaugeReading {
                index: self.next_index,
                host_time: arrived,
                gauges,
                strobe: strobe.then(|| Volts(scan[6])),
                lost_before: std::mem::take(&mut self.lost_before_next),
            });
            self.next_index += 1;
        }
        self.read_in_task += scans as u64;
        self.stats.scans += scans as u64;
    }
}

impl GaugeSource for NiDaq {
    fn describe(&self) -> String {
        self.settings.describe()
    }

    fn start(&mut self) -> Result<(), ForceError> {
        if self.running {
            return Ok(());
        }
        self.pending.clear();
        self.start_tasks().map_err(|e| self.device_error(e))?;
        self.running = true;
        Ok(())
    }

    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        if let Some(r) = self.pending.pop_front() {
            return Ok(Some(r));
        }
        if !self.running {
            return Err(ForceError::Device {
                device: self.describe(),
                message: "acquisition is not running; start it first".into(),
            });
        }
        let per_scan = self.settings.channels_per_scan();
        let mut buffer = std::mem::take(&mut self.buffer);
        let read = self
            .task
            .read(self.block, per_scan, timeout.as_secs_f64(), &mut buffer);
        self.buffer = buffer;
        let arrived = HostTime::now();
        match read {
            Ok(n) => self.take_block(n, arrived),
            Err(ReadError { scans, status: s }) => match s.code {
                status::SAMPLES_NOT_YET_AVAILABLE => self.take_block(scans, arrived),
                status::SAMPLES_NO_LONGER_AVAILABLE | status::INPUT_FIFO_OVERFLOW => {
                    self.recover()?
                }
                _ => {
                    let e = DaqError::sort(
                        &self.settings.device,
                        Setting::Device,
                        "DAQmxReadAnalogF64",
                        s,
                    );
                    self.running = false;
                    return Err(self.device_error(e));
                }
            },
        }
        Ok(self.pending.pop_front())
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        if !self.running {
            return Ok(());
        }
        self.running = false;
        self.pending.clear();
        self.stop_tasks().map_err(|s| {
            self.device_error(DaqError::sort(
                &self.settings.device,
                Setting::Device,
                "DAQmxStopTask",
                s,
            ))
        })
    }
}
