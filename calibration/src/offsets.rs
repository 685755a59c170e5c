//! Force offsets: the F/T bias from no-contact windows, its drift through a run and the zero-load
//! check against a profile. Pure functions of samples; no device access.

use fringe_rig::{NewtonMetres, Newtons, Wrench};
use serde::{Deserialize, Serialize};

/// Channel names in [`Wrench::to_array`] order.
pub const CHANNELS: [&str; 6] = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"];

/// The bias of one no-contact window: per channel mean and standard error of the mean
/// (N for forces, N m for torques), with the window's mid time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bias {
    pub mean: [f64; 6],
    pub standard_error: [f64; 6],
    pub samples: usize,
    /// Mean sample time, s (on the caller's time base).
    pub t_s: f64,
}

impl Bias {
    /// The mean as a wrench.
    pub fn wrench(&self) -> Wrench {
        Wrench::from_array(self.mean)
    }
}

/// Bias of a no-contact window of `(time s, wrench)` samples; `None` for fewer than two samples.
///
/// The standard error is sd / sqrt(n), which assumes uncorrelated noise (true of the F/T
/// sensor's white noise; drift within one short window is negligible).
pub fn bias(samples: &[(f64, Wrench)]) -> Option<Bias> {
    let n = samples.len();
    if n < 2 {
        return None;
    }
    let mut mean = [0.0; 6];
    for (_, w) in samples {
        for (m, v) in mean.iter_mut().zip(w.to_array()) {
            *m += v;
        }
    }
    mean.iter_mut().for_each(|m| *m /= n as f64);
    let mut var = [0.0; 6];
    for (_, w) in samples {
        for ((s, v), m) in var.iter_mut().zip(w.to_array()).zip(mean) {
            *s += (v - m).powi(2);
        }
    }
    let standard_error = var.map(|s| (s / (n - 1) as f64).sqrt() / (n as f64).sqrt());
    let t_s = samples.iter().map(|(t, _)| t).sum::<f64>() / n as f64;
    Some(Bias {
        mean,
        standard_error,
        samples: n,
        t_s,
    })
}

/// Offset drift through a run: per channel a straight line offset(t) = intercept + slope t fitted
/// (weighted by 1 / standard error^2) to biases re-measured at every retract.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Drift {
    /// Offset at t = 0 (N / N m).
    pub intercept: [f64; 6],
    /// Change per second (N/s / N m/s).
    pub slope_per_s: [f64; 6],
    /// 1-sigma uncertainty of the slope from the fit.
    pub slope_sigma: [f64; 6],
    /// RMS of the biases about the line.
    pub residual_rms: [f64; 6],
    pub windows: usize,
}

impl Drift {
    /// The fitted offset at time `t_s`.
    pub fn offset_at(&self, t_s: f64) -> Wrench {
        Wrench::from_array(std::array::from_fn(|i| {
            self.intercept[i] + self.slope_per_s[i] * t_s
        }))
    }
}

/// Fits [`Drift`] to `biases` (at least two at different times); `None` otherwise.
///
/// Slope uncertainty: from the weighted fit, scaled up by the reduced chi-square when the biases
/// scatter more than their standard errors (drift is a random walk, not a line).
pub fn drift(biases: &[Bias]) -> Option<Drift> {
    let n = biases.len();
    if n < 2 {
        return None;
    }
    let t0 = biases[0].t_s;
    if biases.iter().all(|b| (b.t_s - t0).abs() < 1e-9) {
        return None;
    }
    let mut out = Drift {
        intercept: [0.0; 6],
        slope_per_s: [0.0; 6],
        slope_sigma: [0.0; 6],
        residual_rms: [0.0; 6],
        windows: n,
    };
    for ch in 0..6 {
        let w: Vec<f64> = biases
            .iter()
            .map(|b| 1.0 / b.standard_error[ch].max(1e-12).powi(2))
            .collect();
        let sw: f64 = w.iter().sum();
        let st = biases.iter().zip(&w).map(|(b, w)| w * b.t_s).sum::<f64>() / sw;
        let sy = biases
            .iter()
            .zip(&w)
            .map(|(b, w)| w * b.mean[ch])
            .sum::<f64>()
            / sw;
        let stt: f64 = biases
            .iter()
            .zip(&w)
            .map(|(b, w)| w * (b.t_s - st).powi(2))
            .sum();
        let sty: f64 = biases
            .iter()
            .zip(&w)
            .map(|(b, w)| w * (b.t_s - st) * (b.mean[ch] - sy))
            .sum();
        let slope = sty / stt;
        let intercept = sy - slope * st;
        let resid: Vec<f64> = biases
            .iter()
            .map(|b| b.mean[ch] - intercept - slope * b.t_s)
            .collect();
        let chi2: f64 = resid.iter().zip(&w).map(|(r, w)| w * r * r).sum();
        let scale = if n > 2 {
            (chi2 / (n - 2) as f64).max(1.0)
        } else {
            1.0
        };
        out.intercept[ch] = intercept;
        out.slope_per_s[ch] = slope;
        out.slope_sigma[ch] = (scale / stt).sqrt();
        out.residual_rms[ch] = (resid.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
    }
    Some(out)
}

/// Force offsets as kept in a profile: the bias when the profile was made.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceOffsets {
    /// Fx Fy Fz, N.
    pub force_n: [f64; 3],
    /// Tx Ty Tz, N m.
    pub torque_nm: [f64; 3],
    /// Standard errors, same units.
    pub force_sigma_n: [f64; 3],
    pub torque_sigma_nm: [f64; 3],
    /// Samples averaged.
    pub samples: usize,
    /// Drift of Fx Fy Fz through the run the profile came from, N/s (when measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift_n_per_s: Option<[f64; 3]>,
}

