//! The one opener of real devices: a [`device_spec`](crate::device_spec) description, from a rig
//! file section or from a bring-up command's flags, becomes a driver on its link, the link's
//! traffic recorded when asked. The rig (`RigConfig::open`) and `fringe ystage`, `axis`, `ft`
//! and `camera` all open their devices here.

use crate::device_spec::{AxisSpec, CameraSpec, ModbusLink, ModbusSpec, NetFtScaling, NetFtSpec};
use fringe_rig::apt::driver::{open_serial, AptConfig};
use fringe_rig::apt::ThorlabsAxis;
use fringe_rig::axis::{Axis, AxisError};
use fringe_rig::camera::{Camera, CameraError};
use fringe_rig::force::ForceError;
use fringe_rig::manual::ManualStage;
use fringe_rig::modbus::{Framing, MapError, ModbusStage, RegisterMap, StageOptions};
use fringe_rig::netft::{self, NetFt};
use fringe_rig::scan::control::Operator;
use fringe_rig::trace::record::{record_datagrams, record_stream};
use fringe_rig::transport::serial::SerialLink;
use fringe_rig::transport::tcp::TcpLink;
use fringe_rig::transport::udp::UdpLink;
use fringe_rig::transport::{ByteLink, DatagramLink};
use std::io;
use std::path::Path;
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
