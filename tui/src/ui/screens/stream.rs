//! The Stream screen: the unit off the bench, as `fringe stream` runs it (the camera and the
//! unit's model, nothing else), started and stopped here. It shows the newest prediction
//! (every force, the contact point on the disc, the shape with its probabilities), the rate and
//! the frames skipped, the latency by stage, what is published where, the predicted Fz over the
//! last seconds (on the simulated bench beside the simulator's truth, with the errors so far),
//! the unit's health figures and what the stream said. A running stream goes on whichever
//! screen is shown, and holds the camera: scans and the bench wait for it.

use crate::ui::app::App;
use crate::ui::binding::{self, char, Binding, HelpRow, Scope};
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::state::{StreamView, Tab};
use crate::ui::streaming;
use crate::ui::view::shortened;
use crate::ui::widgets::disc::{aspect, canvas, Glyph, Layer};
use crate::ui::widgets::time_chart::{self, Series};
use crate::ui::widgets::{panel, legend_panel, BAD, GOOD, MEASURED, PREDICTED, WARN};
use fringe_app::stream::{LatencyFigures, Stage, Stream, StreamState, TOPICS};
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;
use std::time::{Duration, Instant};

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("stream");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Stream",
    help,
    draw: |f, area, s| draw(f, area, &s.stream, s.scan.disc_radius_mm),
    hint: |s| {
        if s.stream.running {
            "s stop the stream"
        } else {
            "s stream · m stream and record to MCAP"
        }
    },
    open: |_| Box::new(Streamer::default()),
};

/// How often the screen reads the running stream's state.
const READ_EVERY: Duration = Duration::from_millis(100);

#[derive(Debug, Clone, Copy)]
enum Action {
    StartOrStop,
    Record,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[char('s')],
        scope: Scope::Shown,
        action: Action::StartOrStop,
        label: "s",
        help: "start or stop the stream (the camera and the model, over ROS 2)",
    },
    Binding {
        keys: &[char('m')],
        scope: Scope::Shown,
        action: Action::Record,
        label: "m",
        help: "start the stream, recording it to streams/*.mcap",
    },
];

fn help() -> Vec<HelpRow> {
    binding::help_rows(KEYS, Some(SCREEN.title))
}

/// Starts and stops the stream (the [`App`] holds it) and reads its state.
#[derive(Default)]
struct Streamer {
    /// When the state was last read.
    read: Option<Instant>,
    /// Warnings already put in the log.
    said: usize,
    /// Whether Zenoh was connected when last read.
    connected: Option<bool>,
}

impl Streamer {
    fn start(&mut self, app: &mut App, record: bool) {
        if app.scan_active() {
            app.state.error =
                Some("a scan holds the camera: start the stream when it ends".into());
            return;
        }
        // The bench screen's session holds the camera too.
        app.close_bench();
        let mcap = record.then(|| streaming::recording_path(&app.opts.runs));
        let mut said = Vec::new();
        let request = streaming::request(
            &app.opts.config,
            app.opts.model.as_ref(),
            app.opts.model_from_rig,
            mcap,
            &mut |line| said.push(line),
        );
        let view = &mut app.state.stream;
        for line in said {
            view.log(line);
        }
        let request = match request {
            Ok(r) => r,
            Err(e) => {
                view.log(format!("cannot stream: {e}"));
                app.state.error = Some(e);
                return;
            }
        };
        view.model = format!("{} ({})", request.model.path.display(), request.model.describe());
        view.node = request.ros2.describe();
        match Stream::start(request) {
            Ok((stream, notes)) => {
                view.log("stream started");
                for n in notes {
                    view.log(n);
                }
                view.state = Some(stream.state());
                view.running = true;
                app.stream = Some(stream);
                *self = Streamer::default();
            }
            Err(e) => {
                view.log(format!("cannot stream: {e}"));
                app.state.error = Some(format!("cannot stream: {e}"));
            }
        }
    }

    /// Takes the stream's state: its new warnings and connection changes into the log; a
    /// stream that stopped by itself is finished.
    fn read(&mut self, app: &mut App) {
        let Some(stream) = &app.stream else {
            return;
        };
        let state = stream.state();
        let view = &mut app.state.stream;
        for w in state.warnings.iter().skip(self.said) {
            view.log(format!("warning: {w}"));
        }
        self.said = state.warnings.len();
        if state.connected != self.connected {
            match (self.connected, state.connected) {
                (_, Some(true)) => view.log("Zenoh: connected"),
                (Some(true), Some(false)) => {
                    view.log("Zenoh: disconnected; publishing goes on, reconnecting")
                }
                (None, Some(false)) => view.log(
                    "Zenoh: no router or peer yet at the endpoints; publishing anyway, connecting in the background",
                ),
                _ => {}
            }
            self.connected = state.connected;
        }
        let failure = state.failure.clone();
        view.state = Some(state);
        if let Some(why) = failure {
            view.log(format!("the stream stopped: {why}"));
            app.state.error = Some(format!("the stream stopped: {why}"));
            app.stop_stream();
        }
    }
}

