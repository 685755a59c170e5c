//! `fringe axis`: bring up one Thorlabs stepper axis from the command line.

use super::arg_values;
use super::limits::SoftLimitArgs;
use crate::global::Global;
use anyhow::{bail, Context};
use fringe_app::rig::{open_thorlabs, TraceTo};
use fringe_rig::apt::Actuator;
use fringe_rig::{apt::Timeouts, AptConfig, Controller};
use fringe_rig::{Axis, AxisError, AxisStatus, SoftLimits, StopMode};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use std::time::Duration;

#[derive(clap::Args)]
pub struct AxisArgs {
    /// Serial port of the controller (see `fringe devices`), e.g. /dev/ttyUSB0.
    #[arg(long, value_name = "PATH")]
    port: String,
    /// Actuator model: ZFS06/13/25, ZST206/213/225, DRV013/014/225/250/208/001, NRT100/150,
    /// LTS150/300. Its travel (0 at the home switch) is the soft limits unless --min/--max are
    /// given.
    #[arg(long, value_name = "NAME")]
    actuator: String,
    /// Controller: kst101, kst201, bsc201, bsc202, bsc203.
    #[arg(long, default_value = "kst101")]
    controller: Controller,
    /// Rack bay (0..=9) of a BSC202/203 channel.
    #[arg(long)]
    bay: Option<u8>,
    /// Channel ident in messages.
    #[arg(long, default_value_t = 1)]
    channel: u8,
    /// Maximum velocity in mm/s (homing runs at the smaller of this and 1 mm/s).
    #[arg(long, value_name = "MM_S", default_value_t = 1.0)]
    velocity: f64,
    /// Acceleration in mm/s^2.
    #[arg(long, value_name = "MM_S2", default_value_t = 1.0)]
    acceleration: f64,
    #[command(flatten)]
    limits: SoftLimitArgs,
    /// Seconds to wait for a home or move to finish.
    #[arg(long, value_name = "SECONDS", default_value = "120", value_parser = arg_values::seconds)]
    timeout: Duration,
    #[command(subcommand)]
    action: Action,
}

#[derive(clap::Subcommand)]
enum Action {
    /// Home the axis and wait.
    Home,
    /// Print position and status bits.
    Status,
    /// Move to an absolute position in mm and wait.
    Move {
        #[arg(value_name = "MM", allow_negative_numbers = true, value_parser = arg_values::millimetres)]
        mm: f64,
    },
    /// Move by a distance in mm and wait.
    MoveRel {
        #[arg(value_name = "MM", allow_negative_numbers = true, value_parser = arg_values::millimetres)]
        mm: f64,
    },
    /// Stop (profiled unless --immediate).
    Stop {
        #[arg(long)]
        immediate: bool,
    },
}

fn print_status(s: &AxisStatus) {
    println!("position: {:.4}", s.position);
    println!("moving: {}, homed: {}", s.moving, s.homed);
    if s.flags.is_empty() {
        println!("status bits: (none set)");
    } else {
        println!("status bits: {}", s.flags.join(", "));
    }
    if !s.faults.is_empty() {
        println!("faults: {}", s.faults.join(", "));
    }
}

pub fn run(args: AxisArgs, global: &Global) -> anyhow::Result<()> {
    let actuator = Actuator::by_name(&args.actuator).with_context(|| {
        format!(
            "unknown actuator `{}` (known: {})",
            args.actuator,
            Actuator::known_names()
        )
    })?;
    for (name, v) in [
        ("--velocity", args.velocity),
        ("--acceleration", args.acceleration),
    ] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name} must be a positive number, got {v}");
        }
    }
    // Messages name the axis by its actuator ("axis ZFS25 (serial /dev/ttyUSB0): ...").
    let mut config = AptConfig::new(&args.actuator, args.controller, actuator);
    config.bay = args.bay;
    config.channel = args.channel;
    config.velocity = MillimetresPerSecond(args.velocity);
    config.acceleration = MillimetresPerSecondSquared(args.acceleration);
    config.home.velocity = MillimetresPerSecond(args.velocity.min(1.0));
    config.timeouts = Timeouts::default();
    // Without --min/--max the actuator's travel (0 at the home switch) is the soft limits: a
    // move past it would drive into a limit switch.
    let given = args.limits.limits()?;
    let travel = match (&given, actuator.travel) {
        (None, Some(t)) => Some((
            t,
            SoftLimits::new(Millimetres(0.0), t).map_err(|e| anyhow::anyhow!("{e}"))?,
        )),
        _ => None,
    };
    config.soft_limits = given.or_else(|| travel.map(|(_, l)| l));
    let mut axis = open_thorlabs(
        &args.port,
        config,
        TraceTo::new(global.record_trace.as_deref(), "apt"),
    )?;
    if let Some(info) = axis.info() {
        println!(
            "controller: {} serial {} firmware {} on {}",
            info.model,
            info.serial_number,
            info.firmware_version(),
            axis.endpoint()
        );
    }
    let timeout = args.timeout;
    let refused = |e: AxisError| -> anyhow::Error {
        match (&e, travel) {
            (AxisError::SoftLimit { .. }, Some((t, _))) => anyhow::anyhow!(
                "{e}: the {}'s travel is {} mm (0 at its home switch), its soft limits when --min and --max are not given; to move elsewhere give both (--min MM --max MM)",
                actuator.name,
                t.0
            ),
            _ => e.into(),
        }
    };
    let status = match args.action {
        Action::Status => axis.status()?,
        Action::Home => axis.home(timeout)?,
        Action::Move { mm } => axis.move_to(Millimetres(mm), timeout).map_err(refused)?,
        Action::MoveRel { mm } => axis.move_by(Millimetres(mm), timeout).map_err(refused)?,
        Action::Stop { immediate } => {
            axis.stop(if immediate {
                StopMode::Immediate
            } else {
                StopMode::Profiled
            })?;
            axis.status()?
        }
    };
    print_status(&status);
    Ok(())
}
