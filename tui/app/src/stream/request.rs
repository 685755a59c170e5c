//! What a stream is asked for.

use crate::rig::file::RigConfig;
use fringe_sensor_models::{BackendKind, Model};
use std::path::PathBuf;

/// The ROS 2 node: its namespace, domain and frame id, and the Zenoh endpoints.
#[derive(Debug, Clone, PartialEq)]
pub struct Ros2Settings {
    /// `/fringe`: topics `/fringe/wrench`, `/fringe/contact`, `/fringe/shape`.
    pub namespace: String,
    pub domain: u32,
    /// The frame id in every header.
    pub frame_id: String,
    /// Zenoh endpoints to connect to (rmw_zenoh's router: `tcp/localhost:7447`).
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on.
    pub listen: Vec<String>,
    /// Whether the messages go out over Zenoh (`--no-ros2` keeps them to the recording).
    pub publish: bool,
}

impl Ros2Settings {
    pub const DEFAULT_NAMESPACE: &'static str = "/fringe";
    pub const DEFAULT_FRAME_ID: &'static str = "fringe_sensor";
    pub const DEFAULT_CONNECT: &'static str = "tcp/localhost:7447";
    pub const DEFAULT_LISTEN: &'static str = "tcp/localhost:0";
    /// The node's name.
    pub const NODE: &'static str = "fringe_stream";

    /// The rig file's `[stream]` settings, each defaulted.
    pub fn from_rig(config: &RigConfig) -> Ros2Settings {
        let s = config.stream_section();
        let or_default = |v: &Vec<String>, d: &str| {
            if v.is_empty() {
                vec![d.to_string()]
            } else {
                v.clone()
            }
        };
        Ros2Settings {
            namespace: s
                .namespace
                .clone()
                .unwrap_or_else(|| Self::DEFAULT_NAMESPACE.into()),
            domain: s.domain.unwrap_or(0),
            frame_id: s
                .frame_id
                .clone()
                .unwrap_or_else(|| Self::DEFAULT_FRAME_ID.into()),
            connect: or_default(&s.connect, Self::DEFAULT_CONNECT),
            listen: or_default(&s.listen, Self::DEFAULT_LISTEN),
            publish: true,
        }
    }

    /// Takes the domain from `ROS_DOMAIN_ID`'s value, as ROS 2 does when the domain is not
    /// given otherwise (`None` or blank: the domain stays).
    pub fn domain_from_env(&mut self, value: Option<&str>) -> Result<(), String> {
        let Some(v) = value.filter(|v| !v.trim().is_empty()) else {
            return Ok(());
        };
        self.domain = v
            .trim()
            .parse()
            .map_err(|_| format!("ROS_DOMAIN_ID={v:?}: give a domain id 0 to 232"))?;
        Ok(())
    }

    /// The node as the operator reads it: its name, domain and endpoints.
    pub fn describe(&self) -> String {
        if !self.publish {
            return "not publishing over ROS 2 (recording only)".into();
        }
        format!(
            "ROS 2 node {}/{} on domain {} (Zenoh: connect {}; listen {})",
            self.namespace.trim_end_matches('/'),
            Self::NODE,
            self.domain,
            self.connect.join(", "),
            self.listen.join(", "),
        )
    }

    /// Checks the namespace as rcl does (`fringe_ros2::namespace`; `fringe/left` is taken as
    /// `/fringe/left`) and the domain id, and the frame id is not empty.
    pub fn check(&mut self) -> Result<(), String> {
        self.namespace = fringe_ros2::namespace(&self.namespace).map_err(|e| e.to_string())?;
        if self.domain > 232 {
            return Err(format!(
                "domain {}: ROS 2 domain ids are 0 to 232",
                self.domain
            ));
        }
        if self.frame_id.trim().is_empty() {
            return Err(
                "the frame id is empty: give --frame-id NAME (fringe_sensor by default)".into(),
            );
        }
        Ok(())
    }
}

/// A stream to run.
pub struct StreamRequest {
    /// The rig (its camera and unit: the simulated bench when simulated).
    pub config: RigConfig,
    /// The model (chosen by `crate::models::choose_model`).
    pub model: Model,
    pub backend: BackendKind,
    /// Inference threads of each network.
    pub threads: usize,
    pub ros2: Ros2Settings,
    /// Record the same messages to this MCAP file.
    pub mcap: Option<PathBuf>,
    /// Frames a second published as compressed images (0: none).
    pub image_hz: f64,
    /// On the simulated bench, the robot's seed.
    pub robot_seed: u64,
}
