//! The residual plot of a registration fit.
//!
//! [`residual_plot`]: the press positions in stage mm (x right, y up), each with its residual
//! vector (seen minus predicted, turned back into the stage frame) scaled up by a round factor so
//! that the longest inlier spans about a third of the press spacing; outliers in red, ringed,
//! their vectors capped at 0.45 of the spacing and labelled with their length. The title gives
//! the factor, the RMS residual and the presses used; a bar of a round number of residual px at
//! that factor is drawn in the lower left. Drawn by `fringe-plot`.

use super::similarity_fit::SimilarityFit;
use fringe_plot::palette::{BLACK, BLUE, RED};
use fringe_plot::{Axis, Chart, Corner, PlotError, Series};
use image::RgbImage;

/// Plot size, px.
pub(crate) const PLOT_PX: u32 = 720;

/// The largest of 1, 2, 5 x 10^n not above `x` (x > 0).
fn round_down_125(x: f64) -> f64 {
    let e = x.log10().floor();
    let base = 10f64.powf(e);
    let m = x / base;
    let f = if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    };
    f * base
}

/// Formats a round number without trailing zeros.
fn fmt_round(x: f64) -> String {
    if x >= 1.0 {
        format!("{}", x.round() as i64)
    } else {
        let s = format!("{x:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// The residual plot of `fit` over the presses' stage positions `stage_mm` (same order as
/// `fit.residuals`).
pub fn residual_plot(fit: &SimilarityFit, stage_mm: &[[f64; 2]]) -> Result<RgbImage, PlotError> {
    let n = stage_mm.len().min(fit.residuals.len());
    let pts = &stage_mm[..n];
    let x = Axis::new("stage x (mm)");
    let y = Axis::new("stage y (mm)");
    if n == 0 {
        return Chart::new("Registration residuals: no presses", x, y).render(PLOT_PX, PLOT_PX);
    }
    let frame = PlotFrame::around(pts);
    let vectors = ResidualVectors::new(fit, pts, frame.span);
    let scale = vectors.scale;
    let (mut inliers, mut outliers, mut rings, mut labels) = (vec![], vec![], vec![], vec![]);
    for (k, p) in pts.iter().enumerate() {
        let mut d = [scale * vectors.mm[k][0], scale * vectors.mm[k][1]];
        let len = d[0].hypot(d[1]);
        let cap = 0.45 * vectors.spacing;
        if len > cap {
            d = [d[0] * cap / len, d[1] * cap / len];
            labels.push((*p, format!("{:.1} px", fit.residuals[k].length_px())));
        }
        let arrow = [*p, [p[0] + d[0], p[1] + d[1]]];
        if fit.residuals[k].outlier {
            outliers.push(arrow);
            rings.push(*p);
        } else {
            inliers.push(arrow);
        }
    }
    let bar = frame.scale_bar(fit, scale);
    let title = format!(
        "Registration residuals x{}: RMS {:.3} px, {} of {} presses",
        fmt_round(scale),
        fit.residual_rms_px,
        fit.inliers,
        n
    );
    let [x0, x1, y0, y1] = frame.bounds();
    // Room above the presses for the legend.
    let y1 = y1 + 0.3 * (y1 - y0);
    let mut chart = Chart::new(title, x.range(x0, x1), y.range(y0, y1))
        .equal_aspect()
        .legend_at(Corner::UpperRight)
        .series(Series::points("press (stage position)", pts, 5, BLACK))
        .series(Series::arrows(
            format!("residual x{} (seen - predicted)", fmt_round(scale)),
            &inliers,
            BLUE,
        ));
    if !outliers.is_empty() {
        chart = chart
            .series(Series::arrows(
                "outlier's residual (capped)",
                &outliers,
                RED,
            ))
            .series(Series::rings("outlier", &rings, 11, RED));
    }
    if let Some((segment, label)) = bar {
        chart = chart
            .series(Series::segments(
                format!("scale: {label}"),
                &[segment],
                BLUE,
            ))
            .series(Series::labels(&[(segment[0], label)], BLUE));
    }
    chart
        .series(Series::labels(&labels, RED))
        .render(PLOT_PX, PLOT_PX)
}

/// The square of stage mm shown on the plot.
struct PlotFrame {
    /// Largest extent of the presses, mm (at least 1).
    span: f64,
    /// Centre of the presses' bounding box, mm.
    cx: f64,
    cy: f64,
    /// Half the side of the shown square, mm.
    half: f64,
}

impl PlotFrame {
    /// The square about the bounding box of `pts`, padded by 15 % of its span on each side.
    fn around(pts: &[[f64; 2]]) -> PlotFrame {
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in pts {
            x0 = x0.min(p[0]);
            x1 = x1.max(p[0]);
            y0 = y0.min(p[1]);
            y1 = y1.max(p[1]);
        }
        let span = (x1 - x0).max(y1 - y0).max(1.0);
        let pad = 0.15 * span;
        PlotFrame {
            span,
            cx: 0.5 * (x0 + x1),
            cy: 0.5 * (y0 + y1),
            half: 0.5 * span + pad,
        }
    }

    /// x from, x to, y from, y to (mm).
    fn bounds(&self) -> [f64; 4] {
        [
            self.cx - self.half,
            self.cx + self.half,
            self.cy - self.half,
            self.cy + self.half,
        ]
    }

    /// A bar of a round number of residual px at `scale`, at most a quarter of the plot, in its
    /// lower left corner, and its label ("0.5 px residual").
    fn scale_bar(&self, fit: &SimilarityFit, scale: f64) -> Option<([[f64; 2]; 2], String)> {
        if fit.px_per_mm.is_nan() || fit.px_per_mm <= 0.0 {
            return None;
        }
        let side = 2.0 * self.half;
        let px = round_down_125((0.25 * side / scale * fit.px_per_mm).max(1e-9));
        let len = px / fit.px_per_mm * scale;
        let (x, y) = (
            self.cx - self.half + 0.04 * side,
            self.cy - self.half + 0.04 * side,
        );
        Some((
            [[x, y], [x + len, y]],
            format!("{} px residual", fmt_round(px)),
        ))
    }
}

/// The presses' residual vectors in the stage frame and the factor they are drawn at.
struct ResidualVectors {
    /// Per press, seen minus predicted turned back into the stage frame, mm.
    mm: Vec<[f64; 2]>,
    /// The smallest distance between two presses (or the span for one press), mm.
    spacing: f64,
    /// Drawing factor: round, the longest inlier vector about a third of the spacing.
    scale: f64,
}

impl ResidualVectors {
    /// The vectors of `fit`'s residuals at `pts` (one per residual); `span` as in [`PlotFrame`].
    fn new(fit: &SimilarityFit, pts: &[[f64; 2]], span: f64) -> ResidualVectors {
        let n = pts.len();
        let mm: Vec<[f64; 2]> = fit.residuals[..n]
            .iter()
            .map(|r| fit.px_to_stage_vector(r.residual_px))
            .collect();
        // The scale follows the inliers; an outlier's vector is capped and labelled with its
        // length.
        let any_inlier = fit.residuals[..n].iter().any(|r| !r.outlier);
        let longest = mm
            .iter()
            .zip(&fit.residuals[..n])
            .filter(|(_, r)| !any_inlier || !r.outlier)
            .map(|(v, _)| v[0].hypot(v[1]))
            .fold(0.0f64, f64::max);
        let spacing = smallest_spacing(pts, span);
        let scale = if longest > 0.0 {
            round_down_125((0.35 * spacing / longest).max(1e-9))
        } else {
            1.0
        };
        ResidualVectors { mm, spacing, scale }
    }
}

/// The smallest distance between two distinct points of `pts` (`span` if there is none).
fn smallest_spacing(pts: &[[f64; 2]], span: f64) -> f64 {
    let n = pts.len();
    let mut spacing = span;
    for i in 0..n {
        for j in i + 1..n {
            let d = (pts[i][0] - pts[j][0]).hypot(pts[i][1] - pts[j][1]);
            if d > 1e-6 {
                spacing = spacing.min(d);
            }
        }
    }
    spacing
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registration::similarity_fit::{fit_similarity, FitSettings, Press};

    #[test]
    fn round_numbers() {
        assert_eq!(round_down_125(0.37), 0.2);
        assert_eq!(round_down_125(7.0), 5.0);
        assert_eq!(round_down_125(199.0), 100.0);
        assert_eq!(fmt_round(0.05), "0.05");
        assert_eq!(fmt_round(200.0), "200");
    }

    #[test]
    fn the_residual_plot_draws_presses_arrows_and_the_outlier() {
        // A 3 x 3 grid at 17 px/mm with a little noise, the middle press seen 6 px off.
        let mut stage = Vec::new();
        let mut presses = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                let s = [10.0 + 6.0 * i as f64, 5.0 + 6.0 * j as f64];
                let e = 0.1 * (((i * 7 + j * 3) % 5) as f64 - 2.0);
                let bump = if i == 1 && j == 1 { 6.0 } else { 0.0 };
                stage.push(s);
                presses.push(Press {
                    stage_mm: s,
                    pixel: [900.0 + 17.0 * s[0] + e + bump, 600.0 - 17.0 * s[1] - e],
                    sigma_px: 0.1,
                });
            }
        }
        let fit = fit_similarity(&presses, &FitSettings::default()).expect("fit");
        assert!(fit.residuals[4].outlier);
        let img = residual_plot(&fit, &stage).expect("plot");
        assert_eq!(img.dimensions(), (PLOT_PX, PLOT_PX));
        let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
        assert!(count(BLUE) > 100, "inlier arrows and the scale bar");
        assert!(count(RED) > 60, "the outlier's ring, arrow and label");
        assert!(count(BLACK) > 9 * 50, "the presses, the frame and the text");
        let empty = residual_plot(&fit, &[]).expect("plot");
        assert_eq!(empty.dimensions(), (PLOT_PX, PLOT_PX));
    }
}
