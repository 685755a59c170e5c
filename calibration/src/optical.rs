//! The optical centre, radius and usable crop radius of the sensor disc, from no-contact frames.
//!
//! Steps ([`find_disc`]):
//! 1. average the frames (grey levels, 0-255 scale) — noise falls with the square root of their
//!    number;
//! 2. first estimate: centroid and equal-area radius of the bright class of an Otsu split
//!    ([`edges::initial_estimate`]);
//! 3. edge points on 720 rays from that estimate: the steepest bright-to-dark descent of the
//!    radial profile between 0.7 and 1.3 radii, sub-pixel ([`edges::edge_on_ray`]); a ray
//!    counts when its step contrast exceeds 6 noise sigmas and a quarter of the disc contrast;
//! 4. RANSAC circle (2 px band) to reject hot spots and rim reflections, then the geometric
//!    least-squares circle (Gauss-Newton on distances) with the inlier band re-set to 3 robust
//!    sigmas; uncertainties from its covariance ([`circle_fit`]); steps 3-4 repeat once about
//!    the fitted centre;
//! 5. the radius refined by a model fit of the azimuthal median profile (blurred step + rim ring,
//!    [`edge_model`]): under heavy blur the rim ring pulls the steepest descent outwards;
//! 6. the crop radius ([`crop`]).
//!
//! Coordinates: image px, x right, y down, pixel (i, j) centred at (i + 0.5, j + 0.5) — the
//! convention of the simulated bench (`fringe_sim::SensorGeometry`).
//!
//! No sensor in view is an error, not a circle: fewer than 40 % of the rays show an edge, fewer
//! than 50 % of them agree on one circle, an RMS residual above 2 px, or a disc contrast under 8
//! noise sigmas ([`OpticalError::NoSensor`]).

pub(crate) mod circle_fit;
pub(crate) mod crop;
pub(crate) mod edge_model;
pub(crate) mod edges;
pub(crate) mod grey;
pub(crate) mod overlay;

use circle_fit::CircleFit;
use edges::{edge_on_ray, initial_estimate, EdgePoint, Initial, Ray};
use grey::{median_f64, GreyImage};

/// Rays for the edge points.
pub(crate) const EDGE_RAYS: usize = 720;
/// Least fraction of in-image rays with a clear edge.
pub(crate) const MIN_EDGE_SUPPORT: f64 = 0.40;
/// Least fraction of in-image rays on the fitted circle.
pub(crate) const MIN_INLIER_FRACTION: f64 = 0.50;
/// Largest RMS distance of the inlier edge points from the circle, px.
pub(crate) const MAX_RESIDUAL_PX: f64 = 2.0;
/// Least inside-outside contrast of the disc, in noise sigmas.
pub(crate) const MIN_CONTRAST_SIGMAS: f64 = 8.0;

/// The sensor disc as found.
#[derive(Debug, Clone, PartialEq)]
pub struct DiscFit {
    /// Image size, px.
    pub width: usize,
    pub height: usize,
    /// Frames averaged.
    pub frames: usize,
    /// Optical centre, px.
    pub centre_x: f64,
    pub centre_y: f64,
    /// Disc radius, px (from the edge-profile model; the circle fit's radius if that fails).
    pub radius: f64,
    /// 1-sigma uncertainties, px.
    pub sigma_x: f64,
    pub sigma_y: f64,
    pub sigma_radius: f64,
    /// Radius of the geometric circle fit to the steepest-descent edge points, px.
    pub edge_radius: f64,
    /// RMS distance of the inlier edge points from the circle, px.
    pub residual_rms_px: f64,
    /// Edge points used / rays inside the image.
    pub inliers: usize,
    pub rays: usize,
    /// Usable crop radius about the centre, px (see [`crop`]).
    pub crop_radius: f64,
    /// Edge blur (Gaussian sigma), px, from the edge-profile model.
    pub edge_blur_px: Option<f64>,
    /// Disc inside and outside grey levels and noise sigma, DN.
    pub inside_dn: f64,
    pub outside_dn: f64,
    pub noise_dn: f64,
}

impl DiscFit {
    /// Centre minus the image centre, px [x right, y down].
    pub fn shift(&self) -> [f64; 2] {
        [
            self.centre_x - 0.5 * self.width as f64,
            self.centre_y - 0.5 * self.height as f64,
        ]
    }
}

