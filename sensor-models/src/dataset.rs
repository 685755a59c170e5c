//! Labelled frames from fringe's runs or from datasets in the reference layout
//! (`0.images/` + `0.labels.csv`), with the reference's label rules applied once, here: every
//! force and moment as its magnitude, and |Fz| under 0.2 N (the F/T noise floor) meaning no
//! contact (shape "None", no contact point).

use fringe_calibration::profile::Profile;
use fringe_rig::camera::PixelFormat;
use fringe_rig::store::documents::{FrameRecord, StartDocument};
use fringe_rig::store::run_writer::{read_document, read_lines};
use fringe_rig::store::{FRAMES, START};
use std::path::{Path, PathBuf};

/// |Fz| under this is no contact, N.
pub const CONTACT_THRESHOLD_N: f64 = 0.2;
/// The largest force or moment a label row may hold, N or N m: far beyond any F/T sensor of an
/// indentation bench (a row beyond it is a unit or parsing mistake, not a reading).
pub const MAX_LABEL_N: f64 = 1e4;

/// One labelled frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    pub image: PathBuf,
    /// How the image file's pixels are to be read (a run's Bayer frames are stored as the raw
    /// mosaic in a grey PNG).
    pub format: Option<PixelFormat>,
    /// [Fx Fy Fz Mx My Mz Ft] as magnitudes.
    pub force: [f64; 7],
    /// "None" or the indenter's name.
    pub shape: String,
    /// mm from the sensor centre (+x right, +y up in the camera view).
    pub contact: Option<[f64; 2]>,
    /// The physical indentation the frame belongs to (run and grid point): frames of one press
    /// never land on two sides of a split.
    pub press: String,
    /// Stage position of the press (x, y mm), when known.
    pub stage_mm: Option<[f64; 2]>,
}

impl Sample {
    /// Fz label, N.
    pub fn fz(&self) -> f64 {
        self.force[2]
    }
}

/// A set of samples from one source, with the calibration it was labelled with.
#[derive(Debug, Clone)]
pub struct Source {
    pub path: PathBuf,
    pub samples: Vec<Sample>,
    /// The calibration profile: a run's, or a reference-layout dataset's `profile.toml`.
    pub profile: Option<Profile>,
    pub sensor_id: Option<String>,
    /// Records left out: no force label, or marked untrustworthy.
    pub skipped: usize,
}

/// Why a dataset could not be read.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    #[error("{0}: neither a run (start.json + frames.jsonl) nor a reference-layout dataset (0.labels.csv + 0.images/)")]
    Unknown(String),
    #[error("{0}: no such run or dataset")]
    Missing(String),
    #[error(transparent)]
    Store(#[from] fringe_rig::store::StoreError),
    #[error("{path}: line {line}: {message}")]
    Csv {
        path: String,
        line: u64,
        message: String,
    },
    #[error("{path}: the calibration profile cannot be read: {message}")]
    Profile { path: String, message: String },
}

/// Applies the label rules to a force vector, shape and contact.
pub fn label(
    force: [f64; 6],
    shape: &str,
    contact: Option<[f64; 2]>,
) -> ([f64; 7], String, Option<[f64; 2]>) {
    let [fx, fy, fz, mx, my, mz] = force.map(f64::abs);
    let ft = (fx * fx + fy * fy + fz * fz).sqrt();
    let forces = [fx, fy, fz, mx, my, mz, ft];
    match contact {
        Some(c) if fz >= CONTACT_THRESHOLD_N && shape != "None" => {
            (forces, shape.to_string(), Some(c))
        }
        _ => (forces, "None".to_string(), None),
    }
}

/// The sample a run's frame record makes (the label rules applied), or None when the record has
/// no trustworthy label. Runs read from disk and live validation both label frames here.
pub fn from_record(
    r: &FrameRecord,
    run_id: &str,
    image: PathBuf,
    format: Option<PixelFormat>,
) -> Option<Sample> {
    let w = r.wrench.filter(|_| r.valid)?;
    let (force, shape, contact) = label(w.to_array(), &r.shape, r.contact);
    Some(Sample {
        image,
        format,
        force,
        shape,
        contact,
        press: format!("{run_id}#{}", r.point),
        stage_mm: Some([r.commanded.x.value(), r.commanded.y.value()]),
    })
}

