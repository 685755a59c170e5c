//! `fringe check` on a commissioned simulated unit (`layered-3`, at half the frame size, quick
//! axes): unchanged, it checks ok; with its F/T zero moved by 0.1 N it is told to calibrate again
//! with the evidence; the history keeps both and plots them. Bad input is refused before anything
//! moves: no certificate, another unit, certificates of another sensor or a newer format, a
//! damaged history.

mod common;
use common::{
    arg, fringe, fringe_command, quick_commission, refused_in, scratch, text, unit_rig_at,
};
use std::path::Path;

/// The bench time a check said it would take, s.
fn announced_s(t: &str) -> f64 {
    t.split("acceptance positions with ")
        .nth(1)
        .and_then(|r| r.split("about ").nth(1))
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no announced bench time in: {t}"))
}

#[test]
fn an_unchanged_unit_checks_ok_and_a_moved_force_zero_is_caught_and_kept_in_its_history() {
    let dir = scratch("check");
    let rig = unit_rig_at(&dir, 0.5);
    let o = quick_commission(&dir, &rig).output().expect("commission");
    assert!(o.status.success(), "{}", text(&o));

    let check = |rig: &Path| {
        fringe_command()
            .args([
                "check",
                "--rig",
                arg(rig),
                "--yes",
                "--out",
                arg(&dir.join("runs")),
            ])
            .current_dir(&dir)
            .output()
            .expect("check")
    };
    let o = check(&rig);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("verdict: ok"), "{t}");
    let said = announced_s(&t);
    assert!(said > 10.0 && said <= 120.0, "{t}");

    // The same unit, its F/T zero moved by 0.1 N along z (an overload, a knock).
    let aged = dir.join("aged.toml");
    let rig_text = std::fs::read_to_string(&rig).expect("rig");
    std::fs::write(
        &aged,
        format!("{rig_text}\n[sim.ageing]\nft_offset_n = [0.0, 0.0, 0.1]\n"),
    )
    .expect("aged rig");
    let o = check(&aged);
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(t.contains("verdict: calibrate again"), "{t}");
    assert!(t.contains("because: the F/T zero moved"), "{t}");
    let zero = t
        .lines()
        .find(|l| l.trim_start().starts_with("force_zero_n"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no force_zero_n figure: {t}"));
    assert!((zero - 0.1).abs() < 0.04, "{t}");

    // Both checks are in the unit's history, and plotted.
    let o = fringe(&["check", "--rig", arg(&rig), "--history"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("2 checks of sensor layered-3"), "{t}");
    assert!(t.contains("recalibrate"), "{t}");
    assert!(dir.join("profiles/layered-3.health.png").is_file());
    // Each check's run is kept like any run.
    let runs = std::fs::read_dir(dir.join("runs")).expect("runs").count();
    assert_eq!(runs, 2);
}

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
