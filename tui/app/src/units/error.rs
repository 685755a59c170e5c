//! Why a unit named by id or file could not be had.

use fringe_rig::ConfigError;
use std::path::PathBuf;

/// A unit that could not be had, or not on this rig.
#[derive(Debug, thiserror::Error)]
pub enum UnitError {
    /// No unit of that id is known here (under the profiles, on the simulated bench, the rig's).
    #[error("unit {unit} is not known here{}; the units known: {}", rig_says(.rig), known_list(.known))]
    Unknown {
        unit: String,
        /// The rig's sensor, when it names one.
        rig: Option<String>,
        known: Vec<String>,
    },
    /// A real rig that holds another unit.
    #[error(
        "unit {unit} is not on this rig: the rig's sensor is {rig} (the `sensor` key of {origin}); \
         mount unit {unit} and name it there, or use the rig file of the bench that holds it"
    )]
    NotOnRig {
        unit: String,
        rig: String,
        origin: String,
    },
    /// A simulator's sensor file given for a real rig.
    #[error(
        "{}: a simulator's sensor file (unit {unit}); a real rig takes the unit's id or its \
         calibration profile",
        path.display()
    )]
    SimulatedOnly { path: PathBuf, unit: String },
    /// A file that names no unit, or cannot be read.
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    /// Not a unit's id.
    #[error("{0:?} is no unit's id (letters, digits, '-', '_' and '.') and no file")]
    BadId(String),
    #[error(transparent)]
    Config(#[from] ConfigError),
}

fn rig_says(rig: &Option<String>) -> String {
    rig.as_ref()
        .map(|r| format!(": the rig's sensor is {r}"))
        .unwrap_or_default()
}

fn known_list(ids: &[String]) -> String {
    if ids.is_empty() {
        "none yet".into()
    } else {
        ids.join(", ")
    }
}
