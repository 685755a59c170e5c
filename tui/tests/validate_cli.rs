//! `fringe validate --no-tui --report DIR` on the simulated bench: a model of known output runs
//! on every labelled frame of a short scan; the measured side must be the frame's synchronised
//! label (checked against the simulator's truth for the same frame) and the metrics must be those
//! of the model's output against that truth.

mod common;

use common::{
    constant_model, fringe, only_run, scratch, text, CONSTANT_FZ_N as FZ_OUT, VALIDATE_PLAN,
};
use std::collections::HashMap;
use std::path::Path;

fn number_after(s: &str, key: &str) -> f64 {
    let rest = &s[s.find(key).unwrap_or_else(|| panic!("{key} in {s}")) + key.len()..];
    let n: String = rest
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    n.parse()
        .unwrap_or_else(|_| panic!("number after {key} in {s}"))
}

/// `fringe validate --no-tui --yes --model MODEL --plan PLAN --out RUNS`, run in `dir`.
fn validate_command(dir: &Path, model: &Path, plan: &Path, runs: &Path) -> std::process::Command {
    let mut cmd = common::fringe_command();
    cmd.current_dir(dir)
        .args(["validate", "--no-tui", "--yes", "--model"])
        .arg(model)
        .arg("--plan")
        .arg(plan)
        .arg("--out")
        .arg(runs);
    cmd
}

