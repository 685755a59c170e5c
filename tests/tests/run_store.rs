//! The run store: a run written, closed and verified; a crash mid-write reopened without losing
//! or duplicating anything; damage of every kind reported by verify.

use fringe_rig::store::list_runs as list;
use fringe_rig::store::verify_run as verify;
use fringe_rig::store::{ExitStatus, FrameRecord, Position, StartDocument, StopDocument};
use fringe_rig::store::{RunFile, RunReader, RunWriter, StoreError};
use fringe_rig::ForceSample;
use fringe_rig::HostTime;
use fringe_rig::{Frame, PixelFormat};
use fringe_rig::{Millimetres, Newtons, Wrench};
use fringe_tests::snapshot;
use std::io::Write;
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fringe-store-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn start(id: &str) -> StartDocument {
    StartDocument {
        layout_version: 1,
        run_id: id.into(),
        started_utc: fringe_rig::store::now_utc(),
        software: "fringe test".into(),
        sensor_id: "layered-01".into(),
        variant: None,
        plan: "[grid]\nx = [0.0, 5.0]\n".into(),
        rig: "simulated = true\n".into(),
        calibration_profile: None,
        seed: Some(42),
        ft_axes: None,
        sync_method: "strobe".into(),
        // A run of layout 1 (before the storage was recorded): RGB8 frames in RGB PNGs.
        frames: None,
    }
}

fn frame(id: u64) -> Frame {
    Frame {
        id,
        device_timestamp: id * 20_000_000,
        host_arrival: HostTime(id * 20_000_000 + 3_000_000),
        width: 8,
        height: 4,
        format: PixelFormat::Rgb8,
        data: (0..96).map(|k| (k as u64 * 7 + id) as u8).collect(),
    }
}

fn record(index: u64, file: String, fz: f64) -> FrameRecord {
    let pos = Position {
        x: Millimetres(index as f64),
        y: Millimetres(0.0),
        z: Millimetres(5.0),
    };
    FrameRecord {
        index,
        frame_id: index,
        file,
        device_timestamp: index * 20_000_000,
        host_arrival_ns: index * 20_000_000 + 3_000_000,
        exposure: None,
        exposure_ticks: None,
        point: index / 2,
        commanded: pos,
        measured: pos,
        wrench: Some(Wrench {
            fz: Newtons(fz),
            ..Wrench::default()
        }),
        shear: None,
        shape: "pentagon".into(),
        contact: Some([index as f64, 0.0]),
        valid: true,
        notes: vec![],
    }
}

fn samples(from: u64, n: u64) -> Vec<ForceSample> {
    (from..from + n)
        .map(|k| ForceSample {
            device_tick: k,
            transport_seq: Some(k as u32),
            host_time: HostTime(k * 200_000),
            wrench: Wrench {
                fz: Newtons(-(k as f64) * 1e-3),
                ..Wrench::default()
            },
            status: 0,
            strobe: None,
        })
        .collect()
}

/// Writes `frames` frames (with force) to an open writer.
fn write_frames(w: &mut RunWriter, frames: std::ops::Range<u64>) {
    for id in frames {
        let index = w.next_index();
        let file = w.save_frame_image(&frame(id), index).expect("frame image");
        w.append_frame(&record(index, file, -(id as f64)))
            .expect("record");
        let from = w.force_samples();
        w.append_force(&samples(from, 100)).expect("force");
    }
}

fn stop(frames: u64, force: u64) -> StopDocument {
    StopDocument {
        exit_status: ExitStatus::Completed,
        reason: "all points done".into(),
        stopped_utc: fringe_rig::store::now_utc(),
        frames,
        dropped_frames: 0,
        force_samples: force,
        lost_force_samples: 0,
        points_done: frames / 2,
        sync_method: Some("strobe".into()),
        sync_error_ns: Some(57_735.0),
    }
}

fn finished_run(root: &Path, id: &str) -> PathBuf {
    let mut w = RunWriter::create(root, &start(id)).expect("create");
    w.append_event("checkpoint", Some(0), "point 0")
        .expect("event");
    write_frames(&mut w, 0..6);
    w.checkpoint().expect("checkpoint");
    w.finish(&stop(6, 600)).expect("finish")
}

