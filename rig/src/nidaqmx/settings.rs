//! How the DAQ is wired and sampled: device, channels, terminal configuration, range and rate.

use super::api;
use super::error::{DaqError, Setting};
use crate::units::{Hertz, Volts};
use std::ffi::c_int;

/// How the analogue inputs are wired (NI's terminal configurations).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Terminal {
    /// Differential: ATI's DAQ wiring of the gauges (default).
    #[default]
    Differential,
    /// Referenced single-ended.
    Rse,
    /// Non-referenced single-ended.
    Nrse,
    /// Pseudo-differential.
    PseudoDifferential,
    /// The device's default for the channel.
    DeviceDefault,
}

impl Terminal {
    /// The names a rig file or flag uses.
    pub const NAMES: [&'static str; 5] = ["diff", "rse", "nrse", "pseudo-diff", "default"];

    pub fn parse(name: &str) -> Result<Terminal, DaqError> {
        Ok(match name {
            "diff" | "differential" => Terminal::Differential,
            "rse" => Terminal::Rse,
            "nrse" => Terminal::Nrse,
            "pseudo-diff" | "pseudodiff" => Terminal::PseudoDifferential,
            "default" => Terminal::DeviceDefault,
            other => {
                return Err(DaqError::Setting {
                    setting: Setting::Terminal,
                    message: format!("{other:?} is not one of {}", Terminal::NAMES.join(", ")),
                })
            }
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Terminal::Differential => "diff",
            Terminal::Rse => "rse",
            Terminal::Nrse => "nrse",
            Terminal::PseudoDifferential => "pseudo-diff",
            Terminal::DeviceDefault => "default",
        }
    }

    pub(crate) fn code(self) -> c_int {
        match self {
            Terminal::Differential => api::VAL_DIFF,
            Terminal::Rse => api::VAL_RSE,
            Terminal::Nrse => api::VAL_NRSE,
            Terminal::PseudoDifferential => api::VAL_PSEUDO_DIFF,
            Terminal::DeviceDefault => api::VAL_CFG_DEFAULT,
        }
    }
}

/// The DAQ's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct DaqSettings {
    /// NI device name ("Dev1", as NI MAX or `nilsdev` lists it).
    pub device: String,
    /// The six gauge channels, in the `.cal` file's gauge order ("ai0:5").
    pub gauges: String,
    /// The channel carrying the camera's exposure-active signal ("ai7"), if wired.
    pub strobe: Option<String>,
    pub terminal: Terminal,
    /// Input range, +- volts (the gauges' and the strobe's).
    pub range: Volts,
    /// Scans per second on the device's sample clock.
    pub rate: Hertz,
    /// Scans the driver's buffer holds per channel (NI's default for the rate when `None`: 2 s
    /// at 5 kHz).
    pub buffer_scans: Option<u32>,
}

impl Default for DaqSettings {
    fn default() -> Self {
        DaqSettings {
            device: "Dev1".into(),
            gauges: "ai0:5".into(),
            strobe: None,
            terminal: Terminal::Differential,
            range: Volts(10.0),
            rate: Hertz(5000.0),
            buffer_scans: None,
        }
    }
}

/// Gauges an ATI `.cal` matrix converts.
pub(crate) const GAUGES: usize = 6;

impl DaqSettings {
    /// Checks what can be checked without the device.
    pub fn check(&self) -> Result<(), DaqError> {
        let bad = |setting, message: String| Err(DaqError::Setting { setting, message });
        if self.device.trim().is_empty() || self.device.contains('/') {
            return bad(
                Setting::Device,
                format!(
                    "{:?} is not a device name: give the name NI MAX or `nilsdev` lists (Dev1)",
                    self.device
                ),
            );
        }
        let n = channel_count(&self.gauges).map_err(|message| DaqError::Setting {
            setting: Setting::Gauges,
            message,
        })?;
        if n != GAUGES {
            return bad(
                Setting::Gauges,
                format!(
                    "{:?} names {n} channel(s), but an ATI .cal file converts {GAUGES} gauges: name six, in the .cal file's gauge order (ai0:5)",
                    self.gauges
                ),
            );
        }
        if let Some(s) = &self.strobe {
            let n = channel_count(s).map_err(|message| DaqError::Setting {
                setting: Setting::Strobe,
                message,
            })?;
            if n != 1 {
                return bad(
                    Setting::Strobe,
                    format!("{s:?} names {n} channels; the strobe is one channel (ai7)"),
                );
            }
        }
        if !(self.range.0.is_finite() && self.range.0 > 0.0) {
            return bad(
                Setting::Range,
                format!(
                    "{} V: must be a positive number of volts (10 for +-10 V)",
                    self.range.0
                ),
            );
        }
        if !(self.rate.0.is_finite() && self.rate.0 > 0.0) {
            return bad(
                Setting::Rate,
                format!("{} Hz: must be a positive rate (5000)", self.rate.0),
            );
        }
        if self.buffer_scans == Some(0) {
            return bad(
                Setting::Buffer,
                "0 scans: leave it out for NI's default".into(),
            );
        }
        Ok(())
    }

