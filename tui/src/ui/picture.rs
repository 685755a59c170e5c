//! A picture drawn with 24-bit half blocks: each cell shows two pixels, the upper one as the
//! foreground of `▀`, the lower one as the background. Works in tmux and over ssh, needs no
//! terminal query. The picture arrives already small (made on a worker thread); drawing only
//! samples it.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Color;
use ratatui::widgets::Widget;

/// An RGB picture fitted into an area, centred, keeping its aspect (cells are twice as tall as
/// wide, so one cell holds two pixel rows).
pub struct Picture<'a>(pub &'a image::RgbImage);

impl Widget for Picture<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let img = self.0;
        if area.width == 0 || area.height == 0 || img.width() == 0 || img.height() == 0 {
            return;
        }
        // Output pixels: width x 2 height; scale to fit.
        let (iw, ih) = (img.width() as f64, img.height() as f64);
        let scale = (area.width as f64 / iw).min(2.0 * area.height as f64 / ih);
        let w = ((iw * scale).round() as u16).clamp(1, area.width);
        let h2 = ((ih * scale).round() as u16).clamp(1, 2 * area.height);
        let h = h2.div_ceil(2);
        let x0 = area.x + (area.width - w) / 2;
        let y0 = area.y + (area.height - h) / 2;
        let sample = |px: u16, py: u16| -> Color {
            if py >= h2 {
                return Color::Reset;
            }
            let sx = ((px as f64 + 0.5) / scale).floor().min(iw - 1.0) as u32;
            let sy = ((py as f64 + 0.5) / scale).floor().min(ih - 1.0) as u32;
            let p = img.get_pixel(sx, sy).0;
            Color::Rgb(p[0], p[1], p[2])
        };
        for cy in 0..h {
            for cx in 0..w {
                let cell = &mut buf[(x0 + cx, y0 + cy)];
                cell.set_symbol("▀")
                    .set_fg(sample(cx, 2 * cy))
                    .set_bg(sample(cx, 2 * cy + 1));
            }
        }
    }
}
