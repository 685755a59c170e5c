//! `fringe model info|run|export`: what a model file is, its predictions on images, its ONNX
//! graph.

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use fringe_app::models::choice::{self, ChoiceNote, ForSensor};
use fringe_calibration::Profile;
use fringe_rig::store::read_plain;
use fringe_sensor_models::builtin;
use fringe_sensor_models::eval::frame_ref;
use fringe_sensor_models::onnx_graph;
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::Model;
use fringe_sensor_models::Prediction;
use fringe_sensor_models::Predictor;
use fringe_sensor_models::ReferenceSensor;
use fringe_sensor_models::StateDict;
use fringe_sensor_models::{CardSource, ModelCard};
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
    }
}

/// The file names of a two-stage model in its directory.
const PAIR_CONTACT: &str = "model.safetensors";
const PAIR_FORCE: &str = "force.safetensors";
const PAIR_CONTACT_NET: &str = "contact.safetensors";

/// Writes the two-stage model of `a`: the networks' weights and cards into `a.out`, the contact
/// model's card naming its window networks, then opens it to check they run together.
fn pair(a: &PairArgs) -> Result<()> {
    fringe_rig::store::outside_runs(&a.out).context("--out")?;
    let contact = open_model(&a.contact_model)?;
    if a.force_model.is_none() && a.contact.is_none() {
        bail!(
            "give a force network (FORCE_MODEL), a contact network (--contact) or both: a \
             two-stage model reads a window about the contact with at least one"
        );
    }
    let weights_c = weights_of(&contact)?;
    if contact.force_window_mm().is_some() {
        bail!(
            "{}: a force network cannot find the contact: give the model that finds it first \
             (the keypoint CNN)",
            a.contact_model.display()
        );
    }
    if contact.force.is_some() || contact.contact_refiner.is_some() {
        bail!("{}: already a two-stage model", a.contact_model.display());
    }
    let design = contact.card.as_ref().and_then(|c| c.variant.clone());
    let of = format!("the contact model {}", a.contact_model.display());
    let force = match &a.force_model {
        Some(path) => {
            let net = open_model(path)?;
            if net.force_window_mm().is_none() {
                bail!(
                    "{}: not a force network (its card has no force_window_mm): train one with \
                     `fringe train --force-window MM`",
                    path.display()
                );
            }
            net.check_design(design.as_deref(), &of)?;
            Some(net)
        }
        None => None,
    };
    let refiner = match &a.contact {
        Some(path) => {
            let net = open_model(path)?;
            if !net.card.as_ref().is_some_and(|c| c.refines_contact) || net.force.is_some() {
                bail!(
                    "{}: not a contact network (its card does not say refines_contact): train \
                     one with `fringe train --arch keypoint --force-window MM`",
                    path.display()
                );
            }
            net.check_design(design.as_deref(), &of)?;
            Some(net)
        }
        None => None,
    };
    // Every network is checked before anything is written.
    for net in force.iter().chain(&refiner) {
        weights_of(net)?;
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("{}: cannot create", a.out.display()))?;
    let mut card = contact.travelling_card();
    for (net, file, slot) in [
        (&refiner, PAIR_CONTACT_NET, &mut card.contact_model),
        (&force, PAIR_FORCE, &mut card.force_model),
    ] {
        if let Some(net) = net {
            write_network(&a.out.join(file), weights_of(net)?, &net.travelling_card())?;
            *slot = Some(file.to_string());
        }
    }
    let out_c = a.out.join(PAIR_CONTACT);
    write_network(&out_c, weights_c, &card)?;
    let joined = builtin::open(&out_c)?;
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
        out_c.display(),
        contact.describe()
    );
    Ok(())
}

/// The weights of a network joined into a two-stage model.
fn weights_of(net: &Model) -> Result<&StateDict> {
    net.weights().ok_or_else(|| {
        anyhow::anyhow!(
            "{}: a two-stage model is made of weights files (.safetensors, .pth): export ONNX \
             afterwards",
            net.path.display()
        )
    })
}