#[test]
fn headless_validation_scores_the_model_against_the_synchronised_labels() {
    let dir = scratch("headless");
    let model = constant_model(&dir);
    let plan = dir.join("plan.toml");
    std::fs::write(&plan, VALIDATE_PLAN).expect("plan");
    let report = dir.join("report");
    let runs = dir.join("runs");
    // Full-size frames at 25 fps: with the network running beside it, a debug build films at
    // 50 fps on 2 cores only with nothing else running, and drops pause the scan (the figures
    // under test do not depend on the rate; the counts are over the frames the run keeps).
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, "[camera]\nframe_rate = 25.0\n").expect("rig file");
    let out = validate_command(&dir, &model, &plan, &runs)
        .arg("--rig")
        .arg(&rig)
        .arg("--report")
        .arg(&report)
        .output()
        .expect("run fringe");
    let all = text(&out);
    assert!(out.status.success(), "{all}");
    assert!(all.contains("design geometry"), "{all}");
    // Before the bench moved: the model's time per frame here against the camera's period.
    let per_frame_ms = number_after(&all, "the model's networks take about");
    assert!(per_frame_ms > 0.0, "{all}");
    assert!(all.contains("a frame every 40.0 ms at 25 fps"), "{all}");

    // The run the plan recorded, its labels and the simulator's truth per frame.
    let run = only_run(&runs);
    let truth: HashMap<u64, f64> = std::fs::read_to_string(run.join("truth.jsonl"))
        .expect("truth")
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["kind"] == "frame")
        .map(|v| {
            let id = v["id"].as_u64().expect("id");
            (id, v["contact_force_n"].as_f64().unwrap_or(0.0))
        })
        .collect();
    let labelled = std::fs::read_to_string(run.join("frames.jsonl"))
        .expect("frames")
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["valid"] == true && !v["wrench"].is_null())
        .count();

    let rows: Vec<serde_json::Value> = std::fs::read_to_string(report.join("validation.jsonl"))
        .expect("validation.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).expect("json line"))
        .collect();
    let offered = number_after(&all, "validation (tract backend):") as usize;
    let ran = number_after(&all, "offered,") as usize;
    let skipped = number_after(&all, "run,") as usize;
    assert_eq!(offered, labelled, "every labelled frame is offered: {all}");
    assert_eq!(ran + skipped, offered, "{all}");
    assert_eq!(rows.len(), ran);
    assert!(ran >= 20, "the network ran on {ran} frames: {all}");

    // The measured side is the frame's synchronised label: it follows the truth of that frame.
    let mut sq_label = 0.0;
    let mut sq_model = 0.0;
    let mut in_contact = 0;
    for r in &rows {
        let id = r["frame_id"].as_u64().expect("frame id");
        let t = truth
            .get(&id)
            .copied()
            .unwrap_or_else(|| panic!("frame {id} in the truth"));
        let measured = r["measured"]["fz_n"].as_f64().expect("measured fz");
        sq_label += (measured - t).powi(2);
        sq_model += (FZ_OUT - t).powi(2);
        in_contact += usize::from(r["measured"]["shape"] == "pentagon");
        assert_eq!(
            r["predicted"]["fz_n"]
                .as_f64()
                .map(|v| (v - FZ_OUT).abs() < 1e-4),
            Some(true)
        );
    }
    let n = rows.len() as f64;
    let label_rms = (sq_label / n).sqrt();
    assert!(label_rms < 0.1, "labels vs truth RMS {label_rms:.3} N");
    // The model's Fz error is its constant against the true force, to the labels' accuracy.
    let reported = number_after(&all, "Fz RMSE");
    let expected = (sq_model / n).sqrt();
    assert!(
        (reported - expected).abs() < 0.1,
        "reported Fz RMSE {reported} N, against the truth {expected:.3} N"
    );
    // The shape head always says pentagon: accuracy is the share of frames in contact.
    let accuracy = number_after(&all, "shape accuracy");
    let share = 100.0 * in_contact as f64 / n;
    assert!(
        (accuracy - share).abs() < 0.2,
        "accuracy {accuracy} % vs {share:.1} %"
    );
    assert!(
        in_contact > 0 && in_contact < rows.len(),
        "{in_contact} of {n}"
    );
    let md = std::fs::read_to_string(report.join("report.md")).expect("report.md");
    assert!(md.contains("Live validation"), "{md}");
    for png in ["fz.png", "contact.png", "confusion.png"] {
        assert!(report.join(png).is_file(), "{png}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn validation_with_a_missing_or_bad_model_says_what_to_pass() {
    let out = fringe(&["validate", "--no-tui", "--model", "nothere.pth"]);
    assert!(!out.status.success());
    let t = text(&out);
    assert!(
        t.contains("nothere.pth: no such model file") && t.contains("`default`"),
        "{t}"
    );
    let out = fringe(&["validate", "--no-tui", "--model", "builtin:nothere"]);
    assert!(!out.status.success());
    assert!(text(&out).contains("fringe has: layered"), "{}", text(&out));
    let dir = scratch("bad-model");
    let bad = dir.join("notes.pth");
    std::fs::write(&bad, "not a model").expect("write");
    let out = common::fringe_command()
        .args(["validate", "--no-tui", "--model"])
        .arg(&bad)
        .output()
        .expect("run");
    assert!(!out.status.success());
    assert!(text(&out).contains("notes.pth"), "{}", text(&out));
    // A model whose classes do not name the plan's indenter is refused before the scan, as
    // eval refuses it, instead of leaving every contact frame unscored.
    let weights = dir.join("other-classes.safetensors");
    std::fs::copy(constant_model(&dir), &weights).expect("weights");
    std::fs::write(
        dir.join("other-classes.json"),
        r#"{"classes": ["None", "triangle", "rectangle"]}"#,
    )
    .expect("card");
    let plan = dir.join("plan.toml");
    std::fs::write(&plan, VALIDATE_PLAN).expect("plan");
    let out = validate_command(&dir, &weights, &plan, &dir.join("runs"))
        .output()
        .expect("run");
    let t = text(&out);
    assert!(!out.status.success(), "{t}");
    assert!(t.contains("do not include pentagon"), "{t}");
    assert!(!t.contains("completed"), "refused before the scan ran: {t}");
    // A model of the other sensor design reads these frames wrongly with no error: refused
    // before the scan, naming both designs.
    let weights = dir.join("integrated.safetensors");
    std::fs::copy(constant_model(&dir), &weights).expect("weights");
    std::fs::write(
        dir.join("integrated.json"),
        r#"{"classes": ["None", "pentagon", "rectangle"], "variant": "integrated"}"#,
    )
    .expect("card");
    let out = validate_command(&dir, &weights, &plan, &dir.join("runs"))
        .output()
        .expect("run");
    let t = text(&out);
    assert!(!out.status.success(), "{t}");
    assert!(
        t.contains("the model is for the integrated sensor design and this sensor is layered"),
        "{t}"
    );
    assert!(!t.contains("completed"), "refused before the scan ran: {t}");
}
