//! `fringe` with no command: a self-check that needs no hardware.
//!
//! It runs the real Net F/T driver over real UDP against the built-in simulated Net F/T box on
//! loopback (a two-second press rising to 5 N; `fringe_app::simulation::netft_selfcheck`), reports what
//! arrived, lists the serial ports of
//! this machine and points to the bring-up commands. The full simulated bench (axes, camera,
//! renderer) replaces this with a short grid scan.

use crate::global::Global;
use fringe_app::simulation::netft_selfcheck;

pub fn run(global: &Global) -> anyhow::Result<()> {
    println!(
        "fringe {}: no command given, running the self-check on the simulated Net F/T",
        env!("CARGO_PKG_VERSION")
    );
    let c = netft_selfcheck(global.record_trace.as_deref())?;
    println!(
        "  Net F/T driver over udp {}: {} samples in {:.2} s ({:.0} Hz), {} lost, {} out of order, peak |Fz| {:.2} N",
        c.addr,
        c.samples,
        c.seconds,
        c.samples as f64 / c.seconds,
        c.stats.lost,
        c.stats.out_of_order,
        c.peak_n
    );
    println!();
    crate::cmd::devices::run(crate::cmd::devices::DevicesArgs {}, global)?;
    println!();
    println!("bench bring-up commands (see `fringe --help` and README.md):");
    println!("  fringe axis --port PATH --actuator ZFS25 status|home|move MM|move-rel MM|stop");
    println!("  fringe ft --netft HOST stream --seconds 10 --csv ft.csv");
    println!("  fringe ystage --modbus-tcp HOST:PORT --map oriental-az status|home|move MM");
    println!("  fringe camera --aravis ID grab --count 10 --out frames/   (build with --features aravis)");
    Ok(())
}
