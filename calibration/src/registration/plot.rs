//! The residual plot of a registration fit, and the drawing primitives it and the contact overlay
//! use (lines, circles, a 3x5 pixel font).
//!
//! [`residual_plot`]: the press positions in stage mm (x right, y up), inliers as blue dots,
//! outliers as red ones, each with its residual vector (seen minus predicted, turned back into
//! the stage frame) scaled up by a round factor so that the longest one spans about a third of
//! the press spacing (outliers do not set the scale: their vectors are capped at 0.45 of the
//! spacing and labelled with their length); the factor, the RMS residual and a bar of a round
//! number of residual px are written on the plot.

use super::similarity_fit::SimilarityFit;
use image::{Rgb, RgbImage};

/// Plot size, px.
pub const PLOT_PX: u32 = 720;
const MARGIN: f64 = 70.0;
const FONT_SCALE: i64 = 3;
/// Residual plot colours: text, frame and press dots;
const BLACK: [u8; 3] = [0, 0, 0];
/// grid lines;
const GREY: [u8; 3] = [215, 215, 215];
/// inlier vectors and the scale bar;
const INLIER_COLOUR: [u8; 3] = [30, 70, 200];
/// outlier vectors.
const OUTLIER_COLOUR: [u8; 3] = [210, 30, 30];

/// Sets pixel (x, y) if it lies in the image.
fn put(img: &mut RgbImage, x: i64, y: i64, colour: [u8; 3]) {
    if x >= 0
        && y >= 0
        && (x as u64) < u64::from(img.width())
        && (y as u64) < u64::from(img.height())
    {
        img.put_pixel(x as u32, y as u32, Rgb(colour));
    }
}

/// A 1 px line from `a` to `b` (image px, pixel centres at +0.5), clipped to the image.
pub fn line(img: &mut RgbImage, a: [f64; 2], b: [f64; 2], colour: [u8; 3]) {
    let steps = (b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil().max(1.0);
    if !steps.is_finite() || steps > 1e5 {
        return;
    }
    let n = steps as i64;
    for s in 0..=n {
        let t = s as f64 / steps;
        let x = a[0] + t * (b[0] - a[0]);
        let y = a[1] + t * (b[1] - a[1]);
        put(img, x.floor() as i64, y.floor() as i64, colour);
    }
}

/// A line `width` px thick (square pen).
pub fn thick_line(img: &mut RgbImage, a: [f64; 2], b: [f64; 2], width: i64, colour: [u8; 3]) {
    let h = (width - 1) / 2;
    for dx in -h..=width - 1 - h {
        for dy in -h..=width - 1 - h {
            let d = [dx as f64, dy as f64];
            line(
                img,
                [a[0] + d[0], a[1] + d[1]],
                [b[0] + d[0], b[1] + d[1]],
                colour,
            );
        }
    }
}

/// A 1 px circle outline of radius `r` about `c`.
pub fn circle(img: &mut RgbImage, c: [f64; 2], r: f64, colour: [u8; 3]) {
    if !(r.is_finite() && r > 0.0 && r < 1e5) {
        return;
    }
    let n = (2.0 * std::f64::consts::PI * r).ceil().max(8.0) as usize;
    for k in 0..n {
        let t = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
        put(
            img,
            (c[0] + r * t.cos()).floor() as i64,
            (c[1] + r * t.sin()).floor() as i64,
            colour,
        );
    }
}

/// A filled disc of radius `r` about `c`.
pub fn dot(img: &mut RgbImage, c: [f64; 2], r: f64, colour: [u8; 3]) {
    let ri = r.ceil() as i64 + 1;
    let (cx, cy) = (c[0].floor() as i64, c[1].floor() as i64);
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            if ((dx * dx + dy * dy) as f64) <= r * r {
                put(img, cx + dx, cy + dy, colour);
            }
        }
    }
}

