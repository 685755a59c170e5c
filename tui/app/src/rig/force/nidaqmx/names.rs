//! Who described a DAQ (the rig file's keys or `fringe daq`'s flags), so that an error names
//! what the user wrote. A module of its own: the rig file's checks name the keys too.

use fringe_rig::nidaqmx::Setting;

/// Where a DAQ's settings were given, so that an error names what the user wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DaqNames {
    /// A rig file's `[force]` keys.
    RigFile,
    /// `fringe daq`'s flags.
    Flags,
}

impl DaqNames {
    /// The key or flag of `setting`, as a user would write it in a message ("key
    /// `force.device`", "--device").
    pub fn of(self, setting: Setting) -> String {
        let (key, flag) = match setting {
            Setting::Library => ("library", "--library"),
            Setting::Device => ("device", "--device"),
            Setting::Gauges => ("gauges", "--channels"),
            Setting::Strobe => ("strobe", "--strobe"),
            Setting::Terminal => ("terminal", "--terminal"),
            Setting::Range => ("range_v", "--range"),
            Setting::Rate => ("rate_hz", "--rate"),
            Setting::Buffer => ("buffer_scans", "--buffer-scans"),
            Setting::CalFile => ("cal_file", "--cal"),
            Setting::Counter => {
                return match self {
                    DaqNames::RigFile => "keys `force.trigger_counter` and `camera.trigger`".into(),
                    DaqNames::Flags => "the camera trigger's counter".into(),
                }
            }
        };
        match self {
            DaqNames::RigFile => format!("key `force.{key}`"),
            DaqNames::Flags => flag.into(),
        }
    }
}
