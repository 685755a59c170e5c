//! The one opener of real devices: a [`device_spec`](crate::rig::device_spec) description, from a rig
//! file section or from a bring-up command's flags, becomes a driver on its link, the link's
//! traffic recorded when asked. The rig (`RigConfig::open`) and `fringe ystage`, `axis`, `ft`,
//! `daq` and `camera` all open their devices here; every force sensor through
//! [`open_force`](crate::rig::force::open_force).

use crate::rig::device_spec::{AxisSpec, CameraSpec, ModbusLink, ModbusSpec};
use fringe_rig::apt::open_serial;
use fringe_rig::nidaqmx::DaqError;
use fringe_rig::record_stream;
use fringe_rig::AptConfig;
use fringe_rig::ByteLink;
use fringe_rig::ForceError;
use fringe_rig::ManualStage;
use fringe_rig::Operator;
use fringe_rig::SerialLink;
use fringe_rig::TcpLink;
use fringe_rig::ThorlabsAxis;
use fringe_rig::{modbus::MapError, Framing, ModbusStage, RegisterMap, StageOptions};
use fringe_rig::{Axis, AxisError};
use fringe_rig::{Camera, CameraError};
use std::io;
use std::path::Path;
use std::time::Duration;

/// How long a TCP connection or the Net F/T's configuration page may take.
pub(crate) const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

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

/// A camera.
pub(crate) fn open_camera(spec: &CameraSpec) -> Result<Box<dyn Camera>, DeviceError> {
    match spec {
        #[cfg(feature = "aravis")]
        CameraSpec::Aravis { id } => {
            let camera = fringe_rig::AravisCamera::open(id.as_deref())
                .map_err(|e| DeviceError::Camera(Box::new(e)))?;
            Ok(Box::new(camera))
        }
        #[cfg(not(feature = "aravis"))]
        CameraSpec::Aravis { .. } => Err(DeviceError::NoAravis),
    }
}