/// Reads a run directory or a reference-layout dataset.
pub fn read(path: &Path) -> Result<Source, DatasetError> {
    if !path.exists() {
        Err(DatasetError::Missing(path.display().to_string()))
    } else if path.join(START).is_file() && path.join(FRAMES).is_file() {
        read_run(path)
    } else if path.join("0.labels.csv").is_file() {
        read_reference(path)
    } else {
        Err(DatasetError::Unknown(path.display().to_string()))
    }
}

/// The pixel format a run's camera delivered (from the rig text in its start document).
fn run_format(start: &StartDocument) -> Option<PixelFormat> {
    let rig: toml::Value = toml::from_str(&start.rig).ok()?;
    match rig.get("camera")?.get("pixel_format")?.as_str()? {
        "bayerrg8" => Some(PixelFormat::BayerRg8),
        "mono8" => Some(PixelFormat::Mono8),
        "rgb8" => Some(PixelFormat::Rgb8),
        _ => None,
    }
}

fn read_run(dir: &Path) -> Result<Source, DatasetError> {
    let start: StartDocument = read_document(&dir.join(START))?;
    let (records, _) = read_lines::<FrameRecord>(&dir.join(FRAMES))?;
    let profile = match &start.calibration_profile {
        Some(p) => {
            Some(
                toml::from_str::<Profile>(&p.content).map_err(|e| DatasetError::Profile {
                    path: dir.join(START).display().to_string(),
                    message: e.to_string(),
                })?,
            )
        }
        None => None,
    };
    let format = run_format(&start);
    let mut samples = Vec::with_capacity(records.len());
    let mut skipped = 0;
    for r in &records {
        match from_record(r, &start.run_id, dir.join(&r.file), format) {
            Some(s) => samples.push(s),
            None => skipped += 1,
        }
    }
    Ok(Source {
        path: dir.to_path_buf(),
        samples,
        profile,
        sensor_id: Some(start.sensor_id),
        skipped,
    })
}

