//! `fringe scan` on the simulated bench: dry runs, plan errors, a run killed mid-point and
//! resumed, Ctrl-C pausing a run that the operator resumes.

mod common;

use common::{
    events, fringe, points_in, resume, resume_to_the_end, scan_command, scan_files as files,
    scan_plan as plan, scratch, snapshot, text, the_run, wait_for_event, TestRun, QUICK_RIG,
};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn a_dry_run_prints_points_path_and_duration_and_moves_nothing() {
    let dir = scratch("dry");
    let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .current_dir(&dir)
        .args(["scan", "--dry-run"])
        .output()
        .expect("run");
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    assert!(t.contains("no rig.toml: using the simulated bench"), "{t}");
    assert!(t.contains("6 points"), "{t}");
    assert!(t.contains("prompt: mount the pentagon indenter"), "{t}");
    assert!(t.contains("estimated duration"), "{t}");
    assert!(!dir.join("runs").exists(), "a dry run writes no run");
}

/// `fringe scan NAME` runs the built-in plan of that name (the error for a missing plan file
/// lists them by name), unless a file of that name is there; `fringe plans` lists them.
#[test]
fn built_in_plans_are_listed_and_run_by_name() {
    let dir = scratch("by-name");
    let dry = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
            .current_dir(&dir)
            .args(args)
            .output()
            .expect("run");
        let t = text(&out);
        assert!(out.status.success(), "{args:?}: {t}");
        t
    };
    let t = dry(&["scan", "short-grid", "--dry-run"]);
    assert!(
        t.contains("plan: built-in plan short-grid (tui/app/plans/short-grid.toml)"),
        "{t}"
    );
    assert!(t.contains("6 points"), "{t}");
    let t = dry(&["scan", "demo", "--dry-run"]);
    assert!(t.contains("plan: built-in plan demo"), "{t}");
    assert!(t.contains("3 points"), "{t}");
    // A file of that name wins over the built-in plan.
    std::fs::write(dir.join("demo"), plan("[11.0, 12.5]")).expect("plan");
    let t = dry(&["scan", "demo", "--dry-run"]);
    assert!(t.contains("plan: demo\n"), "{t}");
    assert!(t.contains("2 points"), "{t}");
    // The list: every built-in plan by name with its points, presses and time, and no template.
    let t = dry(&["plans"]);
    let line = |name: &str| {
        t.lines()
            .find(|l| l.trim_start().starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("{name} not listed:\n{t}"))
            .to_string()
    };
    let grid = line("short-grid");
    assert!(
        grid.contains("6 points, 6 presses to 1, 4 N, about 0:0"),
        "{grid}"
    );
    assert!(grid.contains("the main job"), "{grid}");
    assert!(
        line("demo").contains("3 points, 3 presses to 1, 4, 9 N"),
        "{t}"
    );
    // Each (force, direction, speed) of a slide is a press of its own.
    assert!(
        line("slides").contains("4 points, 48 presses to 1.5, 2.5 N"),
        "{t}"
    );
    assert!(
        line("calibration").contains("9 points, 9 presses to 1.5 N"),
        "{t}"
    );
    assert!(!t.contains("commission "), "{t}");
    assert!(t.contains("fringe scan NAME"), "{t}");
}

