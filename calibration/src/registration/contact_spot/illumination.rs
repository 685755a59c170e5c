//! The relative illumination behind each bin: a smooth degree-4 surface fitted to the
//! background's brightness over the crop circle (1 at the optical centre), LED specks left out.

use super::binning::{bin_centre, robust_sigma, Binned};
use super::spot::ContactError;

/// Degree of the illumination surface.
const ILLUMINATION_DEGREE: usize = 4;

/// Terms of the illumination surface.
const ILLUMINATION_TERMS: usize = (ILLUMINATION_DEGREE + 1) * (ILLUMINATION_DEGREE + 2) / 2;

/// Fits a degree-4 polynomial surface to the background brightness (mean of the channels minus
/// `dark_dn`) over the crop circle; returns it per bin relative to its value at the centre.
pub(super) fn illumination_surface(
    bg: &Binned,
    inside: &[usize],
    centre: [f64; 2],
    crop: f64,
    dark_dn: f64,
) -> Result<Vec<f32>, ContactError> {
    let b = Brightness {
        bg,
        centre,
        crop,
        dark_dn,
    };
    let mean = inside.iter().map(|&k| b.grey(k)).sum::<f64>() / inside.len() as f64;
    if mean.is_nan() || mean <= 1.0 {
        return Err(ContactError::Dark { mean_dn: mean });
    }
    let mut keep = vec![true; inside.len()];
    let mut coef = nalgebra::DVector::<f64>::zeros(ILLUMINATION_TERMS);
    for _ in 0..2 {
        coef = fit_surface(&b, inside, &keep).ok_or(ContactError::Dark { mean_dn: mean })?;
        keep = without_specks(&b, inside, &coef);
    }
    let centre_level = surface_at(&coef, 0.0, 0.0);
    if centre_level.is_nan() || centre_level <= 1.0 {
        return Err(ContactError::Dark {
            mean_dn: centre_level,
        });
    }
    let mut out = vec![0f32; bg.ch[0].len()];
    for &k in inside {
        let (x, y) = b.xy(k);
        out[k] = (surface_at(&coef, x, y) / centre_level).max(0.05) as f32;
    }
    Ok(out)
}

/// The background's brightness as the illumination surface is fitted to it.
struct Brightness<'a> {
    bg: &'a Binned,
    /// Optical centre, px.
    centre: [f64; 2],
    /// Crop radius, px.
    crop: f64,
    dark_dn: f64,
}

impl Brightness<'_> {
    /// Mean of the channels minus the dark level at bin `k`, DN.
    fn grey(&self, k: usize) -> f64 {
        let ch = &self.bg.ch;
        (f64::from(ch[0][k]) + f64::from(ch[1][k]) + f64::from(ch[2][k])) / 3.0 - self.dark_dn
    }

    /// Position of bin `k` relative to the centre, in crop radii.
    fn xy(&self, k: usize) -> (f64, f64) {
        let [u, v] = bin_centre(k % self.bg.bw, k / self.bg.bw);
        (
            (u - self.centre[0]) / self.crop,
            (v - self.centre[1]) / self.crop,
        )
    }
}

/// The monomials x^(d-i) y^i of the surface, by degree d up to [`ILLUMINATION_DEGREE`].
fn surface_terms(x: f64, y: f64) -> Vec<f64> {
    let mut t = Vec::new();
    for d in 0..=ILLUMINATION_DEGREE {
        for i in 0..=d {
            t.push(x.powi((d - i) as i32) * y.powi(i as i32));
        }
    }
    t
}

/// The surface with coefficients `coef` at (x, y) (crop radii).
fn surface_at(coef: &nalgebra::DVector<f64>, x: f64, y: f64) -> f64 {
    surface_terms(x, y)
        .iter()
        .zip(coef.iter())
        .map(|(a, b)| a * b)
        .sum::<f64>()
}

/// Least-squares coefficients of the surface over the kept bins of `inside` (normal equations,
/// Cholesky); `None` when they are singular.
fn fit_surface(b: &Brightness, inside: &[usize], keep: &[bool]) -> Option<nalgebra::DVector<f64>> {
    let n_terms = ILLUMINATION_TERMS;
    let mut ata = nalgebra::DMatrix::<f64>::zeros(n_terms, n_terms);
    let mut atb = nalgebra::DVector::<f64>::zeros(n_terms);
    for (&k, _) in inside.iter().zip(keep).filter(|(_, &q)| q) {
        let (x, y) = b.xy(k);
        let t = surface_terms(x, y);
        let g = b.grey(k);
        for a in 0..n_terms {
            atb[a] += t[a] * g;
            for c in a..n_terms {
                ata[(a, c)] += t[a] * t[c];
            }
        }
    }
    for a in 0..n_terms {
        for c in 0..a {
            ata[(a, c)] = ata[(c, a)];
        }
    }
    Some(ata.cholesky()?.solve(&atb))
}

/// Bins of `inside` to keep for the next fit: all but specks (dust, hot pixels) beyond 4
/// robust sigmas of the residuals from the surface `coef`.
fn without_specks(b: &Brightness, inside: &[usize], coef: &nalgebra::DVector<f64>) -> Vec<bool> {
    let res: Vec<f64> = inside
        .iter()
        .map(|&k| {
            let (x, y) = b.xy(k);
            b.grey(k) - surface_at(coef, x, y)
        })
        .collect();
    let s = robust_sigma(&mut res.clone());
    res.iter().map(|r| r.abs() <= 4.0 * s.max(1e-6)).collect()
}
