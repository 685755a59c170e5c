//! Ground truth of a simulated run: what really happened, to score synchronisation, calibration
//! and models against.
//!
//! Records go to a [`TruthSink`]: [`TruthLog`] keeps them in memory (tests), [`TruthWriter`]
//! appends them to a JSON-lines file, one object per line, flushed after every record so a crash
//! loses at most the line being written. Every line has `"kind"`; times are host nanoseconds
//! (`HostTime`, the process's monotonic epoch), device clocks in their own ticks. Kinds and keys:
//!
//! - `bench` (sampled by [`record_bench`], or every period by a [`BenchRecorder`] thread):
//!   `t_ns`; `motor_x_mm`, `motor_y_mm`, `motor_z_mm` (mechanical, from the reverse limits);
//!   `contact_x_mm`, `contact_y_mm` (indenter centre, sensor frame); `depth_mm` (`null` off the disc); `normal_n` (positive = pressing);
//!   `fx_n`..`tz_nm` (true wrench, F/T frame, no noise or bias); `indenter`, `angle_deg`;
//!   `shear_x_n`, `shear_y_n` (tangential force the indenter applies to the surface, sensor
//!   frame), `friction_used` (|Q| / (mu_s P) while sticking, 1 sliding), `sliding`.
//! - `frame` (camera emulator, every exposure): `id`; `exposure_start_ns`, `exposure_end_ns`
//!   (host); `exposure_start_ticks`, `exposure_end_ticks` (device clock); `arrival_ns` (host,
//!   `null` if never delivered); `fate` (`delivered`, `dropped` = lost at random on the link,
//!   `render_busy` = the renderer was still busy, `no_buffer` = the host did not fetch frames);
//!   `contact_force_n`, `contact_x_mm`, `contact_y_mm` (scene at mid-exposure, `null` when no
//!   contact); `shear_x_n`, `shear_y_n` (its tangential force, sensor frame, 0 for a press
//!   without a push) and `slip` (`stick`, `partial_slip`, `gross_slip`), `null` when no contact.
//!   Files written before shear was simulated have none of the three: read as a press without
//!   a push.
//! - `camera_clock`: `t_ns`, `ticks_at_ref`, `ref_ns`, `drift_ppm` (device ticks =
//!   ticks_at_ref + (t - ref) (1 + drift_ppm 1e-6)).
//! - `daq_clock`: `start_ns`, `rate_hz`, `drift_ppm` (sample n is taken at host
//!   start + n / (rate (1 + drift_ppm 1e-6))).
//! - `ft_bias`: `t_ns`, `power_cycle`, `fx_n`..`tz_nm` (power-up bias in effect).

use crate::bench::{Bench, BenchTruth};
use crate::scene::LoadSource;
use fringe_rig::HostTime;
use fringe_rig::Slip;
use fringe_rig::Wrench;
#[cfg(test)]
use std::fs::{File, OpenOptions};
use std::io;
#[cfg(test)]
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// What happened to one exposure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameFate {
    Delivered,
    /// Lost on the link at random (the configured drop probability).
    Dropped,
    /// The renderer was still busy with an earlier frame.
    RenderBusy,
    /// The host's frame buffers were full.
    NoBuffer,
}

impl FrameFate {
    pub fn name(self) -> &'static str {
        match self {
            FrameFate::Delivered => "delivered",
            FrameFate::Dropped => "dropped",
            FrameFate::RenderBusy => "render_busy",
            FrameFate::NoBuffer => "no_buffer",
        }
    }
}

/// One exposure of the simulated camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameTruth {
    pub id: u64,
    pub exposure_start: HostTime,
    pub exposure_end: HostTime,
    pub exposure_start_ticks: u64,
    pub exposure_end_ticks: u64,
    pub arrival: Option<HostTime>,
    pub fate: FrameFate,
    /// Normal force and sensor-frame contact point at mid-exposure, if touching.
    pub contact: Option<(f64, f64, f64)>,
    /// Tangential force on the surface (sensor frame, N) and how the contact holds, at
    /// mid-exposure, if touching.
    pub shear: Option<([f64; 2], Slip)>,
}

