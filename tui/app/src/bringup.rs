//! The bring-up commands' workflows on one device, outside a rig: the command parses its flags
//! into a device description, opens it with the one opener (`crate::rig`) and prints what these
//! return.
//!
//! - `force_stream`: an F/T sensor streamed into a CSV file (`fringe ft stream`, `fringe daq
//!   stream`): one writer and one loop, the `interface` choosing the columns and the words.
//! - `netft`: a Net F/T's software bias (`fringe ft bias`).
//! - `daq`: an NI-DAQmx force path's bias (`fringe daq bias`).
//! - `error`: why a stream or a bias failed.
//! - `camera`: frames grabbed into a folder (`fringe camera grab`).

pub(crate) mod camera;
pub(crate) mod daq;
pub(crate) mod error;
pub(crate) mod force_stream;
pub(crate) mod interface;
pub(crate) mod netft;

pub use camera::{grab, open_source, CameraOpenError, CameraSource, GrabError, Grabbed};
pub use daq::{bias as bias_daq, BiasReport};
pub use error::BringupError;
pub use force_stream::{stream_to_csv, StreamReport};
pub use interface::Interface;
pub use netft::{bias as bias_netft, NetFtBias};