/// 3x5 glyph rows (bit 2 = left column); unknown characters draw as a blank.
fn glyph(ch: char) -> [u8; 5] {
    match ch {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 2, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        '+' => [0, 2, 7, 2, 0],
        '=' => [0, 7, 0, 7, 0],
        'x' => [0, 5, 2, 5, 0],
        'y' => [5, 5, 7, 1, 7],
        'p' => [7, 5, 7, 4, 4],
        'm' => [0, 7, 7, 5, 5],
        's' => [3, 4, 2, 1, 6],
        'r' => [0, 6, 5, 4, 4],
        'e' => [7, 4, 6, 4, 7],
        'i' => [2, 0, 2, 2, 2],
        'd' => [1, 1, 7, 5, 7],
        'u' => [0, 5, 5, 5, 7],
        'a' => [0, 7, 1, 7, 7],
        'l' => [6, 2, 2, 2, 7],
        'o' => [0, 7, 5, 5, 7],
        't' => [2, 7, 2, 2, 3],
        'c' => [0, 7, 4, 4, 7],
        'n' => [0, 6, 5, 5, 5],
        'g' => [7, 5, 7, 1, 7],
        'b' => [4, 4, 7, 5, 7],
        'f' => [3, 2, 7, 2, 2],
        'h' => [4, 4, 7, 5, 5],
        'k' => [5, 5, 6, 5, 5],
        'v' => [0, 5, 5, 5, 2],
        'w' => [0, 5, 5, 7, 7],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        ',' => [0, 0, 0, 2, 4],
        ':' => [0, 2, 0, 2, 0],
        '/' => [1, 1, 2, 4, 4],
        'j' => [1, 0, 1, 5, 7],
        'q' => [7, 5, 7, 1, 1],
        'z' => [7, 1, 2, 4, 7],
        '%' => [5, 1, 2, 4, 5],
        '|' => [2, 2, 2, 2, 2],
        _ => [0; 5],
    }
}

/// Writes `text` (lower case, digits, a few signs) with its top-left corner at (x, y), glyphs
/// 3x5 cells of `scale` px.
pub fn text(img: &mut RgbImage, x: i64, y: i64, scale: i64, s: &str, colour: [u8; 3]) {
    for (n, ch) in s.chars().enumerate() {
        let g = glyph(ch.to_ascii_lowercase());
        let x0 = x + n as i64 * 4 * scale;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            put(
                                img,
                                x0 + col * scale + dx,
                                y + row as i64 * scale + dy,
                                colour,
                            );
                        }
                    }
                }
            }
        }
    }
}

/// Width of `s` in px at `scale`.
pub fn text_width(s: &str, scale: i64) -> i64 {
    (s.chars().count() as i64 * 4 - 1).max(0) * scale
}

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
pub fn residual_plot(fit: &SimilarityFit, stage_mm: &[[f64; 2]]) -> RgbImage {
    let mut img = RgbImage::from_pixel(PLOT_PX, PLOT_PX, Rgb([255, 255, 255]));
    let n = stage_mm.len().min(fit.residuals.len());
    let pts = &stage_mm[..n];
    if n == 0 {
        text(&mut img, 20, 20, FONT_SCALE, "no presses", BLACK);
        return img;
    }
    let frame = PlotFrame::around(pts);
    draw_axes(&mut img, &frame);
    let vectors = ResidualVectors::new(fit, pts, frame.span);
    draw_residuals(&mut img, &frame, fit, pts, &vectors);
    draw_header(&mut img, &frame, fit, n, vectors.scale);
    img
}

/// The square of stage mm shown on the plot and its mapping to plot px.
struct PlotFrame {
    /// Largest extent of the presses, mm (at least 1).
    span: f64,
    /// Centre of the presses' bounding box, mm.
    cx: f64,
    cy: f64,
    /// Half the side of the shown square, mm.
    half: f64,
    /// Side of the plotting area inside the margins, px.
    inner: f64,
    px_per_mm: f64,
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
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let half = 0.5 * span + pad;
        let inner = f64::from(PLOT_PX) - 2.0 * MARGIN;
        let px_per_mm = inner / (2.0 * half);
        PlotFrame {
            span,
            cx,
            cy,
            half,
            inner,
            px_per_mm,
        }
    }

    /// Plot px of the stage point (x, y) mm.
    fn to_plot(&self, x: f64, y: f64) -> [f64; 2] {
        [
            MARGIN + (x - (self.cx - self.half)) * self.px_per_mm,
            MARGIN + ((self.cy + self.half) - y) * self.px_per_mm,
        ]
    }
}

