//! A DAQ feeding gauge voltages, and the calibrated force sensor on top of it.

use super::calfile::Calibration;
use super::transform::ToolTransform;
use crate::clock::HostTime;
use crate::force::{ForceError, ForceSample, ForceSensor, StreamStats};
use crate::units::{Volts, Wrench};
use std::time::{Duration, Instant};

/// One scan of the DAQ: six gauge voltages and, if wired, the camera exposure strobe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaugeReading {
    /// The DAQ's sample index (its sample clock), consecutive without loss.
    pub index: u64,
    /// Host time at which the scan was received.
    pub host_time: HostTime,
    pub gauges: [Volts; 6],
    /// Extra channel sampled with the gauges (camera ExposureActive).
    pub strobe: Option<Volts>,
    /// Scans lost just before this one (the reader fell behind and acquisition restarted); the
    /// index skips them.
    pub lost_before: u64,
}

/// Something that delivers gauge voltages: a DAQ driver, a replay, a simulation.
pub trait GaugeSource: Send {
    /// A name for messages ("ni-daq Dev1/ai0:5").
    fn describe(&self) -> String;
    /// Starts acquisition.
    fn start(&mut self) -> Result<(), ForceError>;
    /// The next scan, or `None` if none arrived within `timeout`.
    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError>;
    /// Stops acquisition.
    fn stop(&mut self) -> Result<(), ForceError>;
}

impl<S: GaugeSource + ?Sized> GaugeSource for Box<S> {
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn start(&mut self) -> Result<(), ForceError> {
        (**self).start()
    }
    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        (**self).next_reading(timeout)
    }
    fn stop(&mut self) -> Result<(), ForceError> {
        (**self).stop()
    }
}

/// A force/torque sensor made of a gauge source and its `.cal` calibration.
pub struct CalibratedSensor<S: GaugeSource> {
    source: S,
    calibration: Calibration,
    tool: Option<ToolTransform>,
    bias: [f64; 6],
    bias_scans: usize,
    last_index: Option<u64>,
    stats: StreamStats,
    /// The gauges' limit, volts (the DAQ's input range), when known: a gauge read at it is
    /// saturated.
    limit: Option<f64>,
}

/// A gauge read at this share of its limit or beyond is saturated: the ADC clips at the end of
/// its range (within a few of its steps: 305 uV of 10 V at 16 bits), and what the gauge would
/// have read past it is lost. A reading short of it, however near, is still a reading.
pub const SATURATION_SHARE: f64 = 0.9999;

impl<S: GaugeSource> CalibratedSensor<S> {
    /// A sensor converting `source`'s voltages with `calibration` (no bias, no tool transform).
    pub fn new(source: S, calibration: Calibration) -> CalibratedSensor<S> {
        CalibratedSensor {
            source,
            calibration,
            tool: None,
            bias: [0.0; 6],
            bias_scans: 1,
            last_index: None,
            stats: StreamStats::default(),
            limit: None,
        }
    }

    /// Refuses scans with a gauge at the end of `range` (the DAQ's input range,
    /// +- volts) or beyond: a clipped gauge turns the calibration matrix's forces into
    /// nonsense (a normal force read as tens of newtons pulling), which no force check could
    /// then trust.
    pub fn with_saturation(mut self, range: Volts) -> Self {
        self.limit = Some(range.0);
        self
    }

    /// An error when a gauge of `r` is saturated.
    fn check_saturation(&self, r: &GaugeReading) -> Result<(), ForceError> {
        let Some(limit) = self.limit else {
            return Ok(());
        };
        match r
            .gauges
            .iter()
            .enumerate()
            .find(|(_, v)| v.0.abs() >= SATURATION_SHARE * limit)
        {
            Some((i, v)) => Err(ForceError::Device {
                device: self.source.describe(),
                message: format!(
                    "gauge {} (of 6, in the .cal file's order) read {:+.3} V at scan {}, the limit of the +-{limit} V input range: it is saturated and the forces cannot be read; the transducer is overloaded (take the load off), or its output needs a larger range (`force.range_v`)",
                    i + 1,
                    v.0,
                    r.index
                ),
            }),
            None => Ok(()),
        }
    }

    /// Expresses wrenches in a tool frame.
    pub fn with_tool(mut self, tool: ToolTransform) -> Self {
        self.tool = Some(tool);
        self
    }

    /// How many scans [`ForceSensor::bias`] averages (e.g. 500 for 0.1 s at 5 kHz).
    pub fn with_bias_scans(mut self, scans: usize) -> Self {
        self.bias_scans = scans.max(1);
        self
    }

    /// The bias voltages in use.
    pub fn bias_volts(&self) -> [f64; 6] {
        self.bias
    }

    /// The gauge source (for its own counters).
    pub fn source(&self) -> &S {
        &self.source
    }

    /// The gauge source, taken back (before it is started).
    pub fn into_source(self) -> S {
        self.source
    }

    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    fn read(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(r) = self.source.next_reading(left)? else {
                return Ok(None);
            };
            if let Some(last) = self.last_index {
                if r.index <= last {
                    self.stats.out_of_order += 1;
                    continue;
                }
                self.stats.lost += r.index - last - 1;
            } else {
                self.stats.lost += r.lost_before;
            }
            self.last_index = Some(r.index);
            self.stats.received += 1;
            return Ok(Some(r));
        }
    }
}

impl<S: GaugeSource> ForceSensor for CalibratedSensor<S> {
    fn describe(&self) -> String {
        format!(
            "{} (calibration {} {})",
            self.source.describe(),
            self.calibration.serial,
            self.calibration.source
        )
    }

    fn start(&mut self) -> Result<(), ForceError> {
        self.last_index = None;
        self.stats = StreamStats::default();
        self.source.start()
    }

    fn next_sample(&mut self, timeout: Duration) -> Result<Option<ForceSample>, ForceError> {
        let Some(r) = self.read(timeout)? else {
            return Ok(None);
        };
        self.check_saturation(&r)?;
        let volts = r.gauges.map(|v| v.0);
        let w = self
            .calibration
            .convert(volts, self.bias, self.tool.as_ref());
        Ok(Some(ForceSample {
            device_tick: r.index,
            transport_seq: None,
            host_time: r.host_time,
            wrench: Wrench::from_array(w),
            status: 0,
            strobe: r.strobe,
        }))
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        self.source.stop()
    }

    fn bias(&mut self) -> Result<(), ForceError> {
        let mut sum = [0.0; 6];
        let per_scan = Duration::from_secs(1);
        for _ in 0..self.bias_scans {
            let r = self.read(per_scan)?.ok_or_else(|| ForceError::NoData {
                device: self.source.describe(),
                waited: per_scan,
                hint:
                    "no gauge scan arrived to take the bias from; check that acquisition is running"
                        .into(),
            })?;
            self.check_saturation(&r)?;
            for (s, v) in sum.iter_mut().zip(r.gauges) {
                *s += v.0;
            }
        }
        self.bias = sum.map(|s| s / self.bias_scans as f64);
        Ok(())
    }

    fn stats(&self) -> StreamStats {
        self.stats
    }
}
