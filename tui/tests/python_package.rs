//! The `fringe` Python package (python/, built by maturin: scripts/test installs it into the test
//! venv, FRINGE_PYTHON) against fringe's own reading of the same runs: frames as fringe's MCAP
//! export holds them, labels as the runs record them, inputs and predictions as `fringe eval`
//! scores them, the model `fringe eval` picks, and the bad inputs a lab meets (a run being
//! written, a damaged frame, a newer layout). The Python half is python/tests/check_package.py.

mod common;

use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The Python with the package and the MCAP readers: FRINGE_PYTHON, else python3.
fn python() -> String {
    std::env::var("FRINGE_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// Runs check_package.py `args`; asserts it passed and returns the JSON line it printed.
fn check(args: &[&str]) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../python/tests/check_package.py");
    let out = Command::new(python())
        .arg(&script)
        .args(args)
        .output()
        .expect("run the Python interpreter (FRINGE_PYTHON or python3)");
    let t = text(&out);
    assert!(
        out.status.success(),
        "check_package.py {args:?} (with the fringe package installed: scripts/test installs it \
         into the venv it sets FRINGE_PYTHON to):\n{t}"
    );
    let last = String::from_utf8_lossy(&out.stdout)
        .lines()
        .last()
        .unwrap_or_default()
        .to_string();
    serde_json::from_str(&last).unwrap_or_else(|e| panic!("{e}: {t}"))
}

/// A five-point plan pressed to 1.2 N: enough presses for each side of the split, all of one
/// stratum (the split shares each shape and force level, to the newton, between the sides: a
/// press to 1.5 N could read 1 N or 2 N).
const PLAN: &str = r#"
name = "python"
[grid]
x = [10.0, 11.5, 13.0, 14.5, 16.0]
y = [25.0]
[indenters]
shapes = ["pentagon"]
[approach]
safe_z = 14.0
[indentation]
force_targets = [1.2]
ramp_rate = 6.0
dwell = 0.3
[safety]
force_ceiling = 10.0
"#;

/// Three runs of the quick rig, made once per build: BayerRG8 frames in FGL (the default for
/// the Bayer camera), RGB8 frames in PNG files, and only the disc's square (Bayer, FGL).
fn runs() -> (PathBuf, PathBuf, PathBuf) {
    // Named for the plan and the rigs too, so that data made by another version of them is
    // never taken.
    let recipe = format!("{PLAN}{QUICK_RIG}");
    let key = recipe.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    });
    let dir = shared(&format!("python-runs-{key:016x}"), |dir| {
        let plan = dir.join("plan.toml");
        std::fs::write(&plan, PLAN).expect("plan");
        for (name, camera, recording) in [
            ("fgl", "", ""),
            (
                "png",
                "pixel_format = \"rgb8\"\n",
                "[recording]\ncodec = \"png\"\n",
            ),
            (
                "disc",
                "",
                "[recording]\nstore = \"disc\"\ndisc_margin_px = 4.0\n",
            ),
        ] {
            let rig = dir.join(format!("{name}.toml"));
            let rig_text = QUICK_RIG.replace(
                "[camera]\ndriver = \"sim\"\n",
                &format!("[camera]\ndriver = \"sim\"\n{camera}"),
            );
            std::fs::write(&rig, format!("{rig_text}{recording}")).expect("rig");
            let out = fringe_command()
                .args(["scan", "--yes", "--rig", arg(&rig), "--out"])
                .arg(dir.join(name))
                .arg(&plan)
                .output()
                .expect("run fringe");
            assert!(out.status.success(), "{}", text(&out));
        }
    });
    (
        only_run(&dir.join("fgl")),
        only_run(&dir.join("png")),
        only_run(&dir.join("disc")),
    )
}

/// A copy of the run `from` in `to`.
fn copy_run(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("copy");
    for e in std::fs::read_dir(from).expect("run") {
        let e = e.expect("entry");
        if e.file_type().expect("type").is_dir() {
            copy_run(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).expect("copy");
        }
    }
}

/// Rewrites `run`'s start document by `edit`.
fn edit_start(run: &Path, edit: impl FnOnce(&mut serde_json::Map<String, serde_json::Value>)) {
    let path = run.join("start.json");
    let mut start: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("start.json"))
            .expect("start.json");
    edit(start.as_object_mut().expect("an object"));
    std::fs::write(&path, serde_json::to_string_pretty(&start).expect("json")).expect("write");
}

