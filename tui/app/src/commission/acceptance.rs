//! Steps 4 and 5 of commissioning: the adapted model written with its card, the acceptance scan
//! at held-out positions (between the lattice the rounds press on), the whole network evaluated
//! on it and judged against the spec, the report and the certificate.

use super::certificate::{
    Certificate, CurvePoint, Figures, ModelRef, UsedRuns, CERTIFICATE_FORMAT, MODEL, PROFILE,
};
use super::journal::ScanEntry;
use super::press_choice::{choose, tour, PressedPoint, UsableDisc, LATTICE_MM};
use super::press_plan::{disc_margin, press_plan};
use super::pruning::prune_rounds;
use super::rounds::{shapes, Adaptation};
use super::scans::{estimate_s, scan, set_aside, Commissioning};
use crate::models::adapted_card::{adapted_card, write_adapted};
use crate::models::choice::open_model;
use crate::models::verdict;
use crate::session::scan::ProfileUse;
use crate::workflow_error::{Context, WorkflowError};
use fringe_calibration::Profile;
use fringe_plot::html::Page;
use fringe_plot::palette::{green_to_red, BLUE, GREY, ORANGE};
use fringe_plot::{Axis, Chart, Corner, Series};
use fringe_sensor_models::dataset;
use fringe_sensor_models::eval::{evaluate, Evaluation};
use fringe_sensor_models::report;
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::Model;
use fringe_sensor_models::Predictor;
use fringe_sensor_models::{judge, Verdict};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

type Result<T> = std::result::Result<T, WorkflowError>;

/// How the acceptance ended: the verdict and where the certificate and the model are.
pub struct Accepted {
    pub sensor: String,
    pub pass: bool,
    /// The checks the unit failed, in words (empty when it passed).
    pub failures: Vec<String>,
    pub spec_origin: String,
    pub certificate: PathBuf,
    pub model: PathBuf,
}

/// Steps 4 and 5: the verdict, after the certificate and the report are written.
pub(crate) fn accept(
    c: &mut Commissioning<'_>,
    base: &Model,
    profile: &Profile,
    adaptation: Adaptation,
) -> Result<Accepted> {
    let model_path = write_model(c, base, &adaptation)?;
    let entry = acceptance_entry(c, base, profile)?;
    let line = format!(
        "step 4: acceptance at {} held-out positions",
        c.journal.options.acceptance_presses
    );
    c.say(line);
    let (run_dir, took) = scan(c, &entry, ProfileUse::Consume)?;
    if let Some(e) = c.journal.acceptance.as_mut() {
        e.took_s = Some(e.took_s.unwrap_or(0.0) + took);
    }
    c.journal.write(&c.dir)?;
    let started = Instant::now();
    let model = open_model(&model_path)?;
    if let Some(w) = model.missing_card_warning() {
        c.host.notice(format!("warning: {w}"));
    }
    // The scan is complete when the model was evaluated on it: one whose frames cannot be used
    // is kept aside and pressed again on resume, never taken as done.
    let (eval, presses) = match evaluated(c, &model, &run_dir) {
        Ok(done) => done,
        Err(e) => {
            let kept = set_aside(&run_dir)?;
            return Err(e.context(format!(
                "the acceptance scan could not be evaluated (it is kept as {} and pressed again when the commissioning is resumed: fringe commission --resume {})",
                kept.display(),
                c.dir.display()
            )));
        }
    };
    if let Some(e) = c.journal.acceptance.as_mut() {
        e.completed = true;
    }
    c.journal.write(&c.dir)?;
    c.compute_s += started.elapsed().as_secs_f64();
    let v = judge(&eval, &c.spec);
    let cert = certificate(c, base, &adaptation, &eval, &v, &run_dir, presses)?;
    write_report(c, &cert, &eval, &adaptation, &v)?;
    let path = cert.write(&c.dir)?;
    for line in verdict::lines(&v) {
        c.say(line);
    }
    if v.pass && !c.keep_runs {
        prune_rounds(c, &adaptation.runs)?;
    }
    c.say(format!("wrote {}", path.display()));
    c.say(format!("wrote {}", c.dir.join("report.md").display()));
    c.say(format!(
        "wrote {} (one file: opens in any browser)",
        c.dir.join("report.html").display()
    ));
    Ok(Accepted {
        sensor: cert.sensor_id,
        pass: v.pass,
        failures: v.failures(),
        spec_origin: cert.spec_origin,
        certificate: path,
        model: model_path,
    })
}

