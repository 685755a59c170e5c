//! The simulated devices, each speaking its real protocol to the real driver: the APT stepper
//! controller, the Modbus y stage, the Net F/T box, the camera, the DAQ and the NI-DAQmx library
//! it is read through. Emulators with a protocol are split into a sans-io core and its servers.

pub mod apt_emulator;
pub mod camera_emulator;
pub mod daq_emulator;
pub mod daqmx_library;
pub mod modbus_emulator;
pub mod netft_box;
pub mod netft_emulator;
