//! What a run directory holds: the start and stop documents, frame records and events.

use super::error::StoreError;
use super::frames::{Encoding, FrameStorage};
use super::layout::FRAMES;
use crate::camera::{parse_format_name, PixelFormat};
use crate::force::FtAxes;
use crate::units::{Millimetres, Wrench};
use std::path::{Component, Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// Version of the run layout written by this build. 2: the start document records how the
/// frames are stored ([`StartDocument::frames`]); 3: one-channel frames may be FGL files
/// (`frames/*.fgl`, `Encoding::Fgl`); 4: FGL files carry a checksum (FGL version 2,
/// `frames::fgl`), which a fringe reading up to layout 3 could not decode. Runs of every earlier
/// layout are still read.
pub const LAYOUT_VERSION: u32 = 4;

/// Written once when a run starts.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StartDocument {
    pub layout_version: u32,
    pub run_id: String,
    /// UTC wall-clock time, RFC 3339.
    pub started_utc: String,
    pub software: String,
    pub sensor_id: String,
    /// The sensor's design (`layered`, `integrated`) when the rig names it or simulates it;
    /// absent in runs written before it was recorded ([`StartDocument::sensor_variant`] finds
    /// it in their rig text).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variant: Option<String>,
    /// The scan plan as given (TOML text).
    pub plan: String,
    /// The rig configuration as used (TOML text; "simulated" details included).
    pub rig: String,
    /// Calibration profile used for contact labels, if any (path and its content).
    pub calibration_profile: Option<ProfileRef>,
    /// Seed of the simulated bench, when the run is simulated.
    pub seed: Option<u64>,
    /// Synchronisation method ("strobe", "clock-fit", "host").
    pub sync_method: String,
    /// How the frames are stored (pixel format, the part of the frame kept, encoding); absent
    /// in runs of layout 1 ([`StartDocument::frame_storage`] says how they stored them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frames: Option<FrameStorage>,
    /// How the F/T's axes sit on the bench, which turns its readings into the sensor's frame
    /// ([`FrameRecord::shear`]); absent when the rig did not say (and in runs recorded before
    /// shear was labelled).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ft_axes: Option<FtAxes>,
}

impl StartDocument {
    /// How this run's frames are stored: as recorded, or, for a run of layout 1, the camera's
    /// pixels in ordinary PNGs, whole frames, in the pixel format its rig text names (the raw
    /// BayerRG8 mosaic in a grey PNG) or else RGB8 (the default camera format of layout 1).
    pub fn frame_storage(&self) -> FrameStorage {
        self.frames.unwrap_or(FrameStorage {
            pixel_format: rig_pixel_format(&self.rig).unwrap_or(PixelFormat::Rgb8),
            cutout: None,
            encoding: Encoding::Png,
        })
    }

    /// The sensor's design: as recorded, else (runs written before it was recorded) the rig
    /// text's `variant` key, else the design the simulated camera's line in the rig text names
    /// (`# camera: simulated WxH ..., sensor ID (DESIGN)`). `None` when nothing says.
    pub fn sensor_variant(&self) -> Option<String> {
        if let Some(v) = &self.variant {
            return Some(v.clone());
        }
        if let Some(v) = toml::from_str::<toml::Value>(&self.rig)
            .ok()
            .and_then(|rig| rig.get("variant")?.as_str().map(str::to_string))
        {
            return Some(v);
        }
        self.rig.lines().find_map(|line| {
            let rest = line.strip_prefix("# camera: simulated ")?;
            let (_, after) = rest.rsplit_once(&format!("sensor {} (", self.sensor_id))?;
            Some(after.strip_suffix(')')?.to_string())
        })
    }
}

/// `camera.pixel_format` of a rig file's text, if it names one.
fn rig_pixel_format(rig: &str) -> Option<PixelFormat> {
    let rig: toml::Value = toml::from_str(rig).ok()?;
    parse_format_name(rig.get("camera")?.get("pixel_format")?.as_str()?)
}

/// A calibration profile as recorded by a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ProfileRef {
    pub path: String,
    pub content: String,
}

/// An exposure window on the host time base.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Exposure {
    pub start_ns: f64,
    pub end_ns: f64,
    /// Estimated error of the window's placement, ns.
    pub error_ns: f64,
}

