//! Step 3's second candidate: the custom CNN's last block trained again with its heads on the
//! rounds' frames (pure Rust), kept only when it beats the heads alone on presses it never saw.

use super::pruning::frames_kept;
use super::scans::Commissioning;
use crate::workflow_error::WorkflowError;
use fringe_sensor_models::adapt::{fit_heads, held_out_presses, AdaptConfig};
use fringe_sensor_models::dataset;
use fringe_sensor_models::Model;
use fringe_sensor_models::{train_last_block, BlockConfig, BlockFit, BlockInputs};
use std::path::PathBuf;
use std::time::Instant;

type Result<T> = std::result::Result<T, WorkflowError>;

/// Every how many frames of a press the block trains on (neighbours are nearly the same
/// picture).
const EVERY: usize = 2;

/// Trains the last block on the frames of `runs`; `None` for a model without the custom CNN's
/// last block.
pub(crate) fn train(
    c: &mut Commissioning<'_>,
    base: &Model,
    runs: &[PathBuf],
) -> Result<Option<BlockFit>> {
    let Some(base_weights) = base.weights() else {
        return Ok(None);
    };
    frames_kept(c, runs, "--last-block")?;
    let started = Instant::now();
    let sources = runs
        .iter()
        .map(|r| dataset::read(r))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let threads = c.threads;
    let host = &mut *c.host;
    let Some(data) = BlockInputs::read(base, &sources, threads, EVERY, |d, t| {
        host.frames("reading the last block's inputs", d, t)
    })?
    else {
        return Ok(None);
    };
    let seed = c.journal.options.seed;
    let samples: Vec<_> = sources
        .iter()
        .flat_map(|s| s.samples.iter().cloned())
        .collect();
    let held_out = held_out_presses(&samples, 5, seed);
    let config = BlockConfig {
        seed,
        threads: c.threads,
        ..BlockConfig::default()
    };
    let heads = AdaptConfig {
        folds: 5,
        seed,
        threads: c.threads,
    };
    c.say(format!(
        "step 3: training the last block with the heads on {} frames ({} presses held out), {} epochs",
        data.len(),
        held_out.len(),
        config.epochs
    ));
    let host = &mut *c.host;
    let fit = train_last_block(
        base_weights,
        &data,
        &held_out,
        &config,
        |f| Ok(fit_heads(base_weights, f, &heads)?.weights),
        |epoch, units| {
            host.say(format!(
                "  epoch {epoch}: held-out error {units:.3} of the spec"
            ))
        },
    )?;
    c.compute_s += started.elapsed().as_secs_f64();
    c.say(format!(
        "  on the held-out presses: heads alone {}",
        fit.heads_only.describe()
    ));
    if fit.epoch > 0 {
        c.say(format!(
            "  last block, epoch {}: {} (kept)",
            fit.epoch,
            fit.kept.describe()
        ));
    } else {
        c.say("  the last block did no better on them: the heads alone are kept".into());
    }
    Ok(Some(fit))
}
