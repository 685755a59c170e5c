//! Frame rendering time of both sensor builds at full size (1920x1200).
//!
//! `cargo run --release -p fringe-sim --example render_bench [-- FRAMES] [--bayer | --mono]
//! [--only CASE]` (default 200 frames per case, RGB8; `--bayer` / `--mono`: the BayerRG8 /
//! Mono8 frames the simulated camera renders in those formats; `--only`: one case, for
//! profiling). For each sensor and shape it renders a contact moving across the disc with a
//! changing force and angle, and prints mean, p95 and max wall-clock milliseconds per frame,
//! and the CPU time per frame summed over all threads (from getrusage: independent of other
//! processes competing for the cores, unlike the wall clock). The cases:
//!
//! - `pentagon`, `rectangle`: a press alone;
//! - `pushed`: a pentagon pushed along the surface too, with a tangential force, direction and
//!   share of the friction that change every frame, so every frame builds its own field;
//! - `held`: a pentagon pressed and pushed with one force, direction and share of the friction,
//!   standing still (a held push: consecutive frames have the same field);
//! - `none`: the unloaded sensor.
//!
//! The push fields of both punches are computed before the cases (`Renderer::prepare_push`,
//! timed apart). Before them, for each sensor, the first push with a fresh renderer (`stall`): frames paced
//! at 50 Hz, a pentagon pressed for 1 s and then pushed for 2 s with the share of the friction
//! rising from 0 to 1 (every traction level in turn), and the slowest frame (a frame that
//! waits for fields built on first use is a dropped frame in a live run). Exits non-zero if a
//! mean exceeds 20 ms (a 50 Hz camera in real time).

use fringe_rig::PixelFormat;
use fringe_rig::{Millimetres, Newtons};
use fringe_sim::Renderer;
use fringe_sim::SensorConfig;
use fringe_sim::{Contact, FrameRenderer, Scene, Shear};
use std::time::{Duration, Instant};

/// User plus system CPU time of this process so far (all threads), ms.
fn cpu_ms() -> f64 {
    // SAFETY: getrusage only writes the struct we pass.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let ms = |t: libc::timeval| t.tv_sec as f64 * 1e3 + t.tv_usec as f64 * 1e-3;
    ms(usage.ru_utime) + ms(usage.ru_stime)
}

/// Frame `k` of `frames` of case `name`: the scene the case renders.
fn scene(name: &str, renderer: &Renderer, k: usize, frames: usize) -> Scene {
    let s = k as f64 / frames as f64;
    let a = std::f64::consts::TAU * s;
    let config = renderer.config();
    let contact = match name {
        "none" => None,
        "held" => Some(Contact {
            shape: config.pentagon(),
            force: Newtons(5.0),
            x: Millimetres(6.0),
            y: Millimetres(-4.0),
            angle_deg: 20.0,
            shear: Some(Shear {
                force: Newtons(1.5),
                direction_deg: 30.0,
                friction_used: 0.45,
                sliding: false,
            }),
        }),
        _ => Some(Contact {
            shape: if name == "rectangle" {
                config.rectangle()
            } else {
                config.pentagon()
            },
            force: Newtons(0.5 + 8.5 * s),
            x: Millimetres(15.0 * a.cos()),
            y: Millimetres(10.0 * a.sin()),
            angle_deg: 90.0 * s,
            shear: (name == "pushed").then_some(Shear {
                force: Newtons(0.3 + 2.7 * s),
                direction_deg: 360.0 * s,
                friction_used: s,
                sliding: s > 0.9,
            }),
        }),
    };
    Scene { contact }
}

