//! Acquisition throughput: full 1920x1200 frames at 50 Hz plus the 5 kHz force stream recorded
//! into a run, with the simulated camera rendering in the same process.
//!
//! `cargo run --release -p fringe-sim --example record_bench -- [SECONDS] [--rgb] [--disc] [--png] [--keep-frames] [--keep-run]`
//! (default 600 s; the camera delivers its native BayerRG8 mosaic, one byte per pixel, stored in
//! FGL as a scan stores it; `--rgb`: on-camera interpolated RGB8 instead, in an RGB PNG;
//! `--disc`: only the square around the disc is stored, with the rig file's default margin;
//! `--png`: the mosaic as colour planes in PNG, as `[recording] codec = "png"` stores it). The
//! simulated bench presses the layered sensor with the pentagon at about
//! 4 N (so every frame has fringes to render and to compress); the force stream, the camera
//! stream and the recorder (strobe labels, lossless frames, the raw force log, frame records)
//! run on their own threads as in a scan, filming all the time. Every 10 s it prints the counts;
//! at the end: frames rendered, recorded and dropped, force samples received and lost, bytes
//! stored and the storage rate, and the process's CPU time as a share of the two cores.
//!
//! 50 frames/s of 1 MB frames is about 50 MB/s, 30 GB in 10 minutes: more than the build
//! machine's free disk. Unless `--keep-frames` is given, a frame's file is deleted once it has
//! been written and counted (everything else of the run is kept); the encoding, writing and
//! fsync work is all done.
//! Exits non-zero if a frame is dropped or a force sample lost.

use fringe_rig::scan::{labeler_for, LATCH_PERIOD};
use fringe_rig::store::{now_utc, Position, StartDocument, LAYOUT_VERSION};
use fringe_rig::store::{FrameCodec, FrameStorage, DISC_MARGIN_PX};
use fringe_rig::store::{RunFile, RunReader, RunWriter};
use fringe_rig::CameraStream;
use fringe_rig::ForceStream;
use fringe_rig::Millimetres;
use fringe_rig::SyncMethod;
use fringe_rig::{CameraSettings, PixelFormat};
use fringe_rig::{Filming, FrameContext, Recorder};
use fringe_sim::{ground_truth::FrameFate, TruthLog, TruthSink};
use fringe_sim::{SimRig, SimRigConfig};
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// User plus system CPU time of this process so far, s.
fn cpu_s() -> f64 {
    // SAFETY: getrusage only writes the struct we pass.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    s(usage.ru_utime) + s(usage.ru_stime)
}

/// Bytes of the files under `dir` (recursively).
fn bytes_in(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .filter_map(Result::ok)
        .map(|e| match e.metadata() {
            Ok(m) if m.is_dir() => bytes_in(&e.path()),
            Ok(m) => m.len(),
            Err(_) => 0,
        })
        .sum()
}