/// `model` evaluated on the acceptance run `run_dir`, and the presses it holds.
fn evaluated(
    c: &mut Commissioning<'_>,
    model: &Model,
    run_dir: &Path,
) -> Result<(Evaluation, usize)> {
    let source = dataset::read(run_dir)?;
    let presses = {
        let mut p: Vec<&str> = source.samples.iter().map(|s| s.press.as_str()).collect();
        p.sort_unstable();
        p.dedup();
        p.len()
    };
    let mut predictor = Predictor::new(model, BackendKind::Tract, c.threads)?;
    let host = &mut *c.host;
    let eval = evaluate(model, &mut predictor, &[source], None, None, |d, t| {
        host.frames("evaluating the acceptance scan", d, t)
    })?;
    Ok((eval, presses))
}

/// The adapted model in the directory, with its card beside it and in it.
fn write_model(c: &mut Commissioning<'_>, base: &Model, a: &Adaptation) -> Result<PathBuf> {
    let path = c.dir.join(MODEL);
    let mut card = adapted_card(
        base,
        &a.adapted,
        &a.runs,
        5,
        c.journal.options.seed,
        Some(&c.journal.options.sensor),
    );
    if let Some(serde_json::Value::Object(adaptation)) = card.other.get_mut("adaptation") {
        adaptation.insert("method".into(), a.method().name().into());
        if let Some(f) = &a.fine_tune {
            adaptation.insert("fine_tune".into(), f.record.clone());
        }
        if let Some(b) = &a.block {
            adaptation.insert(
                "last_block".into(),
                serde_json::json!({
                    "about": "the custom CNN's last convolution block trained again with the heads (pure Rust, Adam, pulled towards the base), one fold of presses held out; the epoch with the least held-out error kept, epoch 0 being the heads alone",
                    "epoch_kept": b.epoch,
                    "held_out_presses": b.held_out_presses,
                    "train_frames": b.train_frames,
                    "heads_only_held_out": b.heads_only,
                    "kept_held_out": b.kept,
                    "held_out_curve": b.curve,
                }),
            );
        }
    }
    write_adapted(&path, a.weights(), &card)?;
    c.say(format!(
        "step 3: adapted {} on {} frames of {} presses: wrote {}",
        base.path.display(),
        a.adapted.frames,
        a.adapted.presses,
        path.display()
    ));
    for h in &a.adapted.heads {
        c.say(format!(
            "  {:<11} {}: {:.4} before, {:.4} after (cross-validated over presses)",
            h.head, h.figure, h.before, h.after
        ));
    }
    Ok(path)
}

/// The acceptance scan's journal entry: positions between the rounds' lattice, spread over the
/// disc (chosen once, before the scan, and kept).
fn acceptance_entry(
    c: &mut Commissioning<'_>,
    base: &Model,
    profile: &Profile,
) -> Result<ScanEntry> {
    if let Some(e) = &c.journal.acceptance {
        return Ok(e.clone());
    }
    let limits = c.config.limits()?;
    let disc = UsableDisc::from_profile(profile)?;
    let held_out = disc.lattice(LATTICE_MM, 0.5, &limits, &c.journal.options.sensor)?;
    let points = tour(
        &choose(&held_out, &[], c.journal.options.acceptance_presses, 1e6),
        disc.centre_mm,
    );
    let plan = press_plan(
        "acceptance",
        &points,
        &shapes(base),
        &format!(
            "fringe commission, sensor {}: acceptance at {} held-out positions (half a lattice step from every adaptive press)",
            c.journal.options.sensor,
            points.len()
        ),
        disc_margin(profile),
    )?;
    let e = ScanEntry {
        run_id: "acceptance".into(),
        estimate_s: estimate_s(&plan, &c.config)?,
        plan,
        took_s: None,
        completed: false,
    };
    c.journal.acceptance = Some(e.clone());
    c.journal.write(&c.dir)?;
    Ok(e)
}

