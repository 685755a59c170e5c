//! Positions drawn on the sensor disc (Braille canvas): the plan's points with their path, or the
//! measured and predicted contact points.

use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::widgets::canvas::{Canvas, Circle, Line, Points};
use ratatui::widgets::Block;

/// A layer of points.
pub(crate) struct Layer<'a> {
    pub coords: &'a [(f64, f64)],
    pub color: Color,
    /// Join the points in order (a path).
    pub path: bool,
    pub glyph: Glyph,
}

/// How a layer's points are drawn.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Glyph {
    /// Braille dots (for many points).
    Dots,
    /// Numbered in order, the first as `n + 1`.
    Numbers(usize),
    /// One symbol at each point.
    Symbol(&'static str),
}

/// A canvas about `centre` showing `radius` mm around it (the disc's outline when `outline`),
/// y up; cells are about twice as tall as wide, so the x range is widened to keep circles round.
pub(crate) fn canvas<'a>(
    block: Block<'a>,
    centre: (f64, f64),
    radius: f64,
    outline: bool,
    layers: Vec<Layer<'a>>,
    aspect: f64,
) -> Canvas<'a, impl Fn(&mut ratatui::widgets::canvas::Context<'_>) + 'a> {
    let disc = outline.then_some(Disc { centre, radius });
    canvas_about(block, centre, radius, disc, layers, aspect)
}

/// The sensor disc: its centre and radius, mm.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Disc {
    pub centre: (f64, f64),
    pub radius: f64,
}

/// A canvas about `centre` showing `radius` mm around it, with the outline of `disc` (clipped
/// where it leaves the view) and its centre marked when the view does not hold the whole disc.
pub(crate) fn canvas_about<'a>(
    block: Block<'a>,
    centre: (f64, f64),
    radius: f64,
    disc: Option<Disc>,
    layers: Vec<Layer<'a>>,
    aspect: f64,
) -> Canvas<'a, impl Fn(&mut ratatui::widgets::canvas::Context<'_>) + 'a> {
    let r = radius * 1.08;
    let rx = r * aspect.max(1.0);
    Canvas::default()
        .block(block)
        .marker(Marker::Braille)
        .x_bounds([centre.0 - rx, centre.0 + rx])
        .y_bounds([centre.1 - r, centre.1 + r])
        .paint(move |ctx| {
            if let Some(d) = disc {
                ctx.draw(&Circle {
                    x: d.centre.0,
                    y: d.centre.1,
                    radius: d.radius,
                    color: Color::DarkGray,
                });
                if d.radius > radius * 1.01 {
                    ctx.print(
                        d.centre.0,
                        d.centre.1,
                        ratatui::text::Span::styled("+", Style::new().fg(Color::DarkGray)),
                    );
                }
            }
            for layer in &layers {
                if layer.path {
                    for w in layer.coords.windows(2) {
                        ctx.draw(&Line {
                            x1: w[0].0,
                            y1: w[0].1,
                            x2: w[1].0,
                            y2: w[1].1,
                            color: Color::DarkGray,
                        });
                    }
                }
                // Text is drawn over the dots and lines; later layers over earlier ones.
                let style = Style::new().fg(layer.color);
                match layer.glyph {
                    Glyph::Dots => ctx.draw(&Points {
                        coords: layer.coords,
                        color: layer.color,
                    }),
                    Glyph::Numbers(first) => {
                        for (i, (x, y)) in layer.coords.iter().enumerate() {
                            let n = (first + i + 1).to_string();
                            ctx.print(*x, *y, ratatui::text::Span::styled(n, style));
                        }
                    }
                    Glyph::Symbol(symbol) => {
                        for (x, y) in layer.coords {
                            ctx.print(*x, *y, ratatui::text::Span::styled(symbol, style));
                        }
                    }
                }
            }
        })
}

/// Width over height of `area` in cell units made square (a cell is about 1:2).
pub(crate) fn aspect(area: ratatui::layout::Rect) -> f64 {
    if area.height == 0 {
        return 1.0;
    }
    area.width as f64 / (2.0 * area.height as f64)
}
