//! An ATI transducer's gauges read by an NI-DAQmx device and converted by the transducer's `.cal`
//! file: its description, its opener, and its errors said in the terms of who described it (the
//! rig file's keys or `fringe daq`'s flags).

pub(crate) mod names;

use crate::rig::device_open::{DeviceError, TraceTo};
use crate::rig::file::RigConfig;
use crate::rig::force::section::{daq_settings, ForceSection};
use fringe_rig::atical::{CalibratedSensor, Calibration, GaugeReading, GaugeSource, ToolTransform};
use fringe_rig::nidaqmx::{
    CameraTrigger, DaqError, DaqSettings, DaqStats, Library, NiDaq, Setting,
};
use fringe_rig::ConfigError;
use fringe_rig::ForceError;
use fringe_rig::RecordingGauges;
use names::DaqNames;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// An NI-DAQmx device reading an ATI transducer's gauges (and the camera strobe), with the
/// transducer's `.cal` file.
#[derive(Debug, Clone, PartialEq)]
pub struct DaqSpec {
    pub settings: DaqSettings,
    /// The transducer's ATI calibration file.
    pub cal_file: PathBuf,
    /// NI-DAQmx's library, when not on the system's search path.
    pub library: Option<PathBuf>,
    /// Wrenches expressed in this tool frame, when given.
    pub tool: Option<ToolTransform>,
    /// The camera trigger the DAQ's counter generates, when it triggers the camera.
    pub camera_trigger: Option<CameraTrigger>,
    /// Who described it: errors name the rig file's key or the command's flag.
    pub named_by: DaqNames,
}

impl DaqSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        format!(
            "force: {}, calibration {}",
            self.settings.describe(),
            self.cal_file.display()
        )
    }
}

/// An ATI transducer read through an NI-DAQmx device: its gauges converted by the `.cal` file.
pub type DaqForce = CalibratedSensor<DaqGauges>;

/// The DAQ's gauge source, its reads recorded when asked.
pub enum DaqGauges {
    Live(NiDaq),
    Recorded(RecordingGauges<NiDaq>),
}

impl DaqGauges {
    /// The DAQ.
    pub fn daq(&self) -> &NiDaq {
        match self {
            DaqGauges::Live(d) => d,
            DaqGauges::Recorded(r) => r.inner(),
        }
    }

    /// The DAQ's counters: scans delivered, overruns and the scans they lost.
    pub fn stats(&self) -> DaqStats {
        self.daq().stats()
    }

    fn source(&mut self) -> &mut dyn GaugeSource {
        match self {
            DaqGauges::Live(d) => d,
            DaqGauges::Recorded(r) => r,
        }
    }
}

impl GaugeSource for DaqGauges {
    fn describe(&self) -> String {
        self.daq().describe()
    }
    fn start(&mut self) -> Result<(), ForceError> {
        self.source().start()
    }
    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        self.source().next_reading(timeout)
    }
    fn stop(&mut self) -> Result<(), ForceError> {
        self.source().stop()
    }
}

/// Seconds of scans a DAQ's bias averages.
const DAQ_BIAS_S: f64 = 0.1;

/// The DAQ `spec` describes: NI-DAQmx loaded (from `spec.library`, else the system's search
/// path), the device configured and committed, the `.cal` file read.
pub fn open_daq(spec: &DaqSpec, trace: TraceTo) -> Result<DaqForce, DeviceError> {
    let calibration = load_calibration(spec)?;
    let library = Library::load(spec.library.as_deref()).map_err(|e| daq_error(spec, e))?;
    open_daq_with(&library, calibration, spec, trace)
}

/// The DAQ `spec` describes on an NI-DAQmx library already loaded (the simulated bench's
/// in-process library; `spec.library` is not used) with its calibration already read
/// (`spec.cal_file` is not read): the opener [`open_daq`] ends in.
pub(crate) fn open_daq_with(
    library: &Arc<Library>,
    calibration: Calibration,
    spec: &DaqSpec,
    trace: TraceTo,
) -> Result<DaqForce, DeviceError> {
    let mut daq = NiDaq::open(library, spec.settings.clone()).map_err(|e| daq_error(spec, e))?;
    if let Some(trigger) = &spec.camera_trigger {
        daq = daq
            .with_camera_trigger(library, trigger.clone())
            .map_err(|e| daq_error(spec, e))?;
    }
    let gauges = match trace.dir {
        None => DaqGauges::Live(daq),
        Some(dir) => DaqGauges::Recorded(
            RecordingGauges::new(daq, &dir.join(format!("{}.trace", trace.name)), trace.name)
                .map_err(|source| DeviceError::Trace {
                    device: "force".into(),
                    dir: dir.display().to_string(),
                    source,
                })?,
        ),
    };
    let bias_scans = (spec.settings.rate.0 * DAQ_BIAS_S).round().max(1.0) as usize;
    let sensor = CalibratedSensor::new(gauges, calibration)
        .with_bias_scans(bias_scans)
        .with_saturation(spec.settings.range);
    Ok(match spec.tool {
        Some(tool) => sensor.with_tool(tool),
        None => sensor,
    })
}

