//! Recording wrappers: every byte or datagram that crosses a link goes to a trace file.
//!
//! Lines are flushed as they are written, so a crash loses nothing already exchanged.

use super::format::{Direction, LinkKind, Trace};
use crate::transport::{ByteLink, DatagramLink};
use std::fs::File;
use std::io::{self, LineWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Appends data lines to a trace file.
pub(crate) struct TraceWriter {
    out: LineWriter<File>,
    start: Instant,
    path: PathBuf,
}

impl TraceWriter {
    /// Creates `path` (and its directory) and writes the header.
    pub(crate) fn create(
        path: &Path,
        device: &str,
        endpoint: &str,
        kind: LinkKind,
    ) -> io::Result<TraceWriter> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| annotate(e, path))?;
        }
        let file = File::create(path).map_err(|e| annotate(e, path))?;
        let mut out = LineWriter::new(file);
        out.write_all(Trace::header(device, endpoint, kind, &[]).as_bytes())?;
        Ok(TraceWriter {
            out,
            start: Instant::now(),
            path: path.to_path_buf(),
        })
    }

    /// Appends one data line stamped with the time since the trace started.
    pub(crate) fn append(&mut self, direction: Direction, bytes: &[u8]) -> io::Result<()> {
        self.append_at(self.start.elapsed(), direction, bytes)
    }

    /// Appends one data line with an explicit time since the trace started.
    pub(crate) fn append_at(
        &mut self,
        time: Duration,
        direction: Direction,
        bytes: &[u8],
    ) -> io::Result<()> {
        self.out
            .write_all(Trace::data_line(time, direction, bytes).as_bytes())
    }

    /// Appends a comment line (`# text`), for readers of the file.
    pub(crate) fn comment(&mut self, text: &str) -> io::Result<()> {
        for line in text.lines() {
            writeln!(self.out, "# {line}")?;
        }
        Ok(())
    }

    /// The file being written.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }
}

fn annotate(e: io::Error, path: &Path) -> io::Error {
    io::Error::new(
        e.kind(),
        format!("cannot write trace {}: {e}", path.display()),
    )
}

/// A byte link that records both directions to a trace.
pub(crate) struct RecordingLink<L> {
    inner: L,
    writer: TraceWriter,
}

impl<L: ByteLink> RecordingLink<L> {
    /// Wraps `inner`, recording to `path` under the device name `device`.
    pub(crate) fn new(inner: L, path: &Path, device: &str) -> io::Result<Self> {
        let writer = TraceWriter::create(path, device, &inner.describe(), LinkKind::Stream)?;
        Ok(RecordingLink { inner, writer })
    }
}

impl<L: ByteLink> ByteLink for RecordingLink<L> {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.writer.append(Direction::ToDevice, bytes)?;
        self.inner.write_all(bytes)
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let n = self.inner.read(buf, timeout)?;
        if n > 0 {
            self.writer.append(Direction::FromDevice, &buf[..n])?;
        }
        Ok(n)
    }

    fn purge(&mut self) -> io::Result<()> {
        self.inner.purge()
    }

    fn describe(&self) -> String {
        self.inner.describe()
    }
}

/// A datagram link that records every datagram to a trace.
pub(crate) struct RecordingDatagramLink<L> {
    inner: L,
    writer: TraceWriter,
}

impl<L: DatagramLink> RecordingDatagramLink<L> {
    /// Wraps `inner`, recording to `path` under the device name `device`.
    pub(crate) fn new(inner: L, path: &Path, device: &str) -> io::Result<Self> {
        let writer = TraceWriter::create(path, device, &inner.describe(), LinkKind::Datagram)?;
        Ok(RecordingDatagramLink { inner, writer })
    }
}

impl<L: DatagramLink> DatagramLink for RecordingDatagramLink<L> {
    fn send(&mut self, datagram: &[u8]) -> io::Result<()> {
        self.writer.append(Direction::ToDevice, datagram)?;
        self.inner.send(datagram)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        let got = self.inner.recv(buf, timeout)?;
        if let Some(n) = got {
            self.writer.append(Direction::FromDevice, &buf[..n])?;
        }
        Ok(got)
    }

    fn describe(&self) -> String {
        self.inner.describe()
    }
}

/// Wraps `link` in a recorder writing `DIR/<device>.trace` when `dir` is given.
pub fn record_stream(
    link: Box<dyn ByteLink>,
    dir: Option<&Path>,
    device: &str,
) -> io::Result<Box<dyn ByteLink>> {
    match dir {
        Some(dir) => Ok(Box::new(RecordingLink::new(
            link,
            &dir.join(format!("{device}.trace")),
            device,
        )?)),
        None => Ok(link),
    }
}

/// Wraps `link` in a recorder writing `DIR/<device>.trace` when `dir` is given.
pub fn record_datagrams(
    link: Box<dyn DatagramLink>,
    dir: Option<&Path>,
    device: &str,
) -> io::Result<Box<dyn DatagramLink>> {
    match dir {
        Some(dir) => Ok(Box::new(RecordingDatagramLink::new(
            link,
            &dir.join(format!("{device}.trace")),
            device,
        )?)),
        None => Ok(link),
    }
}
