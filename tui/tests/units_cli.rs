//! Units by name: `fringe units` lists every unit known with its certificate, next check and the
//! model `validate` runs for it; `--unit FILE|ID` puts a unit on the simulated bench, and an
//! unknown one is refused naming the units known. (A unit commissioned and checked for real is
//! listed in `commission_cli.rs`, which makes one.)

mod common;
use common::{arg, fringe, refused_in, scratch, text, unit_rig_at};

/// A certificate (format 1) of `sensor`, passing or not, issued at `utc`.
fn certificate(sensor: &str, pass: bool, utc: &str) -> String {
    serde_json::json!({
        "format": 1, "fringe_version": "0.1.0", "issued_utc": utc, "sensor_id": sensor,
        "variant": "layered", "pass": pass, "failures": [],
        "figures": {"fz_rmse_n": 0.31, "contact_rmse_mm": 1.02, "shape_accuracy": 0.985,
                    "macro_f1": 0.99, "frames": 100, "presses": 6},
        "verdict": {}, "spec": {}, "spec_origin": "paper",
        "base_model": {"path": "default", "sha256": "0", "describe": "test"},
        "model": "model.safetensors", "adaptation": "heads", "profile": "profile.toml",
        "runs": {"calibration": "runs/calibration", "rounds": [], "acceptance": "runs/acceptance"},
        "learning_curve": [], "bench_s": 1.0, "compute_s": 1.0
    })
    .to_string()
}

#[test]
fn every_unit_is_listed_with_its_certificate_next_check_and_model() {
    let dir = scratch("units-list");
    let rig = unit_rig_at(&dir, 0.5);
    let profiles = dir.join("profiles");
    let passed = profiles.join("layered-3.commission-2026-12-01T09-00-00Z");
    std::fs::create_dir_all(&passed).expect("dir");
    std::fs::write(
        passed.join("certificate.json"),
        certificate("layered-3", true, "2026-12-01T09:30:00.000Z"),
    )
    .expect("cert");
    std::fs::write(passed.join("model.safetensors"), "").expect("model");
    // A later commissioning of another unit that failed: listed, its model not used.
    let failed = profiles.join("layered-2.commission-2026-12-02T09-00-00Z");
    std::fs::create_dir_all(&failed).expect("dir");
    std::fs::write(
        failed.join("certificate.json"),
        certificate("layered-2", false, "2026-12-02T10:00:00.000Z"),
    )
    .expect("cert");
    let o = fringe(&["units", "--rig", arg(&rig)]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let block = |id: &str| -> String {
        t.split("\n\n")
            .find(|b| b.starts_with(&format!("{id} (")))
            .unwrap_or_else(|| panic!("no {id}: {t}"))
            .to_string()
    };
    let l3 = block("layered-3");
    assert!(l3.contains("on the rig"), "{l3}");
    assert!(
        l3.contains("certificate:   PASS 2026-12-01 09:30 UTC against paper"),
        "{l3}"
    );
    assert!(l3.contains("next check:    2026-12-08"), "{l3}");
    assert!(
        l3.contains("validate uses: its commissioned model")
            && l3.contains("layered-3.commission-2026-12-01T09-00-00Z/model.safetensors"),
        "{l3}"
    );
    let l2 = block("layered-2");
    assert!(
        l2.contains("certificate:   FAIL 2026-12-02 10:00 UTC"),
        "{l2}"
    );
    assert!(l2.contains("none: commission the unit first"), "{l2}");
    assert!(
        l2.contains("validate uses: builtin:layered-two-stage"),
        "{l2}"
    );
    // The simulated bench's other units are listed too.
    assert!(
        block("integrated-2").contains("integrated, simulated"),
        "{t}"
    );

    // A unit named by its certificate is that unit; on the simulated bench by id, the bench
    // carries it (a dry run says so and moves nothing).
    let o = fringe(&[
        "commission",
        "--rig",
        arg(&rig),
        "--unit",
        arg(&passed.join("certificate.json")),
        "--dry-run",
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("commissioning of sensor layered-3"), "{t}");
    let o = fringe(&[
        "commission",
        "--rig",
        arg(&rig),
        "--unit",
        "layered-2",
        "--dry-run",
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("commissioning of sensor layered-2"), "{t}");
    // An unknown unit is refused, naming the units known.
    let t = refused_in(
        &dir,
        &["check", "--rig", arg(&rig), "--unit", "layered-9", "--yes"],
    );
    assert!(
        t.contains("unit layered-9 is not known here")
            && t.contains("the rig's sensor is layered-3")
            && t.contains("integrated-1, integrated-2"),
        "{t}"
    );
    assert!(!dir.join("runs").exists());
}
