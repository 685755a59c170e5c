//! `fringe check`'s bad input, refused before anything moves: no certificate, another unit,
//! certificates of another sensor or a newer format, a damaged history. (Checks of a
//! commissioned unit, ok and with its F/T zero moved, are in `commission_cli.rs`: they check the
//! unit that test commissions, which takes minutes of simulated bench time to make.)

mod common;
use common::{arg, refused_in, scratch, unit_rig_at};

#[test]
fn bad_input_is_refused_before_anything_moves() {
    let dir = scratch("check-bad");
    let rig = unit_rig_at(&dir, 0.5);
    let profiles = dir.join("profiles");
    let run = |extra: &[&str]| {
        let mut args = vec!["check", "--rig", arg(&rig), "--yes"];
        args.extend_from_slice(extra);
        refused_in(&dir, &args)
    };
    // No certificate: commission it first, naming where certificates are looked for.
    let t = run(&[]);
    assert!(t.contains("no certificate of sensor layered-3"), "{t}");
    assert!(
        t.contains(arg(&profiles)) && t.contains("fringe commission"),
        "{t}"
    );
    // Another unit than the one under the camera.
    let t = run(&["--sensor", "layered-9"]);
    assert!(t.contains("the rig's sensor is layered-3"), "{t}");
    // A certificate of another sensor in this unit's name, and one of a newer format: both
    // named and passed over.
    let other = profiles.join("layered-3.commission-2026-01-01T00-00-00Z");
    std::fs::create_dir_all(&other).expect("dir");
    std::fs::write(other.join("certificate.json"), certificate_of("layered-7")).expect("cert");
    let newer = profiles.join("layered-3.commission-2026-02-01T00-00-00Z");
    std::fs::create_dir_all(&newer).expect("dir");
    std::fs::write(newer.join("certificate.json"), "{\"format\": 99}").expect("cert");
    let t = run(&[]);
    assert!(
        t.contains("its certificate is of sensor layered-7, not layered-3"),
        "{t}"
    );
    assert!(t.contains("certificate format 99 is newer"), "{t}");
    assert!(t.contains("no certificate of sensor layered-3"), "{t}");
    // A passing certificate of this unit whose acceptance run is gone: found before anything
    // is pressed, naming the run.
    let gone = profiles.join("layered-3.commission-2026-03-01T00-00-00Z");
    std::fs::create_dir_all(gone.join("runs/calibration")).expect("dir");
    std::fs::write(gone.join("runs/calibration/start.json"), "{}").expect("start");
    std::fs::write(gone.join("certificate.json"), certificate_of("layered-3")).expect("cert");
    std::fs::write(gone.join("model.safetensors"), "").expect("model");
    let t = run(&[]);
    assert!(
        t.contains("the commissioning's acceptance scan")
            && t.contains("runs/acceptance is missing")
            && t.contains("nothing is pressed"),
        "{t}"
    );
    std::fs::remove_dir_all(&gone).expect("remove");
    // A damaged history is reported, not fatal.
    std::fs::write(
        profiles.join("layered-3.health.jsonl"),
        "{\"format\":1,\"che\n",
    )
    .expect("h");
    let t = run(&["--history"]);
    assert!(t.contains("layered-3.health.jsonl:1: damaged entry"), "{t}");
    assert!(t.contains("no checks of sensor layered-3 yet"), "{t}");
    // Nothing was pressed.
    assert!(!dir.join("runs").exists());
}

/// A passing certificate (format 1) of `sensor`.
fn certificate_of(sensor: &str) -> String {
    serde_json::json!({
        "format": 1,
        "fringe_version": "0.1.0",
        "issued_utc": "2026-01-01T00:00:00Z",
        "sensor_id": sensor,
        "variant": "layered",
        "pass": true,
        "failures": [],
        "figures": {"fz_rmse_n": 0.3, "contact_rmse_mm": 1.0, "shape_accuracy": 0.99,
                    "macro_f1": 0.99, "frames": 100, "presses": 6},
        "verdict": {},
        "spec": {},
        "spec_origin": "test",
        "base_model": {"path": "default", "sha256": "0", "describe": "test"},
        "model": "model.safetensors",
        "adaptation": "heads",
        "profile": "profile.toml",
        "runs": {"calibration": "runs/calibration", "rounds": [], "acceptance": "runs/acceptance"},
        "learning_curve": [],
        "bench_s": 1.0,
        "compute_s": 1.0
    })
    .to_string()
}
