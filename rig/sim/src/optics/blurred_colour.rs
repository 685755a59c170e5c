//! Colour of a defocused fringe pattern: a table over fringe order N and its local spread sigma_N.
//!
//! A blurred pixel averages the sharp image over nearby points; where N varies by sigma_N across the
//! blur (sigma_N = |grad N| sigma_blur, docs/photoelastic-sim.md, "Rendering recipe") its colour is the
//! expected sharp colour over N' ~ Normal(N, sigma_N). Fringe orders are magnitudes and the fringe law
//! is even in N, so N' < 0 reads the colour at |N'|.
//!
//! Row k of the table holds that average at sigma_N = k * max_sigma / (rows - 1); lookup is bilinear
//! in (N, sigma_N).

use crate::optics::colour::{spectral_colour_with, Polariser};

/// Colour averaged over a Gaussian spread of fringe orders, tabulated over (N, sigma_N).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BlurredColourTable {
    max_order: f64,
    max_sigma: f64,
    columns: usize,
    rows: usize,
    /// Row-major: `rows` rows of `columns` RGB entries.
    entries: Vec<[f32; 3]>,
}

/// Gaussian weights at offsets -half..=half steps, normalised to sum 1.
fn gaussian_weights(sigma_steps: f64, half: usize) -> Vec<f64> {
    let w: Vec<f64> = (0..=2 * half)
        .map(|k| {
            let d = (k as f64 - half as f64) / sigma_steps;
            (-0.5 * d * d).exp()
        })
        .collect();
    let sum: f64 = w.iter().sum();
    w.into_iter().map(|x| x / sum).collect()
}

impl BlurredColourTable {
    /// `columns` (at least 2) fringe orders evenly over 0..=`max_order`, `rows` (at least 2) spreads
    /// evenly over 0..=`max_sigma`, colours behind `polariser`.
    pub(crate) fn new(
        columns: usize,
        max_order: f64,
        rows: usize,
        max_sigma: f64,
        polariser: Polariser,
    ) -> BlurredColourTable {
        let columns = columns.max(2);
        let rows = rows.max(2);
        let step = max_order / (columns - 1) as f64;
        // Sharp colours on the same step, extended by 5 sigma past both ends (mirrored below 0).
        let pad = (5.0 * max_sigma / step).ceil() as usize;
        let sharp: Vec<[f64; 3]> = (0..columns + 2 * pad)
            .map(|k| {
                let n = (k as f64 - pad as f64) * step;
                spectral_colour_with(n.abs(), polariser)
            })
            .collect();
        let mut entries = Vec::with_capacity(rows * columns);
        for row in 0..rows {
            let sigma = max_sigma * row as f64 / (rows - 1) as f64;
            let sigma_steps = sigma / step;
            // Below a tenth of a step the Gaussian is a delta on this grid: the row is the sharp one.
            let (half, weights) = if sigma_steps < 0.1 {
                (0, vec![1.0])
            } else {
                let half = ((5.0 * sigma_steps).ceil() as usize).min(pad);
                (half, gaussian_weights(sigma_steps, half))
            };
            for col in 0..columns {
                let centre = col + pad;
                let mut rgb = [0.0f64; 3];
                for (k, w) in weights.iter().enumerate() {
                    let s = sharp[centre + k - half];
                    for c in 0..3 {
                        rgb[c] += w * s[c];
                    }
                }
                entries.push([rgb[0] as f32, rgb[1] as f32, rgb[2] as f32]);
            }
        }
        BlurredColourTable {
            max_order,
            max_sigma,
            columns,
            rows,
            entries,
        }
    }

    /// Largest fringe order in the table; larger orders read the last column.
    pub(crate) fn max_order(&self) -> f64 {
        self.max_order
    }

    /// Largest spread in the table; larger spreads read the last row.
    pub(crate) fn max_sigma(&self) -> f64 {
        self.max_sigma
    }

