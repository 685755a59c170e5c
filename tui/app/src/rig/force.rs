//! The F/T door: every force/torque interface described by one [`ForceSpec`] and opened by one
//! [`open_force`], for the rig and for the bring-up commands alike. Each interface is a module of
//! its own, its description and its opener: [`netft`] (an ATI Net F/T over RDT/UDP) and
//! [`nidaqmx`] (an ATI transducer's gauges read by an NI-DAQmx device).
//!
//! A new interface: its module here, a variant of [`ForceSpec`] with its arms, an arm of
//! [`open_force`], and its `driver` in the rig file's `[force]` section.

pub mod netft;
pub mod nidaqmx;

use crate::rig::device_open::{DeviceError, TraceTo};
use fringe_rig::force::ForceSensor;
use netft::{open_netft, NetFtSpec};
use nidaqmx::{open_daq, DaqSpec};
use std::path::Path;

/// A force/torque sensor: one variant per interface, all opened by [`open_force`].
#[derive(Debug, Clone, PartialEq)]
pub enum ForceSpec {
    /// An ATI Net F/T or Ethernet Axia over RDT/UDP.
    NetFt(NetFtSpec),
    /// An ATI transducer's gauges read by an NI-DAQmx device, converted by its `.cal` file.
    NiDaqmx(DaqSpec),
}

impl ForceSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        match self {
            ForceSpec::NetFt(n) => n.describe(),
            ForceSpec::NiDaqmx(d) => d.describe(),
        }
    }

    /// Whether the force stream carries the camera's exposure strobe (strobe sync possible).
    pub fn records_strobe(&self) -> bool {
        match self {
            ForceSpec::NetFt(_) => false,
            ForceSpec::NiDaqmx(d) => d.settings.strobe.is_some(),
        }
    }

    /// The name of its trace under `--record-trace DIR` (`DIR/<name>.trace`).
    pub fn trace_name(&self) -> &'static str {
        match self {
            ForceSpec::NetFt(_) => "netft",
            ForceSpec::NiDaqmx(_) => "force",
        }
    }
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
