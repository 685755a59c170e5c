//! Inference and preprocessing timings on this machine, with PyTorch eager measured in the same
//! run when `FRINGE_TORCH_PYTHON` names a Python with torch (sensor-models/tests/python/torch_bench.py).
//!
//!     cargo run --release -p fringe-sensor-models --example model_bench [-- ITERATIONS]
//!     cargo run --release -p fringe-sensor-models --example model_bench --features onnxruntime [-- ITERATIONS]
//!     model_bench --export DIR                 the seeded graphs as DIR/<arch>.onnx, for other tools
//!     model_bench --profile [FILE.onnx ...]    where tract's time goes, per kind of operation, at
//!                                              224 px on 1 and 2 threads (default: the seeded graphs)
//!
//! Batch 1 at 224 x 224 (the custom and keypoint CNNs at 112 x 112 too, ResNet-18 at 112 and 160); the default backend (tract) on 1 and 2 threads, and with
//! `--features onnxruntime` ONNX Runtime on 1 and 2 intra-op threads (`ORT_DYLIB_PATH` names the
//! library; README.md); a 1920x1200 frame through the
//! one preprocessing (RGB8 and BayerRG8). Weights are seeded random values: timing does not
//! depend on them.

use fringe_rig::PixelFormat;
use fringe_sensor_models::onnx_graph;
use fringe_sensor_models::profile_tract;
use fringe_sensor_models::Architecture;
use fringe_sensor_models::Backend;
use fringe_sensor_models::TractBackend;
use fringe_sensor_models::{Centre, Colour, FrameRef, Preprocessing, Preprocessor};
use fringe_sensor_models::{StateDict, Tensor};
use std::time::Instant;

fn seeded(arch: Architecture) -> StateDict {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    StateDict::from_pairs(arch.layout(3).into_iter().map(|(k, shape)| {
        let n: usize = shape.iter().product();
        let fan_in = shape.iter().skip(1).product::<usize>().max(1) as f32;
        let data = (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let u = (s >> 11) as f32 / (1u64 << 53) as f32 - 0.5;
                if k.ends_with("running_var") {
                    1.0 + u.abs()
                } else {
                    u / fan_in.sqrt()
                }
            })
            .collect();
        (k, Tensor::new(shape, data).expect("tensor"))
    }))
}

/// (median, mean) ms of `f` over `n` runs after 3 warm-ups.
fn time(n: usize, mut f: impl FnMut()) -> (f64, f64) {
    for _ in 0..3 {
        f();
    }
    let mut t: Vec<f64> = (0..n)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let mean = t.iter().sum::<f64>() / n as f64;
    t.sort_by(f64::total_cmp);
    (t[n / 2], mean)
}

/// The seeded graph of every architecture, by name.
fn seeded_graphs() -> Vec<(String, tract_onnx::pb::ModelProto)> {
    Architecture::ALL
        .iter()
        .map(|&arch| {
            (
                arch.name().to_string(),
                onnx_graph::build(arch, 3, &seeded(arch)),
            )
        })
        .collect()
}

fn export(dir: &str) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {dir}: {e}"))?;
    for (name, proto) in seeded_graphs() {
        let path = format!("{dir}/{name}.onnx");
        std::fs::write(&path, onnx_graph::encode(&proto))
            .map_err(|e| format!("cannot write {path}: {e}"))?;
        println!("wrote {path}");
    }
    Ok(())
}