/// One network of a two-stage model into `path`: its weights with the card embedded, and the
/// card beside it (`<file>.json`), as training writes them.
fn write_network(path: &Path, weights: &StateDict, card: &ModelCard) -> Result<()> {
    fringe_sensor_models::write_safetensors_with_card(path, weights, Some(card))
        .with_context(|| format!("{}: cannot write", path.display()))?;
    let [json, _] = ModelCard::candidates(path);
    let text = serde_json::to_string_pretty(card)?;
    std::fs::write(&json, text + "\n").with_context(|| format!("{}: cannot write", json.display()))
}

/// Opens a model argument ([`choice::open_model`]), warning on stderr of a model without its
/// card.
pub(crate) fn open_model(path: &Path) -> Result<Model> {
    let m = choice::open_model(path)?;
    if let Some(w) = m.missing_card_warning() {
        eprintln!("warning: {w}");
    }
    Ok(m)
}

/// The model a command runs ([`choice::choose_model`]): the commissioned model taken said on
/// stdout, warnings on stderr.
pub(crate) fn choose_model(given: Option<&Path>, sensor: &ForSensor<'_>) -> Result<Model> {
    Ok(choice::choose_model(
        given,
        sensor,
        &mut |note| match note {
            ChoiceNote::Commissioned(line) => println!("{line}"),
            ChoiceNote::Warning(w) => eprintln!("warning: {w}"),
        },
    )?)
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
    let m = open_model(&a.model)?;
    let profile = match &a.profile {
        Some(p) => Some(Profile::load(p)?),
        None => None,
    };
    let reference = a.reference_preprocessing.map(ReferenceChoice::sensor);
    let config = m.preprocessing(profile.as_ref(), reference)?;
    if let Some(w) = m.scale_warning(&config) {
        eprintln!("warning: {w}");
    }
    let mut predictor = Predictor::new(
        &m,
        a.backend,
        crate::cmd::arg_values::cap_threads(a.threads),
    )?;
    for image in &a.images {
        let frame = read_plain(image)?;
        if let Some(warning) = config.coverage_warning(frame.width, frame.height) {
            eprintln!("warning: {}: {warning}", image.display());
        }
        let fref = frame_ref(&frame);
        let tensor = config
            .run(fref)
            .map_err(|e| anyhow::anyhow!("{}: {e}", image.display()))?;
        let predicted = predictor.predict(&tensor, 1, &[fref], &config, profile.as_ref())?;
        let Some(p) = predicted.into_iter().next() else {
            bail!("{}: the model gave no output", image.display());
        };
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
    let m = open_model(path)?;
    refuse_model_file(&m.path, out)?;
    if let Some(w) = m.copy_warning() {
        eprintln!("warning: {w}");
    }
    // The graph carries the model's card, so that `model info`, `model run` and eval read it
    // with the input size, colour and classes it was trained with.
    let bytes = onnx_graph::encode(&m.onnx_with_card()?);
    let tmp = out.with_extension("onnx.partial");
    std::fs::write(&tmp, &bytes).with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, out).with_context(|| format!("{}: cannot write", out.display()))?;
    println!(
        "{}: {} ONNX graph (opset {}), {} bytes, inputs `{}` [N,3,{},{}], outputs {}",
        out.display(),
        m.describe(),
        onnx_graph::OPSET,
        bytes.len(),
        onnx_graph::INPUT,
        m.input_size,
        m.input_size,
        onnx_graph::OUTPUTS.join(", ")
    );
    Ok(())
}

/// Refuses an output that is one of the model's own files (its weights or its card,
/// `<file>.json` or `<stem>.json`): writing the graph there would destroy the model.
fn refuse_model_file(model: &Path, out: &Path) -> Result<()> {
    let real = |p: &Path| std::fs::canonicalize(p).ok();
    let Some(out_real) = real(out) else {
        // It does not exist yet: it is no file of the model.
        return Ok(());
    };
    let own = std::iter::once(model.to_path_buf()).chain(ModelCard::candidates(model));
    if own
        .collect::<Vec<_>>()
        .iter()
        .any(|f| real(f).as_ref() == Some(&out_real))
    {
        bail!(
            "{}: that is a file of the model {} (its weights or its card): writing the ONNX graph there would destroy it; give another output, e.g. {}",
            out.display(),
            model.display(),
            model.with_extension("onnx").display()
        );
    }
    Ok(())
}
