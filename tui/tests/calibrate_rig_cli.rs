//! `fringe calibrate --sensor ID` on the simulated bench: the calibration scan and the profile
//! from it. In a file of its own so that no other test shares the cores with its scan.

mod common;
use common::{fringe, label_rms, scratch, text};
use fringe_calibration::Profile;

/// `fringe calibrate --sensor ID` on the default simulated bench (its camera at 25 fps: at 50 fps a
/// debug build on 2 cores drops full-size frames under any load, and a point interrupted three
/// times ends the scan; the geometry is the default bench's): the calibration scan,
/// then a profile whose optics, registration and force offsets match the simulator's truth
/// (layered sensor: optical centre (990, 600) px, radius 490 px, 18.3 px/mm, rotation 0,
/// mirrored; the stage over the sensor centre at the bench geometry's x/y centre), the report
/// images, the run of the scan kept, every frame of it labelled.
#[test]
fn calibrates_the_simulated_bench_from_a_calibration_scan() {
    let root = scratch("rig");
    let out = root.join("profiles");
    let runs = root.join("runs");
    let rig = root.join("rig.toml");
    std::fs::write(&rig, "[camera]\nframe_rate = 25.0\n").expect("rig file");
    let o = fringe(&[
        "calibrate",
        "--rig",
        rig.to_str().expect("utf-8"),
        "--sensor",
        "layered-1",
        "--out",
        out.to_str().expect("utf-8"),
        "--runs",
        runs.to_str().expect("utf-8"),
        "--yes",
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("9 presses"), "{t}");
    let config =
        fringe_app::rig::sim_config(&fringe_app::RigConfig::simulated()).expect("sim config");
    let g = config.sensor.geometry();
    let b = &config.bench.geometry;
    let p = Profile::load(&out.join("layered-1.toml")).expect("profile");
    assert!(
        (p.optical.centre_x_px - g.centre_px[0]).abs() < 0.5,
        "{p:?}"
    );
    assert!(
        (p.optical.centre_y_px - g.centre_px[1]).abs() < 0.5,
        "{p:?}"
    );
    assert!(
        (p.optical.radius_px - config.sensor.geometry.disc_radius_px).abs() < 1.0,
        "{p:?}"
    );
    let r = p
        .registration
        .as_ref()
        .expect("registration in the profile");
    assert!(
        (r.px_per_mm / g.px_per_mm - 1.0).abs() < 0.005,
        "px/mm {} vs {}: {t}",
        r.px_per_mm,
        g.px_per_mm
    );
    assert!((r.rotation_deg - g.rotation_deg).abs() < 0.2, "{r:?}: {t}");
    assert_eq!(r.mirror, g.mirror);
    assert!(
        (r.contact_origin_stage_mm[0] - b.x_centre_mm).abs() < 0.05
            && (r.contact_origin_stage_mm[1] - b.y_centre_mm).abs() < 0.05,
        "origin {:?} vs ({}, {})",
        r.contact_origin_stage_mm,
        b.x_centre_mm,
        b.y_centre_mm
    );
    assert_eq!(r.presses + r.outliers, 9, "{r:?}");
    let offsets = p
        .force_offsets
        .as_ref()
        .expect("force offsets in the profile");
    assert!(offsets.samples >= 400, "{offsets:?}");
    // The profile names the run it came from, and the run is there.
    assert!(p.source.contains("calibration-layered-1"), "{}", p.source);
    assert!(std::path::Path::new(&p.source).join("start.json").is_file());
    for report in [
        "layered-1.png",
        "layered-1-registration.png",
        "layered-1-contact.png",
    ] {
        let img = image::open(out.join(report)).expect(report);
        assert!(img.width() > 100 && img.height() > 100, "{report}");
    }
    assert!(t.contains("mirror right"), "{t}");
    // Every frame of the calibration scan got the force of its own exposure: none left
    // without a label (frames delivered late by the renderer once went unmatched for seconds),
    // and the labels agree with the simulator's truth.
    let frames = std::fs::read_to_string(std::path::Path::new(&p.source).join("frames.jsonl"))
        .expect("frames.jsonl");
    let unlabelled: Vec<&str> = frames
        .lines()
        .filter(|l| l.contains("\"wrench\":null"))
        .collect();
    assert!(
        unlabelled.is_empty(),
        "{} of {} frames unlabelled, first: {}",
        unlabelled.len(),
        frames.lines().count(),
        unlabelled[0]
    );
    let rms = label_rms(&t);
    assert!(rms < 0.05, "label force RMS {rms} N against truth: {t}");
    std::fs::remove_dir_all(&root).ok();
}
