//! The Validate screen: the raw frame and the network input side by side, predicted against
//! measured Fz over time, the contact points on the disc, the shape with its probability, the
//! running metrics, the error by grid cell, the loop rate and the frames skipped.

use crate::ui::picture::Picture;
use crate::ui::screen::{Plain, ScreenDef};
use crate::ui::state::{Tab, UiState};
use crate::ui::widgets::disc::{aspect, canvas, Glyph, Layer};
use crate::ui::widgets::time_chart::{self, Series};
use crate::ui::view::shortened;
use crate::ui::widgets::{legend_panel, panel, BAD, GOOD, MEASURED, PREDICTED, WARN};
use fringe_app::session::ValidationState;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("validate");

/// No keys of its own: `r` (Scan) runs the plan with live validation when this screen is shown.
pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Validate",
    help: Vec::new,
    draw,
    hint: |s| s.scan.phase.key_hint(),
    open: |_| Box::new(Plain),
};

fn draw(f: &mut Frame, area: Rect, s: &UiState) {
    let Some(v) = &s.validation else {
        let text = match &s.model {
            Some(m) => vec![
                Line::from(format!("model: {m}")),
                Line::from(""),
                Line::from(
                    "press r to run the scan plan with live validation: every frame it records",
                ),
                Line::from(
                    "goes through the model and is compared with its synchronised F/T label.",
                ),
            ],
            None => vec![
                Line::from("no model chosen."),
                Line::from(""),
                Line::from("start fringe with one:  fringe validate --model FILE"),
                Line::from(
                    "(a .pth, .pt, .safetensors or .onnx file that `fringe model info` reads)",
                ),
            ],
        };
        f.render_widget(
            Paragraph::new(text)
                .wrap(Wrap { trim: true })
                .block(panel("live validation")),
            area,
        );
        return;
    };
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(45), Constraint::Percentage(55)]).areas(area);
    let [pictures, contact_area] =
        Layout::vertical([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(left);
    let [raw_area, input_area] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)])
            .areas(pictures);
    for (title, area, pick) in [("frame", raw_area, 0), ("network input", input_area, 1)] {
        let block = panel(title);
        let inner = block.inner(area);
        f.render_widget(block, area);
        match &v.latest {
            Some(l) => f.render_widget(Picture(if pick == 0 { &l.frame } else { &l.input }), inner),
            None => f.render_widget(Paragraph::new("waiting for a labelled frame"), inner),
        }
    }
    draw_contact(f, contact_area, v, s.scan.disc_radius_mm);
    let [metrics_area, chart_area, cells_area] = Layout::vertical([
        Constraint::Length(8),
        Constraint::Min(6),
        Constraint::Length(8),
    ])
    .areas(right);
    draw_metrics(f, metrics_area, v);
    draw_fz(f, chart_area, v);
    draw_cells(f, cells_area, v);
}

fn draw_metrics(f: &mut Frame, area: Rect, v: &ValidationState) {
    let e = &v.errors;
    let shape = match &v.latest {
        Some(l) => {
            let ok = l.prediction.shape == l.label.shape;
            Line::from(vec![
                Span::raw("shape: "),
                Span::styled(
                    format!(
                        "{} {:.0} %",
                        l.prediction.shape,
                        100.0 * l.prediction.confidence()
                    ),
                    Style::new().fg(if ok { GOOD } else { BAD }),
                ),
                Span::raw(format!("   (measured: {})", l.label.shape)),
            ])
        }
        None => Line::from("shape: -"),
    };
    let skipped_style = if v.skipped == 0 {
        Style::new()
    } else {
        Style::new().fg(WARN)
    };
    let text = vec![
        Line::from(format!(
            "Fz RMSE {:>6.3} N   contact RMSE {:>6.2} mm   shape accuracy {:>5.1} %",
            nan_dash(e.fz_rmse()),
            nan_dash(e.contact_rmse()),
            100.0 * nan_dash(e.accuracy())
        )),
        Line::from(format!("over {} frames ({} in contact)", e.n, e.n_contact)),
        shape,
        Line::from(format!(
            "{:.1} predictions/s · {:.1} ms/frame · waited {:.0} ms ({} waiting)",
            v.loop_hz, v.latency_ms, v.waited_ms, v.waiting
        )),
        Line::from(vec![
            Span::raw(format!("{} of {} run · ", v.ran, v.offered)),
            Span::styled(format!("{} skipped", v.skipped), skipped_style),
            Span::raw(if v.cut > 0 {
                format!(" · {} cut with interrupted points", v.cut)
            } else {
                String::new()
            }),
        ]),
        match (&v.failure, &v.behind) {
            (Some(why), _) => Line::styled(why.clone(), Style::new().fg(BAD)),
            (None, Some(behind)) => Line::styled(behind.clone(), Style::new().fg(WARN)),
            (None, None) => Line::from(""),
        },
    ];
    // The backend always shown; a long model description cut to what fits.
    let backend = v.backend.to_string();
    let room = area.width.saturating_sub(backend.chars().count() as u16 + 7);
    let title = format!("{} · {backend}", shortened(&v.model, room));
    f.render_widget(
        Paragraph::new(text)
            .wrap(Wrap { trim: false })
            .block(panel(&title)),
        area,
    );
}

