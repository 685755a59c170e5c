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
            .map_err(|e| {
                io::Error::new(
                    e.kind(),
                    format!("cannot resolve {addr}: {e} (expected HOST:PORT)"),
                )
            })?
            .next()
            .ok_or_else(|| {
                io::Error::new(
                    io::ErrorKind::NotFound,
                    format!("{addr} resolves to no address"),
                )
            })?;
        let local = if peer.is_ipv4() {
            "0.0.0.0:0"
        } else {
            "[::]:0"
        };
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
        match self.socket.send(datagram) {
            Ok(_) => Ok(()),
            // An earlier datagram hit a closed port (a box still booting answers ICMP port
            // unreachable): the error is that datagram's, and it is cleared; send this one.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {
                match self.socket.send(datagram) {
                    Ok(_) => Ok(()),
                    // Still refused: this one is lost as well, as datagrams are; the caller
                    // sees no answer and asks again or gives up with its own advice.
                    Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Ok(()),
                    Err(e) => Err(e),
                }
            }
            Err(e) => Err(e),
        }
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        self.socket
            .set_read_timeout(Some(timeout.max(Duration::from_micros(100))))?;
        match self.socket.recv(buf) {
            Ok(n) => Ok(Some(n)),
            Err(e)
                if e.kind() == io::ErrorKind::WouldBlock || e.kind() == io::ErrorKind::TimedOut =>
            {
                Ok(None)
            }
            // A previous datagram hit a closed port (ICMP unreachable): report as nothing received.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Ok(None),
            Err(e) => Err(e),
        }
    }

    fn describe(&self) -> String {
        format!("udp {}", self.peer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closed_port_is_silence_not_an_error() {
        // A port nothing listens on: each datagram draws an ICMP port unreachable.
        let closed = UdpSocket::bind("127.0.0.1:0").expect("bind");
        let addr = closed.local_addr().expect("addr");
        drop(closed);
        let mut link = UdpLink::connect(&addr.to_string()).expect("connect");
        let mut buf = [0u8; 64];
        for _ in 0..3 {
            link.send(b"start").expect("send to a closed port");
            std::thread::sleep(Duration::from_millis(20));
        }
        assert_eq!(
            link.recv(&mut buf, Duration::from_millis(20))
                .expect("recv"),
            None
        );
        link.send(b"start")
            .expect("send after the refusal was read");
    }
}
