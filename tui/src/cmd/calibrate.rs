//! `fringe calibrate --sensor ID [--rig rig.toml]`: the calibration scan on the rig (the simulated
//! bench by default) and the sensor's profile from it: optical centre, radius and crop radius,
//! image-to-stage registration, force offsets, with report images beside the profile.
//!
//! `fringe calibrate --images DIR --sensor ID`: the optical part from existing image files (PNG or
//! TIFF): centre, shift from the image centre, radius and crop radius (`fringe_app::session::fit_disc`
//! and its neighbours in `tui/app/src/session/calibration_images.rs`).

use crate::cmd::scan::execute;
use crate::global::Global;
use anyhow::{bail, Context};
use fringe_app::session::{
    calibrate_run, calibration_completed, calibration_plan, spot_settings, CalibrationGrid,
    WrittenProfile, DEFAULT_MAX_FRAMES,
};
use fringe_app::session::{choose_no_contact, fit_disc, image_files, write_profile};
use fringe_app::{ProfileUse, RigConfig, SessionEnd};
use fringe_calibration::offsets::CHANNELS;
use fringe_calibration::profile_path;
use fringe_calibration::DiscFit;
use fringe_calibration::ScanCalibration;
use fringe_rig::{scan::new_run_id, RunTarget};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct CalibrateArgs {
    /// Sensor build id: names the profile file (`<profiles>/<ID>.toml`).
    #[arg(long, value_name = "ID")]
    sensor: String,
    /// Calibrate the optics from this folder of no-contact frames (PNG or TIFF, for example a
    /// reference-pipeline `0.images/`) instead of running the calibration scan.
    #[arg(long, value_name = "DIR")]
    images: Option<PathBuf>,
    /// The rig file (default: ./rig.toml if present, else the simulated bench).
    #[arg(long, value_name = "FILE", conflicts_with = "images")]
    rig: Option<PathBuf>,
    /// Folder for the profile and its report images (default: the rig file's `profiles`, or
    /// `profiles`).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Average at most this many no-contact frames (spread evenly over them).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_FRAMES)]
    max_frames: usize,
    /// Your own calibration plan (stage mm) instead of the built-in grid.
    #[arg(long, value_name = "FILE", conflicts_with = "images")]
    plan: Option<PathBuf>,
    /// Half-width of the built-in press grid around the nominal centre, mm.
    #[arg(long, value_name = "MM", default_value_t = CalibrationGrid::DEFAULT_SPAN_MM)]
    span: f64,
    /// Presses per axis of the built-in grid (points x points).
    #[arg(long, value_name = "N", default_value_t = CalibrationGrid::DEFAULT_POINTS)]
    points: usize,
    /// Force of each light press, N.
    #[arg(long, value_name = "N", default_value_t = CalibrationGrid::DEFAULT_FORCE_N)]
    force: f64,
    /// Indenter of the presses.
    #[arg(long, value_name = "SHAPE", default_value = CalibrationGrid::DEFAULT_INDENTER)]
    indenter: String,
    /// Directory that receives the calibration scan's run.
    #[arg(long, value_name = "DIR", default_value = "runs")]
    runs: PathBuf,
    /// The sensor's construction, which tunes contact finding: `layered` (thin photoelastic
    /// film, fringes hugging the indenter) or `integrated` (thick gel, rings over the disc).
    /// Default: the simulated sensor's, else layered.
    #[arg(long, value_name = "KIND")]
    variant: Option<String>,
    /// Answer every operator prompt with "continue".
    #[arg(long)]
    yes: bool,
}

pub fn run(args: CalibrateArgs, global: &Global) -> anyhow::Result<()> {
    if let Some(out) = &args.out {
        fringe_rig::store::outside_runs(out).context("--out")?;
    }
    if args.max_frames == 0 {
        bail!("--max-frames 0: use at least 1");
    }
    match &args.images {
        Some(dir) => from_images(&args, dir),
        None => from_rig(&args, global),
    }
}

/// The optical part from a folder of images.
fn from_images(args: &CalibrateArgs, dir: &Path) -> anyhow::Result<()> {
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("profiles"));
    let profile_file = profile_path(&out, &args.sensor)?;
    let files = image_files(dir)?;
    let (chosen, how) = choose_no_contact(dir, &files)?;
    if chosen.is_empty() {
        bail!("{how}: no frame to use in {}", dir.display());
    }
    println!("{how}");
    let (average, fit) = fit_disc(dir, &chosen, args.max_frames)?;
    print_fit(&fit);
    let report = write_profile(&args.sensor, dir, &average, &fit, &out, &profile_file)?;
    println!("wrote {}", profile_file.display());
    println!(
        "wrote {} (fitted disc green, crop circle yellow, centre red)",
        report.display()
    );
    Ok(())
}