fn read_reference(dir: &Path) -> Result<Source, DatasetError> {
    let path = dir.join("0.labels.csv");
    let shown = path.display().to_string();
    let mut reader = csv::Reader::from_path(&path).map_err(|e| DatasetError::Csv {
        path: shown.clone(),
        line: 0,
        message: e.to_string(),
    })?;
    let headers = reader
        .headers()
        .map_err(|e| DatasetError::Csv {
            path: shown.clone(),
            line: 1,
            message: e.to_string(),
        })?
        .clone();
    let col = |name: &str| -> Result<usize, DatasetError> {
        headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| DatasetError::Csv {
                path: shown.clone(),
                line: 1,
                message: format!("no column {name} (the reference layout has New_Image_Name, Fx .. Ft, X_Position_mm, Y_Position_mm, Indentor_Shape)"),
            })
    };
    let names = [
        "New_Image_Name",
        "Fx",
        "Fy",
        "Fz",
        "Mx",
        "My",
        "Mz",
        "X_Position_mm",
        "Y_Position_mm",
        "Indentor_Shape",
    ];
    let idx = names.map(col);
    let mut cols = [0usize; 10];
    for (c, i) in cols.iter_mut().zip(idx) {
        *c = i?;
    }
    let mut samples = Vec::new();
    for (k, rec) in reader.records().enumerate() {
        let line = k as u64 + 2;
        let rec = rec.map_err(|e| DatasetError::Csv {
            path: shown.clone(),
            line,
            message: e.to_string(),
        })?;
        let field = |i: usize| rec.get(cols[i]).unwrap_or("").trim();
        let num = |i: usize| -> Result<f64, DatasetError> {
            let text = field(i);
            if text.is_empty() || text.eq_ignore_ascii_case("nan") {
                return Ok(f64::NAN);
            }
            text.parse::<f64>().map_err(|_| DatasetError::Csv {
                path: shown.clone(),
                line,
                message: format!("{} = {text:?} is not a number", names[i]),
            })
        };
        let force = [num(1)?, num(2)?, num(3)?, num(4)?, num(5)?, num(6)?];
        if force.iter().any(|v| !v.is_finite()) {
            return Err(DatasetError::Csv {
                path: shown.clone(),
                line,
                message: "a force or moment is missing".into(),
            });
        }
        if let Some((i, v)) = force
            .iter()
            .enumerate()
            .find(|(_, v)| v.abs() > MAX_LABEL_N)
        {
            return Err(DatasetError::Csv {
                path: shown.clone(),
                line,
                message: format!(
                    "{} = {v:e} is beyond {MAX_LABEL_N:e} (N or N m): not a reading of a force sensor; fix or remove the row",
                    names[i + 1]
                ),
            });
        }
        let (x, y) = (num(7)?, num(8)?);
        let contact = (x.is_finite() && y.is_finite()).then_some([x, y]);
        let named = field(9);
        if contact.is_none() && named != "None" && force[2].abs() >= CONTACT_THRESHOLD_N {
            return Err(DatasetError::Csv {
                path: shown.clone(),
                line,
                message: format!(
                    "Fz = {} N presses a {named} but the row has no contact position (X_Position_mm, Y_Position_mm): give it, or mark the row Indentor_Shape None",
                    force[2]
                ),
            });
        }
        let (force, shape, contact) = label(force, named, contact);
        let image = field(0);
        let plain = !image.is_empty()
            && Path::new(image)
                .components()
                .all(|c| matches!(c, std::path::Component::Normal(_)));
        if !plain {
            return Err(DatasetError::Csv {
                path: shown.clone(),
                line,
                message: format!(
                    "New_Image_Name = {image:?} is not a file name inside 0.images/ (no absolute path, no `..`): a dataset holds its own images"
                ),
            });
        }
        samples.push(Sample {
            image: dir.join("0.images").join(image),
            format: None,
            force,
            shape,
            contact,
            // The reference layout does not say which frames share a press: each frame is its
            // own (a split of such a dataset cannot keep presses together).
            press: format!("{}#{image}", dir.display()),
            stage_mm: None,
        });
    }
    // A dataset that names its sensor's geometry (`fringe sim dataset` writes one) is
    // preprocessed with it, as a run is with its calibration profile.
    let profile_path = dir.join("profile.toml");
    let profile = if profile_path.is_file() {
        Some(
            Profile::load(&profile_path).map_err(|e| DatasetError::Profile {
                path: profile_path.display().to_string(),
                message: e.to_string(),
            })?,
        )
    } else {
        None
    };
    Ok(Source {
        path: dir.to_path_buf(),
        samples,
        sensor_id: profile.as_ref().map(|p| p.sensor_id.clone()),
        profile,
        skipped: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn label_rules_take_magnitudes_and_the_noise_floor() {
        let (f, s, c) = label(
            [0.1, -0.2, -3.0, 0.01, -0.02, 0.0],
            "pentagon",
            Some([1.0, 2.0]),
        );
        assert_eq!(f[2], 3.0);
        assert_eq!(f[1], 0.2);
        assert!((f[6] - (0.01f64 + 0.04 + 9.0).sqrt()).abs() < 1e-12);
        assert_eq!((s.as_str(), c), ("pentagon", Some([1.0, 2.0])));
        let (_, s, c) = label(
            [0.0, 0.0, -0.15, 0.0, 0.0, 0.0],
            "pentagon",
            Some([1.0, 2.0]),
        );
        assert_eq!((s.as_str(), c), ("None", None));
    }

    /// Reads a reference-layout dataset whose labels file holds `rows` after the header.
    fn read_rows(name: &str, rows: &str) -> Result<Source, DatasetError> {
        let dir = std::env::temp_dir().join(format!("fringe-rows-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("0.images")).expect("dataset dir");
        let header =
            "New_Image_Name,Fx,Fy,Fz,Mx,My,Mz,Ft,X_Position_mm,Y_Position_mm,Indentor_Shape";
        std::fs::write(dir.join("0.labels.csv"), format!("{header}\n{rows}")).expect("labels");
        let read = read(&dir);
        let _ = std::fs::remove_dir_all(&dir);
        read
    }

    #[test]
    fn label_rows_that_cannot_be_true_are_refused_naming_the_row() {
        let ok = "image_0.tiff,0,0,-3.0,0,0,0,3.0,1.0,2.0,pentagon\n\
                  image_1.tiff,0,0,-0.05,0,0,0,0.05,,,None\n";
        assert_eq!(read_rows("ok", ok).expect("good rows").samples.len(), 2);
        let cases = [
            (
                "image_0.tiff,0,0,-3.0,0,0,0,3.0,nan,nan,pentagon\n",
                "no contact position",
            ),
            (
                "image_0.tiff,0,0,-1e308,0,0,0,1,1,2,pentagon\n",
                "Fz = -1e308",
            ),
            (
                "/etc/passwd,0,0,-3,0,0,0,3,1,2,pentagon\n",
                "not a file name",
            ),
            ("../x.tiff,0,0,-3,0,0,0,3,1,2,pentagon\n", "not a file name"),
        ];
        for (row, why) in cases {
            let e = read_rows("bad", row).expect_err(row).to_string();
            assert!(e.contains("line 2") && e.contains(why), "{row}: {e}");
        }
    }
}