    /// R, G, B in 0..=1 at fringe order `fringe_order` blurred over `sigma_n` fringe orders, bilinear
    /// in both; negative or NaN values read 0.
    pub(crate) fn lookup(&self, fringe_order: f64, sigma_n: f64) -> [f32; 3] {
        let position = |value: f64, max: f64, count: usize| {
            let last = (count - 1) as f64;
            let pos = if value.is_nan() {
                0.0
            } else {
                (value / max * last).clamp(0.0, last)
            };
            let k = (pos.floor() as usize).min(count - 2);
            (k, (pos - k as f64) as f32)
        };
        let (i, u) = position(fringe_order, self.max_order, self.columns);
        let (j, v) = position(sigma_n, self.max_sigma, self.rows);
        let at = |i: usize, j: usize| self.entries[j * self.columns + i];
        let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
        let mut out = [0.0f32; 3];
        for ch in 0..3 {
            let top = a[ch] + (b[ch] - a[ch]) * u;
            let bottom = c[ch] + (d[ch] - c[ch]) * u;
            out[ch] = top + (bottom - top) * v;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::colour::{contrast, ColourTable};
    use rand::{Rng, SeedableRng};

    /// Expected colour over N' ~ Normal(n, sigma), by direct quadrature of the spectral sum.
    fn direct_average(n: f64, sigma: f64, polariser: Polariser) -> [f64; 3] {
        let steps = 400;
        let mut rgb = [0.0; 3];
        let mut total = 0.0;
        for k in 0..=steps {
            let z = -5.0 + 10.0 * k as f64 / steps as f64;
            let w = (-0.5 * z * z).exp();
            let s = spectral_colour_with((n + sigma * z).abs(), polariser);
            for c in 0..3 {
                rgb[c] += w * s[c];
            }
            total += w;
        }
        rgb.map(|x| x / total)
    }

    fn small_table() -> BlurredColourTable {
        BlurredColourTable::new(512, 10.0, 33, 1.0, Polariser::Ideal)
    }

    #[test]
    fn zero_spread_row_is_the_sharp_table() {
        let blurred = small_table();
        let sharp = ColourTable::with_polariser(512, 10.0, Polariser::Ideal);
        let mut worst: f32 = 0.0;
        for k in 0..=300 {
            let n = 10.0 * k as f64 / 300.0;
            let (a, b) = (blurred.lookup(n, 0.0), sharp.lookup(n));
            for c in 0..3 {
                worst = worst.max((a[c] - b[c]).abs());
            }
        }
        eprintln!("sigma_N = 0 row vs sharp table max difference {worst:e}");
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn large_spread_fades_colours_to_grey() {
        let table = small_table();
        let peak = |sigma: f64| {
            (0..=100)
                .map(|k| {
                    contrast(
                        table
                            .lookup(1.0 + 2.0 * k as f64 / 100.0, sigma)
                            .map(f64::from),
                    )
                })
                .fold(0.0, f64::max)
        };
        let (sharp, mid, wide) = (peak(0.0), peak(0.3), peak(1.0));
        eprintln!("peak contrast over N 1..3: sigma 0 {sharp}, 0.3 {mid}, 1.0 {wide}");
        assert!(
            sharp > 0.8 && mid < sharp && wide < 0.02,
            "{sharp} {mid} {wide}"
        );
        for c in table.lookup(2.0, 1.0) {
            assert!((c - 0.5).abs() < 0.02, "{c}");
        }
    }

    #[test]
    fn lookup_matches_a_direct_average() {
        let film = Polariser::FILM_560;
        let table = BlurredColourTable::new(512, 10.0, 33, 1.0, film);
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let mut worst: f64 = 0.0;
        for _ in 0..40 {
            let n = rng.gen_range(0.0..8.0);
            let sigma = rng.gen_range(0.0..1.0);
            let exact = direct_average(n, sigma, film);
            let looked = table.lookup(n, sigma);
            for c in 0..3 {
                worst = worst.max((exact[c] - f64::from(looked[c])).abs());
            }
        }
        eprintln!("blurred table vs direct Gaussian average max error {worst:e}");
        assert!(worst < 0.01, "{worst}");
        // Out of range: spreads beyond the table read the last row, negative values read 0.
        assert_eq!(table.lookup(3.0, 5.0), table.lookup(3.0, 1.0));
        assert_eq!(table.lookup(-1.0, -1.0), table.lookup(0.0, 0.0));
    }
}
