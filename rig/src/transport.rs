//! Transports: how bytes reach a device.
//!
//! Two shapes cover the bench: a byte stream (serial ports, pseudo-terminals, TCP) and datagrams
//! (UDP). Drivers talk to `dyn ByteLink` / `dyn DatagramLink`, so the same driver runs on a real
//! port, on a simulated device, on a recording wrapper ([`crate::trace::RecordingLink`]) or on a
//! replayed trace ([`crate::trace::ReplayLink`]).

pub(crate) mod memory;
pub(crate) mod pty;
pub(crate) mod serial;
pub(crate) mod tcp;
pub(crate) mod udp;

use std::io;
use std::time::Duration;

/// A bidirectional byte stream to one device.
pub trait ByteLink: Send {
    /// Writes all of `bytes` (one protocol message per call where the protocol has messages).
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()>;

    /// Reads whatever arrives within `timeout` into `buf`. `Ok(0)` means nothing arrived in time.
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;

    /// Discards anything buffered in either direction (no-op where meaningless).
    fn purge(&mut self) -> io::Result<()> {
        Ok(())
    }

    /// A short human description naming the endpoint, for error messages ("serial /dev/ttyUSB0").
    fn describe(&self) -> String;
}

/// A datagram socket connected to one device.
pub trait DatagramLink: Send {
    /// Sends one datagram.
    fn send(&mut self, datagram: &[u8]) -> io::Result<()>;

    /// Receives one datagram into `buf`; `Ok(None)` when nothing arrived within `timeout`.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>>;

    /// A short human description naming the endpoint ("udp 192.168.1.1:49152").
    fn describe(&self) -> String;
}

impl<T: ByteLink + ?Sized> ByteLink for Box<T> {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).write_all(bytes)
    }
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        (**self).read(buf, timeout)
    }
    fn purge(&mut self) -> io::Result<()> {
        (**self).purge()
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
}

impl<T: DatagramLink + ?Sized> DatagramLink for Box<T> {
    fn send(&mut self, datagram: &[u8]) -> io::Result<()> {
        (**self).send(datagram)
    }
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        (**self).recv(buf, timeout)
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
}
