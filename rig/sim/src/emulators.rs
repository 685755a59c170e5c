//! The simulated devices, each speaking its real protocol to the real driver: the APT stepper
//! controller, the Modbus y stage, the Net F/T box, the camera, the DAQ and the NI-DAQmx library
//! it is read through. Emulators with a protocol are split into a sans-io core and its servers.

pub(crate) mod apt_emulator;
pub(crate) mod camera_emulator;
pub(crate) mod daq_emulator;
pub(crate) mod daqmx_library;
pub(crate) mod modbus_emulator;
pub(crate) mod netft_box;
pub(crate) mod netft_emulator;
