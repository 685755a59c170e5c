//! The similarity transform from stage millimetres to image pixels, fitted to presses.
//!
//! Convention (the simulator's `SensorGeometry` after the bench's stage-to-sensor shift): with
//! the stage point (x, y) mm, the image point (u, v) px, the complex numbers z = x + i y and
//! q = u - i v (image y up),
//!
//! - proper: q = a z + b, a = k e^(i theta);
//! - mirrored: q = a conj(z) + b, a = -k e^(i theta) (the sensor x axis reversed before the
//!   rotation: u = u0 + k (c m x - s y), v = v0 - k (s m x + c y), m = -1);
//!
//! k px/mm, theta counter-clockwise on the image, b the image of the stage origin. Both are linear
//! least squares in (Re a, Im a, Re b, Im b); the one with the smaller residual is kept and the
//! other's excess residual, in units of the noise, says how decisive the mirror decision is.
//!
//! Outliers: with 5 or more presses, each press is predicted from the fit of the others and its
//! error compared with the residual scale of that fit; the press most beyond
//! [`FitSettings::outlier_factor`] times its expected error (and beyond
//! [`FitSettings::min_outlier_px`]) is flagged and left out, and the test repeats, keeping at
//! least 4 presses that are not collinear.

use nalgebra::{Matrix4, Vector4};

/// One press: where the stage stood and where the contact was seen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Press {
    pub stage_mm: [f64; 2],
    pub pixel: [f64; 2],
    /// 1-sigma of the pixel position (larger axis), px.
    pub sigma_px: f64,
}

/// Thresholds of the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitSettings {
    /// A press is an outlier when its leave-one-out prediction error exceeds this many times
    /// its expected size (sqrt(2) times the per-coordinate residual sigma of the fit without it).
    pub outlier_factor: f64,
    /// ... and beyond this many px.
    pub min_outlier_px: f64,
    /// The wrong mirror must raise the residual sum of squares by at least this many noise
    /// variances.
    pub min_mirror_chi2: f64,
    /// Smallest over largest spread (standard deviation along the principal axes) of the stage
    /// positions; below it the presses are collinear.
    pub min_spread_ratio: f64,
    /// Noise floor of a press position, px (the residual scale never counts as smaller).
    pub noise_floor_px: f64,
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings {
            outlier_factor: 5.0,
            min_outlier_px: 0.5,
            min_mirror_chi2: 25.0,
            min_spread_ratio: 0.05,
            noise_floor_px: 0.05,
        }
    }
}

/// Presses that cannot give a transform.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("{0} presses: the registration needs at least 3 (non-collinear)")]
    TooFew(usize),
    #[error("press {index} has a non-finite position or sigma")]
    NotFinite { index: usize },
    #[error("the presses are collinear (spread {minor_mm:.3} mm across their line against {major_mm:.3} mm along it): add presses off the line")]
    Collinear { minor_mm: f64, major_mm: f64 },
    #[error("mirror undecided: the proper and the mirrored fit leave {proper_rms_px:.2} and {mirrored_rms_px:.2} px RMS (difference {chi2:.1} noise variances, need {need:.0}): spread the presses over both stage axes")]
    MirrorAmbiguous {
        proper_rms_px: f64,
        mirrored_rms_px: f64,
        chi2: f64,
        need: f64,
    },
    #[error("the stage positions do not determine a scale (all presses at one point?)")]
    Degenerate,
}

/// Residual of one press under the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressResidual {
    /// Seen minus predicted, px [u, v].
    pub residual_px: [f64; 2],
    /// Left out of the fit as an outlier.
    pub outlier: bool,
}

impl PressResidual {
    pub fn length_px(&self) -> f64 {
        self.residual_px[0].hypot(self.residual_px[1])
    }
}