/// Why no disc was reported.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OpticalError {
    #[error("no frames to analyse")]
    NoFrames,
    #[error(transparent)]
    Size(#[from] grey::SizeMismatch),
    #[error("no sensor disc found: {0}")]
    NoSensor(String),
}

/// Finds the disc in the average of `frames`.
pub fn find_disc(frames: &[GreyImage]) -> Result<DiscFit, OpticalError> {
    let g = grey::average(frames)?.ok_or(OpticalError::NoFrames)?;
    find_disc_in(&g)
}

/// Finds the disc in one (averaged) grey image.
pub fn find_disc_in(g: &GreyImage) -> Result<DiscFit, OpticalError> {
    let (init, noise) = first_estimate(g)?;
    let contrast = init.inside_dn - init.outside_dn;
    let first = edge_circle(g, [init.cx, init.cy], init.r, contrast, noise, 3.0)?;
    let c = first.fit.circle;
    let EdgeCircle {
        fit,
        inliers,
        rays,
        angles,
    } = edge_circle(g, [c.cx, c.cy], c.r, contrast, noise, 2.0)?;
    let c = fit.circle;
    let centre = [c.cx, c.cy];
    let model = model_edge(g, &fit, &angles, &init);
    let (radius, sigma_radius) = match model {
        Some(m) => (m.radius, m.sigma_radius.max(fit.sigma_r)),
        None => (c.r, fit.sigma_r),
    };
    let crop_radius = crop::crop_radius(g, centre, radius, contrast, noise);
    Ok(DiscFit {
        width: g.width,
        height: g.height,
        frames: g.frames,
        centre_x: c.cx,
        centre_y: c.cy,
        radius,
        sigma_x: fit.sigma_cx,
        sigma_y: fit.sigma_cy,
        sigma_radius,
        edge_radius: c.r,
        residual_rms_px: fit.rms_px,
        inliers,
        rays,
        crop_radius,
        edge_blur_px: model.map(|m| m.blur_sigma),
        inside_dn: init.inside_dn,
        outside_dn: init.outside_dn,
        noise_dn: noise,
    })
}

/// The first estimate of the disc and the image noise sigma, DN; an error when the image is too
/// small, uniform, of too little contrast or its bright region too small for a sensor.
fn first_estimate(g: &GreyImage) -> Result<(Initial, f64), OpticalError> {
    let no = |m: String| Err(OpticalError::NoSensor(m));
    if g.width < 16 || g.height < 16 {
        return no(format!("the image is only {}x{} px", g.width, g.height));
    }
    let noise = g.noise_sigma().max(0.05);
    let Some(init) = initial_estimate(g) else {
        return no("the image is uniform".into());
    };
    let contrast = init.inside_dn - init.outside_dn;
    if contrast < MIN_CONTRAST_SIGMAS * noise {
        return no(format!(
            "the bright and dark parts differ by {contrast:.1} DN, under {MIN_CONTRAST_SIGMAS} noise sigmas ({:.1} DN)",
            MIN_CONTRAST_SIGMAS * noise
        ));
    }
    let min_dim = g.width.min(g.height) as f64;
    if init.r < 0.05 * min_dim {
        return no(format!(
            "the bright region is only {:.0} px across",
            2.0 * init.r
        ));
    }
    Ok((init, noise))
}

/// The circle through the edge points about one centre estimate.
struct EdgeCircle {
    fit: CircleFit,
    /// Edge points on the circle.
    inliers: usize,
    /// Rays inside the image.
    rays: usize,
    /// Angles of the rays whose edge point is on the circle, rad.
    angles: Vec<f64>,
}

