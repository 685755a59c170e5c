//! `fringe`: rig controller and calibration suite for photoelastic tactile sensors.

mod cmd;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// Rig controller and calibration suite for camera-based photoelastic tactile sensors.
#[derive(Parser)]
#[command(name = "fringe", version, about)]
struct Cli {
    /// Record everything that crosses each device link to DIR/<device>.trace.
    #[arg(long, global = true, value_name = "DIR")]
    record_trace: Option<PathBuf>,

    #[command(subcommand)]
    command: Command,
}

/// Options shared by every command that opens devices.
pub struct Global {
    pub record_trace: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// List serial ports (Thorlabs controllers marked) and cameras.
    Devices(cmd::devices::DevicesArgs),
    /// Grab frames from a camera (Aravis) or a recorded camera trace.
    Camera(cmd::camera::CameraArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let global = Global { record_trace: cli.record_trace };
    let result = match cli.command {
        Command::Devices(args) => cmd::devices::run(args, &global),
        Command::Camera(args) => cmd::camera::run(args, &global),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fringe: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// Joins an error and its causes into one line, without repeating a cause already quoted.
fn one_line(e: &anyhow::Error) -> String {
    let mut out = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !out.contains(&c) {
            out.push_str(": ");
            out.push_str(&c);
        }
    }
    out
}
