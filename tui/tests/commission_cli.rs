//! `fringe commission` on a simulated unit of the layered design (`layered-3`, at half the
//! frame size, quick axes): the whole job cut short by a kill and resumed, its certificate
//! recomputed by `fringe eval`, the unit's commissioned model chosen by default, the
//! adaptation's determinism, then `fringe check` of the commissioned unit over its life; and bad
//! input refused before anything moves.

mod common;
use common::{
    arg, fringe, fringe_command, printed_figure, quick_commission, refused_in, rendered, scratch,
    shows_a_report, text, unit_rig_at,
};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

/// The quick bench with the `layered-3` unit at half the frame size, its profiles in `profiles`.
fn unit_rig(dir: &Path) -> PathBuf {
    unit_rig_at(dir, 0.5)
}

/// The commissioning directory under `profiles` (there is one).
fn commissioning(profiles: &Path) -> PathBuf {
    let found: Vec<PathBuf> = std::fs::read_dir(profiles)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    found
        .into_iter()
        .find(|p| p.is_dir() && p.to_string_lossy().contains(".commission-"))
        .unwrap_or_else(|| panic!("no commissioning under {}", profiles.display()))
}

#[test]
fn a_unit_is_commissioned_through_a_kill_recomputed_by_eval_and_checked_over_its_life() {
    let dir = scratch("commission");
    let rig = unit_rig(&dir);
    let profiles = dir.join("profiles");
    // Killed while the first adaptive round presses (a spec this small a budget can meet: the
    // test is of the job, not of the figures, which BENCHMARKS.md has).
    let mut child = quick_commission(&dir, &rig)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start fringe commission");
    let until = Instant::now() + Duration::from_secs(240);
    let events = |p: &Path| std::fs::read_to_string(p.join("events.jsonl")).unwrap_or_default();
    let cut = loop {
        if let Some(c) = std::fs::read_dir(&profiles).ok().and_then(|_| {
            let c = commissioning(&profiles);
            events(&c.join("runs/round-1"))
                .contains("\"point-done\"")
                .then_some(c)
        }) {
            break c;
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("fringe commission ended before its first round: {status}");
        }
        assert!(Instant::now() < until, "round 1 did not start in time");
        std::thread::sleep(Duration::from_millis(50));
    };
    child.kill().expect("kill");
    let _ = child.wait();

    // Resumed: nothing recorded is pressed again, the round goes on from its checkpoint.
    let o = fringe_command()
        .args([
            "commission",
            "--rig",
            arg(&rig),
            "--yes",
            "--resume",
            arg(&cut),
        ])
        .current_dir(&dir)
        .output()
        .expect("resume");
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("resuming the run"), "{t}");
    assert!(!t.contains("step 1: calibration"), "calibrated twice: {t}");
    assert!(t.contains("verdict:        PASS"), "{t}");
    assert!(events(&cut.join("runs/round-1")).contains("resume-run"));
    let runs: Vec<String> = std::fs::read_dir(cut.join("runs"))
        .expect("runs")
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect();
    assert!(
        runs.iter().all(|r| !r.contains("stopped")),
        "a run was pressed again: {runs:?}"
    );
    assert!(runs.contains(&"acceptance".to_string()), "{runs:?}");

    // The certificate: verdict, figures, learning curve, hash of the base, the runs used.
    let cert: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(cut.join("certificate.json")).expect("certificate"),
    )
    .expect("certificate json");
    assert_eq!(cert["pass"], true, "{cert}");
    assert_eq!(cert["sensor_id"], "layered-3");
    assert_eq!(cert["variant"], "layered");
    assert_eq!(
        cert["base_model"]["sha256"].as_str().map(str::len),
        Some(64)
    );
    assert!(!cert["learning_curve"].as_array().expect("curve").is_empty());
    for f in [
        "report.md",
        "learning.png",
        "presses.png",
        "fz.png",
        "model.json",
        "profile.toml",
    ] {
        assert!(cut.join(f).is_file(), "{f} missing");
    }
    // The report as one page a browser shows: the verdict, the spec, the weak cells, the plots
    // inside it, which millimetres are which.
    let page = std::fs::read_to_string(cut.join("report.html")).expect("report.html");
    assert!(page.contains("Verdict: PASS against"), "{page}");
    assert!(page.contains("Weak cells") && page.contains("The spec"));
    assert!(page.matches("src=\"data:image/png;base64,").count() >= 5);
    assert!(page.contains("stage millimetres") && page.contains("sensor millimetres"));
    if let Some(shot) = rendered(&cut.join("report.html"), 1200, 2400) {
        shows_a_report(&shot, true);
    }

    // `fringe eval` on the acceptance run recomputes the certificate's figures.
    let acceptance = cut.join(cert["runs"]["acceptance"].as_str().expect("acceptance run"));
    let model = cut.join("model.safetensors");
    let o = fringe(&["eval", "--model", arg(&model), arg(&acceptance)]);
    let e = text(&o);
    assert!(o.status.success(), "{e}");
    let fz = cert["figures"]["fz_rmse_n"].as_f64().expect("fz");
    let contact = cert["figures"]["contact_rmse_mm"]
        .as_f64()
        .expect("contact");
    assert!(
        (printed_figure(&e, "Fz RMSE:") - fz).abs() < 1e-4,
        "{e}\n{cert}"
    );
    assert!(
        (printed_figure(&e, "contact RMSE:") - contact).abs() < 1e-4,
        "{e}\n{cert}"
    );

    // Without --model, eval of the unit's data runs its commissioned model (the rig file in the
    // working directory names where the profiles are).
    assert_eq!(rig, dir.join("rig.toml"));
    let o = fringe_command()
        .args(["eval", arg(&acceptance)])
        .current_dir(&dir)
        .output()
        .expect("eval");
    let e = text(&o);
    assert!(e.contains("sensor layered-3's commissioned model"), "{e}");
    assert!((printed_figure(&e, "Fz RMSE:") - fz).abs() < 1e-4, "{e}");

    // Deterministic: the same runs and seed give the same weights, byte for byte.
    let first = std::fs::read(&model).expect("model");
    let o = fringe_command()
        .args([
            "commission",
            "--rig",
            arg(&rig),
            "--yes",
            "--resume",
            arg(&cut),
        ])
        .current_dir(&dir)
        .output()
        .expect("again");
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        std::fs::read(&model).expect("model"),
        first,
        "weights differ"
    );

    #[cfg(feature = "torch")]
    fine_tuning_asked_of_too_few_presses_keeps_the_heads(&dir, &rig, &cut, &first);

    checks_of_the_commissioned_unit(&dir, &rig);
}

