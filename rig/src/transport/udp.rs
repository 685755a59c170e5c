//! UDP datagrams (ATI Net F/T RDT).

use super::DatagramLink;
use std::io;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::Duration;

/// A UDP socket connected to one peer.
pub struct UdpLink {
    socket: UdpSocket,
    peer: SocketAddr,
}

impl UdpLink {
    /// Binds an ephemeral local port and connects it to `addr` ("host:port").
    pub fn connect(addr: &str) -> io::Result<UdpLink> {
        let peer = addr
            .to_socket_addrs()
            .map_err(|e| io::Error::new(e.kind(), format!("cannot resolve {addr}: {e} (expected HOST:PORT)")))?
            .next()
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, format!("{addr} resolves to no address")))?;
        let local = if peer.is_ipv4() { "0.0.0.0:0" } else { "[::]:0" };
        let socket = UdpSocket::bind(local)?;
        socket.connect(peer)?;
        set_receive_buffer(&socket, 4 << 20);
        Ok(UdpLink { socket, peer })
    }

    /// The peer address.
    pub fn peer(&self) -> SocketAddr {
        self.peer
    }
}

/// Asks the kernel for a larger receive buffer so bursts at 7 kHz are not dropped; fails soft.
fn set_receive_buffer(socket: &UdpSocket, bytes: i32) {
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: setsockopt on a valid socket fd with a pointer to a live i32 of the right size.
        unsafe {
            libc::setsockopt(
                socket.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RCVBUF,
                &bytes as *const i32 as *const libc::c_void,
                std::mem::size_of::<i32>() as libc::socklen_t,
            );
        }
    }
}

impl DatagramLink for UdpLink {
    fn send(&mut self, datagram: &[u8]) -> io::Result<()> {
        self.socket.send(datagram).map(|_| ())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        self.socket.set_read_timeout(Some(timeout.max(Duration::from_micros(100))))?;
        match self.socket.recv(buf) {
            Ok(n) => Ok(Some(n)),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock || e.kind() == io::ErrorKind::TimedOut => Ok(None),
            // A previous datagram hit a closed port (ICMP unreachable): report as nothing received.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Ok(None),
            Err(e) => Err(e),
        }
    }

    fn describe(&self) -> String {
        format!("udp {}", self.peer)
    }
}
