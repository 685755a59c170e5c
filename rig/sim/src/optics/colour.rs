//! Colour of a fringe order under a white LED, seen by an RGB camera through a dark-field circular
//! polariscope.
//!
//! For each channel c (docs/photoelastic-sim.md, "Colour"; the spectral sum follows
//! diegoeusse/CreacionImagenesMultipolarizadas):
//!
//! I_c(N) = sum_lambda S(lambda) Q_c(lambda) sin^2(pi N l_ref / lambda) / sum_lambda S Q_c,
//!
//! with N the fringe order at l_ref = 550 nm, a white-LED spectrum
//! S = exp(-(l - 450)^2 / (2 10^2)) + 1.2 exp(-(l - 565)^2 / (2 50^2)) and camera responses Q_c as
//! Gaussians at 600, 535 and 460 nm (sigma 30, 35, 25 nm). The sin^2 law is the dark-field circular
//! polariscope (Freire & Voloshin, "Photoelasticity", EOLSS). Low orders give saturated colours;
//! beyond about N = 5 the channels average towards grey ("high-order white").
//!
//! The sum is baked once into a table over N and read with linear interpolation.

use std::f64::consts::PI;

/// Reference wavelength at which fringe orders are given, nm.
pub(crate) const REFERENCE_WAVELENGTH_NM: f64 = 550.0;

/// Spectral sampling: 380..=780 nm in 1 nm steps.
const LAMBDA_MIN_NM: f64 = 380.0;
const LAMBDA_STEPS: usize = 401;

fn gaussian(x: f64, centre: f64, sigma: f64) -> f64 {
    let d = (x - centre) / sigma;
    (-0.5 * d * d).exp()
}

/// Relative spectral power of the white LED (blue pump plus phosphor) at `lambda_nm`.
pub(crate) fn led_spectrum(lambda_nm: f64) -> f64 {
    gaussian(lambda_nm, 450.0, 10.0) + 1.2 * gaussian(lambda_nm, 565.0, 50.0)
}

/// Relative response of camera channel 0 = R, 1 = G, 2 = B at `lambda_nm`.
pub(crate) fn camera_response(channel: usize, lambda_nm: f64) -> f64 {
    match channel {
        0 => gaussian(lambda_nm, 600.0, 30.0),
        1 => gaussian(lambda_nm, 535.0, 35.0),
        _ => gaussian(lambda_nm, 460.0, 25.0),
    }
}

/// The circular polariser in front of the mirrored layer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Polariser {
    /// Ideal quarter-wave plate at every wavelength: the unloaded sensor is black.
    Ideal,
    /// Film plate that is quarter-wave at `design_wavelength_nm` only
    /// (docs/photoelastic-sim.md, "Optics"): it leaks cos^2(Gamma), Gamma = (pi/2)(l0 / lambda).
    Film {
        /// l0, the wavelength at which the film is exactly quarter-wave, nm.
        design_wavelength_nm: f64,
    },
}

impl Polariser {
    /// Film plate quarter-wave at 560 nm: faint bluish unloaded background.
    #[cfg(test)]
    pub(crate) const FILM_560: Polariser = Polariser::Film {
        design_wavelength_nm: 560.0,
    };

    /// Fraction of the light that reaches the camera from the unloaded sensor at `lambda_nm`.
    pub(crate) fn leak(self, lambda_nm: f64) -> f64 {
        match self {
            Polariser::Ideal => 0.0,
            Polariser::Film {
                design_wavelength_nm,
            } => (0.5 * PI * design_wavelength_nm / lambda_nm).cos().powi(2),
        }
    }
}

/// R, G, B intensity (0 = dark, 1 = the channel's full unpolarised-through value) at fringe order N,
/// computed by the spectral sum with an ideal quarter-wave plate.
#[cfg(test)]
pub(crate) fn spectral_colour(fringe_order: f64) -> [f64; 3] {
    spectral_colour_with(fringe_order, Polariser::Ideal)
}

/// [`spectral_colour`] behind `polariser`. The leak L(lambda) of a film plate fills the dark part of
/// the fringe law: I = sin^2 + L (1 - sin^2), so the unloaded sensor shows L and full-wave bright
/// orders stay at 1 (a first-order model of the imperfect plate, exact at N = 0).
pub(crate) fn spectral_colour_with(fringe_order: f64, polariser: Polariser) -> [f64; 3] {
    let mut num = [0.0; 3];
    let mut den = [0.0; 3];
    for k in 0..LAMBDA_STEPS {
        let lambda = LAMBDA_MIN_NM + k as f64;
        let s = led_spectrum(lambda);
        let dark_field = (PI * fringe_order * REFERENCE_WAVELENGTH_NM / lambda)
            .sin()
            .powi(2);
        let leak = polariser.leak(lambda);
        let transmitted = dark_field + leak * (1.0 - dark_field);
        for c in 0..3 {
            let w = s * camera_response(c, lambda);
            num[c] += w * transmitted;
            den[c] += w;
        }
    }
    [num[0] / den[0], num[1] / den[1], num[2] / den[2]]
}

/// Colour contrast of an RGB triple: largest minus smallest channel.
#[cfg(test)]
pub(crate) fn contrast(rgb: [f64; 3]) -> f64 {
    let max = rgb.iter().copied().fold(f64::MIN, f64::max);
    let min = rgb.iter().copied().fold(f64::MAX, f64::min);
    max - min
}

