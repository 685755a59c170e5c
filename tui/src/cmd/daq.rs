//! `fringe daq`: bring up an ATI transducer read through an NI-DAQmx device (the paper's NI
//! USB-6218) with its `.cal` file.
//!
//! ```text
//! fringe daq --device Dev1 --channels ai0:5 [--strobe ai7] --cal FILE [--library PATH]
//!            [--terminal diff] [--range 10] [--rate 5000] stream --seconds S --csv FILE [--bias]
//! fringe daq ... bias
//! ```

use super::arg_values;
use crate::global::Global;
use fringe_app::bringup;
use fringe_app::bringup::Interface;
use fringe_app::bringup::{stream_to_csv, StreamReport};
use fringe_app::rig::DaqNames;
use fringe_app::rig::TraceTo;
use fringe_app::rig::{open_daq, DaqForce, DaqSpec};
use fringe_rig::nidaqmx::{DaqSettings, Terminal};
use fringe_rig::ForceSensor;
use fringe_rig::{Hertz, Volts};
use std::path::PathBuf;
use std::time::Duration;

#[derive(clap::Args)]
pub struct DaqArgs {
    /// NI device name, as NI MAX or `nilsdev` lists it.
    #[arg(long, value_name = "NAME", default_value = "Dev1")]
    device: String,

    /// The six gauge channels, in the .cal file's gauge order.
    #[arg(long, value_name = "CHANNELS", default_value = "ai0:5")]
    channels: String,

    /// The analogue input carrying the camera's exposure signal, if wired (adds a strobe_v column).
    #[arg(long, value_name = "CHANNEL")]
    strobe: Option<String>,

    /// The transducer's ATI calibration file (FT*.cal).
    #[arg(long, value_name = "FILE")]
    cal: PathBuf,

    /// NI-DAQmx's library (libnidaqmx.so), when not on the system's search path.
    #[arg(long, value_name = "PATH")]
    library: Option<PathBuf>,

    /// Terminal configuration: diff, rse, nrse, pseudo-diff or default.
    #[arg(long, value_name = "CONFIG", default_value = "diff")]
    terminal: String,

    /// Input range, +- volts.
    #[arg(
        long,
        value_name = "V",
        default_value_t = 10.0,
        allow_negative_numbers = true
    )]
    range: f64,

    /// Scans per second on the device's sample clock.
    #[arg(
        long,
        value_name = "HZ",
        default_value_t = 5000.0,
        allow_negative_numbers = true
    )]
    rate: f64,

    /// Scans the input buffer holds per channel (NI's default when not given: 2 s at 5 kHz).
    #[arg(long, value_name = "N")]
    buffer_scans: Option<u32>,

    #[command(subcommand)]
    action: DaqAction,
}

#[derive(clap::Subcommand)]
enum DaqAction {
    /// Stream calibrated samples to a CSV file and count them against the elapsed time.
    Stream {
        /// How long to stream.
        #[arg(long, value_name = "S", value_parser = arg_values::seconds)]
        seconds: Duration,
        /// Output CSV: host time s, sample index, Fx Fy Fz (N), Tx Ty Tz (N m)[, strobe V].
        #[arg(long, value_name = "FILE")]
        csv: PathBuf,
        /// Take a bias at the current load first (the rows are then relative to it).
        #[arg(long)]
        bias: bool,
    },
    /// Take a bias at the current load and show the reading after it.
    Bias,
}

impl DaqArgs {
    /// The DAQ the flags describe, as a rig file's `[force]` section would describe it; errors
    /// name the flag.
    fn spec(&self) -> anyhow::Result<DaqSpec> {
        let terminal =
            Terminal::parse(&self.terminal).map_err(|e| anyhow::anyhow!("--terminal: {e}"))?;
        let settings = DaqSettings {
            device: self.device.clone(),
            gauges: self.channels.clone(),
            strobe: self.strobe.clone(),
            terminal,
            range: Volts(self.range),
            rate: Hertz(self.rate),
            buffer_scans: self.buffer_scans,
        };
        let spec = DaqSpec {
            settings,
            cal_file: self.cal.clone(),
            library: self.library.clone(),
            tool: None,
            camera_trigger: None,
            named_by: DaqNames::Flags,
        };
        if let Err(e) = spec.settings.check() {
            return Err(fringe_app::rig::daq_error(&spec, e).into());
        }
        Ok(spec)
    }
}

fn open(args: &DaqArgs, global: &Global) -> anyhow::Result<(DaqSpec, DaqForce)> {
    let spec = args.spec()?;
    let sensor = open_daq(&spec, TraceTo::new(global.record_trace.as_deref(), "force"))?;
    Ok((spec, sensor))
}

