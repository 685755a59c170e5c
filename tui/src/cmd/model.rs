//! `fringe model info|run|export`: what a model file is, its predictions on images, its ONNX
//! graph.

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use fringe_app::models;
use fringe_app::models::Exported;
use fringe_app::models::Networks;
use fringe_app::models::{ChoiceNote, ForSensor};
use fringe_app::models::{ImagePredictor, ImageRun};
use fringe_sensor_models::onnx_graph;
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::CardSource;
use fringe_sensor_models::Model;
use fringe_sensor_models::Prediction;
use fringe_sensor_models::ReferenceSensor;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct ModelArgs {
    #[command(subcommand)]
    command: ModelCommand,
}

#[derive(Subcommand)]
enum ModelCommand {
    /// Architecture, shape classes, parameters, input size and preprocessing of a model file.
    Info(InfoArgs),
    /// Run a model on image files: one line (or JSON object) per image with the force vector,
    /// the shape with its probabilities and the contact point.
    Run(RunArgs),
    /// Write a model's ONNX graph (runs in onnxruntime and any ONNX runtime).
    Export(ExportArgs),
    /// Join a model that finds the contact (the keypoint CNN) and window networks trained with
    /// `fringe train --force-window` into a two-stage model: a force network, a contact network
    /// (--contact) or both, copied into --out with the first's card naming them.
    Pair(PairArgs),
    /// Fit a model's slip head (stick, partial slip, gross slip from its readings of a frame
    /// and the two before it) on runs of slides (`fringe scan slides`), and write the model
    /// with it: `fringe eval`, `validate` and `stream` then report slip. The model needs shear
    /// heads (trained on runs that record shear).
    Slip(SlipArgs),
}

#[derive(Args)]
struct SlipArgs {
    /// The model: a weights file with shear heads (`fringe train`'s model.safetensors).
    model: PathBuf,
    /// Runs of slides whose frames carry slip labels.
    #[arg(required = true)]
    data: Vec<PathBuf>,
    /// The model file to write, with the slip head in its card (and the card beside it).
    #[arg(long, value_name = "FILE.safetensors")]
    out: PathBuf,
    /// Inference threads (at most the machine's cores are used).
    #[arg(long, default_value_t = 2, value_parser = crate::cmd::arg_values::threads)]
    threads: usize,
}

