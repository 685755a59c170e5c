//! `fringe ft`: bring up an ATI Net F/T / Ethernet Axia force/torque sensor.
//!
//! ```text
//! fringe ft --netft HOST[:PORT] [--cpf N --cpt N] stream --seconds S --csv FILE
//! fringe ft --netft HOST[:PORT] bias
//! ```

use super::arg_values;
use crate::Global;
use anyhow::{bail, Context};
use fringe_rig::force::{ForceSample, ForceSensor};
use fringe_rig::netft::{self, Command, NetFt, NetFtConfig, NetFtOptions, DEFAULT_PORT};
use fringe_rig::trace::record_datagrams;
use fringe_rig::transport::udp::UdpLink;
use fringe_rig::transport::DatagramLink;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

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

/// Splits `HOST[:PORT]` (`[v6]:PORT` for IPv6) into a host and a port.
fn split_host_port(text: &str) -> anyhow::Result<(String, u16)> {
    let bad =
        || format!("--netft `{text}`: expected HOST or HOST:PORT (for example 192.168.1.1:49152)");
    if let Some(rest) = text.strip_prefix('[') {
        let (host, after) = rest.split_once(']').with_context(bad)?;
        let port = match after.strip_prefix(':') {
            Some(p) => p.parse().with_context(bad)?,
            None if after.is_empty() => DEFAULT_PORT,
            None => bail!(bad()),
        };
        return Ok((host.to_string(), port));
    }
    match text.split_once(':') {
        Some((host, port)) if !port.contains(':') => {
            if host.is_empty() {
                bail!(bad());
            }
            Ok((host.to_string(), port.parse().with_context(bad)?))
        }
        // A bare IPv6 address.
        Some(_) => Ok((text.to_string(), DEFAULT_PORT)),
        None if text.is_empty() => bail!(bad()),
        None => Ok((text.to_string(), DEFAULT_PORT)),
    }
}

fn scaling(args: &FtArgs, host: &str) -> anyhow::Result<NetFtConfig> {
    match (args.cpf, args.cpt) {
        (Some(cpf), Some(cpt)) => Ok(NetFtConfig::new(
            cpf,
            cpt,
            &args.force_unit,
            &args.torque_unit,
            "--cpf/--cpt",
        )?),
        _ => {
            let host_for_url = if host.contains(':') {
                format!("[{host}]")
            } else {
                host.to_string()
            };
            let url = args
                .config_url
                .clone()
                .unwrap_or_else(|| netft::netftapi2_url(&host_for_url));
            Ok(netft::fetch_config(&url, Duration::from_secs(3))?)
        }
    }
}

