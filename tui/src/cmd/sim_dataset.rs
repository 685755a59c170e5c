//! `fringe sim dataset`: synthetic training frames in the reference layout, rendered straight
//! from the simulator (no motion): `DIR/0.images/image_K.png`, `DIR/0.labels.csv` (the columns of
//! `fringe export --format reference`), `DIR/profile.toml` (the sensor's design geometry as a
//! calibration profile, with its registration) and `DIR/dataset.json` (what was asked for).
//!
//! Frames are drawn by `fringe_sim::dataset::frame`, a pure function of (seed, index): workers
//! take the next index to render, each with its own renderer, and a run interrupted at any point
//! continues with the images it left (each image is written under a temporary name and renamed
//! when complete). The labels are written last, atomically.

use super::sim_render::load_sensor;
use anyhow::{anyhow, bail, Context};
use fringe_rig::camera::writer::save_png;
use fringe_rig::camera::{Frame, PixelFormat};
use fringe_rig::clock::HostTime;
use fringe_rig::reference_layout::{LabelRow, LabelWriter, Shape, IMAGES, LABELS};
use fringe_rig::store::durable::write_atomic;
use fringe_rig::units::Newtons;
use fringe_sim::dataset::{frame, DatasetSpec, SyntheticFrame, NO_CONTACT_FRACTION};
use fringe_sim::optics::render::Renderer;
use fringe_sim::optics::sensor::SensorConfig;
use fringe_sim::scene::FrameRenderer;
use std::io::{IsTerminal, Write as _};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use fringe_rig::reference_layout::{SIM_DATASET_DOC, SIM_DATASET_PROFILE};
/// Suffix of an image being written (removed when a run continues).
const PARTIAL: &str = ".partial";

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

/// `dataset.json`: everything the frames follow from, the sensor build with every key of its
/// file (defaults filled in).
fn dataset_document(
    spec: &DatasetSpec,
    sensor: &SensorConfig,
) -> anyhow::Result<serde_json::Value> {
    Ok(serde_json::json!({
        "fringe_version": env!("CARGO_PKG_VERSION"),
        "sensor_id": sensor.id,
        "seed": spec.seed,
        "count": spec.count,
        "shapes": spec.shapes,
        "force_max_n": spec.force_max.0,
        "no_contact_fraction": spec.no_contact_fraction,
        "sensor": serde_json::to_value(sensor).context("cannot encode the sensor build")?,
    }))
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
    let images = out.join(IMAGES);
    // Before anything is written: the frames still to render must fit on the disk.
    let rendered_before = (0..spec.count)
        .filter(|k| images.join(image_name(*k)).is_file())
        .count() as u64;
    check_room(&images, &sensor, spec.count - rendered_before)?;
    let document = dataset_document(&spec, &sensor)?;
    let already = prepare(out, &document)?;
    std::fs::create_dir_all(&images)
        .with_context(|| format!("cannot create {}", images.display()))?;
    let json = serde_json::to_string_pretty(&document).context("cannot encode dataset.json")?;
    write_atomic(&out.join(SIM_DATASET_DOC), json.as_bytes())?;
    let profile_path = out.join(SIM_DATASET_PROFILE);
    fringe_app::sim_bench::sensor_profile(
        &sensor,
        &sensor.id,
        format!(
            "the simulated {} sensor's design geometry (fringe sim dataset); contact labels in its sensor frame",
            sensor.id
        ),
        [0.0, 0.0],
    )
    .save(&profile_path)?;

    remove_partial(&images)?;
    let todo: Vec<u64> = (0..spec.count)
        .filter(|k| !images.join(image_name(*k)).is_file())
        .collect();
    let done_before = spec.count - todo.len() as u64;
    if already && done_before > 0 {
        println!(
            "continuing: {done_before} of {} frames already rendered",
            spec.count
        );
    }
    let started = Instant::now();
    let rendered = render_all(&spec, &sensor, &images, &todo, args.workers)?;
    let elapsed = started.elapsed();

    let labels_path = out.join(LABELS);
    let (labels, without_contact) = labels_csv(&spec, &sensor)
        .with_context(|| format!("cannot write {}", labels_path.display()))?;
    write_atomic(&labels_path, &labels)?;
    let rate = rendered.frames as f64 / rendered.rendering.as_secs_f64().max(1e-9);
    println!(
        "wrote {} frames ({without_contact} without contact) of sensor {} to {}: {} rendered in {:.1} s, {rate:.1} frames/s with {} worker{} (after {:.1} s of renderer start-up)",
        spec.count,
        sensor.id,
        out.display(),
        rendered.frames,
        elapsed.as_secs_f64(),
        args.workers,
        if args.workers == 1 { "" } else { "s" },
        rendered.startup.as_secs_f64(),
    );
    println!(
        "labels {}, profile {} (fringe eval --model MODEL {} uses it)",
        labels_path.display(),
        profile_path.display(),
        out.display()
    );
    Ok(())
}

