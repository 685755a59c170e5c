//! A commissioning's certificate (`certificate.json` in its directory, beside the unit's
//! profile): the verdict against the spec, the held-out figures, the learning curve, the base
//! model's hash, the runs it used and fringe's version. The newest passing certificate of a
//! unit names the model that `fringe validate` and `fringe eval` use for it by default.

use fringe_rig::store::write_atomic;
use std::path::{Path, PathBuf};

/// The certificate's file name in a commissioning directory.
pub(crate) const CERTIFICATE: &str = "certificate.json";
/// The adapted model's file name in a commissioning directory (its card beside it, .json).
pub(crate) const MODEL: &str = "model.safetensors";
/// The unit's profile as commissioned, in the commissioning directory.
pub(crate) const PROFILE: &str = "profile.toml";
/// Format of the certificate this version writes; older ones are read, newer ones refused.
pub(crate) const CERTIFICATE_FORMAT: u32 = 1;

/// The held-out figures (Table-2 metrics) of the acceptance scan.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Figures {
    pub fz_rmse_n: f64,
    pub contact_rmse_mm: f64,
    pub shape_accuracy: f64,
    pub macro_f1: f64,
    pub frames: u64,
    pub presses: usize,
}

/// One point of the learning curve: a round's presses predicted by the model adapted on every
/// press before them (none of them seen), in the spec's units too.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CurvePoint {
    pub round: usize,
    /// Presses adapted on before this round.
    pub presses_before: usize,
    pub fz_rmse_n: f64,
    pub contact_rmse_mm: f64,
    pub shape_accuracy: f64,
    pub frames: u64,
}

/// A model file and its hash.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModelRef {
    pub path: String,
    /// SHA-256 of the file (of the built-in bytes for `default`).
    pub sha256: String,
    pub describe: String,
}

/// The runs a commissioning used, relative to its directory.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UsedRuns {
    pub calibration: String,
    pub rounds: Vec<String>,
    pub acceptance: String,
}

/// The certificate.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Certificate {
    pub format: u32,
    pub fringe_version: String,
    pub issued_utc: String,
    pub sensor_id: String,
    /// The sensor's construction (`layered`, `integrated`) when known.
    #[serde(default)]
    pub variant: Option<String>,
    pub pass: bool,
    /// Why it fails, one line per failed check (empty on pass).
    pub failures: Vec<String>,
    pub figures: Figures,
    /// The spec's checks, each with its value (acceptance's verdict, as JSON).
    pub verdict: serde_json::Value,
    pub spec: serde_json::Value,
    pub spec_origin: String,
    pub base_model: ModelRef,
    /// The adapted model, relative to the directory.
    pub model: String,
    /// How the model was adapted (the card says it in full).
    pub adaptation: String,
    pub profile: String,
    pub runs: UsedRuns,
    pub learning_curve: Vec<CurvePoint>,
    /// Bench time of every scan, s, and computation time, s.
    pub bench_s: f64,
    pub compute_s: f64,
}

impl ModelRef {
    /// The model `spec` names (`default`, `builtin:NAME` or a file), hashed.
    pub fn of(spec: &Path, describe: String) -> Result<ModelRef, CertificateError> {
        use sha2::Digest;
        let bytes = match fringe_sensor_models::builtin::named(spec) {
            Some(Ok(b)) => b.weights_bytes().to_vec(),
            _ => std::fs::read(spec).map_err(|e| CertificateError::Read {
                path: spec.to_path_buf(),
                message: format!("cannot hash the base model: {e}"),
            })?,
        };
        let digest = sha2::Sha256::digest(&bytes);
        Ok(ModelRef {
            path: spec.display().to_string(),
            sha256: digest.iter().map(|b| format!("{b:02x}")).collect(),
            describe,
        })
    }
}

/// A certificate that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum CertificateError {
    #[error("{path}: {message}")]
    Read { path: PathBuf, message: String },
    #[error(
        "{path}: certificate format {found} is newer than this fringe reads \
         ({CERTIFICATE_FORMAT}): read it with the newer fringe that wrote it"
    )]
    Newer { path: PathBuf, found: u32 },
}