/// The fitted stage-to-image similarity.
#[derive(Debug, Clone, PartialEq)]
pub struct SimilarityFit {
    pub px_per_mm: f64,
    pub sigma_px_per_mm: f64,
    /// Counter-clockwise on the image (y up), degrees in (-180, 180].
    pub rotation_deg: f64,
    pub sigma_rotation_deg: f64,
    pub mirror: bool,
    /// Image position of the stage origin, px [u, v].
    pub offset_px: [f64; 2],
    /// Per press, in the order given.
    pub residuals: Vec<PressResidual>,
    /// RMS residual length over the inliers, px.
    pub residual_rms_px: f64,
    /// Presses used (inliers).
    pub inliers: usize,
    /// RMS residual of the other mirror choice over the inliers, px.
    pub other_mirror_rms_px: f64,
    /// How much the other mirror choice raises the residual sum of squares, in noise variances.
    pub mirror_chi2: f64,
    /// Covariance of (Re a, Im a, Re b, Im b).
    covariance: Matrix4<f64>,
    /// (Re a, Im a, Re b, Im b).
    params: Vector4<f64>,
}

/// Solution of one mirror choice over a set of presses.
#[derive(Debug, Clone, Copy)]
struct Solved {
    params: Vector4<f64>,
    /// (X^T X)^-1.
    inverse: Matrix4<f64>,
    rss: f64,
}

/// Rows of the design for stage (x, y): [Re q row, Im q row].
fn rows(mirror: bool, x: f64, y: f64) -> [[f64; 4]; 2] {
    if mirror {
        // q = a (x - i y) + b
        [[x, y, 1.0, 0.0], [-y, x, 0.0, 1.0]]
    } else {
        // q = a (x + i y) + b
        [[x, -y, 1.0, 0.0], [y, x, 0.0, 1.0]]
    }
}

fn q_of(p: &Press) -> [f64; 2] {
    [p.pixel[0], -p.pixel[1]]
}

fn predict(mirror: bool, params: &Vector4<f64>, stage: [f64; 2]) -> [f64; 2] {
    let r = rows(mirror, stage[0], stage[1]);
    let re: f64 = (0..4).map(|j| r[0][j] * params[j]).sum();
    let im: f64 = (0..4).map(|j| r[1][j] * params[j]).sum();
    [re, -im]
}

fn solve(presses: &[Press], use_press: &[bool], mirror: bool) -> Option<Solved> {
    let mut ata = Matrix4::<f64>::zeros();
    let mut atb = Vector4::<f64>::zeros();
    for (p, _) in presses.iter().zip(use_press).filter(|(_, &u)| u) {
        let r = rows(mirror, p.stage_mm[0], p.stage_mm[1]);
        let q = q_of(p);
        for (row, &obs) in r.iter().zip(&q) {
            let v = Vector4::from_row_slice(row);
            ata += v * v.transpose();
            atb += v * obs;
        }
    }
    let inverse = ata.try_inverse()?;
    let params = inverse * atb;
    let rss = presses
        .iter()
        .zip(use_press)
        .filter(|(_, &u)| u)
        .map(|(p, _)| {
            let [u, v] = predict(mirror, &params, p.stage_mm);
            (p.pixel[0] - u).powi(2) + (p.pixel[1] - v).powi(2)
        })
        .sum();
    Some(Solved {
        params,
        inverse,
        rss,
    })
}

/// Standard deviations along the principal axes of the used stage positions, mm (minor, major).
fn spread(presses: &[Press], use_press: &[bool]) -> (f64, f64) {
    let pts: Vec<[f64; 2]> = presses
        .iter()
        .zip(use_press)
        .filter(|(_, &u)| u)
        .map(|(p, _)| p.stage_mm)
        .collect();
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p[0]).sum::<f64>() / n;
    let my = pts.iter().map(|p| p[1]).sum::<f64>() / n;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in &pts {
        sxx += (p[0] - mx).powi(2) / n;
        syy += (p[1] - my).powi(2) / n;
        sxy += (p[0] - mx) * (p[1] - my) / n;
    }
    let mean = 0.5 * (sxx + syy);
    let d = (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    ((mean - d).max(0.0).sqrt(), (mean + d).max(0.0).sqrt())
}