#[test]
fn frames_labels_and_events_read_from_python_are_fringes_own_for_every_storage_and_layout() {
    let dir = scratch("same");
    let (fgl, png, disc) = runs();
    for (name, run, encoding, crop, format) in [
        ("fgl", &fgl, "fgl", false, "bayerrg8"),
        ("png", &png, "png", false, "rgb8"),
        ("disc", &disc, "fgl", true, "bayerrg8"),
    ] {
        let mcap = dir.join(format!("{name}.mcap"));
        let out = fringe(&["export", arg(run), "--format", "mcap", "--out", arg(&mcap)]);
        assert!(out.status.success(), "{}", text(&out));
        let got = check(&["same-as-fringe", arg(run), arg(&mcap)]);
        assert_eq!(got["encoding"], encoding, "{got}");
        assert_eq!(got["crop"], crop, "{got}");
        assert_eq!(got["pixel_format"], format, "{got}");
        assert!(got["frames"].as_u64().expect("frames") > 50, "{got}");
        assert!(got["labelled"].as_u64().expect("labelled") > 20, "{got}");
    }
    // A run of layout 1: frames in PNG files, how they are stored not recorded (the rig text
    // names the camera's pixel format, RGB8), no design recorded.
    let old = dir.join("layout-1");
    copy_run(&png, &old);
    edit_start(&old, |s| {
        s.insert("layout_version".into(), 1.into());
        s.remove("frames");
        s.remove("variant");
    });
    let got = check(&["same-run", arg(&png), arg(&old)]);
    assert_eq!(got["layout"], 1, "{got}");
}

#[test]
fn a_newer_layout_a_damaged_frame_and_a_run_being_written_are_said_clearly() {
    let dir = scratch("bad");
    let (fgl, _, _) = runs();
    // A run of a newer layout than this fringe reads.
    let newer = dir.join("newer");
    copy_run(&fgl, &newer);
    edit_start(&newer, |s| {
        s.insert("layout_version".into(), 99.into());
    });
    let got = check(&["refused", arg(&newer)]);
    let m = got["message"].as_str().expect("message");
    assert!(
        m.contains("start.json") && m.contains("layout version 99") && m.contains("newer fringe"),
        "{m}"
    );
    // Not a run at all.
    let got = check(&["refused", arg(&dir)]);
    assert!(
        got["message"]
            .as_str()
            .expect("message")
            .contains(&dir.display().to_string()),
        "{got}"
    );
    // A damaged frame: named, raised, or skipped when asked.
    let damaged = dir.join("damaged");
    copy_run(&fgl, &damaged);
    let records = std::fs::read_to_string(damaged.join("frames.jsonl")).expect("records");
    let third: serde_json::Value =
        serde_json::from_str(records.lines().nth(3).expect("a fourth record")).expect("record");
    let file = damaged.join(third["file"].as_str().expect("file"));
    let bytes = std::fs::read(&file).expect("frame file");
    std::fs::write(&file, &bytes[..bytes.len() / 3]).expect("truncate");
    let got = check(&["damaged", arg(&damaged), "3"]);
    let m = got["message"].as_str().expect("message");
    assert!(
        m.contains(&file.display().to_string()) && m.contains("frame 3"),
        "{m}"
    );
    // A run being written: no stop document or manifest yet, a record torn mid-write.
    let open = dir.join("open");
    copy_run(&fgl, &open);
    std::fs::remove_file(open.join("stop.json")).expect("stop.json");
    std::fs::remove_file(open.join("MANIFEST.sha256")).expect("manifest");
    let whole = records.lines().count();
    let mut torn = records.clone();
    torn.push_str("{\"index\": 99999, \"frame_id\"");
    std::fs::write(open.join("frames.jsonl"), torn).expect("frames.jsonl");
    let got = check(&["incomplete", arg(&open), &whole.to_string()]);
    let w = got["warning"].as_str().expect("warning");
    assert!(
        w.contains(&open.display().to_string()) && w.contains("not closed"),
        "{w}"
    );
}

