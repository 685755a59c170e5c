//! `fringe stream` on the simulated bench, against a robot's side with no ROS install
//! (tests/python/stream_peer.py with FRINGE_PYTHON): an eclipse-zenoh peer takes every message of
//! the node's topics on rmw_zenoh's keys and decodes it with rosbags, sees the node's and its
//! publishers' liveliness tokens; rosbags reads the MCAP recording, each prediction beside the
//! simulator's truth of the same frame, and the figures it computes are the ones fringe printed.

mod common;

use common::{
    constant_model, constant_model_of_class, scratch, text, unit_rig_at, CONSTANT_CONTACT_MM,
    CONSTANT_FZ_N,
};
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn python() -> String {
    std::env::var("FRINGE_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/python/stream_peer.py")
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// The number printed after `key` in `s`.
fn figure(s: &str, key: &str) -> f64 {
    let at = s.find(key).unwrap_or_else(|| panic!("{key:?} in {s}")) + key.len();
    let n: String = s[at..]
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | '+'))
        .collect();
    n.parse()
        .unwrap_or_else(|_| panic!("a number after {key:?} in {s}"))
}

/// The simulated bench at quarter size and 25 fps, so that a debug build keeps up.
const RIG: &str = "[camera]\nframe_rate = 25.0\n[sim]\nimage_scale = 0.25\n";

