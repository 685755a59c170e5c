//! The signature of a unit in one run: measured on the mean of its no-contact frames (spread
//! through the run), with the disc found by the optical fit.
//!
//! - optical: centre, radius and crop radius with their uncertainties ([`crate::optical`]);
//! - brightness: the mean grey inside [`INNER`] of the radius;
//! - rim light: the mean grey of each degree of angle in the band [`RIM_BAND`] of the radius,
//!   where the LED ring's hot spots and the rim's glow lie (angles about the fitted centre,
//!   counter-clockwise on the image from its x axis);
//! - sides: the mean grey of [`SIDES`] equal sectors of the annulus [`SIDE_BAND`] of the radius;
//! - cells: a [`CELLS`] x [`CELLS`] grid over the square about the centre of half-side
//!   [`INNER`] times the radius, each cell the median over the frames of its pixels' mean (cells
//!   whose centre lies outside [`INNER`] of the radius are left out). The median keeps a frame
//!   with a faint press in it from marking the cells it touches.

use crate::frames::{self, FrameError};
use crate::optical::grey::{self, median_f32, GreyImage};
use crate::optical::{self, DiscFit, OpticalError};
use crate::scan_run::ScanRun;
use std::path::PathBuf;

/// No-contact frames measured at most.
pub(crate) const SIGNATURE_FRAMES: usize = 24;
/// Share of the radius inside which brightness and cells are measured (clear of the rim).
pub const INNER: f64 = 0.85;
/// The band about the rim, shares of the radius, where the rim light is measured.
pub(crate) const RIM_BAND: [f64; 2] = [0.99, 1.07];
/// The annulus whose sectors give the light of each side.
pub(crate) const SIDE_BAND: [f64; 2] = [0.35, INNER];
/// Sectors of the annulus.
pub const SIDES: usize = 12;
/// Cells across the grid.
pub const CELLS: usize = 48;
/// One-degree bins of the rim light.
pub const RIM_BINS: usize = 360;

/// A unit's signature in one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Signature {
    /// The run it was measured on.
    pub run: PathBuf,
    pub width: usize,
    pub height: usize,
    pub fit: DiscFit,
    /// Mean grey inside [`INNER`] of the radius, DN.
    pub brightness_dn: f64,
    /// Mean grey of each degree about the rim, DN ([`RIM_BINS`], angle 0 along the image's x).
    pub rim_dn: Vec<f64>,
    /// Mean grey of each side sector, DN ([`SIDES`], sector k from 360 k / SIDES degrees).
    pub sides_dn: Vec<f64>,
    /// Median cell grey, DN, row-major; `None` outside [`INNER`].
    pub cells: Vec<Option<f32>>,
    /// Side of a cell, px.
    pub cell_px: f64,
}

/// Why a run has no signature.
#[derive(Debug, thiserror::Error)]
pub enum SignatureError {
    #[error("{run}: no no-contact frames to measure (the run recorded none)")]
    NoFrames { run: PathBuf },
    #[error("{run}: {source}")]
    Frames { run: PathBuf, source: FrameError },
    #[error("{run}: {source} (is the unit under the camera, lit and in focus?)")]
    Optical { run: PathBuf, source: OpticalError },
}

impl Signature {
    /// Measures the signature of `run` on at most [`SIGNATURE_FRAMES`] of its no-contact
    /// frames.
    pub fn measure(run: &ScanRun) -> Result<Signature, SignatureError> {
        let dir = run.dir.clone();
        let paths = frames::spread(&run.background, SIGNATURE_FRAMES);
        if paths.is_empty() {
            return Err(SignatureError::NoFrames { run: dir });
        }
        let storage = run.start.frame_storage();
        let greys = paths
            .iter()
            .map(|p| frames::read_placed(p, &storage))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|source| SignatureError::Frames {
                run: dir.clone(),
                source,
            })?;
        Signature::of_frames(dir, &greys)
    }

    /// The signature of no-contact frames `greys` (all of one size) of the run `run`.
    pub fn of_frames(run: PathBuf, greys: &[GreyImage]) -> Result<Signature, SignatureError> {
        let mean = grey::average(greys)
            .map_err(|e| SignatureError::Optical {
                run: run.clone(),
                source: e.into(),
            })?
            .ok_or(SignatureError::NoFrames { run: run.clone() })?;
        let fit = optical::find_disc_in(&mean).map_err(|source| SignatureError::Optical {
            run: run.clone(),
            source,
        })?;
        let centre = [fit.centre_x, fit.centre_y];
        let r = fit.radius;
        let brightness_dn = annulus_mean(&mean, centre, [0.0, INNER * r], 1)[0];
        let rim_dn = annulus_mean(&mean, centre, [RIM_BAND[0] * r, RIM_BAND[1] * r], RIM_BINS);
        let sides_dn = annulus_mean(&mean, centre, [SIDE_BAND[0] * r, SIDE_BAND[1] * r], SIDES);
        let cell_px = 2.0 * INNER * r / CELLS as f64;
        let per_frame: Vec<Vec<Option<f32>>> =
            greys.iter().map(|g| cell_means(g, centre, r)).collect();
        let cells = (0..CELLS * CELLS)
            .map(|k| {
                let mut v: Vec<f32> = per_frame.iter().filter_map(|c| c[k]).collect();
                (!v.is_empty()).then(|| median_f32(&mut v))
            })
            .collect();
        Ok(Signature {
            run,
            width: mean.width,
            height: mean.height,
            fit,
            brightness_dn,
            rim_dn,
            sides_dn,
            cells,
            cell_px,
        })
    }
}

