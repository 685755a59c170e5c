//! Runs exported as WebDataset shards (`fringe export --format webdataset`): POSIX tar files of
//! `--shard-size` samples each, a sample being a frame as stored in PNG (`KEY.png`: one channel as
//! grey, the raw Bayer mosaic as recorded; RGB8 as RGB) and its labels (`KEY.json`), as WebDataset
//! readers stream them from object storage. The tar format is the `tar` crate's.
//!
//! Each shard is written beside its name and moved into place whole; `shards.json` lists the
//! shards with their samples and the runs they came from. A cancelled export removes what it
//! wrote.

use fringe_calibration::Profile;
use fringe_rig::store::{write_png, FrameRecord, RunReader, StartDocument, StoreError};
use fringe_rig::{slip_labels, Slip};
use fringe_sensor_models::dataset;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// The index of an export (its shards, samples and runs), beside the shards.
pub const SHARDS_INDEX: &str = "shards.json";

/// How shards are written.
#[derive(Debug, Clone)]
pub struct ShardOptions {
    /// Samples in each shard (the last one holds what is left).
    pub shard_size: usize,
    /// Set to stop the export (what it wrote is removed); a signal handler's flag.
    pub cancel: Option<&'static AtomicBool>,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ShardSummary {
    pub shards: Vec<PathBuf>,
    pub samples: usize,
    /// Records whose frame file is missing or damaged, left out.
    pub skipped_damaged: usize,
    pub index: PathBuf,
}

