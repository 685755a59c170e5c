//! The per-sensor profile: one human-readable TOML file per sensor build,
//! `profiles/<sensor-id>.toml`, with the optical centre, radius and crop radius (with
//! uncertainties and residual), the image size, and optional sections for the image-to-stage
//! registration and the force offsets. Read with the one config loader
//! (`fringe_rig::load_toml`: errors name the file, line and key); written atomically
//! (a temporary file renamed into place).

use crate::offsets::ForceOffsets;
use crate::optical::DiscFit;
use fringe_rig::{load_toml, ConfigError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// Image size the profile was measured on, px.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageSize {
    pub width: u32,
    pub height: u32,
}

/// The optical calibration. Image px, x right, y down, pixel (i, j) centred at (i + 0.5, j + 0.5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Optical {
    pub centre_x_px: f64,
    pub centre_y_px: f64,
    /// Centre minus the image centre, px.
    pub shift_x_px: f64,
    pub shift_y_px: f64,
    pub radius_px: f64,
    /// Usable crop radius about the centre, px.
    pub crop_radius_px: f64,
    /// 1-sigma uncertainties, px.
    pub sigma_x_px: f64,
    pub sigma_y_px: f64,
    pub sigma_radius_px: f64,
    /// RMS distance of the edge points from the fitted circle, px.
    pub residual_rms_px: f64,
    /// Frames averaged.
    pub frames: usize,
}

impl Optical {
    /// The fit's values, rounded for reading: positions to 0.001 px, uncertainties and the
    /// residual to 0.0001 px (well below their own uncertainty).
    pub fn from_fit(f: &DiscFit) -> Optical {
        let [sx, sy] = f.shift();
        let mpx = |v: f64| (v * 1e3).round() / 1e3;
        let sig = |v: f64| (v * 1e4).round() / 1e4;
        Optical {
            centre_x_px: mpx(f.centre_x),
            centre_y_px: mpx(f.centre_y),
            shift_x_px: mpx(sx),
            shift_y_px: mpx(sy),
            radius_px: mpx(f.radius),
            crop_radius_px: f.crop_radius,
            sigma_x_px: sig(f.sigma_x),
            sigma_y_px: sig(f.sigma_y),
            sigma_radius_px: sig(f.sigma_radius),
            residual_rms_px: sig(f.residual_rms_px),
            frames: f.frames,
        }
    }
}

/// The image-to-stage registration (filled by the calibration scan): stage mm to image px.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Registration {
    pub px_per_mm: f64,
    pub sigma_px_per_mm: f64,
    /// Rotation of the image relative to the stage axes, degrees counter-clockwise.
    pub rotation_deg: f64,
    pub sigma_rotation_deg: f64,
    /// The image is mirror-reversed relative to the stage.
    pub mirror: bool,
    /// Image position of the stage origin, px [x, y].
    pub offset_px: [f64; 2],
    /// Stage position (x, y) that presses the optical centre: the contact origin, mm.
    pub contact_origin_stage_mm: [f64; 2],
    /// 1-sigma of the contact origin per axis, mm (0 in profiles written before it was kept).
    #[serde(default)]
    pub sigma_contact_origin_stage_mm: [f64; 2],
    /// RMS of the press residuals, px.
    pub residual_rms_px: f64,
    /// Presses used.
    pub presses: usize,
    /// Presses left out as outliers (0 in profiles written before it was kept).
    #[serde(default)]
    pub outliers: usize,
}

/// One sensor build's profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    pub sensor_id: String,
    /// When the profile was made, RFC 3339 UTC.
    pub created_utc: String,
    /// Where the data came from (a run directory or an image folder).
    pub source: String,
    pub image: ImageSize,
    pub optical: Optical,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub registration: Option<Registration>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_offsets: Option<ForceOffsets>,
}

/// A profile that could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("cannot write profile {path}: {source} (check the folder exists and is writable)")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot encode profile {path}: {message}")]
    Encode { path: PathBuf, message: String },
    #[error("sensor id `{0}` cannot name a profile file: use letters, digits, `-`, `_` or `.`")]
    BadId(String),
}

