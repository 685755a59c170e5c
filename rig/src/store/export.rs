//! Export to the reference pipeline's layout (`crate::reference_layout`):
//! `0.images/image_K.tiff` and `0.labels.csv` with exactly its columns, so the paper's Python
//! training code reads our runs unchanged. Frames whose label is not valid are left out and
//! counted. Beside them, `0.export.json` records where the rows came from: each run, its sensor and the
//! calibration profile its contact labels are relative to.

use super::documents::{now_utc, FrameRecord, StartDocument};
use super::durable::{sync_dir, write_atomic, write_synced};
use super::error::StoreError;
use super::frames::debayer;
use super::frames::{in_whole_frame, FrameStorage, StoredFrame};
use super::run_lock::RunLock;
use super::run_reader::RunReader;
use super::verify::verify;
use crate::camera::PixelFormat;
use crate::reference_layout::{LabelRow, LabelWriter, Shape, IMAGES, LABELS, NO_CONTACT};
use std::collections::HashSet;
use std::io::Cursor;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// How the exported TIFF images are compressed. All three are baseline TIFF as libtiff (PIL,
/// OpenCV) reads it: LZW or deflate (Adobe, at its fastest level) with the horizontal
/// predictor, or none. Measured on the main job's frames (BENCHMARKS.md, "Export"): LZW 2.6 MB
/// an image, deflate at its fastest level 4.3 MB (its default level would give 2.6 MB at a
/// quarter of the speed), uncompressed 6.9 MB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ImageCompression {
    /// LZW with the horizontal predictor: the smallest at the pace of the export (the default).
    #[default]
    Lzw,
    /// Deflate (its fastest level) with the horizontal predictor.
    Deflate,
    /// Uncompressed, as exports were written before.
    None,
}

impl ImageCompression {
    /// How messages name it.
    pub fn name(self) -> &'static str {
        match self {
            ImageCompression::Deflate => "deflate",
            ImageCompression::Lzw => "LZW",
            ImageCompression::None => "uncompressed",
        }
    }
}

/// Export options.
#[derive(Debug, Clone, Default)]
pub struct ExportOptions {
    /// Set (by a signal handler) to stop the export: what was written is removed and an error
    /// returned, as for any failed export.
    pub cancel: Option<&'static AtomicBool>,
    /// Round forces, torques and positions to this step (the reference trained on 0.1); without
    /// it they are written at the precision of the measurement
    /// ([`MEASURED_DECIMALS`](crate::reference_layout::MEASURED_DECIMALS)).
    pub round: Option<f64>,
    /// How the TIFF images are compressed.
    pub compression: ImageCompression,
    /// Export runs that fail verify too (their problems are recorded in `0.export.json`): a
    /// record whose frame is missing or damaged is left out, the others exported. Records that
    /// name a file outside their run (or a link, a FIFO) are refused even so.
    pub allow_unverified: bool,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportSummary {
    pub images: u64,
    pub without_contact: u64,
    pub skipped_invalid: u64,
    /// Records left out because a record of the same index or frame file was exported already
    /// (a duplicated line; only in runs exported with `allow_unverified`).
    pub skipped_duplicates: u64,
    /// Records left out because their frame is missing or damaged (only in runs exported with
    /// `allow_unverified`; each is listed in its run's problems).
    pub skipped_damaged: u64,
    pub labels: PathBuf,
    /// `0.export.json`: where every row came from.
    pub provenance: PathBuf,
    /// The runs exported, with the calibration profile each used for its contact labels.
    pub runs: Vec<ExportedRun>,
}

/// One run of an export, as recorded in `0.export.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExportedRun {
    pub dir: String,
    pub run_id: String,
    pub sensor_id: String,
    /// The profile the run's contact labels are relative to (`None`: the rig file's origin).
    pub calibration_profile: Option<String>,
    pub sync_method: String,
    /// Rows of `0.labels.csv` from this run: `image_<first>` to `image_<first + images - 1>`.
    pub first_image: u64,
    pub images: u64,
    /// What verify found wrong with the run, and the frames the export left out as missing or
    /// damaged (exported only with `allow_unverified`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<String>,
}

