//! Lines over time (force labels on Scan, measured against predicted |Fz| on Validate): the time
//! axis spans the data, the value axis runs from 0 (or the lowest value) to at least 1, and the
//! panel's title names each line in its colour instead of a legend box over the data.

use super::legend_panel;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::widgets::{Axis, Chart, Dataset, GraphType};
use ratatui::Frame;

/// One line: its name, colour and (t s, value) points in time order.
pub(crate) struct Series<'a> {
    pub name: &'a str,
    pub color: Color,
    pub points: &'a [(f64, f64)],
}

pub(crate) fn draw(f: &mut Frame, area: Rect, title: &str, series: &[Series<'_>]) {
    let first = series.first().map_or(&[][..], |s| s.points);
    let (t0, t1) = match (first.first(), first.last()) {
        (Some(a), Some(b)) if b.0 > a.0 => (a.0, b.0),
        (Some(a), _) => (a.0, a.0 + 1.0),
        _ => (0.0, 1.0),
    };
    let values = || series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let top = values().fold(1.0f64, f64::max).ceil();
    let bottom = values().fold(0.0f64, f64::min).floor();
    let names: Vec<(&str, Color)> = series.iter().map(|s| (s.name, s.color)).collect();
    let chart = Chart::new(
        series
            .iter()
            .map(|s| {
                Dataset::default()
                    .name(s.name)
                    .marker(Marker::Braille)
                    .graph_type(GraphType::Line)
                    .style(Style::new().fg(s.color))
                    .data(s.points)
            })
            .collect(),
    )
    .legend_position(None)
    .block(legend_panel(title, &names))
    .x_axis(
        Axis::default()
            .bounds([t0, t1])
            .labels([format!("{t0:.0} s"), format!("{t1:.0} s")]),
    )
    .y_axis(
        Axis::default()
            .bounds([bottom, top])
            .labels([format!("{bottom:.0}"), format!("{top:.0}")]),
    );
    f.render_widget(chart, area);
}
