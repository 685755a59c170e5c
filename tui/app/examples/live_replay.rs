//! Live validation on a bench whose camera costs no rendering: a recorded run's frames offered
//! to live validation at the camera's rate, as the recorder offers a real camera's frames.
//!
//! On the simulated bench the renderer draws every frame on the same two cores as the model, so
//! the frames `fringe validate` skips there include those the renderer took the time of. Here a
//! "camera and recorder" thread takes each of the run's frames (decoded beforehand), encodes and
//! writes it as the run stores it (the recorder's work on a real bench; to a scratch file in the
//! temporary directory, replaced frame after frame) and hands it with its record to the same
//! [`LiveValidation`] worker at the run's own frame times (`--fps` instead sets the rate), never
//! waiting for the worker: a frame that comes while the worker is busy waits in its queue, and
//! when the queue is full the oldest waiting frame is counted as skipped, exactly as in a scan
//! (`--backlog` sets the queue's length, [`BACKLOG_FRAMES`] by default; 1 keeps only the newest).
//!
//! ```sh
//! cargo build --release -p fringe-app --example live_replay
//! fringe validate --no-tui --yes --out vruns                 # a run of the main job at 50 fps
//! target/release/examples/live_replay vruns/<id> builtin:layered-two-stage [--threads N] [--fps F] [--backlog N]
//! ```
//!
//! Prints frames offered, run and skipped, the latency of a frame (preprocessing and inference:
//! median, 95th percentile, largest), how long frames waited in the queue, how late the offering thread fell behind the frame times,
//! and the share of one core the offering thread used.

use fringe_app::session::{FrameSource, LiveValidation, BACKLOG_FRAMES, THREADS_PER_NETWORK};
use fringe_rig::store::FrameRecord;
use fringe_rig::store::RunReader;
use fringe_rig::store::{in_whole_frame, FrameStorage, StoredFrame};
use fringe_rig::Frame;
use fringe_rig::HostTime;
use fringe_sensor_models::builtin;
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::Predictor;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

struct Args {
    run: PathBuf,
    model: PathBuf,
    threads: usize,
    fps: Option<f64>,
    backlog: usize,
}

fn parse() -> Result<Args, String> {
    let mut positional = Vec::new();
    let mut threads = THREADS_PER_NETWORK;
    let mut fps = None;
    let mut backlog = BACKLOG_FRAMES;
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--threads" => {
                let v = value("--threads")?;
                threads = v
                    .parse()
                    .map_err(|_| format!("--threads {v}: give a whole number of threads"))?;
            }
            "--fps" => {
                let v = value("--fps")?;
                let f: f64 = v
                    .parse()
                    .map_err(|_| format!("--fps {v}: give frames per second"))?;
                if !(f > 0.0 && f.is_finite()) {
                    return Err(format!("--fps {v}: give a positive rate"));
                }
                fps = Some(f);
            }
            "--backlog" => {
                let v = value("--backlog")?;
                backlog = v.parse().ok().filter(|&n: &usize| n >= 1).ok_or(format!(
                    "--backlog {v}: give a whole number of frames, 1 or more"
                ))?;
            }
            _ if a.starts_with("--") => return Err(format!("unknown option {a}")),
            _ => positional.push(PathBuf::from(a)),
        }
    }
    let [run, model] = <[PathBuf; 2]>::try_from(positional).map_err(|_| {
        "usage: live_replay RUN_DIR MODEL [--threads N] [--fps F] [--backlog N]".to_string()
    })?;
    Ok(Args {
        run,
        model,
        threads,
        fps,
        backlog,
    })
}

/// The camera's frame as it was delivered: a stored cutout goes back to its place in a frame of
/// the camera's size (black outside it, where no crop of the run's profile reads).
fn as_delivered(
    stored: StoredFrame,
    record: &FrameRecord,
    arrival: HostTime,
    path: &std::path::Path,
) -> Result<Frame, String> {
    let (width, height, data) = match stored.cutout {
        None => (stored.width, stored.height, stored.data),
        Some(c) => {
            let bpp = stored.format.bytes_per_pixel();
            let full = in_whole_frame(&stored.data, stored.width, bpp, c).ok_or(format!(
                "{}: its cutout does not fit the frame the run names",
                path.display()
            ))?;
            (c.frame_width, c.frame_height, full)
        }
    };
    Ok(Frame {
        id: record.frame_id,
        device_timestamp: record.device_timestamp,
        host_arrival: arrival,
        width,
        height,
        format: stored.format,
        data,
    })
}

