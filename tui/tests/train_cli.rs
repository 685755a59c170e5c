//! `fringe train` (cargo feature `torch`) on a small dataset made by `fringe sim dataset`: the
//! loss falls, the split keeps presses on one side, a resumed training ends where an
//! uninterrupted one does, Ctrl-C saves a checkpoint and says how to resume, and the
//! checkpoints load in PyTorch (the reference classes, strict) and in the default backend with
//! equal outputs, for both architectures.
#![cfg(feature = "torch")]

mod common;
use common::{arg, coarse_sensor, fringe, fringe_command, scratch, shared, text};
use fringe_sensor_models::read_safetensors;
use fringe_sensor_models::Model;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::OnceLock;

/// One dataset for every test of this file: 60 frames of the layered sensor (a coarser
/// fringe-field grid keeps the renderer's start short in a debug build), forces up to 4 N;
/// rendered once per build of `fringe` and shared by the tests' processes.
fn data() -> &'static Path {
    static DATA: OnceLock<PathBuf> = OnceLock::new();
    DATA.get_or_init(|| {
        shared("train_cli-data", |dir| {
            let sensor = coarse_sensor(dir, "layered");
            let o = fringe(&[
                "sim",
                "dataset",
                "--sensor",
                arg(&sensor),
                "--count",
                "60",
                "--seed",
                "3",
                "--force-max",
                "4",
                "--out",
                arg(&dir.join("sim")),
            ]);
            assert!(o.status.success(), "{}", text(&o));
        })
        .join("sim")
    })
}

/// One libtorch thread for every training here: the real-time bench tests that run beside
/// these (three tests at a time on 2 cores) keep a core, and their F/T streams no gaps.
const THREADS: [&str; 2] = ["--threads", "1"];

fn train(out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "train",
        THREADS[0],
        THREADS[1],
        arg(data()),
        "--batch",
        "8",
        "--input-size",
        "64",
        "--pipeline",
        "rgb3-clean",
        "--out",
        arg(out),
    ];
    args.extend_from_slice(extra);
    fringe(&args)
}

/// The card's training record.
fn record(model: &Path) -> serde_json::Value {
    let card = std::fs::read_to_string(format!("{}.json", model.display())).expect("card");
    let v: serde_json::Value = serde_json::from_str(&card).expect("card json");
    v["training"].clone()
}

fn max_abs_diff(a: &Path, b: &Path) -> f32 {
    let (a, b) = (
        read_safetensors(a).expect("a"),
        read_safetensors(b).expect("b"),
    );
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    a.iter()
        .map(|(k, t)| {
            let u = b.get(k).expect("key");
            t.data
                .iter()
                .zip(&u.data)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f32::max)
        })
        .fold(0.0, f32::max)
}

