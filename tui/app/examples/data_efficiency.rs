//! How many presses a unit needs: held-out Fz and contact RMSE against the number of positions
//! pressed, for (b) presses spread uniformly over the disc with the base model's heads adapted
//! on them, (c) presses chosen as `fringe commission` chooses them (each round where the model
//! as adapted so far erred most or has not pressed) with the same adaptation, and (a) models
//! trained from scratch on uniform presses (written here as datasets; `fringe train` trains them
//! and `--score` scores them on the same held-out presses).
//!
//! The presses are made off the bench clock: each position is pressed with every indenter, 12
//! frames from 0.3 N to 9 N (the range a commissioning press films) and one frame before
//! contact, rendered by the unit's simulated sensor exactly as the bench's camera would see the
//! indenter there (no motion, the same renderer, noise and F/T label noise). Positions are in
//! the sensor frame (mm from the disc centre): the unit's design geometry stands for a perfect
//! calibration. Candidates and held-out positions are the commissioning's: a 2 mm lattice over
//! 0.7 of the disc, the held-out lattice shifted half a spacing between them.
//!
//! ```sh
//! E=target/release/examples/data_efficiency
//! cargo build --release -p fringe-app --example data_efficiency
//! $E --sensor rig/sim/sensors/layered-3.toml --out DIR --scratch 15,30,60     # (b), (c), datasets
//! # (a), for each N of --scratch (the command is printed; a build with the torch feature):
//! fringe train $(cat DIR/scratch-N.list) --arch custom --pipeline gray10 --input-size 112 \
//!     --epochs 40 --schedule cosine --out DIR/scratch-N
//! $E --sensor rig/sim/sensors/layered-3.toml --out DIR --score DIR/scratch-N/model.safetensors --positions N
//! ```
//!
//! Every figure lands in `DIR/curves.csv` (a rerun or a new score replaces its own rows), the
//! curves with the spec's threshold in `DIR/fz.png` and `DIR/contact.png`; the table is printed.

use fringe_app::commission::round_errors;
use fringe_app::commission::{
    choose_presses, PressedPoint, UsableDisc, COVERAGE_MM, LATTICE_MM, REACH_FRACTION,
};
use fringe_app::rig::sensor_profile;
use fringe_rig::reference_layout::{
    LabelRow, LabelWriter, Shape as LabelShape, IMAGES, LABELS, SIM_DATASET_DOC,
    SIM_DATASET_PROFILE,
};
use fringe_rig::store::save_png;
use fringe_rig::BenchLimits;
use fringe_rig::HostTime;
use fringe_rig::{Frame, PixelFormat};
use fringe_rig::{Kinematics, SoftLimits};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Newtons};
use fringe_sensor_models::adapt::{fit_heads, head_scores, AdaptConfig, Features};
use fringe_sensor_models::dataset::{self, Source};
use fringe_sensor_models::Errors;
use fringe_sensor_models::Model;
use fringe_sensor_models::Spec;
use fringe_sensor_models::StateDict;
use fringe_sim::dataset::{disc_radius_mm, pressed_frame, shape_named, SHAPES};
use fringe_sim::Renderer;
use fringe_sim::SensorConfig;
use fringe_sim::{Contact, FrameRenderer};
use std::error::Error;
use std::io::Write as _;
use std::path::{Path, PathBuf};

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// Positions per adaptive round (the default of `fringe commission --round-presses`).
const ROUND: usize = 6;
/// Held-out positions (each pressed with every indenter).
const HELD_OUT: usize = 15;
/// Frames in contact per press, and before contact.
const FRAMES_IN_CONTACT: usize = 18;
const FRAMES_BEFORE: usize = 5;
/// How a commissioning press on the bench spreads its frames over the force range: frames in
/// each 1 N level (0.2-1, 1-2, ... 8-9 N) of the acceptance scan of `layered-2`
/// (BENCHMARKS.md, "Every new simulated build"; 1421 frames in contact, 418 before contact, which
/// FRAMES_BEFORE follows). The ramps are slower near each target and the dwells add frames there.
const LEVEL_FRAMES: [f64; 9] = [116.0, 101.0, 197.0, 263.0, 94.0, 100.0, 200.0, 137.0, 213.0];
/// The lightest force of a frame in contact, N (the label rules' threshold).
const FORCE_FROM: f64 = 0.2;
/// Seed of the frames' noise and of the adaptation's folds.
const SEED: u64 = 42;
/// The largest number of positions (b) and (c) press.
const MOST: usize = 48;