#[test]
fn a_robot_s_zenoh_peer_takes_every_topic_and_the_recording_holds_the_truth_beside_it() {
    let dir = scratch("stream-peer");
    let model = constant_model(&dir);
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, RIG).expect("rig");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let mut peer = Command::new(python())
        .arg(script())
        .args(["listen", &endpoint, "3"])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start the Python peer (FRINGE_PYTHON with eclipse-zenoh and rosbags)");
    let mut lines = BufReader::new(peer.stdout.take().expect("stdout")).lines();
    assert_eq!(
        lines.next().and_then(|l| l.ok()).as_deref(),
        Some("ready"),
        "the peer did not start"
    );
    let mcap = dir.join("stream.mcap");
    let out = common::fringe_command()
        .current_dir(&dir)
        .args(["stream", "--seconds", "8", "--image-hz", "2", "--rig"])
        .arg(&rig)
        .arg("--model")
        .arg(&model)
        .arg("--mcap")
        .arg(&mcap)
        .args(["--connect", &endpoint, "--listen", "tcp/127.0.0.1:0"])
        .output()
        .expect("run fringe stream");
    let printed = text(&out);
    assert!(out.status.success(), "{printed}");
    let report: Value = lines
        .find_map(|l| l.ok().filter(|l| l.starts_with('{')))
        .and_then(|l| serde_json::from_str(&l).ok())
        .expect("the peer's report");
    let _ = peer.wait();

    // What fringe says it did.
    let streamed = figure(&printed, "streamed") as u64;
    let published = figure(&printed, "published under /fringe: wrench") as u64;
    assert!(streamed >= 100, "8 s at 25 fps: {printed}");
    assert_eq!(published, streamed, "{printed}");
    assert!(printed.contains("Zenoh: connected"), "{printed}");
    assert!(
        printed.contains("latency, end of exposure to published"),
        "{printed}"
    );
    assert!(figure(&printed, "p50") > 0.0, "{printed}");
    // The camera clock places each exposure where the simulator's camera made it.
    let placed_us = figure(&printed, "against the simulator's truth: within");
    assert!(placed_us < 500.0, "{printed}");

    // The peer decoded every topic (those put before its route was made aside).
    assert_eq!(report["bad"], serde_json::json!([]), "{report}");
    let got = |t: &str| report["counts"][t].as_u64().unwrap_or(0);
    assert!(got("wrench") + 10 >= published, "{report} vs {printed}");
    assert_eq!(got("wrench"), got("shape"), "{report}");
    assert_eq!(
        got("wrench"),
        got("contact"),
        "the model always says pentagon: {report}"
    );
    assert!(got("image/compressed") >= 8, "2 Hz for 8 s: {report}");
    for fz in report["fz"].as_array().expect("fz") {
        assert!(
            (fz.as_f64().expect("fz") - CONSTANT_FZ_N).abs() < 1e-4,
            "{fz}"
        );
    }
    let c = &report["contacts"][0];
    assert!(
        (c[0].as_f64().expect("x") - CONSTANT_CONTACT_MM[0] * 1e-3).abs() < 1e-7,
        "metres: {c}"
    );
    assert!(
        (c[1].as_f64().expect("y") - CONSTANT_CONTACT_MM[1] * 1e-3).abs() < 1e-7,
        "{c}"
    );
    let p = report["shapes"][0]["pentagon"].as_f64().expect("pentagon");
    assert!(p > 0.99, "{report}");
    // Keys and tokens as rmw_zenoh makes them.
    let keys: Vec<&str> = report["keys"]
        .as_array()
        .expect("keys")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert!(
        keys.iter().any(|k| k.starts_with(
            "0/fringe/wrench/geometry_msgs::msg::dds_::WrenchStamped_/RIHS01_8dc3deaf"
        )),
        "{keys:?}"
    );
    let tokens: Vec<&str> = report["tokens"]
        .as_array()
        .expect("tokens")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert!(
        tokens
            .iter()
            .any(|t| t.ends_with("/0/0/NN/%/%fringe/fringe_stream")),
        "{tokens:?}"
    );
    for topic in ["%fringe%wrench", "%fringe%contact", "%fringe%shape"] {
        assert!(
            tokens
                .iter()
                .any(|t| t.contains("/MP/%/%fringe/fringe_stream/") && t.contains(topic)),
            "{topic} in {tokens:?}"
        );
    }

    // The recording: the same messages, and the truth beside them.
    let read = Command::new(python())
        .arg(script())
        .args(["read-mcap"])
        .arg(&mcap)
        .output()
        .expect("read the recording");
    assert!(read.status.success(), "{}", text(&read));
    let rec: Value = serde_json::from_slice(&read.stdout).expect("json");
    assert_eq!(
        rec["counts"]["/fringe/wrench"].as_u64(),
        Some(published),
        "{rec}"
    );
    assert!(rec["stamps_increase"].as_bool().expect("order"), "{rec}");
    let span = rec["span_s"].as_f64().expect("span");
    assert!((6.0..9.0).contains(&span), "stamps over {span} s: {rec}");
    let pairs = rec["pairs"].as_u64().expect("pairs");
    let scored = figure(&printed, "against the simulator's truth (") as u64;
    assert_eq!(pairs, scored, "{rec} vs {printed}");
    assert!(pairs * 10 >= published * 9, "most frames scored: {rec}");
    // Fz RMSE and shape accuracy from the recording are the printed ones.
    let fz_rmse = rec["fz_rmse"].as_f64().expect("rmse");
    assert!(
        (fz_rmse - figure(&printed, "Fz RMSE")).abs() < 1.5e-3,
        "{rec} vs {printed}"
    );
    let accuracy = 100.0 * rec["shape_accuracy"].as_f64().expect("accuracy");
    assert!(
        (accuracy - figure(&printed, "shape accuracy")).abs() < 0.06,
        "{rec} vs {printed}"
    );
    // The robot pressed within the 8 s.
    assert!(
        rec["truth_in_contact"].as_u64().expect("contact") > 10,
        "{rec}"
    );
}

#[test]
fn a_stream_that_would_send_nothing_or_to_a_bad_namespace_is_refused() {
    let dir = scratch("stream-refused");
    let out = common::fringe_command()
        .current_dir(&dir)
        .args(["stream", "--no-ros2", "--seconds", "1"])
        .output()
        .expect("run");
    assert!(!out.status.success());
    assert!(text(&out).contains("give --mcap FILE"), "{}", text(&out));
    let out = common::fringe_command()
        .current_dir(&dir)
        .args([
            "stream",
            "--namespace",
            "/fringe/left finger",
            "--seconds",
            "1",
        ])
        .output()
        .expect("run");
    assert!(!out.status.success());
    assert!(
        text(&out).contains("`/fringe/left finger` is not a ROS 2 namespace: only letters, digits, `_` and `/` may be used"),
        "{}",
        text(&out)
    );
}

