//! What went wrong with NI-DAQmx, sorted by what the user has to change.

use super::api::status;
use std::fmt;

/// A status NI-DAQmx returned, with its text (one line).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DaqmxStatus {
    /// NI's status code (negative: an error); 0 for a failure found before calling NI.
    pub code: i32,
    pub text: String,
}

impl fmt::Display for DaqmxStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.code == 0 {
            write!(f, "{}", self.text)
        } else {
            write!(f, "{} (NI-DAQmx status {})", self.text, self.code)
        }
    }
}

/// The setting an error is about, so that the application can name its own key or flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    Library,
    Device,
    Gauges,
    Strobe,
    Terminal,
    Range,
    Rate,
    Buffer,
    Counter,
    CalFile,
}

impl Setting {
    /// Plain words for the setting.
    pub fn words(self) -> &'static str {
        match self {
            Setting::Library => "the NI-DAQmx library",
            Setting::Device => "the device name",
            Setting::Gauges => "the gauge channels",
            Setting::Strobe => "the strobe channel",
            Setting::Terminal => "the terminal configuration",
            Setting::Range => "the input range",
            Setting::Rate => "the sample rate",
            Setting::Buffer => "the input buffer",
            Setting::Counter => "the camera trigger's counter",
            Setting::CalFile => "the .cal file",
        }
    }
}

/// Errors of the NI-DAQmx driver.
#[derive(Debug, thiserror::Error)]
pub enum DaqError {
    #[error("NI-DAQmx's library {} cannot be loaded ({reason}): install NI-DAQmx for Linux (NI's repository package for your distribution, then `sudo apt install ni-daqmx` and `sudo dkms autoinstall`), or give the library's path", tried.join(" or "))]
    LibraryMissing { tried: Vec<String>, reason: String },
    #[error("{library} is not a usable NI-DAQmx library: it has no {missing}; point at NI's libnidaqmx.so")]
    LibraryIncomplete { library: String, missing: String },
    /// A setting was refused before or by NI-DAQmx; `setting` says which.
    #[error("{}: {message}", setting.words())]
    Setting { setting: Setting, message: String },
    /// The device went away (unplugged, powered off).
    #[error("DAQ {device} is gone (unplugged or powered off?): {status}; plug it in again, check it in NI MAX or `nilsdev`, and resume")]
    Lost { device: String, status: DaqmxStatus },
    /// Another task or program holds the device.
    #[error("DAQ {device} is in use by another task or program: {status}; close it (another fringe, NI MAX's test panel) and try again")]
    Reserved { device: String, status: DaqmxStatus },
    /// Any other call that failed.
    #[error("DAQ {device}: {call} failed: {status}")]
    Call {
        device: String,
        call: &'static str,
        status: DaqmxStatus,
    },
}

impl DaqError {
    /// Sorts a status from configuring `setting` into what the user must change.
    pub fn sort(device: &str, setting: Setting, call: &'static str, s: DaqmxStatus) -> DaqError {
        // NI names the property a refused value belongs to ("Property: DAQmx_AI_Max").
        let property = [
            ("DAQmx_AI_Max", Setting::Range),
            ("DAQmx_AI_Min", Setting::Range),
            ("DAQmx_AI_TermCfg", Setting::Terminal),
            ("DAQmx_SampClk_Rate", Setting::Rate),
            ("DAQmx_Buf_Input_BufSize", Setting::Buffer),
        ]
        .into_iter()
        .find(|(p, _)| s.text.contains(&format!("Property: {p}")))
        .map(|(_, setting)| setting);
        if let (Some(setting), true) = (property, s.code < 0) {
            return DaqError::Setting {
                setting,
                message: format!("{device} refused it: {s}"),
            };
        }
        match s.code {
            status::INVALID_DEVICE_ID => DaqError::Setting {
                setting: Setting::Device,
                message: format!("no NI device is named {device:?}: {s}"),
            },
            status::PHYSICAL_CHAN_DOES_NOT_EXIST => DaqError::Setting {
                setting: if setting == Setting::Strobe {
                    Setting::Strobe
                } else {
                    Setting::Gauges
                },
                message: format!("{device} has no such channel: {s}"),
            },
            status::RESOURCE_RESERVED => DaqError::Reserved {
                device: device.into(),
                status: s,
            },
            c if status::device_lost(c) => DaqError::Lost {
                device: device.into(),
                status: s,
            },
            _ if s.code == 0 => DaqError::Setting {
                setting,
                message: s.text,
            },
            _ => match setting {
                Setting::Rate | Setting::Range | Setting::Terminal | Setting::Buffer => {
                    DaqError::Setting {
                        setting,
                        message: format!("{device} refused it: {s}"),
                    }
                }
                _ => DaqError::Call {
                    device: device.into(),
                    call,
                    status: s,
                },
            },
        }
    }

    /// The setting to change, when the error is about one.
    pub fn setting(&self) -> Option<Setting> {
        match self {
            DaqError::LibraryMissing { .. } | DaqError::LibraryIncomplete { .. } => {
                Some(Setting::Library)
            }
            DaqError::Setting { setting, .. } => Some(*setting),
            DaqError::Lost { .. } | DaqError::Reserved { .. } | DaqError::Call { .. } => None,
        }
    }
}