impl Certificate {
    /// Reads the certificate of the commissioning in `dir`.
    pub fn read(dir: &Path) -> Result<Certificate, CertificateError> {
        let path = dir.join(CERTIFICATE);
        let err = |message: String| CertificateError::Read {
            path: path.clone(),
            message,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| err(e.to_string()))?;
        #[derive(serde::Deserialize)]
        struct Format {
            format: u32,
        }
        let format: Format = serde_json::from_str(&text)
            .map_err(|e| err(format!("not a commissioning certificate ({e})")))?;
        if format.format > CERTIFICATE_FORMAT {
            return Err(CertificateError::Newer {
                path: path.clone(),
                found: format.format,
            });
        }
        serde_json::from_str(&text).map_err(|e| err(format!("damaged certificate ({e})")))
    }

    /// Writes the certificate into `dir`, whole or not at all.
    pub fn write(&self, dir: &Path) -> Result<PathBuf, CertificateError> {
        let path = dir.join(CERTIFICATE);
        let err = |message: String| CertificateError::Read {
            path: path.clone(),
            message,
        };
        let text = serde_json::to_string_pretty(self).map_err(|e| err(e.to_string()))?;
        write_atomic(&path, (text + "\n").as_bytes()).map_err(|e| err(e.to_string()))?;
        Ok(path)
    }
}

/// The directory name of a commissioning of `sensor` started at `utc` (an RFC 3339 time):
/// names sort in time order.
pub(crate) fn directory_name(sensor: &str, utc: &str) -> String {
    let stamp: String = utc
        .chars()
        .map(|c| if c == ':' || c == '.' { '-' } else { c })
        .collect();
    format!("{sensor}.commission-{stamp}")
}

/// The commissioning directories of `sensor` under `profiles`, oldest first (none when the
/// folder cannot be read).
pub(crate) fn commissionings(profiles: &Path, sensor: &str) -> Vec<PathBuf> {
    let prefix = format!("{sensor}.commission-");
    let mut dirs: Vec<PathBuf> = match std::fs::read_dir(profiles) {
        Ok(entries) => entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.is_dir()
                    && p.file_name()
                        .and_then(|n| n.to_str())
                        .is_some_and(|n| n.starts_with(&prefix))
            })
            .collect(),
        Err(_) => return Vec::new(),
    };
    dirs.sort();
    dirs
}

/// The newest commissioning of `sensor` under `profiles` that has not reached its verdict (a
/// journal, no certificate): the one to go on with.
pub fn unfinished(profiles: &Path, sensor: &str) -> Option<PathBuf> {
    commissionings(profiles, sensor)
        .into_iter()
        .rev()
        .find(|d| d.join(super::journal::JOURNAL).is_file() && !d.join(CERTIFICATE).is_file())
}

/// A unit's commissioned model: the newest passing certificate's.
#[derive(Debug, Clone, PartialEq)]
pub struct Commissioned {
    pub dir: PathBuf,
    pub model: PathBuf,
    pub certificate: Certificate,
}

/// The newest commissioning of `sensor` under `profiles` whose certificate passed (newer formats
/// and damaged certificates are passed over, and named in the notes).
pub fn commissioned_model(profiles: &Path, sensor: &str) -> (Option<Commissioned>, Vec<String>) {
    let dirs = commissionings(profiles, sensor);
    let mut notes = Vec::new();
    for dir in dirs.into_iter().rev() {
        if !dir.join(CERTIFICATE).is_file() {
            continue;
        }
        match Certificate::read(&dir) {
            Ok(c) if c.pass && c.sensor_id == sensor => {
                let model = dir.join(&c.model);
                if model.is_file() {
                    return (
                        Some(Commissioned {
                            dir,
                            model,
                            certificate: c,
                        }),
                        notes,
                    );
                }
                notes.push(format!(
                    "{}: its model {} is missing",
                    dir.display(),
                    c.model
                ));
            }
            Ok(c) if c.sensor_id != sensor => notes.push(format!(
                "{}: its certificate is of sensor {}, not {sensor}: passed over",
                dir.display(),
                c.sensor_id
            )),
            Ok(_) => {}
            Err(e) => notes.push(e.to_string()),
        }
    }
    (None, notes)
}
