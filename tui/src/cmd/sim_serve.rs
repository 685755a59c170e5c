//! `fringe sim serve`: the simulated bench's devices on pseudo-terminals and loopback sockets,
//! for third-party software (thorlabs-apt-device, pylablib, pynetft, pymodbus...) or for fringe
//! itself in another process.

use super::sim_render::load_sensor;
use anyhow::Context;
use fringe_sim::{SimRigConfig, SimServe};
use std::io::Write;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

#[derive(clap::Args)]
pub struct SimServeArgs {
    /// Also make PATH a symbolic link to the x controller's pseudo-terminal (stable name).
    #[arg(long, value_name = "PATH")]
    apt_x: Option<std::path::PathBuf>,
    /// Also make PATH a symbolic link to the z controller's pseudo-terminal.
    #[arg(long, value_name = "PATH")]
    apt_z: Option<std::path::PathBuf>,
    /// UDP address of the emulated Net F/T (its netftapi2.xml is served over HTTP on TCP at the
    /// same address, where `fringe ft --netft IP` finds it; an ephemeral port if that is taken).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:49152")]
    netft: SocketAddr,
    /// TCP address of the emulated Modbus y drive (also served as RTU on a pseudo-terminal).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:1502")]
    modbus: SocketAddr,
    /// Sensor build (only its seed matters here; the camera is not served).
    #[arg(
        long,
        value_name = "layered|integrated|PATH.toml",
        default_value = "layered"
    )]
    sensor: String,
    /// Seed of the simulated bench.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Stop after this many seconds (default: run until interrupted).
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
}

pub fn run(args: SimServeArgs) -> anyhow::Result<()> {
    let config = SimRigConfig {
        seed: args.seed,
        sensor: load_sensor(&args.sensor)?,
        ..SimRigConfig::default()
    };
    let serve = SimServe::start(&config, args.netft, args.modbus)
        .context("cannot start the simulated bench's devices")?;
    let e = &serve.endpoints;
    let mut links = Vec::new();
    for (link, target) in [(&args.apt_x, &e.apt_x), (&args.apt_z, &e.apt_z)] {
        if let Some(link) = link {
            if link
                .symlink_metadata()
                .is_ok_and(|m| m.file_type().is_symlink())
            {
                std::fs::remove_file(link)
                    .with_context(|| format!("cannot replace the old link {}", link.display()))?;
            }
            std::os::unix::fs::symlink(target, link).with_context(|| {
                format!(
                    "cannot create the link {} (a file of that name exists?)",
                    link.display()
                )
            })?;
            links.push(link.clone());
        }
    }
    // One `name value` line per endpoint, so a script can read them.
    println!("apt-x {}", e.apt_x);
    println!("apt-z {}", e.apt_z);
    println!("netft {}", e.netft);
    if let Some(url) = &e.netft_http {
        println!("netft-http {url}");
    }
    println!("modbus-tcp {}", e.modbus_tcp);
    if let Some(p) = &e.modbus_rtu {
        println!("modbus-rtu {p}");
    }
    println!("ready");
    std::io::stdout().flush().ok();
    eprintln!(
        "serving: KST101 + ZFS25 on apt-x/apt-z (115200 8N1 RTS/CTS), Net F/T RDT, Modbus y (map {}); Ctrl-C stops",
        config.y_map
    );
    let started = Instant::now();
    loop {
        if let Some(limit) = args.seconds {
            if started.elapsed().as_secs_f64() >= limit {
                break;
            }
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    drop(serve);
    for link in links {
        let _ = std::fs::remove_file(link);
    }
    Ok(())
}