/// Stage positions of one frame.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Position {
    pub x: Millimetres,
    pub y: Millimetres,
    pub z: Millimetres,
}

/// One frame with its labels.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameRecord {
    /// Index of the record in the run (0, 1, 2, ...).
    pub index: u64,
    /// Camera frame id (gaps = dropped frames).
    pub frame_id: u64,
    /// Frame file, relative to the run directory.
    pub file: String,
    pub device_timestamp: u64,
    pub host_arrival_ns: u64,
    pub exposure: Option<Exposure>,
    /// Exposure window in the force stream's sample index (strobe synchronisation).
    #[serde(default)]
    pub exposure_ticks: Option<[f64; 2]>,
    /// Grid point and repetition the frame belongs to.
    pub point: u64,
    pub commanded: Position,
    pub measured: Position,
    /// Six-axis force averaged over the exposure (N, N m), tared, in the F/T's frame.
    pub wrench: Option<Wrench>,
    /// The tangential force the indenter applied to the sensor's surface over the exposure,
    /// in the sensor's frame (x, y along the stage axes), N, signed: the wrench's force turned
    /// by the run's [`StartDocument::ft_axes`]. Absent when the run does not know the F/T's
    /// axes (runs recorded before shear was labelled, a rig file without `[force]
    /// x_axis_deg`) or the frame has no force label.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear: Option<[f64; 2]>,
    /// "None" when |Fz| is under the noise floor, otherwise the indenter's name.
    pub shape: String,
    /// Contact point in mm relative to the sensor centre; `None` when there is no contact.
    pub contact: Option<[f64; 2]>,
    /// False when the label cannot be trusted (force gap in the window, axis moving, ...).
    pub valid: bool,
    /// Why not valid, or other notes.
    pub notes: Vec<String>,
}

impl FrameRecord {
    /// The record's frame file inside the run `dir`. Only a relative path of plain names is a
    /// frame file (no root, no `..`, no `.`): a record never names a file outside its run.
    /// Verify and export both ask here.
    pub fn file_in(&self, dir: &Path) -> Result<PathBuf, StoreError> {
        let rel = Path::new(&self.file);
        let plain =
            !self.file.is_empty() && rel.components().all(|c| matches!(c, Component::Normal(_)));
        if plain {
            Ok(dir.join(rel))
        } else {
            Err(StoreError::Content {
                path: dir.join(FRAMES),
                message: format!(
                    "record {}: file `{}` is not a path inside the run (it must be relative, \
                     without `..`); the record was edited or damaged",
                    self.index, self.file
                ),
            })
        }
    }
}

/// Something that happened during a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Event {
    /// Host time, ns.
    pub host_ns: u64,
    pub utc: String,
    /// "checkpoint", "pause", "resume", "watcher", "prompt", "resume-run", ...
    pub kind: String,
    /// Grid point concerned, if any.
    pub point: Option<u64>,
    pub message: String,
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExitStatus {
    Completed,
    Aborted,
    Failed,
}

/// Written once when a run ends.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StopDocument {
    pub exit_status: ExitStatus,
    pub reason: String,
    pub stopped_utc: String,
    pub frames: u64,
    pub dropped_frames: u64,
    pub force_samples: u64,
    pub lost_force_samples: u64,
    pub points_done: u64,
    /// Synchronisation method used (as in the start document).
    #[serde(default)]
    pub sync_method: Option<String>,
    /// The method's own estimate of its label-time error at the end of the run (1 sigma), ns.
    #[serde(default)]
    pub sync_error_ns: Option<f64>,
}

/// Written at every checkpoint (before each grid point): where the scan goes on after a crash,
/// and how far the frame records went then. Everything recorded after it belongs to a point
/// that did not finish and is cut when the run is resumed.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    /// Index (in the scan program) of the next point to do.
    pub next_point: u64,
    /// Frame records before the checkpoint.
    pub next_index: u64,
    /// Length of frames.jsonl at the checkpoint, bytes.
    pub frames_bytes: u64,
    pub utc: String,
}