#[test]
fn a_finished_run_verifies_and_is_listed() {
    let root = scratch("finished");
    let dir = finished_run(&root, "run-a");
    let report = verify(&dir).expect("verify");
    assert!(report.ok(), "{:?}", report.problems);
    assert_eq!((report.frames, report.force_samples), (6, 600));
    let (runs, unreadable) = list(&root).expect("list");
    assert!(unreadable.is_empty());
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0].frames, 6);
    assert_eq!(
        runs[0].stop.as_ref().map(|s| s.exit_status),
        Some(ExitStatus::Completed)
    );
    let err = RunWriter::create(&root, &start("run-a"))
        .err()
        .expect("an existing run id is refused");
    assert!(err.to_string().contains("exists already"), "{err}");
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn a_close_cut_before_the_manifest_is_finished_and_other_runs_are_left_alone() {
    let root = scratch("cut-close");
    let dir = finished_run(&root, "run-cut");
    let manifest = RunReader::at(&dir).path(RunFile::Manifest);
    let whole = std::fs::read(&manifest).expect("manifest");
    // Killed after the stop document, while the manifest was being hashed.
    std::fs::remove_file(&manifest).expect("remove manifest");
    let report = verify(&dir).expect("verify");
    assert!(
        report.ended
            && report.manifest_missing
            && report
                .problems
                .iter()
                .any(|p| p.contains("MANIFEST.sha256: missing") && p.contains("resuming it")),
        "{report:?}"
    );
    let stop = RunWriter::finish_cut_close(&dir)
        .expect("finish")
        .expect("the cut close");
    assert_eq!(stop.exit_status, ExitStatus::Completed);
    assert_eq!(std::fs::read(&manifest).expect("manifest again"), whole);
    assert!(verify(&dir).expect("verify").ok());
    // A whole run, or one still open (no stop document), is not touched.
    let before = snapshot(&dir);
    assert!(RunWriter::finish_cut_close(&dir).expect("whole").is_none());
    assert_eq!(snapshot(&dir), before);
    let mut open = RunWriter::create(&root, &start("run-open")).expect("create");
    write_frames(&mut open, 0..2);
    open.checkpoint().expect("checkpoint");
    let open_dir = open.dir().to_path_buf();
    let before = snapshot(&open_dir);
    assert!(RunWriter::finish_cut_close(&open_dir)
        .expect("open run")
        .is_none());
    assert_eq!(snapshot(&open_dir), before);
}

