//! A calibration scan's run directory, read for calibration: the no-contact frames (the unloaded
//! background), the frames of each press's dwell with the stage position that pressed them, and
//! the no-contact force windows the scan measured before every point.
//!
//! The scan engine writes the run (`fringe_rig::store`); this module only reads it. Frame
//! selection rules:
//! - background: valid frames labelled shape "None" (|Fz| under the 0.2 N noise floor);
//! - a press: the valid in-contact frames of one grid point whose (tared) Fz is within 15 % of
//!   the point's highest, that is the dwell at the top force target, less two frames at each
//!   end, at most [`PRESS_FRAMES`] of them, spread over the dwell;
//! - force offsets: the raw force samples of the 100 ms before each `force-offset` event (the
//!   engine measures the offset there, at the safe height, before every point).

use crate::offsets::{self, Bias};
use fringe_rig::reference_layout::NO_CONTACT;
use fringe_rig::store::{Event, FrameRecord, StartDocument};
use fringe_rig::store::{RunFile, RunReader, StoreError};
use fringe_rig::Wrench;
use std::path::{Path, PathBuf};

/// Frames averaged per press at most.
pub(crate) const PRESS_FRAMES: usize = 8;
/// Length of the no-contact window before each offset event, s.
const OFFSET_WINDOW_S: f64 = 0.1;
/// A press frame's Fz must be at least this share of the point's highest.
const DWELL_SHARE: f64 = 0.85;
/// Frames left out at each end of a press's dwell.
const DWELL_EDGE_FRAMES: usize = 2;

/// The frames of one press.
#[derive(Debug, Clone, PartialEq)]
pub struct Press {
    /// Grid point (scan program index).
    pub point: u64,
    /// Measured stage position of the press, mm.
    pub stage_mm: [f64; 2],
    /// Mean tared Fz of the chosen frames, N.
    pub force_n: f64,
    /// Frame files (absolute).
    pub files: Vec<PathBuf>,
}

/// What a calibration scan gives calibration.
#[derive(Debug, Clone)]
pub struct ScanRun {
    pub dir: PathBuf,
    pub start: StartDocument,
    /// No-contact frames (absolute paths), in recording order.
    pub background: Vec<PathBuf>,
    pub presses: Vec<Press>,
    /// One no-contact bias per offset measurement, times in s from the first force sample.
    pub offsets: Vec<Bias>,
}

/// Errors reading a calibration run.
#[derive(Debug, thiserror::Error)]
pub enum ScanRunError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("{path}: {message}")]
    Content { path: PathBuf, message: String },
}

impl ScanRun {
    /// Reads the run at `dir`.
    pub fn read(dir: &Path) -> Result<ScanRun, ScanRunError> {
        let run = RunReader::at(dir);
        let start: StartDocument = run.start()?;
        let records = run.frames()?;
        if records.is_empty() {
            return Err(ScanRunError::Content {
                path: run.path(RunFile::Frames),
                message: "no frames recorded".into(),
            });
        }
        let background = records
            .iter()
            .filter(|r| r.valid && r.shape == NO_CONTACT)
            .map(|r| run.frame_file(r))
            .collect::<Result<_, _>>()?;
        let presses = presses(&run, &records)?;
        let events = run.events()?;
        let (samples, _partial) = run.force()?;
        let series: Vec<(u64, Wrench)> = samples
            .iter()
            .map(|s| (s.host_time.nanos(), s.wrench))
            .collect();
        let offsets = offset_windows(&series, &events);
        Ok(ScanRun {
            dir: dir.to_path_buf(),
            start,
            background,
            presses,
            offsets,
        })
    }
}