/// Mean grey of `bins` equal angular sectors of the annulus `radii` (px) about `centre`; a
/// sector without pixels reads 0.
pub(crate) fn annulus_mean(
    g: &GreyImage,
    centre: [f64; 2],
    radii: [f64; 2],
    bins: usize,
) -> Vec<f64> {
    let (mut sum, mut n) = (vec![0.0f64; bins], vec![0usize; bins]);
    let j0 = (centre[1] - radii[1]).floor().max(0.0) as usize;
    let j1 = ((centre[1] + radii[1]).ceil().max(0.0) as usize).min(g.height);
    let i0 = (centre[0] - radii[1]).floor().max(0.0) as usize;
    let i1 = ((centre[0] + radii[1]).ceil().max(0.0) as usize).min(g.width);
    for j in j0..j1 {
        let v = j as f64 + 0.5 - centre[1];
        for i in i0..i1 {
            let u = i as f64 + 0.5 - centre[0];
            let d = u.hypot(v);
            if d < radii[0] || d >= radii[1] {
                continue;
            }
            // Counter-clockwise on the image: y grows downwards.
            let angle = (-v).atan2(u).rem_euclid(std::f64::consts::TAU);
            let b = ((angle / std::f64::consts::TAU * bins as f64) as usize).min(bins - 1);
            sum[b] += f64::from(g.at(i, j));
            n[b] += 1;
        }
    }
    sum.iter()
        .zip(&n)
        .map(|(s, &k)| if k == 0 { 0.0 } else { s / k as f64 })
        .collect()
}

/// Each cell's mean grey in one frame (see [`Signature::cells`]).
fn cell_means(g: &GreyImage, centre: [f64; 2], r: f64) -> Vec<Option<f32>> {
    let half = INNER * r;
    let cell = 2.0 * half / CELLS as f64;
    let origin = [centre[0] - half, centre[1] - half];
    let (mut sum, mut n) = (vec![0.0f64; CELLS * CELLS], vec![0usize; CELLS * CELLS]);
    let j0 = origin[1].floor().max(0.0) as usize;
    let j1 = ((origin[1] + 2.0 * half).ceil().max(0.0) as usize).min(g.height);
    let i0 = origin[0].floor().max(0.0) as usize;
    let i1 = ((origin[0] + 2.0 * half).ceil().max(0.0) as usize).min(g.width);
    for j in j0..j1 {
        let y = (j as f64 + 0.5 - origin[1]) / cell;
        if !(0.0..CELLS as f64).contains(&y) {
            continue;
        }
        for i in i0..i1 {
            let x = (i as f64 + 0.5 - origin[0]) / cell;
            if !(0.0..CELLS as f64).contains(&x) {
                continue;
            }
            let k = y as usize * CELLS + x as usize;
            sum[k] += f64::from(g.at(i, j));
            n[k] += 1;
        }
    }
    (0..CELLS * CELLS)
        .map(|k| {
            let (cx, cy) = ((k % CELLS) as f64 + 0.5, (k / CELLS) as f64 + 0.5);
            let inside = ((cx * cell - half).hypot(cy * cell - half)) < half;
            (inside && n[k] > 0).then(|| (sum[k] / n[k] as f64) as f32)
        })
        .collect()
}