/// Noise variance per coordinate for `rss` over `n` presses: the residual's own estimate, never
/// below the presses' stated sigmas or the floor.
fn noise_var(rss: f64, n: usize, mean_sigma2: f64, floor_px: f64) -> f64 {
    let dof = 2 * n as i64 - 4;
    let s2 = if dof > 0 { rss / dof as f64 } else { 0.0 };
    s2.max(mean_sigma2).max(floor_px * floor_px)
}

/// Fits the stage-to-image similarity to `presses`: both mirror choices, the better kept.
pub(crate) fn fit_similarity(
    presses: &[Press],
    settings: &FitSettings,
) -> Result<SimilarityFit, FitError> {
    check_presses(presses)?;
    let mut use_press = vec![true; presses.len()];
    let (minor, major) = spread(presses, &use_press);
    if major <= 0.0 {
        return Err(FitError::Degenerate);
    }
    if minor < settings.min_spread_ratio * major {
        return Err(FitError::Collinear {
            minor_mm: minor,
            major_mm: major,
        });
    }
    let mean_sigma2 =
        presses.iter().map(|p| p.sigma_px.powi(2)).sum::<f64>() / presses.len() as f64;

    // Mirror on all presses first (an outlier inflates both choices alike).
    let mirror = decide_mirror(presses, &use_press, mean_sigma2, settings)?.0;
    drop_outliers(presses, &mut use_press, mirror, mean_sigma2, settings);

    let (mirror, chosen, other) = decide_mirror(presses, &use_press, mean_sigma2, settings)?;
    similarity_of(
        presses,
        &use_press,
        mirror,
        &chosen,
        &other,
        mean_sigma2,
        settings,
    )
}

/// At least 3 presses, each with finite positions and a finite, non-negative sigma.
fn check_presses(presses: &[Press]) -> Result<(), FitError> {
    if presses.len() < 3 {
        return Err(FitError::TooFew(presses.len()));
    }
    for (index, p) in presses.iter().enumerate() {
        let ok = p.stage_mm.iter().chain(&p.pixel).all(|v| v.is_finite())
            && p.sigma_px.is_finite()
            && p.sigma_px >= 0.0;
        if !ok {
            return Err(FitError::NotFinite { index });
        }
    }
    Ok(())
}

/// Clears `use_press` for outliers under `mirror`, one at a time (the press most beyond its
/// expected leave-one-out error), while 5 or more are used and the rest would not be collinear.
fn drop_outliers(
    presses: &[Press],
    use_press: &mut [bool],
    mirror: bool,
    mean_sigma2: f64,
    settings: &FitSettings,
) {
    loop {
        let n_used = use_press.iter().filter(|&&u| u).count();
        if n_used < 5 {
            break;
        }
        let Some((worst, ratio, err)) =
            worst_left_out(presses, use_press, mirror, mean_sigma2, settings)
        else {
            break;
        };
        if ratio <= settings.outlier_factor || err <= settings.min_outlier_px {
            break;
        }
        use_press[worst] = false;
        let (minor, major) = spread(presses, use_press);
        if minor < settings.min_spread_ratio * major {
            // Dropping it would leave a line: keep it.
            use_press[worst] = true;
            break;
        }
    }
}

/// The used press whose prediction from the fit of the other used presses is worst against its
/// expected size: (press, error / expected size, error px).
fn worst_left_out(
    presses: &[Press],
    use_press: &[bool],
    mirror: bool,
    mean_sigma2: f64,
    settings: &FitSettings,
) -> Option<(usize, f64, f64)> {
    let n_used = use_press.iter().filter(|&&u| u).count();
    let mut worst: Option<(usize, f64, f64)> = None;
    for i in (0..presses.len()).filter(|&i| use_press[i]) {
        let mut others = use_press.to_vec();
        others[i] = false;
        let Some(s) = solve(presses, &others, mirror) else {
            continue;
        };
        let [u, v] = predict(mirror, &s.params, presses[i].stage_mm);
        let err = (presses[i].pixel[0] - u).hypot(presses[i].pixel[1] - v);
        let s2 = noise_var(s.rss, n_used - 1, mean_sigma2, settings.noise_floor_px);
        let ratio = err / (2.0 * s2).sqrt();
        let better = match worst {
            None => true,
            Some(w) => ratio > w.1,
        };
        if better {
            worst = Some((i, ratio, err));
        }
    }
    worst
}

