//! The Calibrate screen's side of a calibration: the built-in calibration plan for the rig, and
//! what the screen shows of a fitted calibration (made on the fitting thread, not in the draw).

use super::state::{CalibrateView, CalibrationPhase, PressRow};
use fringe_app::session::{CalibrationGrid, CalibrationResult};
use fringe_app::RigConfig;
use fringe_rig::{Plan, ScanProgram};

/// Side of the fitted-frame picture, px.
pub const PICTURE_PX: u32 = 160;

/// The built-in calibration grid of `fringe calibrate` (its defaults) for `config`'s sensor:
/// the program, the plan's text, the sensor id and the grid in words.
pub fn plan(config: &RigConfig) -> anyhow::Result<(ScanProgram, String, String, String)> {
    let sensor = config.sensor_id()?;
    let grid = CalibrationGrid::defaults(&sensor);
    let text = grid.plan_text(config)?;
    let origin = "built-in calibration grid";
    let program = Plan::parse(&text, origin)?.program(&config.limits()?, origin)?;
    Ok((program, text, sensor, grid.describe()))
}

/// The screen before anything ran.
pub fn ready_view(config: &RigConfig) -> CalibrateView {
    let (sensor, plan) = match plan(config) {
        Ok((_, _, sensor, described)) => {
            (sensor, format!("built-in calibration grid: {described}"))
        }
        Err(e) => ("?".into(), format!("no calibration plan: {e:#}")),
    };
    let profile = fringe_calibration::profile_path(&config.profile_dir(), &sensor)
        .map(|p| p.display().to_string())
        .unwrap_or_else(|e| e.to_string());
    CalibrateView {
        sensor,
        plan,
        profile,
        phase: CalibrationPhase::Ready,
        fit: Vec::new(),
        registration: String::new(),
        presses: Vec::new(),
        offsets: Vec::new(),
        picture: None,
    }
}

/// Fills `v` with what `r` found.
pub fn show(v: &mut CalibrateView, r: &CalibrationResult) {
    let cal = &r.cal;
    let f = &cal.fit;
    let [sx, sy] = f.shift();
    v.fit = vec![
        format!(
            "centre x {:.2} ± {:.3} px, y {:.2} ± {:.3} px ({} frames averaged)",
            f.centre_x, f.sigma_x, f.centre_y, f.sigma_y, f.frames
        ),
        format!("shift from the image centre x {sx:+.2} px, y {sy:+.2} px"),
        format!(
            "radius {:.2} ± {:.3} px, crop radius {:.0} px",
            f.radius, f.sigma_radius, f.crop_radius
        ),
        format!(
            "edge fit {:.3} px RMS over {} of {} rays",
            f.residual_rms_px, f.inliers, f.rays
        ),
    ];
    let mut residuals = match &cal.registration {
        Ok(reg) => {
            let s = &reg.fit;
            v.registration = format!(
                "{:.3} px/mm, rotation {:+.2}°, {:.3} px RMS; centre pressed at stage ({:.3}, {:.3}) mm",
                s.px_per_mm,
                s.rotation_deg,
                s.residual_rms_px,
                reg.contact_origin_stage_mm[0],
                reg.contact_origin_stage_mm[1]
            );
            s.residuals.iter()
        }
        Err(e) => {
            v.registration = format!("none: {e}");
            [].iter()
        }
    };
    v.presses = cal
        .presses
        .iter()
        .map(|p| PressRow {
            stage_mm: (p.stage_mm[0], p.stage_mm[1]),
            outcome: match &p.spot {
                Ok(_) => residuals
                    .next()
                    .map(|res| (res.length_px(), res.outlier))
                    .ok_or_else(|| "not in the registration".to_string()),
                Err(e) => Err(e.to_string()),
            },
        })
        .collect();
    v.offsets = match &cal.offsets {
        Some(o) => vec![
            format!(
                "Fx {:+.4}  Fy {:+.4}  Fz {:+.4} N (± {:.4} N)",
                o.force_n[0], o.force_n[1], o.force_n[2], o.force_sigma_n[2]
            ),
            format!(
                "Tx {:+.5}  Ty {:+.5}  Tz {:+.5} N m, {} samples",
                o.torque_nm[0], o.torque_nm[1], o.torque_nm[2], o.samples
            ),
        ],
        None => vec!["none: no no-contact window in the force stream".into()],
    };
    v.picture = r.preview(PICTURE_PX).ok();
    v.phase = CalibrationPhase::Fitted;
}