/// `0.export.json`: the provenance of an export (beside `0.labels.csv`, outside `0.images/`, so
/// the reference code never sees it).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct ExportProvenance {
    pub software: String,
    pub exported_utc: String,
    pub round: Option<f64>,
    pub runs: Vec<ExportedRun>,
}

/// File name of the provenance document.
pub(crate) const PROVENANCE: &str = "0.export.json";

/// The labels row of `record` saved as `image` (none without a force label).
pub(crate) fn label_row(image: &str, record: &FrameRecord) -> Option<LabelRow> {
    let wrench = record.wrench?.to_array();
    let contact = record.contact.filter(|_| record.shape != NO_CONTACT);
    let shape = match record.contact {
        Some(_) => Shape::parse(&record.shape),
        None => Shape::NoContact,
    };
    Some(LabelRow {
        image: image.to_string(),
        wrench,
        contact,
        shape,
    })
}

/// Exports `runs` (in order) into `out`, which must not exist yet or be an empty directory
/// outside every run. Runs that fail verify are refused unless `options.allow_unverified`.
/// Everything is written into a temporary directory beside `out` and renamed to `out` when
/// complete: an export that fails leaves nothing behind, one that succeeds holds nothing else.
pub fn export_reference(
    runs: &[PathBuf],
    out: &Path,
    options: &ExportOptions,
    progress: impl FnMut(u64),
) -> Result<ExportSummary, StoreError> {
    let (parent, staging) = check_destination(runs, out)?;
    remove_stale_partials(&parent, &staging);
    let mut checked = Vec::with_capacity(runs.len());
    // Each run stands still while it is read: a scan or a resume writing it is refused meanwhile,
    // and an export of a run being written is refused.
    let mut _locks = Vec::with_capacity(runs.len());
    for run in runs {
        if RunReader::at(run).is_run() {
            _locks.push(RunLock::read(run)?);
        }
        let report = verify(run)?;
        if !report.ok() && !options.allow_unverified {
            return Err(StoreError::Unverified {
                run: run.clone(),
                count: report.problems.len(),
                first: report.problems[0].clone(),
            });
        }
        checked.push(report.problems);
    }
    std::fs::create_dir_all(&parent).map_err(|e| StoreError::io(&parent, e))?;
    std::fs::create_dir(&staging).map_err(|e| StoreError::io(&staging, e))?;
    let written = write_export(runs, checked, &staging, options, progress).and_then(|summary| {
        // `out` is absent or an empty directory (checked above): either is replaced whole.
        std::fs::rename(&staging, out).map_err(|e| StoreError::io(out, e))?;
        sync_dir(&parent)?;
        Ok(summary)
    });
    match written {
        Ok(summary) => Ok(ExportSummary {
            labels: out.join(LABELS),
            provenance: out.join(PROVENANCE),
            ..summary
        }),
        Err(e) => {
            // Best effort: the error that stopped the export is the one to report.
            let _ = std::fs::remove_dir_all(&staging);
            Err(e)
        }
    }
}

/// Removes what earlier exports to the same destination left when their process was killed:
/// `.<name>.partial-<pid>` (a directory or a file) of a pid that is no longer running, where
/// `staging` is this process's `.<name>.partial-<pid>` in `parent`.
pub fn remove_stale_partials(parent: &Path, staging: &Path) {
    let Some(ours) = staging
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
    else {
        return;
    };
    let Some((prefix, _)) = ours.rsplit_once('-') else {
        return;
    };
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = name
            .strip_prefix(prefix)
            .and_then(|rest| rest.strip_prefix('-'))
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        let alive = Path::new("/proc").join(pid.to_string()).exists();
        if alive {
            continue;
        }
        match entry.file_type() {
            Ok(t) if t.is_dir() => {
                let _ = std::fs::remove_dir_all(entry.path());
            }
            Ok(t) if t.is_file() => {
                let _ = std::fs::remove_file(entry.path());
            }
            _ => {}
        }
    }
}

