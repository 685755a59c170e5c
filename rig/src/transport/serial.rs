//! Serial ports (FTDI USB adapters, RS-485 converters) through the `serialport` crate.

use super::ByteLink;
use std::io::{self, Read, Write};
use std::time::Duration;

/// Parity of a serial line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parity {
    None,
    Even,
    Odd,
}

/// Line settings for opening a serial port.
#[derive(Debug, Clone, PartialEq)]
pub struct SerialSettings {
    pub baud: u32,
    pub parity: Parity,
    pub stop_bits: u8,
    /// RTS/CTS hardware flow control.
    pub rts_cts: bool,
}

impl SerialSettings {
    /// 8N1 at `baud`, no flow control.
    pub fn plain(baud: u32) -> Self {
        SerialSettings {
            baud,
            parity: Parity::None,
            stop_bits: 1,
            rts_cts: false,
        }
    }
}

/// A serial port that would not open (the `io::Error` of [`SerialLink::open`] carries it, for a
/// front end that names the command listing the ports).
#[derive(Debug, thiserror::Error)]
#[error("cannot open serial port {path}: {source} (check the cable, the port's path, and that your user is in the dialout group)")]
pub struct PortOpenError {
    pub path: String,
    #[source]
    pub source: serialport::Error,
}

/// An open serial port.
pub struct SerialLink {
    port: Box<dyn serialport::SerialPort>,
    path: String,
}

impl SerialLink {
    /// Opens `path` with `settings`. The error names the port and what to check.
    pub fn open(path: &str, settings: &SerialSettings) -> io::Result<SerialLink> {
        let builder = serialport::new(path, settings.baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(match settings.parity {
                Parity::None => serialport::Parity::None,
                Parity::Even => serialport::Parity::Even,
                Parity::Odd => serialport::Parity::Odd,
            })
            .stop_bits(if settings.stop_bits == 2 {
                serialport::StopBits::Two
            } else {
                serialport::StopBits::One
            })
            .flow_control(if settings.rts_cts {
                serialport::FlowControl::Hardware
            } else {
                serialport::FlowControl::None
            })
            .timeout(Duration::from_millis(50));
        let port = builder.open().map_err(|source| {
            io::Error::new(
                io::ErrorKind::NotFound,
                PortOpenError {
                    path: path.to_string(),
                    source,
                },
            )
        })?;
        Ok(SerialLink {
            port,
            path: path.to_string(),
        })
    }

    /// Sets the RTS line (used by the Thorlabs open sequence).
    pub fn set_rts(&mut self, level: bool) -> io::Result<()> {
        self.port
            .write_request_to_send(level)
            .map_err(io::Error::from)
    }

    /// The path this port was opened with.
    pub fn path(&self) -> &str {
        &self.path
    }
}

impl ByteLink for SerialLink {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.port
            .set_timeout(timeout.max(Duration::from_millis(1)))
            .map_err(io::Error::from)?;
        match self.port.read(buf) {
            Ok(n) => Ok(n),
            Err(e)
                if e.kind() == io::ErrorKind::TimedOut || e.kind() == io::ErrorKind::WouldBlock =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }

    fn purge(&mut self) -> io::Result<()> {
        self.port
            .clear(serialport::ClearBuffer::All)
            .map_err(io::Error::from)
    }

    fn describe(&self) -> String {
        format!("serial {}", self.path)
    }
}

/// A serial port as listed by [`list_ports`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    pub path: String,
    /// USB vendor and product id, when the port is a USB adapter.
    pub usb: Option<(u16, u16)>,
    pub serial_number: Option<String>,
    pub product: Option<String>,
}

impl PortInfo {
    /// True for the FTDI id that Thorlabs controllers use (0403:FAF0).
    pub fn is_thorlabs(&self) -> bool {
        self.usb == Some((0x0403, 0xFAF0))
    }
}

/// Lists the serial ports of this machine.
pub fn list_ports() -> io::Result<Vec<PortInfo>> {
    let ports = serialport::available_ports().map_err(io::Error::from)?;
    Ok(ports
        .into_iter()
        .map(|p| match p.port_type {
            serialport::SerialPortType::UsbPort(u) => PortInfo {
                path: p.port_name,
                usb: Some((u.vid, u.pid)),
                serial_number: u.serial_number,
                product: u.product,
            },
            _ => PortInfo {
                path: p.port_name,
                usb: None,
                serial_number: None,
                product: None,
            },
        })
        .collect())
}
