//! Every unit known: the units with a calibration profile, a commissioning or a health history
//! under the rig's profiles, the rig's own sensor, and, on the simulated bench, the units it can
//! carry; each with its design, its newest certificate, its last check, the next check due and
//! the model `fringe validate` runs for it (the unit's commissioned model, else the model that
//! ships for its design: the one rule of `models::choice`).

use crate::commission::certificate::{
    commissioned_model, commissionings, Certificate, CERTIFICATE,
};
use crate::health::figures::Verdict;
use crate::health::history::{self, history_path};
use crate::rig::file::RigConfig;
use crate::rig::simulated;
use crate::units::schedule::{next_check, NextCheck};
use fringe_calibration::Profile;
use fringe_sensor_models::builtin;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Every unit known, as of `today`.
#[derive(Debug, Clone, PartialEq)]
pub struct Units {
    /// Where their profiles, commissionings and histories are.
    pub profiles: PathBuf,
    /// The rig's sensor, when it names one.
    pub on_rig: Option<String>,
    pub units: Vec<UnitView>,
    /// What could not be read (passed over).
    pub notes: Vec<String>,
}

/// One unit.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitView {
    pub id: String,
    /// `layered` or `integrated`, when known.
    pub design: Option<String>,
    /// The simulated bench can carry it.
    pub simulated: bool,
    /// Its calibration profile.
    pub profile: Option<PathBuf>,
    /// Its newest certificate, passing or not.
    pub certificate: Option<CertificateView>,
    /// Its newest passing certificate, when that is not the newest.
    pub passing: Option<CertificateView>,
    pub last_check: Option<CheckView>,
    pub checks: usize,
    pub next_check: NextCheck,
    pub validate: ValidateModel,
}

/// A certificate in brief.
#[derive(Debug, Clone, PartialEq)]
pub struct CertificateView {
    pub dir: PathBuf,
    pub pass: bool,
    pub issued_utc: String,
    /// The adapted model.
    pub model: PathBuf,
    pub spec_origin: String,
    pub fz_rmse_n: f64,
    pub contact_rmse_mm: f64,
    pub shape_accuracy: f64,
}

/// A check in brief.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckView {
    pub checked_utc: String,
    pub verdict: Verdict,
    pub diagnosis: String,
}

/// The model `fringe validate` runs for a unit when none is given.
#[derive(Debug, Clone, PartialEq)]
pub enum ValidateModel {
    /// Its newest passing commissioning's model.
    Commissioned(PathBuf),
    /// The model that ships for its design (`builtin:NAME`), the design known or not.
    Shipped { model: String, design_known: bool },
    /// No model ships for its design.
    None(String),
}

impl ValidateModel {
    pub fn describe(&self) -> String {
        match self {
            ValidateModel::Commissioned(p) => format!("its commissioned model {}", p.display()),
            ValidateModel::Shipped {
                model,
                design_known: true,
            } => format!("{model} (shipped for its design; not commissioned)"),
            ValidateModel::Shipped { model, .. } => {
                format!("{model} (its design is not known here; not commissioned)")
            }
            ValidateModel::None(why) => why.clone(),
        }
    }
}

impl CertificateView {
    fn of(dir: &Path, c: &Certificate) -> CertificateView {
        CertificateView {
            dir: dir.to_path_buf(),
            pass: c.pass,
            issued_utc: c.issued_utc.clone(),
            model: dir.join(&c.model),
            spec_origin: c.spec_origin.clone(),
            fz_rmse_n: c.figures.fz_rmse_n,
            contact_rmse_mm: c.figures.contact_rmse_mm,
            shape_accuracy: c.figures.shape_accuracy,
        }
    }

    /// `PASS 2026-12-06 10:21 UTC`.
    pub fn describe(&self) -> String {
        format!(
            "{} {}",
            if self.pass { "PASS" } else { "FAIL" },
            when(&self.issued_utc)
        )
    }
}

/// `2026-12-06T10:21:33.120Z` as `2026-12-06 10:21 UTC`.
pub fn when(utc: &str) -> String {
    match (utc.get(..10), utc.get(11..16)) {
        (Some(d), Some(t)) => format!("{d} {t} UTC"),
        _ => utc.to_string(),
    }
}