/// Refuses a destination that is a run, lies inside one, or holds anything; returns the
/// directory `out` is made in and the temporary directory beside it.
fn check_destination(runs: &[PathBuf], out: &Path) -> Result<(PathBuf, PathBuf), StoreError> {
    let refuse = |message: String| StoreError::Content {
        path: out.to_path_buf(),
        message,
    };
    let name = match out.components().next_back() {
        Some(Component::Normal(name)) => name.to_string_lossy().into_owned(),
        _ => {
            return Err(refuse(
                "not a directory name to create (give --out a new or empty directory)".into(),
            ))
        }
    };
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // Into a run (one exported or any other): refused, the run would no longer verify.
    super::layout::outside_runs(out)?;
    let mut seen: Vec<PathBuf> = Vec::with_capacity(runs.len());
    for run in runs {
        let run_real = std::fs::canonicalize(run).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => StoreError::NotARun { dir: run.clone() },
            _ => StoreError::io(run, e),
        })?;
        if seen.contains(&run_real) {
            return Err(StoreError::Content {
                path: run.clone(),
                message: "given twice (each run is exported once)".into(),
            });
        }
        seen.push(run_real);
    }
    if out.join(LABELS).exists() {
        return Err(refuse(
            "an export is already there (choose a new or empty --out directory)".into(),
        ));
    }
    match std::fs::read_dir(out) {
        Ok(mut entries) => {
            if let Some(entry) = entries.next() {
                let what = entry
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .unwrap_or_default();
                return Err(refuse(format!(
                    "is not empty (it holds {what}); choose a new or empty --out directory"
                )));
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(StoreError::io(out, e)),
    }
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    Ok((parent, staging))
}

/// Writes the images, labels and provenance of `runs` into `dir`.
fn write_export(
    runs: &[PathBuf],
    problems: Vec<Vec<String>>,
    dir: &Path,
    options: &ExportOptions,
    mut progress: impl FnMut(u64),
) -> Result<ExportSummary, StoreError> {
    let images = dir.join(IMAGES);
    std::fs::create_dir(&images).map_err(|e| StoreError::io(&images, e))?;
    let labels = dir.join(LABELS);
    let csv = match options.round {
        Some(_) => LabelWriter::new(Vec::new(), options.round),
        None => LabelWriter::measured(Vec::new()),
    }
    .map_err(|e| StoreError::io(&labels, e))?;
    let mut writer = ExportWriter {
        dir,
        images,
        labels,
        options,
        csv,
        counts: ExportCounts::default(),
    };
    let mut exported = Vec::with_capacity(runs.len());
    for (run, mut problems) in runs.iter().zip(problems) {
        let start: StartDocument = RunReader::at(run).start()?;
        let first_image = writer.counts.images;
        problems.extend(writer.export_run(run, &mut progress)?);
        exported.push(ExportedRun {
            dir: run.display().to_string(),
            run_id: start.run_id,
            sensor_id: start.sensor_id,
            calibration_profile: start.calibration_profile.map(|p| p.path),
            sync_method: start.sync_method,
            first_image,
            images: writer.counts.images - first_image,
            problems,
        });
    }
    sync_dir(&writer.images)?;
    let provenance = write_provenance(dir, options, &exported)?;
    let ExportWriter {
        labels,
        csv,
        counts,
        ..
    } = writer;
    let csv = csv.finish().map_err(|e| StoreError::io(&labels, e))?;
    write_atomic(&labels, &csv)?;
    Ok(ExportSummary {
        images: counts.images,
        without_contact: counts.without_contact,
        skipped_invalid: counts.skipped_invalid,
        skipped_duplicates: counts.skipped_duplicates,
        skipped_damaged: counts.skipped_damaged,
        labels,
        provenance,
        runs: exported,
    })
}

/// How many images an export wrote and how many records it left out, so far.
#[derive(Default)]
struct ExportCounts {
    /// Images written (the next image is `image_{images}.tiff`).
    images: u64,
    /// Images written whose frame has no contact.
    without_contact: u64,
    /// Records left out as invalid or without a wrench.
    skipped_invalid: u64,
    /// Records left out for repeating an index or a file of their run.
    skipped_duplicates: u64,
    /// Records left out because their frame is missing or damaged.
    skipped_damaged: u64,
}

/// An export under way: where it writes, the label rows so far and the counts.
struct ExportWriter<'a> {
    /// The export directory.
    dir: &'a Path,
    /// Its image folder.
    images: PathBuf,
    /// Its label file (written at the end).
    labels: PathBuf,
    options: &'a ExportOptions,
    csv: LabelWriter<Vec<u8>>,
    counts: ExportCounts,
}