/// `--resume DIR --fine-tune` on the commissioned unit, whose budget gave too few presses to
/// judge a fine-tuning: it says why and what would give more, nothing is trained or pressed, the
/// heads alone are kept and the card records why (the fine-tuning itself, stopped and resumed,
/// is `train_cli`'s).
#[cfg(feature = "torch")]
fn fine_tuning_asked_of_too_few_presses_keeps_the_heads(
    dir: &Path,
    rig: &Path,
    cut: &Path,
    heads_model: &[u8],
) {
    let o = fringe_command()
        .args([
            "commission",
            "--rig",
            arg(rig),
            "--yes",
            "--resume",
            arg(cut),
        ])
        .arg("--fine-tune")
        .current_dir(dir)
        .output()
        .expect("fine-tune");
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("no full fine-tuning:")
            && t.contains("--budget")
            && t.contains("heads alone are kept"),
        "{t}"
    );
    assert!(!cut.join("fine-tune").exists());
    let journal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cut.join("journal.json")).expect("journal"))
            .expect("journal json");
    assert_eq!(journal["options"]["fine_tune"], true, "{journal}");
    let card: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cut.join("model.json")).expect("card"))
            .expect("card json");
    assert_eq!(card["adaptation"]["method"], "heads", "{card}");
    assert!(
        card["adaptation"]["fine_tune"]["skipped"].is_string(),
        "{card}"
    );
    // The file holds the card too: the tensors are the heads'.
    let heads_copy = dir.join("heads.safetensors");
    std::fs::write(&heads_copy, heads_model).expect("heads copy");
    let tensors = |p: &Path| fringe_sensor_models::read_safetensors(p).expect("weights");
    assert_eq!(
        tensors(&cut.join("model.safetensors")),
        tensors(&heads_copy)
    );
}