/// One ground-truth record.
#[derive(Debug, Clone, PartialEq)]
pub enum TruthRecord {
    Bench {
        truth: BenchTruth,
        wrench: Wrench,
    },
    Frame(FrameTruth),
    CameraClock {
        t: HostTime,
        ticks_at_ref: u64,
        reference: HostTime,
        drift_ppm: f64,
    },
    DaqClock {
        start: HostTime,
        rate_hz: f64,
        drift_ppm: f64,
    },
    FtBias {
        t: HostTime,
        power_cycle: u64,
        bias: Wrench,
    },
}

fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        "null".into()
    }
}

fn wrench_keys(w: &Wrench) -> String {
    let a = w.to_array();
    format!(
        "\"fx_n\":{},\"fy_n\":{},\"fz_n\":{},\"tx_nm\":{},\"ty_nm\":{},\"tz_nm\":{}",
        num(a[0]),
        num(a[1]),
        num(a[2]),
        num(a[3]),
        num(a[4]),
        num(a[5])
    )
}

impl TruthRecord {
    /// The record as one JSON object (no newline).
    pub fn to_json(&self) -> String {
        match self {
            TruthRecord::Bench { truth, wrench } => format!(
                "{{\"kind\":\"bench\",\"t_ns\":{},\"motor_x_mm\":{},\"motor_y_mm\":{},\"motor_z_mm\":{},\
                 \"contact_x_mm\":{},\"contact_y_mm\":{},\"depth_mm\":{},\"normal_n\":{},{},\
                 \"indenter\":\"{}\",\"angle_deg\":{},\"shear_x_n\":{},\"shear_y_n\":{},\
                 \"friction_used\":{},\"sliding\":{}}}",
                truth.t.0,
                num(truth.motors[0].0),
                num(truth.motors[1].0),
                num(truth.motors[2].0),
                num(truth.x.0),
                num(truth.y.0),
                num(truth.depth.0),
                num(truth.normal_force.0),
                wrench_keys(wrench),
                truth.indenter.tip.name(),
                num(truth.indenter.angle_deg),
                num(truth.shear_n[0]),
                num(truth.shear_n[1]),
                num(truth.friction_used),
                truth.sliding
            ),
            TruthRecord::Frame(f) => {
                let (cf, cx, cy) = match f.contact {
                    Some((n, x, y)) => (num(n), num(x), num(y)),
                    None => ("null".into(), "null".into(), "null".into()),
                };
                let (qx, qy, slip) = match f.shear {
                    Some(([qx, qy], slip)) => (num(qx), num(qy), format!("\"{}\"", slip.name())),
                    None => ("null".into(), "null".into(), "null".into()),
                };
                format!(
                    "{{\"kind\":\"frame\",\"id\":{},\"exposure_start_ns\":{},\"exposure_end_ns\":{},\
                     \"exposure_start_ticks\":{},\"exposure_end_ticks\":{},\"arrival_ns\":{},\
                     \"fate\":\"{}\",\"contact_force_n\":{},\"contact_x_mm\":{},\"contact_y_mm\":{},\
                     \"shear_x_n\":{},\"shear_y_n\":{},\"slip\":{}}}",
                    f.id,
                    f.exposure_start.0,
                    f.exposure_end.0,
                    f.exposure_start_ticks,
                    f.exposure_end_ticks,
                    f.arrival.map_or("null".into(), |a| a.0.to_string()),
                    f.fate.name(),
                    cf,
                    cx,
                    cy,
                    qx,
                    qy,
                    slip
                )
            }
            TruthRecord::CameraClock {
                t,
                ticks_at_ref,
                reference,
                drift_ppm,
            } => format!(
                "{{\"kind\":\"camera_clock\",\"t_ns\":{},\"ticks_at_ref\":{},\"ref_ns\":{},\"drift_ppm\":{}}}",
                t.0,
                ticks_at_ref,
                reference.0,
                num(*drift_ppm)
            ),
            TruthRecord::DaqClock {
                start,
                rate_hz,
                drift_ppm,
            } => format!(
                "{{\"kind\":\"daq_clock\",\"start_ns\":{},\"rate_hz\":{},\"drift_ppm\":{}}}",
                start.0,
                num(*rate_hz),
                num(*drift_ppm)
            ),
            TruthRecord::FtBias {
                t,
                power_cycle,
                bias,
            } => format!(
                "{{\"kind\":\"ft_bias\",\"t_ns\":{},\"power_cycle\":{},{}}}",
                t.0,
                power_cycle,
                wrench_keys(bias)
            ),
        }
    }
}