#[test]
fn inputs_and_predictions_from_python_score_as_fringe_eval_and_the_model_is_the_one_it_picks() {
    let dir = scratch("eval");
    let (fgl, _, disc) = runs();
    for (name, run) in [("fgl", &fgl), ("disc", &disc)] {
        let csv = dir.join(format!("{name}.csv"));
        let out = fringe(&[
            "eval",
            "--model",
            "builtin:layered",
            arg(run),
            "--predictions",
            arg(&csv),
        ]);
        let printed = text(&out);
        assert!(out.status.success(), "{printed}");
        let got = check(&["eval-figures", arg(run), "builtin:layered", arg(&csv)]);
        let n = got["n"].as_u64().expect("n");
        assert!(
            printed.contains(&format!("frames:         {n} (")),
            "{got}\n{printed}"
        );
        for (key, printed_key) in [
            ("fz_mse", "Fz MSE:"),
            ("fz_rmse", "Fz RMSE:"),
            ("accuracy", "shape accuracy:"),
        ] {
            let python = got[key].as_f64().expect("figure");
            let fringe = printed_figure(&printed, printed_key);
            assert!(
                format!("{python:.4}") == format!("{fringe:.4}"),
                "{key}: Python {python} vs fringe eval {fringe}\n{printed}"
            );
        }
    }
    // Without --model: the model fringe eval picks for the run's sensor.
    let profiles = dir.join("profiles");
    std::fs::create_dir_all(&profiles).expect("profiles");
    let rig = dir.join("rig.toml");
    std::fs::write(
        &rig,
        QUICK_RIG.replace(
            "name = \"quick simulated bench\"",
            &format!(
                "name = \"quick simulated bench\"\nprofiles = \"{}\"",
                profiles.display()
            ),
        ),
    )
    .expect("rig");
    let out = fringe_command()
        .args(["eval", arg(&fgl)])
        .current_dir(&dir)
        .output()
        .expect("run fringe");
    let printed = text(&out);
    assert!(out.status.success(), "{printed}");
    let got = check(&["for-run", arg(&fgl), arg(&profiles)]);
    let path = got["path"].as_str().expect("path");
    assert!(
        printed.contains(&format!("model:          {path} (")),
        "Python picked {path}:\n{printed}"
    );
}

/// `python -m fringe.train` as one process, or under torchrun as `procs` processes (gloo).
fn train(run: &Path, out: &Path, procs: usize) -> String {
    let (ok, t) = train_with(run, out, procs, &[]);
    assert!(ok, "{t}");
    t
}

/// `python -m fringe.train` with `more` arguments: whether it succeeded, and what it said.
fn train_with(run: &Path, out: &Path, procs: usize, more: &[&str]) -> (bool, String) {
    let mut cmd = Command::new(python());
    if procs > 1 {
        cmd.args(["-m", "torch.distributed.run", "--standalone"])
            .arg(format!("--nproc_per_node={procs}"))
            .args(["-m", "fringe.train"]);
    } else {
        cmd.args(["-m", "fringe.train"]);
    }
    let o = cmd
        .arg(run)
        .args([
            "--arch",
            "custom",
            "--size",
            "64",
            "--batch",
            "8",
            "--max-steps",
            "4",
        ])
        .args(["--epochs", "1", "--workers", "0", "--log-every", "1"])
        .args(more)
        .arg("--out")
        .arg(out)
        .env("OMP_NUM_THREADS", "1")
        .output()
        .expect("run python -m fringe.train");
    (o.status.success(), text(&o))
}

#[test]
fn a_network_trained_from_python_runs_in_fringe_and_torchrun_trains_what_one_process_does() {
    let dir = scratch("train");
    let (fgl, _, _) = runs();
    let one = dir.join("one.safetensors");
    let two = dir.join("two.safetensors");
    let said = train(&fgl, &one, 1);
    assert!(
        said.contains("step 4/4")
            && said.contains("training custom on")
            && said.contains("presses"),
        "{said}"
    );
    let said = train(&fgl, &two, 2);
    assert!(said.contains("2 process(es)"), "{said}");
    let got = check(&["same-weights", arg(&one), arg(&two)]);
    assert!(
        got["max_difference"].as_f64().expect("difference") <= 1e-5,
        "{got}"
    );
    // fringe runs it: its card says what it is, and its outputs are PyTorch's.
    let csv = dir.join("one.csv");
    let out = fringe(&[
        "eval",
        "--model",
        arg(&one),
        arg(&fgl),
        "--predictions",
        arg(&csv),
    ]);
    let printed = text(&out);
    assert!(out.status.success(), "{printed}");
    assert!(printed.contains("custom"), "{printed}");
    let got = check(&["torch-vs-fringe", arg(&one), arg(&fgl), arg(&csv)]);
    assert!(got["frames"].as_u64().expect("frames") > 20, "{got}");
    // A card that does not match the weights: refused by fringe and by the package alike.
    let card = dir.join("one.json");
    let text_card = std::fs::read_to_string(&card).expect("card");
    let mut c: serde_json::Value = serde_json::from_str(&text_card).expect("card json");
    c["classes"] = serde_json::json!(["None", "pentagon", "rectangle", "sphere"]);
    std::fs::write(&card, c.to_string()).expect("card");
    let out = fringe(&["eval", "--model", arg(&one), arg(&fgl)]);
    assert!(!out.status.success(), "{}", text(&out));
    let refused = text(&out);
    let got = check(&["bad-card", arg(&one)]);
    let m = got["message"].as_str().expect("message");
    assert!(
        m.contains("one.json") || m.contains("one.safetensors"),
        "{m}\n{refused}"
    );
}

