//! An ATI Net F/T or Ethernet Axia over RDT/UDP: its description and its opener.

use crate::rig::device_open::{DeviceError, TraceTo, CONNECT_TIMEOUT};
use crate::rig::file::RigConfig;
use crate::rig::force::section::ForceSection;
use crate::rig::host_port::HostPort;
use fringe_rig::record_datagrams;
use fringe_rig::ConfigError;
use fringe_rig::DatagramLink;
use fringe_rig::UdpLink;
use fringe_rig::{netft, netft::Command, NetFt, NetFtConfig, NetFtOptions};
use std::io;

/// An ATI Net F/T or Ethernet Axia over RDT/UDP.
#[derive(Debug, Clone, PartialEq)]
pub struct NetFtSpec {
    pub address: HostPort,
    pub scaling: NetFtScaling,
    pub options: NetFtOptions,
}

impl NetFtSpec {
    /// A Net F/T at `address` streaming in `mode`, the other driver settings the defaults.
    pub fn new(address: HostPort, scaling: NetFtScaling, mode: Command) -> NetFtSpec {
        NetFtSpec {
            address,
            scaling,
            options: NetFtOptions {
                mode,
                ..NetFtOptions::default()
            },
        }
    }
}

impl NetFtSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        format!("force: ATI Net F/T at {}", self.address)
    }
}

/// Where a Net F/T's counts per unit come from.
#[derive(Debug, Clone, PartialEq)]
pub enum NetFtScaling {
    /// Given (rig file `cpf`/`cpt`, `--cpf`/`--cpt`), checked when described.
    Given(NetFtConfig),
    /// Read from the box: `url`, or http://HOST/netftapi2.xml when `None` (where nothing
    /// listens on port 80, the page on TCP at the RDT port: an emulated box's).
    FromBox { url: Option<String> },
}

/// A Net F/T, its scaling read from the box first when not given.
pub fn open_netft(
    spec: &NetFtSpec,
    trace: TraceTo,
) -> Result<NetFt<Box<dyn DatagramLink>>, DeviceError> {
    let device = "force";
    let config = match &spec.scaling {
        NetFtScaling::Given(config) => config.clone(),
        NetFtScaling::FromBox { url } => match url {
            Some(url) => netft::fetch_config(url, CONNECT_TIMEOUT),
            None => netft::fetch_box_config(
                &spec.address.url_host(),
                spec.address.port,
                CONNECT_TIMEOUT,
            ),
        }
        .map_err(|source| DeviceError::Force {
            device: device.into(),
            source: Box::new(source),
        })?,
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

impl RigConfig {
    /// `[force]` with driver "netft".
    pub(crate) fn netft_spec(&self, f: &ForceSection) -> Result<NetFtSpec, ConfigError> {
        let text = f.address.as_deref().ok_or_else(|| {
            self.err("key `force.address` (the Net F/T's host or host:port) is required".into())
        })?;
        let address = HostPort::parse(text, Some(netft::DEFAULT_PORT))
            .map_err(|e| self.err(format!("key `force.address`: {e}")))?;
        let scaling = match (f.cpf, f.cpt) {
            (Some(cpf), Some(cpt)) => NetFtScaling::Given(
                NetFtConfig::new(
                    cpf,
                    cpt,
                    f.force_unit.as_deref().unwrap_or("N"),
                    f.torque_unit.as_deref().unwrap_or("Nm"),
                    "[force] cpf/cpt",
                )
                .map_err(|e| self.err(e.to_string()))?,
            ),
            (None, None) => NetFtScaling::FromBox { url: None },
            _ => return Err(self.err(
                "[force]: give both `cpf` and `cpt`, or neither (then they are read from the box)"
                    .into(),
            )),
        };
        Ok(NetFtSpec::new(address, scaling, Command::RealTime))
    }
}
