//! ATI Net F/T and Ethernet Axia force/torque sensors over RDT (UDP).
//!
//! - [`rdt`]: the pure request/record codec.
//! - [`config`]: counts per force/torque and units, from configuration or the sensor's
//!   `netftapi2.xml`.
//! - [`stream`]: sequence accounting (lost, out-of-order) and status words.
//! - [`driver`]: [`NetFt`], a [`crate::force::ForceSensor`] on any datagram link.

pub(crate) mod config;
pub(crate) mod driver;
pub(crate) mod rdt;
pub(crate) mod stream;

pub use config::{
    fetch_box_config, fetch_config, netftapi2_url, parse_http_response, HttpError, NetFtConfig,
};
pub use driver::{BiasMode, NetFt, NetFtOptions};
pub use rdt::{
    decode_datagram, encode_datagram, Command, RdtError, Record, Records, Request, DEFAULT_PORT,
};
