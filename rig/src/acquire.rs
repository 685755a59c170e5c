//! Acquisition: devices read on their own threads, samples and frames handed on through channels.
//!
//! - [`force_stream`]: a force/torque sensor read continuously; every sample goes to the recorder
//!   channel and the latest ones to a monitor that control loops and safety watchers read.

pub mod force_stream;