impl Screen for Streamer {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        let Some(action) = binding::find(KEYS, code, mods, shown) else {
            return false;
        };
        match (action, app.stream.is_some()) {
            (Action::StartOrStop, true) => {
                self.read(app);
                app.stop_stream();
            }
            (Action::StartOrStop, false) => self.start(app, false),
            (Action::Record, false) => self.start(app, true),
            (Action::Record, true) => {
                app.state.error =
                    Some("a stream is running: stop it (s), then m starts one that records".into())
            }
        }
        true
    }

    fn tick(&mut self, app: &mut App, shown: bool) -> bool {
        let held = app
            .scan_active()
            .then(|| "a scan holds the camera: the stream can start when it ends".to_string());
        let changed = held != app.state.stream.held;
        app.state.stream.held = held;
        if app.stream.is_none() || self.read.is_some_and(|t| t.elapsed() < READ_EVERY) {
            return changed;
        }
        self.read = Some(Instant::now());
        self.read(app);
        changed || shown
    }
}

fn draw(f: &mut Frame, area: Rect, v: &StreamView, disc_radius_mm: Option<f64>) {
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(42), Constraint::Percentage(58)]).areas(area);
    let [prediction_area, contact_area] =
        Layout::vertical([Constraint::Length(14), Constraint::Min(0)]).areas(left);
    let [stream_area, published_area, chart_area, log_area] = Layout::vertical([
        Constraint::Length(9),
        Constraint::Length(7),
        Constraint::Min(6),
        Constraint::Length(10),
    ])
    .areas(right);
    draw_prediction(f, prediction_area, v);
    draw_contact(f, contact_area, v, disc_radius_mm);
    draw_stream(f, stream_area, v);
    draw_published(f, published_area, v);
    draw_fz(f, chart_area, v);
    draw_log(f, log_area, v);
}

/// The newest prediction: every force, the contact, the shape with its probabilities.
fn draw_prediction(f: &mut Frame, area: Rect, v: &StreamView) {
    let block = panel("prediction");
    let latest = v.state.as_ref().and_then(|s| s.latest.as_ref());
    let Some(p) = latest else {
        let mut text = vec![Line::from(if v.running {
            "waiting for the first frame"
        } else {
            "s streams: the camera and the unit's model only, no stages or F/T sensor; each frame's force, contact and shape are published as ROS 2 messages over Zenoh"
        })];
        if !v.running {
            text.push(Line::from(""));
            text.push(Line::from(
                "m streams and records the messages to an MCAP file in streams/ (Foxglove, rosbags and mcap open it)",
            ));
        }
        if let Some(h) = &v.held {
            text.push(Line::from(""));
            text.push(Line::styled(h.clone(), Style::new().fg(WARN)));
        }
        f.render_widget(
            Paragraph::new(text).wrap(Wrap { trim: true }).block(block),
            area,
        );
        return;
    };
    let fz = p.force.fz.value();
    let mut text = vec![
        Line::from(vec![
            Span::raw("Fz "),
            Span::styled(
                format!("{fz:+7.3} N"),
                Style::new().fg(PREDICTED).add_modifier(Modifier::BOLD),
            ),
            Span::raw(format!("   |F| {:6.3} N", p.force.ft.value())),
        ]),
        Line::from(format!(
            "Fx {:+7.3} N   Fy {:+7.3} N",
            p.force.fx.value(),
            p.force.fy.value()
        )),
        Line::from(format!(
            "Mx {:+7.4} N·m   My {:+7.4} N·m   Mz {:+7.4} N·m",
            p.force.mx.value(),
            p.force.my.value(),
            p.force.mz.value()
        )),
        match p.contact {
            Some([x, y]) => Line::from(vec![
                Span::styled("in contact", Style::new().fg(GOOD)),
                Span::raw(format!(" at ({:+.2}, {:+.2}) mm", x.value(), y.value())),
            ]),
            None => Line::from("no contact"),
        },
        Line::from(""),
    ];
    // Each class with its probability as a bar, the predicted one bold.
    let name_width = p
        .probabilities
        .iter()
        .map(|(n, _)| n.chars().count())
        .max()
        .unwrap_or(0);
    let bar_room = usize::from(area.width.saturating_sub(2))
        .saturating_sub(name_width + 8)
        .min(30);
    for (name, prob) in &p.probabilities {
        let filled = (prob.clamp(0.0, 1.0) * bar_room as f64).round() as usize;
        let style = if *name == p.shape {
            Style::new().fg(PREDICTED).add_modifier(Modifier::BOLD)
        } else {
            Style::new()
        };
        text.push(Line::from(vec![
            Span::styled(format!("{name:<name_width$} {:>3.0} % ", 100.0 * prob), style),
            Span::styled("█".repeat(filled), Style::new().fg(PREDICTED)),
        ]));
    }
    f.render_widget(Paragraph::new(text).block(block), area);
}

