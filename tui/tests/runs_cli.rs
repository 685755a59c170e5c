//! `fringe runs` and `fringe verify` on run directories written by the run store.

use fringe_rig::camera::{Frame, PixelFormat};
use fringe_rig::clock::HostTime;
use fringe_rig::store::documents::{
    now_utc, ExitStatus, FrameRecord, Position, StartDocument, StopDocument,
};
use fringe_rig::store::run_writer::RunWriter;
use fringe_rig::units::Millimetres;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fringe(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fringe"))
        .args(args)
        .output()
        .expect("run fringe")
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn write_run(root: &Path, id: &str, finish: bool) -> PathBuf {
    let start = StartDocument {
        layout_version: 1,
        run_id: id.into(),
        started_utc: now_utc(),
        software: "test".into(),
        sensor_id: "integrated-02".into(),
        plan: String::new(),
        rig: String::new(),
        calibration_profile: None,
        seed: None,
        sync_method: "host".into(),
    };
    let mut w = RunWriter::create(root, &start).expect("create");
    for id in 0..3u64 {
        let frame = Frame {
            id,
            device_timestamp: id,
            host_arrival: HostTime(id),
            width: 4,
            height: 2,
            format: PixelFormat::Mono8,
            data: vec![id as u8; 8],
        };
        let file = w.save_frame_image(&frame).expect("save");
        let p = Position {
            x: Millimetres(0.0),
            y: Millimetres(0.0),
            z: Millimetres(0.0),
        };
        w.append_frame(&FrameRecord {
            index: id,
            frame_id: id,
            file,
            device_timestamp: id,
            host_arrival_ns: id,
            exposure: None,
            point: 0,
            commanded: p,
            measured: p,
            wrench: None,
            shape: "None".into(),
            contact: None,
            valid: true,
            notes: vec![],
        })
        .expect("record");
    }
    let dir = w.dir().to_path_buf();
    if finish {
        w.finish(&StopDocument {
            exit_status: ExitStatus::Completed,
            reason: "done".into(),
            stopped_utc: now_utc(),
            frames: 3,
            dropped_frames: 0,
            force_samples: 0,
            lost_force_samples: 0,
            points_done: 1,
        })
        .expect("finish");
    } else {
        w.checkpoint().expect("checkpoint");
    }
    dir
}

#[test]
fn runs_lists_and_verify_judges_runs() {
    let root = std::env::temp_dir().join(format!("fringe-runs-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let done = write_run(&root, "run-done", true);
    let crashed = write_run(&root, "run-crashed", false);

    let out = fringe(&["runs", "--root", root.to_str().expect("utf-8")]);
    let listing = text(&out);
    assert!(out.status.success(), "{listing}");
    assert!(
        listing.contains("run-done") && listing.contains("completed"),
        "{listing}"
    );
    assert!(
        listing.contains("run-crashed") && listing.contains("unfinished"),
        "{listing}"
    );

    let out = fringe(&["verify", done.to_str().expect("utf-8")]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("3 frames"));

    std::fs::write(done.join("frames/00000001.png"), b"not a png").expect("damage");
    let out = fringe(&["verify", done.to_str().expect("utf-8")]);
    let report = text(&out);
    assert!(!out.status.success(), "{report}");
    assert!(
        report.contains("frames/00000001.png: checksum differs"),
        "{report}"
    );

    let out = fringe(&["verify", crashed.to_str().expect("utf-8")]);
    let report = text(&out);
    assert!(!out.status.success());
    assert!(
        report.contains("did not finish") && report.contains("--resume"),
        "{report}"
    );

    let out = fringe(&["verify", root.join("nope").to_str().expect("utf-8")]);
    assert!(!out.status.success());
    assert!(text(&out).contains("start.json"), "{}", text(&out));
    let _ = std::fs::remove_dir_all(&root);
}
