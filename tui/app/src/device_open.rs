//! The one opener of real devices: a [`device_spec`](crate::device_spec) description, from a rig
//! file section or from a bring-up command's flags, becomes a driver on its link, the link's
//! traffic recorded when asked. The rig (`RigConfig::open`) and `fringe ystage`, `axis`, `ft`,
//! `daq` and `camera` all open their devices here; every force sensor through [`open_force`].

use crate::device_spec::{
    AxisSpec, CameraSpec, DaqNames, DaqSpec, ForceSpec, ModbusLink, ModbusSpec, NetFtScaling,
    NetFtSpec,
};
use fringe_rig::apt::config::AptConfig;
use fringe_rig::apt::driver::open_serial;
use fringe_rig::apt::ThorlabsAxis;
use fringe_rig::atical::{CalibratedSensor, Calibration, GaugeReading, GaugeSource};
use fringe_rig::axis::{Axis, AxisError};
use fringe_rig::camera::{Camera, CameraError};
use fringe_rig::force::{ForceError, ForceSensor};
use fringe_rig::manual::ManualStage;
use fringe_rig::modbus::{Framing, MapError, ModbusStage, RegisterMap, StageOptions};
use fringe_rig::netft::{self, NetFt};
use fringe_rig::nidaqmx::{DaqError, DaqStats, Library, NiDaq, Setting};
use fringe_rig::operator::Operator;
use fringe_rig::trace::record::{record_datagrams, record_stream};
use fringe_rig::trace::RecordingGauges;
use fringe_rig::transport::serial::SerialLink;
use fringe_rig::transport::tcp::TcpLink;
use fringe_rig::transport::udp::UdpLink;
use fringe_rig::transport::{ByteLink, DatagramLink};
use std::io;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// How long a TCP connection or the Net F/T's configuration page may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

/// Where a device's link traffic is recorded: `DIR/<name>.trace` when `dir` is given.
#[derive(Debug, Clone, Copy)]
pub struct TraceTo<'a> {
    pub dir: Option<&'a Path>,
    pub name: &'a str,
}

impl<'a> TraceTo<'a> {
    pub fn new(dir: Option<&'a Path>, name: &'a str) -> TraceTo<'a> {
        TraceTo { dir, name }
    }
}

/// A device that could not be opened; each names the device and what to check.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// The port or address could not be opened (the message names it and what to check).
    #[error("{device}: {source}")]
    Link {
        device: String,
        #[source]
        source: io::Error,
    },
    #[error("{device}: cannot record the trace in {dir}: {source} (check the --record-trace directory exists and is writable)")]
    Trace {
        device: String,
        dir: String,
        #[source]
        source: io::Error,
    },
    #[error("{device}: {source}")]
    Map {
        device: String,
        #[source]
        source: Box<MapError>,
    },
    /// The driver refused or the device did not answer.
    #[error("{device}: {source}")]
    Axis {
        device: String,
        #[source]
        source: Box<AxisError>,
    },
    #[error("{device}: {source}")]
    Force {
        device: String,
        #[source]
        source: Box<ForceError>,
    },
    /// The NI-DAQmx device, its library or its `.cal` file: one line naming the key or flag
    /// to change and what to do.
    #[error("{line}")]
    Daq {
        line: String,
        /// The driver's error (its text is in `line`, said in the user's terms).
        error: Box<DaqError>,
    },
    /// The `.cal` file cannot be read or parsed.
    #[error("{line}")]
    CalFile {
        line: String,
        #[source]
        source: Box<fringe_rig::atical::CalError>,
    },
    #[error("camera: {0}")]
    Camera(#[source] Box<CameraError>),
    #[error("camera: this fringe was built without Aravis camera support: rebuild with `cargo build --release --features aravis` (needs `sudo apt install libaravis-dev libusb-1.0-0-dev`)")]
    NoAravis,
    #[error("{device}: a stage moved by hand needs an operator to ask, and none was given")]
    NoOperator { device: String },
}

fn recorded(
    link: Box<dyn ByteLink>,
    trace: TraceTo,
    device: &str,
) -> Result<Box<dyn ByteLink>, DeviceError> {
    record_stream(link, trace.dir, trace.name).map_err(|source| DeviceError::Trace {
        device: device.to_string(),
        dir: trace
            .dir
            .map(|d| d.display().to_string())
            .unwrap_or_default(),
        source,
    })
}

/// Opens the axis `spec` describes; a manual stage asks `operator`.
pub fn open_axis(
    spec: &AxisSpec,
    trace: TraceTo,
    operator: Option<Box<dyn Operator>>,
) -> Result<Box<dyn Axis>, DeviceError> {
    match spec {
        AxisSpec::Thorlabs { port, config } => {
            Ok(Box::new(open_thorlabs(port, config.clone(), trace)?))
        }
        AxisSpec::Modbus(m) => Ok(Box::new(open_modbus(m, trace)?)),
        AxisSpec::Manual { name, limits } => {
            let operator = operator.ok_or_else(|| DeviceError::NoOperator {
                device: name.clone(),
            })?;
            Ok(Box::new(ManualStage::new(name, operator, *limits)))
        }
    }
}