/// The fit from the `chosen` mirror's solution over the used presses (`other`: the other
/// mirror's): scale, rotation and their sigmas, residuals of every press.
fn similarity_of(
    presses: &[Press],
    use_press: &[bool],
    mirror: bool,
    chosen: &Solved,
    other: &Solved,
    mean_sigma2: f64,
    settings: &FitSettings,
) -> Result<SimilarityFit, FitError> {
    let n = use_press.iter().filter(|&&u| u).count();
    let s2 = noise_var(chosen.rss, n, mean_sigma2, settings.noise_floor_px);
    let covariance = chosen.inverse * s2;
    let p = chosen.params;
    let a = if mirror { [-p[0], -p[1]] } else { [p[0], p[1]] };
    let k = a[0].hypot(a[1]);
    if k.is_nan() || k <= 0.0 {
        return Err(FitError::Degenerate);
    }
    let theta = a[1].atan2(a[0]);
    // Jacobians of k and theta in (Re a, Im a) (signs of a mirrored `a` cancel in the variance).
    let jk = Vector4::new(p[0] / k, p[1] / k, 0.0, 0.0);
    let jt = Vector4::new(-p[1] / (k * k), p[0] / (k * k), 0.0, 0.0);
    let var_k = (jk.transpose() * covariance * jk)[0];
    let var_t = (jt.transpose() * covariance * jt)[0];
    Ok(SimilarityFit {
        px_per_mm: k,
        sigma_px_per_mm: var_k.max(0.0).sqrt(),
        rotation_deg: theta.to_degrees(),
        sigma_rotation_deg: var_t.max(0.0).sqrt().to_degrees(),
        mirror,
        offset_px: [p[2], -p[3]],
        residuals: press_residuals(presses, use_press, mirror, &p),
        residual_rms_px: (chosen.rss / n as f64).sqrt(),
        inliers: n,
        other_mirror_rms_px: (other.rss / n as f64).sqrt(),
        mirror_chi2: (other.rss - chosen.rss) / s2,
        covariance,
        params: p,
    })
}

/// Each press's residual under `params`, flagged as an outlier when not used.
fn press_residuals(
    presses: &[Press],
    use_press: &[bool],
    mirror: bool,
    params: &Vector4<f64>,
) -> Vec<PressResidual> {
    presses
        .iter()
        .zip(use_press)
        .map(|(pr, &used)| {
            let [u, v] = predict(mirror, params, pr.stage_mm);
            PressResidual {
                residual_px: [pr.pixel[0] - u, pr.pixel[1] - v],
                outlier: !used,
            }
        })
        .collect()
}

/// (mirror, chosen, other) over the used presses; an error when the choice is not decisive.
fn decide_mirror(
    presses: &[Press],
    use_press: &[bool],
    mean_sigma2: f64,
    settings: &FitSettings,
) -> Result<(bool, Solved, Solved), FitError> {
    let proper = solve(presses, use_press, false).ok_or(FitError::Degenerate)?;
    let mirrored = solve(presses, use_press, true).ok_or(FitError::Degenerate)?;
    let n = use_press.iter().filter(|&&u| u).count();
    let (mirror, chosen, other) = if mirrored.rss < proper.rss {
        (true, mirrored, proper)
    } else {
        (false, proper, mirrored)
    };
    let s2 = noise_var(chosen.rss, n, mean_sigma2, settings.noise_floor_px);
    let chi2 = (other.rss - chosen.rss) / s2;
    if chi2 < settings.min_mirror_chi2 {
        return Err(FitError::MirrorAmbiguous {
            proper_rms_px: (proper.rss / n as f64).sqrt(),
            mirrored_rms_px: (mirrored.rss / n as f64).sqrt(),
            chi2,
            need: settings.min_mirror_chi2,
        });
    }
    Ok((mirror, chosen, other))
}