fn draw_contact(f: &mut Frame, area: Rect, v: &StreamView, disc_radius_mm: Option<f64>) {
    let predicted: Vec<(f64, f64)> = v
        .state
        .as_ref()
        .and_then(|s| s.latest.as_ref())
        .and_then(|p| p.contact)
        .map(|[x, y]| (x.value(), y.value()))
        .into_iter()
        .collect();
    f.render_widget(
        canvas(
            legend_panel("contact, mm", &[("+ predicted", PREDICTED)]),
            (0.0, 0.0),
            disc_radius_mm.unwrap_or(25.0),
            true,
            vec![Layer {
                coords: &predicted,
                color: PREDICTED,
                path: false,
                glyph: Glyph::Symbol("+"),
            }],
            aspect(area),
        ),
        area,
    );
}

/// The frames, the rate, the latency by stage, the model and the camera.
fn draw_stream(f: &mut Frame, area: Rect, v: &StreamView) {
    let title = if v.running { "streaming" } else { "stream" };
    let Some(s) = &v.state else {
        let text = vec![
            Line::from(format!("model: {}", v.model)),
            Line::from(v.node.clone()),
        ];
        f.render_widget(
            Paragraph::new(text)
                .wrap(Wrap { trim: true })
                .block(panel(title)),
            area,
        );
        return;
    };
    let skipped_style = if s.skipped == 0 {
        Style::new()
    } else {
        Style::new().fg(WARN)
    };
    let mut text = vec![
        Line::from(vec![
            Span::raw(format!(
                "{:.0} s · {:.0} frames/s · {} of {} frames run · ",
                s.elapsed_s, s.rate_hz, s.ran, s.frames
            )),
            Span::styled(format!("{} skipped", s.skipped), skipped_style),
            Span::raw(format!(" · {} lost by the camera", s.dropped_by_camera)),
        ]),
        Line::from(format!(
            "latency, exposure end to published: {}{}",
            s.latest_latency_ms
                .map_or("-".to_string(), |l| format!("{l:.1} ms now")),
            s.recent_latency.as_ref().map_or(String::new(), |l| format!(
                " · last {} frames p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms",
                l.frames, l.p50_ms, l.p99_ms, l.max_ms
            ))
        )),
    ];
    if let Some(l) = &s.recent_latency {
        text.push(stages_line(l));
    }
    let room = area.width.saturating_sub(10);
    text.push(Line::from(format!(
        "model: {}",
        shortened(&format!("{} · {}", s.model, s.backend), room)
    )));
    text.push(Line::from(format!(
        "camera: {}",
        shortened(&format!("{} · sensor {}", s.camera, s.sensor), room)
    )));
    f.render_widget(
        Paragraph::new(text)
            .wrap(Wrap { trim: false })
            .block(panel(title)),
        area,
    );
}

/// Each stage's median, the one that dominates marked.
fn stages_line(l: &LatencyFigures) -> Line<'static> {
    let dominant = l.dominant();
    let mut spans = vec![Span::raw("p50 by stage: ")];
    for (i, (stage, p50)) in Stage::ALL.iter().zip(l.stage_p50_ms).enumerate() {
        if i > 0 {
            spans.push(Span::raw(" · "));
        }
        let text = format!("{} {p50:.1} ms", stage.name());
        spans.push(if *stage == dominant {
            Span::styled(text, Style::new().add_modifier(Modifier::BOLD))
        } else {
            Span::raw(text)
        });
    }
    Line::from(spans)
}

