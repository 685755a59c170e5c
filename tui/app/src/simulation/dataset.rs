//! A synthetic training dataset in the reference layout, rendered straight from the simulator
//! (no motion; `fringe sim dataset`): `DIR/0.images/image_K.png`, `DIR/0.labels.csv` (the
//! columns of `fringe export --format reference`), `DIR/profile.toml` (the sensor's design
//! geometry as a calibration profile, with its registration) and `DIR/dataset.json` (what was
//! asked for).
//!
//! Frames are drawn by `fringe_sim::dataset::frame`, a pure function of (seed, index): workers
//! take the next index to render, each with its own renderer, and a run interrupted at any point
//! continues with the images it left (each image is written under a temporary name and renamed
//! when complete). The labels are written last, atomically.

use crate::rig::simulated::sensor_profile;
use fringe_calibration::ProfileError;
use fringe_rig::reference_layout::{LabelRow, LabelWriter, Shape, IMAGES, LABELS};
use fringe_rig::reference_layout::{SIM_DATASET_DOC, SIM_DATASET_PROFILE};
use fringe_rig::store::available_bytes;
use fringe_rig::store::save_png;
use fringe_rig::store::write_atomic;
use fringe_rig::store::FrameFileError;
use fringe_rig::store::StoreError;
use fringe_rig::HostTime;
use fringe_rig::{Frame, PixelFormat};
use fringe_sim::dataset::{frame, DatasetSpec, SyntheticFrame};
use fringe_sim::FrameRenderer;
use fringe_sim::Renderer;
use fringe_sim::{SensorConfig, SensorConfigError};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Suffix of an image being written (removed when a run continues).
const PARTIAL: &str = ".partial";

