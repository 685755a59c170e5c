//! `fringe ft`: bring up an ATI Net F/T / Ethernet Axia force/torque sensor.
//!
//! ```text
//! fringe ft --netft HOST[:PORT] [--cpf N --cpt N] stream --seconds S --csv FILE
//! fringe ft --netft HOST[:PORT] bias
//! ```

use super::arg_values;
use crate::global::Global;
use anyhow::Context;
use fringe_app::bringup;
use fringe_app::bringup::stream_to_csv;
use fringe_app::bringup::Interface;
use fringe_app::rig::HostPort;
use fringe_app::rig::TraceTo;
use fringe_app::rig::{open_netft, NetFtScaling, NetFtSpec};
use fringe_rig::DatagramLink;
use fringe_rig::ForceSensor;
use fringe_rig::{
    netft::{Command, DEFAULT_PORT},
    NetFt, NetFtConfig,
};
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(clap::Args)]
pub struct FtArgs {
    /// Net F/T or Ethernet Axia address, HOST[:PORT] (RDT port, default 49152).
    #[arg(long, value_name = "HOST[:PORT]")]
    netft: String,

    /// Counts per force unit (cfgcpf); read from http://HOST/netftapi2.xml when not given.
    #[arg(long, value_name = "N", requires = "cpt")]
    cpf: Option<f64>,

    /// Counts per torque unit (cfgcpt); read from http://HOST/netftapi2.xml when not given.
    #[arg(long, value_name = "N", requires = "cpf")]
    cpt: Option<f64>,

    /// Force unit the --cpf counts refer to (lbf, N, kN, gf, kgf ...).
    #[arg(long, value_name = "UNIT", default_value = "N")]
    force_unit: String,

    /// Torque unit the --cpt counts refer to (lbf-in, lbf-ft, N-m, N-mm, kN-m ...).
    #[arg(long, value_name = "UNIT", default_value = "N-m")]
    torque_unit: String,

    /// Where to read the sensor configuration instead of http://HOST/netftapi2.xml.
    #[arg(long, value_name = "URL", conflicts_with = "cpf")]
    config_url: Option<String>,

    #[command(subcommand)]
    action: FtAction,
}

#[derive(clap::Subcommand)]
enum FtAction {
    /// Stream samples to a CSV file and report the rate and lost packets.
    Stream {
        /// How long to stream.
        #[arg(long, value_name = "S", value_parser = arg_values::seconds)]
        seconds: Duration,
        /// Output CSV: host time s, rdt sequence, ft sequence, Fx Fy Fz (N), Tx Ty Tz (N m).
        #[arg(long, value_name = "FILE")]
        csv: PathBuf,
        /// Ask for buffered RDT (several records per datagram) instead of real-time.
        #[arg(long)]
        buffered: bool,
    },
    /// Zero the sensor at the current load (RDT software bias) and show the reading after it.
    Bias,
}

impl FtArgs {
    /// The Net F/T the flags describe, as a rig file's `[force]` section would describe it.
    fn spec(&self, mode: Command) -> anyhow::Result<NetFtSpec> {
        let address = HostPort::parse(&self.netft, Some(DEFAULT_PORT)).context("--netft")?;
        let scaling = match (self.cpf, self.cpt) {
            (Some(cpf), Some(cpt)) => NetFtScaling::Given(NetFtConfig::new(
                cpf,
                cpt,
                &self.force_unit,
                &self.torque_unit,
                "--cpf/--cpt",
            )?),
            _ => NetFtScaling::FromBox {
                url: self.config_url.clone(),
            },
        };
        Ok(NetFtSpec::new(address, scaling, mode))
    }
}

fn connect(
    args: &FtArgs,
    global: &Global,
    mode: Command,
) -> anyhow::Result<NetFt<Box<dyn DatagramLink>>> {
    let spec = args.spec(mode)?;
    Ok(open_netft(
        &spec,
        TraceTo::new(global.record_trace.as_deref(), "netft"),
    )?)
}

pub fn run(args: FtArgs, global: &Global) -> anyhow::Result<()> {
    match &args.action {
        FtAction::Stream {
            seconds,
            csv,
            buffered,
        } => {
            let mode = if *buffered {
                Command::Buffered
            } else {
                Command::RealTime
            };
            let sensor = connect(&args, global, mode)?;
            stream(sensor, *seconds, csv)
        }
        FtAction::Bias => bias(connect(&args, global, Command::RealTime)?),
    }
}

