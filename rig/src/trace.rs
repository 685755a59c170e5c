//! Traces: what crossed a transport, on disk, in a human-readable format.
//!
//! A trace is recorded by wrapping any link in a [`record::RecordingLink`] / [`record::RecordingDatagramLink`]
//! (`--record-trace DIR` on every `fringe` command that opens devices), and replayed by a
//! [`ReplayLink`] / [`ReplayDatagramLink`] that feeds the recorded replies to a driver and checks
//! that the driver sends exactly the recorded bytes. The format is documented in
//! `docs/trace-format.md` and in [`format`].
//!
//! A DAQ's gauge scans are recorded in the same format, one datagram per scan ([`gauges`]): a
//! [`RecordingGauges`] wraps any [`crate::atical::GaugeSource`], and the unit tests play the trace back as a
//! gauge source (`gauges::ReplayGauges`) to check the recording.

pub(crate) mod format;
pub(crate) mod gauges;
pub(crate) mod record;
pub(crate) mod replay;

pub use format::Trace;
pub use gauges::RecordingGauges;
pub use record::{record_datagrams, record_stream};
pub use replay::{ReplayDatagramLink, ReplayHandle, ReplayLink, ReplayOptions, ReplayReport};