struct Args {
    sensor: PathBuf,
    out: PathBuf,
    scratch: Vec<usize>,
    score: Option<PathBuf>,
    positions: Option<usize>,
}

fn args() -> Result<Args> {
    let mut a = Args {
        sensor: PathBuf::from("rig/sim/sensors/layered-3.toml"),
        out: PathBuf::from("data-efficiency"),
        scratch: Vec::new(),
        score: None,
        positions: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--sensor" => a.sensor = value()?.into(),
            "--out" => a.out = value()?.into(),
            "--scratch" => {
                a.scratch = value()?
                    .split(',')
                    .map(|n| n.trim().parse::<usize>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|e| format!("--scratch: {e} (give counts of positions, 24,48)"))?
            }
            "--score" => a.score = Some(value()?.into()),
            "--positions" => {
                a.positions = Some(
                    value()?
                        .parse()
                        .map_err(|e| format!("--positions: {e} (a count of positions)"))?,
                )
            }
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    Ok(a)
}

/// Stage limits that let the lattice reach the whole disc (positions are sensor mm here).
fn open_limits() -> Result<BenchLimits> {
    let soft = SoftLimits::new(Millimetres(-100.0), Millimetres(100.0))?;
    let k = Kinematics {
        velocity: MillimetresPerSecond(2.0),
        acceleration: MillimetresPerSecondSquared(4.0),
    };
    Ok(BenchLimits {
        x: soft,
        y: soft,
        z: soft,
        x_motion: k,
        y_motion: k,
        z_motion: k,
        manual_y: false,
        max_force: Newtons(20.0),
        ft_rating: None,
        contact_z: Millimetres(15.0),
        start: None,
    })
}

/// Presses positions with every indenter into one reference-layout dataset per position, kept
/// on disk (a second run reads them back).
struct Presser {
    sensor: SensorConfig,
    renderer: Renderer,
    root: PathBuf,
    pixels: Vec<u8>,
}

impl Presser {
    /// The dataset of position `pos` (sensor mm), `name` unique to it.
    fn press(&mut self, name: &str, number: u64, pos: [f64; 2]) -> Result<Source> {
        let dir = self.root.join(name);
        if !dir.join(LABELS).is_file() {
            self.render(&dir, number, pos)?;
        }
        let mut source = dataset::read(&dir)?;
        // One press per indenter at this position (the bench's run#point), its frames before
        // contact first.
        let per_press = FRAMES_BEFORE + FRAMES_IN_CONTACT;
        for (k, s) in source.samples.iter_mut().enumerate() {
            s.press = format!("{name}#{}", SHAPES[(k / per_press).min(SHAPES.len() - 1)]);
            s.stage_mm = Some(pos);
        }
        Ok(source)
    }

    fn render(&mut self, dir: &Path, number: u64, pos: [f64; 2]) -> Result<()> {
        let images = dir.join(IMAGES);
        std::fs::create_dir_all(&images)?;
        let mut labels = LabelWriter::new(Vec::new(), None)?;
        let mut k = 0u64;
        let mut frames = Vec::new();
        for shape in SHAPES {
            frames.extend((0..FRAMES_BEFORE).map(|_| (None, 0.0)));
            for i in 0..FRAMES_IN_CONTACT {
                let q = (i as f64 + 0.5) / FRAMES_IN_CONTACT as f64;
                frames.push((Some(shape), force_at(q)));
            }
        }
        for (shape, force) in frames {
            let contact = match shape {
                Some(name) => {
                    let tip = shape_named(&self.sensor, name)
                        .ok_or_else(|| format!("the sensor has no {name}"))?;
                    Some((
                        name,
                        Contact {
                            shape: tip,
                            force: Newtons(force),
                            x: Millimetres(pos[0]),
                            y: Millimetres(pos[1]),
                            angle_deg: 0.0,
                            shear: None,
                        },
                    ))
                }
                None => None,
            };
            let f = pressed_frame(SEED, number * 64 + k, contact);
            self.renderer.render_as(
                &f.scene,
                f.render_index,
                PixelFormat::Mono8,
                &mut self.pixels,
            );
            let image = format!("image_{k}.png");
            let frame = Frame {
                id: k,
                device_timestamp: 0,
                host_arrival: HostTime(0),
                width: self.renderer.width(),
                height: self.renderer.height(),
                format: PixelFormat::Mono8,
                data: std::mem::take(&mut self.pixels),
            };
            save_png(&frame, &images.join(&image))?;
            self.pixels = frame.data;
            labels.write(&LabelRow {
                image,
                wrench: f.wrench.to_array(),
                contact: f.contact_mm(),
                shape: f.shape.map_or(LabelShape::NoContact, LabelShape::parse),
            })?;
            k += 1;
        }
        sensor_profile(
            &self.sensor,
            &self.sensor.id,
            format!(
                "the simulated {} sensor's design geometry (data_efficiency)",
                self.sensor.id
            ),
            [0.0, 0.0],
        )
        .save(&dir.join(SIM_DATASET_PROFILE))?;
        let doc = serde_json::json!({
            "sensor_id": self.sensor.id,
            "position_mm": pos,
            "sensor": serde_json::to_value(&self.sensor)?,
        });
        std::fs::write(
            dir.join(SIM_DATASET_DOC),
            serde_json::to_string_pretty(&doc)?,
        )?;
        // The labels last: their presence marks the press as made.
        std::fs::write(dir.join(LABELS), labels.finish()?)?;
        Ok(())
    }
}

/// The force below which a share `q` (0-1) of a bench press's frames in contact lie: the
/// inverse of [`LEVEL_FRAMES`]' distribution, uniform within each level.
fn force_at(q: f64) -> f64 {
    let total: f64 = LEVEL_FRAMES.iter().sum();
    let mut below = 0.0;
    for (k, n) in LEVEL_FRAMES.iter().enumerate() {
        let share = n / total;
        if q <= below + share || k + 1 == LEVEL_FRAMES.len() {
            let from = if k == 0 { FORCE_FROM } else { k as f64 };
            let within = ((q - below) / share).clamp(0.0, 1.0);
            return from + (k as f64 + 1.0 - from) * within;
        }
        below += share;
    }
    LEVEL_FRAMES.len() as f64
}

/// Held-out figures of `weights` on `held`.
#[derive(Debug, Clone, Copy)]
struct Figures {
    fz: f64,
    contact: f64,
    shape: f64,
}

impl Figures {
    fn line(&self) -> String {
        format!(
            "held-out Fz RMSE {:.3} N, contact RMSE {:.2} mm, shape accuracy {:.1} %",
            self.fz,
            self.contact,
            100.0 * self.shape
        )
    }
}

fn score(weights: &StateDict, held: &Features) -> Result<Figures> {
    let mut e = Errors::default();
    for s in head_scores(weights, held)? {
        e.add(&s);
    }
    Ok(Figures {
        fz: e.fz_rmse(),
        contact: e.contact_rmse(),
        shape: e.accuracy(),
    })
}

fn features(model: &Model, sources: &[Source]) -> Result<Features> {
    Ok(Features::read(model, sources, None, 2, |_, _| {})?)
}

fn main() -> Result<()> {
    let a = args()?;
    let sensor = SensorConfig::load(&a.sensor)?;
    let reach = REACH_FRACTION * disc_radius_mm(&sensor);
    let disc = UsableDisc {
        centre_mm: [0.0, 0.0],
        reach_mm: reach,
    };
    let limits = open_limits()?;
    let candidates = disc.lattice(LATTICE_MM, 0.0, &limits, &sensor.id)?;
    let held_at = choose_presses(
        &disc.lattice(LATTICE_MM, 0.5, &limits, &sensor.id)?,
        &[],
        HELD_OUT,
        COVERAGE_MM,
    );
    let uniform = choose_presses(&candidates, &[], candidates.len(), COVERAGE_MM);
    eprintln!(
        "sensor {} ({}): usable reach {reach:.1} mm, {} candidate positions, {} held out",
        sensor.id,
        sensor.variant.name(),
        candidates.len(),
        held_at.len()
    );
    let mut renderer_config = sensor.clone();
    renderer_config.threads = 2;
    let mut presser = Presser {
        renderer: Renderer::new(renderer_config)?,
        sensor: sensor.clone(),
        root: a.out.clone(),
        pixels: Vec::new(),
    };
    let number = |p: &[f64; 2]| {
        candidates
            .iter()
            .position(|c| c == p)
            .map_or(0, |i| i as u64 + 1)
    };
    let name = |p: &[f64; 2]| format!("uniform/pos-{:03}", number(p) - 1);

    let held_sources = held_at
        .iter()
        .enumerate()
        .map(|(i, p)| presser.press(&format!("held-out/pos-{i:02}"), 100_000 + i as u64, *p))
        .collect::<Result<Vec<_>>>()?;

    let shapes = SHAPES.len();

    let curves = a.out.join("curves.csv");
    let mut rows = read_curves(&curves)?;
    if let Some(path) = &a.score {
        let n = a
            .positions
            .ok_or("--score needs --positions N: the positions the model was trained on")?;
        let model = fringe_sensor_models::builtin::open(path)?;
        let weights = model
            .weights()
            .ok_or_else(|| format!("{}: no weights to score", path.display()))?;
        let f = score(weights, &features(&model, &held_sources)?)?;
        println!("{}: {}", path.display(), f.line());
        rows.retain(|r| !(r.method == SCRATCH && r.positions == n));
        rows.push(Row {
            method: SCRATCH.into(),
            positions: n,
            figures: f,
        });
        return finish(&a.out, &mut rows, shapes);
    }

    let base_path = fringe_sensor_models::builtin::commissioning_base(Some(sensor.variant.name()))?;
    let base = fringe_sensor_models::builtin::open(&base_path)?;
    let base_weights = base
        .weights()
        .ok_or("the commissioning base holds no weights")?
        .clone();
    let held = features(&base, &held_sources)?;
    let before = score(&base_weights, &held)?;
    println!(
        "base {} before adaptation: {}",
        base_path.display(),
        before.line()
    );
    let config = AdaptConfig {
        folds: 5,
        seed: SEED,
        threads: 2,
    };

    // (b) uniform presses, adapted on at every step of positions.
    let mut pressed = Features::empty();
    for (i, p) in uniform.iter().take(MOST).enumerate() {
        let source = presser.press(&name(p), number(p), *p)?;
        pressed.append(features(&base, &[source])?)?;
        let n = i + 1;
        if n % 3 == 0 && n >= 3 {
            let fit = fit_heads(&base_weights, &pressed, &config)?;
            let f = score(&fit.weights, &held)?;
            eprintln!("(b) uniform, {n} positions: {}", f.line());
            rows.retain(|r| !(r.method == UNIFORM && r.positions == n));
            rows.push(Row {
                method: UNIFORM.into(),
                positions: n,
                figures: f,
            });
        }
    }

    // (c) adaptive rounds as commissioning presses them.
    let mut learnt = Features::empty();
    let mut weights = base_weights.clone();
    let mut errors: Vec<PressedPoint> = Vec::new();
    let spec = Spec::paper();
    let mut round = 0;
    while errors.len() < MOST * shapes {
        let picks = choose_presses(&candidates, &errors, ROUND, COVERAGE_MM);
        if picks.is_empty() {
            break;
        }
        let sources = picks
            .iter()
            .map(|p| presser.press(&name(p), number(p), *p))
            .collect::<Result<Vec<_>>>()?;
        let f = features(&base, &sources)?;
        let scores = head_scores(&weights, &f)?;
        round += 1;
        let seen = round_errors(round, learnt.presses(), f.samples(), &scores, &spec);
        errors.extend(seen.presses);
        learnt.append(f)?;
        let fit = fit_heads(&base_weights, &learnt, &config)?;
        weights = fit.weights;
        let figures = score(&weights, &held)?;
        let n = errors.len() / shapes;
        eprintln!("(c) adaptive, {n} positions: {}", figures.line());
        rows.retain(|r| !(r.method == ADAPTIVE && r.positions == n));
        rows.push(Row {
            method: ADAPTIVE.into(),
            positions: n,
            figures,
        });
    }

    // (a) datasets of uniform presses for training from scratch: their directories listed in
    // `scratch-N.list`, one per line.
    for n in &a.scratch {
        let mut list = String::new();
        for p in uniform.iter().take(*n) {
            presser.press(&name(p), number(p), *p)?;
            list.push_str(&format!("{}\n", a.out.join(name(p)).display()));
        }
        let path = a.out.join(format!("scratch-{n}.list"));
        std::fs::write(&path, list)?;
        writeln!(
            std::io::stdout(),
            "(a) {n} positions: fringe train $(cat {}) --arch custom --pipeline gray10 --input-size 112 --epochs 40 --schedule cosine --out {}",
            path.display(),
            a.out.join(format!("scratch-{n}")).display()
        )?;
    }
    finish(&a.out, &mut rows, shapes)
}

/// One figure of the curves: a method after `positions` positions.
struct Row {
    method: String,
    positions: usize,
    figures: Figures,
}

const SCRATCH: &str = "a scratch";
const UNIFORM: &str = "b uniform+adapt";
const ADAPTIVE: &str = "c adaptive+adapt";
const HEADER: &str = "method,positions,presses,fz_rmse_n,contact_rmse_mm,shape_accuracy";

/// The rows of `curves.csv` so far (none when it is not there yet).
fn read_curves(path: &Path) -> Result<Vec<Row>> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Ok(Vec::new());
    };
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let bad = || {
            format!(
                "{} line {}: {line:?} is not a row of {HEADER}",
                path.display(),
                i + 1
            )
        };
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 {
            return Err(bad().into());
        }
        let num = |k: usize| f[k].parse::<f64>().map_err(|_| bad());
        rows.push(Row {
            method: f[0].to_string(),
            positions: f[1].parse().map_err(|_| bad())?,
            figures: Figures {
                fz: num(3)?,
                contact: num(4)?,
                shape: num(5)?,
            },
        });
    }
    Ok(rows)
}

