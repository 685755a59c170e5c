//! `fringe`: rig controller and calibration suite for photoelastic tactile sensors.

mod clock_text;
mod cmd;
mod global;
mod hint;
mod signals;
mod stream_text;
mod ui;

use clap::{Parser, Subcommand};
use global::Global;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

/// Rig controller and calibration suite for camera-based photoelastic tactile sensors.
#[derive(Parser)]
#[command(name = "fringe", version, about)]
struct Cli {
    /// Record everything that crosses each device link to DIR/<device>.trace.
    #[arg(long, global = true, value_name = "DIR")]
    record_trace: Option<PathBuf>,

    /// Plain output instead of the terminal UI (the default when stdout is not a terminal);
    /// before or after the command.
    #[arg(long, global = true)]
    no_tui: bool,

    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// List serial ports (Thorlabs controllers marked) and cameras.
    Devices(cmd::devices::DevicesArgs),
    /// ATI Net F/T / Ethernet Axia force/torque sensor: stream to CSV, software bias.
    Ft(cmd::ft::FtArgs),
    /// ATI transducer through an NI-DAQmx device and its .cal file: stream to CSV, bias.
    Daq(cmd::daq::DaqArgs),
    /// Home, query or move the y stage (Modbus TCP, Modbus RTU, manual or a Thorlabs axis).
    Ystage(cmd::ystage::YstageArgs),
    /// Drive one Thorlabs stepper axis (KST101/KST201/BSC20x): home, status, move, stop.
    Axis(cmd::axis::AxisArgs),
    /// Grab frames from a camera (Aravis) or a recorded camera trace.
    Camera(cmd::camera::CameraArgs),
    /// List the built-in scan plans by name: points, presses, estimated time.
    Plans(cmd::plans::PlansArgs),
    /// Run a scan plan (grid of points and force levels) into a run directory; --dry-run shows it.
    Scan(cmd::scan::ScanArgs),
    /// The demonstration on the simulated bench: three presses to 1, 4 and 9 N, filmed,
    /// labelled, stored and scored against the simulator's truth.
    #[cfg(feature = "sim")]
    Demo(cmd::demo::DemoArgs),
    /// Hardware-free self-check: the Net F/T driver against a loopback box, serial ports.
    #[cfg(feature = "sim")]
    Selfcheck,
    /// List the runs in a directory (default runs/), newest first.
    Runs(cmd::runs::RunsArgs),
    /// Check a run directory: records, frames, force log and checksums.
    Verify(cmd::runs::VerifyArgs),
    /// Export runs as a dataset (the reference pipeline's 0.images/ + 0.labels.csv), or a run as
    /// an MCAP file for Foxglove and ROS 2 (--format mcap).
    Export(cmd::runs::ExportArgs),
    /// Calibrate a sensor build: the calibration scan on the rig (or --images DIR for the optics
    /// only) and its profile: centre, crop radius, image-to-stage geometry, force offsets.
    Calibrate(cmd::calibrate::CalibrateArgs),
    /// Evaluate a model on runs or reference-layout datasets: the paper's Table-2 figures,
    /// errors by grid position and force level, a report with plots (--report DIR).
    Eval(cmd::eval::EvalArgs),
    /// Adapt a model to one sensor unit without libtorch: its heads fitted again on the unit's
    /// labelled frames (runs or datasets), cross-validated over presses.
    Adapt(cmd::adapt::AdaptArgs),
    /// Commission a sensor unit in one job: calibrate it, press where the model errs most,
    /// adapt the model to it, accept or reject it against a spec on held-out presses; a
    /// certificate beside its profile.
    Commission(cmd::commission::CommissionArgs),
    /// Check a commissioned unit against its certificate in at most two minutes of bench time:
    /// optics, light, surface, F/T zero and the model's errors; a verdict (ok, calibrate again,
    /// commission again, replace) with its evidence, kept in the unit's history (--history).
    Check(cmd::check::CheckArgs),
    /// Every sensor unit known: its design, certificate (verdict, date, model), last check and
    /// verdict, when the next check is due, and the model validate runs for it.
    Units(cmd::units::UnitsArgs),
    /// Live validation: a model run on every frame a scan plan records, against the frame's
    /// synchronised F/T label; --no-tui --report DIR writes the metrics and plots.
    Validate(cmd::validate::ValidateArgs),
    /// Stream a unit off the bench: the camera and the unit's model only, each frame's force,
    /// contact and shape published as a ROS 2 node over Zenoh (rmw_zenoh) and recorded to MCAP.
    Stream(cmd::stream::StreamArgs),
    /// Train the paper's networks on runs or datasets, split by press, with the paper's
    /// augmentation (cargo feature `torch`).
    Train(cmd::train::TrainArgs),
    /// Model files: what one is (info), its predictions on images (run), its ONNX graph (export).
    Model(cmd::model::ModelArgs),
    /// The simulated bench: render sensor frames, serve its devices.
    #[cfg(feature = "sim")]
    #[command(subcommand)]
    Sim(SimCommand),
}