/// Refuses to start when `frames` more frames cannot fit on the disk holding `images`. A frame
/// takes what a rendered frame of this sensor takes: one already there, else half its raw RGB
/// size (lossless PNG of fringes: 3.3 MB for 1920x1200).
fn check_room(images: &Path, sensor: &SensorConfig, frames: u64) -> anyhow::Result<()> {
    use fringe_rig::store::disk_space::{available_bytes, human};
    if frames == 0 {
        return Ok(());
    }
    let seen = std::fs::read_dir(images)
        .ok()
        .into_iter()
        .flatten()
        .filter_map(Result::ok)
        .filter_map(|e| e.metadata().ok())
        .filter(|m| m.is_file() && m.len() > 0)
        .map(|m| m.len())
        .max();
    let raw = u64::from(sensor.geometry.width) * u64::from(sensor.geometry.height) * 3;
    let per_frame = seen.unwrap_or(raw / 2);
    let needed = per_frame.saturating_mul(frames);
    let free = available_bytes(images)
        .with_context(|| format!("{}: cannot tell the free disk space", images.display()))?;
    if needed > free {
        bail!(
            "{}: {frames} frames need about {} ({} each) and the disk holding it has {} free; free space, choose another --out, or lower --count",
            images.display(),
            human(needed),
            human(per_frame),
            human(free)
        );
    }
    Ok(())
}

/// Checks `out`: a new or empty directory, or one holding a dataset of the same spec (true).
fn prepare(out: &Path, document: &serde_json::Value) -> anyhow::Result<bool> {
    if !out.exists() {
        return Ok(false);
    }
    if !out.is_dir() {
        bail!(
            "--out {}: is a file, not a directory: choose a new or empty directory",
            out.display()
        );
    }
    let doc_path = out.join(SIM_DATASET_DOC);
    if !doc_path.exists() {
        let mut entries = std::fs::read_dir(out)
            .with_context(|| format!("--out {}: cannot read the directory", out.display()))?;
        if entries.next().is_some() {
            bail!(
                "--out {}: the directory is not empty and holds no {SIM_DATASET_DOC}: choose a new or empty directory",
                out.display()
            );
        }
        return Ok(false);
    }
    let text = std::fs::read_to_string(&doc_path)
        .with_context(|| format!("cannot read {}", doc_path.display()))?;
    let old: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a dataset description", doc_path.display()))?;
    // Compared as both read back from text: a float parsed from JSON may differ from the
    // value it was written from in the last bit.
    let new: serde_json::Value = serde_json::to_string(document)
        .and_then(|text| serde_json::from_str(&text))
        .context("cannot encode dataset.json")?;
    let differences = differences(&old, &new);
    if !differences.is_empty() {
        bail!(
            "--out {}: {} describes another dataset ({}): choose a new directory, or give that dataset's flags to continue it",
            out.display(),
            doc_path.display(),
            differences.join("; ")
        );
    }
    Ok(true)
}

/// The keys (but the software version) whose values differ, as "key: OLD there, NEW here".
fn differences(old: &serde_json::Value, new: &serde_json::Value) -> Vec<String> {
    let (Some(old), Some(new)) = (old.as_object(), new.as_object()) else {
        return vec!["not a JSON object".into()];
    };
    let mut keys: Vec<&String> = old.keys().chain(new.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter(|k| k.as_str() != "fringe_version" && old.get(*k) != new.get(*k))
        .map(|k| {
            let show = |v: Option<&serde_json::Value>| match v {
                Some(serde_json::Value::Object(_)) => "(a sensor build)".to_string(),
                Some(v) => v.to_string(),
                None => "missing".into(),
            };
            format!("{k}: {} there, {} here", show(old.get(k)), show(new.get(k)))
        })
        .collect()
}

/// Removes images a stopped run left half-written.
fn remove_partial(images: &Path) -> anyhow::Result<()> {
    let entries =
        std::fs::read_dir(images).with_context(|| format!("cannot read {}", images.display()))?;
    for entry in entries {
        let path = entry
            .with_context(|| format!("cannot read {}", images.display()))?
            .path();
        if path.to_string_lossy().ends_with(PARTIAL) {
            std::fs::remove_file(&path)
                .with_context(|| format!("cannot remove {}", path.display()))?;
        }
    }
    Ok(())
}

fn image_name(k: u64) -> String {
    format!("image_{k}.png")
}

/// What the workers did.
struct Rendered {
    frames: u64,
    /// Until every renderer was built.
    startup: Duration,
    /// From then until the last frame.
    rendering: Duration,
}

/// One worker's message.
enum Progress {
    Ready,
    Frame,
    Failed(anyhow::Error),
}

/// Renders and saves frames `todo` on `workers` threads, printing progress on stderr.
fn render_all(
    spec: &DatasetSpec,
    sensor: &SensorConfig,
    images: &Path,
    todo: &[u64],
    workers: usize,
) -> anyhow::Result<Rendered> {
    if todo.is_empty() {
        return Ok(Rendered {
            frames: 0,
            startup: Duration::ZERO,
            rendering: Duration::ZERO,
        });
    }
    let workers = workers.min(todo.len());
    let mut config = sensor.clone();
    if workers > 1 {
        // Whole frames in parallel: rendering and PNG encoding both keep every core busy.
        config.threads = 1;
    }
    let work = Work {
        spec,
        sensor,
        images,
        todo,
        next: AtomicUsize::new(0),
        stop: AtomicBool::new(false),
    };
    let (tx, rx) = crossbeam_channel::unbounded::<Progress>();
    let started = Instant::now();
    let (rendered, first_error) = std::thread::scope(|scope| {
        for _ in 0..workers {
            let tx = tx.clone();
            let (config, work) = (&config, &work);
            scope.spawn(move || work.render(config, tx));
        }
        drop(tx);
        work.follow(rx, workers, started)
    });
    match first_error {
        Some(e) => Err(e),
        None => Ok(rendered),
    }
}

/// The frames to render, shared by the workers.
struct Work<'a> {
    spec: &'a DatasetSpec,
    sensor: &'a SensorConfig,
    images: &'a Path,
    todo: &'a [u64],
    /// Index into `todo` of the next frame to take.
    next: AtomicUsize,
    /// Set on the first failure: the workers take no more frames.
    stop: AtomicBool,
}

