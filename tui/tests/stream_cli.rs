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

/// The recording as the `mcap` package reads it: the message count of its summary (`None`: no
/// summary, the file did not read back whole) and the wrench messages it holds.
fn mcap_read_back(path: &Path) -> (Option<u64>, u64) {
    let script = r#"
import sys
from mcap.reader import make_reader
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    try:
        summary = reader.get_summary()
        count = summary.statistics.message_count if summary and summary.statistics else -1
    except Exception:
        count = -1
    f.seek(0)
    wrenches = sum(1 for _ in make_reader(f).iter_messages(topics=["/fringe/wrench"]))
print(count, wrenches)
"#;
    let out = Command::new(python())
        .args(["-c", script])
        .arg(path)
        .output()
        .expect("python with the mcap package (FRINGE_PYTHON)");
    let printed = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{}: {printed}{}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let mut numbers = printed.split_whitespace().map(|n| n.parse::<i64>().ok());
    let count = numbers.next().flatten().expect("the message count");
    let wrenches = numbers.next().flatten().expect("the wrench count");
    (u64::try_from(count).ok(), wrenches as u64)
}

#[test]
fn ctrl_c_stops_the_stream_with_its_recording_whole_and_its_summary() {
    let dir = scratch("stream-sigint");
    let model = constant_model(&dir);
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, RIG).expect("rig");
    let mcap = dir.join("stream.mcap");
    let mut stream = common::fringe_command()
        .current_dir(&dir)
        .args(["stream", "--no-ros2", "--rig"])
        .arg(&rig)
        .arg("--model")
        .arg(&model)
        .arg("--mcap")
        .arg(&mcap)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start fringe stream");
    let (tx, rx) = std::sync::mpsc::channel();
    let out = stream.stdout.take().expect("stdout");
    let reader = std::thread::spawn(move || {
        let mut all = Vec::new();
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let _ = tx.send(line.clone());
            all.push(line);
        }
        all.join("\n")
    });
    // Until a status line says 25 frames ran (a second at 25 fps).
    loop {
        let line = rx
            .recv_timeout(std::time::Duration::from_secs(120))
            .unwrap_or_else(|_| panic!("fringe stream printed no status line"));
        if line.contains(" Hz  frames ") && figure(&line, " Hz  frames ") >= 25.0 {
            break;
        }
    }
    // SAFETY: kill(2) on the child's pid; the child is ours and has not been waited for.
    unsafe {
        libc::kill(stream.id() as libc::pid_t, libc::SIGINT);
    }
    let status = stream.wait().expect("fringe stream ends");
    let printed = reader.join().expect("stdout");
    assert!(status.success(), "{printed}");
    assert!(printed.contains("stopping (signal)"), "{printed}");
    let streamed = figure(&printed, "streamed") as u64;
    assert!(streamed >= 25, "{printed}");
    assert!(
        printed.contains(&format!("recorded to {}", mcap.display())),
        "{printed}"
    );
    // The file was closed with its summary, and holds every frame's wrench.
    let (summary, wrenches) = mcap_read_back(&mcap);
    assert!(
        summary.is_some_and(|n| n >= 2 * streamed),
        "{summary:?}: {printed}"
    );
    assert_eq!(wrenches, streamed, "{printed}");
}

/// The recording's disk fills up while it streams: the recording is closed whole and said,
/// the stream goes on to its end; a recording started with less room than it keeps is refused.
/// The disk is a tmpfs mounted in a private mount namespace (`unshare -rm`, as faults_cli's full
/// disk), of 40 MB, filled to below the reserve once the stream runs.
#[test]
fn a_recording_whose_disk_fills_up_is_closed_whole_and_the_stream_goes_on() {
    let dir = scratch("stream-disk-full");
    let model = constant_model(&dir);
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, RIG).expect("rig");
    let rec = dir.join("rec");
    std::fs::create_dir_all(&rec).expect("rec dir");
    let script = r#"
set -u
mount -t tmpfs -o size=40m fringe-test "$REC" || exit 90
"$FRINGE" stream --no-ros2 --seconds 8 --rig "$RIG" --model "$MODEL" --mcap "$REC/stream.mcap" >"$DIR/out.txt" 2>&1 &
stream=$!
while ! grep -q " Hz  frames " "$DIR/out.txt" && kill -0 "$stream" 2>/dev/null; do sleep 0.05; done
dd if=/dev/zero of="$REC/filler" bs=1M count=30 2>/dev/null
wait "$stream"
echo $? >"$DIR/rc"
cp "$REC/stream.mcap" "$DIR/stream.mcap"
"$FRINGE" stream --no-ros2 --seconds 2 --rig "$RIG" --model "$MODEL" --mcap "$REC/second.mcap" >"$DIR/refused.txt" 2>&1
echo $? >"$DIR/refused.rc"
"#;
    let status = Command::new("unshare")
        .args(["-rm", "sh", "-c", script])
        .env("REC", &rec)
        .env("DIR", &dir)
        .env("RIG", &rig)
        .env("MODEL", &model)
        .env("FRINGE", env!("CARGO_BIN_EXE_fringe"))
        .status()
        .expect("unshare (util-linux) runs the test in its own mount namespace");
    assert!(
        status.success(),
        "the namespace script failed ({status}): 90 = tmpfs mount refused"
    );
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    let printed = read("out.txt");
    assert_eq!(read("rc").trim(), "0", "{printed}");
    assert!(
        printed.contains("left (the recording keeps 16 MB)"),
        "{printed}"
    );
    assert!(
        printed.contains("reads back whole; the stream goes on without it"),
        "{printed}"
    );
    // The stream went on to its end (8 s at 25 fps).
    let streamed = figure(&printed, "streamed") as u64;
    assert!(streamed >= 150, "{printed}");
    // The recording reads back whole, with what it took before it was closed.
    let (summary, wrenches) = mcap_read_back(&dir.join("stream.mcap"));
    assert!(summary.is_some(), "no summary: {printed}");
    assert!(
        wrenches >= 25 && wrenches < streamed,
        "{wrenches} of {streamed}: {printed}"
    );
    // With less room than the recording keeps, none is started.
    let refused = read("refused.txt");
    assert_ne!(read("refused.rc").trim(), "0", "{refused}");
    assert!(
        refused.contains("--mcap: the disk holding")
            && refused.contains("free some space or record elsewhere"),
        "{refused}"
    );
}
