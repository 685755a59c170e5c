//! `fringe adapt --model BASE DATA... --out FILE.safetensors`: a model adapted to one sensor
//! unit in pure Rust (no libtorch): its heads fitted again on the unit's labelled frames.

use super::frames_progress::FramesProgress;
use anyhow::{Context, Result};
use clap::Args;
use fringe_app::models;
use fringe_app::models::AdaptRequest;
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
    let request = AdaptRequest {
        model: &a.model,
        data: &a.data,
        out: &a.out,
        profile: a.profile.as_deref(),
        folds: a.folds,
        seed: a.seed,
        threads: crate::cmd::arg_values::cap_threads(a.threads),
    };
    let mut progress = FramesProgress::new("reading features");
    let done = models::adapt(
        &request,
        &mut |w| eprintln!("warning: {w}"),
        &mut |done, total| progress.show(done, total),
    )?;
    progress.finish();
    let (model, adapted) = (&done.base, &done.adapted);
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
    println!("wrote {} and {}", a.out.display(), done.card.display());
    Ok(())
}