#[test]
fn training_lowers_the_loss_and_a_resumed_training_ends_where_a_straight_one_does() {
    let dir = scratch("resume");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let o = train(&a, &["--epochs", "4"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(
        out.contains("split by press") && out.contains("Fz RMSE"),
        "{out}"
    );
    for f in [
        "split.json",
        "loss.png",
        "checkpoint_epoch_2.safetensors",
        "checkpoint_epoch_2.safetensors.json",
        "checkpoint_epoch_2.optimizer.safetensors",
        "checkpoint_epoch_4.safetensors",
        "model.safetensors",
        "model.safetensors.json",
    ] {
        assert!(a.join(f).is_file(), "{f} missing: {out}");
    }
    let model = a.join("model.safetensors");
    let r = record(&model);
    let history = r["history"].as_array().expect("history");
    assert_eq!(history.len(), 4);
    let loss = |k: usize| history[k]["train_loss"].as_f64().expect("loss");
    let fz = |k: usize| history[k]["val_fz_rmse_n"].as_f64().expect("fz rmse");
    // The contact term (mm^2) dominates the loss and falls slowly; the force is learnt first.
    assert!(loss(3) < loss(0), "the loss did not fall: {history:?}");
    assert!(
        fz(3) < 0.8 * fz(0),
        "the validation Fz error did not fall: {history:?}"
    );
    assert!(r["evaluation"]["fz_rmse_n"].as_f64().is_some(), "{r}");

    // The split: every frame on one side, sides disjoint, the frame counts add up.
    let split: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("split.json")).expect("split"))
            .expect("json");
    let side = |k: &str| -> std::collections::BTreeSet<String> {
        split[k]
            .as_array()
            .expect(k)
            .iter()
            .map(|v| v.as_str().expect("press").to_string())
            .collect()
    };
    let (tr, va, te) = (side("train"), side("val"), side("test"));
    assert!(tr.is_disjoint(&va) && tr.is_disjoint(&te) && va.is_disjoint(&te));
    assert_eq!(tr.len() + va.len() + te.len(), 60);
    assert!(!va.is_empty() && !te.is_empty());

    // Two epochs, then resumed for two more: the same weights as four straight.
    let o = train(&b, &["--epochs", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let o = fringe(&[
        "train",
        THREADS[0],
        THREADS[1],
        "--resume",
        arg(&b.join("checkpoint_epoch_2.safetensors")),
        "--epochs",
        "4",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let d = max_abs_diff(&model, &b.join("model.safetensors"));
    assert!(
        d < 1e-5,
        "resumed weights differ from the straight run's by {d}"
    );
    // And the same losses, epoch by epoch.
    let resumed = record(&b.join("model.safetensors"))["history"].clone();
    for k in 0..4 {
        for key in ["train_loss", "val_loss"] {
            let (x, y) = (
                history[k][key].as_f64().expect(key),
                resumed[k][key].as_f64().expect(key),
            );
            assert!(
                (x - y).abs() < 1e-5 * x.abs().max(1.0),
                "epoch {} {key}: {x} straight, {y} resumed",
                k + 1
            );
        }
    }

    // --init starts from trained weights (fine-tuning): its first epoch starts where the
    // four-epoch model ended, far below a random start, and the card names the weights.
    let c = dir.join("c");
    let o = train(
        &c,
        &["--epochs", "1", "--lr", "2e-4", "--init", arg(&model)],
    );
    assert!(o.status.success(), "{}", text(&o));
    let tuned = record(&c.join("model.safetensors"));
    let first = tuned["history"][0]["train_loss"].as_f64().expect("loss");
    assert!(
        first < loss(0) && first < 1.5 * loss(3),
        "a fine-tuning's first epoch ({first}) should start near the model's last ({}), not at a random start's ({})",
        loss(3),
        loss(0)
    );
    assert_eq!(tuned["init"].as_str(), Some(arg(&model)), "{tuned}");
    let o = train(
        &dir.join("d"),
        &["--init", arg(&dir.join("absent.safetensors"))],
    );
    assert!(!o.status.success());
    assert!(text(&o).contains("absent.safetensors"), "{}", text(&o));

    // fringe eval reads the model with its card and the dataset with its profile.
    let o = fringe(&["eval", "--model", arg(&model), arg(data())]);
    assert!(
        o.status.success() && text(&o).contains("shape accuracy"),
        "{}",
        text(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ctrl_c_saves_a_checkpoint_and_the_training_resumes_from_it() {
    let dir = scratch("interrupt");
    let out = dir.join("t");
    let mut child = fringe_command()
        .args([
            "train",
            THREADS[0],
            THREADS[1],
            arg(data()),
            "--batch",
            "4",
            "--input-size",
            "64",
            "--epochs",
            "50",
            "--out",
            arg(&out),
        ])
        .stderr(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn");
    let stderr = child.stderr.take().expect("stderr");
    let mut lines = BufReader::new(stderr).lines();
    let mut seen = Vec::new();
    for line in lines.by_ref() {
        let line = line.expect("line");
        seen.push(line.clone());
        if line.starts_with("epoch 1:") {
            break;
        }
    }
    // SAFETY: a signal to our own child.
    unsafe {
        libc::kill(child.id() as libc::pid_t, libc::SIGINT);
    }
    seen.extend(lines.map_while(Result::ok));
    let status = child.wait().expect("wait");
    let all = seen.join("\n");
    assert_eq!(status.code(), Some(130), "{all}");
    let resume = all
        .lines()
        .find_map(|l| l.strip_prefix("resume with: fringe train --resume "))
        .unwrap_or_else(|| panic!("no resume line: {all}"));
    assert!(Path::new(resume).is_file(), "{resume}");
    let epochs_done = record(Path::new(resume))["epoch"].as_u64().expect("epoch");
    let o = fringe(&[
        "train",
        THREADS[0],
        THREADS[1],
        "--resume",
        resume,
        "--epochs",
        &(epochs_done + 1).to_string(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(out.join("model.safetensors").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs the checkpoint in PyTorch (reference classes, strict load) and in the default backend.
fn pytorch_agrees(model: &Path, arch: &str, dir: &Path) {
    let python = std::env::var("FRINGE_TORCH_PYTHON").unwrap_or_else(|_| "python3".into());
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sensor-models/tests/python/check_trained.py");
    let o = std::process::Command::new(&python)
        .arg(&script)
        .args([arg(model), arch, arg(dir), "64"])
        .output()
        .expect("run python (FRINGE_TORCH_PYTHON)");
    assert!(o.status.success(), "{}", text(&o));
    let expected: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("expected.json")).expect("expected"),
    )
    .expect("json");
    let bytes = std::fs::read(dir.join("inputs.f32")).expect("inputs");
    let x: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let m = Model::open(model).expect("open model");
    let mut backend = m.tract(1).expect("tract");
    let raw = backend.run(&x, 2, 64).expect("run");
    let flat = |k: &str| -> Vec<f32> {
        expected[k]
            .as_array()
            .expect(k)
            .iter()
            .flat_map(|r| {
                r.as_array()
                    .expect("row")
                    .iter()
                    .map(|v| v.as_f64().expect("num") as f32)
            })
            .collect()
    };
    let got_force: Vec<f32> = raw.force.iter().flatten().copied().collect();
    let got_logits: Vec<f32> = raw.shape_logits.iter().flatten().copied().collect();
    let got_contact: Vec<f32> = raw.contact.iter().flatten().copied().collect();
    for (name, got, want) in [
        ("force", &got_force, flat("force")),
        ("shape_logits", &got_logits, flat("shape_logits")),
        ("contact", &got_contact, flat("contact")),
    ] {
        assert_eq!(got.len(), want.len(), "{name}");
        let d = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(
            d < 1e-4,
            "{arch} {name}: the default backend differs from PyTorch by {d}"
        );
    }
}

#[test]
fn checkpoints_load_in_pytorch_and_the_default_backend_with_equal_outputs() {
    let dir = scratch("pytorch");
    for arch in ["custom", "resnet18"] {
        let out = dir.join(arch);
        let o = train(&out, &["--epochs", "2", "--arch", arch]);
        assert!(o.status.success(), "{}", text(&o));
        let model = out.join("model.safetensors");
        let h = record(&model)["history"].clone();
        let loss = |k: usize| h[k]["train_loss"].as_f64().expect("loss");
        assert!(loss(1) < loss(0), "{arch}: the loss did not fall: {h}");
        pytorch_agrees(&model, arch, &out.join("pytorch"));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_settings_are_refused_naming_the_flag() {
    for (args, flag) in [
        (vec!["--epochs", "0"], "--epochs"),
        (vec!["--lr", "nan"], "--lr"),
        (vec!["--batch", "0"], "--batch"),
        (vec!["--pipeline", "grey10"], "gray10"),
        (vec!["--arch", "vgg"], "use custom, resnet18, keypoint"),
    ] {
        let mut all = vec!["train", "no-such-dir"];
        all.extend(args);
        let o = fringe(&all);
        assert!(!o.status.success());
        assert!(text(&o).contains(flag), "{flag}: {}", text(&o));
    }
    let o = fringe(&["train", "no-such-dir", "--epochs", "1"]);
    assert!(
        !o.status.success() && text(&o).contains("no-such-dir: no such run or dataset"),
        "{}",
        text(&o)
    );
}

/// Full fine-tuning (commissioning's `--fine-tune`) of the shipped layered keypoint CNN on the
/// dataset with a fold of presses held out: stopped by the operator after its first batch it
/// leaves a checkpoint, resumed from it it finishes; both candidates are scored on the held-out
/// presses, the fine-tuned one is kept only when it did better, the held-out presses never
/// trained, and the finished outcome is found again in its directory.
#[test]
fn fine_tuning_stops_resumes_and_keeps_the_better_candidate() {
    use fringe_sensor_models::adapt::held_out_presses;
    use fringe_sensor_models::TrainEvent;
    use fringe_sensor_models::{
        fine_tune, finished_fine_tune as finished, FineTuneConfig, FineTuneEvent, FineTuneOutcome,
    };
    use std::sync::atomic::{AtomicBool, Ordering};
    let dir = scratch("fine-tune");
    let out = dir.join("fine-tune");
    let base = fringe_sensor_models::builtin::open(Path::new("builtin:layered-keypoint"))
        .expect("the shipped base");
    let source = fringe_sensor_models::dataset::read(data()).expect("dataset");
    let held = held_out_presses(&source.samples, 5, 42);
    let config = FineTuneConfig {
        epochs: 2,
        batch: 8,
        threads: 1,
        ..FineTuneConfig::default()
    };
    let sources = [source];
    // `stop_at_batch`: the operator stops it once a batch has trained (as Ctrl-C is heard).
    let run = |resume: Option<&Path>, stop_at_batch: bool| {
        let stop = AtomicBool::new(false);
        let mut events = |e: FineTuneEvent| {
            if stop_at_batch && matches!(e, FineTuneEvent::Train(TrainEvent::Batch { .. })) {
                stop.store(true, Ordering::Relaxed);
            }
        };
        fine_tune(
            &base,
            &sources,
            &held,
            &config,
            &out,
            resume,
            &stop,
            &mut events,
        )
        .expect("fine-tune")
    };
    let checkpoint = match run(None, true) {
        FineTuneOutcome::Interrupted { checkpoint } => checkpoint,
        FineTuneOutcome::Finished(_) => panic!("the stop was not heard"),
    };
    assert!(checkpoint.is_file(), "{}", checkpoint.display());
    assert!(
        finished(&out).is_none(),
        "an interrupted fine-tuning counts as finished"
    );
    let done = match run(Some(&checkpoint), false) {
        FineTuneOutcome::Finished(done) => done,
        FineTuneOutcome::Interrupted { .. } => panic!("stopped again"),
    };
    assert_eq!(
        done.kept,
        done.fine_tuned.spec_units < done.heads_only.spec_units,
        "{done:?}"
    );
    assert_eq!(done.held_out_presses, held.len());
    assert_eq!(done.history.len(), 2, "{done:?}");
    assert!(!done.augmented && done.frozen_batch_norm, "{done:?}");
    // The held-out presses are on neither training side of the split it trained with.
    let split: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("split.json")).expect("split"))
            .expect("split json");
    let train: Vec<&str> = split["train"]
        .as_array()
        .expect("train")
        .iter()
        .filter_map(|p| p.as_str())
        .collect();
    assert!(held.iter().all(|p| !train.contains(&p.as_str())), "{split}");
    let again = finished(&out).expect("the finished outcome");
    assert_eq!(again.fine_tuned, done.fine_tuned);
    assert!(again.model.is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A force network (`--force-window`) trains on the presses alone, reads Fz from a window about
/// the contact, and is refused on its own; trained as the keypoint CNN it also reads where the
/// press lies in its window (a contact network). `fringe model pair` joins both to the shipped
/// keypoint CNN, and the two-stage model keeps the keypoint CNN's shape while its force is the
/// force network's and its contact the keypoint CNN's moved within the window, in `fringe model
/// run` and in `fringe eval` alike.
#[test]
fn a_force_window_network_pairs_with_a_contact_model_into_one_two_stage_model() {
    let dir = scratch("force-window");
    let out = dir.join("force");
    let o = train(&out, &["--epochs", "2", "--force-window", "12"]);
    assert!(o.status.success(), "{}", text(&o));
    let said = text(&o);
    assert!(said.contains("fringe model pair"), "{said}");
    let force = out.join("model.safetensors");
    let card: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{}.json", force.display())).expect("card"),
    )
    .expect("card json");
    assert_eq!(card["force_window_mm"], 12.0, "{card}");
    // The custom CNN's global average keeps no position: it reads the force alone.
    assert!(card.get("refines_contact").is_none(), "{card}");
    assert!(!said.contains("contact RMSE:"), "{said}");
    let r = &card["training"];
    assert_eq!(r["force_window_mm"], 12.0);
    let centre = r["evaluation"]["window_centre"]
        .as_str()
        .unwrap_or_default();
    assert!(
        centre.starts_with("the labelled contact moved by 0.7 mm"),
        "{r}"
    );

    // The keypoint CNN on the same windows reads the press's offset too: a contact network.
    let placer = dir.join("contact");
    let o = train(
        &placer,
        &[
            "--epochs",
            "2",
            "--force-window",
            "12",
            "--arch",
            "keypoint",
        ],
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("contact RMSE:"), "{}", text(&o));
    let placer = placer.join("model.safetensors");
    let placer_card: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{}.json", placer.display())).expect("card"),
    )
    .expect("card json");
    assert_eq!(placer_card["refines_contact"], true, "{placer_card}");
    assert!(
        placer_card["training"]["evaluation"]["contact_rmse_mm"].is_f64(),
        "{placer_card}"
    );
    // Only frames in contact train a force network: fewer than the whole data's.
    let frames = |k: &str| r[k].as_u64().expect(k);
    assert!(
        frames("train_frames") + frames("val_frames") + frames("test_frames") < 60,
        "{r}"
    );

    // Alone it is refused, saying what to do.
    let o = fringe(&["eval", arg(data()), "--model", arg(&force)]);
    assert!(!o.status.success());
    assert!(text(&o).contains("fringe model pair"), "{}", text(&o));

    // A network that reads no offset is no contact network.
    let o = fringe(&[
        "model",
        "pair",
        "builtin:layered-keypoint",
        arg(&force),
        "--contact",
        arg(&force),
        "--out",
        arg(&dir.join("refused")),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("refines_contact"), "{}", text(&o));
    assert!(
        !dir.join("refused").exists(),
        "a refused pair writes nothing"
    );

    let pair = dir.join("pair");
    let o = fringe(&[
        "model",
        "pair",
        "builtin:layered-keypoint",
        arg(&force),
        "--contact",
        arg(&placer),
        "--out",
        arg(&pair),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let two = pair.join("model.safetensors");

    // One frame in contact, read by both models.
    let labels = std::fs::read_to_string(data().join("0.labels.csv")).expect("labels");
    let pressed = labels
        .lines()
        .skip(1)
        .find(|l| l.contains("pentagon") || l.contains("rectangle"))
        .and_then(|l| l.split(',').find(|f| f.ends_with(".png")))
        .expect("a frame in contact");
    let image = data().join("0.images").join(pressed);
    let profile = data().join("profile.toml");
    let run = |model: &Path, image: &Path| -> serde_json::Value {
        let o = fringe(&[
            "model",
            "run",
            arg(model),
            arg(image),
            "--profile",
            arg(&profile),
            "--json",
        ]);
        assert!(o.status.success(), "{}", text(&o));
        serde_json::from_slice(&o.stdout).expect("json line")
    };
    let (alone, both) = (
        run(Path::new("builtin:layered-keypoint"), &image),
        run(&two, &image),
    );
    assert_eq!(alone["shape"], both["shape"]);
    // The contact is moved within the 12 mm window about the keypoint CNN's.
    let xy = |v: &serde_json::Value| -> [f64; 2] {
        let c = v["contact_mm"].as_array().expect("a contact");
        [0, 1].map(|i| c[i].as_f64().expect("mm"))
    };
    let (a, b) = (xy(&alone), xy(&both));
    assert_ne!(a, b, "{alone} {both}");
    assert!(
        (a[0] - b[0]).abs() < 6.0 && (a[1] - b[1]).abs() < 6.0,
        "{alone} {both}"
    );
    assert_ne!(alone["force"]["fz"], both["force"]["fz"], "{alone} {both}");
    // A frame the first network finds without contact reads no force.
    let at_rest = labels
        .lines()
        .skip(1)
        .find(|l| l.contains(",None"))
        .and_then(|l| l.split(',').find(|f| f.ends_with(".png")))
        .expect("a frame without contact");
    let rest = run(&two, &data().join("0.images").join(at_rest));
    assert_eq!(rest["shape"], "None", "{rest}");
    assert_eq!(rest["force"]["fz"], 0.0, "{rest}");

    // Evaluation takes the same path: the keypoint CNN's shape figures, the force network's Fz
    // and its contact.
    let figures = |model: &Path| -> String {
        let o = fringe(&["eval", arg(data()), "--model", arg(model)]);
        assert!(o.status.success(), "{}", text(&o));
        text(&o)
    };
    let line = |t: &str, k: &str| -> String {
        t.lines()
            .find(|l| l.contains(k))
            .unwrap_or_else(|| panic!("no {k} in {t}"))
            .to_string()
    };
    let (a, b) = (
        figures(Path::new("builtin:layered-keypoint")),
        figures(&two),
    );
    assert_ne!(line(&a, "contact RMSE"), line(&b, "contact RMSE"), "{b}");
    assert_eq!(line(&a, "shape accuracy"), line(&b, "shape accuracy"));
    assert_ne!(line(&a, "Fz RMSE"), line(&b, "Fz RMSE"), "{b}");

    // A contact network alone moves the contact and keeps the first network's force (the
    // integrated sensor's force lives in rings across the whole disc).
    let placed = dir.join("placed");
    let o = fringe(&[
        "model",
        "pair",
        "builtin:layered-keypoint",
        "--contact",
        arg(&placer),
        "--out",
        arg(&placed),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("the first network's, on the whole disc"),
        "{}",
        text(&o)
    );
    assert!(!placed.join("force.safetensors").exists());
    let moved = run(&placed.join("model.safetensors"), &image);
    assert_eq!(moved["contact_mm"], both["contact_mm"], "{moved} {both}");
    assert_eq!(moved["force"], alone["force"], "{moved} {alone}");
    let o = fringe(&[
        "model",
        "pair",
        "builtin:layered-keypoint",
        "--out",
        arg(&placed),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("--contact"), "{}", text(&o));
    let _ = std::fs::remove_dir_all(&dir);
}
