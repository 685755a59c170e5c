//! Labelled frames from fringe's runs or from datasets in the reference layout
//! (`fringe_rig::reference_layout`: `0.images/` + `0.labels.csv`), with the reference's label
//! rules applied once, here: every force and moment as its magnitude, and the layout's no-contact
//! rule (|Fz| under 0.2 N: shape `None`, no contact point).

use fringe_calibration::Profile;
use fringe_rig::reference_layout::{
    in_contact, read_labels, LabelsError, IMAGES, LABELS, NO_CONTACT, SIM_DATASET_DOC,
    SIM_DATASET_PROFILE,
};
use fringe_rig::store::FrameRecord;
use fringe_rig::store::FrameStorage;
use fringe_rig::store::{RunFile, RunReader, StartDocument};
use fringe_rig::{slip_labels, Newtons, Slip};
use std::path::{Path, PathBuf};

/// One labelled frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sample {
    pub image: PathBuf,
    /// How the image file's pixels are stored: the run's ([`FrameStorage`]); `None` for an
    /// ordinary image file (the reference layout).
    pub storage: Option<FrameStorage>,
    /// [Fx Fy Fz Mx My Mz Ft] as magnitudes.
    pub force: [f64; 7],
    /// "None" or the indenter's name.
    pub shape: String,
    /// mm from the sensor centre (+x right, +y up in the camera view).
    pub contact: Option<[f64; 2]>,
    /// The tangential force the indenter applied to the surface, sensor frame [x, y], N,
    /// signed (`FrameRecord::shear`); `None` where the data does not know it (runs recorded
    /// without the F/T's axes, the reference layout).
    #[serde(default)]
    pub shear: Option<[f64; 2]>,
    /// How the contact held (`fringe_rig::slip_labels`); `None` without contact or where the
    /// data cannot say.
    #[serde(default)]
    pub slip: Option<Slip>,
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
    /// The sensor's design (`layered`, `integrated`): a run's (recorded, or found in its rig
    /// text), a `fringe sim dataset`'s (`dataset.json`); `None` when the data does not say.
    pub variant: Option<String>,
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
    #[error(transparent)]
    Labels(#[from] LabelsError),
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
        Some(c) if in_contact(Newtons(fz)) && shape != NO_CONTACT => {
            (forces, shape.to_string(), Some(c))
        }
        _ => (forces, NO_CONTACT.to_string(), None),
    }
}

/// The sample a run's frame record makes (the label rules applied), or None when the record has
/// no trustworthy label. Runs read from disk and live validation both label frames here.
/// `slip` is the record's slip label, which takes the frames around it
/// ([`fringe_rig::slip_labels`]; `None` where they are not at hand, as live).
pub fn from_record(
    r: &FrameRecord,
    run_id: &str,
    image: PathBuf,
    storage: Option<FrameStorage>,
    slip: Option<Slip>,
) -> Option<Sample> {
    let w = r.wrench.filter(|_| r.valid)?;
    let (force, shape, contact) = label(w.to_array(), &r.shape, r.contact);
    let touching = contact.is_some();
    Some(Sample {
        image,
        storage,
        force,
        shape,
        contact,
        shear: r.shear,
        slip: slip.filter(|_| touching),
        press: format!("{run_id}#{}", r.point),
        stage_mm: Some([r.commanded.x.value(), r.commanded.y.value()]),
    })
}

/// Reads a run directory or a reference-layout dataset.
pub fn read(path: &Path) -> Result<Source, DatasetError> {
    let run = RunReader::at(path);
    if !path.exists() {
        Err(DatasetError::Missing(path.display().to_string()))
    } else if run.is_run() && run.has(RunFile::Frames) {
        read_run(&run)
    } else if path.join(LABELS).is_file() {
        read_reference(path)
    } else {
        Err(DatasetError::Unknown(path.display().to_string()))
    }
}

/// The calibration profile a run was labelled with (the copy in its start document `start`),
/// which its frames are preprocessed with; `None` for a run recorded without one.
pub fn run_profile(
    run: &RunReader,
    start: &StartDocument,
) -> Result<Option<Profile>, DatasetError> {
    start
        .calibration_profile
        .as_ref()
        .map(|p| {
            toml::from_str::<Profile>(&p.content).map_err(|e| DatasetError::Profile {
                path: run.path(RunFile::Start).display().to_string(),
                message: e.to_string(),
            })
        })
        .transpose()
}

fn read_run(run: &RunReader) -> Result<Source, DatasetError> {
    let start = run.start()?;
    let records = run.frames()?;
    let profile = run_profile(run, &start)?;
    let storage = Some(start.frame_storage());
    let mut samples = Vec::with_capacity(records.len());
    let mut skipped = 0;
    let slips = slip_labels(&records);
    for (r, slip) in records.iter().zip(slips) {
        match from_record(r, &start.run_id, run.frame_path(r), storage, slip) {
            Some(s) => samples.push(s),
            None => skipped += 1,
        }
    }
    Ok(Source {
        path: run.dir().to_path_buf(),
        samples,
        profile,
        variant: start.sensor_variant(),
        sensor_id: Some(start.sensor_id),
        skipped,
    })
}

fn read_reference(dir: &Path) -> Result<Source, DatasetError> {
    let mut samples = Vec::new();
    for (_, row) in read_labels(&dir.join(LABELS))? {
        let (force, shape, contact) = label(row.wrench, row.shape.as_str(), row.contact);
        samples.push(Sample {
            image: dir.join(IMAGES).join(&row.image),
            storage: None,
            force,
            shape,
            contact,
            // The reference layout does not say which frames share a press: each frame is its
            // own (a split of such a dataset cannot keep presses together).
            shear: None,
            slip: None,
            press: format!("{}#{}", dir.display(), row.image),
            stage_mm: None,
        });
    }
    // A dataset that names its sensor's geometry (`fringe sim dataset` writes one) is
    // preprocessed with it, as a run is with its calibration profile.
    let profile_path = dir.join(SIM_DATASET_PROFILE);
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
        variant: simulated_variant(dir),
        profile,
        skipped: 0,
    })
}

/// The design of the simulated sensor a `fringe sim dataset` rendered (`dataset.json`,
/// `sensor.variant`); `None` for other datasets or an unreadable file.
fn simulated_variant(dir: &Path) -> Option<String> {
    let text = std::fs::read_to_string(dir.join(SIM_DATASET_DOC)).ok()?;
    let doc: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some(doc.get("sensor")?.get("variant")?.as_str()?.to_string())
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