/// A Thorlabs axis on the serial port `port`.
pub fn open_thorlabs(
    port: &str,
    config: AptConfig,
    trace: TraceTo,
) -> Result<ThorlabsAxis, DeviceError> {
    let device = config.axis.clone();
    let serial = open_serial(port).map_err(|source| DeviceError::Link {
        device: device.clone(),
        source,
    })?;
    let link = recorded(Box::new(serial), trace, &device)?;
    ThorlabsAxis::connect(link, config).map_err(|source| DeviceError::Axis {
        device,
        source: Box::new(source),
    })
}

/// A Modbus stage.
pub fn open_modbus(spec: &ModbusSpec, trace: TraceTo) -> Result<ModbusStage, DeviceError> {
    let device = spec.name.clone();
    let map = RegisterMap::load(&spec.map).map_err(|source| DeviceError::Map {
        device: device.clone(),
        source: Box::new(source),
    })?;
    let link_error = |source| DeviceError::Link {
        device: device.clone(),
        source,
    };
    let (link, framing): (Box<dyn ByteLink>, Framing) = match &spec.link {
        ModbusLink::Tcp(address) => (
            Box::new(TcpLink::connect(&address.to_string(), CONNECT_TIMEOUT).map_err(link_error)?),
            Framing::Tcp,
        ),
        ModbusLink::Rtu { port } => (
            Box::new(SerialLink::open(port, &map.serial_settings(spec.baud)).map_err(link_error)?),
            Framing::Rtu,
        ),
    };
    let link = recorded(link, trace, &device)?;
    Ok(ModbusStage::new(
        &spec.name,
        link,
        framing,
        map,
        StageOptions {
            slave: spec.slave,
            limits: spec.limits,
            baud: spec.baud,
            ..StageOptions::default()
        },
    ))
}

/// A Net F/T, its scaling read from the box first when not given.
pub fn open_netft(
    spec: &NetFtSpec,
    trace: TraceTo,
) -> Result<NetFt<Box<dyn DatagramLink>>, DeviceError> {
    let device = "force";
    let config = match &spec.scaling {
        NetFtScaling::Given(config) => config.clone(),
        NetFtScaling::FromBox { url } => {
            let url = url
                .clone()
                .unwrap_or_else(|| netft::netftapi2_url(&spec.address.url_host()));
            netft::fetch_config(&url, CONNECT_TIMEOUT).map_err(|source| DeviceError::Force {
                device: device.into(),
                source: Box::new(source),
            })?
        }
    };
    let address = spec.address.to_string();
    let link: Box<dyn DatagramLink> =
        Box::new(UdpLink::connect(&address).map_err(|e| DeviceError::Link {
            device: device.into(),
            source: io::Error::new(
                e.kind(),
                format!("cannot open a UDP socket to Net F/T {address}: {e}"),
            ),
        })?);
    let link =
        record_datagrams(link, trace.dir, trace.name).map_err(|source| DeviceError::Trace {
            device: device.into(),
            dir: trace
                .dir
                .map(|d| d.display().to_string())
                .unwrap_or_default(),
            source,
        })?;
    Ok(NetFt::new(link, config, spec.options))
}

/// The force sensor `spec` describes, whatever its interface; `record_trace` records its
/// traffic to `DIR/<name>.trace` ([`ForceSpec::trace_name`]).
pub fn open_force(
    spec: &ForceSpec,
    record_trace: Option<&Path>,
) -> Result<Box<dyn ForceSensor>, DeviceError> {
    let trace = TraceTo::new(record_trace, spec.trace_name());
    Ok(match spec {
        ForceSpec::NetFt(n) => Box::new(open_netft(n, trace)?),
        ForceSpec::NiDaqmx(d) => Box::new(open_daq(d, trace)?),
    })
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
pub fn open_daq_with(
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
    let sensor = CalibratedSensor::new(gauges, calibration).with_bias_scans(bias_scans);
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

/// A camera.
pub fn open_camera(spec: &CameraSpec) -> Result<Box<dyn Camera>, DeviceError> {
    match spec {
        #[cfg(feature = "aravis")]
        CameraSpec::Aravis { id } => {
            let camera = fringe_rig::camera::aravis::AravisCamera::open(id.as_deref())
                .map_err(|e| DeviceError::Camera(Box::new(e)))?;
            Ok(Box::new(camera))
        }
        #[cfg(not(feature = "aravis"))]
        CameraSpec::Aravis { .. } => Err(DeviceError::NoAravis),
    }
}