/// [`spectral_colour`] baked into a table over 0..=`max_order`.
#[derive(Debug, Clone, PartialEq)]
#[cfg(test)]
pub(crate) struct ColourTable {
    max_order: f64,
    entries: Vec<[f32; 3]>,
}

#[cfg(test)]
impl ColourTable {
    /// Default table: 4096 entries up to N = 20.
    pub(crate) fn standard() -> ColourTable {
        ColourTable::new(4096, 20.0)
    }

    /// `entries` (at least 2) samples evenly spaced over fringe orders 0..=`max_order`.
    pub(crate) fn new(entries: usize, max_order: f64) -> ColourTable {
        ColourTable::with_polariser(entries, max_order, Polariser::Ideal)
    }

    /// [`ColourTable::new`] behind `polariser` (see [`spectral_colour_with`]).
    pub(crate) fn with_polariser(
        entries: usize,
        max_order: f64,
        polariser: Polariser,
    ) -> ColourTable {
        let entries = entries.max(2);
        let step = max_order / (entries - 1) as f64;
        let entries = (0..entries)
            .map(|k| {
                let [r, g, b] = spectral_colour_with(k as f64 * step, polariser);
                [r as f32, g as f32, b as f32]
            })
            .collect();
        ColourTable { max_order, entries }
    }

    /// R, G, B in 0..=1 at `fringe_order`, interpolated linearly; negative or NaN orders read N = 0.
    pub(crate) fn lookup(&self, fringe_order: f64) -> [f32; 3] {
        let last = self.entries.len() - 1;
        let pos = if fringe_order.is_nan() {
            0.0
        } else {
            (fringe_order / self.max_order * last as f64).clamp(0.0, last as f64)
        };
        let k = (pos.floor() as usize).min(last - 1);
        let t = (pos - k as f64) as f32;
        let (a, b) = (self.entries[k], self.entries[k + 1]);
        [
            a[0] + (b[0] - a[0]) * t,
            a[1] + (b[1] - a[1]) * t,
            a[2] + (b[2] - a[2]) * t,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peak_contrast(from: f64, to: f64) -> f64 {
        (0..=200)
            .map(|k| contrast(spectral_colour(from + (to - from) * k as f64 / 200.0)))
            .fold(0.0, f64::max)
    }

    #[test]
    fn unloaded_sensor_is_black() {
        assert_eq!(spectral_colour(0.0), [0.0, 0.0, 0.0]);
        assert_eq!(ColourTable::standard().lookup(0.0), [0.0, 0.0, 0.0]);
    }

    #[test]
    fn first_orders_are_strongly_coloured_and_high_orders_fade_to_grey() {
        let at_two = contrast(spectral_colour(2.0));
        let low = peak_contrast(1.0, 3.0);
        let fifth = peak_contrast(4.0, 5.0);
        let tenth = peak_contrast(9.0, 10.0);
        let fifteenth = peak_contrast(14.0, 15.0);
        eprintln!("contrast N=2 {at_two}; peaks 1..3 {low}, 4..5 {fifth}, 9..10 {tenth}, 14..15 {fifteenth}");
        assert!(at_two > 0.6, "{at_two}");
        assert!(low > 0.8, "{low}");
        assert!(low > fifth && fifth > tenth && tenth > fifteenth);
        assert!(fifteenth < 0.05, "{fifteenth}");
        // High-order white: every channel near half its full intensity.
        for c in spectral_colour(20.0) {
            assert!((c - 0.5).abs() < 0.01, "{c}");
        }
    }

    #[test]
    fn table_lookup_matches_the_spectral_sum() {
        let table = ColourTable::standard();
        let mut worst: f64 = 0.0;
        for k in 0..97 {
            let n = 0.2063 * k as f64;
            let exact = spectral_colour(n);
            let looked = table.lookup(n);
            for c in 0..3 {
                worst = worst.max((exact[c] - looked[c] as f64).abs());
            }
        }
        eprintln!("table interpolation max error {worst:e}");
        assert!(worst < 1e-3, "{worst}");
        // Beyond the table the last entry holds; negative orders read as unloaded.
        assert_eq!(table.lookup(25.0), table.lookup(20.0));
        assert_eq!(table.lookup(-1.0), [0.0, 0.0, 0.0]);
    }

    #[test]
    fn film_plate_leaks_a_faint_bluish_background() {
        let film = Polariser::FILM_560;
        let (blue, red) = (film.leak(450.0), film.leak(650.0));
        eprintln!(
            "film leak at 450 nm {blue}, at 650 nm {red}, at 560 nm {}",
            film.leak(560.0)
        );
        assert!((blue - 0.14).abs() < 0.005, "{blue}");
        assert!((red - 0.05).abs() < 0.005, "{red}");
        assert!(film.leak(560.0) < 1e-12);
        assert_eq!(Polariser::Ideal.leak(450.0), 0.0);

        let background = spectral_colour_with(0.0, film);
        eprintln!("unloaded film background RGB {background:?}");
        assert!(background[2] > background[0], "{background:?}");
        assert!(background.iter().all(|&c| c > 0.0 && c < 0.2));
        let table = ColourTable::with_polariser(1024, 10.0, film);
        assert!(table.lookup(0.0)[2] > table.lookup(0.0)[0]);
        // The ideal plate is unchanged by the option.
        assert_eq!(
            spectral_colour_with(1.3, Polariser::Ideal),
            spectral_colour(1.3)
        );
    }
}
