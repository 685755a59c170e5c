//! Predictions smoothed over time. A press evolves smoothly over the frames that film it, so the
//! force and contact point a model reads from consecutive frames of one press may be combined:
//! the least-squares line through the readings of the last `frames` frames of the press (the
//! current one and those before it, never one after), taken at the current frame, started again
//! at each press. It follows a steady ramp without lag (a plain mean over the window lags it by
//! `(frames - 1) / 2` frame intervals) and averages frame-to-frame noise away. The shape is not
//! smoothed.

use crate::eval::Row;
use crate::metrics::{Errors, Scored};
use std::collections::VecDeque;

/// The longest window: a second of frames at the camera's 50 fps.
pub(crate) const MAX_FRAMES: usize = 50;

/// A causal local-linear fit over the last `frames` frames of a press.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Smoothing {
    frames: usize,
}

/// A window that cannot be.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("smoothing over {0} frames: give 3 to {MAX_FRAMES} frames (a line through 2 frames or fewer is the frame's own reading)")]
pub struct SmoothingError(pub usize);

impl Smoothing {
    pub fn new(frames: usize) -> Result<Smoothing, SmoothingError> {
        if (3..=MAX_FRAMES).contains(&frames) {
            Ok(Smoothing { frames })
        } else {
            Err(SmoothingError(frames))
        }
    }

    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The rows (in time order within each press) with their force and contact predictions
    /// replaced by the window's line at the current frame; each press is smoothed on its own.
    pub fn apply(&self, rows: &[Row]) -> Vec<Scored> {
        let mut window: VecDeque<&Scored> = VecDeque::with_capacity(self.frames);
        let mut press: Option<&str> = None;
        let mut out = Vec::with_capacity(rows.len());
        for r in rows {
            if press != Some(r.press.as_str()) {
                window.clear();
                press = Some(r.press.as_str());
            }
            if window.len() == self.frames {
                window.pop_front();
            }
            window.push_back(&r.scored);
            let fz = trend_now(window.iter().map(|s| s.fz_pred));
            let x = trend_now(window.iter().map(|s| s.contact_pred[0]));
            let y = trend_now(window.iter().map(|s| s.contact_pred[1]));
            out.push(Scored {
                fz_pred: fz,
                contact_pred: [x, y],
                ..r.scored
            });
        }
        out
    }

    /// The whole-set errors of the smoothed predictions.
    pub fn errors(&self, rows: &[Row]) -> Errors {
        let mut e = Errors::default();
        for s in self.apply(rows) {
            e.add(&s);
        }
        e
    }
}

/// The least-squares line through the values (one per frame, oldest first), at the newest frame.
fn trend_now(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = values.clone().count();
    if n < 2 {
        return values.sum();
    }
    let nf = n as f64;
    let t_mean = (nf - 1.0) / 2.0;
    let v_mean = values.clone().sum::<f64>() / nf;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, v) in values.enumerate() {
        let dt = k as f64 - t_mean;
        sxy += dt * (v - v_mean);
        sxx += dt * dt;
    }
    v_mean + sxy / sxx * (nf - 1.0 - t_mean)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(press: &str, fz_true: f64, fz_pred: f64, x: f64) -> Row {
        Row {
            scored: Scored {
                fz_true,
                fz_pred,
                shape_true: 1,
                shape_pred: 1,
                contact_true: Some([0.0, 0.0]),
                contact_pred: [x, 0.0],
                shear_true: None,
                shear_pred: None,
                slip_true: None,
                slip_pred: None,
            },
            stage_mm: None,
            press: press.into(),
        }
    }

    #[test]
    fn the_fit_is_causal_and_starts_again_at_each_press() {
        let s = Smoothing::new(3).expect("3 frames");
        let rows = [
            row("a", 1.0, 1.0, 0.0),
            row("a", 2.0, 3.0, 3.0),
            row("a", 3.0, 2.0, 0.0),
            row("a", 4.0, 7.0, 0.0),
            row("b", 1.0, 10.0, 1.0),
        ];
        let out = s.apply(&rows);
        let fz: Vec<f64> = out.iter().map(|o| o.fz_pred).collect();
        // 1; the line through 1, 3; through 1, 3, 2 (mean 2, slope 0.5); through 3, 2, 7
        // (mean 4, slope 2); press b starts afresh. Never a frame after.
        assert_eq!(fz, [1.0, 3.0, 2.5, 6.0, 10.0]);
        assert_eq!(out[1].contact_pred, [3.0, 0.0]);
        assert_eq!(out[4].contact_pred, [1.0, 0.0], "press b starts afresh");
        // Labels and shapes are the frame's own.
        assert_eq!(out[3].fz_true, 4.0);
        assert_eq!(out[3].shape_pred, 1);
    }

    #[test]
    fn a_steady_ramp_is_followed_without_lag_and_noise_is_averaged_down() {
        let s = Smoothing::new(5).expect("5");
        let ramp: Vec<Row> = (0..20)
            .map(|k| row("p", 0.4 * k as f64, 0.4 * k as f64, 0.0))
            .collect();
        assert!(s.errors(&ramp).fz_rmse() < 1e-9, "no lag on a ramp");
        // A steady press read with alternating errors of +-1 N.
        let noisy: Vec<Row> = (0..20)
            .map(|k| row("p", 5.0, if k % 2 == 0 { 6.0 } else { 4.0 }, 0.0))
            .collect();
        let raw = {
            let mut e = Errors::default();
            noisy.iter().for_each(|r| e.add(&r.scored));
            e
        };
        assert!((raw.fz_rmse() - 1.0).abs() < 1e-12);
        let smoothed = s.errors(&noisy).fz_rmse();
        // The press's first frames have less to average over.
        assert!(smoothed < 0.5, "{smoothed}");
    }

    #[test]
    fn a_window_of_one_or_too_many_frames_is_refused() {
        for n in [0, 1, 2, MAX_FRAMES + 1] {
            let e = Smoothing::new(n).expect_err("refused");
            assert!(e.to_string().contains(&format!("{n} frames")), "{e}");
        }
    }
}
