//! `fringe sim render`: one simulated sensor frame as a PNG.

use anyhow::{bail, Context};
use fringe_app::rig::{sensor_by_name, SensorNameError};
use fringe_app::simulation::{render_png, Rendered};
use fringe_rig::{Millimetres, Newtons};
use fringe_sim::Contact;
use fringe_sim::SensorConfig;
use fringe_sim::Shape;
use fringe_sim::Shear;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct SimRenderArgs {
    /// Sensor build: `layered`, `integrated` or a sensor TOML file (see rig/sim/sensors/).
    #[arg(
        long,
        value_name = "layered|integrated|PATH.toml",
        default_value = "layered"
    )]
    sensor: String,
    /// Indenter: pentagon, rectangle, sphere or none (sizes from the sensor file).
    #[arg(
        long,
        value_name = "pentagon|rectangle|sphere|none",
        default_value = "pentagon"
    )]
    shape: String,
    /// Normal force, N.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 4.0,
        allow_negative_numbers = true
    )]
    force: f64,
    /// Contact x in the sensor frame (mm from the disc centre, along the stage's x).
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    x: f64,
    /// Contact y in the sensor frame, mm.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    y: f64,
    /// Indenter rotation about the load axis, degrees counter-clockwise.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    angle: f64,
    /// Tangential force the indenter pushes the surface with, N (0: a normal press).
    #[arg(long, value_name = "N", default_value_t = 0.0)]
    shear: f64,
    /// Direction of the push in the sensor frame, degrees counter-clockwise from +x.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    shear_direction: f64,
    /// Share of the friction limit the push uses, 0 (full stick) to 1 (gross slip).
    #[arg(long, value_name = "0..1", default_value_t = 0.5)]
    friction_used: f64,
    /// PNG file to write.
    #[arg(long, value_name = "FILE.png")]
    out: PathBuf,
    /// Defocus blur radius in px (overrides the sensor's `optics.blur_px`).
    #[arg(long, value_name = "PX")]
    blur: Option<f64>,
    /// Seed of noise, drift and residual birefringence (overrides the sensor's `seed`).
    #[arg(long, value_name = "S")]
    seed: Option<u64>,
    /// Frame number (noise and drift change from frame to frame).
    #[arg(long, value_name = "K", default_value_t = 0)]
    frame: u64,
}

/// The sensor named on the command line: a variant name or a TOML file.
pub fn load_sensor(name: &str) -> anyhow::Result<SensorConfig> {
    match sensor_by_name(name) {
        Ok(sensor) => Ok(sensor),
        Err(SensorNameError::Load(e)) => Err(e.into()),
        Err(SensorNameError::Unknown(other)) => bail!(
            "unknown --sensor `{other}`: use layered, integrated or the path of a sensor .toml file"
        ),
    }
}

pub fn run(args: SimRenderArgs) -> anyhow::Result<()> {
    fringe_rig::store::outside_runs(&args.out).context("--out")?;
    let mut config = load_sensor(&args.sensor)?;
    if let Some(blur) = args.blur {
        if !(blur.is_finite() && (0.0..=40.0).contains(&blur)) {
            bail!("--blur {blur}: use 0 (sharp) to 40 px");
        }
        config.optics.blur_px = blur;
    }
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    if !(args.force.is_finite() && (0.0..=100.0).contains(&args.force)) {
        bail!("--force {}: use 0 to 100 N", args.force);
    }
    if !(args.shear.is_finite() && (0.0..=100.0).contains(&args.shear)) {
        bail!("--shear {}: use 0 to 100 N", args.shear);
    }
    if !(args.friction_used.is_finite() && (0.0..=1.0).contains(&args.friction_used)) {
        bail!(
            "--friction-used {}: use 0 (full stick) to 1 (gross slip)",
            args.friction_used
        );
    }
    for (name, v) in [
        ("--x", args.x),
        ("--y", args.y),
        ("--angle", args.angle),
        ("--shear-direction", args.shear_direction),
    ] {
        if !v.is_finite() {
            bail!("{name} {v}: not a number");
        }
    }
    let disc_mm = config.geometry.disc_radius_px / config.geometry.px_per_mm;
    if args.x.hypot(args.y) > disc_mm {
        bail!(
            "--x {} --y {}: the contact lies outside the sensor disc (radius {disc_mm:.1} mm)",
            args.x,
            args.y
        );
    }
    let shape = match args.shape.as_str() {
        "pentagon" => Some(config.pentagon()),
        "rectangle" => Some(config.rectangle()),
        "sphere" => Some(config.sphere(args.force)),
        "none" => None,
        other => bail!("unknown --shape `{other}`: use pentagon, rectangle, sphere or none"),
    };
    let contact = shape.map(|shape: Shape| Contact {
        shape,
        force: Newtons(args.force),
        x: Millimetres(args.x),
        y: Millimetres(args.y),
        angle_deg: args.angle,
        shear: (args.shear > 0.0).then_some(Shear {
            force: Newtons(args.shear),
            direction_deg: args.shear_direction,
            friction_used: args.friction_used,
            sliding: args.friction_used >= 1.0,
        }),
    });
    let id = config.id.clone();
    let Rendered {
        width: w,
        height: h,
        pixel: [u, v],
    } = render_png(config, contact, [args.x, args.y], args.frame, &args.out)?;
    let push = if args.shear > 0.0 {
        format!(
            ", pushed {} N towards {} deg using {} of the friction",
            args.shear, args.shear_direction, args.friction_used
        )
    } else {
        String::new()
    };
    println!(
        "wrote {} ({w}x{h}, sensor {id}, {} {} N at ({}, {}) mm, {} deg{push}: image pixel ({u:.1}, {v:.1}))",
        args.out.display(),
        args.shape,
        args.force,
        args.x,
        args.y,
        args.angle
    );
    Ok(())
}