impl FrameTruth {
    /// A `frame` line of a ground-truth file; `None` for other kinds or a line that is not one.
    pub fn from_json(line: &str) -> Option<FrameTruth> {
        let v: serde_json::Value = serde_json::from_str(line).ok()?;
        if v.get("kind")?.as_str()? != "frame" {
            return None;
        }
        let u = |key: &str| v.get(key).and_then(serde_json::Value::as_u64);
        let f = |key: &str| v.get(key).and_then(serde_json::Value::as_f64);
        let fate = match v.get("fate")?.as_str()? {
            "delivered" => FrameFate::Delivered,
            "dropped" => FrameFate::Dropped,
            "render_busy" => FrameFate::RenderBusy,
            "no_buffer" => FrameFate::NoBuffer,
            _ => return None,
        };
        let contact = match (f("contact_force_n"), f("contact_x_mm"), f("contact_y_mm")) {
            (Some(n), Some(x), Some(y)) => Some((n, x, y)),
            _ => None,
        };
        // Older files have no shear keys: a contact there is a press without a push.
        let slip = v.get("slip").and_then(serde_json::Value::as_str);
        let shear = match (contact, slip) {
            (None, _) => None,
            (Some(_), None) => Some(([0.0; 2], Slip::Stick)),
            (Some(_), Some(name)) => Some((
                [f("shear_x_n").unwrap_or(0.0), f("shear_y_n").unwrap_or(0.0)],
                Slip::named(name)?,
            )),
        };
        Some(FrameTruth {
            id: u("id")?,
            exposure_start: HostTime(u("exposure_start_ns")?),
            exposure_end: HostTime(u("exposure_end_ns")?),
            exposure_start_ticks: u("exposure_start_ticks")?,
            exposure_end_ticks: u("exposure_end_ticks")?,
            arrival: u("arrival_ns").map(HostTime),
            fate,
            contact,
            shear,
        })
    }
}