/// `dir/<sensor-id>.toml`; the id must be a plain file-name stem.
pub fn profile_path(dir: &Path, sensor_id: &str) -> Result<PathBuf, ProfileError> {
    let ok = !sensor_id.is_empty()
        && !sensor_id.starts_with('.')
        && sensor_id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if !ok {
        return Err(ProfileError::BadId(sensor_id.into()));
    }
    Ok(dir.join(format!("{sensor_id}.toml")))
}

impl Profile {
    /// The radius of the disc the frames are cropped to, in stage millimetres, when the
    /// profile holds a registration (the crop radius over the pixels per millimetre).
    pub fn disc_radius_mm(&self) -> Option<f64> {
        self.registration
            .as_ref()
            .filter(|r| r.px_per_mm > 0.0)
            .map(|r| self.optical.crop_radius_px / r.px_per_mm)
    }

    /// A new profile from an optical fit, dated now.
    pub fn from_fit(sensor_id: &str, source: &str, fit: &DiscFit) -> Profile {
        Profile {
            sensor_id: sensor_id.into(),
            created_utc: fringe_rig::store::now_utc(),
            source: source.into(),
            image: ImageSize {
                width: fit.width as u32,
                height: fit.height as u32,
            },
            optical: Optical::from_fit(fit),
            registration: None,
            force_offsets: None,
        }
    }

    /// Reads a profile; errors name the file, line and key.
    pub fn load(path: &Path) -> Result<Profile, ProfileError> {
        let (p, _text): (Profile, String) = load_toml(path)?;
        Ok(p)
    }

    /// Writes the profile to `path` atomically (a sibling temporary file renamed over it).
    pub fn save(&self, path: &Path) -> Result<(), ProfileError> {
        let body = toml::to_string_pretty(self).map_err(|e| ProfileError::Encode {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let text = format!(
            "# fringe sensor profile: optical centre, radius and crop radius in image px\n\
             # (x right, y down, pixel (i, j) centred at (i + 0.5, j + 0.5)); sigma_* are 1-sigma.\n\
             # Written by `fringe calibrate`; see docs/calibration.md.\n\n{body}"
        );
        let write = |source| ProfileError::Write {
            path: path.to_path_buf(),
            source,
        };
        let tmp = path.with_extension(format!("toml.tmp{}", std::process::id()));
        std::fs::write(&tmp, text).map_err(write)?;
        std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            write(e)
        })
    }

    /// Age in days at `now`; `None` when `created_utc` cannot be read.
    pub fn age_days(&self, now: SystemTime) -> Option<f64> {
        let made = parse_utc_seconds(&self.created_utc)?;
        let now = now.duration_since(UNIX_EPOCH).ok()?.as_secs_f64();
        Some((now - made) / 86_400.0)
    }
}

/// Seconds since 1970 of "YYYY-MM-DDTHH:MM:SS[.fff]Z".
fn parse_utc_seconds(s: &str) -> Option<f64> {
    let s = s.strip_suffix('Z')?;
    let (date, time) = s.split_once('T')?;
    let mut d = date.split('-').map(|p| p.parse::<i64>().ok());
    let (y, m, day) = (d.next()??, d.next()??, d.next()??);
    let mut t = time.split(':');
    let (hh, mm) = (
        t.next()?.parse::<f64>().ok()?,
        t.next()?.parse::<f64>().ok()?,
    );
    let ss = t.next()?.parse::<f64>().ok()?;
    if !(1..=12).contains(&m) || !(1..=31).contains(&day) {
        return None;
    }
    // Days from civil (H. Hinnant).
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    Some(days as f64 * 86_400.0 + hh * 3600.0 + mm * 60.0 + ss)
}

/// A profile older than this many days is stale: scans that use it warn to re-run the
/// calibration.
pub const MAX_AGE_DAYS: f64 = 90.0;

/// What a consumer expects of the profile it is about to use.
#[derive(Debug, Clone, PartialEq)]
pub struct Expectation<'a> {
    pub sensor_id: &'a str,
    /// Image size of the frames it will crop, px.
    pub image: Option<ImageSize>,
    /// Older than this is stale, days.
    pub max_age_days: f64,
}

