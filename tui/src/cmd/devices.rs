//! `fringe devices`: what is plugged in.

use crate::global::Global;
use anyhow::Context;
use fringe_rig::list_ports;

#[derive(clap::Args)]
pub struct DevicesArgs {}

pub fn run(_args: DevicesArgs, _global: &Global) -> anyhow::Result<()> {
    let ports = list_ports().context("cannot list serial ports")?;
    println!("serial ports:");
    if ports.is_empty() {
        println!("  (none found)");
    }
    for p in &ports {
        let usb = match p.usb {
            Some((vid, pid)) => format!(" usb {vid:04x}:{pid:04x}"),
            None => String::new(),
        };
        let serial = p
            .serial_number
            .as_deref()
            .map(|s| format!(" serial {s}"))
            .unwrap_or_default();
        let product = p
            .product
            .as_deref()
            .map(|s| format!(" \"{s}\""))
            .unwrap_or_default();
        let mark = if p.is_thorlabs() {
            "  [Thorlabs APT controller]"
        } else {
            ""
        };
        println!("  {}{usb}{serial}{product}{mark}", p.path);
    }
    list_cameras()
}

#[cfg(feature = "aravis")]
fn list_cameras() -> anyhow::Result<()> {
    let cameras = fringe_rig::list_cameras().context("cannot list Aravis cameras")?;
    println!("cameras (Aravis):");
    if cameras.is_empty() {
        println!("  (none found)");
    }
    for c in &cameras {
        println!(
            "  {}  {} {}  {} {}",
            c.id, c.vendor, c.model, c.protocol, c.address
        );
    }
    Ok(())
}

#[cfg(not(feature = "aravis"))]
fn list_cameras() -> anyhow::Result<()> {
    println!("cameras: not listed (built without Aravis; rebuild with --features aravis)");
    Ok(())
}
