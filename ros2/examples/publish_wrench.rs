//! Publishes a few `geometry_msgs/msg/WrenchStamped` on `/fringe/wrench` as rmw_zenoh would, to
//! try a subscriber against (`examples/zenoh_wrench.py`, or `ros2 topic echo /fringe/wrench` on
//! a ROS 2 system with `rmw_zenoh_cpp`):
//! `cargo run -p fringe-ros2 --features zenoh --example publish_wrench -- tcp/127.0.0.1:7447 20`

use fringe_ros2::{Header, Node, NodeConfig, Qos, Time, Vector3, Wrench, WrenchStamped};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let endpoint = args.next().unwrap_or_else(|| "tcp/127.0.0.1:7447".into());
    let count: u32 = args.next().map(|n| n.parse()).transpose()?.unwrap_or(20);
    let mut config = NodeConfig::new("/fringe", "fringe_stream");
    config.connect = vec![endpoint];
    let mut node = Node::open(config)?;
    let mut wrench = node.publisher::<WrenchStamped>("wrench", Qos::DEFAULT)?;
    for k in 0..count {
        let now = SystemTime::now().duration_since(UNIX_EPOCH)?.as_nanos() as u64;
        let m = WrenchStamped {
            header: Header {
                stamp: Time::from_unix_nanos(now),
                frame_id: "fringe_sensor".into(),
            },
            wrench: Wrench {
                force: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: -0.5 * f64::from(k),
                },
                torque: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                },
            },
        };
        wrench.put(&m, now as i64)?;
        std::thread::sleep(Duration::from_millis(100));
    }
    Ok(())
}
