//! `fringe adapt --model BASE DATA... --out FILE.safetensors`: a model adapted to one sensor
//! unit in pure Rust (no libtorch): its heads fitted again on the unit's labelled frames.

use super::frames_progress::FramesProgress;
use super::model::open_model;
use anyhow::{bail, Context, Result};
use clap::Args;
use fringe_app::models::adapted_card::{adapted_card, write_adapted};
use fringe_app::models::labelled_data::read_sources;
use fringe_calibration::Profile;
use fringe_sensor_models::adapt::{adapt_heads, AdaptConfig};
use std::path::PathBuf;

#[derive(Args)]
pub struct AdaptArgs {
    /// The model to start from: a weights file (.pth / .pt / .safetensors) of the paper's
    /// networks, `builtin:NAME`, or `default` (`builtin:layered`, the layered design's custom
    /// CNN).
    #[arg(long, default_value = "default")]
    model: PathBuf,
    /// The unit's labelled frames: run directories or reference-layout datasets.
    #[arg(required = true)]
    data: Vec<PathBuf>,
    /// The adapted weights (.safetensors; the card is written beside them and into them).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Calibration profile for data that carries none (reference-layout datasets).
    #[arg(long, value_name = "FILE")]
    profile: Option<PathBuf>,
    /// Cross-validation folds over presses.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(2..=20))]
    folds: u64,
    /// Seed of the presses' assignment to folds.
    #[arg(long, default_value_t = 42)]
    seed: u64,
    /// Inference threads (at most the machine's cores are used).
    #[arg(long, default_value_t = 2, value_parser = crate::cmd::arg_values::threads)]
    threads: usize,
}

pub fn run(a: AdaptArgs) -> Result<()> {
    fringe_rig::store::outside_runs(&a.out).context("--out")?;
    if a.out.extension().and_then(|e| e.to_str()) != Some("safetensors") {
        bail!(
            "--out {}: the adapted weights are written as safetensors: name the file *.safetensors",
            a.out.display()
        );
    }
    if a.out.exists() {
        bail!(
            "--out {}: the file exists; choose a new name (an adapted model never overwrites another)",
            a.out.display()
        );
    }
    let model = open_model(&a.model)?;
    if let Some(w) = model.copy_warning() {
        eprintln!("warning: {w}");
    }
    let profile = match &a.profile {
        Some(p) => Some(Profile::load(p)?),
        None => None,
    };
    let sources = read_sources(&a.data, "adapt on")?;
    let config = AdaptConfig {
        folds: a.folds as usize,
        seed: a.seed,
        threads: crate::cmd::arg_values::cap_threads(a.threads),
    };
    let mut progress = FramesProgress::new("reading features");
    let adapted = adapt_heads(
        &model,
        &sources,
        profile.as_ref(),
        &config,
        |done, total| progress.show(done, total),
    )?;
    progress.finish();
    let unit = sources
        .iter()
        .find_map(|s| s.sensor_id.clone())
        .or_else(|| profile.as_ref().map(|p| p.sensor_id.clone()));
    let card = adapted_card(&model, &adapted, &a.data, a.folds, a.seed, unit.as_deref());
    let card_path = write_adapted(&a.out, &adapted.weights, &card)?;
    println!(
        "adapted {} ({}) on {} frames of {} presses",
        model.path.display(),
        model.describe(),
        adapted.frames,
        adapted.presses
    );
    for h in &adapted.heads {
        println!(
            "  {:<11} {}: {:.4} before, {:.4} after (cross-validated over presses)",
            h.head, h.figure, h.before, h.after
        );
    }
    println!("wrote {} and {}", a.out.display(), card_path.display());
    Ok(())
}
