//! An emulated ATI Net F/T box: RDT over UDP (or an in-process datagram pipe) and its
//! `netftapi2.xml` configuration page over HTTP, close enough that the real [`fringe_rig::NetFt`]
//! driver and third-party clients (pynetft) cannot tell it from the box.
//!
//! [`NetFtCore`] is the sans-io box: RDT requests go in, datagrams that are due at a host time come
//! out. It keeps the box's own sample clock: `ft_sequence` counts internal samples since power-up at
//! [`NetFtEmulatorConfig::internal_rate`] (7000 Hz on a Net F/T, with an optional clock error in ppm)
//! and never resets; record `k` of a stream started at internal sample `n0` is internal sample
//! `n0 + floor(k * internal_rate / rdt_rate)` and is due at that sample's host time, so the output
//! is paced in real time with no accumulated drift. The load comes from a
//! [`ForceReading`](crate::scene::ForceReading) evaluated at each record's sample time.
//!
//! [`NetFtEmulator`] runs a core in a thread: [`NetFtEmulator::spawn_udp`] on a UDP socket
//! (replying to whoever sent the start request) plus the HTTP page, or
//! [`NetFtEmulator::spawn_in_process`] on a [`MemoryDatagramLink`].
//!
//! - [`core`]: the sans-io box.
//! - [`server`]: the box on a thread, over UDP or in process.
//! - [`http_page`]: its `netftapi2.xml` page over HTTP.

pub(crate) mod core;
pub(crate) mod http_page;
pub(crate) mod server;

pub use self::core::*;
pub use self::http_page::SimHttp;
pub use self::server::*;