impl ForceOffsets {
    pub fn from_bias(b: &Bias, drift: Option<&Drift>) -> ForceOffsets {
        ForceOffsets {
            force_n: [b.mean[0], b.mean[1], b.mean[2]],
            torque_nm: [b.mean[3], b.mean[4], b.mean[5]],
            force_sigma_n: [
                b.standard_error[0],
                b.standard_error[1],
                b.standard_error[2],
            ],
            torque_sigma_nm: [
                b.standard_error[3],
                b.standard_error[4],
                b.standard_error[5],
            ],
            samples: b.samples,
            drift_n_per_s: drift.map(|d| [d.slope_per_s[0], d.slope_per_s[1], d.slope_per_s[2]]),
        }
    }
}

/// Tolerances of the zero-load check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZeroTolerance {
    pub force: Newtons,
    pub torque: NewtonMetres,
}

impl Default for ZeroTolerance {
    /// 0.05 N (the F/T noise sigma) and 0.005 N m.
    fn default() -> Self {
        ZeroTolerance {
            force: Newtons(0.05),
            torque: NewtonMetres(0.005),
        }
    }
}

/// Zero-load check: one warning per channel whose offset `now` moved from the profile's by more
/// than the tolerance (plus three combined standard errors, so noise alone does not warn).
/// Empty when the offsets agree.
pub fn zero_load_check(profile: &ForceOffsets, now: &Bias, tol: ZeroTolerance) -> Vec<String> {
    let then: Vec<f64> = profile
        .force_n
        .iter()
        .chain(&profile.torque_nm)
        .copied()
        .collect();
    let then_se: Vec<f64> = profile
        .force_sigma_n
        .iter()
        .chain(&profile.torque_sigma_nm)
        .copied()
        .collect();
    let mut warnings = Vec::new();
    for ch in 0..6 {
        let (limit, unit) = if ch < 3 {
            (tol.force.0, "N")
        } else {
            (tol.torque.0, "N m")
        };
        let se = then_se[ch].hypot(now.standard_error[ch]);
        let moved = now.mean[ch] - then[ch];
        if moved.abs() > limit + 3.0 * se {
            warnings.push(format!(
                "{} offset moved {moved:+.4} {unit} since the profile was made (tolerance {limit} {unit}): re-bias the F/T sensor or calibrate the sensor again",
                CHANNELS[ch]
            ));
        }
    }
    warnings
}

/// The zero-load check of a profile, as a scan calls it at its first offset measurement.
#[derive(Debug, Clone)]
pub struct ProfileOffsetCheck {
    pub offsets: ForceOffsets,
    pub tolerance: ZeroTolerance,
    /// The profile file, for the messages.
    pub profile: String,
}

impl fringe_rig::scan::OffsetCheck for ProfileOffsetCheck {
    fn check(&self, mean: [f64; 6], standard_error: [f64; 6]) -> Vec<String> {
        let now = Bias {
            mean,
            standard_error,
            samples: 0,
            t_s: 0.0,
        };
        zero_load_check(&self.offsets, &now, self.tolerance)
            .into_iter()
            .map(|w| format!("{} (profile {})", w, self.profile))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(v: f64) -> Wrench {
        Wrench::from_array([v, -v, 2.0 * v, 0.0, 0.0, 0.0])
    }

    #[test]
    fn bias_drift_and_zero_check_on_exact_data() {
        let win: Vec<(f64, Wrench)> = vec![(0.0, w(1.0)), (1.0, w(3.0))];
        let b = bias(&win).expect("two samples");
        assert_eq!(b.mean[0], 2.0);
        assert_eq!(b.mean[2], 4.0);
        // sd = sqrt(2), se = 1
        assert!((b.standard_error[0] - 1.0).abs() < 1e-12);
        assert_eq!(b.t_s, 0.5);
        assert!(bias(&win[..1]).is_none());

        let biases: Vec<Bias> = (0..5)
            .map(|k| Bias {
                mean: [0.5 + 0.01 * k as f64; 6],
                standard_error: [0.001; 6],
                samples: 100,
                t_s: 10.0 * k as f64,
            })
            .collect();
        let d = drift(&biases).expect("fit");
        assert!((d.slope_per_s[0] - 0.001).abs() < 1e-12, "{d:?}");
        assert!((d.intercept[0] - 0.5).abs() < 1e-12);
        assert!((d.offset_at(20.0).fx.0 - 0.52).abs() < 1e-12);

        let offsets = ForceOffsets::from_bias(&biases[0], Some(&d));
        let loose = ZeroTolerance {
            force: Newtons(0.02),
            torque: NewtonMetres(0.02),
        };
        // Moved 0.01 on every channel: within 0.02.
        assert!(zero_load_check(&offsets, &biases[1], loose).is_empty());
        let warnings = zero_load_check(&offsets, &biases[4], loose);
        // All six channels moved 0.04: over 0.02.
        assert_eq!(warnings.len(), 6, "{warnings:?}");
        assert!(
            warnings[0].starts_with("Fx offset moved +0.0400 N"),
            "{warnings:?}"
        );
    }
}