impl Work<'_> {
    /// One worker: builds a renderer on `config`, then renders and saves frames until none
    /// is left or one failed, telling `tx` of each.
    fn render(&self, config: &SensorConfig, tx: crossbeam_channel::Sender<Progress>) {
        let mut renderer = match Renderer::new(config.clone()) {
            Ok(r) => r,
            Err(e) => {
                let _ = tx.send(Progress::Failed(e.into()));
                return;
            }
        };
        let _ = tx.send(Progress::Ready);
        let mut rgb = Vec::new();
        while !self.stop.load(Ordering::Relaxed) {
            let Some(&k) = self.todo.get(self.next.fetch_add(1, Ordering::Relaxed)) else {
                break;
            };
            let f = frame(self.spec, self.sensor, k);
            let message = match save(&mut renderer, &f, self.images, &mut rgb) {
                Ok(()) => Progress::Frame,
                Err(e) => Progress::Failed(e),
            };
            if tx.send(message).is_err() {
                break;
            }
        }
    }

    /// Follows the `workers`' messages until they are all done, showing progress; stops them
    /// at the first failure, which is returned with what was rendered.
    fn follow(
        &self,
        rx: crossbeam_channel::Receiver<Progress>,
        workers: usize,
        started: Instant,
    ) -> (Rendered, Option<anyhow::Error>) {
        let mut first_error = None;
        let mut rendered = Rendered {
            frames: 0,
            startup: Duration::ZERO,
            rendering: Duration::ZERO,
        };
        let mut meter = Meter::new(self.todo.len() as u64);
        let mut ready = 0;
        let mut rendering_from = started;
        for message in rx {
            match message {
                Progress::Ready => {
                    ready += 1;
                    if ready == workers {
                        rendering_from = Instant::now();
                        rendered.startup = started.elapsed();
                    }
                }
                Progress::Frame => {
                    rendered.frames += 1;
                    meter.show(rendered.frames, rendering_from);
                }
                Progress::Failed(e) => {
                    self.stop.store(true, Ordering::Relaxed);
                    first_error.get_or_insert(e);
                }
            }
        }
        meter.finish();
        rendered.rendering = rendering_from.elapsed();
        (rendered, first_error)
    }
}

/// Renders frame `f` and writes it as `image_K.png` (under a temporary name first).
fn save(
    renderer: &mut Renderer,
    f: &SyntheticFrame,
    images: &Path,
    rgb: &mut Vec<u8>,
) -> anyhow::Result<()> {
    renderer.render(&f.scene, f.render_index, rgb);
    let target = images.join(image_name(f.index));
    let partial = images.join(format!("{}{PARTIAL}", image_name(f.index)));
    let image = Frame {
        id: f.index,
        device_timestamp: 0,
        host_arrival: HostTime(0),
        width: renderer.width(),
        height: renderer.height(),
        format: PixelFormat::Rgb8,
        data: std::mem::take(rgb),
    };
    let saved = save_png(&image, &partial);
    *rgb = image.data;
    saved?;
    std::fs::rename(&partial, &target).with_context(|| {
        format!(
            "cannot rename {} to {}",
            partial.display(),
            target.display()
        )
    })
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

/// `0.labels.csv` of the whole dataset, and how many rows have no contact.
fn labels_csv(spec: &DatasetSpec, sensor: &SensorConfig) -> std::io::Result<(Vec<u8>, u64)> {
    let mut csv = LabelWriter::new(Vec::with_capacity(160 * spec.count as usize), None)?;
    let mut without = 0;
    for k in 0..spec.count {
        let f = frame(spec, sensor, k);
        let shape = match f.shape {
            Some(name) => Shape::parse(name),
            None => {
                without += 1;
                Shape::NoContact
            }
        };
        csv.write(&LabelRow {
            image: image_name(k),
            wrench: f.wrench.to_array(),
            contact: f.contact_mm(),
            shape,
        })?;
    }
    Ok((csv.finish()?, without))
}
