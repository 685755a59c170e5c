//! The names rmw_zenoh (ROS 2's Zenoh middleware) gives a topic's data and its graph: the key
//! expression a message is put on, and the liveliness tokens that make a node and its publishers
//! visible to `ros2 node list` and `ros2 topic list` (ros2/rmw_zenoh, `liveliness_utils.cpp`:
//! `TopicInfo`, `Entity`, `mangle_name`, `qos_to_keyexpr`). Strings only; the session that
//! declares them is the application's.

use crate::type_hash::{type_hash, MessageType};

/// A name with every `/` as `%`, as rmw_zenoh writes names inside a liveliness token.
pub fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// The key a message of type `t` on the fully qualified topic `topic` (`/fringe/wrench`) is put
/// on in ROS domain `domain`: `0/fringe/wrench/geometry_msgs::msg::dds_::WrenchStamped_/RIHS01_..`.
pub fn topic_key(domain: u32, topic: &str, t: &'static MessageType) -> String {
    let inner = topic.strip_prefix('/').unwrap_or(topic);
    let inner = inner.strip_suffix('/').unwrap_or(inner);
    format!("{domain}/{inner}/{}/{}", t.dds_name(), type_hash(t))
}

/// A name ROS 2 would refuse, and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{name}` is not a ROS 2 {what}: {why}")]
pub struct NameError {
    pub name: String,
    pub what: &'static str,
    pub why: &'static str,
}

/// `ns` as a fully qualified ROS 2 namespace, checked as rcl checks one (`rmw_validate_namespace`):
/// `/`-separated tokens of ASCII letters, digits and underscores, none empty or starting with a
/// digit. A missing leading `/` is added and a trailing one dropped (`fringe/` gives `/fringe`);
/// `/` alone is the root namespace.
pub fn namespace(ns: &str) -> Result<String, NameError> {
    let refuse = |why| NameError {
        name: ns.to_string(),
        what: "namespace",
        why,
    };
    let inner = ns.strip_prefix('/').unwrap_or(ns);
    let inner = inner.strip_suffix('/').unwrap_or(inner);
    if inner.is_empty() {
        return match ns {
            "/" => Ok("/".into()),
            _ => Err(refuse("it is empty (the root namespace is `/`)")),
        };
    }
    for token in inner.split('/') {
        if token.is_empty() {
            return Err(refuse("it has an empty part (`//`)"));
        }
        if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(refuse("only letters, digits, `_` and `/` may be used"));
        }
        if token.starts_with(|c: char| c.is_ascii_digit()) {
            return Err(refuse("a part may not start with a digit"));
        }
    }
    Ok(format!("/{inner}"))
}

/// How a publisher delivers (rmw's reliability).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    Reliable,
    BestEffort,
}

/// A publisher's QoS as far as fringe sets it: reliability and a keep-last depth; volatile,
/// no deadline, lifespan or lease (rmw's defaults).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    pub reliability: Reliability,
    pub depth: usize,
}

/// rmw_zenoh's default profile's depth: a field equal to its default is left empty.
const DEFAULT_DEPTH: usize = 42;

impl Qos {
    /// rclcpp's default publisher profile: reliable, keep last 10.
    pub const DEFAULT: Qos = Qos {
        reliability: Reliability::Reliable,
        depth: 10,
    };
    /// Sensor data: best effort, keep last 5.
    pub const SENSOR_DATA: Qos = Qos {
        reliability: Reliability::BestEffort,
        depth: 5,
    };

    /// The QoS as a liveliness token carries it: six `:`-separated groups, a value written only
    /// where it differs from rmw_zenoh's default profile (`::,10:,:,:,,` for [`Qos::DEFAULT`]).
    pub fn key(&self) -> String {
        let reliability = match self.reliability {
            Reliability::Reliable => String::new(),
            Reliability::BestEffort => "2".into(),
        };
        let depth = if self.depth == DEFAULT_DEPTH {
            String::new()
        } else {
            self.depth.to_string()
        };
        format!("{reliability}::,{depth}:,:,:,,")
    }
}

/// The liveliness token of node `node` in namespace `namespace` (`/fringe`), node id `node_id`
/// of the Zenoh session `zid` (its id as text), in ROS domain `domain`, default enclave.
pub fn node_token(domain: u32, zid: &str, node_id: u64, namespace: &str, node: &str) -> String {
    format!(
        "@ros2_lv/{domain}/{zid}/{node_id}/{node_id}/NN/%/{}/{}",
        mangle(namespace),
        mangle(node)
    )
}