/// Paths relative to the commissioning directory, for the certificate.
fn relative(dir: &Path, p: &Path) -> String {
    p.strip_prefix(dir).unwrap_or(p).display().to_string()
}

#[allow(clippy::too_many_arguments)]
fn certificate(
    c: &Commissioning<'_>,
    base: &Model,
    a: &Adaptation,
    eval: &Evaluation,
    v: &Verdict,
    acceptance: &Path,
    presses: usize,
) -> Result<Certificate> {
    let all = &eval.metrics.all;
    let bench_s: f64 = [&c.journal.calibration, &c.journal.acceptance]
        .into_iter()
        .flatten()
        .chain(c.journal.rounds.iter())
        .map(|e| e.took_s.unwrap_or(0.0))
        .sum();
    Ok(Certificate {
        format: CERTIFICATE_FORMAT,
        fringe_version: env!("CARGO_PKG_VERSION").to_string(),
        issued_utc: fringe_rig::store::now_utc(),
        sensor_id: c.journal.options.sensor.clone(),
        variant: base.card.as_ref().and_then(|card| card.variant.clone()),
        pass: v.pass,
        failures: v.failures(),
        figures: Figures {
            fz_rmse_n: all.fz_rmse(),
            contact_rmse_mm: all.contact_rmse(),
            shape_accuracy: all.accuracy(),
            macro_f1: eval.metrics.macro_scores().f1,
            frames: all.n,
            presses,
        },
        verdict: serde_json::to_value(v).context("the verdict")?,
        spec: serde_json::to_value(&c.spec).context("the spec")?,
        spec_origin: c.journal.options.spec_origin.clone(),
        base_model: ModelRef::of(Path::new(&c.journal.options.base), base.describe())?,
        model: MODEL.to_string(),
        adaptation: a.method().about().into(),
        profile: PROFILE.to_string(),
        runs: UsedRuns {
            calibration: c
                .journal
                .calibration
                .as_ref()
                .map(|e| format!("runs/{}", e.run_id))
                .unwrap_or_default(),
            rounds: a.runs.iter().map(|r| relative(&c.dir, r)).collect(),
            acceptance: relative(&c.dir, acceptance),
        },
        learning_curve: a.curve.clone(),
        bench_s,
        compute_s: c.compute_s,
    })
}

