//! The rig file's `[force]` section: which interface reads force and torque (`driver`), the
//! keys each interface takes, and the checks made when the file is read (each interface's
//! module turns the section into its description).

use crate::rig::force::nidaqmx::names::DaqNames;
use fringe_rig::nidaqmx::{DaqError, DaqSettings, Terminal};
use fringe_rig::{FtAxes, Hertz, Volts};
use serde::Deserialize;
use std::path::PathBuf;

/// What reads force and torque.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ForceDriver {
    #[default]
    Sim,
    /// ATI Net F/T or Ethernet Axia over RDT/UDP.
    Netft,
    /// An ATI transducer's gauges through an NI-DAQmx device and its `.cal` file.
    Nidaqmx,
}

impl ForceDriver {
    pub(crate) fn name(self) -> &'static str {
        match self {
            ForceDriver::Sim => "sim",
            ForceDriver::Netft => "netft",
            ForceDriver::Nidaqmx => "nidaqmx",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ForceSection {
    pub driver: ForceDriver,
    /// Net F/T host or host:port (port 49152 by default).
    pub address: Option<String>,
    /// Counts per force / torque unit; read from http://HOST/netftapi2.xml when not given.
    pub cpf: Option<f64>,
    pub cpt: Option<f64>,
    pub force_unit: Option<String>,
    pub torque_unit: Option<String>,
    /// Largest force the F/T sensor and the sensor under test may see, N (default 20).
    pub max_force: Option<f64>,
    /// NI-DAQmx device name (default Dev1).
    pub device: Option<String>,
    /// The six gauge channels in the .cal file's order (default ai0:5).
    pub gauges: Option<String>,
    /// The analogue input carrying the camera's exposure signal (e.g. ai7), if wired.
    pub strobe: Option<String>,
    /// diff (default), rse, nrse, pseudo-diff or default.
    pub terminal: Option<String>,
    /// Input range, +- volts (default 10).
    pub range_v: Option<f64>,
    /// Scans per second (default 5000).
    pub rate_hz: Option<f64>,
    /// Scans the input buffer holds per channel (NI's default when absent).
    pub buffer_scans: Option<u32>,
    /// The transducer's ATI calibration file (required for nidaqmx).
    pub cal_file: Option<PathBuf>,
    /// NI-DAQmx's library, when not on the system's search path.
    pub library: Option<PathBuf>,
    /// Tool frame: displacement (m) and ATI's rotation angles (degrees) of the `.cal` path.
    pub tool_translation_m: Option<[f64; 3]>,
    pub tool_rotation_deg: Option<[f64; 3]>,
    /// With `[camera] trigger = "daq"`: the counter pulsing the camera (default ctr0) and the
    /// terminal its pulses leave on (the counter's default output when absent).
    pub trigger_counter: Option<String>,
    pub trigger_terminal: Option<String>,
    /// How the F/T's axes sit on the bench, for shear labels in the sensor's frame: its x axis
    /// from the stage's +x, counter-clockwise seen from above (degrees), and whether its z
    /// points down at the tool (ATI's tool frame, the default). Without `x_axis_deg` frames
    /// carry no shear label.
    pub x_axis_deg: Option<f64>,
    pub z_toward_tool: Option<bool>,
}

impl ForceSection {
    /// How the F/T's axes sit on the bench, when the section says (`x_axis_deg`).
    pub(crate) fn ft_axes(&self) -> Option<FtAxes> {
        self.x_axis_deg.map(|x_axis_deg| FtAxes {
            x_axis_deg,
            z_toward_tool: self.z_toward_tool.unwrap_or(true),
        })
    }

    /// The Net F/T's keys given.
    fn netft_keys(&self) -> Vec<&'static str> {
        [
            ("address", self.address.is_some()),
            ("cpf", self.cpf.is_some()),
            ("cpt", self.cpt.is_some()),
            ("force_unit", self.force_unit.is_some()),
            ("torque_unit", self.torque_unit.is_some()),
        ]
        .into_iter()
        .filter_map(|(k, given)| given.then_some(k))
        .collect()
    }

    /// The NI-DAQmx keys given.
    fn daq_keys(&self) -> Vec<&'static str> {
        [
            ("device", self.device.is_some()),
            ("gauges", self.gauges.is_some()),
            ("strobe", self.strobe.is_some()),
            ("terminal", self.terminal.is_some()),
            ("range_v", self.range_v.is_some()),
            ("rate_hz", self.rate_hz.is_some()),
            ("buffer_scans", self.buffer_scans.is_some()),
            ("cal_file", self.cal_file.is_some()),
            ("library", self.library.is_some()),
            ("tool_translation_m", self.tool_translation_m.is_some()),
            ("tool_rotation_deg", self.tool_rotation_deg.is_some()),
            ("trigger_counter", self.trigger_counter.is_some()),
            ("trigger_terminal", self.trigger_terminal.is_some()),
        ]
        .into_iter()
        .filter_map(|(k, given)| given.then_some(k))
        .collect()
    }
}

