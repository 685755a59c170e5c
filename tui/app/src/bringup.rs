//! The bring-up commands' workflows on one device, outside a rig: the command parses its flags
//! into a device description, opens it with the one opener (`crate::rig`) and prints what these
//! return.
//!
//! - [`force_stream`]: an F/T sensor streamed into a CSV file (`fringe ft stream`, `fringe daq
//!   stream`): one writer and one loop, the [`interface`] choosing the columns and the words.
//! - [`netft`]: a Net F/T's software bias (`fringe ft bias`).
//! - [`daq`]: an NI-DAQmx force path's bias (`fringe daq bias`).
//! - [`error`]: why a stream or a bias failed.
//! - [`camera`]: frames grabbed into a folder (`fringe camera grab`).

pub mod camera;
pub mod daq;
pub(crate) mod error;
pub mod force_stream;
pub mod interface;
pub mod netft;