/// `--no-tui` is taken after the command as before it (`fringe scan --no-tui` was refused as
/// an unexpected argument: the flag was the top level's only).
#[test]
fn no_tui_is_taken_before_or_after_the_command() {
    let dir = scratch("no-tui");
    for args in [
        ["scan", "--no-tui", "--dry-run"],
        ["--no-tui", "scan", "--dry-run"],
        ["scan", "--dry-run", "--no-tui"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
            .current_dir(&dir)
            .args(args)
            .output()
            .expect("run");
        let t = text(&out);
        assert!(out.status.success(), "{args:?}: {t}");
        assert!(t.contains("6 points"), "{args:?}: {t}");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .current_dir(&dir)
        .args(["model", "info", "builtin:layered", "--no-tui"])
        .output()
        .expect("run");
    assert!(out.status.success(), "{}", text(&out));
    assert!(!dir.join("runs").exists(), "a dry run writes no run");
}

#[test]
fn a_dry_run_states_the_runs_size_on_disk_and_the_free_space() {
    let dir = scratch("dry-size");
    let (rig, plan_path) = files(&dir);
    let root = dir.join("runs");
    let dry = |rig: &Path| {
        let out = fringe(&[
            "scan",
            plan_path.to_str().expect("path"),
            "--rig",
            rig.to_str().expect("path"),
            "--out",
            root.to_str().expect("path"),
            "--dry-run",
        ]);
        let t = text(&out);
        assert!(out.status.success(), "{t}");
        t
    };
    // The quick rig's camera: a quarter of 1920x1200, BayerRG8 at 50 fps.
    let t = dry(&rig);
    let line = t
        .lines()
        .find(|l| l.starts_with("expected on disk: "))
        .unwrap_or_else(|| panic!("no expected size in {t}"));
    assert!(
        line.contains("frames ") && line.contains(" of 480x300 bayerrg8, "),
        "{line}"
    );
    assert!(
        line.contains("force log ") && line.contains("records "),
        "{line}"
    );
    assert!(
        t.contains(&format!(
            "free on the filesystem holding {}: ",
            root.display()
        )),
        "{t}"
    );
    assert!(!t.contains("would be refused"), "{t}");
    // Only the disc's square: the square of the simulated sensor's design geometry (whose disc
    // nearly fills the quarter-size frame: a small margin).
    let disc = dir.join("disc-rig.toml");
    let store = "[recording]\nstore = \"disc\"\ndisc_margin_px = 4.0\n";
    std::fs::write(&disc, format!("{QUICK_RIG}{store}")).expect("rig");
    let t = dry(&disc);
    assert!(t.contains("disc squares of 480x300 bayerrg8"), "{t}");
    // The same asked by the plan on the rig that stores whole frames.
    let plan_text = std::fs::read_to_string(&plan_path).expect("plan");
    std::fs::write(&plan_path, format!("{plan_text}{store}")).expect("plan");
    let t = dry(&rig);
    assert!(t.contains("disc squares of 480x300 bayerrg8"), "{t}");
    assert!(!root.exists(), "a dry run writes no run");
}

/// A plan of the quick rig's three points that films for weeks: ten targets held 600 s each,
/// a thousand times (about 100 TB of frames).
fn weeks_long_plan() -> String {
    plan("[11.0, 12.5, 14.0]")
        .replace(
            "force_targets = [1.0, 3.0]",
            "force_targets = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5]",
        )
        .replace("dwell = 0.4", "dwell = 600.0\nrepetitions = 1000")
}

#[test]
fn a_scan_that_will_not_fit_on_the_disk_is_refused_before_anything_moves() {
    let dir = scratch("no-room");
    let (rig, _) = files(&dir);
    let root = dir.join("runs");
    let plan_path = dir.join("weeks.toml");
    std::fs::write(&plan_path, weeks_long_plan()).expect("plan");
    let out = fringe(&[
        "scan",
        "--yes",
        "--rig",
        rig.to_str().expect("path"),
        "--out",
        root.to_str().expect("path"),
        plan_path.to_str().expect("path"),
    ]);
    let t = text(&out);
    assert!(!out.status.success(), "{t}");
    assert!(
        t.contains(&format!(
            "{}: not enough disk space for this scan",
            root.display()
        )) && t.contains("it will write about")
            && t.contains("needs")
            && t.contains(&format!("the filesystem holding {} has", root.display()))
            && t.contains("--out DIR")
            && t.contains("[recording] store = \"disc\""),
        "{t}"
    );
    assert!(
        !t.contains("homing") && !t.contains("run directory"),
        "moved: {t}"
    );
    assert!(the_run(&root).is_none(), "a run was created: {t}");

    // A resume of such a run is refused for its points left, the run unchanged.
    let crashed = TestRun {
        id: "crashed",
        points: 3,
        finish: false,
        plan: &weeks_long_plan(),
        sync: "strobe",
    }
    .write(&dir.join("old"));
    let before = snapshot(&crashed);
    let out = resume(&rig, &crashed);
    let t = text(&out);
    assert!(!out.status.success(), "{t}");
    assert!(
        t.contains(&format!(
            "{}: not enough disk space to resume this run (2998 points left)",
            crashed.display()
        )),
        "{t}"
    );
    assert!(!t.contains("homing"), "moved: {t}");
    assert!(
        snapshot(&crashed) == before,
        "the refused resume changed the run"
    );
}

#[test]
fn a_plan_outside_the_soft_limits_is_refused_naming_file_and_key() {
    let dir = scratch("limits");
    let (rig, _) = files(&dir);
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, plan("[11.0, 99.0]")).expect("plan");
    let out = fringe(&[
        "scan",
        bad.to_str().expect("path"),
        "--rig",
        rig.to_str().expect("path"),
        "--dry-run",
    ]);
    let t = text(&out);
    assert!(!out.status.success(), "{t}");
    assert!(
        t.contains("bad.toml") && t.contains("grid.x") && t.contains("99"),
        "{t}"
    );
}

#[test]
fn a_run_killed_mid_point_is_resumed_without_losing_or_repeating_a_point() {
    let dir = scratch("crash");
    let (rig, plan_path) = files(&dir);
    let root = dir.join("runs");
    let mut child = scan_command(&rig, &root, &plan_path)
        .spawn()
        .expect("spawn");
    // Kill it (SIGKILL: no cleanup at all) while it presses point 2.
    let run = wait_for_event(&root, &mut child, |e| {
        e.contains("\"kind\":\"contact\"") && e.contains("\"point\":1")
    });
    std::thread::sleep(Duration::from_millis(300));
    child.kill().expect("kill");
    let _ = child.wait();
    assert!(!run.join("stop.json").exists());
    let verify = fringe(&["verify", run.to_str().expect("path")]);
    assert!(
        !verify.status.success(),
        "an interrupted run is not complete"
    );
    assert!(text(&verify).contains("--resume"), "{}", text(&verify));

    resume_to_the_end(&rig, &run);
    let events = events(&run);
    let resumed = events
        .iter()
        .find(|e| e.contains("\"kind\":\"resume-run\""))
        .expect("resume event");
    assert!(resumed.contains("resumed at point 1"), "{resumed}");
}

/// An unfinished run of the plan `files` writes, as the engine leaves it after a crash during
/// its third point: checkpoint before point 2, the 3 records of point 2 after it.
fn crashed_run(dir: &Path) -> PathBuf {
    TestRun {
        id: "crashed",
        points: 3,
        finish: false,
        plan: &plan("[11.0, 12.5, 14.0]"),
        sync: "strobe",
    }
    .write(&dir.join("runs"))
}

#[test]
fn a_resume_refuses_a_run_whose_checkpointed_records_are_missing() {
    let dir = scratch("cut-records");
    let (rig, _) = files(&dir);
    let run = crashed_run(&dir);
    // frames.jsonl cut in the middle (in the records of point 1), after the checkpoint.
    let frames = run.join("frames.jsonl");
    let text_before = std::fs::read_to_string(&frames).expect("frames");
    let cut = text_before
        .lines()
        .take(4)
        .map(|l| l.len() + 1)
        .sum::<usize>()
        + 40;
    std::fs::write(&frames, &text_before[..cut]).expect("cut");
    let before = snapshot(&run);
    let out = resume(&rig, &run);
    let t = text(&out);
    assert!(!out.status.success(), "{t}");
    assert!(
        t.contains("holds 4 records but checkpoint.json counts 6 before point 2")
            && t.contains("records of finished points are missing"),
        "{t}"
    );
    assert!(snapshot(&run) == before, "a refused resume changed the run");
    let verify = fringe(&["verify", run.to_str().expect("path")]);
    let t = text(&verify);
    assert!(!verify.status.success(), "{t}");
    assert!(t.contains("checkpoint.json counts 6"), "{t}");
}

#[test]
fn a_resume_with_a_different_plan_changes_nothing() {
    let dir = scratch("other-plan");
    let (rig, _) = files(&dir);
    let run = crashed_run(&dir);
    let other = dir.join("other.toml");
    std::fs::write(&other, plan("[11.0, 12.5]")).expect("plan");
    let before = snapshot(&run);
    assert!(before.contains_key("frames/00000008.fgl"));
    let out = fringe(&[
        "scan",
        other.to_str().expect("path"),
        "--yes",
        "--rig",
        rig.to_str().expect("path"),
        "--resume",
        run.to_str().expect("path"),
    ]);
    let t = text(&out);
    assert!(!out.status.success(), "{t}");
    assert!(t.contains("different plan"), "{t}");
    assert!(
        snapshot(&run) == before,
        "the refused resume cut records or removed frames"
    );
}

#[test]
fn bad_plan_and_camera_numbers_are_refused_before_anything_moves() {
    let dir = scratch("bad-numbers");
    let (rig, _) = files(&dir);
    let root = dir.join("runs");
    let good = plan("[11.0, 12.5]");
    let cases = [
        // The safety defect: a nan threshold pressed the sensor to the ceiling.
        (
            good.replace("safe_z = 14.0", "safe_z = 14.0\ncontact_threshold = nan"),
            QUICK_RIG.to_string(),
            "approach.contact_threshold",
        ),
        (
            good.replace("safe_z = 14.0", "safe_z = 14.0\ncontact_threshold = 5.0"),
            QUICK_RIG.to_string(),
            "force_targets",
        ),
        (
            good.replace("dwell = 0.4", "dwell = 1e300"),
            QUICK_RIG.to_string(),
            "indentation.dwell",
        ),
        (
            good.replace("ramp_rate = 6.0", "ramp_rate = 1e-300"),
            QUICK_RIG.to_string(),
            "indentation.ramp_rate",
        ),
        (
            good.replace("dwell = 0.4", "dwell = 0.4\nrepetitions = 4294967295"),
            QUICK_RIG.to_string(),
            "indentation.repetitions",
        ),
        (
            good.clone(),
            QUICK_RIG.replace(
                "driver = \"sim\"\n[force]",
                "driver = \"sim\"\nframe_rate = 0.0\n[force]",
            ),
            "camera.frame_rate",
        ),
        (
            good.clone(),
            QUICK_RIG.replace(
                "driver = \"sim\"\n[force]",
                "driver = \"sim\"\nexposure_us = -5.0\n[force]",
            ),
            "camera.exposure_us",
        ),
    ];
    for (plan_text, rig_text, key) in cases {
        let plan_path = dir.join("bad-plan.toml");
        std::fs::write(&plan_path, &plan_text).expect("plan");
        std::fs::write(&rig, &rig_text).expect("rig");
        for dry in [true, false] {
            let mut args = vec!["scan", "--out", root.to_str().expect("path"), "--rig"];
            args.push(rig.to_str().expect("path"));
            args.push(plan_path.to_str().expect("path"));
            if dry {
                args.push("--dry-run");
            }
            let out = fringe(&args);
            let t = text(&out);
            assert!(!out.status.success(), "{key} accepted: {t}");
            assert!(t.contains(key) && !t.contains("panicked"), "{key}: {t}");
            assert!(!t.contains("homing"), "{key}: homed before refusing: {t}");
            assert!(the_run(&root).is_none(), "{key}: a run was created");
        }
    }
}

#[test]
fn ctrl_c_at_the_pause_prompt_acts_without_a_key() {
    let dir = scratch("ctrlc-prompt");
    let (rig, plan_path) = files(&dir);
    let root = dir.join("runs");
    let mut child = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .args(["scan", "--out"])
        .arg(&root)
        .arg("--rig")
        .arg(&rig)
        .arg(&plan_path)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let interrupt = |child: &Child| {
        // SAFETY: signalling our own child process.
        unsafe {
            libc::kill(child.id() as libc::pid_t, libc::SIGINT);
        }
    };
    let run = wait_for_event(&root, &mut child, |e| {
        e.contains("\"kind\":\"contact\"") && e.contains("\"point\":0")
    });
    interrupt(&child);
    wait_for_event(&root, &mut child, |e| {
        e.contains("\"kind\":\"prompt\"") && e.contains("resume?")
    });
    // Nothing is typed (stdin stays open): the second Ctrl-C alone must end the scan.
    interrupt(&child);
    let until = Instant::now() + Duration::from_secs(20);
    let status = loop {
        if let Some(status) = child.try_wait().expect("try_wait") {
            break status;
        }
        assert!(
            Instant::now() < until,
            "fringe still waits for a key after Ctrl-C at the prompt"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = child.wait_with_output().expect("output");
    let t = text(&out);
    assert!(!status.success(), "{t}");
    assert!(t.contains("Ctrl-C at the prompt: aborting"), "{t}");
    assert!(t.contains("aborted"), "{t}");
    let stop = std::fs::read_to_string(run.join("stop.json")).expect("stop.json");
    assert!(stop.contains("aborted"), "{stop}");
    assert_eq!(points_in(&run), vec![0]);
}

#[test]
fn ctrl_c_pauses_after_the_indentation_and_the_operator_resumes() {
    let dir = scratch("ctrlc");
    let (rig, plan_path) = files(&dir);
    let root = dir.join("runs");
    let mut child = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .args(["scan", "--out"])
        .arg(&root)
        .arg("--rig")
        .arg(&rig)
        .arg(&plan_path)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let run = wait_for_event(&root, &mut child, |e| {
        e.contains("\"kind\":\"contact\"") && e.contains("\"point\":0")
    });
    // SAFETY: signalling our own child process.
    unsafe {
        libc::kill(child.id() as libc::pid_t, libc::SIGINT);
    }
    wait_for_event(&root, &mut child, |e| {
        e.contains("\"kind\":\"prompt\"") && e.contains("resume?")
    });
    let evs = events(&run);
    assert!(evs
        .iter()
        .any(|e| e.contains("point-done") && e.contains("\"point\":0")));
    assert!(!evs.iter().any(|e| e.contains("point-interrupted")));
    child
        .stdin
        .as_mut()
        .expect("stdin")
        .write_all(b"r\n")
        .expect("answer");
    let out = child.wait_with_output().expect("wait");
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    assert!(
        t.contains("Ctrl-C: pausing after the current indentation"),
        "{t}"
    );
    assert!(t.contains("completed: 3 of 3 points"), "{t}");
    assert_eq!(points_in(&run), vec![0, 1, 2]);
}

/// What fringe prints once it has opened the simulated bench's devices (their description lines)
/// or moved anything.
fn opened_or_moved(t: &str) -> bool {
    t.lines().any(|l| l.starts_with("  force: "))
        || t.contains("homing")
        || t.contains("z to the safe height")
}

#[test]
fn a_safe_height_in_the_gel_and_forces_past_the_transducer_are_refused_before_anything_moves() {
    let dir = scratch("issue-59-safety");
    let (rig, _) = files(&dir);
    let root = dir.join("runs");
    // The issue's plan: two points 4 mm apart, safe_z 16 with the surface at 15 mm.
    let in_gel = r#"
name = "in-gel"
[grid]
points = [[10.5, 25.0], [14.5, 25.0]]
[indenters]
shapes = ["pentagon"]
[approach]
safe_z = 16.0
[indentation]
force_targets = [2.0]
ramp_rate = 6.0
dwell = 0.4
[safety]
force_ceiling = 12.0
"#;
    let hard = plan("[11.0, 12.5]")
        .replace("force_targets = [1.0, 3.0]", "force_targets = [150.0]")
        .replace("force_ceiling = 10.0", "force_ceiling = 200.0");
    let unbounded = QUICK_RIG.replace(
        "[force]\ndriver = \"sim\"",
        "[force]\ndriver = \"sim\"\nmax_force = 1e9",
    );
    let rgb8_fgl = QUICK_RIG.replace(
        "[camera]\ndriver = \"sim\"",
        "[camera]\ndriver = \"sim\"\npixel_format = \"rgb8\"",
    ) + "[recording]\ncodec = \"fgl\"\n";
    let cases = [
        (
            in_gel.to_string(),
            QUICK_RIG.to_string(),
            "key approach.safe_z: 16 mm is at or past the sensor surface (first contact at z = 15 mm",
        ),
        (
            hard.clone(),
            unbounded,
            "key force.max_force: 1e9 N is above the rated range of the F/T transducer, the simulated Mini40 (SI-40-2, serial FT90001): 120 N in Fz",
        ),
        (
            hard,
            QUICK_RIG.to_string(),
            "key safety.force_ceiling: 200 N is above the rated range of the F/T transducer, the simulated Mini40 (SI-40-2, serial FT90001): 120 N in Fz",
        ),
        (
            plan("[11.0, 12.5]"),
            rgb8_fgl,
            "`recording.codec` = \"fgl\" stores one-channel frames",
        ),
    ];
    for (plan_text, rig_text, refusal) in cases {
        let plan_path = dir.join("plan.toml");
        std::fs::write(&plan_path, &plan_text).expect("plan");
        std::fs::write(&rig, &rig_text).expect("rig");
        for dry in [true, false] {
            let mut args = vec!["scan", "--yes", "--out", root.to_str().expect("path")];
            args.extend(["--rig", rig.to_str().expect("path")]);
            args.push(plan_path.to_str().expect("path"));
            if dry {
                args.push("--dry-run");
            }
            let out = fringe(&args);
            let t = text(&out);
            assert!(!out.status.success(), "dry {dry}: accepted: {t}");
            assert!(t.contains(refusal), "dry {dry}: {t}");
            assert!(
                !opened_or_moved(&t),
                "dry {dry}: opened or moved before refusing: {t}"
            );
            assert!(
                the_run(&root).is_none(),
                "dry {dry}: a run was created: {t}"
            );
        }
    }
}

#[test]
fn a_resume_of_a_run_another_process_writes_opens_no_device() {
    let dir = scratch("resume-held");
    let (rig, plan_path) = files(&dir);
    let root = dir.join("runs");
    // A run as a writer holds it (this process): its start document written, its lock taken.
    let plan_text = std::fs::read_to_string(&plan_path).expect("plan");
    let start = fringe_rig::store::StartDocument {
        layout_version: fringe_rig::store::LAYOUT_VERSION,
        run_id: "held".into(),
        started_utc: fringe_rig::store::now_utc(),
        software: "test".into(),
        sensor_id: "layered-sim".into(),
        variant: None,
        plan: plan_text,
        rig: QUICK_RIG.into(),
        calibration_profile: None,
        seed: None,
        ft_axes: None,
        sync_method: "strobe".into(),
        frames: None,
    };
    let writer = fringe_rig::store::RunWriter::create(&root, &start).expect("run");
    let run = writer.dir().to_path_buf();
    let out = resume(&rig, &run);
    let t = text(&out);
    assert!(!out.status.success(), "a second writer ran: {t}");
    assert!(
        t.contains("the run is in use") && t.contains(&format!("pid {}", std::process::id())),
        "{t}"
    );
    assert!(!opened_or_moved(&t), "opened the rig before refusing: {t}");
    drop(writer);
}
