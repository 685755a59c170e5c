//! The screens drawn from hand-built states on a test terminal: the text as the user would see
//! it (insta snapshots under `snapshots/`) and the colours that carry meaning.

use super::draw;
use crate::ui::keys;
use crate::ui::screens;
use crate::ui::state::{
    BenchView, CalibrateView, CalibrationPhase, CommissionPhase, CommissionView, Dialog,
    HealthView, Phase, Picker, PlanPoint, PressRow, RunRow, RunsView, ScanView, StreamView,
    UiState, UnitsView,
};
use crate::ui::widgets;
use fringe_app::session::{
    AxisId, AxisState, BenchPhase, BenchState, CameraState, ForcePoint, ForceState,
};
use fringe_app::session::{CellErrors, FzPoint, Latest, ValidationState};
use fringe_app::session::{LabelPoint, ViewState};
use fringe_app::stream::{LatencyFigures, Published, StreamHealth, StreamState};
use fringe_rig::Millimetres;
use fringe_sensor_models::dataset::Sample;
use fringe_sensor_models::Errors;
use fringe_sensor_models::{ForceVector, Prediction};
use ratatui::backend::TestBackend;
use ratatui::buffer::Buffer;
use ratatui::style::{Color, Modifier};
use ratatui::Terminal;
use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::Duration;

fn render(s: &UiState, w: u16, h: u16) -> Terminal<TestBackend> {
    let mut t = Terminal::new(TestBackend::new(w, h)).expect("test backend");
    t.draw(|f| draw(f, s)).expect("draw");
    t
}

/// The screen's rows as text.
fn rows(b: &Buffer) -> Vec<String> {
    (0..b.area.height)
        .map(|y| {
            (0..b.area.width)
                .map(|x| b[(x, y)].symbol())
                .collect::<String>()
        })
        .collect()
}

/// Where `text` starts on screen (first match).
fn find(b: &Buffer, text: &str) -> Option<(u16, u16)> {
    rows(b).iter().enumerate().find_map(|(y, row)| {
        row.find(text).map(|byte| {
            // Column: characters before the match (cells hold one char each here).
            let x = row[..byte].chars().count();
            (x as u16, y as u16)
        })
    })
}

fn grid() -> Vec<PlanPoint> {
    let mut v = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            v.push(PlanPoint {
                x_mm: 100.0 + 4.0 * (i as f64 - 1.0),
                y_mm: 50.0 + 4.0 * (j as f64 - 1.0),
            });
        }
    }
    v
}

fn ready() -> UiState {
    UiState {
        tab: screens::scan::TAB,
        help: false,
        rig: "simulated bench (no rig configured)".into(),
        scan_whole_disc: false,
        scan: ScanView {
            plan: "short-grid".into(),
            points: grid(),
            origin_mm: (100.0, 50.0),
            disc_radius_mm: Some(12.5),
            targets: "2, 5 N".into(),
            estimate: Duration::from_secs(95),
            // Its presses filmed in whole 1920x1200 BayerRG8 frames at 50 fps.
            expected_bytes: Some(2_420_000_000),
            phase: Phase::Ready,
            done: 0,
            total: 9,
            eta: Duration::from_secs(95),
            force_n: 0.0,
            frame_rate_hz: 0.0,
            frames: 0,
            dropped: 0,
            current: None,
            log: VecDeque::new(),
            live: ViewState::default(),
            run_dir: None,
        },
        model: None,
        validation: None,
        runs: RunsView {
            root: "runs".into(),
            model: "builtin:layered".into(),
            ..RunsView::default()
        },
        bench: BenchView::default(),
        stream: StreamView::default(),
        calibrate: CalibrateView {
            sensor: "layered-1".into(),
            plan: "built-in calibration grid: 9 light presses".into(),
            profile: "profiles/layered-1.toml".into(),
            phase: CalibrationPhase::Ready,
            fit: Vec::new(),
            registration: String::new(),
            presses: Vec::new(),
            offsets: Vec::new(),
            picture: None,
        },
        commission: CommissionView::default(),
        health: HealthView::default(),
        units: UnitsView::default(),
        dialog: None,
        picker: None,
        error: None,
    }
}

/// The Bench screen after a jog of z that hit the force ceiling, with x not homed.
fn on_bench() -> UiState {
    let mut s = ready();
    s.tab = screens::bench::TAB;
    let axis = |p: f64, homed: bool, moving: bool, limits: (f64, f64)| AxisState {
        endpoint: "simulated".into(),
        position_mm: Some(p),
        homed,
        moving,
        limits_mm: limits,
        faults: Vec::new(),
        manual: false,
    };
    let mut x = axis(100.0, false, false, (0.0, 150.0));
    x.faults = vec!["forward limit switch".into()];
    s.bench = BenchView {
        bench: BenchState {
            phase: BenchPhase::Ready,
            devices: vec!["simulated x".into()],
            axes: [
                x,
                axis(50.0, true, false, (0.0, 100.0)),
                axis(11.2345, true, true, (0.0, 13.0)),
            ],
            force: ForceState {
                device: "simulated Net F/T".into(),
                fz_n: -15.6,
                f_n: 15.7,
                rate_hz: 5000.0,
                received: 50_000,
                lost: 3,
                restarts: 0,
                max_n: 15.0,
                peak_n: 15.9,
            },
            camera: CameraState {
                device: "simulated camera".into(),
                fps: 25.0,
                frames: 250,
                dropped: 0,
                frame_id: 251,
            },
            picture: Some(picture()),
            chart: (0..40)
                .map(|i| ForcePoint {
                    t_s: i as f64 * 0.1,
                    fz_n: -(i as f64) * 0.4,
                    f_n: i as f64 * 0.4,
                })
                .collect(),
            messages: [
                "bench open: jog, home and tare from here; a scan takes the devices over",
                "z: moving by +0.100 mm",
                "force 15.70 N over the ceiling 15.00 N: z stopped; moves into or across the sensor are refused until it is under; retract z (←, or h)",
            ]
            .map(String::from)
            .into(),
        },
        axis: AxisId::Z,
        step: 1,
        held: None,
    };
    s
}