/// Edge points on rays from `centre` (about radius `r`) and the robust circle through them
/// (RANSAC band `band` px); an error when too few rays show an edge or lie on the circle, or the
/// points scatter too far from it.
fn edge_circle(
    g: &GreyImage,
    centre: [f64; 2],
    r: f64,
    contrast: f64,
    noise: f64,
    band: f64,
) -> Result<EdgeCircle, OpticalError> {
    let no = |m: String| Err(OpticalError::NoSensor(m));
    let (points, rays) = edge_points(g, centre, r, contrast, noise);
    if rays == 0 {
        return no("no ray from the bright region's centre stays in the image".into());
    }
    let support = points.len() as f64 / rays as f64;
    if support < MIN_EDGE_SUPPORT {
        return no(format!(
            "only {:.0} % of {rays} rays show a bright-to-dark edge (need {:.0} %)",
            100.0 * support,
            100.0 * MIN_EDGE_SUPPORT
        ));
    }
    let xy: Vec<[f64; 2]> = points.iter().map(|p| [p.x, p.y]).collect();
    let min_dim = g.width.min(g.height) as f64;
    let range = (0.05 * min_dim, 2.0 * g.width.max(g.height) as f64);
    let Some((fit, inliers)) = circle_fit::robust(&xy, band, 0.5, range) else {
        return no("the edge points do not form a circle".into());
    };
    let n_in = inliers.iter().filter(|&&k| k).count();
    if (n_in as f64) < MIN_INLIER_FRACTION * rays as f64 {
        return no(format!(
            "only {n_in} of {rays} rays lie on one circle (need {:.0} %)",
            100.0 * MIN_INLIER_FRACTION
        ));
    }
    if fit.rms_px > MAX_RESIDUAL_PX {
        return no(format!(
            "the edge points scatter {:.1} px RMS about the best circle (limit {MAX_RESIDUAL_PX} px)",
            fit.rms_px
        ));
    }
    let angles: Vec<f64> = points
        .iter()
        .zip(&inliers)
        .filter(|(_, &k)| k)
        .map(|(p, _)| p.angle)
        .collect();
    Ok(EdgeCircle {
        fit,
        inliers: n_in,
        rays,
        angles,
    })
}

/// The edge-profile model fitted to the median profile of the rays at `angles` about the circle
/// of `fit`; `None` when it fails or disagrees with the circle (8 px or more apart, or a radius
/// sigma of 1 px or more).
fn model_edge(
    g: &GreyImage,
    fit: &CircleFit,
    angles: &[f64],
    init: &Initial,
) -> Option<edge_model::EdgeModelFit> {
    let c = fit.circle;
    median_profile(g, [c.cx, c.cy], c.r, angles).and_then(|samples| {
        edge_model::fit(&samples, c.r, init.inside_dn, init.outside_dn)
            .filter(|m| (m.radius - c.r).abs() < 8.0 && m.sigma_radius < 1.0)
    })
}

/// Edge points on [`EDGE_RAYS`] rays about `centre`; also the number of rays inside the image.
fn edge_points(
    g: &GreyImage,
    centre: [f64; 2],
    r: f64,
    contrast: f64,
    noise: f64,
) -> (Vec<EdgePoint>, usize) {
    let mut points = Vec::new();
    let mut rays = 0;
    for n in 0..EDGE_RAYS {
        let angle = std::f64::consts::TAU * n as f64 / EDGE_RAYS as f64;
        let Some(ray) = Ray::sample(g, centre, angle, 0.7 * r, 1.3 * r, 1, 0.0)
            .or_else(|| Ray::sample(g, centre, angle, 0.85 * r, 1.1 * r, 1, 0.0))
        else {
            continue;
        };
        rays += 1;
        if let Some(e) = edge_on_ray(&ray, centre, 1.0) {
            if e.contrast >= 6.0 * noise && e.contrast >= 0.25 * contrast {
                points.push(e);
            }
        }
    }
    (points, rays)
}

/// (radius, median level over `angles`) from 0.9 R to 1.1 R (at least 45 px either side).
fn median_profile(
    g: &GreyImage,
    centre: [f64; 2],
    r: f64,
    angles: &[f64],
) -> Option<Vec<(f64, f64)>> {
    let w = (0.1 * r).max(45.0);
    let rays: Vec<Ray> = angles
        .iter()
        .filter_map(|&a| Ray::sample(g, centre, a, r - w, r + w, 1, 0.0))
        .collect();
    if rays.len() < 16 {
        return None;
    }
    let n = rays.iter().map(|ray| ray.values.len()).min()?;
    Some(
        (0..n)
            .map(|k| {
                let mut v: Vec<f64> = rays.iter().map(|ray| ray.values[k]).collect();
                (rays[0].radius(k), median_f64(&mut v))
            })
            .collect(),
    )
}