/// `report.md` (the evaluation's report with the commissioning's verdict, learning curve and
/// press map before it) and its plots, and the same as one self-contained page, `report.html`
/// (the verdict, the spec and its checks, the weak cells, the plots embedded).
fn write_report(
    c: &Commissioning<'_>,
    cert: &Certificate,
    eval: &Evaluation,
    a: &Adaptation,
    v: &Verdict,
) -> Result<()> {
    let title = format!("Acceptance of sensor {}", cert.sensor_id);
    let path = report::write(&c.dir, &title, eval)?;
    let evaluation = std::fs::read_to_string(&path).unwrap_or_default();
    let curve = |f: fn(&CurvePoint) -> f64| -> Vec<[f64; 2]> {
        a.curve
            .iter()
            .map(|p| [p.presses_before as f64, f(p)])
            .collect()
    };
    let fz = curve(|p| p.fz_rmse_n);
    let contact = curve(|p| p.contact_rmse_mm);
    let presses = || Axis::new("presses adapted on").integers().from_zero();
    let learning = fringe_plot::panels(
        &[
            Chart::new(
                "Fz error on unseen presses",
                presses(),
                Axis::new("Fz RMSE (N)").from_zero(),
            )
            .series(Series::line("", &fz, BLUE).with_markers()),
            Chart::new(
                "Contact error on unseen presses",
                presses(),
                Axis::new("contact RMSE (mm)").from_zero(),
            )
            .series(Series::line("", &contact, ORANGE).with_markers()),
        ],
        2,
        (640, 480),
    )
    .context("learning.png")?;
    learning
        .save(c.dir.join("learning.png"))
        .context("learning.png")?;
    let presses_png = press_map(&a.pressed, &a.disc).context("presses.png")?;
    presses_png
        .save(c.dir.join("presses.png"))
        .context("presses.png")?;
    write_html(c, cert, eval, a, v, &learning, &presses_png)?;
    let mut md = format!(
        "# Commissioning of sensor {}\n\nVerdict: **{}** against {}.\n\n",
        cert.sensor_id,
        if cert.pass { "PASS" } else { "FAIL" },
        cert.spec_origin
    );
    for f in &cert.failures {
        let _ = writeln!(md, "- fails: {f}");
    }
    let _ = write!(
        md,
        "\nHeld-out acceptance ({} presses, {} frames): Fz RMSE {:.3} N, contact RMSE {:.2} mm, shape accuracy {:.1} %, macro F1 {:.3}.\n\nBase model {} (sha256 {}); bench time {:.0} s, computation {:.0} s; fringe {}.\n\n## Learning curve\n\nEach round's presses predicted by the model adapted on every press before them.\n\n![learning curve](learning.png)\n\n| round | presses before | frames | Fz RMSE, N | contact RMSE, mm | shape accuracy |\n|---|---|---|---|---|---|\n",
        cert.figures.presses,
        cert.figures.frames,
        cert.figures.fz_rmse_n,
        cert.figures.contact_rmse_mm,
        100.0 * cert.figures.shape_accuracy,
        cert.figures.macro_f1,
        cert.base_model.path,
        cert.base_model.sha256,
        cert.bench_s,
        cert.compute_s,
        cert.fringe_version
    );
    for p in &a.curve {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.3} | {:.2} | {:.1} % |",
            p.round,
            p.presses_before,
            p.frames,
            p.fz_rmse_n,
            p.contact_rmse_mm,
            100.0 * p.shape_accuracy
        );
    }
    md.push_str("\n## Presses\n\nEach adaptive press where it was made, its error before adaptation in the spec's units (green at or under the threshold, red at three times it and over).\n\n![presses](presses.png)\n\n");
    md.push_str(&evaluation.replacen("# ", "## ", 1));
    std::fs::write(&path, md).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// `report.html`: the commissioning on one page that opens anywhere (nothing fetched).