/// A 4x4 picture: left half red, right half blue.
fn picture() -> image::RgbImage {
    image::RgbImage::from_fn(4, 4, |x, _| {
        if x < 2 {
            image::Rgb([200, 0, 0])
        } else {
            image::Rgb([0, 0, 200])
        }
    })
}

fn running() -> UiState {
    let mut s = ready();
    let v = &mut s.scan;
    v.phase = Phase::Running;
    v.done = 4;
    v.current = Some((4, "press 5.0 N".into()));
    v.eta = Duration::from_secs(61);
    v.force_n = 4.87;
    v.frame_rate_hz = 50.0;
    v.frames = 812;
    v.dropped = 1;
    v.run_dir = Some("runs/20261125-short-grid".into());
    v.log("starting short-grid");
    v.log("warning: no calibration profile: design geometry used");
    v.live.picture = Some(picture());
    v.live.labels = (0..50)
        .map(|i| LabelPoint {
            t_s: i as f64 * 0.1,
            fz_n: (i as f64 * 0.1).min(5.0),
            f_n: (i as f64 * 0.1).min(5.0) + 0.1,
        })
        .collect();
    s
}

fn prediction(fz: f64, shape: &str, p: f64, at: [f64; 2]) -> Prediction {
    Prediction {
        force: ForceVector::from_array([0.1, 0.1, fz as f32, 0.0, 0.0, 0.0, fz as f32]),
        shape: shape.into(),
        probabilities: vec![("None".into(), 1.0 - p), (shape.into(), p)],
        contact: Some([Millimetres(at[0]), Millimetres(at[1])]),
        contact_raw: [Millimetres(at[0]), Millimetres(at[1])],
        shear: None,
        slip: None,
    }
}

fn errors(n: u64, rmse: f64) -> Errors {
    Errors {
        n,
        sum_sq_fz: rmse * rmse * n as f64,
        n_contact: n,
        sum_sq_contact: 0.25 * n as f64,
        correct: n - 1,
        ..Errors::default()
    }
}

fn validating() -> UiState {
    let mut s = running();
    s.tab = screens::validate::TAB;
    s.model = Some("models/disc7.pth".into());
    let label = Sample {
        image: PathBuf::from("frames/000812.png"),
        storage: None,
        force: [0.1, 0.1, 4.9, 0.0, 0.0, 0.0, 4.9],
        shape: "sphere".into(),
        contact: Some([2.0, -1.0]),
        shear: None,
        slip: None,
        press: "run/4".into(),
        stage_mm: Some([104.0, 50.0]),
    };
    s.validation = Some(ValidationState {
        model: "ResNet-18 (4 classes)".into(),
        backend: "tract",
        offered: 300,
        ran: 280,
        skipped: 20,
        cut: 0,
        loop_hz: 46.5,
        latency_ms: 18.2,
        waited_ms: 31.0,
        waiting: 2,
        backlog: 10,
        history: (0..40)
            .map(|i| FzPoint {
                t_s: i as f64 * 0.1,
                measured_n: (i as f64 * 0.15).min(5.0),
                predicted_n: (i as f64 * 0.15).min(5.0) * 0.9,
            })
            .collect(),
        latest: Some(Latest {
            prediction: prediction(4.4, "cylinder", 0.62, [2.5, -1.2]),
            label,
            frame: picture(),
            input: picture(),
        }),
        errors: errors(280, 0.42),
        cells: vec![
            CellErrors {
                stage_mm: [96.0, 50.0],
                errors: errors(90, 0.3),
            },
            CellErrors {
                stage_mm: [100.0, 50.0],
                errors: errors(90, 1.0),
            },
            CellErrors {
                stage_mm: [104.0, 50.0],
                errors: errors(100, 2.2),
            },
        ],
        failure: None,
        behind: None,
    });
    s
}

#[test]
fn scan_screen_before_the_run_shows_the_plan_and_how_to_start() {
    let t = render(&ready(), 120, 36);
    insta::assert_snapshot!("scan_ready", t.backend());
    let b = t.backend().buffer();
    let (x, y) = find(b, "ready: press r to run").expect("phase line");
    assert_eq!(b[(x, y)].fg, widgets::ACCENT);
    assert!(find(b, "short-grid: 9 points").is_some());
    assert!(find(b, "9 points to 2, 5 N, about 0:01:35").is_some());
    assert!(
        find(b, "r run the scan").is_some(),
        "the footer says how to run"
    );
}

/// Columns of the plan's point numbers `1`, `2`, `3` on one row of the Scan screen's plan
/// panel (the left 40 %).
fn first_row_numbers(b: &Buffer) -> Option<[usize; 3]> {
    let panel = (b.area.width as usize * 2) / 5;
    // Below the tab bar and the panel's title.
    (2..b.area.height).find_map(|y| {
        let cells: Vec<&str> = (0..panel).map(|x| b[(x as u16, y)].symbol()).collect();
        let at = |d: &str| cells.iter().position(|c| *c == d);
        match (at("1"), at("2"), at("3")) {
            (Some(a), Some(b), Some(c)) if a < b && b < c => Some([a, b, c]),
            _ => None,
        }
    })
}