fn profile(files: &[String], runs: usize) -> Result<(), String> {
    let graphs = if files.is_empty() {
        seeded_graphs()
    } else {
        let mut graphs = Vec::new();
        for f in files {
            let bytes = std::fs::read(f).map_err(|e| format!("cannot read {f}: {e}"))?;
            let proto = prost::Message::decode(bytes.as_slice())
                .map_err(|e| format!("{f} is not an ONNX model: {e}"))?;
            graphs.push((f.clone(), proto));
        }
        graphs
    };
    for (name, proto) in graphs {
        for threads in [1, 2] {
            let p = profile_tract(proto.clone(), 224, threads, runs)
                .map_err(|e| format!("{name}: {e}"))?;
            println!(
                "{name} @224, {threads} thread(s): {:.2} ms a run (mean of {runs})",
                p.run_ms
            );
            for o in p.ops.iter().filter(|o| o.ms >= 0.05) {
                println!(
                    "  {:8.2} ms  {:5.1} %  {:3} x {}",
                    o.ms,
                    100.0 * o.ms / p.run_ms,
                    o.nodes,
                    o.op
                );
            }
        }
    }
    Ok(())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let done = match args.first().map(String::as_str) {
        Some("--export") => Some(match args.get(1) {
            Some(dir) => export(dir),
            None => Err("--export needs a directory".into()),
        }),
        Some("--profile") => Some(profile(&args[1..], 20)),
        _ => None,
    };
    if let Some(result) = done {
        if let Err(e) = result {
            eprintln!("model_bench: {e}");
            std::process::exit(2);
        }
        return;
    }
    let n: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(50);
    println!("{n} iterations per figure; median / mean in ms");
    let (w, h) = (1920u32, 1200u32);
    let rgb: Vec<u8> = (0..w * h * 3)
        .map(|i| (i.wrapping_mul(2654435761) >> 24) as u8)
        .collect();
    let bayer: Vec<u8> = rgb.iter().step_by(3).copied().collect();
    for (colour, label) in [(Colour::Grey, "grey"), (Colour::Rgb, "rgb")] {
        let cfg = Preprocessing {
            centre: Centre::At([990.0, 600.0]),
            crop_radius_px: 461.0,
            frame_size: Some((w, h)),
            sensor: "bench".into(),
            input_size: 224,
            colour,
            reference: false,
        };
        let mut pre = Preprocessor::new(cfg.clone());
        let mut out = vec![0f32; cfg.tensor_len()];
        for (format, data, fname) in [
            (PixelFormat::Rgb8, &rgb, "RGB8"),
            (PixelFormat::BayerRg8, &bayer, "BayerRG8"),
        ] {
            let frame = FrameRef {
                width: w,
                height: h,
                format,
                data,
                cutout: None,
            };
            let (med, mean) = time(n, || {
                pre.run_into(frame, 0.0, &mut out).expect("preprocess");
            });
            println!("preprocess 1920x1200 {fname} -> 224 {label}: {med:.2} / {mean:.2}");
        }
    }
    for arch in Architecture::ALL {
        let sd = seeded(arch);
        let proto = onnx_graph::build(arch, 3, &sd);
        // The small networks also at 112 px, the shipped models' input size; ResNet-18 at the
        // two smaller input sizes `fringe train --input-size` offers too (fewer multiply-adds).
        let sizes: &[usize] = if arch == Architecture::Resnet18 {
            &[112, 160, 224]
        } else {
            &[112, 224]
        };
        for (&size, threads) in sizes.iter().flat_map(|s| [(s, 1), (s, 2)]) {
            let mut b = TractBackend::new(proto.clone(), 3, threads).expect("backend");
            let input = vec![0.1f32; 3 * size * size];
            let iters = if arch == Architecture::Resnet18 {
                n.min(30)
            } else {
                n
            };
            let (med, mean) = time(iters, || {
                b.run(&input, 1, size as u32).expect("run");
            });
            println!(
                "tract {} batch 1 @{size}, {threads} thread(s): {med:.2} / {mean:.2}",
                arch.name()
            );
        }
        #[cfg(feature = "onnxruntime")]
        {
            use fringe_sensor_models::OrtBackend;
            let bytes = onnx_graph::encode(&proto);
            for threads in [1, 2] {
                let mut b = match OrtBackend::new(&bytes, 3, threads) {
                    Ok(b) => b,
                    Err(e) => {
                        println!("onnxruntime: {e}");
                        break;
                    }
                };
                let input = vec![0.1f32; 3 * 224 * 224];
                let (med, mean) = time(n, || {
                    b.run(&input, 1, 224).expect("run");
                });
                println!(
                    "onnxruntime {} batch 1 @224, {threads} thread(s): {med:.2} / {mean:.2}",
                    arch.name()
                );
            }
        }
    }
    if let Some(py) = std::env::var_os("FRINGE_TORCH_PYTHON") {
        let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/torch_bench.py");
        let status = std::process::Command::new(py)
            .arg(script)
            .arg(n.to_string())
            .status();
        if !status.is_ok_and(|s| s.success()) {
            eprintln!("torch_bench.py failed");
        }
    } else {
        println!("(set FRINGE_TORCH_PYTHON to time PyTorch eager in the same run)");
    }
}