/// The bench time a check said it would take, s.
fn announced_s(t: &str) -> f64 {
    t.split("acceptance positions with ")
        .nth(1)
        .and_then(|r| r.split("about ").nth(1))
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no announced bench time in: {t}"))
}

/// `fringe check` of the unit commissioned in `dir` on `rig`: unchanged, it checks ok; with its
/// F/T zero moved by 0.1 N it is told to calibrate again with the evidence; the history keeps
/// both and plots them.
fn checks_of_the_commissioned_unit(dir: &Path, rig: &Path) {
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
            .current_dir(dir)
            .output()
            .expect("check")
    };
    let o = check(rig);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("verdict: ok"), "{t}");
    // Its report, one page a browser shows.
    let report = t
        .lines()
        .find_map(|l| l.strip_prefix("report: "))
        .and_then(|l| l.split(" (").next())
        .map(|p| dir.join(p))
        .unwrap_or_else(|| panic!("no report line: {t}"));
    let page = std::fs::read_to_string(&report).expect("the check's report");
    assert!(
        page.contains("Verdict: ok: the unit is as it was accepted"),
        "{page}"
    );
    assert!(page.contains("src=\"data:image/png;base64,"));
    if let Some(shot) = rendered(&report, 1200, 2400) {
        shows_a_report(&shot, true);
    }
    let said = announced_s(&t);
    assert!(said > 10.0 && said <= 120.0, "{t}");

    // The same unit, its F/T zero moved by 0.1 N along z (an overload, a knock).
    let aged = dir.join("aged.toml");
    let rig_text = std::fs::read_to_string(rig).expect("rig");
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
        .find(|l| l.trim_start().starts_with("force zero "))
        .and_then(|l| l.split_whitespace().nth(2))
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no force zero figure: {t}"));
    assert!((zero - 0.1).abs() < 0.04, "{t}");

    // Both checks are in the unit's history, and plotted.
    let o = fringe(&["check", "--rig", arg(rig), "--history"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("2 checks of sensor layered-3"), "{t}");
    assert!(t.contains("recalibrate"), "{t}");
    assert!(dir.join("profiles/layered-3.health.png").is_file());
    // The unit is listed with its certificate, its last check's verdict (recalibrate: act on it
    // and check again now) and the commissioned model validate runs for it.
    let o = fringe(&["units", "--rig", arg(rig)]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let unit = t
        .split("\n\n")
        .find(|b| b.starts_with("layered-3 ("))
        .unwrap_or_else(|| panic!("layered-3 not listed: {t}"));
    assert!(unit.contains("certificate:   PASS"), "{unit}");
    assert!(
        unit.contains("last check:    recalibrate") && unit.contains("(2 checks)"),
        "{unit}"
    );
    assert!(unit.contains("next check:    now"), "{unit}");
    assert!(
        unit.contains("validate uses: its commissioned model")
            && unit.contains("model.safetensors"),
        "{unit}"
    );
    // Each check's run is kept like any run.
    let runs = std::fs::read_dir(dir.join("runs")).expect("runs").count();
    assert_eq!(runs, 2);
}

/// Issue 62: a commissioning on a camera that loses bursts of frames runs unattended to its
/// verdict. `--dry-run` says what it will take and makes nothing; the job says the same before
/// anything moves; each point the drops spoilt is pressed again and recorded in its run (no
/// prompt waits: standard input is closed, so one would abort); the pause and the progress give
/// the same count of drops; after the pass the rounds' frames are pruned, their features kept.
#[test]
fn a_unit_is_commissioned_unattended_through_camera_drops() {
    let dir = scratch("commission-drops");
    let rig = unit_rig(&dir);
    // Two half-second stalls of the camera (25 frames at 50 fps, over the 10 the watchers allow
    // in 2 s) in every scan, 8 s and 20 s after its rig opens: while a press is filmed.
    let mut rig_text = std::fs::read_to_string(&rig).expect("rig");
    for after in [8.0, 20.0] {
        rig_text.push_str(&format!(
            "\n[[sim.faults]]\ndevice = \"camera\"\nfault = \"stall\"\nafter = {after}\nduration = 0.5\n"
        ));
    }
    std::fs::write(&rig, rig_text).expect("rig with drops");
    let profiles = dir.join("profiles");

    let o = quick_commission(&dir, &rig)
        .arg("--dry-run")
        .stdin(Stdio::null())
        .output()
        .expect("dry run");
    let dry = text(&o);
    assert!(o.status.success(), "{dry}");
    let cost = dry
        .lines()
        .find(|l| l.starts_with("what it takes"))
        .unwrap_or_else(|| panic!("no cost line: {dry}"))
        .to_string();
    for said in [
        "presses, bench time",
        "computation about",
        "disk at most",
        "written in all",
        "kept after a pass",
    ] {
        assert!(cost.contains(said), "{cost}");
    }
    assert!(
        dry.contains("  calibration: 9 positions, 9 presses"),
        "{dry}"
    );
    assert!(
        dry.contains("  acceptance: 3 positions, 6 presses"),
        "{dry}"
    );
    assert!(dry.contains("nothing was made and nothing moved"), "{dry}");
    assert!(!profiles.exists(), "a dry run made {}", profiles.display());

    let o = quick_commission(&dir, &rig)
        .stdin(Stdio::null())
        .output()
        .expect("commission");
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("verdict:        PASS"), "{t}");
    // The same figures before anything moved.
    let first_step = t.find("step 1: calibration").expect("step 1");
    assert!(t[..first_step].contains(&cost), "{cost}\n{t}");
    assert!(!t.contains("no answer on standard input"), "{t}");

    // Each point the drops spoilt was pressed again, recorded in its run.
    let c = commissioning(&profiles);
    let mut represses = 0;
    for run in std::fs::read_dir(c.join("runs")).expect("runs").flatten() {
        let events = std::fs::read_to_string(run.path().join("events.jsonl")).unwrap_or_default();
        represses += events
            .lines()
            .filter(|l| l.contains("\"re-press\"") && l.contains("camera dropped"))
            .count();
    }
    assert!(represses >= 1, "no point was pressed again: {t}");
    // The pause and the progress count the same drops.
    let paused: Vec<&str> = t
        .lines()
        .filter(|l| l.starts_with("paused: camera dropped"))
        .collect();
    assert!(!paused.is_empty(), "{t}");
    for line in &paused {
        let total = line
            .split('(')
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .unwrap_or_else(|| panic!("no count in {line}"));
        assert!(
            t.lines()
                .any(|l| l.starts_with('[') && l.contains(&format!("  {total} dropped  "))),
            "{line}: no progress line with {total} dropped\n{t}"
        );
    }

    // After the pass: the rounds' frames pruned, their features and records kept; the
    // calibration and acceptance scans whole.
    let journal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(c.join("journal.json")).expect("journal"))
            .expect("journal json");
    let pruned = journal["pruned"].as_array().expect("pruned rounds").clone();
    assert!(!pruned.is_empty(), "{journal}");
    for id in pruned.iter().filter_map(|p| p.as_str()) {
        assert!(c.join(format!("features/{id}.features")).is_file(), "{id}");
        assert!(c.join(format!("runs/{id}/frames.jsonl")).is_file(), "{id}");
        assert!(
            !c.join(format!("runs/{id}/frames")).exists(),
            "{id} kept its frames"
        );
    }
    assert!(t.contains("round-1: its frames pruned"), "{t}");
    let frames_of = |run: &str| {
        std::fs::read_dir(c.join("runs").join(run).join("frames"))
            .map(|d| d.count())
            .unwrap_or(0)
    };
    assert!(frames_of("acceptance") > 0);
    assert!(frames_of("calibration-layered-3") > 0);
}

