//! Why a bring-up stream or bias failed, in the words of the command that ran it (`fringe ft`
//! and `fringe daq` have said the same things differently since each was written; their texts
//! are kept).

use crate::bringup::interface::Interface;
use fringe_rig::ForceError;
use std::io;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Why a bring-up stream or bias failed.
#[derive(Debug, thiserror::Error)]
pub enum BringupError {
    #[error("{}", create_text(*interface, path, source))]
    Create {
        interface: Interface,
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error(transparent)]
    Force(#[from] ForceError),
    #[error("{}", stalled_text(*interface, device, *waited))]
    Stalled {
        interface: Interface,
        device: String,
        waited: Duration,
    },
    #[error("{}", no_samples_text(*interface, device, *waited, path))]
    NoSamples {
        interface: Interface,
        device: String,
        waited: Duration,
        path: PathBuf,
    },
    #[error("{device}: no record after the bias command; check the stream")]
    NoRecordAfterBias { device: String },
}

fn create_text(interface: Interface, path: &Path, source: &io::Error) -> String {
    match interface {
        Interface::NetFt => format!(
            "cannot create {} (check the directory exists and is writable)",
            path.display()
        ),
        Interface::Daq { .. } => format!(
            "cannot create {} ({source}); check the directory exists and is writable",
            path.display()
        ),
    }
}

fn stalled_text(interface: Interface, device: &str, waited: Duration) -> String {
    match interface {
        Interface::NetFt => format!(
            "{device}: the stream stopped (no record for {} s); check the cable and that nothing else restarted the sensor",
            waited.as_secs()
        ),
        Interface::Daq { .. } => format!(
            "{device}: no sample for {} s: the acquisition stopped; check the USB cable and power, and that no other program (NI MAX's test panel) uses the device",
            waited.as_secs_f64()
        ),
    }
}

fn no_samples_text(interface: Interface, device: &str, waited: Duration, path: &Path) -> String {
    let advice = match interface {
        Interface::NetFt => "check the address and that the sensor streams",
        Interface::Daq { .. } => "check the device's name and that its sample clock runs",
    };
    format!(
        "{device}: no sample arrived in {:.1} s; nothing written to {} ({advice})",
        waited.as_secs_f64(),
        path.display()
    )
}