#[test]
fn the_python_example_prints_the_streamed_wrench_without_ros() {
    let dir = scratch("stream-example");
    let model = constant_model(&dir);
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, RIG).expect("rig");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    // fringe listens; the example connects to it as it would to a router.
    let mut stream = common::fringe_command()
        .current_dir(&dir)
        .args(["stream", "--seconds", "10", "--rig"])
        .arg(&rig)
        .arg("--model")
        .arg(&model)
        .args(["--listen", &endpoint, "--connect", "tcp/127.0.0.1:9"])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start fringe stream");
    // The example starts once fringe listens (its first status line is after the node opened).
    let (tx, rx) = std::sync::mpsc::channel();
    let out = stream.stdout.take().expect("stdout");
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut said = Vec::new();
    loop {
        let line = rx
            .recv_timeout(std::time::Duration::from_secs(120))
            .unwrap_or_else(|_| panic!("fringe stream said no `streaming` line: {said:?}"));
        let go = line.starts_with("streaming for");
        said.push(line);
        if go {
            break;
        }
    }
    let mut example = Command::new(python())
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/zenoh_wrench.py"))
        .arg(&endpoint)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the example");
    let status = stream.wait().expect("fringe stream ends");
    let _ = example.kill();
    let printed = example.wait_with_output().expect("example output");
    let lines = String::from_utf8_lossy(&printed.stdout).to_string();
    assert!(status.success(), "fringe stream failed");
    let wrenches: Vec<&str> = lines.lines().filter(|l| l.contains(" Fz ")).collect();
    assert!(
        wrenches.len() >= 50,
        "{} lines: {lines}\n{}",
        wrenches.len(),
        String::from_utf8_lossy(&printed.stderr)
    );
    for l in &wrenches {
        assert!(l.ends_with(&format!("Fz {CONSTANT_FZ_N:7.3} N")), "{l}");
    }
}

#[test]
fn a_camera_that_moved_since_the_unit_s_calibration_is_said_while_streaming() {
    let dir = scratch("stream-health");
    // A model that calls every frame free, so that every frame serves the health watch.
    let model = constant_model_of_class(&dir, 0, "free.safetensors");
    let rig = unit_rig_at(&dir, 0.25);
    let text_of_rig = std::fs::read_to_string(&rig).expect("rig");
    std::fs::write(
        &rig,
        text_of_rig.replace("[camera]\n", "[camera]\nframe_rate = 25.0\n"),
    )
    .expect("rig");
    // The unit's profile as calibrated, then the camera knocked 6 px to the right since.
    let config = fringe_app::RigConfig::load(&rig).expect("rig file");
    let mut profile = fringe_app::rig::unit_profile(&config, "layered-3")
        .expect("profile")
        .expect("the design's profile");
    profile.optical.centre_x_px -= 6.0;
    let path = fringe_calibration::profile_path(&dir.join("profiles"), "layered-3").expect("path");
    std::fs::create_dir_all(dir.join("profiles")).expect("profiles");
    profile.save(&path).expect("save the profile");
    let out = common::fringe_command()
        .current_dir(&dir)
        .args(["stream", "--no-ros2", "--seconds", "15", "--rig"])
        .arg(&rig)
        .arg("--model")
        .arg(&model)
        .arg("--mcap")
        .arg(dir.join("s.mcap"))
        .output()
        .expect("run fringe stream");
    let printed = text(&out);
    assert!(out.status.success(), "{printed}");
    assert!(
        printed.contains("warning: the optical centre is (+")
            && printed.contains("px from the unit's profile"),
        "{printed}"
    );
    let shift = figure(&printed, "optical centre (");
    assert!((shift - 6.0).abs() < 0.5, "{printed}");
    assert!(!printed.contains("the light changed"), "{printed}");
    // The model reads 2 N on frames it calls free: its no-contact baseline is off, and said.
    assert!(
        printed.contains("on frames it calls free of contact the model reads Fz +2.000 N"),
        "{printed}"
    );
}
