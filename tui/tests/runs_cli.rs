//! `fringe runs` and `fringe verify` on run directories written by the run store.

mod common;

use common::{fringe, text};
use fringe_rig::camera::{Frame, PixelFormat};
use fringe_rig::clock::HostTime;
use fringe_rig::store::documents::{
    now_utc, ExitStatus, FrameRecord, Position, StartDocument, StopDocument,
};
use fringe_rig::store::run_writer::RunWriter;
use fringe_rig::units::{Millimetres, Newtons, Wrench};
use std::path::{Path, PathBuf};

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
        let file = w.save_frame_image(&frame, id).expect("save");
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
            exposure_ticks: None,
            point: 0,
            commanded: p,
            measured: p,
            // Frames 0 and 1 are labelled (1 in contact), frame 2 has no force label.
            wrench: (id < 2).then(|| Wrench {
                fz: Newtons(-(id as f64) * 2.5),
                ..Wrench::default()
            }),
            shape: if id == 1 { "rectangle" } else { "None" }.into(),
            contact: (id == 1).then_some([1.5, -2.0]),
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
            sync_method: Some("strobe".into()),
            sync_error_ns: None,
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

#[test]
fn export_writes_the_reference_layout() {
    let root = std::env::temp_dir().join(format!("fringe-export-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let a = write_run(&root, "run-a", true);
    let b = write_run(&root, "run-b", true);
    let out = root.join("dataset");
    let args = [
        "export",
        a.to_str().expect("utf-8"),
        b.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ];
    let result = fringe(&args);
    assert!(result.status.success(), "{}", text(&result));
    let csv = std::fs::read_to_string(out.join("0.labels.csv")).expect("labels");
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("New_Image_Name,Fx,Fy,Fz,Mx,My,Mz,Ft,X_Position_mm,Y_Position_mm,Indentor_Shape")
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 4, "{csv}");
    assert_eq!(rows[0], "image_0.tiff,0,0,0,0,0,0,0,NaN,NaN,None");
    assert_eq!(rows[1], "image_1.tiff,0,0,-2.5,0,0,0,2.5,1.5,-2,rectangle");
    assert!(rows[3].starts_with("image_3.tiff,"));
    for k in 0..4 {
        let img = image::open(out.join(format!("0.images/image_{k}.tiff"))).expect("tiff");
        assert_eq!((img.width(), img.height()), (4, 2));
    }
    assert!(
        text(&result).contains("2 invalid frames left out"),
        "{}",
        text(&result)
    );
    // Provenance beside the labels: each run, its rows, and that it had no calibration profile
    // (which the export warns about).
    let prov: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("0.export.json")).expect("provenance"),
    )
    .expect("json");
    let runs = prov["runs"].as_array().expect("runs");
    assert_eq!(runs.len(), 2);
    assert_eq!(runs[0]["run_id"], "run-a");
    assert_eq!(
        (runs[0]["first_image"].as_u64(), runs[0]["images"].as_u64()),
        (Some(0), Some(2))
    );
    assert_eq!(runs[1]["first_image"].as_u64(), Some(2));
    assert!(runs[1]["calibration_profile"].is_null());
    assert!(
        text(&result).contains("used no calibration profile"),
        "{}",
        text(&result)
    );
    let again = fringe(&args);
    assert!(!again.status.success());
    assert!(text(&again).contains("already there"), "{}", text(&again));
    let _ = std::fs::remove_dir_all(&root);
}