/// Draws the grid with tick labels every round number of mm, the frame box and the axis names.
fn draw_axes(img: &mut RgbImage, frame: &PlotFrame) {
    let PlotFrame {
        cx,
        cy,
        half,
        inner,
        ..
    } = *frame;
    let step = round_down_125(2.0 * half / 4.0);
    let mut t = ((cx - half) / step).ceil() * step;
    while t <= cx + half + 1e-9 {
        let [u, _] = frame.to_plot(t, cy);
        line(img, [u, MARGIN], [u, MARGIN + inner], GREY);
        let label = fmt_round_signed(t);
        text(
            img,
            u as i64 - text_width(&label, 2) / 2,
            (MARGIN + inner + 8.0) as i64,
            2,
            &label,
            BLACK,
        );
        t += step;
    }
    let mut t = ((cy - half) / step).ceil() * step;
    while t <= cy + half + 1e-9 {
        let [_, v] = frame.to_plot(cx, t);
        line(img, [MARGIN, v], [MARGIN + inner, v], GREY);
        let label = fmt_round_signed(t);
        text(
            img,
            MARGIN as i64 - 8 - text_width(&label, 2),
            v as i64 - 5,
            2,
            &label,
            BLACK,
        );
        t += step;
    }
    let box_corners = [
        [MARGIN, MARGIN],
        [MARGIN + inner, MARGIN],
        [MARGIN + inner, MARGIN + inner],
        [MARGIN, MARGIN + inner],
    ];
    for k in 0..4 {
        line(img, box_corners[k], box_corners[(k + 1) % 4], BLACK);
    }
    text(
        img,
        (MARGIN + inner / 2.0) as i64 - text_width("stage x mm", 2) / 2,
        (MARGIN + inner + 30.0) as i64,
        2,
        "stage x mm",
        BLACK,
    );
    text(img, 6, (MARGIN - 24.0) as i64, 2, "stage y mm", BLACK);
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

/// Draws each press as a black dot with its scaled residual vector (blue for inliers; red,
/// circled and capped at 0.45 of the spacing with its length written, for outliers).
fn draw_residuals(
    img: &mut RgbImage,
    frame: &PlotFrame,
    fit: &SimilarityFit,
    pts: &[[f64; 2]],
    vectors: &ResidualVectors,
) {
    let scale = vectors.scale;
    for (k, p) in pts.iter().enumerate() {
        let outlier = fit.residuals[k].outlier;
        let colour = if outlier {
            OUTLIER_COLOUR
        } else {
            INLIER_COLOUR
        };
        let a = frame.to_plot(p[0], p[1]);
        let mut d = [scale * vectors.mm[k][0], scale * vectors.mm[k][1]];
        let len = d[0].hypot(d[1]);
        let cap = 0.45 * vectors.spacing;
        if len > cap {
            d = [d[0] * cap / len, d[1] * cap / len];
            let label = format!("{:.1} px", fit.residuals[k].length_px());
            text(img, a[0] as i64 + 12, a[1] as i64 + 12, 2, &label, colour);
        }
        let b = frame.to_plot(p[0] + d[0], p[1] + d[1]);
        thick_line(img, a, b, 2, colour);
        dot(img, b, 2.0, colour);
        dot(img, a, 4.0, BLACK);
        if outlier {
            circle(img, a, 9.0, colour);
        }
    }
}

/// Writes the header (drawing factor, RMS residual, presses used) and draws a bar of a round
/// number of residual px at that factor.
fn draw_header(img: &mut RgbImage, frame: &PlotFrame, fit: &SimilarityFit, n: usize, scale: f64) {
    let head = format!(
        "residuals x{}   rms {:.3} px   {} of {} presses",
        fmt_round(scale),
        fit.residual_rms_px,
        fit.inliers,
        n
    );
    text(img, MARGIN as i64, 14, 2, &head, BLACK);
    let (inner, px_per_mm) = (frame.inner, frame.px_per_mm);
    let bar_px_residual = if fit.px_per_mm > 0.0 {
        // A round residual (px) whose bar is at most a quarter of the plot.
        round_down_125((0.25 * inner / px_per_mm / scale * fit.px_per_mm).max(1e-9))
    } else {
        1.0
    };
    let bar_len = bar_px_residual / fit.px_per_mm.max(1e-12) * scale * px_per_mm;
    let (bx, by) = (MARGIN + inner - bar_len - 10.0, MARGIN - 14.0);
    thick_line(img, [bx, by], [bx + bar_len, by], 3, INLIER_COLOUR);
    let label = format!("{} px", fmt_round(bar_px_residual));
    text(
        img,
        (bx - 10.0) as i64 - text_width(&label, 2),
        by as i64 - 5,
        2,
        &label,
        BLACK,
    );
}

fn fmt_round_signed(x: f64) -> String {
    let v = if x.abs() < 1e-9 { 0.0 } else { x };
    let s = format!("{v:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_numbers() {
        assert_eq!(round_down_125(0.37), 0.2);
        assert_eq!(round_down_125(7.0), 5.0);
        assert_eq!(round_down_125(199.0), 100.0);
        assert_eq!(fmt_round(0.05), "0.05");
        assert_eq!(fmt_round(200.0), "200");
        assert_eq!(fmt_round_signed(-6.0), "-6");
    }

    #[test]
    fn text_and_lines_draw_inside_the_image_only() {
        let mut img = RgbImage::new(40, 20);
        text(&mut img, 1, 1, 1, "1.5 px", [255, 0, 0]);
        line(&mut img, [-50.0, -50.0], [100.0, 100.0], [0, 255, 0]);
        circle(&mut img, [20.0, 10.0], 30.0, [0, 0, 255]);
        assert!(img.pixels().any(|p| p.0 == [255, 0, 0]));
        assert!(img.pixels().any(|p| p.0 == [0, 255, 0]));
    }
}
