//! The labelled frames a model is evaluated or adapted on (`fringe eval`, `fringe adapt`): runs
//! or reference-layout datasets read, one without a labelled frame refused; what they agree on
//! of their sensor; and where a model would see them at another scale than it was trained on.

use fringe_calibration::Profile;
use fringe_sensor_models::dataset::{self, DatasetError, Source};
use fringe_sensor_models::Model;
use fringe_sensor_models::ReferenceSensor;
use std::path::PathBuf;

/// Labelled data that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum LabelledDataError {
    #[error("{}: no labelled frame to {purpose} ({skipped} left out for want of a trustworthy label): give a run that recorded presses, or a dataset with label rows", path.display())]
    NoLabelledFrame {
        path: PathBuf,
        purpose: String,
        skipped: usize,
    },
    #[error("{0}")]
    Dataset(#[from] DatasetError),
}

/// Reads every dataset; one without a labelled frame is refused, saying what it was wanted for
/// (`evaluate`, `adapt on`).
pub fn read_sources(data: &[PathBuf], purpose: &str) -> Result<Vec<Source>, LabelledDataError> {
    let mut sources = Vec::with_capacity(data.len());
    for d in data {
        let source = dataset::read(d)?;
        if source.samples.is_empty() {
            return Err(LabelledDataError::NoLabelledFrame {
                path: d.clone(),
                purpose: purpose.to_string(),
                skipped: source.skipped,
            });
        }
        sources.push(source);
    }
    Ok(sources)
}

/// What every source says of its sensor (`of`: its id, its design), when they agree.
pub fn agreed(sources: &[Source], of: impl Fn(&Source) -> Option<&str>) -> Option<&str> {
    let first = of(sources.first()?)?;
    sources
        .iter()
        .all(|s| of(s) == Some(first))
        .then_some(first)
}

/// A warning for each source whose frames the model would see at another scale than it was
/// trained on (the source's path, then why).
pub fn scale_warnings(
    model: &Model,
    sources: &[Source],
    profile: Option<&Profile>,
    reference: Option<ReferenceSensor>,
) -> Vec<String> {
    let mut warnings = Vec::new();
    for source in sources {
        let chosen = if reference.is_some() {
            None
        } else {
            source.profile.as_ref().or(profile)
        };
        if let Some(w) = model
            .preprocessing(chosen, reference)
            .ok()
            .and_then(|pre| model.scale_warning(&pre))
        {
            warnings.push(format!("{}: {w}", source.path.display()));
        }
    }
    warnings
}
