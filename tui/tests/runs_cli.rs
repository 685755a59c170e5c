//! `fringe runs` and `fringe verify` on run directories written by the run store.

mod common;

use common::{edit_line, fringe, scratch, snapshot, text, TestRun};
use std::path::{Path, PathBuf};

fn write_run(root: &Path, id: &str, finish: bool) -> PathBuf {
    TestRun {
        finish,
        ..TestRun::finished(id)
    }
    .write(root)
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8")
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

    std::fs::write(done.join("frames/00000001.fgl"), b"not a frame").expect("damage");
    let out = fringe(&["verify", done.to_str().expect("utf-8")]);
    let report = text(&out);
    assert!(!out.status.success(), "{report}");
    assert!(
        report.contains("frames/00000001.fgl: checksum differs"),
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
fn runs_shows_each_runs_size_on_disk() {
    let root = scratch("sizes");
    write_run(&root, "run-small", true);
    let big = write_run(&root, "run-big", false);
    // 4.2 MB more in the unfinished run, as the frames of a point it was recording.
    std::fs::write(big.join("frames/00000099.fgl"), vec![7u8; 4_200_000]).expect("frame");
    let out = fringe(&["runs", "--root", path(&root)]);
    let listing = text(&out);
    assert!(out.status.success(), "{listing}");
    let line = |name: &str| {
        listing
            .lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("no {name} in {listing}"))
            .to_string()
    };
    assert!(
        listing.lines().next().is_some_and(|h| h.contains("size")),
        "{listing}"
    );
    // Sizes are whole megabytes, rounded up: the small run's few kilobytes show as 1 MB.
    assert!(line("run-big").contains(" 5 MB "), "{listing}");
    assert!(line("run-small").contains(" 1 MB "), "{listing}");
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

#[test]
fn runs_names_each_directory_and_refuses_a_missing_root() {
    let root = scratch("names");
    let run = write_run(&root, "run-a", true);
    let copy = root.join("run-a-copy");
    let cp = std::process::Command::new("cp")
        .arg("-a")
        .arg(&run)
        .arg(&copy)
        .status()
        .expect("cp");
    assert!(cp.success());
    let out = fringe(&["runs", "--root", path(&root)]);
    let listing = text(&out);
    assert!(out.status.success(), "{listing}");
    let copy_line = listing
        .lines()
        .find(|l| l.starts_with("run-a-copy "))
        .unwrap_or_else(|| panic!("the copy is listed by its directory: {listing}"));
    assert!(copy_line.contains("(run id run-a)"), "{listing}");
    assert!(
        listing.lines().any(|l| l.starts_with("run-a ")),
        "{listing}"
    );

    let missing = root.join("no-such-dir");
    let out = fringe(&["runs", "--root", path(&missing)]);
    assert!(!out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains("no-such-dir: no such directory"),
        "{}",
        text(&out)
    );
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn export_refuses_runs_that_fail_verify_unless_asked_and_never_exports_a_record_twice() {
    let root = scratch("unverified");
    let out = root.join("dataset");
    let export = |runs: &[&Path], more: &[&str]| {
        let mut args = vec!["export"];
        args.extend(runs.iter().map(|r| path(r)));
        args.extend(["--out", path(&out)]);
        args.extend(more);
        fringe(&args)
    };
    // An edited label (the manifest no longer matches).
    let edited = write_run(&root, "run-edited", true);
    edit_line(&edited.join("frames.jsonl"), 1, |l| {
        Some(l.replace("rectangle", "pentagon"))
    });
    // Records cut from the end of a finished run.
    let truncated = write_run(&root, "run-truncated", true);
    edit_line(&truncated.join("frames.jsonl"), 2, |_| None);
    let unfinished = write_run(&root, "run-unfinished", false);
    for (run, why) in [
        (&edited, "frames.jsonl: checksum differs"),
        (&truncated, "says 3 frames"),
        (&unfinished, "did not finish"),
    ] {
        let result = export(&[run], &[]);
        let t = text(&result);
        assert!(!result.status.success(), "{t}");
        assert!(
            t.contains("fails verify") && t.contains(why) && t.contains("--allow-unverified"),
            "{t}"
        );
        assert!(!out.exists(), "a refused export writes nothing");
    }
    // Asked for: exported, with a warning and the problems in the provenance.
    let result = export(&[&edited], &["--allow-unverified"]);
    let t = text(&result);
    assert!(result.status.success(), "{t}");
    assert!(t.contains("warning") && t.contains("fails verify"), "{t}");
    let prov = std::fs::read_to_string(out.join("0.export.json")).expect("provenance");
    assert!(prov.contains("checksum differs"), "{prov}");
    std::fs::remove_dir_all(&out).expect("clean");

    // A duplicated record line: refused, and exported once when asked for.
    let doubled = write_run(&root, "run-doubled", true);
    edit_line(&doubled.join("frames.jsonl"), 1, |l| {
        Some(format!("{l}\n{l}"))
    });
    let result = export(&[&doubled], &[]);
    assert!(!result.status.success(), "{}", text(&result));
    assert!(
        text(&result).contains("has index 1, expected 2"),
        "{}",
        text(&result)
    );
    let result = export(&[&doubled], &["--allow-unverified"]);
    let t = text(&result);
    assert!(result.status.success(), "{t}");
    let csv = std::fs::read_to_string(out.join("0.labels.csv")).expect("labels");
    assert_eq!(csv.lines().count(), 1 + 2, "{csv}");
    assert!(t.contains("1 duplicated records left out"), "{t}");
    std::fs::remove_dir_all(&out).expect("clean");

    // The same run twice.
    let good = write_run(&root, "run-good", true);
    let result = export(&[&good, &good], &[]);
    assert!(!result.status.success(), "{}", text(&result));
    assert!(text(&result).contains("given twice"), "{}", text(&result));
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn a_failed_export_leaves_nothing_and_an_export_never_mixes_with_other_files() {
    let root = scratch("atomic-export");
    let run = TestRun {
        points: 4,
        ..TestRun::finished("run-a")
    }
    .write(&root.join("runs"));
    let before = snapshot(&run);
    let out = root.join("dataset");
    // A record late in the run (record 10, the eighth image exported) naming a file outside
    // it, which no export reads even when asked to export an unverified run.
    edit_line(&run.join("frames.jsonl"), 10, |l| {
        Some(l.replace("frames/00000010.fgl", "../../00000010.fgl"))
    });
    let result = fringe(&[
        "export",
        path(&run),
        "--out",
        path(&out),
        "--allow-unverified",
    ]);
    let t = text(&result);
    assert!(!result.status.success(), "{t}");
    assert!(t.contains("00000010.fgl"), "{t}");
    let left: Vec<String> = std::fs::read_dir(&root)
        .expect("root")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        left,
        vec!["runs".to_string()],
        "nothing left beside the runs"
    );
    std::fs::write(run.join("frames.jsonl"), &before["frames.jsonl"]).expect("repair");

    // Stale images of an earlier export: refused, nothing added, nothing removed.
    std::fs::create_dir_all(out.join("0.images")).expect("stale dir");
    std::fs::write(out.join("0.images/image_99.tiff"), b"stale").expect("stale");
    let result = fringe(&["export", path(&run), "--out", path(&out)]);
    let t = text(&result);
    assert!(!result.status.success(), "{t}");
    assert!(t.contains("not empty"), "{t}");
    assert_eq!(snapshot(&out).len(), 1, "{:?}", snapshot(&out).keys());

    // Into the run, or a directory inside it: refused, the run unchanged and still intact.
    for inside in [run.clone(), run.join("export"), run.join("frames")] {
        let result = fringe(&["export", path(&run), "--out", path(&inside)]);
        let t = text(&result);
        assert!(!result.status.success(), "{t}");
        assert!(t.contains("inside the run"), "{t}");
    }
    assert!(snapshot(&run) == before, "the run was changed");
    let verify = fringe(&["verify", path(&run)]);
    assert!(verify.status.success(), "{}", text(&verify));

    // What an export killed earlier left (a process that is gone) is removed by the next one.
    std::fs::remove_dir_all(&out).expect("clean");
    let stale = root.join(".dataset.partial-999999999");
    std::fs::create_dir_all(stale.join("0.images")).expect("stale partial");
    std::fs::write(stale.join("0.images/image_0.tiff"), b"half").expect("stale");

    // An empty directory is fine, and holds exactly the export afterwards.
    std::fs::create_dir(&out).expect("empty");
    let result = fringe(&["export", path(&run), "--out", path(&out)]);
    assert!(result.status.success(), "{}", text(&result));
    let files: Vec<String> = snapshot(&out).into_keys().collect();
    assert_eq!(files.len(), 8 + 2, "{files:?}");
    assert!(
        !stale.exists(),
        "the stale partial of a dead export is gone"
    );
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn records_naming_files_outside_the_run_fail_verify_and_are_never_exported() {
    let root = scratch("outside");
    let run = write_run(&root, "run-a", true);
    let frames = run.join("frames.jsonl");
    edit_line(&frames, 0, |l| {
        Some(l.replace("frames/00000000.fgl", "../../../../etc/hostname"))
    });
    edit_line(&frames, 1, |l| {
        Some(l.replace("frames/00000001.fgl", "/etc/hostname"))
    });
    // The manifest rewritten to match, as a careless or hostile edit would.
    fringe_rig::store::write_manifest(&run).expect("manifest");
    let verify = fringe(&["verify", path(&run)]);
    let t = text(&verify);
    assert!(!verify.status.success(), "{t}");
    assert!(
        t.contains("record 0: file `../../../../etc/hostname` is not a path inside the run"),
        "{t}"
    );
    assert!(
        t.contains("record 1: file `/etc/hostname` is not a path inside the run"),
        "{t}"
    );
    let out = root.join("dataset");
    let result = fringe(&[
        "export",
        path(&run),
        "--out",
        path(&out),
        "--allow-unverified",
    ]);
    let t = text(&result);
    assert!(!result.status.success(), "{t}");
    assert!(t.contains("is not a path inside the run"), "{t}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn export_progress_off_a_terminal_is_one_line_per_report() {
    let root = scratch("progress");
    // 250 points of 3 frames: 500 exported images, two progress reports.
    let run = TestRun {
        points: 250,
        ..TestRun::finished("run-long")
    }
    .write(&root);
    let out = root.join("dataset");
    let result = fringe(&["export", path(&run), "--out", path(&out)]);
    let err = String::from_utf8_lossy(&result.stderr).into_owned();
    assert!(result.status.success(), "{}", text(&result));
    assert!(!err.contains('\r'), "{err:?}");
    let reports: Vec<&str> = err.lines().filter(|l| l.contains(" images")).collect();
    assert_eq!(reports, vec!["250 images", "500 images"], "{err:?}");
    let _ = std::fs::remove_dir_all(root);
}

/// `--allow-unverified` exports every record whose frame can be read: a frame with a flipped
/// bit (found by its checksum) and a missing one are left out, each recorded in 0.export.json
/// and named once.
#[test]
fn an_unverified_export_goes_on_past_damaged_frames_and_records_them() {
    let root = scratch("damaged-frames");
    let run = TestRun {
        points: 4,
        ..TestRun::finished("run-a")
    }
    .write(&root.join("runs"));
    // Records 4 and 7 carry labels (exported images 2 and 4 of 8).
    let flipped = run.join("frames/00000004.fgl");
    let mut bytes = std::fs::read(&flipped).expect("frame");
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x08;
    std::fs::write(&flipped, bytes).expect("flip");
    std::fs::remove_file(run.join("frames/00000007.fgl")).expect("remove");
    let out = root.join("dataset");
    let refused = fringe(&["export", path(&run), "--out", path(&out)]);
    assert!(!refused.status.success(), "{}", text(&refused));
    assert!(!out.exists());
    let result = fringe(&[
        "export",
        path(&run),
        "--out",
        path(&out),
        "--allow-unverified",
    ]);
    let t = text(&result);
    assert!(result.status.success(), "{t}");
    assert!(t.contains("2 records left out"), "{t}");
    let csv = std::fs::read_to_string(out.join("0.labels.csv")).expect("labels");
    assert_eq!(csv.lines().count(), 1 + 6, "{csv}");
    assert_eq!(snapshot(&out.join("0.images")).len(), 6);
    let prov: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("0.export.json")).expect("provenance"),
    )
    .expect("json");
    assert_eq!(prov["runs"][0]["images"].as_u64(), Some(6));
    let problems: Vec<String> = prov["runs"][0]["problems"]
        .as_array()
        .expect("problems")
        .iter()
        .map(|p| p.as_str().expect("text").to_string())
        .collect();
    let left_out = |file: &str| {
        problems
            .iter()
            .find(|p| p.starts_with(&format!("{file}: ")) && p.ends_with("left out of the export"))
            .unwrap_or_else(|| panic!("{file} in {problems:?}"))
            .clone()
    };
    let damaged = left_out("frames/00000004.fgl");
    assert!(damaged.contains("checksum does not match"), "{damaged}");
    assert_eq!(damaged.matches("00000004.fgl").count(), 1, "{damaged}");
    assert!(left_out("frames/00000007.fgl").contains("missing"));
    for line in t.lines() {
        assert!(line.matches("00000004.fgl").count() <= 1, "{line}");
    }
}

/// `ln -s ../victim.txt RUN/.lock`: verify reports it, export and resume refuse it, and the
/// file it points to keeps its bytes.
#[test]
fn a_lock_that_is_a_link_is_reported_and_never_written_through() {
    let root = scratch("linked-lock");
    let (rig, _) = common::scan_files(&root);
    let plan = common::scan_plan("[11.0, 12.5, 14.0]");
    let done = write_run(&root, "run-done", true);
    let killed = TestRun {
        finish: false,
        plan: &plan,
        ..TestRun::finished("run-killed")
    }
    .write(&root);
    let victim = root.join("victim.txt");
    std::fs::write(&victim, b"the lab's notes\n").expect("victim");
    for run in [&done, &killed] {
        std::os::unix::fs::symlink("../victim.txt", run.join(".lock")).expect("link");
        let verify = fringe(&["verify", path(run)]);
        let t = text(&verify);
        assert!(!verify.status.success(), "{t}");
        assert!(t.contains(".lock: is a symbolic link"), "{t}");
    }
    let out = root.join("dataset");
    for more in [&[][..], &["--allow-unverified"][..]] {
        let mut args = vec!["export", path(&done), "--out", path(&out)];
        args.extend(more);
        let result = fringe(&args);
        let t = text(&result);
        assert!(!result.status.success(), "{t}");
        assert!(t.contains(".lock"), "{t}");
        assert!(!out.exists());
    }
    let before = snapshot(&killed);
    let resumed = common::resume(&rig, &killed);
    let t = text(&resumed);
    assert!(!resumed.status.success(), "{t}");
    assert!(t.contains(".lock") && t.contains("symbolic link"), "{t}");
    assert!(
        snapshot(&killed) == before,
        "a refused resume changed the run"
    );
    assert_eq!(
        std::fs::read(&victim).expect("victim"),
        b"the lab's notes\n",
        "the file the lock points to keeps its bytes"
    );
}

/// Verify of a run a process is writing names that process, not "did not finish".
#[test]
fn verify_of_a_run_being_written_names_its_writer() {
    use fringe_rig::store::RunWriter;
    let root = scratch("being-written");
    // The test process writes the run (a scan would), while fringe verify looks at it.
    let start = fringe_rig::store::RunReader::at(&write_run(&root, "run-template", false))
        .start()
        .expect("start");
    let writer = RunWriter::create(
        &root,
        &fringe_rig::store::StartDocument {
            run_id: "run-live".into(),
            ..start
        },
    )
    .expect("create");
    let verify = fringe(&["verify", path(writer.dir())]);
    let t = text(&verify);
    assert!(!verify.status.success(), "{t}");
    assert!(
        t.contains("being written") && t.contains(&format!("pid {}", std::process::id())),
        "{t}"
    );
    assert!(
        !t.contains("did not finish") && !t.contains("resume it"),
        "{t}"
    );
    let dir = writer.dir().to_path_buf();
    drop(writer);
    let t = text(&fringe(&["verify", path(&dir)]));
    assert!(
        t.contains("did not finish") && t.contains("--resume"),
        "{t}"
    );
}

/// Every command that writes an output refuses one inside a run before doing any work (one
/// check, `fringe_rig::store::outside_runs`): the run stays intact.
#[test]
fn outputs_inside_a_run_are_refused_by_every_command() {
    let root = scratch("outputs-inside");
    let run = write_run(&root, "run-a", true);
    let before = snapshot(&run);
    let inside = |rel: &str| run.join(rel).to_str().expect("utf-8").to_string();
    let model = root.join("no-model-needed.safetensors");
    let m = path(&model);
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "adapt".into(),
                "--model".into(),
                m.into(),
                "--out".into(),
                inside("adapted.safetensors"),
                path(&run).into(),
            ],
            "--out",
        ),
        (
            vec![
                "model".into(),
                "export".into(),
                m.into(),
                "--onnx".into(),
                inside("frames/model.onnx"),
            ],
            "--onnx",
        ),
        (
            vec![
                "model".into(),
                "pair".into(),
                m.into(),
                m.into(),
                "--out".into(),
                inside("pair"),
            ],
            "--out",
        ),
        (
            vec![
                "eval".into(),
                "--model".into(),
                m.into(),
                path(&run).into(),
                "--report".into(),
                inside("report"),
            ],
            "--report",
        ),
        (
            vec![
                "sim".into(),
                "render".into(),
                "--out".into(),
                inside("render.png"),
            ],
            "--out",
        ),
    ];
    for (args, flag) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let result = fringe(&args);
        let t = text(&result);
        assert!(!result.status.success(), "{args:?}: {t}");
        assert!(
            t.contains(&format!("{flag}: ")) && t.contains("is inside the run"),
            "{args:?}: {t}"
        );
        assert!(
            !t.contains("no-model-needed"),
            "refused before any work: {t}"
        );
    }
    assert!(snapshot(&run) == before, "the run was changed");
    let verify = fringe(&["verify", path(&run)]);
    assert!(verify.status.success(), "{}", text(&verify));
}