/// A plan small on its disc (short-grid's 2 mm by 3 mm on a 25 mm disc) is drawn close up, its
/// points well apart, with the disc's centre marked; `d` shows the whole disc with its outline.
#[test]
fn a_plan_small_on_the_disc_is_drawn_close_up_and_d_shows_the_whole_disc() {
    let mut s = ready();
    s.scan.disc_radius_mm = Some(25.0);
    s.scan.points = [
        (98.0, 48.5),
        (100.0, 48.5),
        (102.0, 48.5),
        (102.0, 51.5),
        (100.0, 51.5),
        (98.0, 51.5),
    ]
    .iter()
    .map(|&(x_mm, y_mm)| PlanPoint { x_mm, y_mm })
    .collect();
    s.scan.total = 6;
    let t = render(&s, 180, 50);
    let b = t.backend().buffer();
    assert!(
        find(b, "short-grid: 6 points · ×").is_some() && find(b, "d: whole disc").is_some(),
        "{}",
        rows(b).join("\n")
    );
    let close = first_row_numbers(b).expect("points 1, 2, 3 on a row");
    assert!(
        close[1] - close[0] >= 8 && close[2] - close[1] >= 8,
        "close up, 2 mm apart: {close:?}\n{}",
        rows(b).join("\n")
    );
    s.scan_whole_disc = true;
    let t = render(&s, 180, 50);
    let b = t.backend().buffer();
    assert!(find(b, "short-grid: 6 points · d: close up").is_some());
    let whole = first_row_numbers(b).expect("points 1, 2, 3 on a row");
    assert!(
        whole[2] - whole[0] < close[2] - close[0],
        "{whole:?} {close:?}"
    );
    // The disc's outline: braille dots far from the plan, on both sides of it.
    let outline_row = rows(b)[25].clone();
    let dots: Vec<usize> = outline_row
        .chars()
        .take(72)
        .enumerate()
        .filter(|(_, c)| ('\u{2801}'..='\u{28ff}').contains(c))
        .map(|(i, _)| i)
        .collect();
    assert!(
        dots.first()
            .is_some_and(|&a| a < whole[0].saturating_sub(10))
            && dots.last().is_some_and(|&z| z > whole[2] + 10),
        "{dots:?}\n{}",
        rows(b).join("\n")
    );
}

#[test]
fn scan_screen_while_running_shows_progress_force_and_the_frame() {
    let t = render(&running(), 120, 36);
    insta::assert_snapshot!("scan_running", t.backend());
    let b = t.backend().buffer();
    assert!(find(b, "point 5 of 9: press 5.0 N").is_some());
    assert!(find(b, "force   4.87 N   ETA 0:01:01").is_some());
    assert!(find(b, "44 %").is_some(), "4 of 9 points done");
    let (x, y) = find(b, "warning: no calibration profile").expect("warning in the log");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    // The frame: half blocks, red on the left, blue on the right.
    let cells: Vec<_> = b.content().iter().filter(|c| c.symbol() == "▀").collect();
    assert!(
        cells.len() >= 8,
        "the frame is drawn ({} cells)",
        cells.len()
    );
    assert!(cells.iter().any(|c| c.fg == Color::Rgb(200, 0, 0)));
    assert!(cells.iter().any(|c| c.fg == Color::Rgb(0, 0, 200)));
}

#[test]
fn validate_screen_compares_prediction_and_measurement() {
    let t = render(&validating(), 140, 44);
    insta::assert_snapshot!("validate_running", t.backend());
    let b = t.backend().buffer();
    assert!(find(b, "Fz RMSE  0.420 N").is_some());
    assert!(find(
        b,
        "46.5 predictions/s · 18.2 ms/frame · waited 31 ms (2 waiting)"
    )
    .is_some());
    assert!(find(b, "280 of 300 run · 20 skipped").is_some());
    // Measured (x) and predicted (+) contact on the disc, in their colours.
    let (x, y) = find(b, "×").expect("measured contact");
    assert_eq!(b[(x, y)].fg, widgets::MEASURED);
    let (x, y) = find(b, "+").expect("predicted contact");
    assert_eq!(b[(x, y)].fg, widgets::PREDICTED);
    // Wrong shape: predicted cylinder for a sphere, in red with the probability.
    let (x, y) = find(b, "cylinder 62 %").expect("shape line");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    assert!(find(b, "(measured: sphere)").is_some());
    let (x, y) = find(b, "20 skipped").expect("skipped frames");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    // Grid cells coloured by their Fz RMSE.
    for (text, colour) in [
        (" 0.30", widgets::GOOD),
        (" 1.00", widgets::WARN),
        (" 2.20", widgets::BAD),
    ] {
        let (x, y) = find(b, text).unwrap_or_else(|| panic!("cell {text}"));
        assert_eq!(b[(x, y)].bg, colour, "cell {text}");
    }
}

#[test]
fn validate_screen_says_when_the_model_is_slower_than_the_camera() {
    let mut s = validating();
    let line =
        "slower than the camera: 48.0 ms a frame, 20.0 ms allowed, at least 58 % of frames skipped";
    if let Some(v) = s.validation.as_mut() {
        v.behind = Some(line.to_string());
    }
    let t = render(&s, 180, 44);
    let b = t.backend().buffer();
    let (x, y) = find(b, line).expect("the pace line");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    // A failure says more and takes its place.
    if let Some(v) = s.validation.as_mut() {
        v.failure = Some("live validation stopped: the backend failed".into());
    }
    let t = render(&s, 180, 44);
    let b = t.backend().buffer();
    assert!(find(b, "live validation stopped").is_some());
    assert!(find(b, line).is_none());
}