#[test]
fn a_crash_mid_write_is_reopened_without_loss_or_duplicates() {
    let root = scratch("crash");
    let mut w = RunWriter::create(&root, &start("run-b")).expect("create");
    write_frames(&mut w, 0..4);
    w.checkpoint().expect("checkpoint");
    let dir = w.dir().to_path_buf();
    drop(w); // the process dies here...
             // ...in the middle of a record and of a force sample.
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(RunReader::at(&dir).path(RunFile::Frames))
        .expect("frames");
    f.write_all(b"{\"index\":4,\"frame_id\":4,\"fi")
        .expect("torn");
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(RunReader::at(&dir).path(RunFile::Force))
        .expect("force");
    f.write_all(&[1, 2, 3, 4, 5]).expect("torn");
    let before = verify(&dir).expect("verify");
    assert!(!before.ok());
    assert!(
        before.problems.iter().any(|p| p.contains("torn")),
        "{:?}",
        before.problems
    );

    let (mut w, existing) = RunWriter::reopen(&dir).expect("reopen");
    assert_eq!(existing.frames.len(), 4);
    assert_eq!(existing.force_samples, 400);
    assert!(existing.cut_bytes >= 5);
    assert_eq!(existing.start.seed, Some(42));
    write_frames(&mut w, 4..7);
    w.finish(&stop(7, 700)).expect("finish");
    let after = verify(&dir).expect("verify");
    assert!(after.ok(), "{:?}", after.problems);
    let frames = RunReader::at(&dir).frames().expect("read");
    let ids: Vec<u64> = frames.iter().map(|f| f.frame_id).collect();
    assert_eq!(ids, (0..7).collect::<Vec<_>>());
    let err = RunWriter::reopen(&dir)
        .err()
        .expect("an ended run cannot resume");
    assert!(err.to_string().contains("has ended"), "{err}");
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn records_after_the_last_checkpoint_are_cut_on_rollback_and_on_resume() {
    let root = scratch("checkpoint");
    let mut w = RunWriter::create(&root, &start("run-c")).expect("create");
    let dir = w.dir().to_path_buf();
    // Point 0 done, checkpoint before point 1; point 1 interrupted and rolled back.
    write_frames(&mut w, 0..3);
    let c = w.checkpoint_at(1).expect("checkpoint");
    assert_eq!((c.next_point, c.next_index), (1, 3));
    write_frames(&mut w, 3..5);
    assert!(dir.join("frames/00000004.png").is_file());
    assert_eq!(w.rollback().expect("rollback"), 2);
    assert_eq!(w.next_index(), 3);
    assert!(!dir.join("frames/00000003.png").exists());
    // Point 1 again, done; checkpoint before point 2; then a crash in the middle of point 2.
    write_frames(&mut w, 5..8);
    w.checkpoint_at(2).expect("checkpoint");
    write_frames(&mut w, 8..10);
    w.checkpoint().expect("sync");
    drop(w);

    let (mut w, existing) = RunWriter::reopen(&dir).expect("reopen");
    assert_eq!(existing.checkpoint.as_ref().map(|c| c.next_point), Some(2));
    assert_eq!(existing.discarded_frames, 2);
    assert_eq!(existing.frames.len(), 6);
    assert!(
        !dir.join("frames/00000006.png").exists(),
        "images of cut records removed"
    );
    write_frames(&mut w, 10..12);
    w.finish(&stop(8, 1200)).expect("finish");
    let frames = RunReader::at(&dir).frames().expect("read");
    // Each record carries Fz = -(frame written); the cut ones are gone, nothing twice.
    let written: Vec<f64> = frames
        .iter()
        .filter_map(|f| f.wrench.map(|w| -w.fz.0))
        .collect();
    assert_eq!(written, vec![0.0, 1.0, 2.0, 5.0, 6.0, 7.0, 10.0, 11.0]);
    let indices: Vec<u64> = frames.iter().map(|f| f.index).collect();
    assert_eq!(indices, (0..8).collect::<Vec<_>>());
    let report = verify(&dir).expect("verify");
    assert!(report.ok(), "{:?}", report.problems);
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn damage_of_every_kind_is_reported() {
    let root = scratch("damage");
    let dir = finished_run(&root, "run-c");
    // A frame changed, another deleted, a stray file, a truncated force log.
    let png = dir.join("frames/00000001.png");
    let mut bytes = std::fs::read(&png).expect("png");
    let last = bytes.len() - 1;
    bytes[last] ^= 0xff;
    std::fs::write(&png, bytes).expect("write");
    std::fs::remove_file(dir.join("frames/00000003.png")).expect("remove");
    std::fs::write(dir.join("notes.txt"), "added later").expect("stray");
    let force = RunReader::at(&dir).path(RunFile::Force);
    let len = std::fs::metadata(&force).expect("meta").len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&force)
        .and_then(|f| f.set_len(len - 80))
        .expect("truncate");
    let report = verify(&dir).expect("verify");
    let all = report.problems.join("\n");
    assert!(
        all.contains("frames/00000001.png: checksum differs"),
        "{all}"
    );
    assert!(
        all.contains("frames/00000003.png: frame of record 3 is missing"),
        "{all}"
    );
    assert!(all.contains("notes.txt: not listed"), "{all}");
    assert!(
        all.contains("says 600 force samples, force.bin holds 599"),
        "{all}"
    );
    assert!(all.contains("force.bin: checksum differs"), "{all}");
    // Not a run at all: a clear error naming the file.
    let err = verify(&root).expect_err("not a run");
    assert!(err.to_string().contains("start.json"), "{err}");
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn an_interrupted_export_removes_what_it_wrote() {
    use fringe_rig::store::{export_reference, ExportOptions};
    static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);
    let root = scratch("export-interrupted");
    let run = finished_run(&root, "run-x");
    let out = root.join("exported");
    let options = ExportOptions {
        cancel: Some(&INTERRUPTED),
        ..ExportOptions::default()
    };
    let e = export_reference(std::slice::from_ref(&run), &out, &options, |_| {})
        .expect_err("interrupted");
    assert!(e.to_string().contains("interrupted"), "{e}");
    let left: Vec<String> = std::fs::read_dir(&root)
        .expect("root")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, vec!["run-x".to_string()], "nothing beside the run");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn frames_of_another_size_than_the_runs_fail_verify() {
    let root = scratch("two-sizes");
    let mut w = RunWriter::create(&root, &start("run-sizes")).expect("create");
    write_frames(&mut w, 0..3);
    // Then frames from another camera size (a resume on another rig, as it was possible).
    for id in 3..5 {
        let index = w.next_index();
        let small = Frame {
            width: 4,
            height: 2,
            data: vec![9; 24],
            ..frame(id)
        };
        let file = w.save_frame_image(&small, index).expect("frame image");
        w.append_frame(&record(index, file, -1.0)).expect("record");
    }
    w.checkpoint().expect("checkpoint");
    let dir = w.finish(&stop(5, 300)).expect("finish");
    let report = verify(&dir).expect("verify");
    let sized: Vec<&String> = report
        .problems
        .iter()
        .filter(|p| p.contains("4x2 px, where the run's frames are 8x4 px"))
        .collect();
    assert_eq!(sized.len(), 2, "{:?}", report.problems);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_refused_or_damaged_resume_leaves_the_run_as_it_was() {
    let root = scratch("refused");
    let mut w = RunWriter::create(&root, &start("run-d")).expect("create");
    let dir = w.dir().to_path_buf();
    // Point 0 done (3 records), checkpoint before point 1, a crash during point 1.
    write_frames(&mut w, 0..3);
    w.checkpoint_at(1).expect("checkpoint");
    write_frames(&mut w, 3..5);
    w.checkpoint().expect("sync");
    drop(w);
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(RunReader::at(&dir).path(RunFile::Frames))
        .expect("frames");
    f.write_all(b"{\"index\":5,").expect("torn");

    // Refused by the caller (a different plan, say): nothing cut, no frame removed.
    let before = snapshot(&dir);
    let refused = RunWriter::reopen_if(&dir, |existing| {
        assert_eq!(existing.discarded_frames, 2);
        Err(StoreError::Content {
            path: dir.clone(),
            message: "refused".into(),
        })
    });
    assert!(refused.is_err());
    assert!(snapshot(&dir) == before, "a refused reopen changed the run");

    // frames.jsonl cut inside the records the checkpoint counts: refused, nothing changed,
    // and verify says so.
    let frames = RunReader::at(&dir).path(RunFile::Frames);
    let text = std::fs::read_to_string(&frames).expect("frames");
    let first = text.find('\n').expect("a line") + 1;
    std::fs::write(&frames, &text[..first + 30]).expect("cut");
    let before = snapshot(&dir);
    let err = RunWriter::reopen(&dir).err().expect("refused");
    assert!(
        err.to_string()
            .contains("holds 1 records but checkpoint.json counts 3 before point 1"),
        "{err}"
    );
    assert!(snapshot(&dir) == before, "a refused reopen changed the run");
    let report = verify(&dir).expect("verify");
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.contains("records of finished points are missing")),
        "{:?}",
        report.problems
    );

    // The same number of records, one of them changed before the checkpoint: refused too.
    let edited = text.replacen("\"frame_id\":1,", "\"frame_id\":11,", 1);
    std::fs::write(&frames, &edited).expect("edit");
    let err = RunWriter::reopen(&dir).err().expect("refused");
    assert!(err.to_string().contains("were changed"), "{err}");
    let _ = std::fs::remove_dir_all(root);
}