/// Why an export stopped.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error("--shard-size 0: a shard holds at least one sample")]
    ShardSize,
    #[error("{}: the directory exists and is not empty: give a new --out directory", .0.display())]
    OutNotEmpty(PathBuf),
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("{}: {source}", .path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: frame {index} cannot be written as PNG: {message}", .run.display())]
    Png {
        run: PathBuf,
        index: u64,
        message: String,
    },
    #[error("the export was stopped: the shards written so far were removed")]
    Cancelled,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ShardError + '_ {
    move |source| ShardError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The labels of one sample: the record as recorded, where it came from and what its pixels
/// are, with the run's calibration geometry (what the one preprocessing crops about).
fn sample_json(
    start: &StartDocument,
    record: &FrameRecord,
    profile: Option<&Profile>,
    trainable: bool,
    slip: Option<Slip>,
) -> serde_json::Value {
    let storage = start.frame_storage();
    let wrench = record.wrench.map(|w| w.to_array());
    serde_json::json!({
        "run_id": start.run_id,
        "sensor_id": start.sensor_id,
        "variant": start.sensor_variant(),
        "index": record.index,
        "frame_id": record.frame_id,
        "point": record.point,
        "press": format!("{}#{}", start.run_id, record.point),
        "valid": record.valid,
        "trainable": trainable,
        "fx": wrench.map(|w| w[0]),
        "fy": wrench.map(|w| w[1]),
        "fz": wrench.map(|w| w[2]),
        "mx": wrench.map(|w| w[3]),
        "my": wrench.map(|w| w[4]),
        "mz": wrench.map(|w| w[5]),
        "contact_x_mm": record.contact.map(|c| c[0]),
        "contact_y_mm": record.contact.map(|c| c[1]),
        "shape": record.shape,
        "shear_x_n": record.shear.map(|q| q[0]),
        "shear_y_n": record.shear.map(|q| q[1]),
        "slip": slip.map(Slip::name),
        "exposure": record.exposure,
        "host_arrival_ns": record.host_arrival_ns,
        "commanded": record.commanded,
        "measured": record.measured,
        "notes": record.notes,
        "pixel_format": storage.pixel_format,
        "cutout": storage.cutout,
        "sync_method": start.sync_method,
        "optical_centre_px": profile.map(|p| [p.optical.centre_x_px, p.optical.centre_y_px]),
        "crop_radius_px": profile.map(|p| p.optical.crop_radius_px),
    })
}

/// A shard being written: its tar and where it goes when whole.
struct Shard {
    tar: tar::Builder<BufWriter<File>>,
    partial: PathBuf,
    path: PathBuf,
    samples: usize,
}

impl Shard {
    fn open(out: &Path, number: usize) -> Result<Shard, ShardError> {
        let path = out.join(format!("shard-{number:06}.tar"));
        let partial = out.join(format!("shard-{number:06}.tar.partial"));
        let file = File::create(&partial).map_err(io(&partial))?;
        Ok(Shard {
            tar: tar::Builder::new(BufWriter::new(file)),
            partial,
            path,
            samples: 0,
        })
    }

    fn add(&mut self, name: &str, bytes: &[u8]) -> Result<(), ShardError> {
        let mut header = tar::Header::new_ustar();
        header.set_size(bytes.len() as u64);
        header.set_mode(0o644);
        header.set_mtime(0);
        header.set_entry_type(tar::EntryType::Regular);
        self.tar
            .append_data(&mut header, name, bytes)
            .map_err(io(&self.partial))
    }

    fn close(self) -> Result<PathBuf, ShardError> {
        let partial = self.partial;
        let mut w = self.tar.into_inner().map_err(io(&partial))?;
        w.flush().map_err(io(&partial))?;
        w.get_ref().sync_all().map_err(io(&partial))?;
        std::fs::rename(&partial, &self.path).map_err(io(&self.path))?;
        Ok(self.path)
    }
}

/// A sample key: the run id and the record index, without the dots WebDataset splits keys at.
fn key(run_id: &str, index: u64) -> String {
    format!("{}-{index:07}", run_id.replace('.', "_"))
}

/// Writes the frames of `runs` into shards of `options.shard_size` samples under `out` (created;
/// an existing directory must be empty); `progress` hears the samples written so far.
pub fn export_shards(
    runs: &[PathBuf],
    out: &Path,
    options: &ShardOptions,
    mut progress: impl FnMut(usize),
) -> Result<ShardSummary, ShardError> {
    if options.shard_size == 0 {
        return Err(ShardError::ShardSize);
    }
    if out.exists() && std::fs::read_dir(out).map_err(io(out))?.next().is_some() {
        return Err(ShardError::OutNotEmpty(out.to_path_buf()));
    }
    // Read every run's documents before writing anything.
    let mut opened = Vec::with_capacity(runs.len());
    for dir in runs {
        let reader = RunReader::at(dir);
        let start = reader.start()?;
        let records = reader.frames()?;
        let profile = dataset::run_profile(&reader, &start).map_err(|e| ShardError::Io {
            path: dir.clone(),
            source: std::io::Error::other(e.to_string()),
        })?;
        opened.push((reader, start, records, profile));
    }
    std::fs::create_dir_all(out).map_err(io(out))?;
    let written = write_all(&opened, out, options, &mut progress);
    if written.is_err() {
        remove_written(out);
    }
    written
}

type Opened = (RunReader, StartDocument, Vec<FrameRecord>, Option<Profile>);

fn write_all(
    opened: &[Opened],
    out: &Path,
    options: &ShardOptions,
    progress: &mut impl FnMut(usize),
) -> Result<ShardSummary, ShardError> {
    let mut shards = Vec::new();
    let mut index_shards = Vec::new();
    let mut current: Option<Shard> = None;
    let mut samples = 0;
    let mut skipped_damaged = 0;
    let mut png = Vec::new();
    for (reader, start, records, profile) in opened {
        let storage = start.frame_storage();
        let slips = slip_labels(records);
        for (record, slip) in records.iter().zip(slips) {
            if options
                .cancel
                .as_ref()
                .is_some_and(|c| c.load(Ordering::SeqCst))
            {
                return Err(ShardError::Cancelled);
            }
            let frame = match reader.stored_frame(&storage, record)? {
                Ok(f) => f,
                Err(_) => {
                    skipped_damaged += 1;
                    continue;
                }
            };
            png.clear();
            write_png(
                &mut png,
                frame.width,
                frame.height,
                frame.format,
                &frame.data,
            )
            .map_err(|e| ShardError::Png {
                run: reader.dir().to_path_buf(),
                index: record.index,
                message: e.to_string(),
            })?;
            let trainable =
                dataset::from_record(record, &start.run_id, PathBuf::new(), None, None).is_some();
            let labels = sample_json(start, record, profile.as_ref(), trainable, slip);
            let k = key(&start.run_id, record.index);
            let shard = match &mut current {
                Some(s) => s,
                slot => slot.insert(Shard::open(out, shards.len())?),
            };
            shard.add(&format!("{k}.png"), &png)?;
            shard.add(&format!("{k}.json"), labels.to_string().as_bytes())?;
            shard.samples += 1;
            samples += 1;
            progress(samples);
            if shard.samples == options.shard_size {
                if let Some(s) = current.take() {
                    let n = s.samples;
                    let path = s.close()?;
                    index_shards.push(shard_entry(&path, n));
                    shards.push(path);
                }
            }
        }
    }
    if let Some(s) = current.take() {
        let n = s.samples;
        let path = s.close()?;
        index_shards.push(shard_entry(&path, n));
        shards.push(path);
    }
    let index = out.join(SHARDS_INDEX);
    let runs: Vec<serde_json::Value> = opened
        .iter()
        .map(|(reader, start, _, _)| {
            serde_json::json!({
                "dir": reader.dir(),
                "run_id": start.run_id,
                "sensor_id": start.sensor_id,
                "variant": start.sensor_variant(),
                "calibration_profile": start.calibration_profile.as_ref().map(|p| &p.path),
            })
        })
        .collect();
    let text = serde_json::to_string_pretty(&serde_json::json!({
        "format": "webdataset",
        "shard_size": options.shard_size,
        "samples": samples,
        "skipped_damaged": skipped_damaged,
        "shards": index_shards,
        "runs": runs,
    }))
    .map_err(|e| ShardError::Io {
        path: index.clone(),
        source: std::io::Error::other(e),
    })?;
    fringe_rig::store::write_atomic(&index, text.as_bytes())?;
    Ok(ShardSummary {
        shards,
        samples,
        skipped_damaged,
        index,
    })
}

fn shard_entry(path: &Path, samples: usize) -> serde_json::Value {
    serde_json::json!({
        "file": path.file_name().map(|n| n.to_string_lossy().into_owned()),
        "samples": samples,
    })
}

/// Removes the shards (whole or partial) and the index an export wrote into `out`.
fn remove_written(out: &Path) {
    for e in std::fs::read_dir(out).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with("shard-") || name == SHARDS_INDEX {
            let _ = std::fs::remove_file(e.path());
        }
    }
    let _ = std::fs::remove_dir(out);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_carry_no_dots_and_sort_by_record() {
        assert_eq!(
            key("2026-12-01T10-00-00.5Z-grid", 7),
            "2026-12-01T10-00-00_5Z-grid-0000007"
        );
        assert!(key("r", 9) < key("r", 10));
    }
}