#[test]
fn bad_input_is_refused_before_anything_moves() {
    let dir = scratch("commission-bad");
    let rig = unit_rig(&dir);
    let run = |extra: &[&str]| {
        let mut args = vec!["commission", "--rig", arg(&rig), "--yes"];
        args.extend_from_slice(extra);
        refused_in(&dir, &args)
    };
    let spec = dir.join("spec.toml");
    std::fs::write(&spec, "fz_rmse_n = 0.49\nfz_rsme_mm = 1.0\n").expect("spec");
    let t = run(&["--spec", arg(&spec)]);
    assert!(t.contains("spec.toml") && t.contains("fz_rsme_mm"), "{t}");
    std::fs::write(&spec, "fz_rmse_n = 0.0\n").expect("spec");
    let t = run(&["--spec", arg(&spec)]);
    assert!(t.contains("fz_rmse_n"), "{t}");
    // A spec without a threshold would pass any unit.
    std::fs::write(&spec, "").expect("spec");
    let t = run(&["--spec", arg(&spec)]);
    assert!(
        t.contains("spec.toml: no threshold") && t.contains("add at least one of"),
        "{t}"
    );
    let t = run(&["--budget", "0"]);
    assert!(t.contains("--budget 0"), "{t}");
    // On the simulated bench's own axes a minute holds fewer presses than an adaptation needs:
    // refused before the calibration presses, saying what the presses take.
    let bench = scratch("commission-small-budget");
    let t = refused_in(&bench, &["commission", "--yes", "--budget", "1"]);
    assert!(
        t.contains("--budget 1: the adaptation needs at least 5 presses")
            && t.contains("give a larger --budget"),
        "{t}"
    );
    assert!(!t.contains("step 1"), "{t}");
    assert!(!bench.join("profiles").exists(), "{t}");
    let t = run(&["--base", arg(&dir.join("nothing.safetensors"))]);
    assert!(
        t.contains("nothing.safetensors") && t.contains("no such model"),
        "{t}"
    );
    // The last block is the custom CNN's: asked of the default (keypoint) base, it is refused.
    let t = run(&["--last-block"]);
    assert!(
        t.contains("--last-block") && t.contains("builtin:layered-keypoint"),
        "{t}"
    );
    // Full fine-tuning needs libtorch; with it, it trains every layer and excludes the last
    // block's training.
    #[cfg(not(feature = "torch"))]
    {
        let t = run(&["--fine-tune"]);
        assert!(
            t.contains("--fine-tune") && t.contains("--features torch"),
            "{t}"
        );
    }
    #[cfg(feature = "torch")]
    {
        let custom = ["--base", "builtin:layered", "--last-block", "--fine-tune"];
        let t = run(&custom);
        assert!(t.contains("--last-block and --fine-tune"), "{t}");
    }
    // A window network reads a window about a contact another network finds: refused as a
    // base, by the rule eval keeps, and on resume of a commissioning that names one.
    let t = run(&["--base", "builtin:layered-force"]);
    assert!(
        t.contains("--base builtin:layered-force")
            && t.contains("a window network of a two-stage model"),
        "{t}"
    );
    let windowed = dir.join("windowed");
    std::fs::create_dir_all(windowed.join("runs")).expect("dir");
    std::fs::write(
        windowed.join("journal.json"),
        serde_json::json!({
            "format": 1, "fringe_version": "0.1.0", "started_utc": "2026-12-01T00:00:00.000Z",
            "options": {"sensor": "layered-3", "base": "builtin:layered-force", "budget_min": 1.5,
                        "spec": null, "spec_origin": "paper", "seed": 42, "round_presses": 3,
                        "acceptance_presses": 3}
        })
        .to_string(),
    )
    .expect("journal");
    let t = run(&["--resume", arg(&windowed)]);
    assert!(
        t.contains("cannot resume")
            && t.contains("--base builtin:layered-force")
            && t.contains("a window network of a two-stage model"),
        "{t}"
    );
    assert_eq!(
        std::fs::read_dir(windowed.join("runs"))
            .expect("runs")
            .count(),
        0,
        "the resume pressed"
    );
    // A commissioning started at a quarter of the frame size, resumed on this rig (half): its
    // profile and rounds fit the other frames, so nothing is pressed.
    let quarter = dir.join("quarter");
    std::fs::create_dir_all(quarter.join("runs")).expect("dir");
    std::fs::write(
        quarter.join("journal.json"),
        serde_json::json!({
            "format": 1, "fringe_version": "0.1.0", "started_utc": "2026-12-01T00:00:00.000Z",
            "options": {"sensor": "layered-3", "base": "builtin:layered-keypoint",
                        "budget_min": 1.5, "spec": null, "spec_origin": "paper", "seed": 42,
                        "round_presses": 3, "acceptance_presses": 3,
                        "camera": {"pixel_format": "bayerrg8", "size_px": [480, 300],
                                   "image_scale": 0.25}}
        })
        .to_string(),
    )
    .expect("journal");
    let t = run(&["--resume", arg(&quarter)]);
    assert!(
        t.contains("the rig's camera gives other frames than this commissioning was started with")
            && t.contains("frame size 960x600 px, was 480x300 px")
            && t.contains("sim.image_scale 0.5, was 0.25"),
        "{t}"
    );
    assert!(!t.contains("commissioning directory"), "{t}");
    assert_eq!(
        std::fs::read_dir(quarter.join("runs"))
            .expect("runs")
            .count(),
        0,
        "the resume pressed"
    );
    let t = run(&["--resume", arg(&dir.join("profiles"))]);
    assert!(t.contains("no commissioning journal"), "{t}");
    // A resumed commissioning keeps its options; only the budget may be given again.
    let t = run(&["--resume", arg(&dir.join("profiles")), "--seed", "3"]);
    assert!(t.contains("cannot be used with"), "{t}");
    // A unit of the other design: the shipped layered model is refused as its base.
    let integrated = dir.join("integrated.toml");
    let text_of_rig = std::fs::read_to_string(&rig).expect("rig");
    std::fs::write(
        &integrated,
        text_of_rig.replace(
            "name = \"quick layered-3\"",
            "name = \"quick layered-3\"\nvariant = \"integrated\"",
        ),
    )
    .expect("rig");
    let o = fringe(&[
        "commission",
        "--rig",
        arg(&integrated),
        "--yes",
        "--base",
        "builtin:layered",
    ]);
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(
        t.contains("the model is for the layered sensor design and this unit is integrated"),
        "{t}"
    );
    // Nothing was pressed, calibrated or written.
    assert!(!dir.join("profiles").exists() || commissioning_count(&dir.join("profiles")) == 0);
}