/// Why a profile cannot be used as it is. Said without naming a command: the front end adds the
/// one that helps.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProfileWarning {
    /// The sensor has no profile: it was never calibrated (here).
    #[error("no profile for sensor `{sensor_id}` ({} is missing)", path.display())]
    Missing { sensor_id: String, path: PathBuf },
    /// The profile is older than the limit: the sensor wants calibrating again.
    #[error("profile {} is {age_days:.0} days old (made {created_utc}; limit {limit_days} days)", path.display())]
    Stale {
        path: PathBuf,
        age_days: f64,
        created_utc: String,
        limit_days: f64,
    },
    /// Unreadable, another sensor's, of unknown age or made at another image size.
    #[error("{0}")]
    Other(String),
}

/// Loads `dir/<sensor-id>.toml` and checks it; the profile (if readable) and warnings for a
/// missing, unreadable, stale or mismatched profile (empty when it can be used as is).
pub fn load_checked(
    dir: &Path,
    want: &Expectation,
    now: SystemTime,
) -> (Option<Profile>, Vec<ProfileWarning>) {
    let path = match profile_path(dir, want.sensor_id) {
        Ok(p) => p,
        Err(e) => return (None, vec![ProfileWarning::Other(e.to_string())]),
    };
    if !path.exists() {
        return (
            None,
            vec![ProfileWarning::Missing {
                sensor_id: want.sensor_id.to_string(),
                path,
            }],
        );
    }
    match Profile::load(&path) {
        Ok(p) => {
            let w = check(&p, &path, want, now);
            (Some(p), w)
        }
        Err(e) => (
            None,
            vec![ProfileWarning::Other(format!("profile unusable: {e}"))],
        ),
    }
}