/// A run killed while writing its manifest, then a bit flipped in a frame: verify names the
/// frame and does not advise the resume that would write a manifest over it; the resume refuses.
#[test]
fn a_run_without_its_manifest_and_a_damaged_frame_is_not_blessed() {
    let root = scratch("no-manifest");
    let (rig, _) = common::scan_files(&root);
    let plan = common::scan_plan("[11.0, 12.5, 14.0]");
    let run = TestRun {
        plan: &plan,
        ..TestRun::finished("run-a")
    }
    .write(&root);
    std::fs::remove_file(run.join("MANIFEST.sha256")).expect("killed before the manifest");
    let frame = run.join("frames/00000001.fgl");
    let mut bytes = std::fs::read(&frame).expect("frame");
    let last = bytes.len() - 6;
    bytes[last] ^= 0x01;
    std::fs::write(&frame, bytes).expect("flip");
    let verify = fringe(&["verify", path(&run)]);
    let t = text(&verify);
    assert!(!verify.status.success(), "{t}");
    assert!(
        t.contains("frames/00000001.fgl: ") && t.contains("checksum does not match"),
        "{t}"
    );
    assert!(!t.contains("resume it to write the manifest"), "{t}");
    assert!(t.contains("mend the problems above first"), "{t}");
    let resumed = common::resume(&rig, &run);
    let t = text(&resumed);
    assert!(!resumed.status.success(), "{t}");
    assert!(t.contains("frames/00000001.fgl"), "{t}");
    assert!(
        !run.join("MANIFEST.sha256").exists(),
        "no manifest vouches for the damaged frame"
    );
}