impl ExportWriter<'_> {
    /// Exports the valid frames of the run in `run`, in record order, skipping repeated ones and,
    /// when unverified runs are allowed, those whose frame is missing or damaged: returns a line
    /// for each of these.
    fn export_run(
        &mut self,
        run: &Path,
        progress: &mut impl FnMut(u64),
    ) -> Result<Vec<String>, StoreError> {
        let mut left_out = Vec::new();
        let reader = RunReader::at(run);
        let storage = reader.start()?.frame_storage();
        let records = reader.frames()?;
        let mut indices = HashSet::new();
        let mut files = HashSet::new();
        for record in records {
            self.check_cancel()?;
            let source = reader.frame_file(&record)?;
            if !indices.insert(record.index) || !files.insert(record.file.clone()) {
                self.counts.skipped_duplicates += 1;
                continue;
            }
            if !record.valid || record.wrench.is_none() {
                self.counts.skipped_invalid += 1;
                continue;
            }
            let image = match read_frame(run, &storage, &record)? {
                Ok(image) => image,
                Err(reason) if self.options.allow_unverified => {
                    left_out.push(format!(
                        "{}: {reason} (frame of record {}): left out of the export",
                        record.file, record.index
                    ));
                    self.counts.skipped_damaged += 1;
                    continue;
                }
                Err(reason) => {
                    return Err(StoreError::Content {
                        path: source,
                        message: format!("{reason} (frame of record {})", record.index),
                    })
                }
            };
            let name = format!("image_{}.tiff", self.counts.images);
            self.write_image(&image, &name)?;
            if let Some(row) = label_row(&name, &record) {
                self.csv
                    .write(&row)
                    .map_err(|e| StoreError::io(&self.labels, e))?;
            }
            if record.contact.is_none() {
                self.counts.without_contact += 1;
            }
            self.counts.images += 1;
            progress(self.counts.images);
        }
        Ok(left_out)
    }

    /// Fails when the export was cancelled (by a signal).
    fn check_cancel(&self) -> Result<(), StoreError> {
        if self
            .options
            .cancel
            .is_some_and(|c| c.load(Ordering::SeqCst))
        {
            return Err(StoreError::Content {
                path: self.dir.to_path_buf(),
                message: "the export was interrupted (Ctrl-C or a signal); nothing was exported"
                    .into(),
            });
        }
        Ok(())
    }

    /// Writes `image` as TIFF image `name`.
    fn write_image(&self, image: &image::DynamicImage, name: &str) -> Result<(), StoreError> {
        let target = self.images.join(name);
        let tiff =
            encode_tiff(image, self.options.compression).map_err(|e| StoreError::Content {
                path: target.clone(),
                message: e.to_string(),
            })?;
        write_synced(&target, &tiff)
    }
}

/// `image` (RGB8 or grey) as a TIFF file compressed as `compression` says.
pub(crate) fn encode_tiff(
    image: &image::DynamicImage,
    compression: ImageCompression,
) -> Result<Vec<u8>, tiff::TiffError> {
    use tiff::encoder::{colortype, Compression, DeflateLevel, Predictor, TiffEncoder};
    let mut out = Cursor::new(Vec::new());
    let (method, predictor) = match compression {
        ImageCompression::Deflate => (
            Compression::Deflate(DeflateLevel::Fast),
            Predictor::Horizontal,
        ),
        ImageCompression::Lzw => (Compression::Lzw, Predictor::Horizontal),
        ImageCompression::None => (Compression::Uncompressed, Predictor::None),
    };
    let mut encoder = TiffEncoder::new(&mut out)?
        .with_compression(method)
        .with_predictor(predictor);
    let (w, h) = (image.width(), image.height());
    match image {
        image::DynamicImage::ImageLuma8(g) => {
            encoder.write_image::<colortype::Gray8>(w, h, g.as_raw())?
        }
        other => encoder.write_image::<colortype::RGB8>(w, h, other.to_rgb8().as_raw())?,
    }
    Ok(out.into_inner())
}

