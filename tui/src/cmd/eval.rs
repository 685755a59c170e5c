//! `fringe eval [--model MODEL] [--unit FILE|ID] DATA... [--report DIR]`: a model's Table-2 figures on runs or
//! reference-layout datasets.

use super::frames_progress::FramesProgress;
use super::model::{choose_model, say, ReferenceChoice};
use super::unit_arg::UnitArg;
use anyhow::{bail, Context, Result};
use clap::Args;
use fringe_app::models;
use fringe_app::models::ForSensor;
use fringe_app::models::{agreed, read_sources, scale_warnings};
use fringe_calibration::Profile;
use fringe_sensor_models::eval::{evaluate, Evaluation};
use fringe_sensor_models::judge;
use fringe_sensor_models::report;
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::Model;
use fringe_sensor_models::Predictor;
use fringe_sensor_models::Smoothing;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct EvalArgs {
    /// The model: .pth / .pt, .safetensors or .onnx, or `builtin:NAME` (the models that ship
    /// with fringe, README.md "The default models"; `default` is `builtin:layered`). Default: the
    /// commissioned model of the data's sensor (`fringe commission`, under the rig file's
    /// profiles), else its design's two-stage model (`builtin:layered-two-stage`,
    /// `builtin:integrated-two-stage`). A model of another design than the data's is refused.
    #[arg(long)]
    model: Option<PathBuf>,
    /// The unit the data is of (its id or one of its files, as `fringe units` lists them): its
    /// commissioned model is the default. Data that names another sensor is refused.
    #[command(flatten)]
    unit: UnitArg,
    /// Run directories or reference-layout datasets (0.images/ + 0.labels.csv).
    #[arg(required = true)]
    data: Vec<PathBuf>,
    /// Write report.md and its plots here.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Write every frame's label and prediction to this CSV file (one row per frame evaluated,
    /// in order: press, stage position, Fz, shape and contact, true and predicted).
    #[arg(long, value_name = "FILE")]
    predictions: Option<PathBuf>,
    /// Calibration profile for data that carries none (reference-layout datasets).
    #[arg(long, value_name = "FILE")]
    profile: Option<PathBuf>,
    /// Preprocess as the reference code does, for models it trained.
    #[arg(long, value_name = "SENSOR", num_args = 0..=1, default_missing_value = "layered")]
    reference_preprocessing: Option<ReferenceChoice>,
    /// Inference threads (at most the machine's cores are used).
    #[arg(long, default_value_t = 2, value_parser = crate::cmd::arg_values::threads)]
    threads: usize,
    /// Inference backend: tract (built in), onnxruntime (cargo feature `onnxruntime`) or torch
    /// (cargo feature `torch`; also runs TorchScript modules).
    #[arg(long, default_value = "tract")]
    backend: BackendKind,
    /// Judge the figures against a spec: a TOML file of thresholds (README.md, "Acceptance"), or
    /// `paper` for the paper's custom-CNN row; the exit status is 1 when the model fails it.
    #[arg(long, value_name = "FILE|paper")]
    spec: Option<PathBuf>,
    /// Refuse a model without shear heads (its card's `shear`): the tangential force is what
    /// the evaluation is for. Without it a model that has them is scored on shear wherever the
    /// data records it, and one that has none is scored on the rest.
    #[arg(long)]
    shear: bool,
    /// Also give the figures with the force and contact of each frame read from the last N
    /// frames of its press (the least-squares line through their readings, at the frame: causal,
    /// no lag on a steady ramp); the per-frame figures and the spec's verdict stay per frame.
    #[arg(long, value_name = "N")]
    smooth: Option<usize>,
}

