//! `fringe demo --quick`: the main job on the simulated bench writes a verified run whose force
//! labels agree with the simulator's ground truth.

mod common;

use common::label_rms;
use std::process::Command;

#[test]
fn the_demo_writes_a_verified_run_with_truthful_labels() {
    let root = std::env::temp_dir().join(format!("fringe-demo-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .args(["demo", "--quick", "--out"])
        .arg(&root)
        .output()
        .expect("run fringe demo");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rms = label_rms(&stdout);
    assert!(rms < 0.2, "force labels off by {rms} N RMS\n{stdout}");
    let run = std::fs::read_dir(&root)
        .expect("runs dir")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.join("start.json").is_file())
        .expect("a run directory");
    let verify = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .arg("verify")
        .arg(&run)
        .output()
        .expect("verify");
    assert!(
        verify.status.success(),
        "{}",
        String::from_utf8_lossy(&verify.stdout)
    );
    let events = std::fs::read_to_string(run.join("events.jsonl")).expect("events");
    assert!(
        events.contains("first contact at z "),
        "the press found no contact:\n{events}"
    );
    let truth = std::fs::read_to_string(run.join("truth.jsonl")).expect("ground truth");
    assert!(
        truth.lines().any(|l| l.contains("\"kind\":\"frame\"")),
        "no frame truth"
    );
    let frames = std::fs::read_to_string(run.join("frames.jsonl")).expect("frames");
    assert!(frames.lines().count() >= 5, "{frames}");
    assert!(frames.contains("\"shape\":\"pentagon\""), "{frames}");
    let _ = std::fs::remove_dir_all(&root);
}
