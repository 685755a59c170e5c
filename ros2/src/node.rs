//! A ROS 2 node on Zenoh as rmw_zenoh speaks it (feature `zenoh`): a peer session with
//! rmw_zenoh's settings (connect to the router, `tcp/localhost:7447` by default, retried in the
//! background; multicast scouting off), a liveliness token for the node and one for each
//! publisher, and every message put on its topic's key with the attachment rmw_zenoh's
//! subscribers read (sequence number, source timestamp, publisher GID). `ros2 topic list` and
//! `ros2 topic echo` on a ROS 2 system running `rmw_zenoh_cpp` see these topics.

use crate::messages::{encode, EncodeError, RosMessage};
use crate::names::{node_token, publisher_token, topic_key, Qos};
use std::marker::PhantomData;
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;
use zenoh::{Session, Wait};

/// Where and as what the node appears.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeConfig {
    /// ROS domain id.
    pub domain: u32,
    /// `/fringe`, or `/` for none.
    pub namespace: String,
    /// `fringe_stream`.
    pub name: String,
    /// Zenoh endpoints to connect to (`tcp/localhost:7447`, rmw_zenoh's router).
    pub connect: Vec<String>,
    /// Endpoints to listen on, for peers on the same host (`tcp/localhost:0`).
    pub listen: Vec<String>,
}

impl NodeConfig {
    /// rmw_zenoh's endpoints for node `name` in `namespace`, domain 0.
    pub fn new(namespace: &str, name: &str) -> NodeConfig {
        NodeConfig {
            domain: 0,
            namespace: namespace.to_string(),
            name: name.to_string(),
            connect: vec!["tcp/localhost:7447".into()],
            listen: vec!["tcp/localhost:0".into()],
        }
    }
}

/// Why the node could not do what was asked.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error("Zenoh setting {key} = {value}: {message}")]
    Config {
        key: &'static str,
        value: String,
        message: String,
    },
    #[error("cannot open a Zenoh session (connect {connect:?}, listen {listen:?}): {message}")]
    Open {
        connect: Vec<String>,
        listen: Vec<String>,
        message: String,
    },
    #[error("cannot declare {what}: {message}")]
    Declare { what: String, message: String },
    #[error(transparent)]
    Encode(#[from] EncodeError),
    #[error("cannot publish on {key}: {message}")]
    Put { key: String, message: String },
}

/// A ROS 2 node (see the module).
pub struct Node {
    session: Session,
    config: NodeConfig,
    zid: String,
    next_entity: u64,
    _token: LivelinessToken,
}

/// This node's id in its session (one node a session).
const NODE_ID: u64 = 0;

fn set(config: &mut zenoh::Config, key: &'static str, value: String) -> Result<(), NodeError> {
    config
        .insert_json5(key, &value)
        .map_err(|e| NodeError::Config {
            key,
            value,
            message: e.to_string(),
        })
}

fn json_list(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}

impl Node {
    /// Opens the session and declares the node. An endpoint that does not answer yet does not
    /// stop it: the session keeps connecting in the background ([`Node::connected`]).
    pub fn open(config: NodeConfig) -> Result<Node, NodeError> {
        let mut z = zenoh::Config::default();
        set(&mut z, "mode", "\"peer\"".into())?;
        set(&mut z, "connect/endpoints", json_list(&config.connect))?;
        set(&mut z, "listen/endpoints", json_list(&config.listen))?;
        set(&mut z, "scouting/multicast/enabled", "false".into())?;
        set(
            &mut z,
            "connect/timeout_ms",
            "{router: -1, peer: -1, client: 0}".into(),
        )?;
        set(
            &mut z,
            "connect/exit_on_failure",
            "{router: false, peer: false, client: true}".into(),
        )?;
        let session = zenoh::open(z).wait().map_err(|e| NodeError::Open {
            connect: config.connect.clone(),
            listen: config.listen.clone(),
            message: e.to_string(),
        })?;
        let zid = session.zid().to_string();
        let key = node_token(
            config.domain,
            &zid,
            NODE_ID,
            &config.namespace,
            &config.name,
        );
        let token = session
            .liveliness()
            .declare_token(key.clone())
            .wait()
            .map_err(|e| NodeError::Declare {
                what: format!("the node's liveliness token {key}"),
                message: e.to_string(),
            })?;
        Ok(Node {
            session,
            config,
            zid,
            next_entity: NODE_ID + 1,
            _token: token,
        })
    }

    /// Whether a router or another peer is connected.
    pub fn connected(&self) -> bool {
        let info = self.session.info();
        info.routers_zid().wait().next().is_some() || info.peers_zid().wait().next().is_some()
    }

    /// The topic `name` under the node's namespace: `/fringe/wrench`.
    pub fn topic(&self, name: &str) -> String {
        let ns = self.config.namespace.trim_end_matches('/');
        format!("{ns}/{}", name.trim_start_matches('/'))
    }

    /// A publisher of `M` on the topic `name` (under the node's namespace) with `qos`.
    pub fn publisher<M: RosMessage>(
        &mut self,
        name: &str,
        qos: Qos,
    ) -> Result<Publisher<M>, NodeError> {
        let topic = self.topic(name);
        let id = self.next_entity;
        self.next_entity += 1;
        let c = &self.config;
        let token_key = publisher_token(
            c.domain,
            &self.zid,
            NODE_ID,
            id,
            &c.namespace,
            &c.name,
            &topic,
            M::TYPE,
            qos,
        );
        let key = topic_key(c.domain, &topic, M::TYPE);
        let publisher = self
            .session
            .declare_publisher(key.clone())
            .congestion_control(CongestionControl::Drop)
            .wait()
            .map_err(|e| NodeError::Declare {
                what: format!("a publisher on {key}"),
                message: e.to_string(),
            })?;
        let token = self
            .session
            .liveliness()
            .declare_token(token_key.clone())
            .wait()
            .map_err(|e| NodeError::Declare {
                what: format!("the publisher's liveliness token {token_key}"),
                message: e.to_string(),
            })?;
        Ok(Publisher {
            publisher,
            key,
            gid: xxhash_rust::xxh3::xxh3_128(token_key.as_bytes()).to_le_bytes(),
            sequence: 0,
            _token: token,
            _message: PhantomData,
        })
    }
}