impl SimilarityFit {
    /// Image position of the stage point, px.
    pub fn to_pixel(&self, stage_mm: [f64; 2]) -> [f64; 2] {
        predict(self.mirror, &self.params, stage_mm)
    }

    /// Stage position whose press is seen at `pixel`, mm.
    pub fn to_stage(&self, pixel: [f64; 2]) -> [f64; 2] {
        stage_of(self.mirror, &self.params, pixel)
    }

    /// The stage position that presses the image point `centre_px` (the optical centre: the
    /// contact origin) and its 1-sigma per axis, mm, from the fit's covariance and the centre's
    /// own sigma `sigma_centre_px` [x, y].
    pub fn contact_origin(
        &self,
        centre_px: [f64; 2],
        sigma_centre_px: [f64; 2],
    ) -> ([f64; 2], [f64; 2]) {
        let origin = self.to_stage(centre_px);
        // Numerical Jacobian in (params, centre).
        let mut var = [0.0f64; 2];
        let mut jp = [[0.0f64; 4]; 2];
        for j in 0..4 {
            let h = 1e-6 * self.params[j].abs().max(1.0);
            let mut p = self.params;
            p[j] += h;
            let s = stage_of(self.mirror, &p, centre_px);
            jp[0][j] = (s[0] - origin[0]) / h;
            jp[1][j] = (s[1] - origin[1]) / h;
        }
        for (axis, v) in var.iter_mut().enumerate() {
            let g = Vector4::from_row_slice(&jp[axis]);
            *v = (g.transpose() * self.covariance * g)[0];
        }
        for (c, sc) in sigma_centre_px.iter().enumerate() {
            let h = 1e-3;
            let mut px = centre_px;
            px[c] += h;
            let s = stage_of(self.mirror, &self.params, px);
            for axis in 0..2 {
                var[axis] += ((s[axis] - origin[axis]) / h * sc).powi(2);
            }
        }
        (origin, [var[0].max(0.0).sqrt(), var[1].max(0.0).sqrt()])
    }

    /// Stage-frame vector (mm) of an image-plane displacement `d_px` (the linear part inverted).
    pub fn px_to_stage_vector(&self, d_px: [f64; 2]) -> [f64; 2] {
        let o = self.to_stage([0.0, 0.0]);
        let s = self.to_stage(d_px);
        [s[0] - o[0], s[1] - o[1]]
    }
}