fn connect(
    args: &FtArgs,
    global: &Global,
    mode: Command,
) -> anyhow::Result<NetFt<Box<dyn DatagramLink>>> {
    let (host, port) = split_host_port(&args.netft)?;
    let config = scaling(args, &host)?;
    let addr = if host.contains(':') {
        format!("[{host}]:{port}")
    } else {
        format!("{host}:{port}")
    };
    let link: Box<dyn DatagramLink> = Box::new(
        UdpLink::connect(&addr)
            .with_context(|| format!("cannot open a UDP socket to Net F/T {addr}"))?,
    );
    let dir = global.record_trace.as_deref();
    let link = record_datagrams(link, dir, "netft").with_context(|| match dir {
        Some(d) => format!(
            "cannot record a trace in {} (check the directory is writable)",
            d.display()
        ),
        None => "cannot open the link".to_string(),
    })?;
    Ok(NetFt::new(
        link,
        config,
        NetFtOptions {
            mode,
            ..NetFtOptions::default()
        },
    ))
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

fn csv_row(out: &mut impl Write, s: &ForceSample) -> std::io::Result<()> {
    let w = s.wrench.to_array();
    writeln!(
        out,
        "{:.6},{},{},{},{},{},{},{},{}",
        s.host_time.seconds(),
        s.transport_seq.unwrap_or(0),
        s.device_tick,
        w[0],
        w[1],
        w[2],
        w[3],
        w[4],
        w[5]
    )
}

fn stream(
    mut sensor: NetFt<Box<dyn DatagramLink>>,
    duration: Duration,
    csv: &PathBuf,
) -> anyhow::Result<()> {
    // A file this command created and filled with nothing is removed again (never a device
    // such as /dev/null, nor a file that was there before).
    let created = !csv.exists();
    let discard_empty = || {
        if created && csv.metadata().is_ok_and(|m| m.is_file()) {
            let _ = std::fs::remove_file(csv);
        }
    };
    let file = File::create(csv).with_context(|| {
        format!(
            "cannot create {} (check the directory exists and is writable)",
            csv.display()
        )
    })?;
    let mut out = BufWriter::new(file);
    let write_err = |e: std::io::Error| anyhow::anyhow!("cannot write {}: {e}", csv.display());
    writeln!(
        out,
        "host_time_s,rdt_sequence,ft_sequence,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm"
    )
    .map_err(write_err)?;
    if let Err(e) = sensor.start() {
        drop(out);
        discard_empty();
        return Err(e.into());
    }
    let started = Instant::now();
    let mut count = 0u64;
    let mut first = None;
    let mut last = None;
    let mut last_arrival = Instant::now();
    let stall = Duration::from_secs(1);
    let result = loop {
        if started.elapsed() >= duration {
            break Ok(());
        }
        match sensor.next_sample(Duration::from_millis(50)) {
            Ok(Some(s)) => {
                csv_row(&mut out, &s).map_err(write_err)?;
                count += 1;
                first.get_or_insert(s.host_time);
                last = Some(s.host_time);
                last_arrival = Instant::now();
            }
            Ok(None) if last_arrival.elapsed() >= stall => {
                break Err(anyhow::anyhow!(
                    "{}: the stream stopped (no record for {} s); check the cable and that nothing else restarted the sensor",
                    sensor.describe(),
                    stall.as_secs()
                ))
            }
            Ok(None) => {}
            Err(e) => break Err(e.into()),
        }
    };
    let stopped = sensor.stop();
    out.flush().map_err(write_err)?;
    let stats = sensor.stats();
    let span = match (first, last) {
        (Some(a), Some(b)) => b.since(a).as_secs_f64(),
        _ => 0.0,
    };
    let rate = if count > 1 && span > 0.0 {
        (count - 1) as f64 / span
    } else {
        0.0
    };
    println!("samples: {count}");
    println!("rate: {rate:.1} Hz");
    println!("lost packets: {}", stats.lost);
    println!("out of order: {}", stats.out_of_order);
    if count == 0 {
        // A CSV of only the header would pass for a recording; leave nothing instead.
        drop(out);
        discard_empty();
        result?;
        bail!(
            "{}: no sample arrived in {:.1} s; nothing written to {} (check the address and that the sensor streams)",
            sensor.describe(),
            duration.as_secs_f64(),
            csv.display()
        );
    }
    println!("csv: {}", csv.display());
    result?;
    stopped?;
    Ok(())
}

fn bias(mut sensor: NetFt<Box<dyn DatagramLink>>) -> anyhow::Result<()> {
    sensor.start()?;
    sensor.bias()?;
    // Skip records already in flight when the bias was applied, then average 100 ms.
    let wait = Duration::from_millis(500);
    let settle = Instant::now() + Duration::from_millis(50);
    let end = settle + Duration::from_millis(100);
    let mut sum = [0.0; 6];
    let mut n = 0u32;
    loop {
        let Some(s) = sensor.next_sample(wait)? else {
            bail!(
                "{}: no record after the bias command; check the stream",
                sensor.describe()
            );
        };
        let now = Instant::now();
        if now >= settle {
            for (a, v) in sum.iter_mut().zip(s.wrench.to_array()) {
                *a += v;
            }
            n += 1;
        }
        if now >= end && n > 0 {
            break;
        }
    }
    sensor.stop()?;
    let m = sum.map(|v| v / f64::from(n));
    println!("software bias sent to {}", sensor.describe());
    println!(
        "reading after bias (mean of {n}): Fx {:.4} N  Fy {:.4} N  Fz {:.4} N  Tx {:.5} N m  Ty {:.5} N m  Tz {:.5} N m",
        m[0], m[1], m[2], m[3], m[4], m[5]
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::split_host_port;

    #[test]
    fn host_and_port() {
        assert_eq!(
            split_host_port("192.168.1.1").expect("bare"),
            ("192.168.1.1".into(), 49152)
        );
        assert_eq!(
            split_host_port("ft.local:5000").expect("port"),
            ("ft.local".into(), 5000)
        );
        assert_eq!(split_host_port("[::1]:7").expect("v6"), ("::1".into(), 7));
        assert_eq!(
            split_host_port("fe80::1").expect("bare v6"),
            ("fe80::1".into(), 49152)
        );
        assert!(split_host_port("host:port").is_err());
        assert!(split_host_port(":80").is_err());
    }
}