/// The frame records of a ground-truth file (a run's `truth.jsonl`); lines of other kinds are
/// passed over.
pub fn read_frames(path: &Path) -> Result<Vec<FrameTruth>, TruthError> {
    let text = std::fs::read_to_string(path).map_err(|source| TruthError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(text.lines().filter_map(FrameTruth::from_json).collect())
}

/// Somewhere ground truth goes. Called from several emulator threads.
pub trait TruthSink: Send + Sync {
    fn record(&self, record: TruthRecord);
}

/// The ground truth's file inside a simulated run.
pub const TRUTH_FILE: &str = "truth.jsonl";

/// Ground truth kept in memory.
#[derive(Debug, Default)]
pub struct TruthLog {
    records: Mutex<Vec<TruthRecord>>,
}

impl TruthLog {
    pub fn new() -> Arc<TruthLog> {
        Arc::new(TruthLog::default())
    }

    /// A copy of every record so far.
    pub fn records(&self) -> Vec<TruthRecord> {
        self.records
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// The frame records so far.
    pub fn frames(&self) -> Vec<FrameTruth> {
        self.records()
            .into_iter()
            .filter_map(|r| match r {
                TruthRecord::Frame(f) => Some(f),
                _ => None,
            })
            .collect()
    }
}

impl TruthSink for TruthLog {
    fn record(&self, record: TruthRecord) {
        self.records
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(record);
    }
}

/// Errors writing ground truth, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum TruthError {
    #[error("ground truth file {path}: {source} (check the directory exists and is writable)")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
}

/// Ground truth appended to a JSON-lines file, flushed per record.
#[cfg(test)]
pub(crate) struct TruthWriter {
    path: PathBuf,
    out: Mutex<BufWriter<File>>,
    /// The first write error, kept because [`TruthSink::record`] cannot return it.
    error: Mutex<Option<String>>,
}

#[cfg(test)]
impl TruthWriter {
    /// Opens (creates or appends to) `path`.
    pub(crate) fn create(path: &Path) -> Result<Arc<TruthWriter>, TruthError> {
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|source| TruthError::Io {
                path: path.to_path_buf(),
                source,
            })?;
        Ok(Arc::new(TruthWriter {
            path: path.to_path_buf(),
            out: Mutex::new(BufWriter::new(file)),
            error: Mutex::new(None),
        }))
    }

    /// The first error met while writing, if any (e.g. disk full).
    pub(crate) fn error(&self) -> Option<String> {
        self.error.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

#[cfg(test)]
impl TruthSink for TruthWriter {
    fn record(&self, record: TruthRecord) {
        let line = record.to_json();
        let mut out = self.out.lock().unwrap_or_else(|e| e.into_inner());
        let result = writeln!(out, "{line}").and_then(|_| out.flush());
        if let Err(e) = result {
            let mut err = self.error.lock().unwrap_or_else(|e| e.into_inner());
            if err.is_none() {
                *err = Some(format!("ground truth file {}: {e}", self.path.display()));
            }
        }
    }
}

/// Records the bench's true state at `t` into `sink`.
pub(crate) fn record_bench(bench: &Bench, sink: &dyn TruthSink, t: HostTime) {
    let truth = bench.truth_at(t);
    // What the F/T truly feels, a push included.
    let wrench = bench.true_wrench_at(t);
    sink.record(TruthRecord::Bench { truth, wrench });
}

/// A thread recording the bench's true state at a fixed period until dropped or stopped.
pub(crate) struct BenchRecorder {
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl BenchRecorder {
    /// Records `bench` into `sink` every `period` (e.g. 1 ms) from now on.
    pub(crate) fn spawn(
        bench: Arc<Bench>,
        sink: Arc<dyn TruthSink>,
        period: std::time::Duration,
    ) -> io::Result<BenchRecorder> {
        use std::sync::atomic::{AtomicBool, Ordering};
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let period_ns = period.as_nanos().max(1) as u64;
        let thread = std::thread::Builder::new()
            .name("sim-truth-bench".into())
            .spawn(move || {
                let mut next = HostTime::now();
                while !flag.load(Ordering::Relaxed) {
                    record_bench(&bench, sink.as_ref(), next);
                    next = HostTime(next.0 + period_ns);
                    let now = HostTime::now();
                    if next > now {
                        std::thread::sleep(next.since(now));
                    }
                }
            })?;
        Ok(BenchRecorder {
            stop,
            thread: Some(thread),
        })
    }

    /// Stops recording and waits for the thread.
    pub(crate) fn stop(mut self) {
        self.finish();
    }

    fn finish(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for BenchRecorder {
    fn drop(&mut self) {
        self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::BenchConfig;

    #[test]
    fn writer_appends_one_flushed_json_line_per_record() {
        let dir = std::env::temp_dir().join(format!("fringe-truth-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("truth.jsonl");
        let _ = std::fs::remove_file(&path);
        let bench = Bench::new(BenchConfig::default());
        let w = TruthWriter::create(&path).expect("create");
        record_bench(&bench, w.as_ref(), HostTime::now());
        w.record(TruthRecord::Frame(FrameTruth {
            id: 7,
            exposure_start: HostTime(10),
            exposure_end: HostTime(2_000_010),
            exposure_start_ticks: 5,
            exposure_end_ticks: 2_000_005,
            arrival: None,
            fate: FrameFate::RenderBusy,
            contact: None,
            shear: None,
        }));
        // Read while the writer is still open: flushed per record.
        let text = std::fs::read_to_string(&path).expect("read");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2, "{text}");
        assert!(
            lines[0].starts_with("{\"kind\":\"bench\",\"t_ns\":"),
            "{}",
            lines[0]
        );
        assert!(lines[0].contains("\"indenter\":\"pentagon\""));
        assert!(lines[0].contains("\"normal_n\":0,"), "{}", lines[0]);
        assert!(lines[1].contains("\"fate\":\"render_busy\""));
        assert!(lines[1].contains("\"arrival_ns\":null"));
        assert!(lines[1].ends_with('}'));
        assert!(w.error().is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn frame_lines_read_back_as_written() {
        let frames = [
            FrameTruth {
                id: 12,
                exposure_start: HostTime(1_000),
                exposure_end: HostTime(2_001_000),
                exposure_start_ticks: 987_654_321,
                exposure_end_ticks: 989_654_321,
                arrival: Some(HostTime(9_000_000)),
                fate: FrameFate::Delivered,
                contact: Some((3.25, -2.5, 0.125)),
                shear: Some(([1.5, -0.25], Slip::PartialSlip)),
            },
            FrameTruth {
                id: 14,
                exposure_start: HostTime(1_000),
                exposure_end: HostTime(2_001_000),
                exposure_start_ticks: 987_654_321,
                exposure_end_ticks: 989_654_321,
                arrival: Some(HostTime(9_000_000)),
                fate: FrameFate::Delivered,
                contact: Some((3.25, -2.5, 0.125)),
                shear: Some(([0.0, 0.0], Slip::Stick)),
            },
            FrameTruth {
                id: 13,
                exposure_start: HostTime(20_001_000),
                exposure_end: HostTime(22_001_000),
                exposure_start_ticks: 1_007_654_321,
                exposure_end_ticks: 1_009_654_321,
                arrival: None,
                fate: FrameFate::RenderBusy,
                contact: None,
                shear: None,
            },
        ];
        for f in frames {
            let line = TruthRecord::Frame(f).to_json();
            assert_eq!(FrameTruth::from_json(&line), Some(f), "{line}");
        }
        // A line written before shear was simulated: a contact there is a press without a push.
        let old = "{\"kind\":\"frame\",\"id\":3,\"exposure_start_ns\":1,\"exposure_end_ns\":2,\
                   \"exposure_start_ticks\":1,\"exposure_end_ticks\":2,\"arrival_ns\":5,\
                   \"fate\":\"delivered\",\"contact_force_n\":2.0,\"contact_x_mm\":1.0,\"contact_y_mm\":0.5}";
        let read = FrameTruth::from_json(old).expect("an old frame line");
        assert_eq!(read.contact, Some((2.0, 1.0, 0.5)));
        assert_eq!(read.shear, Some(([0.0, 0.0], Slip::Stick)));
        let bench = Bench::new(BenchConfig::default());
        let log = TruthLog::new();
        record_bench(&bench, log.as_ref(), HostTime(5));
        let line = log.records()[0].to_json();
        assert_eq!(
            FrameTruth::from_json(&line),
            None,
            "a bench line is not a frame"
        );
        assert_eq!(FrameTruth::from_json("{\"kind\":\"frame\",\"id\""), None);
    }

    #[test]
    fn recorder_samples_the_bench_at_its_period() {
        let bench = Bench::new(BenchConfig::default());
        let log = TruthLog::new();
        let started = std::time::Instant::now();
        let rec = BenchRecorder::spawn(bench, log.clone(), std::time::Duration::from_millis(2))
            .expect("spawn");
        std::thread::sleep(std::time::Duration::from_millis(100));
        rec.stop();
        // The sleep and the stop overrun by however long a loaded machine makes them: at one
        // record per 2 ms, no more records than the time that really passed holds.
        let most = started.elapsed().as_millis() as usize / 2 + 2;
        let times: Vec<u64> = log
            .records()
            .iter()
            .filter_map(|r| match r {
                TruthRecord::Bench { truth, .. } => Some(truth.t.0),
                _ => None,
            })
            .collect();
        assert!(
            times.len() >= 20 && times.len() <= most,
            "{} records (at most {most})",
            times.len()
        );
        assert!(times.windows(2).all(|p| p[1] - p[0] == 2_000_000));
    }
}
