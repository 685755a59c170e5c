//! `fringe train DATA... --arch custom|resnet18|keypoint [--pipeline gray10|rgb3|rgb3-clean]
//! [--epochs N] [--batch 32] [--lr 1e-3] [--out DIR] [--resume CHECKPOINT]`: the paper's
//! networks (and fringe's keypoint CNN) trained on runs or reference-layout datasets (cargo feature `torch`).

use anyhow::Result;
use clap::Args;
use fringe_sensor_models::Architecture;
use fringe_sensor_models::Pipeline;
use fringe_sensor_models::Schedule;
use std::path::PathBuf;

#[derive(Args)]
pub struct TrainArgs {
    /// Run directories or reference-layout datasets (0.images/ + 0.labels.csv); taken from the
    /// checkpoint's card with --resume.
    data: Vec<PathBuf>,
    /// Network: custom (the paper's custom CNN), resnet18, or keypoint (the custom CNN's
    /// convolutions with 16 soft-argmax keypoints that keep where the fringes are).
    #[arg(long, value_parser = fringe_app::models::architecture, default_value = "custom")]
    arch: Architecture,
    /// Augmentation: gray10 (grey + noise, 10 copies), rgb3 (RGB + noise, 3), rgb3-clean.
    #[arg(long, default_value = "gray10")]
    pipeline: Pipeline,
    /// Epochs (default 40, the reference's; with --resume, the checkpoint's, or more to extend).
    #[arg(long)]
    epochs: Option<usize>,
    #[arg(long, default_value_t = 32)]
    batch: usize,
    #[arg(long, default_value_t = 1e-3)]
    lr: f64,
    /// Learning rate over the epochs: constant (the reference's) or cosine (from --lr down to a
    /// hundredth of it at the last epoch).
    #[arg(long, default_value = "constant")]
    schedule: Schedule,
    /// Seed of the split, the augmentation, the initial weights and the batch order.
    #[arg(long, default_value_t = 42)]
    seed: u64,
    /// Network input size, px.
    #[arg(long, default_value_t = 224)]
    input_size: u32,
    /// Checkpoints, split.json, loss.png and the final model.safetensors go here.
    #[arg(long, default_value = "training")]
    out: PathBuf,
    /// Continue a training from one of its checkpoints (same split, copies and optimiser state).
    #[arg(long, value_name = "CHECKPOINT.safetensors")]
    resume: Option<PathBuf>,
    /// Calibration profile for datasets that carry none.
    #[arg(long, value_name = "FILE")]
    profile: Option<PathBuf>,
    /// Threads for libtorch and the data preparation.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Start from these weights instead of a random initialisation (fine-tuning, for example
    /// a few epochs at a lower --lr on the same data and --seed, so the split is the same).
    #[arg(long, value_name = "WEIGHTS", conflicts_with = "resume")]
    init: Option<PathBuf>,
    /// Train the force network of a two-stage model: it reads Fz, and where the press lies from
    /// the window's centre, from a window of this side (mm) about the contact, on the frames in
    /// contact. `fringe model pair` joins it to a
    /// model that finds the contact (the keypoint CNN).
    #[arg(long, value_name = "MM")]
    force_window: Option<f64>,
    /// Train on every Nth frame of the training side (validation and test keep every frame):
    /// a 50 Hz run's neighbouring frames differ little, so a slide scan trains about as well on
    /// a third of them in a third of the time. With --resume, the checkpoint's.
    #[arg(long, value_name = "N", default_value_t = 1)]
    every: usize,
}

#[cfg(not(feature = "torch"))]
pub fn run(_: TrainArgs) -> Result<()> {
    anyhow::bail!(
        "this fringe was built without training: build it with the cargo feature `torch` \
         (pip install --no-deps torch==2.13.0 nvidia-cuda-runtime==13.0.96 nvidia-cuda-cupti==13.0.85; LIBTORCH=<site-packages>/torch cargo build --release --features torch; README.md, \"Optional features\", has the whole line)"
    )
}

#[cfg(feature = "torch")]
pub use with_torch::run;

#[cfg(feature = "torch")]
mod with_torch {
    use super::*;
    use crate::signals::{self, Again, Signal};
    use anyhow::Context;
    use fringe_app::models;
    use fringe_app::models::TrainRequest;
    use fringe_sensor_models::{TrainConfig, TrainEvent, TrainOutcome as Outcome};
    use std::io::{IsTerminal, Write};
    use std::time::Instant;