/// Inverse of [`predict`]: z = (q - b) / a, conjugated for a mirror.
fn stage_of(mirror: bool, p: &Vector4<f64>, pixel: [f64; 2]) -> [f64; 2] {
    let (qr, qi) = (pixel[0] - p[2], -pixel[1] - p[3]);
    let d = p[0] * p[0] + p[1] * p[1];
    // (qr + i qi) / (ar + i ai)
    let zr = (qr * p[0] + qi * p[1]) / d;
    let zi = (qi * p[0] - qr * p[1]) / d;
    if mirror {
        [zr, -zi]
    } else {
        [zr, zi]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Presses of a known transform (sensor geometry composed with a stage origin), with
    /// deterministic pseudo-noise of about `noise` px.
    fn presses(
        k: f64,
        rot_deg: f64,
        mirror: bool,
        stage: &[[f64; 2]],
        noise: f64,
    ) -> (Vec<Press>, [f64; 2]) {
        let (s, c) = rot_deg.to_radians().sin_cos();
        let m = if mirror { -1.0 } else { 1.0 };
        let (cu, cv) = (990.0, 600.0);
        let origin = [12.5, 7.25];
        let out = stage
            .iter()
            .enumerate()
            .map(|(n, st)| {
                let (x, y) = (st[0] - origin[0], st[1] - origin[1]);
                let e = noise * (((n * 7919) % 13) as f64 / 6.0 - 1.0);
                let f = noise * (((n * 104_729) % 11) as f64 / 5.0 - 1.0);
                Press {
                    stage_mm: *st,
                    pixel: [
                        cu + k * (c * m * x - s * y) + e,
                        cv - k * (s * m * x + c * y) + f,
                    ],
                    sigma_px: noise.max(0.01),
                }
            })
            .collect();
        (out, origin)
    }

    fn grid(n: usize, half: f64) -> Vec<[f64; 2]> {
        let mut g = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let t = |q: usize| -half + 2.0 * half * q as f64 / (n - 1) as f64;
                g.push([12.5 + t(i), 7.25 + t(j)]);
            }
        }
        g
    }

    #[test]
    fn recovers_both_mirrors_and_the_contact_origin() {
        for mirror in [false, true] {
            for rot in [0.0, 5.0, -93.0, 178.0] {
                let (p, origin) = presses(18.3, rot, mirror, &grid(3, 6.0), 0.1);
                let f = fit_similarity(&p, &FitSettings::default()).expect("fit");
                assert_eq!(f.mirror, mirror);
                assert!((f.px_per_mm - 18.3).abs() < 0.01, "{f:?}");
                let dr = (f.rotation_deg - rot + 540.0).rem_euclid(360.0) - 180.0;
                assert!(dr.abs() < 0.05, "{rot}: {f:?}");
                let (o, so) = f.contact_origin([990.0, 600.0], [0.02, 0.02]);
                assert!((o[0] - origin[0]).abs() < 0.01 && (o[1] - origin[1]).abs() < 0.01);
                assert!(so[0] > 0.0 && so[0] < 0.02, "{so:?}");
                assert!(f.residuals.iter().all(|r| !r.outlier));
                assert!(f.mirror_chi2 > 1e3);
                let back = f.to_pixel(f.to_stage([700.0, 500.0]));
                assert!((back[0] - 700.0).abs() < 1e-9 && (back[1] - 500.0).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn flags_an_outlier_and_refuses_collinear_or_too_few_presses() {
        let (mut p, _) = presses(17.0, 4.0, true, &grid(3, 6.0), 0.1);
        p[5].pixel[0] += 6.0;
        let f = fit_similarity(&p, &FitSettings::default()).expect("fit");
        let flagged: Vec<usize> = (0..p.len()).filter(|&i| f.residuals[i].outlier).collect();
        assert_eq!(flagged, vec![5], "{f:?}");
        assert!((f.residuals[5].length_px() - 6.0).abs() < 0.5);
        assert!(f.residual_rms_px < 0.3 && f.inliers == 8);
        assert!((f.px_per_mm - 17.0).abs() < 0.02);

        let line: Vec<[f64; 2]> = (0..5).map(|i| [i as f64, 2.0 * i as f64]).collect();
        let (p, _) = presses(17.0, 4.0, false, &line, 0.1);
        let e = fit_similarity(&p, &FitSettings::default()).expect_err("collinear");
        assert!(matches!(e, FitError::Collinear { .. }), "{e}");
        assert!(matches!(
            fit_similarity(&p[..2], &FitSettings::default()),
            Err(FitError::TooFew(2))
        ));
        // Nearly collinear with noise: the mirror cannot be told.
        let thin = [[0.0, 0.0], [3.0, 0.6], [6.0, 0.0], [9.0, 0.6], [12.0, 0.0]];
        let (p, _) = presses(17.0, 4.0, false, &thin, 15.0);
        let e = fit_similarity(&p, &FitSettings::default()).expect_err("ambiguous");
        assert!(matches!(e, FitError::MirrorAmbiguous { .. }), "{e}");
    }
}