/// `t` as an RFC 3339 UTC timestamp with milliseconds ("2026-11-22T03:45:12.345Z").
pub(crate) fn rfc3339_utc(t: SystemTime) -> String {
    let d = t.duration_since(UNIX_EPOCH).unwrap_or_default();
    let secs = d.as_secs();
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, day) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60,
        d.subsec_millis()
    )
}

/// The current time as [`rfc3339_utc`].
pub fn now_utc() -> String {
    rfc3339_utc(SystemTime::now())
}

/// `YYYY-MM-DD` of `days` since 1970-01-01 (the date part of [`rfc3339_utc`]).
pub fn utc_date(days: i64) -> String {
    let (y, m, d) = civil_from_days(days);
    format!("{y:04}-{m:02}-{d:02}")
}

/// Days since 1970-01-01 of the date an RFC 3339 time (`2026-12-06T14:00:00Z`) or a bare
/// `YYYY-MM-DD` begins with (H. Hinnant's days_from_civil); `None` when it is no date.
pub fn utc_days(utc: &str) -> Option<i64> {
    let d = utc.get(..10)?;
    let mut parts = d.split('-');
    let y: i64 = parts.next()?.parse().ok()?;
    let m: i64 = parts.next()?.parse().ok()?;
    let dd: i64 = parts.next()?.parse().ok()?;
    if !(1..=12).contains(&m) || !(1..=31).contains(&dd) {
        return None;
    }
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + dd - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    Some(era * 146_097 + doe - 719_468)
}

/// Year, month, day of the proleptic Gregorian calendar from days since 1970-01-01
/// (H. Hinnant's civil_from_days algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn dates_go_round() {
        for d in ["1970-01-01", "2024-02-29", "2026-12-31", "2027-01-01"] {
            assert_eq!(utc_date(utc_days(d).expect(d)), d);
        }
        assert_eq!(
            utc_date(utc_days("2026-12-30T10:00:00Z").expect("d") + 7),
            "2027-01-06"
        );
        assert_eq!(utc_days("2026-13-01"), None);
        // The date rfc3339_utc writes reads back as the same day.
        let t = SystemTime::UNIX_EPOCH + Duration::from_secs(20_000 * 86_400 + 3_600);
        assert_eq!(utc_days(&rfc3339_utc(t)), Some(20_000));
    }

    #[test]
    fn only_relative_plain_paths_are_frame_files() {
        let mut r = FrameRecord {
            index: 7,
            frame_id: 7,
            file: String::new(),
            device_timestamp: 0,
            host_arrival_ns: 0,
            exposure: None,
            exposure_ticks: None,
            point: 0,
            commanded: Position {
                x: Millimetres(0.0),
                y: Millimetres(0.0),
                z: Millimetres(0.0),
            },
            measured: Position {
                x: Millimetres(0.0),
                y: Millimetres(0.0),
                z: Millimetres(0.0),
            },
            wrench: None,
            shear: None,
            shape: "None".into(),
            contact: None,
            valid: true,
            notes: vec![],
        };
        let run = Path::new("/runs/a");
        r.file = "frames/00000007.png".into();
        assert_eq!(
            r.file_in(run).expect("inside"),
            Path::new("/runs/a/frames/00000007.png")
        );
        for bad in [
            "",
            "/etc/hostname",
            "../../../../etc/hostname",
            "frames/../../b/frames/00000007.png",
            "./frames/00000007.png",
        ] {
            r.file = bad.into();
            let err = r.file_in(run).expect_err(bad).to_string();
            assert!(
                err.contains("record 7") && err.contains("not a path inside the run"),
                "{err}"
            );
        }
    }

    #[test]
    fn timestamps_are_rfc3339_utc() {
        assert_eq!(rfc3339_utc(UNIX_EPOCH), "1970-01-01T00:00:00.000Z");
        // 2026-11-22T03:45:12.345Z
        let t = UNIX_EPOCH + Duration::from_millis(1_795_319_112_345);
        assert_eq!(rfc3339_utc(t), "2026-11-22T03:45:12.345Z");
        // Leap day.
        let t = UNIX_EPOCH + Duration::from_secs(951_782_400);
        assert_eq!(rfc3339_utc(t), "2000-02-29T00:00:00.000Z");
    }
}
