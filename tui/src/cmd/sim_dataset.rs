//! `fringe sim dataset`: synthetic training frames in the reference layout, rendered straight
//! from the simulator (no motion; `fringe_app::simulation::write_dataset` writes them): this parses
//! the flags and prints the progress and what was written.

use super::sim_render::load_sensor;
use anyhow::{anyhow, bail, Context};
use fringe_app::simulation::{write_dataset, DatasetError, DatasetEvent};
use fringe_rig::reference_layout::SIM_DATASET_DOC;
use fringe_rig::store::human_bytes as human;
use fringe_rig::Newtons;
use fringe_sim::dataset::{DatasetSpec, NO_CONTACT_FRACTION};
use std::io::{IsTerminal, Write as _};
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(clap::Args)]
pub struct SimDatasetArgs {
    /// Sensor build: `layered`, `integrated` or a sensor TOML file (see rig/sim/sensors/).
    #[arg(
        long,
        value_name = "layered|integrated|PATH.toml",
        default_value = "layered"
    )]
    sensor: String,
    /// Number of frames.
    #[arg(long, value_name = "N")]
    count: u64,
    /// Dataset directory (new, empty, or a dataset of the same spec to continue).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Indenter shapes to draw from, comma-separated.
    #[arg(
        long,
        value_name = "pentagon,rectangle",
        value_delimiter = ',',
        default_value = "pentagon,rectangle"
    )]
    shapes: Vec<String>,
    /// The strongest press, N (forces are uniform from 0.25 N up to it).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 9.0,
        allow_negative_numbers = true
    )]
    force_max: f64,
    /// Seed of every draw (shape, force, contact, angle, label noise, image noise).
    #[arg(long, value_name = "S", default_value_t = 1)]
    seed: u64,
    /// Share of frames without contact.
    #[arg(
        long,
        value_name = "0..1",
        default_value_t = NO_CONTACT_FRACTION,
        allow_negative_numbers = true
    )]
    no_contact_fraction: f64,
    /// Frames rendered at once, each by its own single-threaded renderer (1: one renderer on
    /// the sensor file's `threads`).
    #[arg(long, value_name = "N", default_value_t = 2)]
    workers: usize,
}

pub fn run(args: SimDatasetArgs) -> anyhow::Result<()> {
    fringe_rig::store::outside_runs(&args.out).context("--out")?;
    let sensor = load_sensor(&args.sensor)?;
    let spec = DatasetSpec {
        count: args.count,
        shapes: args.shapes.iter().map(|s| s.trim().to_string()).collect(),
        force_max: Newtons(args.force_max),
        seed: args.seed,
        no_contact_fraction: args.no_contact_fraction,
    };
    spec.check(&sensor)
        .map_err(|e| anyhow!("--{} {}: {}", e.key, e.value, e.allowed))?;
    if !(1..=64).contains(&args.workers) {
        bail!("--workers {}: use 1 to 64", args.workers);
    }
    let out = &args.out;
    let mut meter = None;
    let written = write_dataset(
        &spec,
        &sensor,
        out,
        args.workers,
        &mut |event| match event {
            DatasetEvent::Continuing { done, count } => {
                println!("continuing: {done} of {count} frames already rendered")
            }
            DatasetEvent::Rendering { total } => meter = Some(Meter::new(total)),
            DatasetEvent::Rendered { done, from, .. } => {
                if let Some(m) = &mut meter {
                    m.show(done, from)
                }
            }
            DatasetEvent::RenderingOver => {
                if let Some(m) = &meter {
                    m.finish()
                }
            }
        },
    )
    .map_err(with_flags)?;
    let rendered = written.rendered;
    let rate = rendered.frames as f64 / rendered.rendering.as_secs_f64().max(1e-9);
    println!(
        "wrote {} frames ({} without contact) of sensor {} to {}: {} rendered in {:.1} s, {rate:.1} frames/s with {} worker{} (after {:.1} s of renderer start-up)",
        spec.count,
        written.without_contact,
        sensor.id,
        out.display(),
        rendered.frames,
        written.elapsed.as_secs_f64(),
        args.workers,
        if args.workers == 1 { "" } else { "s" },
        rendered.startup.as_secs_f64(),
    );
    println!(
        "labels {}, profile {} (fringe eval --model MODEL {} uses it)",
        written.labels.display(),
        written.profile.display(),
        out.display()
    );
    Ok(())
}

/// The dataset directory's refusals said with the flags that change them.
fn with_flags(e: DatasetError) -> anyhow::Error {
    match e {
        DatasetError::OutIsFile { out } => anyhow!(
            "--out {}: is a file, not a directory: choose a new or empty directory",
            out.display()
        ),
        DatasetError::OutUnreadable { out, source } => anyhow::Error::new(source)
            .context(format!("--out {}: cannot read the directory", out.display())),
        DatasetError::OutNotEmpty { out } => anyhow!(
            "--out {}: the directory is not empty and holds no {SIM_DATASET_DOC}: choose a new or empty directory",
            out.display()
        ),
        DatasetError::OtherDataset {
            out,
            doc,
            differences,
        } => anyhow!(
            "--out {}: {} describes another dataset ({}): choose a new directory, or give that dataset's flags to continue it",
            out.display(),
            doc.display(),
            differences.join("; ")
        ),
        DatasetError::NoRoom {
            images,
            frames,
            needed,
            per_frame,
            free,
        } => anyhow!(
            "{}: {frames} frames need about {} ({} each) and the disk holding it has {} free; free space, choose another --out, or lower --count",
            images.display(),
            human(needed),
            human(per_frame),
            human(free)
        ),
        other => other.into(),
    }
}

/// Progress on stderr: a `\r` line on a terminal, otherwise a line every ~10 %.
struct Meter {
    total: u64,
    tty: bool,
    next_tenth: u64,
    shown: Instant,
}

impl Meter {
    fn new(total: u64) -> Meter {
        Meter {
            total,
            tty: std::io::stderr().is_terminal(),
            next_tenth: 1,
            shown: Instant::now(),
        }
    }

    fn show(&mut self, done: u64, from: Instant) {
        let total = self.total.max(1);
        let line = || {
            let secs = from.elapsed().as_secs_f64().max(1e-9);
            let rate = done as f64 / secs;
            let eta = (total - done.min(total)) as f64 / rate.max(1e-9);
            format!(
                "rendering: {done} of {total} frames ({} %), {rate:.1} frames/s, ETA {}",
                100 * done / total,
                eta_text(eta)
            )
        };
        if self.tty {
            if done == total || self.shown.elapsed() >= Duration::from_millis(200) {
                self.shown = Instant::now();
                let mut err = std::io::stderr();
                let _ = write!(err, "\r{}\x1b[K", line());
                let _ = err.flush();
            }
        } else if done * 10 >= self.next_tenth * total {
            while done * 10 >= self.next_tenth * total {
                self.next_tenth += 1;
            }
            let _ = writeln!(std::io::stderr(), "{}", line());
        }
    }

    fn finish(&self) {
        if self.tty {
            let _ = writeln!(std::io::stderr());
        }
    }
}

fn eta_text(seconds: f64) -> String {
    let s = seconds.round() as u64;
    if s >= 3600 {
        format!("{}h{:02}m", s / 3600, (s % 3600) / 60)
    } else if s >= 60 {
        format!("{}m{:02}s", s / 60, s % 60)
    } else {
        format!("{s} s")
    }
}