/// `fringe sim ...` subcommands.
#[cfg(feature = "sim")]
#[derive(Subcommand)]
enum SimCommand {
    /// Render one simulated sensor frame to a PNG.
    Render(cmd::sim_render::SimRenderArgs),
    /// Render a synthetic training dataset in the reference layout (0.images/ + 0.labels.csv):
    /// random shape, force, contact point and angle per frame, no-contact frames, F/T-noise labels.
    Dataset(cmd::sim_dataset::SimDatasetArgs),
    /// Expose the simulated devices on pseudo-terminals and loopback sockets and print where.
    Serve(cmd::sim_serve::SimServeArgs),
}

fn main() -> ExitCode {
    // Output piped into `head` and the like ends quietly, as for other command-line tools.
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let global = Global {
        record_trace: cli.record_trace,
        no_tui: cli.no_tui,
    };
    let result = match cli.command {
        None if !global.no_tui && std::io::stdout().is_terminal() => cmd::scan::run_ui(),
        None => cmd::scan::run(cmd::scan::ScanArgs::main_job(), &global),
        Some(Command::Scan(args)) => cmd::scan::run(args, &global),
        Some(Command::Plans(args)) => cmd::plans::run(args, &global),
        #[cfg(feature = "sim")]
        Some(Command::Demo(args)) => cmd::demo::run(args, &global),
        #[cfg(feature = "sim")]
        Some(Command::Selfcheck) => cmd::selfcheck::run(&global),
        Some(Command::Devices(args)) => cmd::devices::run(args, &global),
        Some(Command::Ft(args)) => cmd::ft::run(args, &global),
        Some(Command::Daq(args)) => cmd::daq::run(args, &global),
        Some(Command::Ystage(args)) => cmd::ystage::run(args, &global),
        Some(Command::Axis(args)) => cmd::axis::run(args, &global),
        Some(Command::Camera(args)) => cmd::camera::run(args, &global),
        Some(Command::Runs(args)) => cmd::runs::run_list(args, &global),
        Some(Command::Verify(args)) => cmd::runs::run_verify(args, &global),
        Some(Command::Export(args)) => cmd::runs::run_export(args, &global),
        Some(Command::Calibrate(args)) => cmd::calibrate::run(args, &global),
        Some(Command::Model(args)) => cmd::model::run(args),
        Some(Command::Eval(args)) => cmd::eval::run(args),
        Some(Command::Adapt(args)) => cmd::adapt::run(args),
        Some(Command::Commission(args)) => cmd::commission::run(args, &global),
        Some(Command::Check(args)) => cmd::check::run(args, &global),
        Some(Command::Units(args)) => cmd::units::run(args),
        Some(Command::Train(args)) => cmd::train::run(args),
        Some(Command::Validate(args)) => cmd::validate::run(args, &global),
        Some(Command::Stream(args)) => cmd::stream::run(args),
        #[cfg(feature = "sim")]
        Some(Command::Sim(SimCommand::Render(args))) => cmd::sim_render::run(args),
        #[cfg(feature = "sim")]
        Some(Command::Sim(SimCommand::Dataset(args))) => cmd::sim_dataset::run(args),
        #[cfg(feature = "sim")]
        Some(Command::Sim(SimCommand::Serve(args))) => cmd::sim_serve::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Not eprintln!: with the terminal gone (hung up) it would panic.
            let line = hint::with_hint(one_line(&e), &e);
            let _ = writeln!(std::io::stderr(), "fringe: {line}");
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