    pub fn run(a: TrainArgs) -> Result<()> {
        fringe_rig::store::outside_runs(&a.out).context("--out")?;
        let request = TrainRequest {
            data: a.data,
            arch: a.arch,
            pipeline: a.pipeline,
            epochs: a.epochs,
            batch: a.batch,
            lr: a.lr,
            schedule: a.schedule,
            seed: a.seed,
            input_size: a.input_size,
            out: a.out,
            resume: a.resume,
            profile: a.profile,
            threads: a.threads,
            init: a.init,
            force_window: a.force_window,
            every: a.every,
        };
        let training = models::prepare_training(request, &mut |d, s| {
            eprintln!(
                "data: {} ({} labelled frames, {} left out without a trustworthy label)",
                d.display(),
                s.samples.len(),
                s.skipped
            )
        })?;
        let config = &training.config;
        // Ctrl-C once: finish the batch, save a checkpoint, say how to resume. Twice: quit now.
        let stop = signals::catch(&[Signal::Interrupt], Again::Ends);
        let mut progress = Progress {
            tty: std::io::stderr().is_terminal(),
            started: Instant::now(),
            last_pct: usize::MAX,
            last_line: Instant::now(),
            last_tenth: 0,
            batch: config.batch,
            force_only: config.force_window_mm.is_some(),
            offset: config.reads_contact_offset(),
        };
        let outcome = training.run(stop, &mut |e| progress.show(e))?;
        let _ = std::io::stderr().flush();
        report(outcome, config);
        Ok(())
    }

    /// The training's progress on stderr: bars on a terminal, fewer lines in a log.
    struct Progress {
        tty: bool,
        started: Instant,
        /// The last preparation percentage shown.
        last_pct: usize,
        /// When the last line about the epoch under way was written to a log.
        last_line: Instant,
        /// The last tenth of the epoch under way shown in a log.
        last_tenth: usize,
        /// Images per batch, for the epoch's ETA.
        batch: usize,
        /// A force network: its shape head is not trained.
        force_only: bool,
        /// A force network whose contact head reads the press's offset from the window's centre.
        offset: bool,
    }

    impl Progress {
        /// Shows one event of the training.
        fn show(&mut self, e: TrainEvent) {
            let tty = self.tty;
            match e {
                TrainEvent::Split { train, val, test, path } => eprintln!(
                    "split by press: {train} frames for training, {val} for validation, {test} for test ({})",
                    path.display()
                ),
                TrainEvent::Preparing { side, done, total } => {
                    let pct = 100 * done / total.max(1);
                    if tty {
                        eprint!("\rpreparing the {side} inputs: {done} of {total} frames ({pct} %)");
                        if done == total {
                            eprintln!();
                        }
                    } else if quarter_line_due(pct, self.last_pct, done, total) {
                        eprintln!("preparing the {side} inputs: {done} of {total} frames ({pct} %)");
                    }
                    self.last_pct = pct;
                }
                TrainEvent::Batch { epoch, epochs, batch, batches, loss, images_per_second } => {
                    let left = batches.saturating_sub(batch) as f64 * (images_per_second.recip() * self.batch as f64);
                    if tty {
                        let width = 24;
                        let filled = width * batch / batches.max(1);
                        eprint!(
                            "\repoch {epoch}/{epochs} [{}{}] {batch}/{batches} loss {loss:.4} {images_per_second:.0} img/s, epoch ETA {}   ",
                            "#".repeat(filled),
                            ".".repeat(width - filled),
                            duration(left)
                        );
                    } else if let Some(tenth) =
                        log_line_due(batch, batches, self.last_tenth, self.last_line.elapsed())
                    {
                        eprintln!(
                            "epoch {epoch}/{epochs}: {batch} of {batches} batches ({} %), loss {loss:.4}, {images_per_second:.0} img/s, epoch ETA {}",
                            100 * batch / batches.max(1),
                            duration(left)
                        );
                        self.last_tenth = tenth;
                        self.last_line = Instant::now();
                    }
                }
                TrainEvent::Epoch(r) => {
                    if tty {
                        eprintln!();
                    }
                    self.last_tenth = 0;
                    self.last_line = Instant::now();
                    let heads = if self.offset {
                        format!(", contact RMSE {:.2} mm (from the window's centre)", r.val_contact_rmse_mm)
                    } else if self.force_only {
                        String::new()
                    } else {
                        format!(
                            ", contact RMSE {:.2} mm, shape accuracy {:.3}",
                            r.val_contact_rmse_mm, r.val_shape_accuracy
                        )
                    };
                    let shear = r.val_shear_rmse_n.map_or(String::new(), |[x, y]| {
                        format!(", shear RMSE Fx {x:.3} N, Fy {y:.3} N")
                    });
                    eprintln!(
                        "epoch {}: loss {:.4} (validation {:.4}); validation Fz RMSE {:.3} N{heads}{shear}; {:.0} s, {:.0} img/s; {} so far",
                        r.epoch, r.train_loss, r.val_loss, r.val_fz_rmse_n, r.seconds, r.images_per_second,
                        duration(self.started.elapsed().as_secs_f64())
                    );
                }
                TrainEvent::Checkpoint(p) => eprintln!("checkpoint: {}", p.display()),
                TrainEvent::Evaluating { done, total } => {
                    let pct = 100 * done / total.max(1);
                    if tty {
                        eprint!("\revaluating on the test side: {done} of {total} frames");
                        if done == total {
                            eprintln!();
                        }
                    } else if quarter_line_due(pct, self.last_pct, done, total) {
                        eprintln!("evaluating on the test side: {done} of {total} frames ({pct} %)");
                    }
                    self.last_pct = pct;
                }
            }
        }
    }

