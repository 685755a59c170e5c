//! fringe's ROS 2 node and MCAP recording against independent peers from PyPI, with no ROS
//! install (tests/python/ros2_peer.py with the interpreter in FRINGE_PYTHON): eclipse-zenoh sees
//! the node and its publisher as rmw_zenoh's graph does and receives the messages on their
//! rmw_zenoh keys with the attachment; rosbags decodes them and computes the same type hash;
//! rosbags and the mcap / mcap-ros2-support readers open the recording.

use fringe_ros2::{
    type_hash, Classification, Header, Node, NodeConfig, ObjectHypothesis, Qos, Recorder,
    RosMessage, Time, Vector3, Wrench, WrenchStamped,
};
use fringe_tests::{python, python_script, require_python_module};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn wrench(fz: f64) -> WrenchStamped {
    WrenchStamped {
        header: Header {
            stamp: Time::from_unix_nanos(1_796_500_000_000_000_000),
            frame_id: "fringe_sensor".into(),
        },
        wrench: Wrench {
            force: Vector3 {
                x: 0.0,
                y: 0.0,
                z: fz,
            },
            torque: Vector3 {
                x: 0.0,
                y: 0.0,
                z: 0.0,
            },
        },
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

#[test]
fn a_ros_2_peer_sees_the_node_and_decodes_its_messages() {
    require_python_module("zenoh");
    require_python_module("rosbags");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let mut child = Command::new(python())
        .arg(python_script("ros2_peer.py"))
        .args(["subscribe", &endpoint, "5"])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start the Python peer");
    let mut lines = BufReader::new(child.stdout.take().expect("stdout")).lines();
    assert_eq!(lines.next().and_then(|l| l.ok()).as_deref(), Some("ready"));

    let mut config = NodeConfig::new("/fringe", "fringe_stream");
    config.connect = vec![endpoint.clone()];
    config.listen = vec!["tcp/127.0.0.1:0".into()];
    let mut node = Node::open(config).expect("node");
    let mut publisher = node
        .publisher::<WrenchStamped>("wrench", Qos::DEFAULT)
        .expect("publisher");
    // Put until the peer has taken its five (the first may go before its subscription arrives).
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let result = lines.find_map(|l| l.ok().filter(|l| l.starts_with('{')));
        let _ = tx.send(result);
    });
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut k = 0i64;
    let report = loop {
        if let Ok(r) = rx.try_recv() {
            break r.expect("the peer's report");
        }
        assert!(Instant::now() < deadline, "the peer took nothing in 30 s");
        k += 1;
        publisher
            .put(&wrench(-0.5 * k as f64), 1_000 + k)
            .expect("put");
        std::thread::sleep(Duration::from_millis(50));
    };
    let _ = child.wait();
    let r: serde_json::Value = serde_json::from_str(&report).expect("json");
    let hash = type_hash(WrenchStamped::TYPE);
    assert_eq!(r["hash"], hash.as_str(), "rosbags' type hash");
    let messages = r["messages"].as_array().expect("messages");
    assert_eq!(messages.len(), 5, "{r}");
    let mut last_seq = 0;
    for m in messages {
        assert_eq!(m["key"], publisher.key(), "{m}");
        assert_eq!(m["attachment_len"], 33);
        assert_eq!(m["gid_len"], 16);
        let seq = m["seq"].as_i64().expect("seq");
        assert!(seq > last_seq, "{r}");
        last_seq = seq;
        assert_eq!(m["sent_ns"].as_i64(), Some(1_000 + seq));
        assert_eq!(m["fz"].as_f64(), Some(-0.5 * seq as f64));
        assert_eq!(m["frame_id"], "fringe_sensor");
    }
    let tokens: Vec<&str> = r["tokens"]
        .as_array()
        .expect("tokens")
        .iter()
        .filter_map(|t| t.as_str())
        .collect();
    assert!(
        tokens
            .iter()
            .any(|t| t.ends_with("/0/0/NN/%/%fringe/fringe_stream")),
        "{tokens:?}"
    );
    let publisher_token = format!(
        "/0/1/MP/%/%fringe/fringe_stream/%fringe%wrench/geometry_msgs::msg::dds_::WrenchStamped_/{hash}/::,10:,:,:,,"
    );
    assert!(
        tokens.iter().any(|t| t.ends_with(&publisher_token)),
        "{tokens:?}"
    );
}

#[test]
fn a_recording_opens_in_rosbags_and_the_mcap_readers() {
    require_python_module("rosbags");
    require_python_module("mcap_ros2");
    let dir = std::env::temp_dir().join(format!("fringe-ros2-peer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("stream.mcap");
    let mut r = Recorder::create(&path).expect("create");
    let mut w = r
        .channel::<WrenchStamped>("/fringe/wrench", Qos::DEFAULT)
        .expect("wrench");
    let mut s = r
        .channel::<Classification>("/fringe/shape", Qos::DEFAULT)
        .expect("shape");
    for k in 0..40u64 {
        r.write(&mut w, &wrench(-0.1 * k as f64), 10 + k, 10 + k)
            .expect("write");
    }
    let shape = Classification {
        header: wrench(0.0).header,
        results: vec![
            ObjectHypothesis {
                class_id: "pentagon".into(),
                score: 0.8,
            },
            ObjectHypothesis {
                class_id: "rectangle".into(),
                score: 0.2,
            },
        ],
    };
    for k in 0..10u64 {
        r.write(&mut s, &shape, 100 + k, 100 + k).expect("write");
    }
    r.finish().expect("finish");
    let out = Command::new(python())
        .arg(python_script("ros2_peer.py"))
        .args(["read-mcap", &path.display().to_string()])
        .output()
        .expect("run the Python readers");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the readers' json");
    assert_eq!(v["rosbags"]["/fringe/wrench"], 40, "{v}");
    assert_eq!(v["rosbags"]["/fringe/shape"], 10, "{v}");
    assert_eq!(v["mcap_ros2"], 50, "{v}");
    assert_eq!(v["summary"], true);
    let fz: Vec<f64> = v["fz"]
        .as_array()
        .expect("fz")
        .iter()
        .filter_map(|x| x.as_f64())
        .collect();
    assert_eq!(fz.len(), 40);
    assert!(
        fz.iter().enumerate().all(|(k, f)| *f == -0.1 * k as f64),
        "{fz:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