/// Checks `[force]` as far as it can be without the rig: the Net F/T's counts, keys of another
/// driver than the one chosen, and a DAQ's settings and its `.cal` file. The message of the
/// first fault (the rig file names itself in front of it).
pub(crate) fn check_force_section(force: &ForceSection) -> Result<(), String> {
    for (key, v) in [("force.cpf", force.cpf), ("force.cpt", force.cpt)] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "key `{key}` = {v}: must be a number > 0 (counts per unit, from the sensor's calibration sheet)"
                ));
            }
        }
    }
    let driver = force.driver;
    if let Some(a) = force.x_axis_deg {
        if !a.is_finite() {
            return Err(format!(
                "key `force.x_axis_deg` = {a}: must be a number of degrees (the F/T's x axis from the stage's +x, counter-clockwise seen from above)"
            ));
        }
    }
    if force.z_toward_tool.is_some() && force.x_axis_deg.is_none() {
        return Err("key `force.z_toward_tool` needs `force.x_axis_deg` (the F/T's x axis from the stage's +x, counter-clockwise seen from above, degrees)".into());
    }
    if driver == ForceDriver::Sim && force.x_axis_deg.is_some() {
        return Err("key `force.x_axis_deg` on the simulated bench: its F/T's axes are those of its mount; remove the key".into());
    }
    // A simulated force sensor predates the DAQ's keys and has always ignored the Net F/T's.
    let foreign = match driver {
        ForceDriver::Netft | ForceDriver::Sim => force.daq_keys(),
        ForceDriver::Nidaqmx => force.netft_keys(),
    };
    if let Some(key) = foreign.first() {
        let owner = if driver == ForceDriver::Nidaqmx {
            "a Net F/T's (driver \"netft\")"
        } else {
            "an NI-DAQmx device's (driver \"nidaqmx\")"
        };
        let allowed = match driver {
            ForceDriver::Nidaqmx => DAQ_KEYS,
            ForceDriver::Netft => NETFT_KEYS,
            ForceDriver::Sim => "max_force; the simulated force path is chosen by `sim.force_path`",
        };
        return Err(format!(
            "key `force.{key}` is {owner}, but `force.driver` = \"{}\": remove it, or change the driver (driver \"{}\" takes {allowed})",
            driver.name(),
            driver.name(),
        ));
    }
    if driver == ForceDriver::Nidaqmx && force.cal_file.is_none() {
        return Err(
            "key `force.cal_file` (the transducer's ATI .cal file) is required for driver \"nidaqmx\"".into(),
        );
    }
    if driver == ForceDriver::Nidaqmx {
        daq_settings(force).map_err(|(key, message)| format!("{key}: {message}"))?;
    }
    Ok(())
}

/// The DAQ's settings from `[force]`, checked as far as they can be without the device; an
/// error names the key.
pub(crate) fn daq_settings(f: &ForceSection) -> Result<DaqSettings, (String, String)> {
    let named = |e: DaqError| match (&e, e.setting()) {
        (DaqError::Setting { message, .. }, Some(s)) => (DaqNames::RigFile.of(s), message.clone()),
        _ => ("[force]".to_string(), e.to_string()),
    };
    let d = DaqSettings::default();
    let settings = DaqSettings {
        device: f.device.clone().unwrap_or(d.device),
        gauges: f.gauges.clone().unwrap_or(d.gauges),
        strobe: f.strobe.clone(),
        terminal: match &f.terminal {
            Some(t) => Terminal::parse(t).map_err(named)?,
            None => d.terminal,
        },
        range: f.range_v.map_or(d.range, Volts),
        rate: f.rate_hz.map_or(d.rate, Hertz),
        buffer_scans: f.buffer_scans,
    };
    settings.check().map_err(named)?;
    Ok(settings)
}

/// The `[force]` keys each driver takes, for messages.
const NETFT_KEYS: &str =
    "address, cpf, cpt, force_unit, torque_unit, max_force, x_axis_deg, z_toward_tool";
const DAQ_KEYS: &str = "device, gauges, strobe, terminal, range_v, rate_hz, buffer_scans, cal_file, library, tool_translation_m, tool_rotation_deg, max_force, x_axis_deg, z_toward_tool";