/// The first push of a fresh renderer of `config`, paced at 50 Hz: 1 s of a 5 N pentagon
/// press, then 2 s of a push rising to 2.5 N with the share of the friction rising from 0 to
/// 1. Prints the slowest frame of each part and the CPU time of the whole (all threads).
fn first_push(config: SensorConfig, format: PixelFormat) -> Result<(), Box<dyn std::error::Error>> {
    const PERIOD: Duration = Duration::from_millis(20);
    let (press, push) = (50usize, 100usize);
    let mut renderer = Renderer::new(config)?;
    let shape = renderer.config().pentagon();
    let mut out = Vec::new();
    let mut worst = [(0.0f64, 0usize); 2];
    let cpu_start = cpu_ms();
    let start = Instant::now();
    for k in 0..press + push {
        let u = k.saturating_sub(press) as f64 / (push - 1) as f64;
        let contact = Contact {
            shape,
            force: Newtons(5.0),
            x: Millimetres(4.0 + 3.0 * u),
            y: Millimetres(-3.0),
            angle_deg: 15.0,
            shear: (k >= press).then_some(Shear {
                force: Newtons(2.5 * u.max(0.02)),
                direction_deg: 10.0,
                friction_used: u,
                sliding: false,
            }),
        };
        let due = start + PERIOD * k as u32;
        std::thread::sleep(due.saturating_duration_since(Instant::now()));
        let t = Instant::now();
        renderer.render_as(
            &Scene {
                contact: Some(contact),
            },
            k as u64,
            format,
            &mut out,
        );
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let part = usize::from(k >= press);
        if ms > worst[part].0 {
            worst[part] = (ms, k);
        }
    }
    let cpu = cpu_ms() - cpu_start;
    println!(
        "  stall     slowest press frame {:6.2} ms (frame {}), slowest push frame {:6.2} ms \
         (frame {}), cpu {cpu:6.0} ms in all ({} frames at 50 Hz)",
        worst[0].0,
        worst[0].1,
        worst[1].0,
        worst[1].1,
        press + push
    );
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let only = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1))
        .cloned();
    let frames: usize = match args
        .iter()
        .enumerate()
        .find(|(i, a)| !a.starts_with("--") && (*i == 0 || args[i - 1] != "--only"))
    {
        Some((_, a)) => a.parse()?,
        None => 200,
    };
    let format = if args.iter().any(|a| a == "--bayer") {
        PixelFormat::BayerRg8
    } else if args.iter().any(|a| a == "--mono") {
        PixelFormat::Mono8
    } else {
        PixelFormat::Rgb8
    };
    let wanted = |name: &str| only.as_deref().is_none_or(|o| o == name);
    let mut worst_mean: f64 = 0.0;
    for config in [SensorConfig::layered(), SensorConfig::integrated()] {
        let id = config.id.clone();
        if wanted("stall") {
            println!("{id}: first push");
            first_push(config.clone(), format)?;
        }
        let start = Instant::now();
        let mut renderer = Renderer::new(config)?;
        let startup = start.elapsed();
        // The push fields of both flat punches now, so that no case below computes them (a
        // press would otherwise have them computed in the background during its frames).
        let start = Instant::now();
        for shape in [renderer.config().pentagon(), renderer.config().rectangle()] {
            renderer.prepare_push(&shape);
        }
        println!(
            "{id}: start-up {:.0} ms, push fields of both punches {:.0} ms, {}x{} {format:?}, \
             {} threads",
            startup.as_secs_f64() * 1e3,
            start.elapsed().as_secs_f64() * 1e3,
            renderer.width(),
            renderer.height(),
            renderer.config().threads
        );
        let mut out = Vec::new();
        for name in ["pentagon", "rectangle", "pushed", "held", "none"] {
            if !wanted(name) {
                continue;
            }
            let mut times = Vec::with_capacity(frames);
            let cpu_start = cpu_ms();
            for k in 0..frames {
                let scene = scene(name, &renderer, k, frames);
                let t = Instant::now();
                renderer.render_as(&scene, k as u64, format, &mut out);
                times.push(t.elapsed().as_secs_f64() * 1e3);
            }
            let cpu = (cpu_ms() - cpu_start) / frames as f64;
            times.sort_by(f64::total_cmp);
            let mean = times.iter().sum::<f64>() / times.len() as f64;
            let p95 = times[(0.95 * (times.len() - 1) as f64).round() as usize];
            let max = times[times.len() - 1];
            println!(
                "  {name:<9} mean {mean:6.2} ms  p95 {p95:6.2} ms  max {max:6.2} ms  \
                 cpu {cpu:6.2} ms/frame  ({frames} frames)"
            );
            worst_mean = worst_mean.max(mean);
        }
    }
    if worst_mean > 20.0 {
        eprintln!("mean frame time {worst_mean:.2} ms exceeds 20 ms");
        std::process::exit(1);
    }
    Ok(())
}