#[derive(Args)]
struct PairArgs {
    /// The model that finds the contact and the shape (a file or `builtin:NAME`).
    contact_model: PathBuf,
    /// The force network (`fringe train --force-window`'s model.safetensors). Without one the
    /// first network's force is kept (give --contact then).
    force_model: Option<PathBuf>,
    /// A contact network: a window network that places the contact (`fringe train --arch
    /// keypoint --force-window`; its card says refines_contact). It runs before the force
    /// network, whose window is then centred on the contact it places.
    #[arg(long, value_name = "WEIGHTS")]
    contact: Option<PathBuf>,
    /// The directory to write the two-stage model into (model.safetensors, force.safetensors
    /// and their cards).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

#[derive(Args)]
struct InfoArgs {
    /// A .pth / .pt (torch.save), .safetensors or .onnx file, or `default` (the model that
    /// ships with fringe).
    model: PathBuf,
}

/// The reference pipeline's sensors (crop diameter 980 or 1100 px about the image centre).
#[derive(Clone, Copy, ValueEnum)]
pub enum ReferenceChoice {
    Layered,
    Integrated,
}

impl ReferenceChoice {
    pub fn sensor(self) -> ReferenceSensor {
        match self {
            ReferenceChoice::Layered => ReferenceSensor::Layered,
            ReferenceChoice::Integrated => ReferenceSensor::Integrated,
        }
    }
}

#[derive(Args)]
struct RunArgs {
    /// A model file or `default`.
    model: PathBuf,
    /// Image files (PNG, TIFF, ...): full sensor frames.
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// The sensor's calibration profile (optical centre, crop radius): profiles/ID.toml.
    #[arg(long, value_name = "FILE")]
    profile: Option<PathBuf>,
    /// Preprocess as the reference code does (image centre, its crop diameter), for models it
    /// trained.
    #[arg(long, value_name = "SENSOR", num_args = 0..=1, default_missing_value = "layered")]
    reference_preprocessing: Option<ReferenceChoice>,
    /// One JSON object per line instead of text.
    #[arg(long)]
    json: bool,
    /// Inference threads (at most the machine's cores are used).
    #[arg(long, default_value_t = 2, value_parser = crate::cmd::arg_values::threads)]
    threads: usize,
    /// Inference backend: tract (built in), onnxruntime (cargo feature `onnxruntime`) or torch
    /// (cargo feature `torch`; also runs TorchScript modules).
    #[arg(long, default_value = "tract")]
    backend: BackendKind,
}

#[derive(Args)]
struct ExportArgs {
    model: PathBuf,
    /// Where to write the ONNX file.
    #[arg(long, value_name = "OUT.onnx")]
    onnx: PathBuf,
}

pub fn run(args: ModelArgs) -> Result<()> {
    match args.command {
        ModelCommand::Info(a) => info(&a.model),
        ModelCommand::Run(a) => run_images(a),
        ModelCommand::Export(a) => export(&a.model, &a.onnx),
        ModelCommand::Pair(a) => pair(&a),
        ModelCommand::Slip(a) => slip(&a),
    }
}

/// Fits and writes the slip head of `a`, and says how it fits its own data.
fn slip(a: &SlipArgs) -> Result<()> {
    fringe_rig::store::outside_runs(&a.out).context("--out")?;
    let mut progress = crate::cmd::frames_progress::FramesProgress::new("reading the slides");
    let fitted = models::fit_slip(
        &models::SlipFitRequest {
            model: &a.model,
            data: &a.data,
            out: &a.out,
            threads: crate::cmd::arg_values::cap_threads(a.threads),
        },
        &mut |done, total| progress.show(done, total),
    )?;
    progress.finish();
    println!(
        "slip head:      fitted on {} frames of {} presses; gross slip reported after {} frame(s) in a row",
        fitted.frames, fitted.presses, fitted.head.confirm_frames
    );
    if let Some(s) = &fitted.on_fitting_data {
        println!(
            "on that data:   {} (the fitting data itself: evaluate on other runs for a held-out figure)",
            crate::cmd::slip_onsets::onset_summary(s)
        );
    }
    println!("model:          {}", fitted.path.display());
    Ok(())
}

/// Writes the two-stage model of `a` and says what it reads with which network.
fn pair(a: &PairArgs) -> Result<()> {
    fringe_rig::store::outside_runs(&a.out).context("--out")?;
    let nets = Networks {
        contact_model: &a.contact_model,
        force_model: a.force_model.as_deref(),
        contact: a.contact.as_deref(),
    };
    let paired = models::pair(&nets, &a.out, &mut warn)?;
    let joined = &paired.joined;
    let placed = joined
        .contact_refiner
        .as_ref()
        .map(|r| {
            format!(
                "; the contact placed by {} in a {} mm window about it",
                r.path.display(),
                r.force_window_mm().unwrap_or_default()
            )
        })
        .unwrap_or_default();
    let read = match &joined.force {
        Some(f) => format!(
            "force: {}, a {} mm window about the contact",
            f.path.display(),
            f.force_window_mm().unwrap_or_default()
        ),
        None => "force: the first network's, on the whole disc".to_string(),
    };
    println!(
        "two-stage model: {} (contact and shape: {}{placed}; {read})",
        paired.path.display(),
        paired.contact_model.describe()
    );
    Ok(())
}

/// A warning on stderr.
fn warn(w: String) {
    eprintln!("warning: {w}");
}

/// Opens a model argument ([`models::open_model`]), warning on stderr of a model without its
/// card.
pub(crate) fn open_model(path: &Path) -> Result<Model> {
    let m = models::open_model(path)?;
    if let Some(w) = m.missing_card_warning() {
        eprintln!("warning: {w}");
    }
    Ok(m)
}

/// The model a command runs ([`models::choose_model`]): the commissioned model taken said on
/// stdout, warnings on stderr.
pub(crate) fn choose_model(given: Option<&Path>, sensor: &ForSensor<'_>) -> Result<Model> {
    Ok(models::choose_model(given, sensor, &mut say)?)
}

/// What the model choice tells the operator: the commissioned model taken on stdout, warnings
/// on stderr.
pub(crate) fn say(note: ChoiceNote) {
    match note {
        ChoiceNote::Commissioned(line) => println!("{line}"),
        ChoiceNote::Warning(w) => eprintln!("warning: {w}"),
    }
}

fn info(path: &Path) -> Result<()> {
    let m = open_model(path)?;
    println!("model:         {}", m.path.display());
    println!(
        "card:          {}",
        match &m.card_source {
            CardSource::Beside(p) => p.display().to_string(),
            CardSource::Embedded => "in the file's metadata".to_string(),
            CardSource::Builtin => "built in".to_string(),
            CardSource::Missing => "none (input size, colour and classes are guesses)".to_string(),
        }
    );
    println!("architecture:  {}", m.describe());
    println!(
        "shape classes: {} ({})",
        m.classes.len(),
        m.classes.join(", ")
    );
    println!("parameters:    {}", m.parameters);
    println!("stored as:     {}", m.stored);
    println!(
        "input:         3 x {0} x {0}, {1}",
        m.input_size,
        m.colour.name()
    );
    println!(
        "outputs:       force [Fx Fy Fz Mx My Mz Ft] (magnitudes), shape probabilities, contact x y (mm)"
    );
    let refines = |m: &fringe_sensor_models::Model| {
        if m.card.as_ref().is_some_and(|c| c.refines_contact) {
            ", and where the press lies from the window's centre"
        } else {
            ""
        }
    };
    if let Some(window) = m.force_window_mm() {
        println!(
            "two-stage:     this is a force network: it reads Fz{} from a {window} mm window about \
             the contact; run it paired (`fringe model pair`)",
            refines(&m)
        );
    }
    if let Some(r) = &m.contact_refiner {
        println!(
            "two-stage:     the contact is placed by {} ({}, 3 x {2} x {2}) in a {3} mm window \
             about the contact this network finds",
            r.path.display(),
            r.describe(),
            r.input_size,
            r.force_window_mm().unwrap_or_default()
        );
    }
    if let Some(f) = &m.force {
        println!(
            "two-stage:     the force{} is read by {} ({}, 3 x {3} x {3}) from a {4} mm window \
             about the contact this network finds",
            refines(f),
            f.path.display(),
            f.describe(),
            f.input_size,
            f.force_window_mm().unwrap_or_default()
        );
    }
    let pre = m
        .card
        .as_ref()
        .and_then(|c| c.preprocessing.clone())
        .unwrap_or_else(|| "profile (pass --profile profiles/ID.toml to run it)".into());
    println!("preprocessing: {pre}");
    if let Some(sensor) = m.card.as_ref().and_then(|c| c.sensor_id.as_ref()) {
        println!("sensor:        {sensor}");
    }
    Ok(())
}

fn run_images(a: RunArgs) -> Result<()> {
    let run = ImageRun {
        model: &a.model,
        profile: a.profile.as_deref(),
        reference: a.reference_preprocessing.map(ReferenceChoice::sensor),
        backend: a.backend,
        threads: crate::cmd::arg_values::cap_threads(a.threads),
    };
    let mut predictor = ImagePredictor::open(&run, &mut warn)?;
    for image in &a.images {
        let p = predictor.predict(image, &mut warn)?;
        if a.json {
            println!("{}", json_line(image, &p));
        } else {
            println!("{}: {}", image.display(), text_line(&p));
        }
    }
    Ok(())
}

fn text_line(p: &Prediction) -> String {
    let f = &p.force;
    let others: Vec<String> = p
        .probabilities
        .iter()
        .filter(|(n, _)| *n != p.shape)
        .map(|(n, v)| format!("{n} {:.1} %", 100.0 * v))
        .collect();
    let contact = match p.contact {
        Some([x, y]) => format!("contact x {:.1} y {:.1} mm", x.value(), y.value()),
        None => "contact -".to_string(),
    };
    // Only Fz is trained (the reference's loss): the other force outputs are in the JSON form
    // for models trained on them, never shown as if they were measurements.
    format!(
        "Fz {:.2} N  shape {} {:.1} % ({})  {contact}",
        f.fz.value(),
        p.shape,
        100.0 * p.confidence(),
        others.join(", ")
    )
}

fn json_line(image: &Path, p: &Prediction) -> serde_json::Value {
    let f = &p.force;
    serde_json::json!({
        "image": image.display().to_string(),
        "force": {
            "fx": f.fx.value(), "fy": f.fy.value(), "fz": f.fz.value(),
            "mx": f.mx.value(), "my": f.my.value(), "mz": f.mz.value(), "ft": f.ft.value(),
        },
        "shape": p.shape,
        "probabilities": p.probabilities.iter().map(|(n, v)| (n.clone(), serde_json::json!(v))).collect::<serde_json::Map<_, _>>(),
        "contact_mm": p.contact.map(|[x, y]| [x.value(), y.value()]),
    })
}

fn export(path: &Path, out: &Path) -> Result<()> {
    fringe_rig::store::outside_runs(out).context("--onnx")?;
    let Exported { model: m, bytes } = models::export_onnx(path, out, &mut warn)?;
    println!(
        "{}: {} ONNX graph (opset {}), {} bytes, inputs `{}` [N,3,{},{}], outputs {}",
        out.display(),
        m.describe(),
        onnx_graph::OPSET,
        bytes,
        onnx_graph::INPUT,
        m.input_size,
        m.input_size,
        onnx_graph::OUTPUTS.join(", ")
    );
    Ok(())
}