#[test]
fn validate_screen_without_a_model_says_how_to_choose_one() {
    let mut s = ready();
    s.tab = screens::validate::TAB;
    let t = render(&s, 100, 20);
    let b = t.backend().buffer();
    assert!(find(b, "fringe validate --model FILE").is_some());
    s.model = Some("m.pth".into());
    let t = render(&s, 100, 20);
    assert!(find(
        t.backend().buffer(),
        "press r to run the scan plan with live"
    )
    .is_some());
}

#[test]
fn a_dialog_is_drawn_over_the_screen_with_its_answers() {
    let mut s = running();
    s.dialog = Some(Dialog {
        title: "change the indenter".into(),
        message: "mount the cylinder indenter, then continue".into(),
    });
    let t = render(&s, 120, 36);
    insta::assert_snapshot!("dialog", t.backend());
    let b = t.backend().buffer();
    let (x, y) = find(b, "change the indenter").expect("dialog title");
    // The border around the title is in the warning colour.
    assert_eq!(b[(x - 2, y)].fg, widgets::WARN);
    assert!(find(b, "continue").is_some() && find(b, "abort the scan").is_some());
}

#[test]
fn an_error_replaces_the_key_hints_in_red() {
    let mut s = running();
    s.error = Some("a scan is running: press a to abort it first".into());
    let t = render(&s, 120, 36);
    let b = t.backend().buffer();
    let (x, y) = find(b, "a scan is running").expect("error line");
    assert_eq!(y, 35, "on the last row");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    assert!(find(b, "next screen").is_none());
}

#[test]
fn runs_screen_lists_runs_with_status_and_verdict() {
    let mut s = ready();
    s.tab = screens::runs::TAB;
    s.runs.rows = vec![
        RunRow {
            name: "20261125-083000-short-grid".into(),
            status: "completed".into(),
            frames: 2310,
            bytes: Some(2_470_000_000),
            verified: Some("ok: 2310 frames, 115500 force samples".into()),
            evaluated: Some("Fz 0.465 N · contact 0.97 mm · shape 99.9 %".into()),
            exported: Some("exported 2310 images to exports/20261125-083000-short-grid".into()),
        },
        RunRow {
            name: "20261124-170000-short-grid".into(),
            status: "aborted".into(),
            frames: 120,
            bytes: Some(131_500_000),
            verified: Some("1 problem(s): frames.jsonl: line 121 truncated".into()),
            evaluated: Some("cannot evaluate: frames.jsonl: line 121".into()),
            exported: Some("cannot export: it fails verify".into()),
        },
        RunRow {
            name: "20261124-160000-wide".into(),
            status: "unfinished".into(),
            frames: 5,
            bytes: None,
            verified: None,
            evaluated: Some("evaluating: 300 of 1672 frames".into()),
            exported: None,
        },
    ];
    s.runs.selected = 1;
    let t = render(&s, 170, 12);
    insta::assert_snapshot!("runs", t.backend());
    let b = t.backend().buffer();
    let (x, y) = find(b, "ok: 2310 frames").expect("verdict");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    let (x, y) = find(b, "1 problem(s)").expect("verdict");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    let (x, y) = find(b, "20261124-170000").expect("selected row");
    assert!(b[(x, y)].modifier.contains(Modifier::REVERSED));
    let (x, y) = find(b, "unfinished").expect("status");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    let (x, y) = find(b, "cannot evaluate").expect("evaluation error");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    assert!(find(b, "Fz 0.465 N").is_some(), "evaluation figures");
    assert!(find(b, "2.5 GB").is_some(), "the run's size on disk");
    assert!(find(b, "132 MB").is_some(), "the aborted run's size");
    assert!(
        find(b, "e evaluate with builtin:layered").is_some(),
        "which model e uses"
    );
    let (x, y) = find(b, "exported 2310 images").expect("export outcome");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    // At the UI tests' 160 columns a run id as long as the scans write stays whole.
    s.runs.rows[0].name = "model-check-2026-11-27T23-28-31-919Z".into();
    let narrow = render(&s, 160, 12);
    assert!(
        find(
            narrow.backend().buffer(),
            "model-check-2026-11-27T23-28-31-919Z"
        )
        .is_some(),
        "{}",
        narrow.backend()
    );
    let (x, y) = find(b, "cannot export").expect("export error");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
}