/// Streams samples into the CSV file `csv` for `duration` and prints their rate and losses.
fn stream(
    mut sensor: NetFt<Box<dyn DatagramLink>>,
    duration: Duration,
    csv: &Path,
) -> anyhow::Result<()> {
    let report = stream_to_csv(
        &mut sensor,
        Interface::NetFt,
        duration,
        csv,
        false,
        &mut |_, _| {},
    )?;
    println!("samples: {}", report.samples);
    println!("rate: {:.1} Hz", report.rate());
    println!("lost packets: {}", report.stats.lost);
    println!("out of order: {}", report.stats.out_of_order);
    if report.samples > 0 {
        println!("csv: {}", csv.display());
    }
    report.ended?;
    Ok(())
}

fn bias(mut sensor: NetFt<Box<dyn DatagramLink>>) -> anyhow::Result<()> {
    let b = bringup::bias_netft(&mut sensor)?;
    let (m, n) = (b.mean_after, b.records);
    println!("software bias sent to {}", sensor.describe());
    println!(
        "reading after bias (mean of {n}): Fx {:.4} N  Fy {:.4} N  Fz {:.4} N  Tx {:.5} N m  Ty {:.5} N m  Tz {:.5} N m",
        m[0], m[1], m[2], m[3], m[4], m[5]
    );
    Ok(())
}

/// The same Net F/T described by `fringe ft` flags and by a rig file's `[force]` section.
#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use fringe_app::rig::ForceSpec;
    use fringe_app::RigConfig;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        ft: FtArgs,
    }

    fn flags(args: &[&str]) -> NetFtSpec {
        let cli = Cli::try_parse_from(std::iter::once("ft").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        cli.ft.spec(Command::RealTime).expect("spec from flags")
    }

    fn rig_file(force: &str) -> NetFtSpec {
        let text = format!(
            "[x]\ndriver = \"thorlabs\"\n[y]\ndriver = \"manual\"\n[z]\ndriver = \"thorlabs\"\n[force]\ndriver = \"netft\"\n{force}\n[camera]\ndriver = \"aravis\"\n"
        );
        match RigConfig::parse(&text, "rig.toml")
            .expect("rig file")
            .force_spec()
            .expect("spec from the rig file")
        {
            ForceSpec::NetFt(spec) => spec,
            other => panic!("a Net F/T rig file gave {other:?}"),
        }
    }

    #[test]
    fn flags_and_a_rig_file_describe_the_same_sensor_ipv6_included() {
        for (flag, key, host, port) in [
            ("[fe80::1]:49153", "[fe80::1]:49153", "fe80::1", 49153),
            ("fe80::1", "fe80::1", "fe80::1", DEFAULT_PORT),
            ("[::1]", "[::1]", "::1", DEFAULT_PORT),
            ("ft.local:5000", "ft.local:5000", "ft.local", 5000),
            ("192.168.1.1", "192.168.1.1", "192.168.1.1", DEFAULT_PORT),
        ] {
            let a = flags(&["--netft", flag, "bias"]);
            let b = rig_file(&format!("address = \"{key}\""));
            assert_eq!(a, b, "{flag}");
            assert_eq!(
                a.address,
                HostPort {
                    host: host.into(),
                    port
                }
            );
            assert_eq!(a.scaling, NetFtScaling::FromBox { url: None });
        }
        let a = flags(&[
            "--netft",
            "[::1]:49152",
            "--cpf",
            "1000000",
            "--cpt",
            "1000",
            "--force-unit",
            "lbf",
            "bias",
        ]);
        let b = rig_file(
            "address = \"[::1]:49152\"\ncpf = 1000000.0\ncpt = 1000.0\nforce_unit = \"lbf\"\ntorque_unit = \"N-m\"",
        );
        assert_eq!(a, b);
    }

    #[test]
    fn both_descriptions_open_the_same_driver_on_the_same_ipv6_address() {
        // Opening a Net F/T with its counts given only opens a UDP socket to it.
        if std::net::UdpSocket::bind("[::1]:0").is_err() {
            eprintln!("no IPv6 loopback here: the descriptions are compared above");
            return;
        }
        let args = ["--netft", "[::1]:49152", "--cpf", "1", "--cpt", "1", "bias"];
        let a = flags(&args);
        let b = rig_file("address = \"[::1]:49152\"\ncpf = 1.0\ncpt = 1.0\ntorque_unit = \"N-m\"");
        let trace = TraceTo::new(None, "netft");
        let one = open_netft(&a, trace).expect("open from flags");
        let two = open_netft(&b, trace).expect("open from the rig file");
        assert_eq!(one.describe(), two.describe());
        assert!(
            one.describe().contains("[::1]:49152") || one.describe().contains("::1"),
            "{}",
            one.describe()
        );
    }
}
