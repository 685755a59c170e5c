//! Export to the reference pipeline's layout: `0.images/image_K.tiff` and `0.labels.csv` with
//! exactly its columns, so the paper's Python training code reads our runs unchanged.
//!
//! Columns: New_Image_Name, Fx, Fy, Fz, Mx, My, Mz, Ft, X_Position_mm, Y_Position_mm,
//! Indentor_Shape. Forces in N, torques in N m (the reference mixed N m and N mm: we write N m
//! everywhere), Ft = |F| = sqrt(Fx^2 + Fy^2 + Fz^2), positions = contact point in mm relative to
//! the sensor centre, "NaN" and shape "None" without contact. Frames whose label is not valid are
//! left out and counted. Values are written in full precision unless rounding is asked for.
//! Beside them, `0.export.json` records where the rows came from: each run, its sensor and the
//! calibration profile its contact labels are relative to.

use super::documents::{now_utc, FrameRecord, StartDocument};
use super::run_writer::{read_document, read_lines};
use super::{StoreError, FRAMES, START};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The reference header line.
pub const HEADER: &str =
    "New_Image_Name,Fx,Fy,Fz,Mx,My,Mz,Ft,X_Position_mm,Y_Position_mm,Indentor_Shape";

/// Export options.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExportOptions {
    /// Round forces, torques and positions to this step (the reference trained on 0.1).
    pub round: Option<f64>,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportSummary {
    pub images: u64,
    pub without_contact: u64,
    pub skipped_invalid: u64,
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
}

/// `0.export.json`: the provenance of an export (beside `0.labels.csv`, outside `0.images/`, so
/// the reference code never sees it).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExportProvenance {
    pub software: String,
    pub exported_utc: String,
    pub round: Option<f64>,
    pub runs: Vec<ExportedRun>,
}

/// File name of the provenance document.
pub const PROVENANCE: &str = "0.export.json";

fn fmt_value(v: f64, round: Option<f64>) -> String {
    if v.is_nan() {
        return "NaN".into();
    }
    // Negative zero is written as 0.
    let v = if v == 0.0 { 0.0 } else { v };
    match round {
        Some(step) if step > 0.0 => {
            let r = (v / step).round() * step;
            let r = if r == 0.0 { 0.0 } else { r };
            let decimals = (-step.log10()).ceil().max(0.0) as usize;
            format!("{r:.decimals$}")
        }
        _ => format!("{v}"),
    }
}

/// One CSV row for `record` saved as `image`.
pub fn label_row(image: &str, record: &FrameRecord, options: &ExportOptions) -> Option<String> {
    let w = record.wrench?;
    let [fx, fy, fz, mx, my, mz] = w.to_array();
    let ft = (fx * fx + fy * fy + fz * fz).sqrt();
    let (x, y) = match record.contact {
        Some([x, y]) if record.shape != "None" => (x, y),
        _ => (f64::NAN, f64::NAN),
    };
    let shape = if record.contact.is_some() {
        record.shape.as_str()
    } else {
        "None"
    };
    let mut row = image.to_string();
    for v in [fx, fy, fz, mx, my, mz, ft, x, y] {
        let _ = write!(row, ",{}", fmt_value(v, options.round));
    }
    let _ = write!(row, ",{shape}");
    Some(row)
}

/// Exports `runs` (in order) into `out` (created; must not hold a previous export).
pub fn export_reference(
    runs: &[PathBuf],
    out: &Path,
    options: &ExportOptions,
    mut progress: impl FnMut(u64),
) -> Result<ExportSummary, StoreError> {
    let images = out.join("0.images");
    let labels = out.join("0.labels.csv");
    if labels.exists() {
        return Err(StoreError::Content {
            path: labels,
            message: "an export is already there (choose an empty --out directory)".into(),
        });
    }
    std::fs::create_dir_all(&images).map_err(|e| StoreError::io(&images, e))?;
    let mut csv = String::from(HEADER);
    csv.push('\n');
    let (mut k, mut none, mut skipped) = (0u64, 0u64, 0u64);
    let mut exported = Vec::with_capacity(runs.len());
    for run in runs {
        let start: StartDocument = read_document(&run.join(START))?;
        let first_image = k;
        let (records, _) = read_lines::<FrameRecord>(&run.join(FRAMES))?;
        for record in records {
            if !record.valid || record.wrench.is_none() {
                skipped += 1;
                continue;
            }
            let name = format!("image_{k}.tiff");
            let source = run.join(&record.file);
            let image = image::open(&source).map_err(|e| StoreError::Content {
                path: source.clone(),
                message: e.to_string(),
            })?;
            let target = images.join(&name);
            image.save(&target).map_err(|e| StoreError::Content {
                path: target.clone(),
                message: e.to_string(),
            })?;
            if let Some(row) = label_row(&name, &record, options) {
                csv.push_str(&row);
                csv.push('\n');
            }
            if record.contact.is_none() {
                none += 1;
            }
            k += 1;
            progress(k);
        }
        exported.push(ExportedRun {
            dir: run.display().to_string(),
            run_id: start.run_id,
            sensor_id: start.sensor_id,
            calibration_profile: start.calibration_profile.map(|p| p.path),
            sync_method: start.sync_method,
            first_image,
            images: k - first_image,
        });
    }
    let provenance = out.join(PROVENANCE);
    let doc = ExportProvenance {
        software: format!("fringe {}", env!("CARGO_PKG_VERSION")),
        exported_utc: now_utc(),
        round: options.round,
        runs: exported.clone(),
    };
    let json = serde_json::to_string_pretty(&doc).map_err(|e| StoreError::Content {
        path: provenance.clone(),
        message: format!("cannot encode: {e}"),
    })?;
    super::durable::write_atomic(&provenance, json.as_bytes())?;
    super::durable::write_atomic(&labels, csv.as_bytes())?;
    Ok(ExportSummary {
        images: k,
        without_contact: none,
        skipped_invalid: skipped,
        labels,
        provenance,
        runs: exported,
    })
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
            shape: "pentagon".into(),
            contact,
            valid: true,
            notes: vec![],
        }
    }

    #[test]
    fn rows_follow_the_reference_columns() {
        let row = label_row(
            "image_0.tiff",
            &record(Some([1.25, -3.5]), -12.0),
            &ExportOptions::default(),
        )
        .expect("row");
        assert_eq!(
            row,
            "image_0.tiff,0.3,-0.4,-12,0.012,-0.034,0,12.010412149464313,1.25,-3.5,pentagon"
        );
        assert_eq!(HEADER.split(',').count(), row.split(',').count());
        let rounded = label_row(
            "image_1.tiff",
            &record(Some([1.26, -3.54]), -4.04),
            &ExportOptions { round: Some(0.1) },
        )
        .expect("row");
        assert_eq!(
            rounded,
            "image_1.tiff,0.3,-0.4,-4.0,0.0,0.0,0.0,4.1,1.3,-3.5,pentagon"
        );
        let none = label_row(
            "image_2.tiff",
            &record(None, -0.05),
            &ExportOptions::default(),
        )
        .expect("row");
        assert!(none.ends_with(",NaN,NaN,None"), "{none}");
    }
}