/// What an export of some runs will write, said before it starts: the images it will hold,
/// their bytes and the time to write them, measured by exporting a few of the runs' own frames
/// (spread over them) in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportEstimate {
    /// Images the export will write (valid records with a force label).
    pub images: u64,
    /// Frames exported in memory to measure the rest.
    pub sampled: u64,
    /// Bytes of the images and the labels.
    pub bytes: u64,
    /// Time to write them all, at the sampled frames' pace (reading, demosaicing, encoding) plus
    /// writing the bytes.
    pub time: std::time::Duration,
}

/// Frames sampled for an [`ExportEstimate`].
const ESTIMATE_SAMPLES: usize = 5;

/// Bytes of one row of `0.labels.csv` at the precision of the measurement, about.
const LABEL_ROW_BYTES: u64 = 90;

/// Estimates the export of `runs` with `options` (their compression): counts the images it will
/// write and exports [`ESTIMATE_SAMPLES`] of their frames, spread over the runs, in memory.
pub fn estimate_export(
    runs: &[PathBuf],
    options: &ExportOptions,
) -> Result<ExportEstimate, StoreError> {
    // (run, its storage, the records it will export)
    let mut exportable = Vec::with_capacity(runs.len());
    for run in runs {
        let reader = RunReader::at(run);
        let storage = reader.start()?.frame_storage();
        let mut seen = HashSet::new();
        let records: Vec<FrameRecord> = reader
            .frames()?
            .into_iter()
            .filter(|r| seen.insert(r.index) && r.valid && r.wrench.is_some())
            .collect();
        exportable.push((run, storage, records));
    }
    let images: u64 = exportable.iter().map(|(_, _, r)| r.len() as u64).sum();
    let mut sampled = 0u64;
    let (mut sample_bytes, mut sample_time) = (0u64, std::time::Duration::ZERO);
    for k in 0..ESTIMATE_SAMPLES.min(images as usize) {
        // The k-th of evenly spaced images over all the runs.
        let mut at = (k as u64 * images / ESTIMATE_SAMPLES.min(images as usize) as u64) as usize;
        let Some((run, storage, record)) = exportable.iter().find_map(|(run, storage, records)| {
            if at < records.len() {
                Some((run, storage, &records[at]))
            } else {
                at -= records.len();
                None
            }
        }) else {
            break;
        };
        let started = std::time::Instant::now();
        let Ok(Ok(image)) = read_frame(run, storage, record) else {
            continue;
        };
        let Ok(tiff) = encode_tiff(&image, options.compression) else {
            continue;
        };
        sample_time += started.elapsed();
        sample_bytes += tiff.len() as u64;
        sampled += 1;
    }
    let per = |total: f64| {
        if sampled == 0 {
            0.0
        } else {
            total / sampled as f64
        }
    };
    let image_bytes = per(sample_bytes as f64) * images as f64;
    let bytes = image_bytes as u64 + images * LABEL_ROW_BYTES;
    let time = per(sample_time.as_secs_f64()) * images as f64 + bytes as f64 / WRITE_BYTES_PER_S;
    Ok(ExportEstimate {
        images,
        sampled,
        bytes,
        time: std::time::Duration::try_from_secs_f64(time).unwrap_or(std::time::Duration::MAX),
    })
}

/// The pace of writing the images to disk (each synced) that an estimate assumes, bytes/s.
const WRITE_BYTES_PER_S: f64 = 200e6;

/// The frame of `record` (inside `run`, stored as `storage` says) as the reference code reads
/// images; `Ok(Err(reason))` when it is missing or damaged (the reason without the file's path),
/// an error when the record names what is not the run's own regular file (a link, a FIFO),
/// which no export reads.
fn read_frame(
    run: &Path,
    storage: &FrameStorage,
    record: &FrameRecord,
) -> Result<Result<image::DynamicImage, String>, StoreError> {
    let stored = match RunReader::at(run).stored_frame(storage, record)? {
        Ok(stored) => stored,
        Err(reason) => return Ok(Err(reason)),
    };
    Ok(reference_image(stored).ok_or_else(|| "its pixels do not fill it".to_string()))
}