/// Why a dataset was not written. The directory's refusals carry what the front end says
/// about its own flags.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The dataset directory is a file.
    #[error("{}: is a file, not a directory", out.display())]
    OutIsFile { out: PathBuf },
    /// The dataset directory cannot be read.
    #[error("{}: cannot read the directory", out.display())]
    OutUnreadable {
        out: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The dataset directory holds something else than a dataset.
    #[error("{}: the directory is not empty and holds no {SIM_DATASET_DOC}", out.display())]
    OutNotEmpty { out: PathBuf },
    /// The dataset directory holds a dataset of another spec.
    #[error("{}: {} describes another dataset ({})", out.display(), doc.display(), differences.join("; "))]
    OtherDataset {
        out: PathBuf,
        doc: PathBuf,
        /// "key: OLD there, NEW here".
        differences: Vec<String>,
    },
    /// The frames still to render would not fit on the disk.
    #[error("{}: {frames} frames need about {needed} bytes and the disk holding it has {free} bytes free", images.display())]
    NoRoom {
        images: PathBuf,
        frames: u64,
        /// Bytes, all frames and one frame.
        needed: u64,
        per_frame: u64,
        free: u64,
    },
    /// A file or directory could not be read or written: `context` says which.
    #[error("{context}")]
    Io {
        context: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("{0}")]
    Store(#[source] StoreError),
    #[error("{0}")]
    Profile(#[source] ProfileError),
    #[error("{0}")]
    Image(#[source] FrameFileError),
    #[error("{0}")]
    Renderer(#[source] SensorConfigError),
}

fn io(context: String) -> impl FnOnce(std::io::Error) -> DatasetError {
    move |source| DatasetError::Io {
        context,
        source: Box::new(source),
    }
}

fn json(context: &str) -> impl FnOnce(serde_json::Error) -> DatasetError + '_ {
    move |source| DatasetError::Io {
        context: context.to_string(),
        source: Box::new(source),
    }
}

/// What happened while a dataset was written, for the front end to show.
pub enum DatasetEvent {
    /// Continuing a dataset of the same spec: `done` of `count` frames already rendered.
    Continuing { done: u64, count: u64 },
    /// The renderers start on `total` frames.
    Rendering { total: u64 },
    /// `done` of `total` frames rendered, the rendering having begun at `from`.
    Rendered {
        done: u64,
        total: u64,
        from: Instant,
    },
    /// The rendering is over.
    RenderingOver,
}

/// What the workers did.
#[derive(Debug, Clone, Copy)]
pub struct Rendered {
    pub frames: u64,
    /// Until every renderer was built.
    pub startup: Duration,
    /// From then until the last frame.
    pub rendering: Duration,
}

/// A dataset written.
#[derive(Debug)]
pub struct DatasetWritten {
    pub rendered: Rendered,
    /// From the first frame rendered to the last.
    pub elapsed: Duration,
    /// Rows of the labels without contact.
    pub without_contact: u64,
    pub labels: PathBuf,
    pub profile: PathBuf,
}

/// Writes (or continues) the dataset `spec` of `sensor` in `out` on `workers` threads, telling
/// `events` how it goes. `spec` is checked against `sensor` by the caller.
pub fn write_dataset(
    spec: &DatasetSpec,
    sensor: &SensorConfig,
    out: &Path,
    workers: usize,
    events: &mut dyn FnMut(DatasetEvent),
) -> Result<DatasetWritten, DatasetError> {
    let images = out.join(IMAGES);
    // Before anything is written: the frames still to render must fit on the disk.
    let rendered_before = (0..spec.count)
        .filter(|k| images.join(image_name(*k)).is_file())
        .count() as u64;
    check_room(&images, sensor, spec.count - rendered_before)?;
    let document = dataset_document(spec, sensor)?;
    let already = prepare(out, &document)?;
    std::fs::create_dir_all(&images).map_err(io(format!("cannot create {}", images.display())))?;
    let json_text =
        serde_json::to_string_pretty(&document).map_err(json("cannot encode dataset.json"))?;
    write_atomic(&out.join(SIM_DATASET_DOC), json_text.as_bytes()).map_err(DatasetError::Store)?;
    let profile = out.join(SIM_DATASET_PROFILE);
    sensor_profile(
        sensor,
        &sensor.id,
        format!(
            "the simulated {} sensor's design geometry (fringe sim dataset); contact labels in its sensor frame",
            sensor.id
        ),
        [0.0, 0.0],
    )
    .save(&profile)
    .map_err(DatasetError::Profile)?;

    remove_partial(&images)?;
    let todo: Vec<u64> = (0..spec.count)
        .filter(|k| !images.join(image_name(*k)).is_file())
        .collect();
    let done_before = spec.count - todo.len() as u64;
    if already && done_before > 0 {
        events(DatasetEvent::Continuing {
            done: done_before,
            count: spec.count,
        });
    }
    let started = Instant::now();
    let rendered = render_all(spec, sensor, &images, &todo, workers, events)?;
    let elapsed = started.elapsed();

    let labels = out.join(LABELS);
    let (csv, without_contact) =
        labels_csv(spec, sensor).map_err(io(format!("cannot write {}", labels.display())))?;
    write_atomic(&labels, &csv).map_err(DatasetError::Store)?;
    Ok(DatasetWritten {
        rendered,
        elapsed,
        without_contact,
        labels,
        profile,
    })
}

/// `dataset.json`: everything the frames follow from, the sensor build with every key of its
/// file (defaults filled in).
fn dataset_document(
    spec: &DatasetSpec,
    sensor: &SensorConfig,
) -> Result<serde_json::Value, DatasetError> {
    Ok(serde_json::json!({
        "fringe_version": env!("CARGO_PKG_VERSION"),
        "sensor_id": sensor.id,
        "seed": spec.seed,
        "count": spec.count,
        "shapes": spec.shapes,
        "force_max_n": spec.force_max.0,
        "no_contact_fraction": spec.no_contact_fraction,
        "sensor": serde_json::to_value(sensor).map_err(json("cannot encode the sensor build"))?,
    }))
}

/// Refuses to start when `frames` more frames cannot fit on the disk holding `images`. A frame
/// takes what a rendered frame of this sensor takes: one already there, else half its raw RGB
/// size (lossless PNG of fringes: 3.3 MB for 1920x1200).
fn check_room(images: &Path, sensor: &SensorConfig, frames: u64) -> Result<(), DatasetError> {
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
    let free = available_bytes(images).map_err(io(format!(
        "{}: cannot tell the free disk space",
        images.display()
    )))?;
    if needed > free {
        return Err(DatasetError::NoRoom {
            images: images.to_path_buf(),
            frames,
            needed,
            per_frame,
            free,
        });
    }
    Ok(())
}

/// Checks `out`: a new or empty directory, or one holding a dataset of the same spec (true).
fn prepare(out: &Path, document: &serde_json::Value) -> Result<bool, DatasetError> {
    if !out.exists() {
        return Ok(false);
    }
    if !out.is_dir() {
        return Err(DatasetError::OutIsFile {
            out: out.to_path_buf(),
        });
    }
    let doc_path = out.join(SIM_DATASET_DOC);
    if !doc_path.exists() {
        let mut entries = std::fs::read_dir(out).map_err(|source| DatasetError::OutUnreadable {
            out: out.to_path_buf(),
            source,
        })?;
        if entries.next().is_some() {
            return Err(DatasetError::OutNotEmpty {
                out: out.to_path_buf(),
            });
        }
        return Ok(false);
    }
    let text = std::fs::read_to_string(&doc_path)
        .map_err(io(format!("cannot read {}", doc_path.display())))?;
    let context = format!("{}: not a dataset description", doc_path.display());
    let old: serde_json::Value = serde_json::from_str(&text).map_err(json(&context))?;
    // Compared as both read back from text: a float parsed from JSON may differ from the
    // value it was written from in the last bit.
    let new: serde_json::Value = serde_json::to_string(document)
        .and_then(|text| serde_json::from_str(&text))
        .map_err(json("cannot encode dataset.json"))?;
    let differences = differences(&old, &new);
    if !differences.is_empty() {
        return Err(DatasetError::OtherDataset {
            out: out.to_path_buf(),
            doc: doc_path,
            differences,
        });
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
fn remove_partial(images: &Path) -> Result<(), DatasetError> {
    let read_err = || io(format!("cannot read {}", images.display()));
    let entries = std::fs::read_dir(images).map_err(read_err())?;
    for entry in entries {
        let path = entry.map_err(read_err())?.path();
        if path.to_string_lossy().ends_with(PARTIAL) {
            std::fs::remove_file(&path).map_err(io(format!("cannot remove {}", path.display())))?;
        }
    }
    Ok(())
}

fn image_name(k: u64) -> String {
    format!("image_{k}.png")
}

/// One worker's message.
enum Progress {
    Ready,
    Frame,
    Failed(DatasetError),
}

/// Renders and saves frames `todo` on `workers` threads, telling `events` of each frame.
fn render_all(
    spec: &DatasetSpec,
    sensor: &SensorConfig,
    images: &Path,
    todo: &[u64],
    workers: usize,
    events: &mut dyn FnMut(DatasetEvent),
) -> Result<Rendered, DatasetError> {
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
    let (tx, rx) = mpsc::channel::<Progress>();
    let started = Instant::now();
    let (rendered, first_error) = std::thread::scope(|scope| {
        for _ in 0..workers {
            let tx = tx.clone();
            let (config, work) = (&config, &work);
            scope.spawn(move || work.render(config, tx));
        }
        drop(tx);
        work.follow(rx, workers, started, events)
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
    fn render(&self, config: &SensorConfig, tx: mpsc::Sender<Progress>) {
        let mut renderer = match Renderer::new(config.clone()) {
            Ok(r) => r,
            Err(e) => {
                let _ = tx.send(Progress::Failed(DatasetError::Renderer(e)));
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

    /// Follows the `workers`' messages until they are all done, telling `events` of each
    /// frame; stops them at the first failure, which is returned with what was rendered.
    fn follow(
        &self,
        rx: mpsc::Receiver<Progress>,
        workers: usize,
        started: Instant,
        events: &mut dyn FnMut(DatasetEvent),
    ) -> (Rendered, Option<DatasetError>) {
        let mut first_error = None;
        let mut rendered = Rendered {
            frames: 0,
            startup: Duration::ZERO,
            rendering: Duration::ZERO,
        };
        let total = self.todo.len() as u64;
        events(DatasetEvent::Rendering { total });
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
                    events(DatasetEvent::Rendered {
                        done: rendered.frames,
                        total,
                        from: rendering_from,
                    });
                }
                Progress::Failed(e) => {
                    self.stop.store(true, Ordering::Relaxed);
                    first_error.get_or_insert(e);
                }
            }
        }
        events(DatasetEvent::RenderingOver);
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
) -> Result<(), DatasetError> {
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
    saved.map_err(DatasetError::Image)?;
    std::fs::rename(&partial, &target).map_err(io(format!(
        "cannot rename {} to {}",
        partial.display(),
        target.display()
    )))
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
