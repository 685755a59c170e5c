//! NI-DAQmx data acquisition devices (the reference bench's NI USB-6218) reading an ATI
//! transducer's six gauges and the camera's exposure strobe, and triggering the camera.
//!
//! - [`api`]: the C functions and constants used, one table filled by one resolver.
//! - [`library`]: `libnidaqmx.so` loaded at run time (nothing from NI at build time) and its
//!   tasks behind safe calls.
//! - [`settings`]: device, channels, terminal configuration, range, rate; the camera trigger.
//! - [`gauges`]: [`NiDaq`], a [`crate::atical::GaugeSource`] for the `.cal` path.
//! - [`error`]: errors sorted by the setting to change.
//!
//! Which documented facts the driver relies on, and where NI documents them, is listed in
//! `docs/nidaqmx.md`.

pub mod api;
pub(crate) mod error;
pub(crate) mod gauges;
pub(crate) mod library;
pub(crate) mod settings;

pub use error::{DaqError, DaqmxStatus, Setting};
pub use gauges::{DaqStats, NiDaq};
pub use library::Library;
pub use settings::{CameraTrigger, DaqSettings, Terminal};
