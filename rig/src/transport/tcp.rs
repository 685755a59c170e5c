//! TCP byte streams (Modbus TCP stages, simulated devices on loopback).

use super::ByteLink;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// A connected TCP stream.
pub struct TcpLink {
    stream: TcpStream,
    peer: String,
}

impl TcpLink {
    /// Connects to `addr` ("host:port") within `timeout`.
    pub fn connect(addr: &str, timeout: Duration) -> io::Result<TcpLink> {
        let addrs: Vec<_> = addr
            .to_socket_addrs()
            .map_err(|e| io::Error::new(e.kind(), format!("cannot resolve {addr}: {e} (expected HOST:PORT)")))?
            .collect();
        let mut last = None;
        for a in addrs {
            match TcpStream::connect_timeout(&a, timeout) {
                Ok(stream) => {
                    stream.set_nodelay(true)?;
                    return Ok(TcpLink { stream, peer: addr.to_string() });
                }
                Err(e) => last = Some(e),
            }
        }
        let e = last.unwrap_or_else(|| io::Error::new(io::ErrorKind::NotFound, "no address"));
        Err(io::Error::new(
            e.kind(),
            format!("cannot connect to tcp {addr}: {e} (check the address, the port and that the device is powered and on this network)"),
        ))
    }

    /// Wraps an accepted or connected stream.
    pub fn from_stream(stream: TcpStream) -> io::Result<TcpLink> {
        let peer = stream.peer_addr().map(|a| a.to_string()).unwrap_or_else(|_| "?".into());
        stream.set_nodelay(true)?;
        Ok(TcpLink { stream, peer })
    }
}

impl ByteLink for TcpLink {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes)
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.stream.set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        match self.stream.read(buf) {
            Ok(0) => Err(io::Error::new(
                io::ErrorKind::ConnectionAborted,
                format!("tcp {} closed the connection", self.peer),
            )),
            Ok(n) => Ok(n),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock || e.kind() == io::ErrorKind::TimedOut => Ok(0),
            Err(e) => Err(e),
        }
    }

    fn describe(&self) -> String {
        format!("tcp {}", self.peer)
    }
}
