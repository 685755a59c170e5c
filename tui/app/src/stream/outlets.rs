//! The ROS 2 messages a prediction makes and where they go: the Zenoh node's publishers (as
//! rmw_zenoh speaks) and the MCAP recorder's channels, the same messages to both.
//!
//! Topics under the namespace:
//! - `wrench` (`geometry_msgs/msg/WrenchStamped`): every force the model predicts, N and N m, as
//!   magnitudes (the reference networks are trained on |F| per axis); z is the normal force
//!   pressing into the sensor.
//! - `contact` (`geometry_msgs/msg/PointStamped`, only in contact): the contact point in the
//!   sensor's frame, metres (x right, y up in the camera's view of the disc, z 0 on the surface).
//! - `shape` (`vision_msgs/msg/Classification`): every shape class with its probability
//!   (`None` is no contact).
//! - `image/compressed` (`sensor_msgs/msg/CompressedImage`, PNG), at a lower rate when asked.
//!
//! Every header is stamped with the middle of the frame's exposure, in Unix time (the host's
//! monotonic clock carried onto the wall clock read when fringe started).

use crate::stream::request::Ros2Settings;
use fringe_ros2::{
    Channel, Classification, CompressedImage, Header, Node, NodeConfig, NodeError,
    ObjectHypothesis, Point, PointStamped, Publisher, Qos, RecordError, Recorder, RosMessage,
    Vector3, Wrench, WrenchStamped,
};
#[cfg(feature = "sim")]
use fringe_sensor_models::dataset::Sample;
use fringe_sensor_models::Prediction;
use std::path::{Path, PathBuf};

/// The topics, under the namespace, with their message types.
pub const TOPICS: [(&str, &str); 4] = [
    ("wrench", "geometry_msgs/msg/WrenchStamped"),
    ("contact", "geometry_msgs/msg/PointStamped"),
    ("shape", "vision_msgs/msg/Classification"),
    ("image/compressed", "sensor_msgs/msg/CompressedImage"),
];

/// The messages of one frame's prediction.
pub(crate) struct Messages {
    pub wrench: WrenchStamped,
    pub contact: Option<PointStamped>,
    pub shape: Classification,
}

impl Messages {
    /// The messages of `p`, stamped at `unix_ns` in `frame_id`.
    pub(crate) fn of(p: &Prediction, unix_ns: i64, frame_id: &str) -> Messages {
        let h = Header::at_unix_nanos(unix_ns.max(0) as u64, frame_id);
        let f = &p.force;
        Messages {
            wrench: WrenchStamped {
                header: h.clone(),
                wrench: Wrench {
                    force: Vector3 {
                        x: f.fx.value(),
                        y: f.fy.value(),
                        z: f.fz.value(),
                    },
                    torque: Vector3 {
                        x: f.mx.value(),
                        y: f.my.value(),
                        z: f.mz.value(),
                    },
                },
            },
            contact: p.contact.map(|[x, y]| PointStamped {
                header: h.clone(),
                point: Point {
                    x: x.value() * 1e-3,
                    y: y.value() * 1e-3,
                    z: 0.0,
                },
            }),
            shape: Classification {
                header: h,
                results: p
                    .probabilities
                    .iter()
                    .map(|(class, score)| ObjectHypothesis {
                        class_id: class.clone(),
                        score: *score,
                    })
                    .collect(),
            },
        }
    }
}

/// What went out, counted by topic.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Published {
    pub wrench: u64,
    pub contact: u64,
    pub shape: u64,
    pub image: u64,
    /// Messages Zenoh refused (each named once in `StreamState::warnings`).
    pub failed: u64,
}

/// The Zenoh node and its publishers.
pub(crate) struct Ros2Outlet {
    node: Node,
    wrench: Publisher<WrenchStamped>,
    contact: Publisher<PointStamped>,
    shape: Publisher<Classification>,
}

impl Ros2Outlet {
    /// Opens the node (it connects in the background when no endpoint answers yet).
    pub(crate) fn open(
        s: &Ros2Settings,
    ) -> Result<(Ros2Outlet, Publisher<CompressedImage>), NodeError> {
        let mut node = Node::open(NodeConfig {
            domain: s.domain,
            namespace: s.namespace.clone(),
            name: Ros2Settings::NODE.into(),
            connect: s.connect.clone(),
            listen: s.listen.clone(),
        })?;
        let wrench = node.publisher("wrench", Qos::SENSOR_DATA)?;
        let contact = node.publisher("contact", Qos::SENSOR_DATA)?;
        let shape = node.publisher("shape", Qos::SENSOR_DATA)?;
        let image = node.publisher("image/compressed", Qos::SENSOR_DATA)?;
        Ok((
            Ros2Outlet {
                node,
                wrench,
                contact,
                shape,
            },
            image,
        ))
    }

    /// Whether a router or another peer is connected.
    pub(crate) fn connected(&self) -> bool {
        self.node.connected()
    }

    /// Puts the messages, sent at `now_unix_ns`.
    pub(crate) fn put(
        &mut self,
        m: &Messages,
        now_unix_ns: i64,
        count: &mut Published,
    ) -> Result<(), NodeError> {
        self.wrench.put(&m.wrench, now_unix_ns)?;
        count.wrench += 1;
        if let Some(c) = &m.contact {
            self.contact.put(c, now_unix_ns)?;
            count.contact += 1;
        }
        self.shape.put(&m.shape, now_unix_ns)?;
        count.shape += 1;
        Ok(())
    }
}

