//! ROS 2 without a ROS install, free of I/O: the messages fringe's stream publishes, encoded as
//! ROS 2 does (classic CDR, little endian, behind the 4-byte encapsulation header), their type
//! hashes (REP-2011, `RIHS01_...`) and the names rmw_zenoh gives their topics and entities
//! (key expressions, liveliness tokens, QoS). The Zenoh session and the MCAP file are the
//! application's; this crate only makes the bytes and the strings they carry.

#![warn(unreachable_pub)]
#![warn(unnameable_types)]

mod messages;
mod names;
#[cfg(feature = "zenoh")]
mod node;
#[cfg(feature = "mcap")]
mod recorder;
mod type_hash;

pub use messages::{
    encode, Classification, CompressedImage, EncodeError, Header, Image, Log, ObjectHypothesis,
    Point, PointStamped, RosMessage, Time, Vector3, Wrench, WrenchStamped,
};
pub use names::{
    mangle, namespace, node_token, publisher_token, topic_key, NameError, Qos, Reliability,
};
#[cfg(feature = "zenoh")]
pub use node::{Node, NodeConfig, NodeError, Publisher};
#[cfg(feature = "mcap")]
pub use recorder::{Channel, RecordError, Recorder};
pub use type_hash::{msg_definition, type_hash, MessageType};