/// A publisher of one message type on one topic.
pub struct Publisher<M> {
    publisher: zenoh::pubsub::Publisher<'static>,
    key: String,
    gid: [u8; 16],
    sequence: i64,
    _token: LivelinessToken,
    _message: PhantomData<fn(M)>,
}

impl<M: RosMessage> Publisher<M> {
    /// Puts `m`, stamped as sent at `unix_ns` (ns since the Unix epoch, the source timestamp
    /// rmw_zenoh attaches), with the next sequence number.
    pub fn put(&mut self, m: &M, unix_ns: i64) -> Result<(), NodeError> {
        let bytes = encode(m)?;
        self.sequence += 1;
        let attachment = zenoh_ext::z_serialize(&(self.sequence, unix_ns, self.gid));
        self.publisher
            .put(bytes)
            .attachment(attachment)
            .wait()
            .map_err(|e| NodeError::Put {
                key: self.key.clone(),
                message: e.to_string(),
            })
    }

    /// The key expression its messages are put on.
    pub fn key(&self) -> &str {
        &self.key
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::{Header, Time, Vector3, Wrench, WrenchStamped};
    use std::time::{Duration, Instant};

    fn free_port() -> u16 {
        std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map(|a| a.port())
            .unwrap_or(47447)
    }

    /// A peer on loopback (playing the ROS 2 side) sees the node's and the publisher's
    /// liveliness tokens, and receives each message on its rmw_zenoh key with the 33-byte
    /// attachment: sequence 1, 2, the timestamp given, the GID.
    #[test]
    fn a_peer_sees_the_node_its_publisher_and_the_messages_as_rmw_zenoh_s() {
        let port = free_port();
        let mut peer = zenoh::Config::default();
        peer.insert_json5("mode", "\"peer\"").expect("mode");
        peer.insert_json5("listen/endpoints", &format!("[\"tcp/127.0.0.1:{port}\"]"))
            .expect("listen");
        peer.insert_json5("scouting/multicast/enabled", "false")
            .expect("scouting");
        let peer = zenoh::open(peer).wait().expect("peer");
        let data = peer.declare_subscriber("3/**").wait().expect("subscriber");

        let mut config = NodeConfig::new("/fringe", "fringe_stream");
        config.domain = 3;
        config.connect = vec![format!("tcp/127.0.0.1:{port}")];
        config.listen = vec!["tcp/127.0.0.1:0".into()];
        let mut node = Node::open(config).expect("node");
        let deadline = Instant::now() + Duration::from_secs(10);
        while !node.connected() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }
        assert!(node.connected(), "the node never reached the peer");
        let mut wrench = node
            .publisher::<WrenchStamped>("wrench", Qos::DEFAULT)
            .expect("publisher");
        assert!(wrench
            .key()
            .starts_with("3/fringe/wrench/geometry_msgs::msg::dds_::WrenchStamped_/RIHS01_"));

        // Declarations travel to the peer: ask until both tokens are there.
        let publisher_seen = |t: &String| {
            t.contains("/0/1/MP/%/%fringe/fringe_stream/%fringe%wrench/geometry_msgs::msg::dds_::WrenchStamped_/RIHS01_")
                && t.ends_with("/::,10:,:,:,,")
        };
        let mut tokens: Vec<String> = Vec::new();
        while Instant::now() < deadline && !tokens.iter().any(publisher_seen) {
            let replies = peer.liveliness().get("@ros2_lv/3/**").wait().expect("get");
            tokens.clear();
            while let Ok(Some(r)) = replies.recv_timeout(Duration::from_secs(1)) {
                if let Ok(s) = r.result() {
                    tokens.push(s.key_expr().to_string());
                }
            }
        }
        assert!(
            tokens
                .iter()
                .any(|t| t.ends_with("/0/0/NN/%/%fringe/fringe_stream")),
            "{tokens:?}"
        );
        assert!(tokens.iter().any(publisher_seen), "{tokens:?}");

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
        // Put until the subscription has reached the node (declarations travel too).
        let mut got = None;
        let mut sent = 0i64;
        while got.is_none() && Instant::now() < deadline + Duration::from_secs(5) {
            sent += 1;
            wrench.put(&m, 1_000 + sent).expect("put");
            got = data.recv_timeout(Duration::from_millis(200)).ok().flatten();
        }
        let sample = got.expect("no message reached the peer");
        assert_eq!(sample.key_expr().as_str(), wrench.key());
        assert_eq!(
            sample.payload().to_bytes().as_ref(),
            encode(&m).expect("encode").as_slice()
        );
        let att = sample.attachment().expect("attachment").to_bytes();
        assert_eq!(att.len(), 33, "{att:?}");
        let seq = i64::from_le_bytes(att[0..8].try_into().expect("8"));
        let ts = i64::from_le_bytes(att[8..16].try_into().expect("8"));
        assert!(seq >= 1 && seq <= sent, "{seq} of {sent}");
        assert_eq!(ts, 1_000 + seq);
        assert_eq!(att[16], 16);
        assert_ne!(&att[17..], &[0u8; 16]);
    }
}