/// The MCAP recording and its channels.
pub(crate) struct McapOutlet {
    recorder: Recorder,
    wrench: Channel<WrenchStamped>,
    contact: Channel<PointStamped>,
    shape: Channel<Classification>,
    image: Channel<CompressedImage>,
    #[cfg(feature = "sim")]
    truth: Option<TruthChannels>,
}

/// The simulator's truth beside the predictions: `<ns>/truth/wrench` (the true normal force as
/// z), `<ns>/truth/contact` (in contact only) and `<ns>/truth/shape` (the true class, score 1),
/// each stamped as the prediction of the same frame.
#[cfg(feature = "sim")]
struct TruthChannels {
    wrench: Channel<WrenchStamped>,
    contact: Channel<PointStamped>,
    shape: Channel<Classification>,
}

impl McapOutlet {
    /// Creates the recording at `path` with a channel per topic under `namespace`, and the truth's
    /// channels when `truth` (the simulated bench).
    pub(crate) fn create(
        path: &Path,
        namespace: &str,
        truth: bool,
    ) -> Result<McapOutlet, RecordError> {
        let mut recorder = Recorder::create(path)?;
        let topic = |name: &str| format!("{}/{name}", namespace.trim_end_matches('/'));
        let wrench = recorder.channel(&topic("wrench"), Qos::SENSOR_DATA)?;
        let contact = recorder.channel(&topic("contact"), Qos::SENSOR_DATA)?;
        let shape = recorder.channel(&topic("shape"), Qos::SENSOR_DATA)?;
        let image = recorder.channel(&topic("image/compressed"), Qos::SENSOR_DATA)?;
        #[cfg(not(feature = "sim"))]
        let _ = truth;
        #[cfg(feature = "sim")]
        let truth = if truth {
            Some(TruthChannels {
                wrench: recorder.channel(&topic("truth/wrench"), Qos::DEFAULT)?,
                contact: recorder.channel(&topic("truth/contact"), Qos::DEFAULT)?,
                shape: recorder.channel(&topic("truth/shape"), Qos::DEFAULT)?,
            })
        } else {
            None
        };
        Ok(McapOutlet {
            recorder,
            wrench,
            contact,
            shape,
            image,
            #[cfg(feature = "sim")]
            truth,
        })
    }

    /// The file being written.
    pub(crate) fn path(&self) -> &Path {
        self.recorder.path()
    }

    /// Records the truth of the frame stamped `stamp` (Unix ns), logged at its stamp.
    #[cfg(feature = "sim")]
    pub(crate) fn write_truth(
        &mut self,
        stamp: i64,
        sample: &Sample,
        frame_id: &str,
    ) -> Result<(), RecordError> {
        let Some(ch) = self.truth.as_mut() else {
            return Ok(());
        };
        let h = Header::at_unix_nanos(stamp.max(0) as u64, frame_id);
        let t = stamp.max(0) as u64;
        let f = &sample.force;
        let wrench = WrenchStamped {
            header: h.clone(),
            wrench: Wrench {
                force: Vector3 {
                    x: f[0],
                    y: f[1],
                    z: f[2],
                },
                torque: Vector3 {
                    x: f[3],
                    y: f[4],
                    z: f[5],
                },
            },
        };
        self.recorder.write(&mut ch.wrench, &wrench, t, t)?;
        if let Some([x, y]) = sample.contact {
            let contact = PointStamped {
                header: h.clone(),
                point: Point {
                    x: x * 1e-3,
                    y: y * 1e-3,
                    z: 0.0,
                },
            };
            self.recorder.write(&mut ch.contact, &contact, t, t)?;
        }
        let shape = Classification {
            header: h,
            results: vec![ObjectHypothesis {
                class_id: sample.shape.clone(),
                score: 1.0,
            }],
        };
        self.recorder.write(&mut ch.shape, &shape, t, t)
    }

    /// Records the messages, logged at `now_unix_ns`.
    pub(crate) fn write(&mut self, m: &Messages, now_unix_ns: i64) -> Result<(), RecordError> {
        let t = now_unix_ns.max(0) as u64;
        self.recorder.write(&mut self.wrench, &m.wrench, t, t)?;
        if let Some(c) = &m.contact {
            self.recorder.write(&mut self.contact, c, t, t)?;
        }
        self.recorder.write(&mut self.shape, &m.shape, t, t)
    }

    /// Records a compressed image, logged at `now_unix_ns`.
    pub(crate) fn write_image(
        &mut self,
        image: &CompressedImage,
        now_unix_ns: i64,
    ) -> Result<(), RecordError> {
        let t = now_unix_ns.max(0) as u64;
        self.recorder.write(&mut self.image, image, t, t)
    }

    /// Writes the summary and closes the file.
    pub(crate) fn finish(self) -> Result<PathBuf, RecordError> {
        self.recorder.finish()
    }
}

/// Puts one message on a publisher (the image thread's).
pub(crate) fn put_one<M: RosMessage>(
    p: &mut Publisher<M>,
    m: &M,
    now_unix_ns: i64,
) -> Result<(), NodeError> {
    p.put(m, now_unix_ns)
}