pub fn run(args: DaqArgs, global: &Global) -> anyhow::Result<()> {
    let (spec, mut sensor) = open(&args, global)?;
    println!("{}", sensor.describe());
    match &args.action {
        DaqAction::Stream { seconds, csv, bias } => {
            let strobe = spec.settings.strobe.is_some();
            let report = stream_to_csv(
                &mut sensor,
                Interface::Daq { strobe },
                *seconds,
                csv,
                *bias,
                &mut |samples, elapsed| {
                    println!("{:5.1} s: {samples} samples", elapsed.as_secs_f64())
                },
            )?;
            print_report(&report, spec.settings.rate, &sensor);
            if report.samples > 0 {
                println!("csv: {}", csv.display());
            }
            report.ended?;
            Ok(())
        }
        DaqAction::Bias => {
            let b = bringup::bias_daq(&mut sensor)?;
            let v = b.volts;
            println!(
                "bias (V): {:.5} {:.5} {:.5} {:.5} {:.5} {:.5}; it holds for this command only (a scan takes its own bias)",
                v[0], v[1], v[2], v[3], v[4], v[5]
            );
            let m = b.mean_after;
            println!(
                "reading after bias (mean of {}): Fx {:.4} N  Fy {:.4} N  Fz {:.4} N  Tx {:.5} N m  Ty {:.5} N m  Tz {:.5} N m",
                b.samples, m[0], m[1], m[2], m[3], m[4], m[5]
            );
            Ok(())
        }
    }
}

/// Prints the samples received against those the elapsed time gives, and the losses.
fn print_report(report: &StreamReport, rate: Hertz, sensor: &DaqForce) {
    let daq = sensor.source().stats();
    println!("samples: {}", report.samples);
    println!(
        "expected: {} ({:.3} s at {} Hz)",
        report.expected(rate),
        report.elapsed.as_secs_f64(),
        rate.0
    );
    println!("lost samples: {}", report.stats.lost);
    println!("overruns: {} ({} scans lost)", daq.overruns, daq.lost);
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use fringe_app::rig::ForceSpec;
    use fringe_app::RigConfig;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        daq: DaqArgs,
    }

    fn args(flags: &[&str]) -> DaqArgs {
        Cli::try_parse_from(std::iter::once("daq").chain(flags.iter().copied()))
            .unwrap_or_else(|e| panic!("{flags:?}: {e}"))
            .daq
    }

    #[test]
    fn flags_and_a_rig_file_describe_the_same_daq() {
        let a = args(&[
            "--device",
            "Dev2",
            "--channels",
            "ai8:13",
            "--strobe",
            "ai15",
            "--cal",
            "FT1.cal",
            "--terminal",
            "rse",
            "--range",
            "5",
            "--rate",
            "2000",
            "--library",
            "/opt/l.so",
            "bias",
        ])
        .spec()
        .expect("spec");
        let text = "[x]\ndriver = \"thorlabs\"\n[y]\ndriver = \"manual\"\n[z]\ndriver = \"thorlabs\"\n[force]\ndriver = \"nidaqmx\"\ndevice = \"Dev2\"\ngauges = \"ai8:13\"\nstrobe = \"ai15\"\ncal_file = \"FT1.cal\"\nterminal = \"rse\"\nrange_v = 5.0\nrate_hz = 2000.0\nlibrary = \"/opt/l.so\"\n[camera]\ndriver = \"aravis\"\n";
        let ForceSpec::NiDaqmx(b) = RigConfig::parse(text, "rig.toml")
            .expect("rig file")
            .force_spec()
            .expect("spec")
        else {
            panic!("not a DAQ");
        };
        assert_eq!(a.settings, b.settings);
        assert_eq!((a.cal_file, a.library), (b.cal_file, b.library));
        let defaults = args(&["--cal", "FT1.cal", "bias"]).spec().expect("spec");
        assert_eq!(defaults.settings, DaqSettings::default());
    }

    #[test]
    fn bad_flags_are_refused_naming_the_flag() {
        for (flags, flag) in [
            (vec!["--terminal", "floating"], "--terminal"),
            (vec!["--channels", "ai0:4"], "--channels"),
            (vec!["--strobe", "ai6:7"], "--strobe"),
            (vec!["--range", "-1"], "--range"),
            (vec!["--rate", "0"], "--rate"),
            (vec!["--device", ""], "--device"),
        ] {
            let mut all = flags.clone();
            all.extend(["--cal", "FT1.cal", "bias"]);
            let e = args(&all).spec().expect_err(flag).to_string();
            assert!(e.contains(flag), "{flags:?}: {e}");
        }
    }
}