fn write_html(
    c: &Commissioning<'_>,
    cert: &Certificate,
    eval: &Evaluation,
    a: &Adaptation,
    v: &Verdict,
    learning: &image::RgbImage,
    presses: &image::RgbImage,
) -> Result<()> {
    let path = c.dir.join("report.html");
    let mut page = Page::new(format!("Commissioning of sensor {}", cert.sensor_id));
    report::verdict_html(&mut page, v, &cert.spec_origin);
    page.heading("The unit and the job");
    let f = &cert.figures;
    page.table(
        &["", ""],
        &[
            vec!["sensor".to_string(), cert.sensor_id.clone()],
            vec![
                "design".to_string(),
                cert.variant.clone().unwrap_or_else(|| "not known".into()),
            ],
            vec!["issued (UTC)".to_string(), cert.issued_utc.clone()],
            vec!["fringe".to_string(), cert.fringe_version.clone()],
            vec!["adapted model".to_string(), c.dir.join(&cert.model).display().to_string()],
            vec!["adaptation".to_string(), cert.adaptation.clone()],
            vec![
                "base model".to_string(),
                format!("{} (sha256 {})", cert.base_model.path, cert.base_model.sha256),
            ],
            vec![
                "held-out acceptance".to_string(),
                format!(
                    "{} presses, {} frames: Fz RMSE {:.3} N, contact RMSE {:.2} mm, shape accuracy {:.1} %, macro F1 {:.3}",
                    f.presses,
                    f.frames,
                    f.fz_rmse_n,
                    f.contact_rmse_mm,
                    100.0 * f.shape_accuracy,
                    f.macro_f1
                ),
            ],
            vec![
                "time".to_string(),
                format!("bench {:.0} s, computation {:.0} s", cert.bench_s, cert.compute_s),
            ],
        ],
    );
    page.heading("The spec");
    let mut spec_rows: Vec<Vec<String>> = Vec::new();
    spec_lines("", &cert.spec, &mut spec_rows);
    page.paragraph(&format!("From {}.", cert.spec_origin));
    page.table(&["key", "value"], &spec_rows);
    page.heading("Learning curve");
    page.paragraph(
        "Each round's presses predicted by the model adapted on every press before them.",
    );
    let rows: Vec<Vec<String>> = a
        .curve
        .iter()
        .map(|p| {
            vec![
                p.round.to_string(),
                p.presses_before.to_string(),
                p.frames.to_string(),
                format!("{:.3}", p.fz_rmse_n),
                format!("{:.2}", p.contact_rmse_mm),
                format!("{:.1} %", 100.0 * p.shape_accuracy),
            ]
        })
        .collect();
    page.table(
        &[
            "round",
            "presses before",
            "frames",
            "Fz RMSE (N)",
            "contact RMSE (mm)",
            "shape accuracy",
        ],
        &rows,
    );
    page.image("Learning curve", learning)
        .context("report.html")?;
    page.heading("Presses");
    page.note("The press map is in stage millimetres: where the stage put the indenter, over the usable disc found by the calibration.");
    page.image(
        "Adaptive presses on the stage (stage mm), each coloured by its error before adaptation",
        presses,
    )
    .context("report.html")?;
    report::evaluation_html(&mut page, eval);
    for (caption, img) in [
        ("Predicted against measured Fz (N)", report::fz_plot(eval)),
        (
            "Contact: each labelled contact joined to its prediction (sensor mm)",
            report::contact_plot(eval),
        ),
        (
            "Shape confusion matrix",
            report::confusion_plot(&eval.metrics),
        ),
    ] {
        page.image(caption, &img.context("report.html")?)
            .context("report.html")?;
    }
    std::fs::write(&path, page.finish())
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// A spec (as the certificate keeps it, JSON) as rows of key and value: nested keys joined with
/// dots (`all.fz_rmse_n`), lists numbered, nothing left as JSON text.
fn spec_lines(key: &str, v: &serde_json::Value, out: &mut Vec<Vec<String>>) {
    let join = |k: &str| {
        if key.is_empty() {
            k.to_string()
        } else {
            format!("{key}.{k}")
        }
    };
    match v {
        serde_json::Value::Object(m) => {
            for (k, v) in m {
                spec_lines(&join(k), v, out);
            }
        }
        serde_json::Value::Array(items) if items.is_empty() => {
            out.push(vec![key.to_string(), "none".to_string()]);
        }
        serde_json::Value::Array(items) => {
            for (n, v) in items.iter().enumerate() {
                spec_lines(&join(&(n + 1).to_string()), v, out);
            }
        }
        serde_json::Value::Null => out.push(vec![key.to_string(), "not set".to_string()]),
        other => out.push(vec![key.to_string(), other.to_string()]),
    }
}

/// The adaptive presses on the stage over the usable disc (grey circle, its centre marked), each
/// a dot coloured by its error before adaptation (spec units: green at or under the threshold,
/// red at three times it and over).
fn press_map(
    pressed: &[PressedPoint],
    disc: &UsableDisc,
) -> std::result::Result<image::RgbImage, fringe_plot::PlotError> {
    let colour = |error: f64| green_to_red((error - 1.0) / 2.0);
    let dots: Vec<([f64; 2], [u8; 3])> = pressed
        .iter()
        .map(|p| (p.stage_mm, colour(p.error)))
        .collect();
    let [cx, cy] = disc.centre_mm;
    let half = 1.1 * disc.reach_mm.max(1e-3);
    Chart::new(
        "Adaptive presses: error before adaptation",
        // Room on the right for the legend, clear of the disc.
        Axis::new("stage x (mm)").range(cx - half, cx + 2.2 * half),
        Axis::new("stage y (mm)").range(cy - half, cy + half),
    )
    .equal_aspect()
    .series(Series::circle(
        format!("usable disc ({:.1} mm reach)", disc.reach_mm),
        disc.centre_mm,
        disc.reach_mm,
        GREY,
    ))
    .series(Series::points("disc centre", &[disc.centre_mm], 4, GREY))
    .series(Series::coloured_points(&dots, 8))
    .series(Series::key("error at the threshold or under", colour(1.0)))
    .series(Series::key("error twice the threshold", colour(2.0)))
    .series(Series::key("error three times it or over", colour(3.0)))
    .note(format!("disc centre: stage x {cx:.1} mm, y {cy:.1} mm"))
    .notes_at(Corner::LowerRight)
    .render(940, 640)
}