/// The liveliness token of publisher `entity_id` of that node, on the fully qualified topic
/// `topic` with messages of type `t` and QoS `qos`.
#[allow(clippy::too_many_arguments)]
pub fn publisher_token(
    domain: u32,
    zid: &str,
    node_id: u64,
    entity_id: u64,
    namespace: &str,
    node: &str,
    topic: &str,
    t: &'static MessageType,
    qos: Qos,
) -> String {
    format!(
        "@ros2_lv/{domain}/{zid}/{node_id}/{entity_id}/MP/%/{}/{}/{}/{}/{}/{}",
        mangle(namespace),
        mangle(node),
        mangle(topic),
        t.dds_name(),
        type_hash(t),
        qos.key()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::{RosMessage, WrenchStamped};

    const HASH: &str = "RIHS01_8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77";

    #[test]
    fn a_topic_s_data_key_is_rmw_zenoh_s() {
        assert_eq!(
            topic_key(0, "/fringe/wrench", WrenchStamped::TYPE),
            format!("0/fringe/wrench/geometry_msgs::msg::dds_::WrenchStamped_/{HASH}")
        );
        assert_eq!(
            topic_key(7, "/wrench", WrenchStamped::TYPE),
            format!("7/wrench/geometry_msgs::msg::dds_::WrenchStamped_/{HASH}")
        );
    }

    #[test]
    fn node_and_publisher_tokens_are_rmw_zenoh_s() {
        let zid = "1f2e3d4c5b6a79880102030405060708";
        assert_eq!(
            node_token(0, zid, 0, "/fringe", "fringe_stream"),
            format!("@ros2_lv/0/{zid}/0/0/NN/%/%fringe/fringe_stream")
        );
        assert_eq!(
            publisher_token(
                0,
                zid,
                0,
                1,
                "/fringe",
                "fringe_stream",
                "/fringe/wrench",
                WrenchStamped::TYPE,
                Qos::DEFAULT
            ),
            format!(
                "@ros2_lv/0/{zid}/0/1/MP/%/%fringe/fringe_stream/%fringe%wrench/geometry_msgs::msg::dds_::WrenchStamped_/{HASH}/::,10:,:,:,,"
            )
        );
        assert_eq!(Qos::SENSOR_DATA.key(), "2::,5:,:,:,,");
        assert_eq!(
            node_token(0, zid, 3, "/", "n"),
            format!("@ros2_lv/0/{zid}/3/3/NN/%/%/n")
        );
    }
}

/// Every name this module makes is a key expression Zenoh accepts (canonical, no wildcard).
#[cfg(test)]
mod zenoh_check {
    use super::*;
    use crate::messages::{
        Classification, CompressedImage, PointStamped, RosMessage, WrenchStamped,
    };
    use zenoh::key_expr::KeyExpr;

    #[test]
    fn every_name_is_a_canonical_zenoh_key_expression() {
        let zid = "1f2e3d4c5b6a79880102030405060708";
        let mut names = vec![node_token(0, zid, 0, "/fringe", "fringe_stream")];
        for (topic, t) in [
            ("/fringe/wrench", WrenchStamped::TYPE),
            ("/fringe/contact", PointStamped::TYPE),
            ("/fringe/shape", Classification::TYPE),
            ("/fringe/image/compressed", CompressedImage::TYPE),
        ] {
            names.push(topic_key(0, topic, t));
            for qos in [Qos::DEFAULT, Qos::SENSOR_DATA] {
                names.push(publisher_token(
                    0,
                    zid,
                    0,
                    1,
                    "/fringe",
                    "fringe_stream",
                    topic,
                    t,
                    qos,
                ));
            }
        }
        for n in names {
            let k = KeyExpr::try_from(n.as_str()).unwrap_or_else(|e| panic!("{n}: {e}"));
            assert_eq!(k.as_str(), n, "not canonical");
            assert!(!n.contains('*'), "{n}");
        }
    }

    #[test]
    fn namespaces_are_checked_as_rcl_checks_them() {
        assert_eq!(namespace("/fringe").as_deref(), Ok("/fringe"));
        assert_eq!(namespace("fringe/").as_deref(), Ok("/fringe"));
        assert_eq!(
            namespace("/robot_1/fringe").as_deref(),
            Ok("/robot_1/fringe")
        );
        assert_eq!(namespace("/").as_deref(), Ok("/"));
        for bad in ["", "/a//b", "/my robot", "/fringe-1", "/1robot"] {
            let e = namespace(bad).expect_err(bad);
            assert!(e.to_string().contains("is not a ROS 2 namespace"), "{e}");
        }
    }
}