/// A stored frame as the reference code reads images: RGB (a BayerRG8 mosaic demosaiced by
/// [`debayer::to_rgb8`], fringe's one demosaicing) or grey, the whole camera frame (a run that
/// stored only the disc's square has black around it, where nothing was recorded).
pub(crate) fn reference_image(stored: StoredFrame) -> Option<image::DynamicImage> {
    let (w, h) = (stored.width, stored.height);
    let (channels, pixels) = match stored.format {
        PixelFormat::Mono8 => (1, stored.data),
        PixelFormat::Rgb8 => (3, stored.data),
        PixelFormat::BayerRg8 => (3, debayer::to_rgb8(&stored.data, w as usize, h as usize)),
    };
    let (fw, fh, pixels) = match stored.cutout {
        None => (w, h, pixels),
        Some(c) => (
            c.frame_width,
            c.frame_height,
            in_whole_frame(&pixels, w, channels, c)?,
        ),
    };
    if channels == 1 {
        image::GrayImage::from_raw(fw, fh, pixels).map(Into::into)
    } else {
        image::RgbImage::from_raw(fw, fh, pixels).map(Into::into)
    }
}

/// Writes the provenance document of an export of `exported` into `dir`; its path.
fn write_provenance(
    dir: &Path,
    options: &ExportOptions,
    exported: &[ExportedRun],
) -> Result<PathBuf, StoreError> {
    let provenance = dir.join(PROVENANCE);
    let doc = ExportProvenance {
        software: format!("fringe {}", env!("CARGO_PKG_VERSION")),
        exported_utc: now_utc(),
        round: options.round,
        runs: exported.to_vec(),
    };
    let json = serde_json::to_string_pretty(&doc).map_err(|e| StoreError::Content {
        path: provenance.clone(),
        message: format!("cannot encode: {e}"),
    })?;
    write_atomic(&provenance, json.as_bytes())?;
    Ok(provenance)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::documents::Position;
    use crate::units::{Millimetres, NewtonMetres, Newtons, Wrench};

    fn record(contact: Option<[f64; 2]>, fz: f64) -> FrameRecord {
        let p = Position {
            x: Millimetres(0.0),
            y: Millimetres(0.0),
            z: Millimetres(0.0),
        };
        FrameRecord {
            index: 0,
            frame_id: 0,
            file: "frames/00000000.png".into(),
            device_timestamp: 0,
            host_arrival_ns: 0,
            exposure: None,
            exposure_ticks: None,
            point: 0,
            commanded: p,
            measured: p,
            wrench: Some(Wrench {
                fx: Newtons(0.3),
                fy: Newtons(-0.4),
                fz: Newtons(fz),
                tx: NewtonMetres(0.012),
                ty: NewtonMetres(-0.034),
                tz: NewtonMetres(0.0),
            }),
            shear: None,
            shape: "pentagon".into(),
            contact,
            valid: true,
            notes: vec![],
        }
    }

    /// The labels file's line for `record` saved as `image`.
    fn line(image: &str, record: &FrameRecord, round: Option<f64>) -> String {
        let mut w = LabelWriter::new(Vec::new(), round).expect("writer");
        w.write(&label_row(image, record).expect("row"))
            .expect("write");
        let text = String::from_utf8(w.finish().expect("finish")).expect("utf-8");
        text.lines().nth(1).expect("a row").to_string()
    }

    #[test]
    fn rows_follow_the_reference_columns() {
        let row = line("image_0.tiff", &record(Some([1.25, -3.5]), -12.0), None);
        assert_eq!(
            row,
            "image_0.tiff,0.3,-0.4,-12,0.012,-0.034,0,12.010412149464313,1.25,-3.5,pentagon"
        );
        assert_eq!(
            crate::reference_layout::COLUMNS.len(),
            row.split(',').count()
        );
        let rounded = line(
            "image_1.tiff",
            &record(Some([1.26, -3.54]), -4.04),
            Some(0.1),
        );
        assert_eq!(
            rounded,
            "image_1.tiff,0.3,-0.4,-4.0,0.0,0.0,0.0,4.1,1.3,-3.5,pentagon"
        );
        let none = line("image_2.tiff", &record(None, -0.05), None);
        assert!(none.ends_with(",NaN,NaN,None"), "{none}");
    }
}
