//! Frame rendering time of both sensor builds at full size (1920x1200).
//!
//! `cargo run --release -p fringe-sim --example render_bench [-- FRAMES] [--bayer | --mono]`
//! (default 200 frames per case, RGB8; `--bayer` / `--mono`: the BayerRG8 / Mono8 frames the
//! simulated camera renders in those formats). For each sensor and shape it renders a contact moving across the disc with a changing
//! force and angle (`pushed`: a pentagon pushed along the surface too, with a tangential force,
//! direction and share of the friction that change every frame, so every frame builds its own
//! field), and prints mean, p95 and max wall-clock milliseconds per frame, and the CPU
//! time per frame summed over all threads (from getrusage: independent of other processes
//! competing for the cores, unlike the wall clock). Exits non-zero if a mean exceeds 20 ms (a
//! 50 Hz camera in real time).

use fringe_rig::PixelFormat;
use fringe_rig::{Millimetres, Newtons};
use fringe_sim::Renderer;
use fringe_sim::SensorConfig;
use fringe_sim::{Contact, FrameRenderer, Scene, Shear};
use std::time::Instant;

/// User plus system CPU time of this process so far, ms.
fn cpu_ms() -> f64 {
    // SAFETY: getrusage only writes the struct we pass.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let ms = |t: libc::timeval| t.tv_sec as f64 * 1e3 + t.tv_usec as f64 * 1e-3;
    ms(usage.ru_utime) + ms(usage.ru_stime)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames: usize = match args.iter().find(|a| !a.starts_with("--")) {
        Some(a) => a.parse()?,
        None => 200,
    };
    let format = if args.iter().any(|a| a == "--bayer") {
        PixelFormat::BayerRg8
    } else if args.iter().any(|a| a == "--mono") {
        PixelFormat::Mono8
    } else {
        PixelFormat::Rgb8
    };
    let mut worst_mean: f64 = 0.0;
    for config in [SensorConfig::layered(), SensorConfig::integrated()] {
        let id = config.id.clone();
        let start = Instant::now();
        let mut renderer = Renderer::new(config)?;
        println!(
            "{id}: start-up {:.0} ms, {}x{} {format:?}, {} threads",
            start.elapsed().as_secs_f64() * 1e3,
            renderer.width(),
            renderer.height(),
            renderer.config().threads
        );
        let shapes = [
            ("pentagon", renderer.config().pentagon()),
            ("rectangle", renderer.config().rectangle()),
            ("pushed", renderer.config().pentagon()),
            ("none", renderer.config().rectangle()),
        ];
        let mut out = Vec::new();
        for (name, shape) in shapes {
            let mut times = Vec::with_capacity(frames);
            let cpu_start = cpu_ms();
            for k in 0..frames {
                let s = k as f64 / frames as f64;
                let a = std::f64::consts::TAU * s;
                let contact = (name != "none").then_some(Contact {
                    shape,
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
                });
                let t = Instant::now();
                renderer.render_as(&Scene { contact }, k as u64, format, &mut out);
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
