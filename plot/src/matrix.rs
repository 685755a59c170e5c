//! A matrix of counts (a confusion matrix): rows and columns named, each cell shaded by its share
//! of its row and written with its count and that share.

use crate::canvas::render;
use crate::error::PlotError;
use crate::font;
use crate::palette::{BLACK, WHITE};
use crate::xy::Ticked;
use image::RgbImage;
use plotters::chart::ChartBuilder;
use plotters::element::{Rectangle, Text};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{Color, RGBColor};

/// Counts by row and column, the diagonal shaded blue and the rest red.
#[derive(Debug, Clone)]
pub struct Matrix<'a> {
    /// The chart's title.
    pub title: &'a str,
    /// What the rows and the columns are ("labelled shape", "predicted shape").
    pub rows_label: &'a str,
    pub columns_label: &'a str,
    /// The names of the rows, which are also the columns.
    pub names: &'a [String],
    /// `counts[row][column]`.
    pub counts: &'a [Vec<u64>],
}

impl Matrix<'_> {
    /// The matrix as a `side` x `side` picture.
    pub fn render(&self, side: u32) -> Result<RgbImage, PlotError> {
        let n = self.names.len().max(1);
        let at = |k: usize| k as f64;
        let name = move |v: f64, names: &[String]| -> String {
            let k = v.round();
            if (v - k).abs() > 1e-6 || k < 0.0 {
                return String::new();
            }
            names.get(k as usize).cloned().unwrap_or_default()
        };
        render(side, side, |root| {
            root.fill(&RGBColor(255, 255, 255))?;
            let longest = self
                .names
                .iter()
                .map(|s| s.chars().count())
                .max()
                .unwrap_or(1) as u32;
            let mut ctx = ChartBuilder::on(root)
                .caption(self.title, font::text(21.0, BLACK))
                .margin(14)
                .margin_right(24)
                .x_label_area_size(56)
                .y_label_area_size(longest * 9 + 44)
                .build_cartesian_2d(
                    Ticked {
                        lo: -0.5,
                        hi: n as f64 - 0.5,
                        ticks: (0..n).map(at).collect(),
                    },
                    Ticked {
                        lo: -0.5,
                        hi: n as f64 - 0.5,
                        ticks: (0..n).map(at).collect(),
                    },
                )?;
            // Row 0 at the top: y = n - 1 - row.
            let names = self.names;
            let x_fmt = |v: &f64| name(*v, names);
            let y_fmt = |v: &f64| name(n as f64 - 1.0 - *v, names);
            ctx.configure_mesh()
                .disable_mesh()
                .x_desc(self.columns_label)
                .y_desc(self.rows_label)
                .axis_desc_style(font::text(18.0, BLACK))
                .label_style(font::text(15.0, BLACK))
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt)
                .draw()?;
            for (i, row) in self.counts.iter().enumerate().take(n) {
                let total = row.iter().sum::<u64>();
                for (j, &v) in row.iter().enumerate().take(n) {
                    let share = if total > 0 {
                        v as f64 / total as f64
                    } else {
                        0.0
                    };
                    let shade = (255.0 - 200.0 * share).round() as u8;
                    let fill = if i == j {
                        RGBColor(shade, shade, 255)
                    } else {
                        RGBColor(255, shade, shade)
                    };
                    let (x, y) = (j as f64, (n - 1 - i) as f64);
                    ctx.draw_series([
                        Rectangle::new([(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)], fill.filled()),
                        Rectangle::new(
                            [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                            RGBColor(WHITE[0], WHITE[1], WHITE[2]).stroke_width(2),
                        ),
                    ])?;
                    let centre = Pos::new(HPos::Center, VPos::Center);
                    ctx.draw_series([
                        Text::new(
                            v.to_string(),
                            (x, y + 0.08),
                            font::text(20.0, BLACK).pos(centre),
                        ),
                        Text::new(
                            format!("{:.0} %", 100.0 * share),
                            (x, y - 0.18),
                            font::text(13.0, BLACK).pos(centre),
                        ),
                    ])?;
                }
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_shaded_by_their_share_of_the_row() {
        let names = vec!["None".to_string(), "Sphere".to_string()];
        let counts = vec![vec![9, 1], vec![0, 10]];
        let img = Matrix {
            title: "Confusion matrix",
            rows_label: "labelled",
            columns_label: "predicted",
            names: &names,
            counts: &counts,
        }
        .render(300)
        .expect("draws");
        // A full diagonal cell is deep blue; the off-diagonal 10 % is pale red.
        assert!(img.pixels().any(|p| p.0 == [55, 55, 255]));
        assert!(img.pixels().any(|p| p.0 == [255, 235, 235]));
    }
}
