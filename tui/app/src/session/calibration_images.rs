//! The optical part of a sensor's profile from a folder of no-contact images (PNG or TIFF), in
//! place of the calibration scan (`fringe calibrate --images DIR`): the frames without contact
//! chosen, averaged and fitted (centre, shift from the image centre, radius and crop radius),
//! then the profile and its report image written.

use fringe_calibration::find_disc_in;
use fringe_calibration::grey_average;
use fringe_calibration::overlay;
use fringe_calibration::spread;
use fringe_calibration::FrameError;
use fringe_calibration::{DiscFit, GreyImage, OpticalError};
use fringe_calibration::{Profile, ProfileError};
use fringe_rig::reference_layout::{
    in_contact, read_labels, LabelsError, CONTACT_THRESHOLD, LABELS,
};
use fringe_rig::Newtons;
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// Why the optics could not be calibrated from the images.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationImagesError {
    #[error("cannot read image folder {}", dir.display())]
    ReadFolder {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("image folder {} holds no PNG or TIFF files (.png, .tif, .tiff)", dir.display())]
    NoImages { dir: PathBuf },
    #[error("{0}")]
    Labels(#[source] LabelsError),
    /// `context`: the folder (and the frames averaged); the frames or the fit failed.
    #[error("{context}")]
    Frames {
        context: String,
        #[source]
        source: FrameError,
    },
    #[error("{context}")]
    Fit {
        context: String,
        #[source]
        source: OpticalError,
    },
    #[error("cannot create profile folder {}", dir.display())]
    CreateFolder {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Profile(#[source] ProfileError),
    #[error("cannot write report {}", path.display())]
    Report {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    /// The report picture could not be drawn.
    #[error("cannot write report {}", path.display())]
    Draw {
        path: PathBuf,
        #[source]
        source: fringe_plot::PlotError,
    },
}

/// The image files of `dir` (PNG or TIFF), sorted; refused when there is none.
pub fn image_files(dir: &Path) -> Result<Vec<PathBuf>, CalibrationImagesError> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| CalibrationImagesError::ReadFolder {
            dir: dir.to_path_buf(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_image(p))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(CalibrationImagesError::NoImages {
            dir: dir.to_path_buf(),
        });
    }
    Ok(files)
}

fn is_image(p: &Path) -> bool {
    p.is_file()
        && p.extension()
            .and_then(|e| e.to_str())
            .map(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "tif" | "tiff"))
            .unwrap_or(false)
}

/// The no-contact frames: from a `0.labels.csv` in DIR or beside it (the layout's no-contact
/// rule) when there is one, else all of them. Also a line saying which.
pub fn choose_no_contact(
    dir: &Path,
    files: &[PathBuf],
) -> Result<(Vec<PathBuf>, String), CalibrationImagesError> {
    let candidates = [
        dir.join(LABELS),
        dir.parent().map(|p| p.join(LABELS)).unwrap_or_default(),
    ];
    let Some(labels) = candidates.iter().find(|p| p.is_file()) else {
        return Ok((
            files.to_vec(),
            format!(
                "no {LABELS} in or beside {}: using all {} frames, assumed free of contact",
                dir.display(),
                files.len()
            ),
        ));
    };
    let quiet: HashSet<String> = read_labels(labels)
        .map_err(CalibrationImagesError::Labels)?
        .into_iter()
        .filter(|(_, row)| !in_contact(Newtons(row.wrench[2])))
        .map(|(_, row)| row.image)
        .collect();
    let chosen: Vec<PathBuf> = files
        .iter()
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| quiet.contains(n))
        })
        .cloned()
        .collect();
    let how = format!(
        "{}: {} of {} frames have |Fz| < {} N (no contact)",
        labels.display(),
        chosen.len(),
        files.len(),
        CONTACT_THRESHOLD.0
    );
    Ok((chosen, how))
}

/// At most `max_frames` of the `chosen` frames of `dir` (spread evenly over them) averaged, and
/// the disc fitted on the average.
pub fn fit_disc(
    dir: &Path,
    chosen: &[PathBuf],
    max_frames: usize,
) -> Result<(GreyImage, DiscFit), CalibrationImagesError> {
    let used = spread(chosen, max_frames);
    let average = grey_average(&used, None).map_err(|source| CalibrationImagesError::Frames {
        context: dir.display().to_string(),
        source,
    })?;
    let fit = find_disc_in(&average).map_err(|source| CalibrationImagesError::Fit {
        context: format!("{} ({} frames averaged)", dir.display(), used.len()),
        source,
    })?;
    Ok((average, fit))
}

/// Writes the profile of `sensor` from `fit` to `profile_file` (its folder `out` created), and
/// beside it the report image (the averaged frame with the fitted disc green, the crop circle
/// yellow and the centre red), whose path it returns.
pub fn write_profile(
    sensor: &str,
    dir: &Path,
    average: &GreyImage,
    fit: &DiscFit,
    out: &Path,
    profile_file: &Path,
) -> Result<PathBuf, CalibrationImagesError> {
    std::fs::create_dir_all(out).map_err(|source| CalibrationImagesError::CreateFolder {
        dir: out.to_path_buf(),
        source,
    })?;
    let profile = Profile::from_fit(sensor, &dir.display().to_string(), fit);
    profile
        .save(profile_file)
        .map_err(CalibrationImagesError::Profile)?;
    let report = profile_file.with_extension("png");
    overlay(average, fit)
        .map_err(|source| CalibrationImagesError::Draw {
            path: report.clone(),
            source,
        })?
        .save(&report)
        .map_err(|source| CalibrationImagesError::Report {
            path: report.clone(),
            source,
        })?;
    Ok(report)
}