fn commissioning_count(profiles: &Path) -> usize {
    std::fs::read_dir(profiles)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().contains(".commission-"))
                .count()
        })
        .unwrap_or(0)
}

#[test]
fn a_unit_whose_disc_is_not_found_stops_at_calibration_with_what_to_do() {
    // The unit's LEDs give no light: the optical fit finds no disc, as with a camera out of
    // focus or a unit not under it.
    let dir = scratch("commission-no-disc");
    let rig = unit_rig_at(&dir, 0.25);
    let unlit =
        std::fs::read_to_string(&rig).expect("rig") + "[sim.ageing]\nled_dimming_pct = 100.0\n";
    std::fs::write(&rig, unlit).expect("rig");
    let o = fringe_command()
        .args(["commission", "--rig", arg(&rig), "--yes"])
        .current_dir(&dir)
        .output()
        .expect("run");
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(t.contains("the calibration of layered-3 failed"), "{t}");
    assert!(t.contains("no sensor disc found"), "{t}");
    assert!(!t.contains("step 2"), "{t}");
    let c = commissioning(&dir.join("profiles"));
    let journal = std::fs::read_to_string(c.join("journal.json")).expect("journal");
    assert!(journal.contains("\"rounds\": []"), "{journal}");
    // The camera settings it started with are kept, for a resume to check.
    let kept: serde_json::Value = serde_json::from_str(&journal).expect("journal json");
    assert_eq!(
        kept["options"]["camera"],
        serde_json::json!({"pixel_format": "bayerrg8", "size_px": [480, 300], "image_scale": 0.25}),
        "{journal}"
    );
    // Resuming presses the calibration again; the failed scan is kept beside it.
    assert!(t.contains("fringe commission --resume"), "{t}");
    assert!(c.join("runs/calibration-layered-3.stopped-1").is_dir());
}