fn load_calibration(spec: &DaqSpec) -> Result<Calibration, DeviceError> {
    Calibration::load(&spec.cal_file).map_err(|e| DeviceError::CalFile {
        line: format!(
            "force: {}: {e}; give the transducer's ATI calibration file (FT*.cal, from the CD or ATI's site by serial number)",
            spec.named_by.of(Setting::CalFile)
        ),
        source: Box::new(e),
    })
}

/// A DAQ error as one line naming the key or flag to change and what to do.
pub fn daq_error(spec: &DaqSpec, e: DaqError) -> DeviceError {
    let names = spec.named_by;
    let line = match (&e, e.setting()) {
        (DaqError::LibraryMissing { .. }, _) => format!(
            "force: {e} with {}",
            match names {
                DaqNames::RigFile =>
                    "key `force.library` in the rig file (or --library PATH for `fringe daq`)",
                DaqNames::Flags => "--library PATH (key `force.library` in a rig file)",
            }
        ),
        (DaqError::LibraryIncomplete { .. }, _) => {
            format!("force: {}: {e}", names.of(Setting::Library))
        }
        // NI's refusals get what to do; the driver's own checks already say it.
        (DaqError::Setting { message, .. }, Some(setting))
            if message.contains("NI-DAQmx status") =>
        {
            format!(
                "force ({}): {}: {message}; {}",
                spec.settings.describe(),
                names.of(setting),
                daq_advice(setting)
            )
        }
        (DaqError::Setting { message, .. }, Some(setting)) => format!(
            "force ({}): {}: {message}",
            spec.settings.describe(),
            names.of(setting),
        ),
        _ => format!("force ({}): {e}", spec.settings.describe()),
    };
    DeviceError::Daq {
        line,
        error: Box::new(e),
    }
}

/// What to do about a refused setting.
fn daq_advice(setting: Setting) -> String {
    match setting {
        Setting::Library => "point at NI's libnidaqmx.so".into(),
        Setting::Device => "give the device's name as NI MAX or `nilsdev` lists it (Dev1)".into(),
        Setting::Gauges => "name the six gauge channels in the .cal file's gauge order (ai0:5)".into(),
        Setting::Strobe => "name the one analogue input that carries the camera's exposure signal (ai7), or leave it out".into(),
        Setting::Terminal => format!(
            "use one of {} (ATI's DAQ wiring is diff)",
            fringe_rig::nidaqmx::Terminal::NAMES.join(", ")
        ),
        Setting::Range => "use an input range the device has (USB-6218: 10, 5, 1 or 0.2 V)".into(),
        Setting::Rate => "use a scan rate the device can give for all its channels (5000 Hz)".into(),
        Setting::Buffer => "leave it out for NI's default, or give more scans".into(),
        Setting::Counter => "use a counter the device has (ctr0) and a frame rate below the scan rate".into(),
        Setting::CalFile => "give the transducer's ATI calibration file".into(),
    }
}

impl RigConfig {
    /// `[force]` with driver "nidaqmx".
    pub(crate) fn daq_spec(&self, f: &ForceSection) -> Result<DaqSpec, ConfigError> {
        let settings =
            daq_settings(f).map_err(|(key, message)| self.err(format!("{key}: {message}")))?;
        let cal_file = f.cal_file.clone().ok_or_else(|| {
            self.err(
                "key `force.cal_file` (the transducer's ATI .cal file) is required for driver \"nidaqmx\"".into(),
            )
        })?;
        let tool = match (f.tool_translation_m, f.tool_rotation_deg) {
            (None, None) => None,
            (d, r) => {
                let d = d.unwrap_or([0.0; 3]);
                let r = r.unwrap_or([0.0; 3]);
                if let Some((key, _)) = [("tool_translation_m", d), ("tool_rotation_deg", r)]
                    .into_iter()
                    .find(|(_, v)| v.iter().any(|x| !x.is_finite()))
                {
                    return Err(self.err(format!(
                        "key `force.{key}`: must be three finite numbers (tool_translation_m in metres, tool_rotation_deg in degrees)"
                    )));
                }
                Some(ToolTransform::from_ati(d, r.map(f64::to_radians)))
            }
        };
        let camera_trigger = match self.daq_triggers_camera()? {
            true => Some(CameraTrigger {
                counter: f.trigger_counter.clone().unwrap_or_else(|| "ctr0".into()),
                terminal: f.trigger_terminal.clone(),
                frame_rate: self.camera_settings()?.frame_rate,
                duty: 0.5,
            }),
            false => None,
        };
        Ok(DaqSpec {
            settings,
            cal_file,
            library: f.library.clone(),
            tool,
            camera_trigger,
            named_by: DaqNames::RigFile,
        })
    }
}
