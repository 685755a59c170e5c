//! The three synchronisation methods scored against the simulator's ground truth over a longer
//! run: label-time RMS and max error, frames scored, and the labelled Fz error during presses.
//!
//! `cargo run --release -p fringe-sim --example sync_bench -- [SECONDS] [JITTER_MS] [DRIFT_PPM] [trigger]`
//! (defaults 120 s, 3 ms, 100 ppm: camera clock slow and DAQ clock fast by DRIFT_PPM, frames and
//! force blocks arriving 0-JITTER_MS late, 5 ms camera readout, 1 mm presses every 2 s; `trigger`:
//! the camera triggered by the DAQ's counter, and the `trigger` method scored too).

use fringe_sim::ground_truth;
use fringe_sim::ground_truth::SyncBenchConfig;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: f64| -> Result<f64, String> {
        args.get(i).map_or(Ok(default), |a| {
            a.parse::<f64>()
                .map_err(|e| format!("argument {} ({a:?}): {e}", i + 1))
        })
    };
    let config = SyncBenchConfig {
        seconds: arg(0, 120.0)?,
        arrival_jitter_ms: arg(1, 3.0)?,
        camera_drift_ppm: arg(2, 100.0)?,
        force_drift_ppm: -arg(2, 100.0)?,
        daq_trigger: args.get(3).is_some_and(|a| a == "trigger"),
        ..SyncBenchConfig::default()
    };
    println!(
        "{} s scored after {} s warm-up; arrival jitter 0-{} ms (frames and force blocks); \
         camera clock {:+} ppm, DAQ clock {:+} ppm; readout {} ms; {} mm presses every {} s",
        config.seconds,
        config.warm_up_s,
        config.arrival_jitter_ms,
        config.camera_drift_ppm,
        config.force_drift_ppm,
        config.readout_ms,
        config.press_depth_mm,
        config.press_period_s
    );
    let report = ground_truth::run_sync_bench(&config)?;
    println!(
        "{} frames delivered while scoring, {} force samples{}",
        report.frames_delivered,
        report.force_samples,
        report
            .latch_error
            .as_ref()
            .map_or(String::new(), |e| format!("; latch failed: {e}"))
    );
    println!(
        "{:<10} {:>7} {:>6} {:>12} {:>12} {:>12} {:>8} {:>10} {:>10} {:>12}",
        "method",
        "frames",
        "unlab",
        "time RMS us",
        "time max us",
        "mean us",
        "pressed",
        "Fz RMS N",
        "Fz max N",
        "estimate us"
    );
    for s in &report.scores {
        println!(
            "{:<10} {:>7} {:>6} {:>12.1} {:>12.1} {:>+12.1} {:>8} {:>10.4} {:>10.4} {:>12}",
            s.method.name(),
            s.frames,
            s.unlabelled,
            s.time_rms_ns / 1e3,
            s.time_max_ns / 1e3,
            s.time_mean_ns / 1e3,
            s.fz_frames,
            s.fz_rms_n,
            s.fz_max_n,
            s.estimated_error_ns
                .map_or("-".to_string(), |e| format!("{:.1}", e / 1e3))
        );
    }
    for s in &report.scores {
        if let Some(why) = &s.first_unlabelled {
            println!("{}: first unlabelled {why}", s.method.name());
        }
    }
    Ok(())
}
