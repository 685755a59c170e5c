//! In-process links: a byte stream or datagram pipe between a driver and a simulated device in the
//! same process, with no socket or pseudo-terminal. The default simulated rig wires the real
//! drivers to the emulators through these, so a default run exercises the real driver code.

use super::{ByteLink, DatagramLink};
use crossbeam_channel::{unbounded, Receiver, RecvTimeoutError, Sender};
use std::collections::VecDeque;
use std::io;
use std::time::Duration;

/// One end of an in-process byte stream. Writes on one end are read on the other; dropping an end
/// makes the other end's writes fail with `BrokenPipe` (like a closed port).
pub struct MemoryByteLink {
    name: String,
    tx: Sender<Vec<u8>>,
    rx: Receiver<Vec<u8>>,
    pending: VecDeque<u8>,
}

/// A connected pair of byte-stream ends named `a` and `b` (names appear in error messages).
pub fn byte_pair(a: &str, b: &str) -> (MemoryByteLink, MemoryByteLink) {
    let (tx_ab, rx_ab) = unbounded();
    let (tx_ba, rx_ba) = unbounded();
    (
        MemoryByteLink {
            name: a.to_string(),
            tx: tx_ab,
            rx: rx_ba,
            pending: VecDeque::new(),
        },
        MemoryByteLink {
            name: b.to_string(),
            tx: tx_ba,
            rx: rx_ab,
            pending: VecDeque::new(),
        },
    )
}

fn closed(name: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::BrokenPipe,
        format!("in-process link {name}: the other end was closed"),
    )
}

impl ByteLink for MemoryByteLink {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.tx.send(bytes.to_vec()).map_err(|_| closed(&self.name))
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        if self.pending.is_empty() {
            match self.rx.recv_timeout(timeout) {
                Ok(chunk) => self.pending.extend(chunk),
                Err(RecvTimeoutError::Timeout) => return Ok(0),
                Err(RecvTimeoutError::Disconnected) => return Err(closed(&self.name)),
            }
        }
        // Take whatever else is already queued without waiting.
        while let Ok(chunk) = self.rx.try_recv() {
            self.pending.extend(chunk);
        }
        let n = buf.len().min(self.pending.len());
        for (slot, byte) in buf.iter_mut().zip(self.pending.drain(..n)) {
            *slot = byte;
        }
        Ok(n)
    }

    fn purge(&mut self) -> io::Result<()> {
        self.pending.clear();
        while self.rx.try_recv().is_ok() {}
        Ok(())
    }

    fn describe(&self) -> String {
        format!("in-process {}", self.name)
    }
}

/// One end of an in-process datagram pipe; message boundaries are kept.
pub struct MemoryDatagramLink {
    name: String,
    tx: Sender<Vec<u8>>,
    rx: Receiver<Vec<u8>>,
}

/// A connected pair of datagram ends named `a` and `b`.
pub fn datagram_pair(a: &str, b: &str) -> (MemoryDatagramLink, MemoryDatagramLink) {
    let (tx_ab, rx_ab) = unbounded();
    let (tx_ba, rx_ba) = unbounded();
    (
        MemoryDatagramLink {
            name: a.to_string(),
            tx: tx_ab,
            rx: rx_ba,
        },
        MemoryDatagramLink {
            name: b.to_string(),
            tx: tx_ba,
            rx: rx_ab,
        },
    )
}

impl DatagramLink for MemoryDatagramLink {
    fn send(&mut self, datagram: &[u8]) -> io::Result<()> {
        self.tx
            .send(datagram.to_vec())
            .map_err(|_| closed(&self.name))
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        match self.rx.recv_timeout(timeout) {
            Ok(datagram) => {
                // Like UDP: a datagram longer than the buffer is truncated.
                let n = datagram.len().min(buf.len());
                buf[..n].copy_from_slice(&datagram[..n]);
                Ok(Some(n))
            }
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(closed(&self.name)),
        }
    }

    fn describe(&self) -> String {
        format!("in-process {}", self.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_cross_in_order_and_split_reads_keep_the_rest() {
        let (mut a, mut b) = byte_pair("driver", "device");
        a.write_all(&[1, 2, 3]).expect("write");
        a.write_all(&[4, 5]).expect("write");
        let mut buf = [0u8; 2];
        assert_eq!(
            b.read(&mut buf, Duration::from_millis(100)).expect("read"),
            2
        );
        assert_eq!(buf, [1, 2]);
        let mut rest = [0u8; 8];
        assert_eq!(
            b.read(&mut rest, Duration::from_millis(100)).expect("read"),
            3
        );
        assert_eq!(&rest[..3], &[3, 4, 5]);
        assert_eq!(
            b.read(&mut rest, Duration::from_millis(10)).expect("read"),
            0
        );
    }

    #[test]
    fn a_closed_end_is_reported_with_its_name() {
        let (mut a, b) = byte_pair("apt-x", "emulator");
        drop(b);
        let err = a.write_all(&[1]).expect_err("peer closed");
        assert_eq!(err.kind(), io::ErrorKind::BrokenPipe);
        assert!(err.to_string().contains("apt-x"), "{err}");
    }

    #[test]
    fn datagrams_keep_their_boundaries() {
        let (mut a, mut b) = datagram_pair("netft", "box");
        a.send(&[1, 2, 3]).expect("send");
        a.send(&[4]).expect("send");
        let mut buf = [0u8; 16];
        assert_eq!(
            b.recv(&mut buf, Duration::from_millis(100)).expect("recv"),
            Some(3)
        );
        assert_eq!(
            b.recv(&mut buf, Duration::from_millis(100)).expect("recv"),
            Some(1)
        );
        assert_eq!(buf[0], 4);
        assert_eq!(
            b.recv(&mut buf, Duration::from_millis(10)).expect("recv"),
            None
        );
    }
}