/// Every unit known on the rig of `config`, as of `today` (RFC 3339).
pub fn list(config: &RigConfig, today: &str) -> Units {
    let profiles = config.profile_dir();
    let on_rig = config.sensor_id().ok();
    let sim_units = if config.is_simulated() {
        simulated::units()
    } else {
        Vec::new()
    };
    let mut ids: BTreeSet<String> = ids_under(&profiles);
    ids.extend(on_rig.iter().cloned());
    ids.extend(sim_units.iter().map(|(id, _)| id.clone()));
    let mut notes = Vec::new();
    let units = ids
        .into_iter()
        .map(|id| {
            let sim_design = sim_units
                .iter()
                .find(|(u, _)| *u == id)
                .map(|(_, d)| d.to_string());
            let rig_design = (on_rig.as_deref() == Some(id.as_str()))
                .then(|| config.sensor_variant().ok().flatten().map(str::to_string))
                .flatten();
            unit(&profiles, &id, sim_design, rig_design, today, &mut notes)
        })
        .collect();
    Units {
        profiles,
        on_rig,
        units,
        notes,
    }
}

/// The ids of the units known under `profiles`: the calibration profiles, the commissionings and
/// the health histories there.
fn ids_under(profiles: &Path) -> BTreeSet<String> {
    let mut ids = BTreeSet::new();
    let Ok(entries) = std::fs::read_dir(profiles) else {
        return ids;
    };
    for e in entries.flatten() {
        let path = e.path();
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        if let Some((id, _)) = name.split_once(".commission-") {
            if path.is_dir() {
                ids.insert(id.to_string());
            }
        } else if let Some(id) = name.strip_suffix(".health.jsonl") {
            ids.insert(id.to_string());
        } else if name.ends_with(".toml") && path.is_file() {
            if let Ok(p) = Profile::load(&path) {
                ids.insert(p.sensor_id);
            }
        }
    }
    ids
}

/// The ids known for `config`, for messages.
pub(crate) fn known_ids(config: &RigConfig) -> Vec<String> {
    let mut ids = ids_under(&config.profile_dir());
    ids.extend(config.sensor_id().ok());
    if config.is_simulated() {
        ids.extend(simulated::units().into_iter().map(|(id, _)| id));
    }
    ids.into_iter().collect()
}

fn unit(
    profiles: &Path,
    id: &str,
    sim_design: Option<String>,
    rig_design: Option<String>,
    today: &str,
    notes: &mut Vec<String>,
) -> UnitView {
    let newest = commissionings(profiles, id)
        .into_iter()
        .rev()
        .filter(|d| d.join(CERTIFICATE).is_file())
        .find_map(|d| match Certificate::read(&d) {
            Ok(c) if c.sensor_id == id => Some(CertificateView::of(&d, &c)),
            Ok(_) => None,
            Err(e) => {
                notes.push(e.to_string());
                None
            }
        });
    let (commissioned, _) = commissioned_model(profiles, id);
    let passing = commissioned
        .as_ref()
        .map(|c| CertificateView::of(&c.dir, &c.certificate));
    let cert_design = commissioned
        .as_ref()
        .and_then(|c| c.certificate.variant.clone());
    let design = cert_design.or(sim_design.clone()).or(rig_design);
    let history = match history::read(&history_path(profiles, id)) {
        Ok(h) => {
            notes.extend(h.notes.iter().cloned());
            h.entries
        }
        Err(e) => {
            notes.push(e.to_string());
            Vec::new()
        }
    };
    let last_check = history.last().map(|e| CheckView {
        checked_utc: e.checked_utc.clone(),
        verdict: e.verdict(),
        diagnosis: e.assessment.diagnosis.clone(),
    });
    let next = next_check(
        passing.as_ref().map(|c| c.issued_utc.as_str()),
        last_check
            .as_ref()
            .map(|c| (c.checked_utc.as_str(), c.verdict)),
        today,
    );
    let validate = match &commissioned {
        Some(c) => ValidateModel::Commissioned(c.model.clone()),
        None => match builtin::for_design(design.as_deref()) {
            Ok(p) => ValidateModel::Shipped {
                model: shipped_name(&p),
                design_known: design.is_some(),
            },
            Err(e) => ValidateModel::None(e.to_string()),
        },
    };
    let profile = fringe_calibration::profile_path(profiles, id)
        .ok()
        .filter(|p| p.is_file());
    UnitView {
        id: id.to_string(),
        design,
        simulated: sim_design.is_some(),
        profile,
        passing: passing.filter(|p| newest.as_ref().is_some_and(|n| n.dir != p.dir)),
        certificate: newest,
        last_check,
        checks: history.len(),
        next_check: next,
        validate,
    }
}

/// A built-in model's argument as a person gives it (`builtin:layered-two-stage`).
fn shipped_name(p: &Path) -> String {
    p.display().to_string()
}