/// The calibration scan on the rig, then the whole profile from its run.
fn from_rig(args: &CalibrateArgs, global: &Global) -> anyhow::Result<()> {
    let (config, source) = RigConfig::resolve(args.rig.as_deref())?;
    println!(
        "fringe {}: calibration of sensor {} on rig: {}",
        env!("CARGO_PKG_VERSION"),
        args.sensor,
        source.describe()
    );
    let out = args.out.clone().unwrap_or_else(|| config.profile_dir());
    // A sensor id that cannot name a profile file is refused before anything moves.
    profile_path(&out, &args.sensor)?;
    warn_other_sensor(&config, &out, &args.sensor);
    let (spot, default_note) = spot_settings(args.variant.as_deref(), &config)?;
    if let Some(note) = default_note {
        println!("{note}");
    }
    let end = calibration_scan(args, &config, global)?;
    let run_dir = end.outcome.run_dir.clone();
    println!(
        "locating the contact in the presses of {}...",
        run_dir.display()
    );
    let result = calibrate_run(&run_dir, &args.sensor, args.max_frames, spot)?;
    let cal = &result.cal;
    print_calibration(cal);
    #[cfg(feature = "sim")]
    if let Some(sim) = &end.sim {
        print_truth(&sim.calibration_truth(cal));
    }
    if let Err(e) = &cal.registration {
        eprintln!(
            "warning: no image-to-stage registration ({e}); the profile keeps the optical part and the force offsets, and scans use the rig file's contact origin"
        );
    }
    let written = result.write(&out)?;
    print_written(&written);
    Ok(())
}

/// Warns when the rig file names another sensor than the one calibrated, whose profile the
/// rig's scans would read.
fn warn_other_sensor(config: &RigConfig, out: &Path, sensor: &str) {
    if let Ok(rig_sensor) = config.sensor_id() {
        if rig_sensor != sensor {
            eprintln!(
                "warning: the rig file names sensor {rig_sensor}; scans on it read {}, not this profile",
                profile_path(out, &rig_sensor)
                    .map(|p| p.display().to_string())
                    .unwrap_or_default()
            );
        }
    }
}

/// Runs the calibration plan (`--plan` or the built-in grid) into a new run; an error unless
/// the scan completed.
fn calibration_scan(
    args: &CalibrateArgs,
    config: &RigConfig,
    global: &Global,
) -> anyhow::Result<SessionEnd> {
    let grid = CalibrationGrid {
        sensor: args.sensor.clone(),
        points: args.points,
        span_mm: args.span,
        force_n: args.force,
        indenter: args.indenter.clone(),
    };
    let plan = calibration_plan(args.plan.as_deref(), &grid, config)?;
    println!(
        "plan: {}: {} presses, then the profile from the run",
        plan.name,
        plan.program.points.len()
    );
    let target = RunTarget::New {
        root: args.runs.clone(),
        run_id: new_run_id(&format!("calibration-{}", args.sensor)),
    };
    let end = execute(
        config,
        plan.program,
        plan.text,
        target,
        args.yes,
        ProfileUse::Ignore,
        global,
        &mut |_| Ok(()),
    )?;
    let outcome = &end.outcome;
    println!("calibration scan written to {}", outcome.run_dir.display());
    calibration_completed(outcome)?;
    Ok(end)
}

/// Prints what the calibration found: the optical fit, each press and the force offsets.
fn print_calibration(cal: &ScanCalibration) {
    println!(
        "optical: {} no-contact frames averaged, {} presses",
        cal.fit.frames,
        cal.presses.len()
    );
    print_fit(&cal.fit);
    print_presses(cal);
    print_offsets(cal);
}

/// Names the files written: the profile and its report images.
fn print_written(written: &WrittenProfile) {
    println!("wrote {}", written.profile.display());
    println!(
        "wrote {} (fitted disc green, crop circle yellow, centre red)",
        written.report.display()
    );
    if let Some(p) = &written.residuals {
        println!(
            "wrote {} (registration residuals per press, scaled up)",
            p.display()
        );
    }
    if let Some(p) = &written.contact {
        println!(
            "wrote {} (the press nearest the centre, its located contact marked)",
            p.display()
        );
    }
}