#[test]
fn bench_shows_devices_jog_state_force_and_frame() {
    let s = on_bench();
    let t = render(&s, 120, 30);
    insta::assert_snapshot!("bench", t.backend());
    let b = t.backend().buffer();
    let (x, y) = find(b, "▶ z").expect("the chosen axis is marked");
    assert!(b[(x, y)].modifier.contains(Modifier::BOLD));
    assert!(find(b, "11.2345 mm").is_some(), "z position");
    let (x, y) = find(b, "not homed").expect("x not homed");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    let (x, y) = find(b, "forward limit").expect("fault shown");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    let (x, y) = find(b, "moving").expect("z moving");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    let (x, y) = find(b, "Fz ").expect("force");
    assert_eq!(b[(x, y)].fg, widgets::BAD, "over the ceiling");
    let (x, y) = find(b, "3 lost").expect("lost samples");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    let (x, y) = find(b, "force 15.70 N over the ceiling").expect("the stop is said");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    assert!(find(b, "jog step 0.1 mm").is_some());
    assert!(find(b, "←/→ jog").is_some(), "the bench keys in the footer");
    // The picture: red left half, blue right half, as 24-bit colours.
    let reds = b
        .content()
        .iter()
        .filter(|c| c.fg == Color::Rgb(200, 0, 0))
        .count();
    let blues = b
        .content()
        .iter()
        .filter(|c| c.fg == Color::Rgb(0, 0, 200))
        .count();
    assert!(
        reds > 0 && blues > 0,
        "frame drawn ({reds} red, {blues} blue)"
    );

    let mut held = on_bench();
    held.bench.held = Some("a scan holds the devices: its state is on the Scan screen".into());
    let t = render(&held, 120, 30);
    let b = t.backend().buffer();
    let (x, y) = find(b, "a scan holds the devices").expect("why the bench is closed");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
}

/// The Calibrate screen with a fit awaiting `w`: one press an outlier, one not located.
fn calibrated() -> UiState {
    let mut s = ready();
    s.tab = screens::calibrate::TAB;
    let c = &mut s.calibrate;
    c.phase = CalibrationPhase::Fitted;
    c.fit = vec![
        "centre x 978.41 ± 0.021 px, y 612.30 ± 0.020 px (50 frames averaged)".into(),
        "shift from the image centre x +18.41 px, y +12.30 px".into(),
        "radius 540.12 ± 0.015 px, crop radius 520 px".into(),
    ];
    c.registration =
        "45.012 px/mm, rotation +0.52°, 0.410 px RMS; centre pressed at stage (100.402, 50.271) mm"
            .into();
    c.presses = vec![
        PressRow {
            stage_mm: (95.0, 45.0),
            outcome: Ok((0.31, false)),
        },
        PressRow {
            stage_mm: (100.0, 45.0),
            outcome: Ok((7.9, true)),
        },
        PressRow {
            stage_mm: (105.0, 45.0),
            outcome: Err("no contact spot brighter than the background".into()),
        },
    ];
    c.offsets = vec!["Fx +0.0120  Fy -0.0040  Fz +0.1500 N (± 0.0010 N)".into()];
    c.picture = Some(picture());
    s
}

/// A commissioning of `layered-3` in its third round: two rounds scored, presses on the map.
fn commissioning() -> UiState {
    use fringe_app::commission::CurvePoint;
    use fringe_app::commission::{PressedPoint, UsableDisc};
    let mut s = ready();
    s.tab = screens::commission::TAB;
    s.scan.phase = Phase::Running;
    s.scan.done = 4;
    s.scan.total = 12;
    let point = |round, before, fz, contact, shape| CurvePoint {
        round,
        presses_before: before,
        fz_rmse_n: fz,
        contact_rmse_mm: contact,
        shape_accuracy: shape,
        frames: 1108,
    };
    let press = |x, y, error| PressedPoint {
        stage_mm: [x, y],
        error,
    };
    let mut log = VecDeque::new();
    log.push_back("round 2: 1116 frames of 12 presses, unseen by the model adapted on 12 presses: Fz RMSE 0.262 N, contact RMSE 1.41 mm, shape accuracy 99.6 %".to_string());
    log.push_back(
        "round 3: 6 positions x 2 indenters, about 220 s of bench time (309 s of 600 s spent)"
            .to_string(),
    );
    s.commission = CommissionView {
        sensor: "layered-3".into(),
        plan: String::new(),
        phase: CommissionPhase::Running("round 3: 6 positions x 2 indenters".into()),
        dir: Some("profiles/layered-3.commission-2026-11-28T01-29-27-699Z".into()),
        resumable: None,
        existing: None,
        log,
        progress: None,
        thresholds: (Some(0.49), Some(1.47), Some(0.953)),
        curve: vec![
            point(1, 0, 2.274, 2.18, 0.970),
            point(2, 12, 0.262, 1.41, 0.996),
        ],
        pressed: vec![
            press(12.5, 25.0, 0.6),
            press(18.0, 25.0, 1.6),
            press(7.0, 25.0, 3.1),
            press(12.5, 31.0, 0.9),
        ],
        disc: Some(UsableDisc {
            centre_mm: [12.5, 25.0],
            reach_mm: 8.0,
        }),
    };
    s
}

#[test]
fn commission_shows_the_learning_curve_against_the_spec_and_the_error_map() {
    let s = commissioning();
    let t = render(&s, 150, 30);
    insta::assert_snapshot!("commission", t.backend());
    let b = t.backend().buffer();
    assert!(find(b, "round 3: 6 positions").is_some(), "the step");
    assert!(find(b, "round 3: 6 positions x 2 indenters · point 5 of 12").is_some());
    // Round 1's force and contact are over the spec, round 2's force within and contact within.
    let (x, y) = find(b, "2.274").expect("round 1's force");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    let (x, y) = find(b, "0.262").expect("round 2's force");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    let (x, y) = find(b, "1.41").expect("round 2's contact");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    let (x, y) = find(b, "97.0").expect("round 1's shapes");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    assert!(
        find(b, "< 0.49").is_some() && find(b, "> 95.3").is_some(),
        "the spec row"
    );
    // The map: one press of each colour.
    for colour in [widgets::GOOD, widgets::WARN, widgets::BAD] {
        assert!(
            b.content()
                .iter()
                .any(|c| c.symbol() == "●" && c.fg == colour),
            "a press drawn in {colour:?}"
        );
    }
    assert!(find(b, "s stop (resumable)").is_some(), "the footer says s");

    let mut failed = commissioning();
    failed.scan.phase = Phase::Ready;
    failed.commission.phase = CommissionPhase::Verdict {
        pass: false,
        summary: "sensor layered-3 fails the paper's row: contact RMSE 1.84 mm over 1.47".into(),
    };
    failed.commission.resumable = Some("profiles/layered-3.commission-x".into());
    let t = render(&failed, 150, 30);
    let b = t.backend().buffer();
    let (x, y) = find(b, "FAIL: sensor layered-3").expect("the verdict");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    assert!(find(b, "c go on with the unfinished one").is_some());
}

