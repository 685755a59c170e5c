//! Bringing up an NI-DAQmx force path (`fringe daq`): taking a bias at the current load (its
//! stream is [`stream_to_csv`](crate::bringup::force_stream::stream_to_csv), as `fringe ft`'s).
//! The command parses its flags into a [`DaqSpec`](crate::rig::force::nidaqmx::DaqSpec), opens
//! it with [`open_daq`](crate::rig::force::nidaqmx::open_daq) and prints what these return.

use crate::bringup::error::BringupError;
use crate::bringup::force_stream::STALL;
use crate::bringup::interface::Interface;
use fringe_rig::atical::{CalibratedSensor, GaugeSource};
use fringe_rig::ForceSensor;
use fringe_rig::HostTime;
use std::time::Duration;

/// What a bias left: the bias voltages and the mean reading after it.
#[derive(Debug, Clone, PartialEq)]
pub struct BiasReport {
    /// The gauge voltages subtracted from now on, V.
    pub volts: [f64; 6],
    /// Mean of the samples in the 100 ms after the bias: Fx Fy Fz (N), Tx Ty Tz (N m).
    pub mean_after: [f64; 6],
    /// Samples averaged.
    pub samples: u64,
}

/// Takes a bias at the current load and reads 100 ms after it.
pub fn bias<G: GaugeSource>(sensor: &mut CalibratedSensor<G>) -> Result<BiasReport, BringupError> {
    sensor.start()?;
    let result = bias_started(sensor);
    let stopped = sensor.stop();
    let report = result?;
    stopped?;
    Ok(report)
}

fn bias_started<G: GaugeSource>(
    sensor: &mut CalibratedSensor<G>,
) -> Result<BiasReport, BringupError> {
    sensor.bias()?;
    let mut sum = [0.0; 6];
    let mut n = 0u64;
    let mut first: Option<HostTime> = None;
    loop {
        let Some(s) = sensor.next_sample(STALL)? else {
            return Err(BringupError::Stalled {
                interface: Interface::Daq { strobe: false },
                device: sensor.describe(),
                waited: STALL,
            });
        };
        let t0 = *first.get_or_insert(s.host_time);
        for (a, v) in sum.iter_mut().zip(s.wrench.to_array()) {
            *a += v;
        }
        n += 1;
        if s.host_time.since(t0) >= Duration::from_millis(100) {
            break;
        }
    }
    Ok(BiasReport {
        volts: sensor.bias_volts(),
        mean_after: sum.map(|v| v / n as f64),
        samples: n,
    })
}