/// Deletes finished frame files, adding their sizes to `bytes`.
fn reap_frames(dir: &Path, bytes: &mut u64) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.filter_map(Result::ok) {
        let path = e.path();
        if path.extension().is_some_and(|x| x == "png" || x == "fgl") {
            if let Ok(m) = e.metadata() {
                if std::fs::remove_file(&path).is_ok() {
                    *bytes += m.len();
                }
            }
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let keep = args.iter().any(|a| a == "--keep-frames");
    let rgb = args.iter().any(|a| a == "--rgb");
    let disc = args.iter().any(|a| a == "--disc");
    let codec = args.iter().any(|a| a == "--png").then_some(FrameCodec::Png);
    let seconds: f64 = match args.iter().find(|a| !a.starts_with("--")) {
        Some(a) => a.parse()?,
        None => 600.0,
    };
    let config = SimRigConfig::default();
    let truth = TruthLog::new();
    let (rig, devices) = SimRig::start(&config, Some(truth.clone() as Arc<dyn TruthSink>))?;
    let geometry = rig.bench.config().geometry;
    let mut z = devices.z;
    let mut x = devices.x;
    let mut y = devices.y;
    println!("homing and pressing the sensor...");
    for axis in [&mut x, &mut y, &mut z] {
        axis.home(Duration::from_secs(60))?;
    }
    x.move_to(
        Millimetres(geometry.x_centre_mm + 2.0),
        Duration::from_secs(60),
    )?;
    y.move_to(
        Millimetres(geometry.y_centre_mm - 1.0),
        Duration::from_secs(60),
    )?;
    // About 0.35 mm into the gel: a few newtons with the pentagon.
    z.move_to(
        Millimetres(geometry.z_touch_mm + 0.35),
        Duration::from_secs(60),
    )?;

    let pixel_format = if rgb {
        PixelFormat::Rgb8
    } else {
        CameraSettings::default().pixel_format
    };
    let g = &config.sensor.geometry;
    let cutout = if disc {
        Some(FrameStorage::disc_square(
            [
                f64::from(g.width) / 2.0 + g.centre_offset_px[0],
                f64::from(g.height) / 2.0 + g.centre_offset_px[1],
            ],
            g.disc_radius_px,
            DISC_MARGIN_PX,
            g.width,
            g.height,
        )?)
    } else {
        None
    };
    let root = std::env::temp_dir().join(format!("fringe-record-bench-{}", std::process::id()));
    let start = StartDocument {
        layout_version: LAYOUT_VERSION,
        run_id: "record-bench".into(),
        started_utc: now_utc(),
        software: format!("fringe {} record_bench", env!("CARGO_PKG_VERSION")),
        sensor_id: config.sensor.id.clone(),
        variant: Some(config.sensor.variant.name().into()),
        plan: String::new(),
        rig: "simulated bench".into(),
        calibration_profile: None,
        seed: Some(config.seed),
        ft_axes: None,
        sync_method: "strobe".into(),
        frames: Some(FrameStorage::new(pixel_format, cutout)?.with_codec(codec)?),
    };
    let writer = RunWriter::create(&root, &start)?;
    let run_dir = writer.dir().to_path_buf();
    let stream = ForceStream::spawn(devices.force)?;
    let monitor = stream.monitor();
    let settings = CameraSettings {
        pixel_format,
        ..CameraSettings::default()
    };
    let tick_hz = devices.camera.info().tick_frequency as f64;
    let cameras = CameraStream::spawn_with_latches(devices.camera, &settings, LATCH_PERIOD)?;
    let context = FrameContext::default();
    let here = Position {
        x: Millimetres(geometry.x_centre_mm + 2.0),
        y: Millimetres(geometry.y_centre_mm - 1.0),
        z: Millimetres(geometry.z_touch_mm + 0.35),
    };
    context.set(Some(Filming {
        point: 0,
        commanded: here,
        measured: here,
        contact: [2.0, -1.0],
        shape: "pentagon".into(),
        tare: [0.0; 6],
        slide: None,
    }));
    let recorder = Recorder::spawn(
        writer,
        stream.samples().clone(),
        cameras.frames().clone(),
        labeler_for(SyncMethod::Strobe, None, &settings, tick_hz, &cameras)?,
        context.clone(),
        Vec::new(),
    )?;

    let cpu0 = cpu_s();
    let t0 = Instant::now();
    let mut reaped = 0u64;
    let mut next_report = 10.0;
    let frame_dir = RunReader::at(&run_dir).path(RunFile::FrameDir);
    while t0.elapsed().as_secs_f64() < seconds {
        std::thread::sleep(Duration::from_millis(500));
        if !keep {
            reap_frames(&frame_dir, &mut reaped);
        }
        let t = t0.elapsed().as_secs_f64();
        if t >= next_report {
            let s = recorder.stats();
            println!(
                "{t:6.0} s: {} frames recorded, {} dropped, {:.1} fps; {} force samples, {} lost; CPU {:.0} % of 2 cores",
                s.frames_recorded,
                s.dropped_frames,
                s.frame_rate_hz,
                monitor.stats().received,
                monitor.stats().lost,
                (cpu_s() - cpu0) / t / 2.0 * 100.0
            );
            next_report += 10.0;
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let cpu = cpu_s() - cpu0;
    context.set(None);
    let camera_result = cameras.stop();
    let force_stats = monitor.stats();
    let force_result = stream.stop();
    let (mut writer, stats) = recorder.finish()?;
    writer.checkpoint()?;
    camera_result?;
    force_result?;
    if !keep {
        reap_frames(&frame_dir, &mut reaped);
    }
    let stored = bytes_in(&run_dir) + reaped;
    println!(
        "--- {wall:.1} s of recording, 1920x1200 {} frames, layered sensor pressed",
        if rgb { "RGB8" } else { "BayerRG8" }
    );
    println!(
        "frames: {} seen, {} recorded with a label, {} without, {} dropped by the camera",
        stats.frames_seen, stats.frames_recorded, stats.frames_unlabelled, stats.dropped_frames
    );
    let fates = truth.frames();
    let count = |f: FrameFate| fates.iter().filter(|t| t.fate == f).count();
    println!(
        "camera (simulator's truth): {} exposures, {} delivered, {} dropped while the renderer was busy, {} for want of host buffers",
        fates.len(),
        count(FrameFate::Delivered),
        count(FrameFate::RenderBusy),
        count(FrameFate::NoBuffer)
    );
    println!(
        "force: {} samples received ({:.1} Hz), {} lost, {} in force.bin",
        force_stats.received,
        force_stats.received as f64 / wall,
        force_stats.lost,
        writer.force_samples()
    );
    println!(
        "stored {:.2} GB ({:.1} MB/s){}",
        stored as f64 / 1e9,
        stored as f64 / 1e6 / wall,
        if keep {
            ""
        } else {
            " (frame files deleted after writing)"
        }
    );
    println!(
        "CPU: {cpu:.1} s over {wall:.1} s = {:.0} % of the 2 cores",
        cpu / wall / 2.0 * 100.0
    );
    if args.iter().any(|a| a == "--keep-run") {
        println!("run kept in {}", run_dir.display());
    } else {
        let _ = std::fs::remove_dir_all(&root);
    }
    drop(rig);
    if stats.dropped_frames > 0 || force_stats.lost > 0 {
        return Err(format!(
            "{} frames dropped, {} force samples lost",
            stats.dropped_frames, force_stats.lost
        )
        .into());
    }
    Ok(())
}