/// The dwell frames of every point that pressed.
fn presses(run: &RunReader, records: &[FrameRecord]) -> Result<Vec<Press>, StoreError> {
    let mut points: Vec<u64> = records.iter().map(|r| r.point).collect();
    points.sort_unstable();
    points.dedup();
    let mut out = Vec::new();
    for point in points {
        let touching: Vec<(&FrameRecord, f64)> = records
            .iter()
            .filter(|r| r.point == point && r.valid && r.shape != NO_CONTACT)
            .filter_map(|r| r.wrench.map(|w| (r, w.fz.0.abs())))
            .collect();
        let Some(top) = touching.iter().map(|(_, f)| *f).reduce(f64::max) else {
            continue;
        };
        let mut dwell: Vec<(&FrameRecord, f64)> = touching
            .into_iter()
            .filter(|(_, f)| *f >= DWELL_SHARE * top)
            .collect();
        // The frames at either end of the dwell may still show the end of the ramp or the
        // start of the retract (a frame's label and its picture agree only as well as the
        // synchronisation does): keep the middle of the dwell when there is enough of it.
        if dwell.len() > 2 * DWELL_EDGE_FRAMES + 2 {
            dwell.truncate(dwell.len() - DWELL_EDGE_FRAMES);
            dwell.drain(..DWELL_EDGE_FRAMES);
        }
        let step = dwell.len().div_ceil(PRESS_FRAMES).max(1);
        let chosen: Vec<&(&FrameRecord, f64)> = dwell.iter().step_by(step).collect();
        let n = chosen.len() as f64;
        let mean =
            |f: &dyn Fn(&FrameRecord) -> f64| chosen.iter().map(|(r, _)| f(r)).sum::<f64>() / n;
        out.push(Press {
            point,
            stage_mm: [mean(&|r| r.measured.x.0), mean(&|r| r.measured.y.0)],
            force_n: chosen.iter().map(|(_, f)| f).sum::<f64>() / n,
            files: chosen
                .iter()
                .map(|(r, _)| run.frame_file(r))
                .collect::<Result<_, _>>()?,
        });
    }
    Ok(out)
}

/// The bias of the [`OFFSET_WINDOW_S`] before each `force-offset` event; times in s from the
/// first sample.
fn offset_windows(samples: &[(u64, Wrench)], events: &[Event]) -> Vec<Bias> {
    let Some(&(t0, _)) = samples.first() else {
        return Vec::new();
    };
    let window_ns = (OFFSET_WINDOW_S * 1e9) as u64;
    events
        .iter()
        .filter(|e| e.kind == "force-offset")
        .filter_map(|e| {
            let from = e.host_ns.saturating_sub(window_ns);
            let lo = samples.partition_point(|(t, _)| *t < from);
            let hi = samples.partition_point(|(t, _)| *t <= e.host_ns);
            let window: Vec<(f64, Wrench)> = samples[lo..hi]
                .iter()
                .map(|(t, w)| ((t - t0) as f64 * 1e-9, *w))
                .collect();
            offsets::bias(&window)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::Newtons;

    fn event(host_ns: u64) -> Event {
        Event {
            host_ns,
            utc: String::new(),
            kind: "force-offset".into(),
            point: Some(0),
            message: String::new(),
        }
    }

    #[test]
    fn offset_windows_take_the_samples_just_before_each_event() {
        // 1 kHz samples; Fz is 1 N before 0.5 s and 3 N after.
        let samples: Vec<(u64, Wrench)> = (0..1000u64)
            .map(|k| {
                let w = Wrench {
                    fz: Newtons(if k < 500 { 1.0 } else { 3.0 }),
                    ..Wrench::default()
                };
                (k * 1_000_000, w)
            })
            .collect();
        let b = offset_windows(&samples, &[event(400_000_000), event(900_000_000)]);
        assert_eq!(b.len(), 2);
        assert_eq!(b[0].mean[2], 1.0);
        assert_eq!(b[1].mean[2], 3.0);
        assert_eq!(b[0].samples, 101);
        assert!((b[1].t_s - 0.85).abs() < 1e-9, "{}", b[1].t_s);
    }
}