/// A run of `frames` BayerRG8 8x4 frames, stored as `start` says; its directory.
fn bayer_run(root: &Path, start: &StartDocument) -> PathBuf {
    let mut w = RunWriter::create(root, start).expect("create");
    for id in 0..4 {
        let index = w.next_index();
        let mosaic = Frame {
            format: PixelFormat::BayerRg8,
            data: (0..32).map(|k| (k as u64 * 13 + 5 * id) as u8).collect(),
            ..frame(id)
        };
        let file = w.save_frame_image(&mosaic, index).expect("frame image");
        w.append_frame(&record(index, file, -2.0)).expect("record");
        let from = w.force_samples();
        w.append_force(&samples(from, 100)).expect("force");
    }
    w.checkpoint().expect("checkpoint");
    w.finish(&stop(4, 400)).expect("finish")
}

/// The mosaic `bayer_run` wrote as frame `id`.
fn mosaic_of(id: u64) -> Vec<u8> {
    (0..32).map(|k| (k as u64 * 13 + 5 * id) as u8).collect()
}

#[test]
fn bayer_runs_old_and_new_read_and_export_the_mosaic_the_camera_gave() {
    use fringe_rig::store;
    use fringe_rig::store::{export_reference, ExportOptions};
    use fringe_rig::store::{Encoding, FrameStorage};
    let root = scratch("bayer-layouts");
    // Layout 1: the mosaic as it is in a grey PNG, known as Bayer from the rig text only.
    let old = StartDocument {
        rig: "[camera]\npixel_format = \"bayerrg8\"\n".into(),
        ..start("run-old")
    };
    // Layout 2: the storage recorded, the mosaic as colour planes (what `[recording] codec =
    // "png"` still writes).
    let planes = StartDocument {
        layout_version: 2,
        frames: Some(
            FrameStorage::new(PixelFormat::BayerRg8, None)
                .and_then(|s| s.with_codec(Some(fringe_rig::store::FrameCodec::Png)))
                .expect("storage"),
        ),
        ..start("run-planes")
    };
    // Layout 3: the mosaic in FGL, the default.
    let fgl = StartDocument {
        layout_version: fringe_rig::store::LAYOUT_VERSION,
        frames: Some(FrameStorage::new(PixelFormat::BayerRg8, None).expect("storage")),
        ..start("run-fgl")
    };
    for (start, encoding) in [
        (old, Encoding::Png),
        (planes, Encoding::PngBayerPlanes),
        (fgl, Encoding::Fgl),
    ] {
        let dir = bayer_run(&root, &start);
        let report = verify(&dir).expect("verify");
        assert!(report.ok(), "{:?}", report.problems);
        let storage = RunReader::at(&dir).start().expect("start").frame_storage();
        assert_eq!(
            (storage.pixel_format, storage.encoding),
            (PixelFormat::BayerRg8, encoding)
        );
        let records = RunReader::at(&dir).frames().expect("records");
        for r in &records {
            let stored = storage.read(&r.file_in(&dir).expect("file")).expect("read");
            assert_eq!(stored.data, mosaic_of(r.frame_id), "{}", r.file);
        }
        // The reference layout gets RGB, demosaiced by the one documented demosaicing.
        let out = root.join(format!("export-{}", start.run_id));
        export_reference(
            std::slice::from_ref(&dir),
            &out,
            &ExportOptions::default(),
            |_| {},
        )
        .expect("export");
        for (k, r) in records.iter().enumerate() {
            let tiff = image::open(out.join("0.images").join(format!("image_{k}.tiff")))
                .expect("exported image");
            let rgb = tiff.as_rgb8().expect("an RGB image");
            assert_eq!(
                rgb.as_raw(),
                &store::to_rgb8(&mosaic_of(r.frame_id), 8, 4),
                "image_{k}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// Exports compress their TIFF images (deflate by default, LZW, or none) and every one reads
/// back as the same pixels in the paper's code's reader, PIL; the estimate before an export
/// counts its images and measures its bytes from the run's own frames.
#[test]
fn compressed_exports_read_back_the_same_pixels_in_pil() {
    use fringe_rig::store;
    use fringe_rig::store::FrameStorage;
    use fringe_rig::store::{estimate_export, export_reference, ExportOptions, ImageCompression};
    fringe_tests::require_python_module("PIL");
    let root = scratch("compressed-export");
    let run = bayer_run(
        &root,
        &StartDocument {
            layout_version: fringe_rig::store::LAYOUT_VERSION,
            frames: Some(FrameStorage::new(PixelFormat::BayerRg8, None).expect("storage")),
            ..start("run-tiff")
        },
    );
    let records = RunReader::at(&run).frames().expect("records");
    for compression in [
        ImageCompression::Deflate,
        ImageCompression::Lzw,
        ImageCompression::None,
    ] {
        let out = root.join(format!("export-{}", compression.name()));
        let options = ExportOptions {
            compression,
            ..ExportOptions::default()
        };
        let estimate = estimate_export(std::slice::from_ref(&run), &options).expect("estimate");
        assert_eq!((estimate.images, estimate.sampled), (4, 4), "{estimate:?}");
        export_reference(std::slice::from_ref(&run), &out, &options, |_| {}).expect("export");
        let images = out.join("0.images");
        let written: u64 = (0..4)
            .map(|k| {
                std::fs::metadata(images.join(format!("image_{k}.tiff")))
                    .expect("image")
                    .len()
            })
            .sum();
        assert_eq!(
            estimate.bytes,
            written + 4 * 90,
            "{}: the sampled images are all the images",
            compression.name()
        );
        // The compression tag: 8 (Adobe deflate), 5 (LZW), 1 (none), as PIL reports it.
        let script = "import sys\nfrom PIL import Image\nfor p in sys.argv[1:]:\n    im = Image.open(p)\n    sys.stdout.write(im.info.get('compression', 'raw') + ' ' + im.convert('RGB').tobytes().hex() + '\\n')\n";
        let out = std::process::Command::new(fringe_tests::python())
            .arg("-c")
            .arg(script)
            .args((0..4).map(|k| images.join(format!("image_{k}.tiff"))))
            .output()
            .expect("python");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let lines = String::from_utf8(out.stdout).expect("utf-8");
        let want = match compression {
            ImageCompression::Deflate => "tiff_adobe_deflate",
            ImageCompression::Lzw => "tiff_lzw",
            ImageCompression::None => "raw",
        };
        for (k, (line, r)) in lines.lines().zip(&records).enumerate() {
            let (tag, hex) = line.split_once(' ').expect("tag and pixels");
            assert_eq!(tag, want, "image_{k}");
            let rgb = store::to_rgb8(&mosaic_of(r.frame_id), 8, 4);
            let hex_want: String = rgb.iter().map(|b| format!("{b:02x}")).collect();
            assert_eq!(hex, hex_want, "image_{k} ({want}) read by PIL");
        }
        assert_eq!(lines.lines().count(), 4);
    }
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_run_of_a_newer_layout_is_refused_naming_the_versions() {
    let root = scratch("newer-layout");
    let dir = finished_run(&root, "run-future");
    let start_path = RunReader::at(&dir).path(RunFile::Start);
    let text = std::fs::read_to_string(&start_path).expect("start");
    let future = text.replace("\"layout_version\": 1", "\"layout_version\": 99");
    assert_ne!(future, text, "the start document names its layout version");
    std::fs::write(&start_path, future).expect("write");
    let e = RunReader::at(&dir).start().expect_err("newer layout");
    assert!(
        e.to_string().contains("layout version 99") && e.to_string().contains("newer fringe"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Which sensor design a run was recorded on decides which model may read it: runs record it
/// since layout 2 gained `variant`; older runs still say it, through their rig text.
#[test]
fn a_runs_sensor_design_is_read_from_new_and_old_runs() {
    let root = scratch("design");
    // Written before the design was recorded: the simulated camera's line in the rig text.
    let old_simulated = StartDocument {
        rig: "[sim]\nsensor = \"integrated\"\n\n# devices:\n# camera: simulated 480x300 (frame rate as the camera is configured), sensor layered-01 (integrated)".into(),
        ..start("old-sim")
    };
    // ... or the rig file's own `variant` key (real hardware).
    let old_real = StartDocument {
        rig: "variant = \"layered\"\nsensor = \"layered-01\"\n".into(),
        ..start("old-real")
    };
    let recorded = StartDocument {
        layout_version: fringe_rig::store::LAYOUT_VERSION,
        variant: Some("integrated".into()),
        ..start("recorded")
    };
    let unknown = start("unknown");
    for (doc, want) in [
        (old_simulated, Some("integrated")),
        (old_real, Some("layered")),
        (recorded, Some("integrated")),
        (unknown, None),
    ] {
        let mut w = RunWriter::create(&root, &doc).expect("create");
        write_frames(&mut w, 0..2);
        let dir = w.finish(&stop(2, 0)).expect("finish");
        let back = RunReader::at(&dir).start().expect("start");
        assert_eq!(back.sensor_variant().as_deref(), want, "{}", doc.run_id);
    }
    std::fs::remove_dir_all(&root).ok();
}

/// A `.lock` planted as a link to a file outside the run: verify reports it, a writer (a resume)
/// and a reader (an export) are refused without writing through it, and the file it points to
/// keeps its bytes.
#[test]
fn a_lock_that_is_a_link_is_reported_refused_and_never_written_through() {
    use fringe_rig::store::{export_reference, ExportOptions};
    let root = scratch("linked-lock");
    let finished = finished_run(&root, "run-done");
    let mut open = RunWriter::create(&root, &start("run-open")).expect("create");
    write_frames(&mut open, 0..2);
    open.checkpoint().expect("checkpoint");
    let unfinished = open.dir().to_path_buf();
    drop(open);
    let victim = root.join("victim.txt");
    std::fs::write(&victim, b"the lab's notes").expect("victim");
    for run in [&finished, &unfinished] {
        std::os::unix::fs::symlink("../victim.txt", run.join(".lock")).expect("link");
        let report = verify(run).expect("verify");
        assert!(
            report
                .problems
                .iter()
                .any(|p| p.starts_with(".lock: is a symbolic link")),
            "{:?}",
            report.problems
        );
    }
    let e = export_reference(
        std::slice::from_ref(&finished),
        &root.join("dataset"),
        &ExportOptions {
            allow_unverified: true,
            ..ExportOptions::default()
        },
        |_| {},
    )
    .expect_err("an export through the link");
    assert!(e.to_string().contains(".lock"), "{e}");
    assert!(!root.join("dataset").exists());
    let e = RunWriter::reopen(&unfinished)
        .err()
        .expect("a resume through the link");
    assert!(
        e.to_string().contains(".lock") && e.to_string().contains("symbolic link"),
        "{e}"
    );
    assert!(RunWriter::finish_cut_close(&finished)
        .expect("whole")
        .is_none());
    assert_eq!(
        std::fs::read(&victim).expect("victim"),
        b"the lab's notes",
        "the file the lock points to keeps its bytes"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// A run of FGL frames (the default) stopped before its manifest: a bit flipped in a frame is
/// found by the frame's own checksum; verify names the file and the manifest is not written over
/// it until the frame is whole again.
#[test]
fn a_flipped_bit_in_a_frame_is_found_and_no_manifest_is_written_over_it() {
    use fringe_rig::store::FrameStorage;
    let root = scratch("flipped-frame");
    let fgl = StartDocument {
        layout_version: fringe_rig::store::LAYOUT_VERSION,
        frames: Some(FrameStorage::new(PixelFormat::BayerRg8, None).expect("storage")),
        ..start("run-fgl")
    };
    let dir = bayer_run(&root, &fgl);
    let manifest = RunReader::at(&dir).path(RunFile::Manifest);
    std::fs::remove_file(&manifest).expect("killed before the manifest");
    assert_eq!(
        verify(&dir).expect("verify").problems.len(),
        1,
        "only the manifest"
    );
    let frame = dir.join("frames/00000002.fgl");
    let whole = std::fs::read(&frame).expect("frame");
    let mut flipped = whole.clone();
    flipped[whole.len() - 9] ^= 0x20;
    std::fs::write(&frame, &flipped).expect("flip");
    let report = verify(&dir).expect("verify");
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.starts_with("frames/00000002.fgl: ")
                && p.contains("checksum does not match")
                && p.contains("record 2")),
        "{:?}",
        report.problems
    );
    let e = RunWriter::finish_cut_close(&dir).expect_err("a manifest over a damaged frame");
    assert!(
        e.to_string().contains("frames/00000002.fgl") && e.to_string().contains("restore"),
        "{e}"
    );
    assert!(
        !manifest.exists(),
        "no manifest vouches for the damaged frame"
    );
    std::fs::write(&frame, &whole).expect("restored");
    RunWriter::finish_cut_close(&dir)
        .expect("the frames are whole")
        .expect("the cut close");
    assert!(verify(&dir).expect("verify").ok());
    let _ = std::fs::remove_dir_all(&root);
}

/// A resume would write the run's manifest at its end: a damaged frame of an unfinished run is
/// refused before anything is changed.
#[test]
fn a_resume_over_a_damaged_frame_is_refused_and_changes_nothing() {
    use fringe_rig::store::FrameStorage;
    let root = scratch("resume-damaged");
    let fgl = StartDocument {
        layout_version: fringe_rig::store::LAYOUT_VERSION,
        frames: Some(FrameStorage::new(PixelFormat::Mono8, None).expect("storage")),
        ..start("run-fgl")
    };
    let mut w = RunWriter::create(&root, &fgl).expect("create");
    for id in 0..3 {
        let index = w.next_index();
        let mono = Frame {
            format: PixelFormat::Mono8,
            data: (0..32).map(|k| (k * 3 + id) as u8).collect(),
            ..frame(id)
        };
        let file = w.save_frame_image(&mono, index).expect("frame image");
        w.append_frame(&record(index, file, -1.0)).expect("record");
    }
    w.checkpoint_at(1).expect("checkpoint");
    let dir = w.dir().to_path_buf();
    drop(w);
    let frame_path = dir.join("frames/00000001.fgl");
    let mut bytes = std::fs::read(&frame_path).expect("frame");
    bytes[20] ^= 0x01;
    std::fs::write(&frame_path, &bytes).expect("flip");
    let report = verify(&dir).expect("verify");
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.starts_with("frames/00000001.fgl: ") && p.contains("checksum")),
        "{:?}",
        report.problems
    );
    let before = snapshot(&dir);
    let e = RunWriter::reopen(&dir).err().expect("refused");
    assert!(e.to_string().contains("frames/00000001.fgl"), "{e}");
    assert!(snapshot(&dir) == before, "a refused resume changed the run");
    let _ = std::fs::remove_dir_all(&root);
}

/// Two records naming one frame file (an edit, the manifest rewritten to match): verify says so.
#[test]
fn two_records_naming_one_frame_file_fail_verify() {
    let root = scratch("shared-frame");
    let dir = finished_run(&root, "run-shared");
    let frames = RunReader::at(&dir).path(RunFile::Frames);
    let text = std::fs::read_to_string(&frames).expect("frames");
    let edited = text.replacen("frames/00000004.png", "frames/00000003.png", 1);
    assert_ne!(edited, text);
    std::fs::write(&frames, edited).expect("edit");
    std::fs::remove_file(dir.join("frames/00000004.png")).expect("remove");
    fringe_rig::store::write_manifest(&dir).expect("manifest rewritten");
    let report = verify(&dir).expect("verify");
    assert_eq!(
        report.problems,
        vec![
            "frames/00000003.png: named by record 3 and again by record 4: each frame file \
             belongs to one record (an edited frames.jsonl; an export would give both records \
             the same image)"
                .to_string()
        ]
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Verify of a run that a process is writing names the writer, and says "did not finish" only
/// once no process writes it.
#[test]
fn verify_names_the_process_writing_the_run() {
    let root = scratch("being-written");
    let mut w = RunWriter::create(&root, &start("run-live")).expect("create");
    write_frames(&mut w, 0..2);
    w.checkpoint().expect("checkpoint");
    let dir = w.dir().to_path_buf();
    let report = verify(&dir).expect("verify");
    let pid = format!("pid {}", std::process::id());
    assert!(
        report.writer.as_deref().is_some_and(|h| h.contains(&pid)),
        "{report:?}"
    );
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.contains("being written") && p.contains(&pid)),
        "{:?}",
        report.problems
    );
    assert!(!report.problems.iter().any(|p| p.contains("did not finish")));
    drop(w);
    let report = verify(&dir).expect("verify");
    assert_eq!(report.writer, None);
    assert!(
        report.problems.iter().any(|p| p.contains("did not finish")),
        "{:?}",
        report.problems
    );
    let _ = std::fs::remove_dir_all(&root);
}
