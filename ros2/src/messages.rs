//! The ROS 2 messages fringe's stream publishes and records, with their types' descriptions,
//! and their encoding as ROS 2 puts them on the wire and into MCAP: the 4-byte encapsulation
//! header of little-endian classic CDR (`00 01 00 00`), then the message in classic CDR (XCDR1),
//! aligned from the byte after the header (the `cdr-encoding` crate).

use crate::type_hash::{Field, FieldType, MessageType};
use serde::Serialize;

/// A ROS 2 message type this crate encodes.
pub trait RosMessage: Serialize {
    const TYPE: &'static MessageType;
}

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// A time in nanoseconds since the Unix epoch.
    pub fn from_unix_nanos(ns: u64) -> Time {
        Time {
            sec: (ns / 1_000_000_000) as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

impl Header {
    /// A header stamped `unix_ns` nanoseconds after the Unix epoch, in the frame `frame_id`.
    pub fn at_unix_nanos(unix_ns: u64, frame_id: &str) -> Header {
        Header {
            stamp: Time::from_unix_nanos(unix_ns),
            frame_id: frame_id.to_string(),
        }
    }
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Wrench`: newtons and newton metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Wrench {
    pub force: Vector3,
    pub torque: Vector3,
}

/// `geometry_msgs/msg/WrenchStamped`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WrenchStamped {
    pub header: Header,
    pub wrench: Wrench,
}

/// `geometry_msgs/msg/PointStamped`: metres, as every ROS 2 geometry message.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PointStamped {
    pub header: Header,
    pub point: Point,
}

/// `sensor_msgs/msg/CompressedImage`: `format` as `"jpeg"` or `"png"`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompressedImage {
    pub header: Header,
    pub format: String,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `vision_msgs/msg/ObjectHypothesis`: a class and its probability.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObjectHypothesis {
    pub class_id: String,
    pub score: f64,
}

/// `vision_msgs/msg/Classification`: one hypothesis per class.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Classification {
    pub header: Header,
    pub results: Vec<ObjectHypothesis>,
}

/// `sensor_msgs/msg/Image`: raw pixels, `step` bytes a row, `encoding` as
/// `sensor_msgs/image_encodings.hpp` names it (`mono8`, `rgb8`, `bayer_rggb8`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Image {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub encoding: String,
    pub is_bigendian: u8,
    pub step: u32,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `rcl_interfaces/msg/Log`: a log line as `/rosout` carries it (Foxglove's Log panel shows
/// it); `level` one of [`Log::DEBUG`] to [`Log::FATAL`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Log {
    pub stamp: Time,
    pub level: u8,
    pub name: String,
    pub msg: String,
    pub file: String,
    pub function: String,
    pub line: u32,
}

impl Log {
    pub const DEBUG: u8 = 10;
    pub const INFO: u8 = 20;
    pub const WARN: u8 = 30;
    pub const ERROR: u8 = 40;
    pub const FATAL: u8 = 50;
}

const fn field(name: &'static str, ty: FieldType) -> Field {
    Field { name, ty }
}

static TIME: MessageType = MessageType {
    name: "builtin_interfaces/msg/Time",
    fields: &[
        field("sec", FieldType::Int32),
        field("nanosec", FieldType::Uint32),
    ],
};
static HEADER: MessageType = MessageType {
    name: "std_msgs/msg/Header",
    fields: &[
        field("stamp", FieldType::Nested(&TIME)),
        field("frame_id", FieldType::String),
    ],
};
static XYZ: [Field; 3] = [
    field("x", FieldType::Float64),
    field("y", FieldType::Float64),
    field("z", FieldType::Float64),
];
static VECTOR3: MessageType = MessageType {
    name: "geometry_msgs/msg/Vector3",
    fields: &XYZ,
};
static POINT: MessageType = MessageType {
    name: "geometry_msgs/msg/Point",
    fields: &XYZ,
};
static WRENCH: MessageType = MessageType {
    name: "geometry_msgs/msg/Wrench",
    fields: &[
        field("force", FieldType::Nested(&VECTOR3)),
        field("torque", FieldType::Nested(&VECTOR3)),
    ],
};
static WRENCH_STAMPED: MessageType = MessageType {
    name: "geometry_msgs/msg/WrenchStamped",
    fields: &[
        field("header", FieldType::Nested(&HEADER)),
        field("wrench", FieldType::Nested(&WRENCH)),
    ],
};
static POINT_STAMPED: MessageType = MessageType {
    name: "geometry_msgs/msg/PointStamped",
    fields: &[
        field("header", FieldType::Nested(&HEADER)),
        field("point", FieldType::Nested(&POINT)),
    ],
};
static COMPRESSED_IMAGE: MessageType = MessageType {
    name: "sensor_msgs/msg/CompressedImage",
    fields: &[
        field("header", FieldType::Nested(&HEADER)),
        field("format", FieldType::String),
        field("data", FieldType::Uint8Sequence),
    ],
};
static OBJECT_HYPOTHESIS: MessageType = MessageType {
    name: "vision_msgs/msg/ObjectHypothesis",
    fields: &[
        field("class_id", FieldType::String),
        field("score", FieldType::Float64),
    ],
};
static CLASSIFICATION: MessageType = MessageType {
    name: "vision_msgs/msg/Classification",
    fields: &[
        field("header", FieldType::Nested(&HEADER)),
        field("results", FieldType::NestedSequence(&OBJECT_HYPOTHESIS)),
    ],
};
static IMAGE: MessageType = MessageType {
    name: "sensor_msgs/msg/Image",
    fields: &[
        field("header", FieldType::Nested(&HEADER)),
        field("height", FieldType::Uint32),
        field("width", FieldType::Uint32),
        field("encoding", FieldType::String),
        field("is_bigendian", FieldType::Uint8),
        field("step", FieldType::Uint32),
        field("data", FieldType::Uint8Sequence),
    ],
};
static LOG: MessageType = MessageType {
    name: "rcl_interfaces/msg/Log",
    fields: &[
        field("stamp", FieldType::Nested(&TIME)),
        field("level", FieldType::Uint8),
        field("name", FieldType::String),
        field("msg", FieldType::String),
        field("file", FieldType::String),
        field("function", FieldType::String),
        field("line", FieldType::Uint32),
    ],
};

impl RosMessage for Time {
    const TYPE: &'static MessageType = &TIME;
}
impl RosMessage for Header {
    const TYPE: &'static MessageType = &HEADER;
}
impl RosMessage for WrenchStamped {
    const TYPE: &'static MessageType = &WRENCH_STAMPED;
}
impl RosMessage for PointStamped {
    const TYPE: &'static MessageType = &POINT_STAMPED;
}
impl RosMessage for CompressedImage {
    const TYPE: &'static MessageType = &COMPRESSED_IMAGE;
}
impl RosMessage for ObjectHypothesis {
    const TYPE: &'static MessageType = &OBJECT_HYPOTHESIS;
}
impl RosMessage for Classification {
    const TYPE: &'static MessageType = &CLASSIFICATION;
}
impl RosMessage for Image {
    const TYPE: &'static MessageType = &IMAGE;
}
impl RosMessage for Log {
    const TYPE: &'static MessageType = &LOG;
}

/// A message that could not be encoded.
#[derive(Debug, thiserror::Error)]
#[error("{message}: cannot encode it as CDR: {source}")]
pub struct EncodeError {
    message: &'static str,
    source: cdr_encoding::Error,
}

/// The little-endian classic CDR encapsulation header.
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// `m` as ROS 2 publishes it: the encapsulation header, then the CDR body.
pub fn encode<M: RosMessage>(m: &M) -> Result<Vec<u8>, EncodeError> {
    let body =
        cdr_encoding::to_vec::<_, byteorder::LittleEndian>(m).map_err(|source| EncodeError {
            message: M::TYPE.name,
            source,
        })?;
    let mut out = Vec::with_capacity(4 + body.len());
    out.extend_from_slice(&CDR_LE);
    out.extend_from_slice(&body);
    Ok(out)
}

/// The raw image and the log line (`/rosout`'s type) against `rosbags` 0.11.9: their bytes
/// (`serialize_cdr`) and type hashes (`hash_rihs01` with its Jazzy type store).
#[cfg(test)]
mod image_and_log {
    use super::*;
    use crate::type_hash::{msg_definition, type_hash};

    /// A 3x2 mono8 image and a log line: a `uint8` field takes one byte, unaligned, and the
    /// strings and sequences after it align to 4.
    #[test]
    fn their_bytes_equal_rosbags_s() {
        let image = Image {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: "cam".into(),
            },
            height: 2,
            width: 3,
            encoding: "mono8".into(),
            is_bigendian: 0,
            step: 3,
            data: vec![1, 2, 3, 4, 5, 6],
        };
        assert_eq!(
            encode(&image).expect("encode"),
            vec![
                0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 4, 0, 0, 0, 99, 97, 109, 0, 2, 0, 0, 0, 3, 0,
                0, 0, 6, 0, 0, 0, 109, 111, 110, 111, 56, 0, 0, 0, 3, 0, 0, 0, 6, 0, 0, 0, 1, 2, 3,
                4, 5, 6
            ]
        );
        let log = Log {
            stamp: Time { sec: 5, nanosec: 6 },
            level: Log::WARN,
            name: "fringe".into(),
            msg: "pause".into(),
            file: String::new(),
            function: String::new(),
            line: 0,
        };
        assert_eq!(
            encode(&log).expect("encode"),
            vec![
                0, 1, 0, 0, 5, 0, 0, 0, 6, 0, 0, 0, 30, 0, 0, 0, 7, 0, 0, 0, 102, 114, 105, 110,
                103, 101, 0, 0, 6, 0, 0, 0, 112, 97, 117, 115, 101, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0,
                0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0
            ]
        );
    }

    #[test]
    fn their_hashes_and_definitions_are_those_ros_2_gives() {
        assert_eq!(
            type_hash(Image::TYPE),
            "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47"
        );
        assert_eq!(
            type_hash(Log::TYPE),
            "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac"
        );
        let i = msg_definition(Image::TYPE);
        assert!(
            i.starts_with(
                "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n\
                 uint8 is_bigendian\nuint32 step\nuint8[] data\n"
            ),
            "{i}"
        );
        let l = msg_definition(Log::TYPE);
        assert!(
            l.starts_with("builtin_interfaces/Time stamp\nuint8 level\nstring name\n"),
            "{l}"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A WrenchStamped laid out as Fast-CDR writes it: header, stamp, the frame id's length
    /// (with its NUL) and bytes, padding to 8 from the body's start, six doubles.
    #[test]
    fn a_wrench_is_encoded_as_ros_2_puts_it_on_the_wire() {
        let m = WrenchStamped {
            header: Header {
                stamp: Time::from_unix_nanos(1_700_000_000_250_000_000),
                frame_id: "fringe".into(),
            },
            wrench: Wrench {
                force: Vector3 {
                    x: 0.5,
                    y: -0.25,
                    z: 3.0,
                },
                torque: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: 0.125,
                },
            },
        };
        let b = encode(&m).expect("encode");
        assert_eq!(&b[..4], &[0, 1, 0, 0]);
        let body = &b[4..];
        assert_eq!(
            i32::from_le_bytes(body[0..4].try_into().expect("4")),
            1_700_000_000
        );
        assert_eq!(
            u32::from_le_bytes(body[4..8].try_into().expect("4")),
            250_000_000
        );
        assert_eq!(u32::from_le_bytes(body[8..12].try_into().expect("4")), 7);
        assert_eq!(&body[12..19], b"fringe\0");
        // 19 bytes so far: the first double starts at 24.
        let f64_at = |o: usize| f64::from_le_bytes(body[o..o + 8].try_into().expect("8"));
        assert_eq!(
            [
                f64_at(24),
                f64_at(32),
                f64_at(40),
                f64_at(48),
                f64_at(56),
                f64_at(64)
            ],
            [0.5, -0.25, 3.0, 0.0, 0.0, 0.125]
        );
        assert_eq!(body.len(), 72);
    }

    #[test]
    fn a_classification_holds_one_hypothesis_per_class() {
        let m = Classification {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: String::new(),
            },
            results: vec![
                ObjectHypothesis {
                    class_id: "pentagon".into(),
                    score: 0.75,
                },
                ObjectHypothesis {
                    class_id: "rectangle".into(),
                    score: 0.25,
                },
            ],
        };
        let b = encode(&m).expect("encode");
        let body = &b[4..];
        // stamp (8), frame_id "" (length 1, NUL), pad to 16, results count 2.
        assert_eq!(u32::from_le_bytes(body[8..12].try_into().expect("4")), 1);
        assert_eq!(u32::from_le_bytes(body[16..20].try_into().expect("4")), 2);
        assert_eq!(u32::from_le_bytes(body[20..24].try_into().expect("4")), 9);
        assert_eq!(&body[24..33], b"pentagon\0");
    }

    /// The bytes `rosbags` 0.11.9 (`serialize_cdr`, an independent implementation) gives for
    /// this message.
    #[test]
    fn a_wrench_s_bytes_equal_rosbags_s() {
        let m = WrenchStamped {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: "fringe".into(),
            },
            wrench: Wrench {
                force: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: -1.5,
                },
                torque: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                },
            },
        };
        let mut want = vec![0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 7, 0, 0, 0];
        want.extend_from_slice(b"fringe\0");
        want.extend_from_slice(&[0; 5]);
        for v in [0.0f64, 0.0, -1.5, 0.0, 0.0, 0.0] {
            want.extend_from_slice(&v.to_le_bytes());
        }
        assert_eq!(want.len(), 76);
        assert_eq!(encode(&m).expect("encode"), want);
    }

    #[test]
    fn an_image_s_bytes_are_one_block() {
        let m = CompressedImage {
            header: Header {
                stamp: Time { sec: 3, nanosec: 4 },
                frame_id: "f".into(),
            },
            format: "png".into(),
            data: vec![9, 8, 7],
        };
        let b = encode(&m).expect("encode");
        let body = &b[4..];
        // stamp 8, "f" (4 + 2), pad to 16, "png" (4 + 4) to 24, data: length 3 and the bytes.
        assert_eq!(&body[12..14], b"f\0");
        assert_eq!(u32::from_le_bytes(body[16..20].try_into().expect("4")), 4);
        assert_eq!(&body[20..24], b"png\0");
        assert_eq!(u32::from_le_bytes(body[24..28].try_into().expect("4")), 3);
        assert_eq!(&body[28..], &[9, 8, 7]);
    }

    mod types {
        use crate::messages::{
            Classification, CompressedImage, Header, ObjectHypothesis, PointStamped, RosMessage,
            Time, WrenchStamped,
        };
        use crate::type_hash::{msg_definition, type_hash};

        /// The hashes a ROS 2 Jazzy install writes to `share/<pkg>/msg/<Type>.json` (WrenchStamped,
        /// PointStamped and CompressedImage found so in public sources) and `rosbags` 0.11.9's
        /// `hash_rihs01` gives (all of them, checked in session 64's research).
        #[test]
        fn type_hashes_are_those_ros_2_gives() {
            for (t, want) in [
                (
                    WrenchStamped::TYPE,
                    "RIHS01_8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77",
                ),
                (
                    PointStamped::TYPE,
                    "RIHS01_4c0296af86e01e562e9e0405d138a01537247580076c58ea38d7923ac1045897",
                ),
                (
                    CompressedImage::TYPE,
                    "RIHS01_15640771531571185e2efc8a100baf923961a4d15d5569652e6cb6691e8e371a",
                ),
                (
                    Classification::TYPE,
                    "RIHS01_f74db28d0eaef3afb78f48bf2161cd709a1383a0309d3454383b25be11345143",
                ),
                (
                    ObjectHypothesis::TYPE,
                    "RIHS01_51da43cec11c01957a64d1e05a24acd18aae7745ec30b74348ad5f6d634f7f90",
                ),
                (
                    Header::TYPE,
                    "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
                ),
                (
                    Time::TYPE,
                    "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
                ),
            ] {
                assert_eq!(type_hash(t), want, "{}", t.name);
            }
        }

        #[test]
        fn a_message_definition_carries_every_type_it_refers_to() {
            let d = msg_definition(WrenchStamped::TYPE);
            let bar = "=".repeat(80);
            assert_eq!(
                d,
                format!(
                    "std_msgs/Header header\ngeometry_msgs/Wrench wrench\n\
                     {bar}\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
                     {bar}\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
                     {bar}\nMSG: geometry_msgs/Wrench\ngeometry_msgs/Vector3 force\ngeometry_msgs/Vector3 torque\n\
                     {bar}\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
                )
            );
            let c = msg_definition(Classification::TYPE);
            assert!(
                c.starts_with("std_msgs/Header header\nvision_msgs/ObjectHypothesis[] results\n"),
                "{c}"
            );
            assert!(
                c.contains("MSG: vision_msgs/ObjectHypothesis\nstring class_id\nfloat64 score\n"),
                "{c}"
            );
            let i = msg_definition(CompressedImage::TYPE);
            assert!(
                i.starts_with("std_msgs/Header header\nstring format\nuint8[] data\n"),
                "{i}"
            );
        }

        #[test]
        fn dds_names_are_rmw_s() {
            assert_eq!(
                WrenchStamped::TYPE.dds_name(),
                "geometry_msgs::msg::dds_::WrenchStamped_"
            );
        }
    }
}