    /// Prints the test metrics of a finished training, or how to resume an interrupted one
    /// (and exits 130).
    fn report(outcome: Outcome, config: &TrainConfig) {
        match outcome {
            Outcome::Finished { model, evaluation } => {
                let m = &evaluation.metrics;
                println!("model:          {}", model.display());
                println!(
                    "test frames:    {} ({} in contact)",
                    m.all.n, m.all.n_contact
                );
                println!("Fz RMSE:        {:.4} N", m.all.fz_rmse());
                println!("contact RMSE:   {:.4} mm", m.all.contact_rmse());
                println!("shape accuracy: {:.4}", m.all.accuracy());
                if let Some([x, y]) = m.all.shear_rmse() {
                    println!("shear RMSE:     Fx {x:.4} N, Fy {y:.4} N");
                }
                println!("loss curves:    {}", config.out.join("loss.png").display());
            }
            Outcome::ForceNetwork {
                model,
                test_frames,
                fz_rmse_n,
                contact_rmse_mm,
                centre_rmse_mm,
            } => {
                println!("force network:  {}", model.display());
                println!(
                    "test frames:    {test_frames} in contact, windows about the labelled contact moved as a first network misses it ({centre_rmse_mm:.3} mm RMS)"
                );
                println!("Fz RMSE:        {fz_rmse_n:.4} N (the network alone)");
                if let Some(c) = contact_rmse_mm {
                    println!(
                        "contact RMSE:   {c:.3} mm (the window's centre moved by the offset the network reads)"
                    );
                }
                println!("loss curves:    {}", config.out.join("loss.png").display());
                println!(
                    "join it to a model that finds the contact: fringe model pair CONTACT_MODEL {} --out DIR",
                    model.display()
                );
            }
            Outcome::Interrupted { checkpoint } => {
                eprintln!(
                    "\ninterrupted: saved {}\nresume with: fringe train --resume {}",
                    checkpoint.display(),
                    checkpoint.display()
                );
                std::process::exit(130);
            }
        }
    }

    /// In a log, where a counter cannot be redrawn, work counted in frames (preparing the inputs,
    /// evaluating the test side) gets a line as it enters each quarter and one at its end.
    fn quarter_line_due(pct: usize, last_pct: usize, done: usize, total: usize) -> bool {
        pct / 25 != last_pct / 25 || done == total
    }

    /// In a log, where a bar cannot be redrawn, the epoch under way gets a line at a tenth of it
    /// when a minute has passed since the last line: none for short epochs, a few for long ones
    /// (a ResNet-18 epoch at 224 px takes many minutes on 2 cores). The tenth to show, if one is due.
    fn log_line_due(
        batch: usize,
        batches: usize,
        last_tenth: usize,
        since_last: std::time::Duration,
    ) -> Option<usize> {
        let tenth = 10 * batch / batches.max(1);
        (tenth > last_tenth && tenth < 10 && since_last >= std::time::Duration::from_secs(60))
            .then_some(tenth)
    }

    fn duration(s: f64) -> String {
        if !s.is_finite() {
            return "-".into();
        }
        let s = s.max(0.0) as u64;
        if s >= 3600 {
            format!("{}h{:02}m", s / 3600, s % 3600 / 60)
        } else {
            format!("{}m{:02}s", s / 60, s % 60)
        }
    }

    #[cfg(test)]
    mod tests {
        use super::{log_line_due, quarter_line_due};
        use std::time::Duration;

        const MINUTE: Duration = Duration::from_secs(60);

        #[test]
        fn a_long_epoch_in_a_log_gets_a_line_at_each_tenth_a_minute_apart() {
            // 200 batches; the 20th ends the first tenth.
            assert_eq!(
                log_line_due(19, 200, 0, MINUTE),
                None,
                "before the first tenth"
            );
            assert_eq!(log_line_due(20, 200, 0, MINUTE), Some(1));
            assert_eq!(
                log_line_due(21, 200, 1, MINUTE),
                None,
                "the same tenth again"
            );
            // Tenths passed while a minute had not: the line comes at the tenth then reached.
            assert_eq!(log_line_due(90, 200, 1, MINUTE * 2), Some(4));
        }

        #[test]
        fn counted_work_in_a_log_gets_a_line_per_quarter_and_at_its_end() {
            // The first frame after another phase (which ended at 100 %).
            assert!(quarter_line_due(0, 100, 1, 640));
            assert!(!quarter_line_due(24, 0, 154, 640), "the same quarter");
            assert!(quarter_line_due(25, 24, 160, 640));
            assert!(quarter_line_due(99, 99, 640, 640), "the last frame");
        }

        #[test]
        fn a_short_epoch_or_its_end_gets_no_line_of_its_own() {
            assert_eq!(
                log_line_due(100, 200, 0, Duration::from_secs(59)),
                None,
                "under a minute since the last line"
            );
            assert_eq!(
                log_line_due(200, 200, 9, MINUTE * 5),
                None,
                "the epoch's own line follows its last batch"
            );
        }
    }
}