#[test]
fn calibrate_shows_the_fit_residuals_offsets_and_how_to_accept() {
    let s = calibrated();
    let t = render(&s, 140, 30);
    insta::assert_snapshot!("calibrate", t.backend());
    let b = t.backend().buffer();
    let (x, y) = find(b, "fitted: press w").expect("how to accept");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    let (x, y) = find(b, "0.31 px").expect("a residual");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    let (x, y) = find(b, "7.90 px, left out").expect("an outlier");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    let (x, y) = find(b, "not located").expect("a press not located");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    assert!(find(b, "crop radius 520 px").is_some());
    assert!(find(b, "Fz +0.1500 N").is_some());
    assert!(
        find(b, "w write the profile").is_some(),
        "the footer says w"
    );
    let reds = b
        .content()
        .iter()
        .filter(|c| c.fg == Color::Rgb(200, 0, 0))
        .count();
    assert!(reds > 0, "the fitted frame is drawn");

    let mut written = calibrated();
    written.calibrate.phase = CalibrationPhase::Written("profiles/layered-1.toml".into());
    let t = render(&written, 140, 30);
    let b = t.backend().buffer();
    let (x, y) = find(b, "written: profiles/layered-1.toml").expect("where it went");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
}

#[test]
fn help_lists_every_key() {
    let mut s = ready();
    s.help = true;
    let t = render(&s, 100, 34);
    let b = t.backend().buffer();
    let rows = keys::help_rows();
    assert_eq!(rows.len(), 31, "{rows:?}");
    for row in rows {
        let line = format!("{} ", row.keys);
        assert!(find(b, &line).is_some(), "help names {}", row.keys);
        assert!(
            find(b, &row.what).is_some(),
            "help names {}: {}",
            row.keys,
            row.what
        );
    }
}

#[test]
fn every_screen_draws_at_any_terminal_size() {
    let mut states = vec![
        ready(),
        running(),
        validating(),
        on_bench(),
        calibrated(),
        commissioning(),
        streaming(),
    ];
    let mut runs = ready();
    runs.tab = screens::runs::TAB;
    runs.runs.rows.push(RunRow {
        name: "r".into(),
        status: "failed".into(),
        frames: 0,
        bytes: Some(4096),
        verified: None,
        evaluated: Some("Fz 0.465 N · contact 0.97 mm · shape 99.9 %".into()),
        exported: Some("exporting: 250 images".into()),
    });
    states.push(runs);
    let mut dialog = running();
    dialog.dialog = Some(Dialog {
        title: "scan paused".into(),
        message: "force ceiling reached".into(),
    });
    states.push(dialog);
    let mut help = validating();
    help.help = true;
    states.push(help);
    for s in &states {
        for w in [1u16, 2, 7, 20, 33, 80, 161] {
            for h in [1u16, 2, 3, 5, 9, 24, 50] {
                render(s, w, h);
            }
        }
    }
}

#[test]
fn the_plan_chooser_lists_the_plans_with_the_chosen_one_highlighted() {
    let mut s = ready();
    s.picker = Some(Picker {
        items: vec![
            "built-in plan short-grid (tui/app/plans/short-grid.toml)".into(),
            "calibration (built in)".into(),
            "plans/wide.toml".into(),
        ],
        selected: 2,
    });
    let t = render(&s, 120, 36);
    let b = t.backend().buffer();
    assert!(find(b, "scan plans · Enter choose · Esc close").is_some());
    let (x, y) = find(b, "plans/wide.toml").expect("listed");
    assert!(b[(x, y)].modifier.contains(Modifier::REVERSED));
    let (x, y) = find(b, "calibration (built in)").expect("listed");
    assert!(!b[(x, y)].modifier.contains(Modifier::REVERSED));
}

/// A check of a unit whose figures are `change`'s, at `utc`.
fn check_entry(
    utc: &str,
    change: &fringe_calibration::health::Change,
) -> fringe_app::health::Entry {
    use fringe_app::health::{assess, Measured, Thresholds};
    let a = assess(
        &Measured {
            change,
            radius_px: 245.0,
            radius_sigma_px: 0.02,
            force_offset_n: Some([0.004, -0.002, 0.006]),
            model_now: None,
            model_then: None,
        },
        &Thresholds::default(),
    );
    fringe_app::health::Entry {
        format: 1,
        fringe_version: "0.1.0".into(),
        checked_utc: utc.into(),
        sensor_id: "layered-3".into(),
        certificate: "profiles/layered-3.commission-2026-11-20T09-00-00Z".into(),
        run: "runs/check".into(),
        bench_s: 45.0,
        assessment: a,
        model_now: None,
        model_then: None,
    }
}