pub fn run(a: EvalArgs) -> Result<()> {
    if let Some(report) = &a.report {
        fringe_rig::store::outside_runs(report).context("--report")?;
    }
    if let Some(file) = &a.predictions {
        fringe_rig::store::outside_runs(file).context("--predictions")?;
    }
    let spec = a.spec.as_deref().map(models::load_spec).transpose()?;
    let smoothing = a
        .smooth
        .map(Smoothing::new)
        .transpose()
        .map_err(|e| anyhow::anyhow!("--smooth: {e}"))?;
    let profile = match &a.profile {
        Some(p) => Some(Profile::load(p)?),
        None => None,
    };
    let sources = read_sources(&a.data, "evaluate")?;
    let profiles = models::profiles_dir(&mut say);
    let named = a.unit.named()?;
    let data_unit = agreed(&sources, |s| s.sensor_id.as_deref());
    if let (Some(u), Some(d)) = (&named, data_unit) {
        if u.id != d {
            bail!(
                "--unit {}: the data is of sensor {d}, not {}: give the unit the data was recorded on",
                u.id,
                u.id
            );
        }
    }
    let model = choose_model(
        a.model.as_deref(),
        &ForSensor {
            profiles: &profiles,
            unit: named.as_ref().map(|u| u.id.as_str()).or(data_unit),
            // Evaluation refuses a model of another design source by source too.
            variant: agreed(&sources, |s| s.variant.as_deref())
                .or(named.as_ref().and_then(|u| u.design.as_deref())),
            whose: "the data's sensor",
        },
    )?;
    if a.shear {
        model.require_shear()?;
    }
    let reference = a.reference_preprocessing.map(ReferenceChoice::sensor);
    for w in scale_warnings(&model, &sources, profile.as_ref(), reference) {
        eprintln!("warning: {w}");
    }
    let mut predictor = Predictor::new(
        &model,
        a.backend,
        crate::cmd::arg_values::cap_threads(a.threads),
    )?;
    let mut progress = FramesProgress::new("evaluating");
    let eval = evaluate(
        &model,
        &mut predictor,
        &sources,
        profile.as_ref(),
        reference,
        |done, total| progress.show(done, total),
    )?;
    progress.finish();
    print_figures(&model, &eval);
    if let Some(s) = smoothing {
        print_smoothed(&s, &eval);
    }
    if let Some(file) = &a.predictions {
        report::write_predictions(file, &eval, &model.classes)?;
        println!("predictions:    {}", file.display());
    }
    let verdict = spec.as_ref().map(|spec| judge(&eval, spec));
    let spec_origin = a
        .spec
        .as_deref()
        .unwrap_or(Path::new(""))
        .display()
        .to_string();
    if let Some(dir) = &a.report {
        let title = format!("Evaluation of {}", model.path.display());
        let path = report::write_judged(
            dir,
            &title,
            &eval,
            verdict.as_ref().map(|v| (v, spec_origin.as_str())),
        )?;
        println!("report:         {}", path.display());
        println!("                {}", path.with_extension("html").display());
    }
    if let Some(v) = verdict {
        for line in models::verdict_lines(&v) {
            println!("{line}");
        }
        if !v.pass {
            bail!(
                "the model fails the spec {}: {}",
                spec_origin,
                v.failures().join("; ")
            );
        }
    }
    Ok(())
}

/// The figures of the smoothed predictions, said as such.
fn print_smoothed(s: &Smoothing, eval: &Evaluation) {
    let e = s.errors(&eval.rows);
    println!(
        "smoothed:       force and contact from the line through the last {} frames of each press, at the frame (causal, no lag on a steady ramp; shape per frame)",
        s.frames()
    );
    println!("  Fz RMSE:      {:.4} N", e.fz_rmse());
    println!("  contact RMSE: {:.4} mm", e.contact_rmse());
}

/// Prints the model and its Table-2 figures.
fn print_figures(model: &Model, eval: &Evaluation) {
    let m = &eval.metrics;
    let s = m.macro_scores();
    println!(
        "model:          {} ({})",
        model.path.display(),
        model.describe()
    );
    println!(
        "frames:         {} ({} in contact, {} left out without a trustworthy label)",
        m.all.n, m.all.n_contact, eval.skipped
    );
    println!("Fz MSE:         {:.4} N^2", m.all.fz_mse());
    println!("Fz RMSE:        {:.4} N", m.all.fz_rmse());
    println!("contact RMSE:   {:.4} mm", m.all.contact_rmse());
    println!("shape accuracy: {:.4}", m.all.accuracy());
    println!(
        "macro:          precision {:.4}, recall {:.4}, F1 {:.4}",
        s.precision, s.recall, s.f1
    );
    if let Some(line) = shear_line(model, eval) {
        println!("{line}");
    }
    if let Some(s) = fringe_sensor_models::eval::slip_onsets(&eval.rows) {
        println!("slip onsets:    {}", super::slip_onsets::onset_summary(&s));
    }
}

/// The shear figures, or why there are none where the data records shear.
fn shear_line(model: &Model, eval: &Evaluation) -> Option<String> {
    let e = &eval.metrics.all;
    match e.shear_rmse() {
        Some([x, y]) => Some(format!(
            "shear RMSE:     Fx {x:.4} N, Fy {y:.4} N over {} frames (signed, the sensor's frame)",
            e.n_shear
        )),
        None if !model.has_shear() && eval.labels_know_shear => Some(
            "shear:          not scored: the model has no shear heads (its card does not say \"shear\")"
                .to_string(),
        ),
        None => None,
    }
}
