//! The bring-up commands' workflows on one device, outside a rig: the command parses its flags
//! into a device description, opens it with the one opener (`crate::rig`) and prints what these
//! return.
//!
//! - [`daq`]: an NI-DAQmx force path (`fringe daq`): streaming, counting and a bias.

pub mod daq;