#[test]
fn health_screen_lists_the_checks_and_the_chosen_one_s_figures_with_the_moved_ones_marked() {
    use fringe_app::health::Verdict;
    use fringe_calibration::health::Change;
    let unchanged = Change {
        centre_shift_px: [0.003, -0.001],
        centre_sigma_px: [0.01, 0.01],
        radius_change_px: 0.004,
        brightness_ratio: 0.96,
        turn_deg: 0.0,
        darkest_rim_deg: 40.0,
        darkest_rim_ratio: 0.97,
        darkest_side_deg: 90.0,
        darkest_side_ratio: 0.99,
        surface_cells: 0,
        cells_compared: 1436,
        surface_peak_dn: 0.8,
        surface_noise_dn: 0.2,
    };
    let knocked = Change {
        centre_shift_px: [2.49, 0.01],
        ..unchanged.clone()
    };
    let mut s = ready();
    s.tab = screens::health::TAB;
    s.health = HealthView {
        sensor: "layered-3".into(),
        certificate: "profiles/layered-3.commission-2026-11-20T09-00-00Z (issued 2026-11-20T09:12:00Z, passed)".into(),
        history: "profiles/layered-3.health.jsonl".into(),
        checks: vec![
            check_entry("2026-11-21T08:00:00Z", &unchanged),
            check_entry("2026-11-27T08:00:00Z", &knocked),
        ],
        notes: vec!["profiles/layered-3.health.jsonl:2: damaged entry passed over".into()],
        selected: 1,
    };
    assert_eq!(s.health.checks[1].verdict(), Verdict::Recalibrate);
    let t = render(&s, 150, 24);
    insta::assert_snapshot!("health", t.backend());
    let b = t.backend().buffer();
    let (x, y) = find(b, "recalibrate").expect("verdict");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    let (x, y) = find(b, "MOVED").expect("moved figure");
    assert_eq!(b[(x, y)].fg, widgets::BAD);
    assert!(find(b, "centre_shift_px").is_some());
    assert!(find(b, "damaged entry passed over").is_some());
}

/// A passing certificate's summary, as `fringe_app::units` gives it.
fn certificate_view(pass: bool, issued: &str) -> fringe_app::units::CertificateView {
    fringe_app::units::CertificateView {
        dir: "profiles/layered-2.commission-2026-12-06T14-41-43-691Z".into(),
        pass,
        issued_utc: issued.into(),
        model: "profiles/layered-2.commission-2026-12-06T14-41-43-691Z/model.safetensors".into(),
        spec_origin: "paper".into(),
        fz_rmse_n: 0.41,
        contact_rmse_mm: 0.69,
        shape_accuracy: 0.993,
    }
}

#[test]
fn units_screen_lists_every_unit_with_its_certificate_check_and_model() {
    use fringe_app::health::Verdict;
    use fringe_app::units::{CheckView, NextCheck, UnitView, ValidateModel};
    let mut s = ready();
    s.tab = screens::units::TAB;
    let commissioned = UnitView {
        id: "layered-2".into(),
        design: Some("layered".into()),
        simulated: true,
        profile: None,
        certificate: Some(certificate_view(true, "2026-12-06T15:30:00.000Z")),
        passing: None,
        last_check: Some(CheckView {
            checked_utc: "2026-12-06T16:00:00.000Z".into(),
            verdict: Verdict::Recalibrate,
            diagnosis: "the F/T zero moved by (+0.000, +0.000, +0.100) N".into(),
        }),
        checks: 2,
        next_check: NextCheck::Now(Verdict::Recalibrate),
        validate: ValidateModel::Commissioned(
            "profiles/layered-2.commission-2026-12-06T14-41-43-691Z/model.safetensors".into(),
        ),
    };
    let new = UnitView {
        id: "layered-3".into(),
        design: Some("layered".into()),
        simulated: true,
        profile: None,
        certificate: None,
        passing: None,
        last_check: None,
        checks: 0,
        next_check: NextCheck::NotCommissioned,
        validate: ValidateModel::Shipped {
            model: "builtin:layered-two-stage".into(),
            design_known: true,
        },
    };
    s.units = UnitsView {
        profiles: "profiles".into(),
        on_rig: Some("layered-2".into()),
        units: vec![commissioned, new],
        notes: Vec::new(),
        selected: 0,
    };
    for width in [100, 200] {
        let t = render(&s, width, 30);
        let b = t.backend().buffer();
        assert!(
            find(b, "layered-2 *").is_some(),
            "the rig's unit marked at {width}"
        );
        let (x, y) = find(b, "PASS 2026-12-06").expect("the certificate");
        assert_eq!(b[(x, y)].fg, widgets::GOOD);
        let (x, y) = find(b, "recalibrate 2026-12-06").expect("the last check");
        assert_eq!(b[(x, y)].fg, widgets::WARN);
        assert!(find(b, "commissioned").is_some(), "{width}");
        assert!(find(b, "shipped").is_some(), "{width}");
        assert!(
            find(b, "validate uses: its commissioned model").is_some(),
            "{width}"
        );
        assert!(find(b, "next check: now").is_some(), "{width}");
    }
}

#[test]
fn commission_shows_the_unit_s_certificate_made_on_the_command_line() {
    let mut s = ready();
    s.tab = screens::commission::TAB;
    s.commission = CommissionView {
        sensor: "layered-2".into(),
        plan: "base model builtin:layered-keypoint".into(),
        existing: Some((
            true,
            "certificate PASS 2026-12-06 15:30 UTC against paper: Fz 0.41 N".into(),
        )),
        ..CommissionView::default()
    };
    let t = render(&s, 150, 30);
    let b = t.backend().buffer();
    assert!(find(b, "no commissioning started here yet").is_none());
    assert!(find(b, "commissioned before (below); r commissions it again").is_some());
    let (x, y) = find(b, "certificate PASS 2026-12-06 15:30 UTC").expect("the certificate");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    assert!(find(b, "r commission it again").is_some(), "the hint");
}