#[test]
fn webdataset_shards_hold_every_frame_and_label_and_stream_in_webdataset() {
    let dir = scratch("shards");
    let (fgl, png, _) = runs();
    let out = dir.join("shards");
    let printed = fringe(&[
        "export",
        arg(&fgl),
        arg(&png),
        "--format",
        "webdataset",
        "--shard-size",
        "40",
        "--out",
        arg(&out),
    ]);
    let t = text(&printed);
    assert!(printed.status.success(), "{t}");
    let got = check(&["shards", arg(&out), arg(&fgl), arg(&png)]);
    let sizes: Vec<u64> = got["shards"]
        .as_array()
        .expect("shards")
        .iter()
        .map(|n| n.as_u64().expect("size"))
        .collect();
    let samples = got["samples"].as_u64().expect("samples");
    assert!(sizes.len() >= 3, "{got}");
    assert!(sizes[..sizes.len() - 1].iter().all(|&n| n == 40), "{got}");
    assert_eq!(sizes.iter().sum::<u64>(), samples, "{got}");
    assert!(
        t.contains(&format!(
            "exported {samples} samples in {} shards",
            sizes.len()
        )),
        "{t}"
    );
    // A second export into the same directory is refused before it writes anything.
    let again = fringe(&[
        "export",
        arg(&fgl),
        "--format",
        "webdataset",
        "--out",
        arg(&out),
    ]);
    assert!(!again.status.success());
    assert!(
        text(&again).contains("is not empty: give a new --out directory"),
        "{}",
        text(&again)
    );
}

#[test]
fn the_torch_dataset_splits_by_press_and_makes_the_papers_augmented_copies() {
    let (fgl, _, _) = runs();
    let got = check(&["dataset", arg(&fgl)]);
    assert!(got["presses"].as_u64().expect("presses") >= 1, "{got}");
}

#[test]
fn a_reference_layout_dataset_trains_from_python_as_fringe_train_reads_it() {
    let dir = scratch("reference");
    let ds = dir.join("ds");
    let out = fringe(&[
        "sim",
        "dataset",
        "--sensor",
        "layered",
        "--count",
        "40",
        "--seed",
        "3",
        "--out",
        arg(&ds),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let got = check(&["reference", arg(&ds)]);
    assert_eq!(got["frames"], 40, "{got}");
    // Trained on it, then trained on from those weights (the second stage of a recipe).
    let first = dir.join("first.safetensors");
    let said = train(&ds, &first, 1);
    assert!(said.contains("training custom on"), "{said}");
    let second = dir.join("second.safetensors");
    let (ok, said) = train_with(&ds, &second, 1, &["--init", arg(&first), "--lr", "2e-4"]);
    assert!(ok, "{said}");
    let card: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("second.json")).expect("card"))
            .expect("card json");
    assert_eq!(card["training"]["init"], arg(&first), "{card}");
    assert_eq!(card["variant"], "layered", "{card}");
    // Weights of another architecture are refused, naming the file.
    let (ok, said) = train_with(
        &ds,
        &dir.join("third.safetensors"),
        1,
        &["--init", arg(&first), "--arch", "resnet18"],
    );
    assert!(!ok, "{said}");
    assert!(
        said.contains("first.safetensors") && said.contains("not resnet18"),
        "{said}"
    );
}
