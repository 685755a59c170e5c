//! Bringing up an ATI Net F/T (`fringe ft`): the RDT software bias, and the mean reading after
//! it (its stream is [`stream_to_csv`](crate::bringup::force_stream::stream_to_csv), as `fringe
//! daq`'s). The command parses its flags into a
//! [`NetFtSpec`](crate::rig::force::netft::NetFtSpec), opens it with
//! [`open_netft`](crate::rig::force::netft::open_netft) and prints what these return.

use crate::bringup::error::BringupError;
use fringe_rig::ForceSensor;
use std::time::{Duration, Instant};

/// The reading after a software bias.
#[derive(Debug, Clone, PartialEq)]
pub struct NetFtBias {
    /// Mean of the records in the 100 ms after the records in flight: Fx Fy Fz (N), Tx Ty Tz
    /// (N m).
    pub mean_after: [f64; 6],
    /// Records averaged.
    pub records: u32,
}

/// Sends the software bias (the sensor zeroed at the current load) and reads after it.
pub fn bias<S: ForceSensor + ?Sized>(sensor: &mut S) -> Result<NetFtBias, BringupError> {
    sensor.start()?;
    sensor.bias()?;
    // Skip records already in flight when the bias was applied, then average 100 ms.
    let wait = Duration::from_millis(500);
    let settle = Instant::now() + Duration::from_millis(50);
    let end = settle + Duration::from_millis(100);
    let mut sum = [0.0; 6];
    let mut n = 0u32;
    loop {
        let Some(s) = sensor.next_sample(wait)? else {
            return Err(BringupError::NoRecordAfterBias {
                device: sensor.describe(),
            });
        };
        let now = Instant::now();
        if now >= settle {
            for (a, v) in sum.iter_mut().zip(s.wrench.to_array()) {
                *a += v;
            }
            n += 1;
        }
        if now >= end && n > 0 {
            break;
        }
    }
    sensor.stop()?;
    Ok(NetFtBias {
        mean_after: sum.map(|v| v / f64::from(n)),
        records: n,
    })
}