fn print_presses(cal: &ScanCalibration) {
    for p in &cal.presses {
        match &p.spot {
            Ok(s) => println!(
                "press {} at stage ({:.3}, {:.3}) mm, {:.2} N, {} frames: contact at ({:.2}, {:.2}) px +- {:.2} px",
                p.point + 1,
                p.stage_mm[0],
                p.stage_mm[1],
                p.force_n,
                p.frames,
                s.u_px,
                s.v_px,
                s.sigma_px()
            ),
            Err(e) => println!(
                "press {} at stage ({:.3}, {:.3}) mm: not located: {e}",
                p.point + 1,
                p.stage_mm[0],
                p.stage_mm[1]
            ),
        }
    }
    let Ok(r) = &cal.registration else {
        return;
    };
    let f = &r.fit;
    println!(
        "registration: {:.4} +- {:.4} px/mm, rotation {:+.3} +- {:.3} deg, {} (the other hand fits {:.2} px RMS), offset ({:.2}, {:.2}) px",
        f.px_per_mm,
        f.sigma_px_per_mm,
        f.rotation_deg,
        f.sigma_rotation_deg,
        if f.mirror { "mirrored" } else { "not mirrored" },
        f.other_mirror_rms_px,
        f.offset_px[0],
        f.offset_px[1]
    );
    println!(
        "residual {:.3} px RMS over {} presses ({} outliers left out); the optical centre is pressed at stage ({:.4} +- {:.4}, {:.4} +- {:.4}) mm",
        f.residual_rms_px,
        f.inliers,
        f.residuals.len() - f.inliers,
        r.contact_origin_stage_mm[0],
        r.sigma_contact_origin_stage_mm[0],
        r.contact_origin_stage_mm[1],
        r.sigma_contact_origin_stage_mm[1]
    );
}

/// The built-in plan with the grid around the rig's nominal centre, the force and the indenter
/// of the arguments.
fn print_offsets(cal: &ScanCalibration) {
    let Some(o) = &cal.offsets else {
        println!("force offsets: no no-contact window in the force stream");
        return;
    };
    println!(
        "force offsets (last of {} no-contact windows): Fx {:+.4} Fy {:+.4} Fz {:+.4} N (+- {:.4} N), Tx {:+.5} Ty {:+.5} Tz {:+.5} N m",
        cal.biases.len(),
        o.force_n[0],
        o.force_n[1],
        o.force_n[2],
        o.force_sigma_n[2],
        o.torque_nm[0],
        o.torque_nm[1],
        o.torque_nm[2]
    );
    if let Some(d) = &cal.drift {
        let per_min: Vec<String> = (0..3)
            .map(|k| {
                format!(
                    "{} {:+.4} +- {:.4}",
                    CHANNELS[k],
                    d.slope_per_s[k] * 60.0,
                    d.slope_sigma[k] * 60.0
                )
            })
            .collect();
        println!(
            "force offset drift through the run, N/min: {}",
            per_min.join(", ")
        );
    }
}

/// On the simulated bench: the calibration against the simulator's truth.
#[cfg(feature = "sim")]
fn print_truth(t: &fringe_app::rig::CalibrationTruth) {
    println!(
        "against the simulator's truth: centre off by {:.3} px, radius by {:+.3} px",
        t.centre_off_px, t.radius_off_px
    );
    if let Some(r) = &t.registration {
        println!(
            "  px/mm {:+.3} %, rotation {:+.3} deg, mirror {}, contact origin off by ({:+.4}, {:+.4}) mm",
            r.px_per_mm_error_pct,
            r.rotation_error_deg,
            if r.mirror_right { "right" } else { "WRONG" },
            r.origin_off_mm[0],
            r.origin_off_mm[1]
        );
    }
    if let Some(d) = t.offset_minus_bias_n {
        println!(
            "  force offset minus the sensor's power-up bias: Fx {:+.4} Fy {:+.4} Fz {:+.4} N (includes the simulated sensor's random-walk drift since power-up)",
            d[0], d[1], d[2]
        );
    }
}

fn print_fit(f: &DiscFit) {
    let [sx, sy] = f.shift();
    println!(
        "image {}x{} px, {} frames averaged, noise {:.2} DN",
        f.width, f.height, f.frames, f.noise_dn
    );
    println!(
        "centre x {:.2} +- {:.3} px, y {:.2} +- {:.3} px",
        f.centre_x, f.sigma_x, f.centre_y, f.sigma_y
    );
    println!("shift from the image centre x {sx:+.2} px, y {sy:+.2} px");
    println!("radius {:.2} +- {:.3} px", f.radius, f.sigma_radius);
    println!("crop radius {:.0} px", f.crop_radius);
    println!(
        "fit residual {:.3} px RMS over {} of {} edge rays",
        f.residual_rms_px, f.inliers, f.rays
    );
}