    /// The physical channel string NI takes for `channels` ("ai0:5" on Dev1 is "Dev1/ai0:5";
    /// a name that already has a device is kept).
    pub fn physical(&self, channels: &str) -> String {
        channels
            .split(',')
            .map(str::trim)
            .map(|c| {
                if c.contains('/') {
                    c.to_string()
                } else {
                    format!("{}/{c}", self.device)
                }
            })
            .collect::<Vec<_>>()
            .join(",")
    }

    /// Channels read per scan: the gauges, then the strobe.
    pub fn channels_per_scan(&self) -> usize {
        GAUGES + usize::from(self.strobe.is_some())
    }

    /// One line for messages ("NI-DAQmx Dev1/ai0:5, strobe ai7, diff +-10 V, 5000 Hz").
    pub fn describe(&self) -> String {
        format!(
            "NI-DAQmx {}{}, {} +-{} V, {} Hz",
            self.physical(&self.gauges),
            self.strobe
                .as_ref()
                .map(|s| format!(", strobe {s}"))
                .unwrap_or_default(),
            self.terminal.name(),
            self.range.0,
            self.rate.0
        )
    }
}

/// How many channels a channel list names: "ai0:5" (a range, either direction), "ai0,ai3",
/// "Dev1/ai0:2, ai4".
pub(crate) fn channel_count(list: &str) -> Result<usize, String> {
    let mut n = 0;
    for part in list.split(',').map(str::trim) {
        let name = part.rsplit('/').next().unwrap_or(part);
        let digits_at = name
            .find(|c: char| c.is_ascii_digit())
            .ok_or_else(|| format!("{part:?} is not a channel name such as ai0 or ai0:5"))?;
        let (prefix, span) = name.split_at(digits_at);
        if prefix.is_empty() {
            return Err(format!(
                "{part:?} is not a channel name such as ai0 or ai0:5"
            ));
        }
        let number = |s: &str| {
            s.strip_prefix(prefix)
                .unwrap_or(s)
                .parse::<u32>()
                .map_err(|_| format!("{part:?} is not a channel name such as ai0 or ai0:5"))
        };
        n += match span.split_once(':') {
            Some((a, b)) => number(a)?.abs_diff(number(b)?) as usize + 1,
            None => {
                number(span)?;
                1
            }
        };
    }
    Ok(n)
}

/// The camera's trigger, generated by one of the DAQ's counters on the analogue input's clock.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraTrigger {
    /// The counter ("ctr0").
    pub counter: String,
    /// The terminal its pulses leave on ("PFI12"), when not the counter's default output.
    pub terminal: Option<String>,
    /// Frames per second.
    pub frame_rate: Hertz,
    /// Fraction of each period the pulse is high.
    pub duty: f64,
}

impl CameraTrigger {
    /// The counter's physical name ("Dev1/ctr0").
    pub fn physical_counter(&self, device: &str) -> String {
        if self.counter.contains('/') {
            self.counter.clone()
        } else {
            format!("{device}/{}", self.counter)
        }
    }

    /// The terminal's full name ("/Dev1/PFI12").
    pub fn physical_terminal(&self, device: &str) -> Option<String> {
        self.terminal.as_ref().map(|t| {
            if t.starts_with('/') {
                t.clone()
            } else {
                format!("/{device}/{t}")
            }
        })
    }

    /// The rising edge of pulse `n`, in analogue-input scans since the start (both tasks start
    /// on the same edge: pulse 0 at scan 0).
    pub fn pulse_scan(&self, n: u64, scan_rate: Hertz) -> f64 {
        n as f64 * scan_rate.0 / self.frame_rate.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_lists_count_as_ni_names_them() {
        assert_eq!(channel_count("ai0:5"), Ok(6));
        assert_eq!(channel_count("ai5:0"), Ok(6));
        assert_eq!(channel_count("Dev1/ai0:2, ai4"), Ok(4));
        assert_eq!(channel_count("ai7"), Ok(1));
        assert!(channel_count("seven").is_err());
        assert!(channel_count("ai0:x").is_err());
    }

    #[test]
    fn a_channel_list_that_is_not_six_gauges_is_refused_naming_the_setting() {
        let s = DaqSettings {
            gauges: "ai0:4".into(),
            ..DaqSettings::default()
        };
        let e = s.check().expect_err("five gauges");
        assert_eq!(e.setting(), Some(Setting::Gauges));
        assert!(e.to_string().contains("names 5 channel(s)"), "{e}");
        assert_eq!(
            DaqSettings::default().physical("ai0:5, Dev2/ai7"),
            "Dev1/ai0:5,Dev2/ai7"
        );
    }
}