fn nan_dash(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

fn draw_fz(f: &mut Frame, area: Rect, v: &ValidationState) {
    let measured: Vec<(f64, f64)> = v.history.iter().map(|p| (p.t_s, p.measured_n)).collect();
    let predicted: Vec<(f64, f64)> = v.history.iter().map(|p| (p.t_s, p.predicted_n)).collect();
    time_chart::draw(
        f,
        area,
        "|Fz|, N",
        &[
            Series {
                name: "measured",
                color: MEASURED,
                points: &measured,
            },
            Series {
                name: "predicted",
                color: PREDICTED,
                points: &predicted,
            },
        ],
    );
}

fn draw_contact(f: &mut Frame, area: Rect, v: &ValidationState, disc_radius_mm: Option<f64>) {
    let (measured, predicted) = match &v.latest {
        Some(l) => (
            l.label
                .contact
                .map(|c| (c[0], c[1]))
                .into_iter()
                .collect::<Vec<_>>(),
            vec![(
                l.prediction.contact_raw[0].value(),
                l.prediction.contact_raw[1].value(),
            )],
        ),
        None => (Vec::new(), Vec::new()),
    };
    let radius = disc_radius_mm.unwrap_or(25.0);
    f.render_widget(
        canvas(
            legend_panel(
                "contact, mm",
                &[("× measured", MEASURED), ("+ predicted", PREDICTED)],
            ),
            (0.0, 0.0),
            radius,
            true,
            vec![
                Layer {
                    coords: &measured,
                    color: MEASURED,
                    path: false,
                    glyph: Glyph::Symbol("×"),
                },
                Layer {
                    coords: &predicted,
                    color: PREDICTED,
                    path: false,
                    glyph: Glyph::Symbol("+"),
                },
            ],
            aspect(area),
        ),
        area,
    );
}

/// Fz RMSE by grid cell, one coloured square per cell laid out as the grid is.
fn draw_cells(f: &mut Frame, area: Rect, v: &ValidationState) {
    let block = panel("Fz RMSE by grid cell (green < 0.5 N, yellow < 1.5 N, red above)");
    let inner = block.inner(area);
    f.render_widget(block, area);
    if v.cells.is_empty() {
        f.render_widget(Paragraph::new("no grid cell scored yet"), inner);
        return;
    }
    let mut xs: Vec<f64> = v.cells.iter().map(|c| c.stage_mm[0]).collect();
    let mut ys: Vec<f64> = v.cells.iter().map(|c| c.stage_mm[1]).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    ys.sort_by(f64::total_cmp);
    ys.dedup();
    let cell_w = 7u16;
    for c in &v.cells {
        let (Some(i), Some(j)) = (
            xs.iter().position(|x| *x == c.stage_mm[0]),
            ys.iter().rev().position(|y| *y == c.stage_mm[1]),
        ) else {
            continue;
        };
        let x = inner.x + i as u16 * cell_w;
        let y = inner.y + j as u16;
        if x + cell_w > inner.right() || y >= inner.bottom() {
            continue;
        }
        let rmse = c.errors.fz_rmse();
        let colour = if rmse < 0.5 {
            GOOD
        } else if rmse < 1.5 {
            WARN
        } else {
            BAD
        };
        f.render_widget(
            Paragraph::new(format!("{rmse:>5.2} ")).style(Style::new().fg(Color::Reset).bg(colour)),
            Rect::new(x, y, cell_w - 1, 1),
        );
    }
}
