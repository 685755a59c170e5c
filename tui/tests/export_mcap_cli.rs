//! `fringe export RUN --format mcap`: a scan run of the simulated bench exported to MCAP, read
//! back by independent readers from PyPI (rosbags' AnyReader and mcap-ros2-support, through
//! tests/python/ros2_peer.py with the interpreter in FRINGE_PYTHON), every channel decoded and
//! compared with the run as the run store reads it.

mod common;

use common::{arg, fringe, only_run, scan_plan, scratch, text, TestRun, QUICK_RIG};
use fringe_rig::store::{FrameRecord, RunReader};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The Python with the readers of tests/python/requirements.txt: FRINGE_PYTHON, else python3.
fn python() -> String {
    std::env::var("FRINGE_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// The exported file as both readers decode it (ros2_peer.py read-run-mcap).
fn decoded(mcap: &Path) -> serde_json::Value {
    for module in ["rosbags", "mcap_ros2"] {
        let check = Command::new(python())
            .args(["-c", &format!("import {module}")])
            .output()
            .expect("run the Python interpreter (FRINGE_PYTHON or python3)");
        assert!(
            check.status.success(),
            "{module} is not importable by {}: run scripts/test (it installs tests/python/requirements.txt into .venv and sets FRINGE_PYTHON)",
            python()
        );
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/python/ros2_peer.py");
    let out = Command::new(python())
        .arg(script)
        .args(["read-run-mcap", arg(mcap)])
        .output()
        .expect("run the Python readers");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("the readers' json")
}

fn unix_ns(utc: &str) -> i64 {
    // `2026-12-06T17:50:56.530Z`, as the run store writes it.
    let days = fringe_rig::store::utc_days(utc).expect("a date");
    let h: i64 = utc[11..13].parse().expect("hours");
    let m: i64 = utc[14..16].parse().expect("minutes");
    let s: i64 = utc[17..19].parse().expect("seconds");
    let ms: i64 = utc[20..23].parse().expect("milliseconds");
    (days * 86_400 + h * 3_600 + m * 60 + s) * 1_000_000_000 + ms * 1_000_000
}

fn f64s(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn partials(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.to_string_lossy().contains(".partial-"))
        .collect()
}

fn has_label(r: &FrameRecord) -> bool {
    r.valid && r.wrench.is_some()
}

fn in_contact(r: &FrameRecord) -> bool {
    has_label(r) && r.contact.is_some() && r.shape != "None"
}

#[test]
fn a_scan_run_exports_to_mcap_that_ros_2_readers_decode_channel_by_channel() {
    let dir = scratch("scan");
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, QUICK_RIG).expect("rig");
    let plan = dir.join("plan.toml");
    std::fs::write(&plan, scan_plan("[12.5]")).expect("plan");
    let runs = dir.join("runs");
    let scan = fringe(&[
        "scan",
        "--yes",
        "--rig",
        arg(&rig),
        "--out",
        arg(&runs),
        arg(&plan),
    ]);
    assert!(scan.status.success(), "{}", text(&scan));
    let run = only_run(&runs);
    let mcap = dir.join("run.mcap");
    let out = fringe(&["export", arg(&run), "--format", "mcap", "--out", arg(&mcap)]);
    let printed = text(&out);
    assert!(out.status.success(), "{printed}");
    assert!(
        printed.contains("expected"),
        "the estimate first: {printed}"
    );
    assert!(printed.contains("stamps: Unix time"), "{printed}");

    let reader = RunReader::at(&run);
    let start = reader.start().expect("start");
    let stop = reader.stop().expect("stop").expect("a stopped run");
    let records = reader.frames().expect("frames");
    let (force, _) = reader.force().expect("force");
    let events = reader.events().expect("events");
    let labelled: Vec<&FrameRecord> = records.iter().filter(|r| has_label(r)).collect();
    let contacts: Vec<&FrameRecord> = records.iter().filter(|r| in_contact(r)).collect();
    assert!(records.len() > 50 && force.len() > 10_000, "a real scan");
    assert!(!contacts.is_empty() && contacts.len() < labelled.len());

    let v = decoded(&mcap);
    let want = [
        ("/fringe/image", "sensor_msgs/msg/Image", records.len()),
        ("/fringe/ft", "geometry_msgs/msg/WrenchStamped", force.len()),
        (
            "/fringe/wrench",
            "geometry_msgs/msg/WrenchStamped",
            labelled.len(),
        ),
        (
            "/fringe/contact",
            "geometry_msgs/msg/PointStamped",
            contacts.len(),
        ),
        (
            "/fringe/shape",
            "vision_msgs/msg/Classification",
            labelled.len(),
        ),
        ("/fringe/events", "rcl_interfaces/msg/Log", events.len()),
    ];
    for (topic, ty, count) in want {
        assert_eq!(v["types"][topic], ty, "{topic}: {}", v["types"]);
        assert_eq!(v["rosbags"][topic].as_u64(), Some(count as u64), "{topic}");
        assert_eq!(
            v["mcap_ros2"][topic].as_u64(),
            Some(count as u64),
            "{topic}"
        );
    }
    assert_eq!(v["types"].as_object().map(|o| o.len()), Some(6));
    assert_eq!(v["summary"], true);
    assert_eq!(v["profile"], "ros2");
    assert_eq!(v["log_time_is_stamp"], true);
    assert_eq!(v["metadata"]["fringe_run"]["run_id"], start.run_id.as_str());
    // rosbags' own hash of every type, from the schemas in the file, is fringe's.
    for (ty, hash) in v["hashes"].as_object().expect("hashes") {
        let ours = match ty.as_str() {
            "sensor_msgs/msg/Image" => {
                fringe_ros2::type_hash(<fringe_ros2::Image as fringe_ros2::RosMessage>::TYPE)
            }
            "geometry_msgs/msg/WrenchStamped" => fringe_ros2::type_hash(
                <fringe_ros2::WrenchStamped as fringe_ros2::RosMessage>::TYPE,
            ),
            "geometry_msgs/msg/PointStamped" => {
                fringe_ros2::type_hash(<fringe_ros2::PointStamped as fringe_ros2::RosMessage>::TYPE)
            }
            "vision_msgs/msg/Classification" => fringe_ros2::type_hash(
                <fringe_ros2::Classification as fringe_ros2::RosMessage>::TYPE,
            ),
            "rcl_interfaces/msg/Log" => {
                fringe_ros2::type_hash(<fringe_ros2::Log as fringe_ros2::RosMessage>::TYPE)
            }
            other => panic!("an unexpected type {other}"),
        };
        assert_eq!(hash, ours.as_str(), "{ty}");
    }

    // Images: the stored pixels, as stored.
    let storage = start.frame_storage();
    let images = v["images"].as_array().expect("images");
    for (k, record) in [0, records.len() / 2, records.len() - 1]
        .into_iter()
        .map(|k| (k, &records[k]))
    {
        let stored = reader
            .stored_frame(&storage, record)
            .expect("readable")
            .expect("whole");
        let i = &images[k];
        assert_eq!(i["encoding"], "bayer_rggb8");
        assert_eq!(
            (
                i["width"].as_u64(),
                i["height"].as_u64(),
                i["step"].as_u64()
            ),
            (
                Some(stored.width as u64),
                Some(stored.height as u64),
                Some(stored.width as u64)
            )
        );
        let sum: u64 = stored.data.iter().map(|&b| b as u64).sum();
        assert_eq!(i["sum"].as_u64(), Some(sum), "image {k}");
        assert_eq!(i["frame_id"], "fringe_sensor_camera");
    }

    // Labels: the run's values, each at its frame's stamp.
    let labels = v["labels"].as_array().expect("labels");
    let shapes = v["shapes"].as_array().expect("shapes");
    for (k, record) in labelled.iter().enumerate() {
        let w = record.wrench.expect("a wrench").to_array();
        assert_eq!(f64s(&labels[k]["wrench"]), w.to_vec(), "label {k}");
        assert_eq!(labels[k]["frame_id"], "fringe_sensor");
        let class = if in_contact(record) {
            record.shape.as_str()
        } else {
            "None"
        };
        assert_eq!(shapes[k]["results"][0][0], class, "shape {k}");
        assert_eq!(shapes[k]["results"][0][1].as_f64(), Some(1.0));
        assert_eq!(shapes[k]["stamp"], labels[k]["stamp"]);
    }
    let points = v["contacts"].as_array().expect("contacts");
    for (k, record) in contacts.iter().enumerate() {
        let [x, y] = record.contact.expect("contact");
        assert_eq!(
            f64s(&points[k]["point"]),
            vec![x / 1000.0, y / 1000.0, 0.0],
            "contact {k} in metres"
        );
    }

    // F/T: every sample, raw, in order; its stamps the host times on one offset.
    let ft = &v["ft"];
    assert_eq!(ft["stamps_increasing"], true);
    assert_eq!(
        f64s(&ft["first"]["wrench"]),
        force[0].wrench.to_array().to_vec()
    );
    assert_eq!(
        f64s(&ft["last"]["wrench"]),
        force[force.len() - 1].wrench.to_array().to_vec()
    );
    assert_eq!(ft["first"]["frame_id"], "fringe_sensor_ft");
    let first_ft = ft["first"]["stamp"].as_i64().expect("stamp");
    let offset = first_ft - force[0].host_time.0 as i64;
    assert_eq!(
        ft["last"]["stamp"].as_i64(),
        Some(offset + force[force.len() - 1].host_time.0 as i64)
    );

    // Unix time: inside the run's start and stop, each event within the millisecond its UTC
    // names, each label between the F/T samples around the middle of its exposure.
    let (begun, ended) = (unix_ns(&start.started_utc), unix_ns(&stop.stopped_utc));
    for stamp in [first_ft, ft["last"]["stamp"].as_i64().expect("stamp")] {
        assert!(begun <= stamp && stamp <= ended + 1_000_000, "{stamp}");
    }
    for (e, got) in events.iter().zip(v["events"].as_array().expect("events")) {
        let stamp = got["stamp"].as_i64().expect("stamp");
        let utc = unix_ns(&e.utc);
        assert!(
            utc - 1_000_000 <= stamp && stamp <= utc + 2_000_000,
            "{} at {stamp}, {utc}",
            e.kind
        );
        assert_eq!(got["name"], format!("fringe.{}", e.kind).as_str());
    }
    for (k, record) in labelled.iter().enumerate() {
        let stamp = labels[k]["stamp"].as_i64().expect("stamp");
        let [a, b] = record.exposure_ticks.expect("strobe windows");
        let mid = 0.5 * (a + b);
        let before = force
            .iter()
            .rev()
            .find(|s| s.device_tick as f64 <= mid)
            .expect("a sample before");
        let after = force
            .iter()
            .find(|s| s.device_tick as f64 >= mid)
            .expect("a sample after");
        let host = stamp - offset;
        assert!(
            before.host_time.0 as i64 <= host && host <= after.host_time.0 as i64,
            "label {k}: host {host} not within {} .. {}",
            before.host_time.0,
            after.host_time.0
        );
    }

    // Never over a file: the second export is refused, the first file kept, nothing partial left.
    let before = std::fs::read(&mcap).expect("the export");
    let again = fringe(&["export", arg(&run), "--format", "mcap", "--out", arg(&mcap)]);
    assert!(!again.status.success());
    assert!(text(&again).contains("the file exists"), "{}", text(&again));
    assert_eq!(std::fs::read(&mcap).expect("the export"), before);
    assert!(partials(&dir).is_empty(), "{:?}", partials(&dir));
}

#[test]
fn an_mcap_export_takes_one_verified_run_and_leaves_nothing_when_refused() {
    let dir = scratch("refused");
    let a = TestRun::finished("run-a").write(&dir.join("runs"));
    let b = TestRun::finished("run-b").write(&dir.join("runs"));
    let mcap = dir.join("a.mcap");
    let export = |more: &[&str]| {
        let mut args = vec!["export"];
        args.extend(more);
        fringe(&args)
    };
    let two = export(&[arg(&a), arg(&b), "--format", "mcap", "--out", arg(&mcap)]);
    assert!(!two.status.success());
    assert!(
        text(&two).contains("one run into one file"),
        "{}",
        text(&two)
    );
    let round = export(&[
        arg(&a),
        "--format",
        "mcap",
        "--round",
        "0.1",
        "--out",
        arg(&mcap),
    ]);
    assert!(!round.status.success());
    assert!(text(&round).contains("--round"), "{}", text(&round));
    let named = export(&[
        arg(&a),
        "--format",
        "mcap",
        "--namespace",
        "/my robot",
        "--out",
        arg(&mcap),
    ]);
    assert!(!named.status.success());
    assert!(
        text(&named).contains("is not a ROS 2 namespace"),
        "{}",
        text(&named)
    );
    assert!(!mcap.exists());
    let inside = export(&[arg(&a), "--format", "mcap", "--out", arg(&b.join("x.mcap"))]);
    assert!(!inside.status.success(), "{}", text(&inside));
    assert!(!b.join("x.mcap").exists());

    // A damaged frame: refused, then exported without it when asked.
    std::fs::write(a.join("frames/00000001.fgl"), b"not a frame").expect("damage");
    let refused = export(&[arg(&a), "--format", "mcap", "--out", arg(&mcap)]);
    assert!(!refused.status.success());
    assert!(
        text(&refused).contains("fails verify"),
        "{}",
        text(&refused)
    );
    assert!(!mcap.exists() && partials(&dir).is_empty());
    let allowed = export(&[
        arg(&a),
        "--format",
        "mcap",
        "--allow-unverified",
        "--out",
        arg(&mcap),
    ]);
    let printed = text(&allowed);
    assert!(allowed.status.success(), "{printed}");
    assert!(printed.contains("frames/00000001.fgl"), "{printed}");
    assert!(printed.contains("from the run's start time"), "{printed}");
    let v = decoded(&mcap);
    // Frames 0 and 2 (1 is damaged); the labels of records 0 and 1 (2 has no force), 1 in contact.
    assert_eq!(v["rosbags"]["/fringe/image"].as_u64(), Some(2), "{v}");
    assert_eq!(v["rosbags"]["/fringe/wrench"].as_u64(), Some(2));
    assert_eq!(v["rosbags"]["/fringe/contact"].as_u64(), Some(1));
    assert!(v["rosbags"]["/fringe/ft"].is_null(), "no force samples");
    let images = v["images"].as_array().expect("images");
    assert_eq!(images[0]["encoding"], "mono8");
    assert_eq!(
        images[1]["sum"].as_u64(),
        Some(8 * 2),
        "frame 2: eight pixels of 2"
    );
    let contact = &v["contacts"][0]["point"];
    assert_eq!(f64s(contact), vec![0.0015, -0.002, 0.0]);
    assert!(partials(&dir).is_empty());
}