/// Warnings for a stale (older than `max_age_days` or image size differs) or mismatched (sensor
/// id differs) profile read from `path`.
pub(crate) fn check(
    p: &Profile,
    path: &Path,
    want: &Expectation,
    now: SystemTime,
) -> Vec<ProfileWarning> {
    let mut w = Vec::new();
    let file = path.display();
    if p.sensor_id != want.sensor_id {
        w.push(ProfileWarning::Other(format!(
            "profile {file} is for sensor `{}`, not `{}`: use that sensor's profile or re-calibrate",
            p.sensor_id, want.sensor_id
        )));
    }
    match p.age_days(now) {
        Some(age) if age > want.max_age_days => w.push(ProfileWarning::Stale {
            path: path.to_path_buf(),
            age_days: age,
            created_utc: p.created_utc.clone(),
            limit_days: want.max_age_days,
        }),
        Some(_) => {}
        None => w.push(ProfileWarning::Other(format!(
            "profile {file}: created_utc `{}` is not an RFC 3339 UTC time, its age is unknown",
            p.created_utc
        ))),
    }
    if let Some(img) = want.image {
        if img != p.image {
            w.push(ProfileWarning::Other(format!(
                "profile {file} was measured on {}x{} px images, these are {}x{} px: re-calibrate for this camera setting",
                p.image.width, p.image.height, img.width, img.height
            )));
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn sample() -> Profile {
        Profile {
            sensor_id: "layered-1".into(),
            created_utc: "2026-11-20T10:00:00.000Z".into(),
            source: "runs/x/0.images".into(),
            image: ImageSize {
                width: 1920,
                height: 1200,
            },
            optical: Optical {
                centre_x_px: 990.02,
                centre_y_px: 600.0,
                shift_x_px: 30.02,
                shift_y_px: 0.0,
                radius_px: 490.0,
                crop_radius_px: 461.0,
                sigma_x_px: 0.003,
                sigma_y_px: 0.003,
                sigma_radius_px: 0.01,
                residual_rms_px: 0.05,
                frames: 4,
            },
            registration: None,
            force_offsets: None,
        }
    }

    #[test]
    fn round_trips_and_warns_when_missing_stale_or_mismatched() {
        let dir = std::env::temp_dir().join(format!("fringe-profile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let mut p = sample();
        p.registration = Some(Registration {
            px_per_mm: 18.3,
            sigma_px_per_mm: 0.01,
            rotation_deg: 0.0,
            sigma_rotation_deg: 0.05,
            mirror: true,
            offset_px: [990.0, 600.0],
            contact_origin_stage_mm: [12.5, 7.0],
            sigma_contact_origin_stage_mm: [0.004, 0.005],
            residual_rms_px: 0.4,
            presses: 9,
            outliers: 1,
        });
        let path = profile_path(&dir, "layered-1").expect("id");
        p.save(&path).expect("write");
        let text = std::fs::read_to_string(&path).expect("read");
        assert!(
            text.contains("[optical]") && text.contains("crop_radius_px = 461.0"),
            "{text}"
        );
        assert_eq!(Profile::load(&path).expect("read back"), p);

        let made =
            UNIX_EPOCH + Duration::from_secs_f64(parse_utc_seconds(&p.created_utc).expect("date"));
        let want = Expectation {
            sensor_id: "layered-1",
            image: Some(p.image),
            max_age_days: 30.0,
        };
        let (got, w) = load_checked(&dir, &want, made + Duration::from_secs(86_400));
        assert!(got.is_some() && w.is_empty(), "{w:?}");
        let (_, w) = load_checked(&dir, &want, made + Duration::from_secs(40 * 86_400));
        assert!(
            w.len() == 1 && w[0].to_string().contains("40 days old"),
            "{w:?}"
        );
        let other_size = Expectation {
            image: Some(ImageSize {
                width: 1280,
                height: 1024,
            }),
            ..want.clone()
        };
        let w = check(&p, &path, &other_size, made);
        assert!(
            w.len() == 1 && w[0].to_string().contains("1280x1024"),
            "{w:?}"
        );
        let other = Expectation {
            sensor_id: "integrated-1",
            ..want.clone()
        };
        let w = check(&p, &path, &other, made);
        assert!(
            w.len() == 1 && w[0].to_string().contains("not `integrated-1`"),
            "{w:?}"
        );
        let (none, w) = load_checked(&dir, &other, made);
        assert!(
            none.is_none() && w[0].to_string().contains("integrated-1.toml is missing"),
            "{w:?}"
        );

        // A bad value names the file and key.
        std::fs::write(
            &path,
            text.replace("radius_px = 490.0", "radius_px = \"big\""),
        )
        .expect("write");
        let e = Profile::load(&path).expect_err("bad").to_string();
        assert!(
            e.contains("layered-1.toml") && e.contains("optical.radius_px"),
            "{e}"
        );
        assert!(profile_path(&dir, "../x").is_err());

        // A registration section written before the origin sigma and outlier count were kept
        // still reads (both default to 0).
        let old = r#"
sensor_id = "layered-1"
created_utc = "2026-11-20T10:00:00.000Z"
source = "runs/x/0.images"

[image]
width = 1920
height = 1200

[optical]
centre_x_px = 990.02
centre_y_px = 600.0
shift_x_px = 30.02
shift_y_px = 0.0
radius_px = 490.0
crop_radius_px = 461.0
sigma_x_px = 0.003
sigma_y_px = 0.003
sigma_radius_px = 0.01
residual_rms_px = 0.05
frames = 4

[registration]
px_per_mm = 18.3
sigma_px_per_mm = 0.01
rotation_deg = 0.0
sigma_rotation_deg = 0.05
mirror = true
offset_px = [990.0, 600.0]
contact_origin_stage_mm = [12.5, 7.0]
residual_rms_px = 0.4
presses = 9
"#;
        std::fs::write(&path, old).expect("write");
        let back = Profile::load(&path).expect("old registration section");
        let reg = back.registration.expect("registration");
        assert_eq!(reg.outliers, 0);
        assert_eq!(reg.sigma_contact_origin_stage_mm, [0.0, 0.0]);
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(
            parse_utc_seconds("1970-01-02T00:00:01.500Z"),
            Some(86_401.5)
        );
    }
}
