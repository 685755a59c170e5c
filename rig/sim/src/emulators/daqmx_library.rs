//! A simulated NI-DAQmx library: NI's C functions over simulated devices, for the real driver
//! ([`fringe_rig::nidaqmx`]) to run against without NI's library or hardware.
//!
//! - [`device`]: a device (an NI USB-6218 by default): what its inputs carry ([`DaqSignals`]),
//!   its sample clock's error and transfers, its ADC, an unplug, the camera trigger's pulses.
//! - `task`: channels, timing and the acquisition filling a task's buffer on the sample clock,
//!   with NI's documented read, timeout and overflow behaviour.
//! - [`c_api`]: the functions with NI's C signatures over a process-wide registry, and
//!   [`c_api::lookup`] giving them by NI's names to the driver's one resolver.
//! - [`texts`]: NI's status codes and texts.
//!
//! The simulated bench's force path is this library under the real driver
//! ([`crate::emulators::daq_emulator`]); the tests' fake `libnidaqmx.so` (`tests/fake-nidaqmx`) exports the
//! same functions from a shared object.

pub(crate) mod c_api;
pub(crate) mod device;
mod task;
pub(crate) mod texts;

pub use device::{DaqSignals, DeviceModel, DeviceTiming, SimDevice};