/// What goes out where: the node and its connection, each topic's count, the recording.
fn draw_published(f: &mut Frame, area: Rect, v: &StreamView) {
    let block = panel("published");
    let Some(s) = &v.state else {
        f.render_widget(
            Paragraph::new("nothing yet: no stream has run")
                .wrap(Wrap { trim: true })
                .block(block),
            area,
        );
        return;
    };
    let mut text = Vec::new();
    match (&s.namespace, s.connected) {
        (Some(_), connected) => text.push(Line::from(vec![
            Span::raw(format!("{} · ", v.node)),
            match connected {
                Some(true) => Span::styled("connected", Style::new().fg(GOOD)),
                _ => Span::styled(
                    "no router or peer yet: publishing, connecting in the background",
                    Style::new().fg(WARN),
                ),
            },
        ])),
        (None, _) => text.push(Line::from("not publishing over ROS 2")),
    }
    if let Some(ns) = &s.namespace {
        let ns = ns.trim_end_matches('/');
        let p = &s.published;
        let counts = [p.wrench, p.contact, p.shape, p.image];
        let topics: Vec<String> = TOPICS
            .iter()
            .zip(counts)
            .map(|((topic, _), n)| format!("{ns}/{topic} {n}"))
            .collect();
        text.push(Line::from(topics.join(" · ")));
        if p.failed > 0 {
            text.push(Line::styled(
                format!("{} messages refused by Zenoh (see the log)", p.failed),
                Style::new().fg(BAD),
            ));
        }
    }
    text.push(Line::from(match &s.mcap {
        Some(m) => format!("recording to {}", m.display()),
        None => "not recording (m starts a stream that records to MCAP)".into(),
    }));
    f.render_widget(
        Paragraph::new(text).wrap(Wrap { trim: false }).block(block),
        area,
    );
}

fn draw_fz(f: &mut Frame, area: Rect, v: &StreamView) {
    let (predicted, truth) = match &v.state {
        Some(s) => (
            s.fz_history.iter().copied().collect::<Vec<_>>(),
            s.true_fz.iter().copied().collect::<Vec<_>>(),
        ),
        None => (Vec::new(), Vec::new()),
    };
    let mut series = vec![Series {
        name: "predicted",
        color: PREDICTED,
        points: &predicted,
    }];
    if !truth.is_empty() {
        series.insert(
            0,
            Series {
                name: "simulator's truth",
                color: MEASURED,
                points: &truth,
            },
        );
    }
    time_chart::draw(f, area, "Fz, N", &series);
}

/// The errors against the truth, the unit's health, then what the stream said, newest last.
fn draw_log(f: &mut Frame, area: Rect, v: &StreamView) {
    let mut text = Vec::new();
    if let Some(s) = &v.state {
        text.extend(truth_line(s));
        if let Some(h) = &s.health {
            text.push(Line::from(format!(
                "health at {:.0} s on free frames: optical centre ({:+.2}, {:+.2}) px from the profile (limit {:.2}) · brightness {:.1} % of the start · Fz {:+.3} N",
                h.at_s,
                h.centre_shift_px[0],
                h.centre_shift_px[1],
                h.centre_limit_px,
                100.0 * h.brightness_ratio,
                h.free_fz_n
            )));
        }
    }
    // The newest messages that fit below, each as many rows as it wraps to.
    let width = usize::from(area.width.saturating_sub(2)).max(1);
    let rows = |line: &str| line.chars().count().div_ceil(width).max(1);
    let mut room = usize::from(area.height.saturating_sub(2))
        .saturating_sub(text.iter().map(|l| rows(&l.to_string())).sum());
    let mut shown = 0;
    for line in v.log.iter().rev() {
        match room.checked_sub(rows(line)) {
            Some(left) => {
                room = left;
                shown += 1;
            }
            None => break,
        }
    }
    for line in v.log.iter().skip(v.log.len() - shown) {
        let style = if line.starts_with("warning") || line.starts_with("the stream stopped") {
            Style::new().fg(WARN)
        } else {
            Style::new()
        };
        text.push(Line::styled(line.clone(), style));
    }
    f.render_widget(
        Paragraph::new(text)
            .wrap(Wrap { trim: false })
            .block(panel("truth, health and messages")),
        area,
    );
}

/// On the simulated bench: the frames scored against the simulator's truth so far.
fn truth_line(s: &StreamState) -> Option<Line<'static>> {
    let (n, e) = s.truth.as_ref()?;
    let presses = s
        .robot_presses
        .map_or(String::new(), |p| format!(" · the robot's presses {p}"));
    Some(if e.n == 0 {
        Line::from(format!("against the simulator's truth: no frame scored yet{presses}"))
    } else {
        Line::from(format!(
            "against the simulator's truth ({n} frames, {} in contact): Fz RMSE {:.3} N · contact RMSE {:.2} mm · shape {:.1} %{presses}",
            e.n_contact,
            e.fz_rmse(),
            e.contact_rmse(),
            100.0 * e.accuracy()
        ))
    })
}