/// A commissioning whose calibration run another process writes (this one, as the UI's
/// commissioning would): `fringe commission --resume` is refused naming the writer, before any
/// device of the rig is opened.
#[test]
fn a_resume_beside_another_writer_of_its_run_opens_no_device() {
    use fringe_app::commission::{Journal, Options, ScanEntry};
    let dir = scratch("commission-held");
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, common::QUICK_RIG).expect("rig");
    let sensor = "layered-1";
    let base = fringe_sensor_models::builtin::commissioning_base(Some("layered")).expect("base");
    let mut journal = Journal::new(Options {
        sensor: sensor.into(),
        base: base.display().to_string(),
        budget_min: 1.5,
        spec: None,
        spec_origin: "the paper".into(),
        seed: 1,
        round_presses: 3,
        acceptance_presses: 3,
        last_block: false,
        fine_tune: false,
        camera: None,
    });
    let plan = common::scan_plan("[11.0, 12.5]");
    let run_id = format!("calibration-{sensor}");
    journal.calibration = Some(ScanEntry {
        run_id: run_id.clone(),
        plan: plan.clone(),
        estimate_s: 10.0,
        took_s: None,
        completed: false,
    });
    let commissioning = dir.join("unit.commission-test");
    std::fs::create_dir_all(commissioning.join("runs")).expect("dir");
    journal.write(&commissioning).expect("journal");
    let start = fringe_rig::store::StartDocument {
        layout_version: fringe_rig::store::LAYOUT_VERSION,
        run_id,
        started_utc: fringe_rig::store::now_utc(),
        software: "test".into(),
        sensor_id: sensor.into(),
        variant: None,
        plan,
        rig: common::QUICK_RIG.into(),
        calibration_profile: None,
        seed: None,
        ft_axes: None,
        sync_method: "strobe".into(),
        frames: None,
    };
    let writer =
        fringe_rig::store::RunWriter::create(&commissioning.join("runs"), &start).expect("run");
    let out = fringe(&[
        "commission",
        "--rig",
        arg(&rig),
        "--yes",
        "--resume",
        arg(&commissioning),
    ]);
    let t = text(&out);
    assert!(!out.status.success(), "a second writer ran: {t}");
    assert!(
        t.contains("the run is in use") && t.contains(&format!("pid {}", std::process::id())),
        "{t}"
    );
    assert!(
        !t.lines().any(|l| l.starts_with("  force: ")) && !t.contains("homing"),
        "opened the rig before refusing: {t}"
    );
    drop(writer);
}
