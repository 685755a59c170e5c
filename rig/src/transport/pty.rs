//! Pseudo-terminals: the device side of a virtual serial port.
//!
//! [`PtyDevice::open`] creates a pseudo-terminal pair in raw mode and keeps the master side; the
//! slave path (`/dev/pts/N`) is what a driver, or third-party software, opens as if it were a USB
//! serial adapter. Simulated controllers and serial tests sit on the master side.

use super::ByteLink;
use std::ffi::CStr;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::time::Duration;

/// The master side of a pseudo-terminal pair, plus the slave's path.
pub struct PtyDevice {
    master: OwnedFd,
    /// Kept open so the master does not see EIO while no client has the slave open.
    _slave: OwnedFd,
    slave_path: String,
}

impl PtyDevice {
    /// Opens a new pseudo-terminal pair in raw mode.
    pub fn open() -> io::Result<PtyDevice> {
        let mut master: libc::c_int = -1;
        let mut slave: libc::c_int = -1;
        let mut name = [0 as libc::c_char; 128];
        // SAFETY: openpty writes two fds and a NUL-terminated name into buffers we own; the name
        // buffer is larger than any pts path.
        let rc = unsafe {
            libc::openpty(
                &mut master,
                &mut slave,
                name.as_mut_ptr(),
                std::ptr::null(),
                std::ptr::null(),
            )
        };
        if rc != 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: openpty succeeded, so both fds are open and owned by us from here on.
        let (master, slave) = unsafe { (OwnedFd::from_raw_fd(master), OwnedFd::from_raw_fd(slave)) };
        // SAFETY: `name` was NUL-terminated by openpty.
        let slave_path = unsafe { CStr::from_ptr(name.as_ptr()) }.to_string_lossy().into_owned();
        make_raw(slave.as_raw_fd())?;
        make_raw(master.as_raw_fd())?;
        Ok(PtyDevice { master, _slave: slave, slave_path })
    }

    /// The path a client opens (`/dev/pts/N`).
    pub fn slave_path(&self) -> &str {
        &self.slave_path
    }
}

fn make_raw(fd: libc::c_int) -> io::Result<()> {
    // SAFETY: termios is plain data; tcgetattr fills it for a valid tty fd.
    unsafe {
        let mut t: libc::termios = std::mem::zeroed();
        if libc::tcgetattr(fd, &mut t) != 0 {
            return Err(io::Error::last_os_error());
        }
        libc::cfmakeraw(&mut t);
        if libc::tcsetattr(fd, libc::TCSANOW, &t) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

impl ByteLink for PtyDevice {
    fn write_all(&mut self, mut bytes: &[u8]) -> io::Result<()> {
        while !bytes.is_empty() {
            // SAFETY: writing from a live slice to an fd we own.
            let n = unsafe {
                libc::write(self.master.as_raw_fd(), bytes.as_ptr() as *const libc::c_void, bytes.len())
            };
            if n < 0 {
                let e = io::Error::last_os_error();
                if e.kind() == io::ErrorKind::Interrupted {
                    continue;
                }
                return Err(e);
            }
            bytes = &bytes[n as usize..];
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let mut pfd = libc::pollfd { fd: self.master.as_raw_fd(), events: libc::POLLIN, revents: 0 };
        let ms = timeout.as_millis().min(i32::MAX as u128) as libc::c_int;
        // SAFETY: one valid pollfd.
        let rc = unsafe { libc::poll(&mut pfd, 1, ms) };
        if rc < 0 {
            let e = io::Error::last_os_error();
            return if e.kind() == io::ErrorKind::Interrupted { Ok(0) } else { Err(e) };
        }
        if rc == 0 {
            return Ok(0);
        }
        // SAFETY: reading into a live mutable slice from an fd we own.
        let n = unsafe { libc::read(self.master.as_raw_fd(), buf.as_mut_ptr() as *mut libc::c_void, buf.len()) };
        if n < 0 {
            let e = io::Error::last_os_error();
            return if e.kind() == io::ErrorKind::WouldBlock || e.kind() == io::ErrorKind::Interrupted {
                Ok(0)
            } else {
                Err(e)
            };
        }
        Ok(n as usize)
    }

    fn purge(&mut self) -> io::Result<()> {
        // SAFETY: tcflush on an fd we own.
        if unsafe { libc::tcflush(self.master.as_raw_fd(), libc::TCIOFLUSH) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!("pty {}", self.slave_path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::serial::{SerialLink, SerialSettings};

    #[test]
    fn serial_port_on_a_pty_round_trips_bytes() {
        let mut dev = PtyDevice::open().expect("openpty");
        let mut port = SerialLink::open(dev.slave_path(), &SerialSettings::plain(115_200)).expect("open slave");
        port.write_all(&[0x23, 0x02, 0x01, 0x00, 0x50, 0x01]).expect("write");
        let mut buf = [0u8; 16];
        let mut got = Vec::new();
        for _ in 0..20 {
            let n = dev.read(&mut buf, Duration::from_millis(50)).expect("read");
            got.extend_from_slice(&buf[..n]);
            if got.len() >= 6 {
                break;
            }
        }
        assert_eq!(got, [0x23, 0x02, 0x01, 0x00, 0x50, 0x01]);
        dev.write_all(&[1, 2, 3]).expect("reply");
        let n = port.read(&mut buf, Duration::from_millis(500)).expect("read back");
        assert_eq!(&buf[..n], &[1, 2, 3]);
    }
}