/// A stream on the simulated bench, 42 s in: the robot pressing with a sphere, Zenoh
/// connected, recording, 3 frames skipped, scored against the truth.
fn streaming() -> UiState {
    let mut s = ready();
    s.tab = screens::stream::TAB;
    let v = &mut s.stream;
    v.running = true;
    v.model = "builtin:layered (ResNet-18, 4 classes)".into();
    v.node = "ROS 2 node /fringe/fringe_stream on domain 0 (Zenoh: connect tcp/localhost:7447; listen tcp/localhost:0)".into();
    v.log("stream started");
    v.log("warning: the unit's light moved: brightness 83 % of the stream's start");
    v.state = Some(StreamState {
        model: "builtin:layered (ResNet-18, 4 classes)".into(),
        backend: "tract",
        camera: "simulated camera".into(),
        sensor: "layered-1".into(),
        frames: 2103,
        dropped_by_camera: 1,
        ran: 2099,
        skipped: 3,
        rate_hz: 50.0,
        latest: Some(prediction(3.25, "sphere", 0.97, [2.5, -1.25])),
        latest_latency_ms: Some(11.4),
        recent_latency: Some(LatencyFigures {
            frames: 500,
            p50_ms: 10.9,
            p99_ms: 16.0,
            max_ms: 21.5,
            stage_p50_ms: [6.6, 0.1, 3.9, 0.3],
            stage_p99_ms: [6.9, 2.0, 8.1, 0.9],
        }),
        fz_history: (0..50)
            .map(|i| (32.0 + 0.2 * i as f64, 3.0 + 0.01 * i as f64))
            .collect(),
        true_fz: (0..45).map(|i| (32.0 + 0.2 * i as f64, 3.1)).collect(),
        truth: Some((2000, errors(2000, 0.21))),
        connected: Some(true),
        namespace: Some("/fringe".into()),
        published: Published {
            wrench: 2099,
            contact: 1400,
            shape: 2099,
            image: 0,
            failed: 0,
        },
        mcap: Some(PathBuf::from(
            "streams/stream-2026-12-06T21-00-00-000Z.mcap",
        )),
        robot_presses: Some(17),
        health: Some(StreamHealth {
            centre_shift_px: [0.4, -0.2],
            centre_limit_px: 1.2,
            brightness_ratio: 0.83,
            free_fz_n: 0.04,
            at_s: 30.0,
        }),
        warnings: Vec::new(),
        failure: None,
        elapsed_s: 42.0,
    });
    s
}

#[test]
fn stream_screen_shows_the_prediction_the_latency_what_is_published_and_the_truth() {
    let t = render(&streaming(), 160, 46);
    insta::assert_snapshot!("stream_running", t.backend());
    let b = t.backend().buffer();
    let (x, y) = find(b, "+3.250 N").expect("Fz");
    assert_eq!(b[(x, y)].fg, widgets::PREDICTED);
    assert!(find(b, "in contact at (+2.50, -1.25) mm").is_some());
    assert!(find(b, "sphere  97 %").is_some());
    assert!(find(b, "50 frames/s · 2099 of 2103 frames run").is_some());
    let (x, y) = find(b, "3 skipped").expect("skipped");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    assert!(find(b, "11.4 ms now · last 500 frames p50 10.9 ms, p99 16.0 ms").is_some());
    // The stage that dominates, in bold.
    let (x, y) = find(b, "camera readout and transfer 6.6 ms").expect("stages");
    assert!(b[(x, y)].modifier.contains(Modifier::BOLD));
    assert!(find(
        b,
        "/fringe/wrench 2099 · /fringe/contact 1400 · /fringe/shape 2099"
    )
    .is_some());
    let (x, y) = find(b, "connected").expect("connection");
    assert_eq!(b[(x, y)].fg, widgets::GOOD);
    assert!(find(
        b,
        "recording to streams/stream-2026-12-06T21-00-00-000Z.mcap"
    )
    .is_some());
    assert!(find(b, "Fz RMSE 0.210 N").is_some());
    assert!(find(b, "the robot's presses 17").is_some());
    assert!(find(b, "brightness 83.0 % of the start").is_some());
    let (x, y) = find(b, "warning: the unit's light moved").expect("warning");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    assert!(find(b, "s stop the stream").is_some());
}

#[test]
fn stream_screen_before_a_stream_says_what_s_and_m_do_and_what_would_run() {
    let mut s = ready();
    s.tab = screens::stream::TAB;
    s.stream.model = "builtin:layered (ResNet-18, 4 classes)".into();
    s.stream.node = "ROS 2 node /fringe/fringe_stream on domain 0".into();
    s.stream.held = Some("a scan holds the camera: the stream can start when it ends".into());
    let t = render(&s, 160, 46);
    let b = t.backend().buffer();
    assert!(find(b, "s streams: the camera and the unit's model only").is_some());
    assert!(find(b, "m streams and records the messages to an MCAP file").is_some());
    assert!(find(b, "model: builtin:layered (ResNet-18, 4 classes)").is_some());
    assert!(find(b, "ROS 2 node /fringe/fringe_stream on domain 0").is_some());
    let (x, y) = find(b, "a scan holds the camera").expect("held");
    assert_eq!(b[(x, y)].fg, widgets::WARN);
    assert!(find(b, "s stream · m stream and record to MCAP").is_some());
}