/// Writes `curves.csv`, the plots `fz.png` and `contact.png` (with the spec's threshold) and
/// prints the table.
fn finish(out: &Path, rows: &mut [Row], shapes: usize) -> Result<()> {
    rows.sort_by(|a, b| (&a.method, a.positions).cmp(&(&b.method, b.positions)));
    let mut csv = format!("{HEADER}\n");
    for r in rows.iter() {
        csv.push_str(&format!(
            "{},{},{},{:.4},{:.4},{:.4}\n",
            r.method,
            r.positions,
            r.positions * shapes,
            r.figures.fz,
            r.figures.contact,
            r.figures.shape
        ));
    }
    std::fs::write(out.join("curves.csv"), &csv)?;
    let spec = Spec::paper().all;
    let x_max = rows.iter().map(|r| r.positions).max().unwrap_or(1) as f64;
    for (file, label, limit, pick) in [
        ("fz.png", "held-out Fz RMSE (N)", spec.fz_rmse_n, 0),
        (
            "contact.png",
            "held-out contact RMSE (mm)",
            spec.contact_rmse_mm,
            1,
        ),
    ] {
        let mut chart = fringe_plot::Chart::new(
            format!("{label} by positions pressed"),
            fringe_plot::Axis::new("positions pressed (x2 indenters)")
                .integers()
                .from_zero(),
            fringe_plot::Axis::new(label).from_zero(),
        );
        for (k, method) in [SCRATCH, UNIFORM, ADAPTIVE].into_iter().enumerate() {
            let pts: Vec<[f64; 2]> = rows
                .iter()
                .filter(|r| r.method == method)
                .map(|r| {
                    let y = if pick == 0 {
                        r.figures.fz
                    } else {
                        r.figures.contact
                    };
                    [r.positions as f64, y]
                })
                .collect();
            if !pts.is_empty() {
                let colour = fringe_plot::palette::SERIES[k % fringe_plot::palette::SERIES.len()];
                chart =
                    chart.series(fringe_plot::Series::line(method, &pts, colour).with_markers());
            }
        }
        if let Some(limit) = limit {
            let spec = [[0.0, limit], [x_max, limit]];
            chart = chart.series(
                fringe_plot::Series::line("spec (paper)", &spec, fringe_plot::palette::RED)
                    .dashed(),
            );
        }
        chart.render(720, 720)?.save(out.join(file))?;
    }
    print!("{csv}");
    Ok(())
}