/// Every frame of the run decoded before the replay starts (on every core), so that the replay
/// costs what a bench costs: decoding is 2.6 times the encoder's work (BENCHMARKS.md, "A faster
/// encoder"), which the replay does instead.
fn decode_all(
    run: &RunReader,
    storage: &FrameStorage,
    records: &[FrameRecord],
) -> Result<Vec<Frame>, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = records.len().div_ceil(cores).max(1);
    let t0 = Instant::now();
    let parts: Vec<Result<Vec<Frame>, String>> = std::thread::scope(|s| {
        let handles: Vec<_> = records
            .chunks(chunk)
            .map(|part| {
                s.spawn(move || {
                    part.iter()
                        .map(|r| {
                            let path = run.frame_path(r);
                            let stored = storage.read(&path).map_err(|e| e.to_string())?;
                            as_delivered(stored, r, HostTime::now(), &path)
                        })
                        .collect()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err("a decoding thread panicked".into()))
            })
            .collect()
    });
    let mut frames = Vec::with_capacity(records.len());
    for p in parts {
        frames.extend(p?);
    }
    println!(
        "decoded {} frames in {:.1} s",
        frames.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(frames)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

/// CPU time of the calling thread (user and system), from procfs (Linux; 100 clock ticks a
/// second).
fn thread_cpu() -> Duration {
    let text = std::fs::read_to_string("/proc/thread-self/stat").unwrap_or_default();
    // Fields after the command's closing parenthesis: utime and stime are the 12th and 13th.
    let after = text.rsplit_once(')').map_or("", |(_, rest)| rest);
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0)
    };
    // Clock ticks are 100 per second on Linux.
    Duration::from_millis((ticks(11) + ticks(12)) * 10)
}

fn run(a: Args) -> Result<(), String> {
    let run = RunReader::at(&a.run);
    let start = run.start().map_err(|e| e.to_string())?;
    let storage = start.frame_storage();
    let source = fringe_sensor_models::dataset::read(&a.run).map_err(|e| e.to_string())?;
    let profile = source.profile.ok_or(format!(
        "{}: the run names no calibration profile to crop its frames with",
        a.run.display()
    ))?;
    let records = run.frames().map_err(|e| e.to_string())?;
    let model = builtin::open(&a.model).map_err(|e| e.to_string())?;
    let predictor =
        Predictor::new(&model, BackendKind::Tract, a.threads).map_err(|e| e.to_string())?;
    println!(
        "run {}: {} frames; model {} ({}), tract, {} thread(s) per network, at most {} frame(s) waiting",
        a.run.display(),
        records.len(),
        model.path.display(),
        model.describe(),
        a.threads,
        a.backlog
    );
    let (live, tap) = LiveValidation::start(
        model,
        predictor,
        FrameSource {
            run_id: start.run_id.clone(),
            profile,
        },
        a.backlog,
    )
    .map_err(|e| e.to_string())?;
    let frames = decode_all(&run, &storage, &records)?;
    let scratch = std::env::temp_dir().join(format!("fringe-live-replay-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    let first_ns = records.first().map_or(0, |r| r.host_arrival_ns);
    let due = |i: usize, r: &FrameRecord| match a.fps {
        Some(f) => Duration::from_secs_f64(i as f64 / f),
        None => Duration::from_nanos(r.host_arrival_ns.saturating_sub(first_ns)),
    };
    let t0 = Instant::now();
    let cpu0 = thread_cpu();
    let mut late = Vec::with_capacity(records.len());
    for (i, (record, mut frame)) in records.iter().zip(frames).enumerate() {
        let at = due(i, record);
        let now = t0.elapsed();
        if now < at {
            std::thread::sleep(at - now);
        } else {
            late.push((now - at).as_secs_f64() * 1e3);
        }
        frame.host_arrival = HostTime::now();
        // The recorder's work on every frame: encoded and written as the run stores it.
        let file = scratch.join(format!("frame.{}", storage.encoding.extension()));
        storage.write(&frame, &file).map_err(|e| e.to_string())?;
        tap.recorded(&frame, record);
    }
    let wall = t0.elapsed();
    let cpu = thread_cpu().saturating_sub(cpu0);
    let v = live.finish(Duration::from_secs(10));
    let s = &v.state;
    let mut lat: Vec<f64> = v.frames.iter().map(|f| f.latency_ms).collect();
    lat.sort_by(f64::total_cmp);
    let mut waited: Vec<f64> = v.frames.iter().map(|f| f.waited_ms).collect();
    waited.sort_by(f64::total_cmp);
    late.sort_by(f64::total_cmp);
    println!(
        "offered {}, run {}, skipped {} ({:.1} %), {:.1} predictions/s over {:.1} s",
        s.offered,
        s.ran,
        s.skipped,
        100.0 * s.skipped as f64 / s.offered.max(1) as f64,
        s.ran as f64 / wall.as_secs_f64(),
        wall.as_secs_f64()
    );
    println!(
        "latency per frame, ms: median {:.1}, 95th percentile {:.1}, largest {:.1}",
        percentile(&lat, 0.5),
        percentile(&lat, 0.95),
        lat.last().copied().unwrap_or(f64::NAN)
    );
    println!(
        "waited for the worker, ms: median {:.1}, 95th percentile {:.1}, largest {:.1}",
        percentile(&waited, 0.5),
        percentile(&waited, 0.95),
        waited.last().copied().unwrap_or(f64::NAN)
    );
    println!(
        "offering thread: {:.0} % of a core; behind the frame times {} times (largest {:.1} ms)",
        100.0 * cpu.as_secs_f64() / wall.as_secs_f64(),
        late.len(),
        late.last().copied().unwrap_or(0.0)
    );
    let _ = std::fs::remove_dir_all(&scratch);
    if let Some(why) = &s.failure {
        return Err(format!("live validation stopped: {why}"));
    }
    Ok(())
}

fn main() -> ExitCode {
    match parse().and_then(run) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
