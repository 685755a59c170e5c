//! Replaying a trace against a driver.
//!
//! A replay link plays the device: it hands the driver the recorded device-to-host bytes and
//! checks that the driver sends exactly the recorded host-to-device bytes, failing with a
//! readable diff that names the trace line. Replies are causal: a recorded reply is delivered only
//! after the host message that preceded it in the trace has been sent, and (unless the speed is
//! infinite) no earlier than the recorded delay after it. Messages declared `unordered` in the
//! header (keep-alives) are accepted at any point and their send times are reported.

use super::format::{hex, Direction, LinkKind, Trace};
use crate::transport::{ByteLink, DatagramLink};
use std::io;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// How a trace is replayed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayOptions {
    /// Time scale: 1.0 replays at recorded pace, 2.0 twice as fast, `f64::INFINITY` as fast as
    /// causality allows.
    pub speed: f64,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions { speed: 1.0 }
    }
}

/// What a finished replay observed.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayReport {
    /// Recorded replies the driver never read.
    pub unread_replies: usize,
    /// Each unordered message the driver sent: its bytes and when (since the replay started).
    pub unordered_sent: Vec<(Vec<u8>, Duration)>,
    /// How long the replay has run.
    pub elapsed: Duration,
}

/// A replay that did not match the trace.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ReplayError(pub String);

struct ReadStep {
    entry: usize,
    /// Index into `writes` of the host message that precedes this reply in the trace.
    gate: Option<usize>,
}

struct Core {
    trace: Trace,
    writes: Vec<usize>,
    write_done: Vec<Option<Instant>>,
    write_cursor: usize,
    write_offset: usize,
    reads: Vec<ReadStep>,
    read_cursor: usize,
    read_offset: usize,
    start: Instant,
    speed: f64,
    unordered_sent: Vec<(Vec<u8>, Duration)>,
    error: Option<String>,
}

enum Readiness {
    Ready,
    At(Instant),
    Blocked,
}

impl Core {
    fn new(trace: Trace, options: ReplayOptions) -> Core {
        let mut writes = Vec::new();
        let mut reads = Vec::new();
        for (i, e) in trace.entries.iter().enumerate() {
            match e.direction {
                Direction::ToDevice => {
                    if !trace.unordered.contains(&e.bytes) {
                        writes.push(i);
                    }
                }
                Direction::FromDevice => reads.push(ReadStep {
                    entry: i,
                    gate: writes.len().checked_sub(1),
                }),
            }
        }
        Core {
            write_done: vec![None; writes.len()],
            writes,
            write_cursor: 0,
            write_offset: 0,
            reads,
            read_cursor: 0,
            read_offset: 0,
            start: Instant::now(),
            speed: if options.speed > 0.0 {
                options.speed
            } else {
                1.0
            },
            unordered_sent: Vec::new(),
            error: None,
            trace,
        }
    }

    fn scaled(&self, d: Duration) -> Duration {
        if self.speed.is_infinite() {
            Duration::ZERO
        } else {
            // A speed near zero would make the wait longer than a Duration holds.
            Duration::try_from_secs_f64(d.as_secs_f64() / self.speed).unwrap_or(Duration::MAX)
        }
    }

    fn readiness(&self, now: Instant) -> Option<Readiness> {
        let step = self.reads.get(self.read_cursor)?;
        let entry = &self.trace.entries[step.entry];
        let due = match step.gate {
            None => self.start + self.scaled(entry.time),
            Some(g) => match self.write_done[g] {
                None => return Some(Readiness::Blocked),
                Some(done) => {
                    let gate_time = self.trace.entries[self.writes[g]].time;
                    done + self.scaled(entry.time.saturating_sub(gate_time))
                }
            },
        };
        Some(if due <= now {
            Readiness::Ready
        } else {
            Readiness::At(due)
        })
    }

    fn fail(&mut self, message: String) -> io::Error {
        if self.error.is_none() {
            self.error = Some(message.clone());
        }
        io::Error::new(io::ErrorKind::InvalidData, message)
    }

    fn accept_write(&mut self, bytes: &[u8]) -> io::Result<()> {
        if let Some(e) = &self.error {
            return Err(io::Error::new(io::ErrorKind::InvalidData, e.clone()));
        }
        if self.trace.unordered.iter().any(|u| u.as_slice() == bytes) {
            let at = self.start.elapsed();
            self.unordered_sent.push((bytes.to_vec(), at));
            return Ok(());
        }
        let datagram = self.trace.kind == LinkKind::Datagram;
        let mut i = 0;
        while i < bytes.len() {
            let Some(&entry_idx) = self.writes.get(self.write_cursor) else {
                let last = self.trace.entries.last().map(|e| e.line).unwrap_or(0);
                let msg = format!(
                    "{}: the driver sent > {} after the last message of the trace (line {last})",
                    self.trace.source,
                    hex(bytes)
                );
                return Err(self.fail(msg));
            };
            let entry = &self.trace.entries[entry_idx];
            let expected = &entry.bytes[self.write_offset..];
            let sent = &bytes[i..];
            let common = expected.len().min(sent.len());
            let mismatch = (0..common).find(|&k| expected[k] != sent[k]);
            let length_mismatch = datagram && expected.len() != sent.len();
            if mismatch.is_some() || length_mismatch {
                let k = mismatch.unwrap_or(common);
                let msg = format!(
                    "{src}: the driver sent bytes the trace does not expect\n  trace line {line} expects > {exp}\n  the driver sent         > {got}\n  first difference at byte {pos}: expected {e}, sent {s}",
                    src = self.trace.source,
                    line = entry.line,
                    exp = hex(&entry.bytes),
                    got = hex(bytes),
                    pos = self.write_offset + k,
                    e = expected.get(k).map(|b| format!("{b:02x}")).unwrap_or_else(|| "end of message".into()),
                    s = sent.get(k).map(|b| format!("{b:02x}")).unwrap_or_else(|| "end of write".into()),
                );
                return Err(self.fail(msg));
            }
            i += common;
            self.write_offset += common;
            if self.write_offset == entry.bytes.len() {
                self.write_done[self.write_cursor] = Some(Instant::now());
                self.write_cursor += 1;
                self.write_offset = 0;
            }
        }
        Ok(())
    }

    fn take_stream(&mut self, buf: &mut [u8], now: Instant) -> usize {
        let mut n = 0;
        while n < buf.len() {
            match self.readiness(now) {
                Some(Readiness::Ready) => {}
                _ => break,
            }
            let entry = &self.trace.entries[self.reads[self.read_cursor].entry];
            let rest = &entry.bytes[self.read_offset..];
            let k = rest.len().min(buf.len() - n);
            buf[n..n + k].copy_from_slice(&rest[..k]);
            n += k;
            self.read_offset += k;
            if self.read_offset == entry.bytes.len() {
                self.read_cursor += 1;
                self.read_offset = 0;
            }
        }
        n
    }

    fn take_datagram(&mut self, buf: &mut [u8], now: Instant) -> Option<usize> {
        match self.readiness(now) {
            Some(Readiness::Ready) => {}
            _ => return None,
        }
        let entry = &self.trace.entries[self.reads[self.read_cursor].entry];
        let k = entry.bytes.len().min(buf.len());
        buf[..k].copy_from_slice(&entry.bytes[..k]);
        self.read_cursor += 1;
        Some(k)
    }
}

type Shared = Arc<(Mutex<Core>, Condvar)>;

fn lock(shared: &Shared) -> MutexGuard<'_, Core> {
    // A poisoned lock only means another thread panicked mid-replay; the state is still usable
    // for reporting.
    shared.0.lock().unwrap_or_else(|p| p.into_inner())
}

/// Waits until something can be delivered or `deadline` passes, calling `take` each time.
fn wait_for<T>(
    shared: &Shared,
    deadline: Instant,
    mut take: impl FnMut(&mut Core, Instant) -> Option<T>,
) -> Option<T> {
    let mut core = lock(shared);
    loop {
        let now = Instant::now();
        if let Some(v) = take(&mut core, now) {
            return Some(v);
        }
        if now >= deadline {
            return None;
        }
        let until = match core.readiness(now) {
            Some(Readiness::At(due)) => due.min(deadline),
            _ => deadline,
        };
        let wait = until.saturating_duration_since(now);
        core = shared
            .1
            .wait_timeout(core, wait)
            .map(|(g, _)| g)
            .unwrap_or_else(|p| p.into_inner().0);
    }
}

/// Inspects a running replay and checks it at the end.
#[derive(Clone)]
pub struct ReplayHandle {
    shared: Shared,
}

impl ReplayHandle {
    /// Checks that the driver sent every recorded host message and nothing else.
    pub fn finish(&self) -> Result<ReplayReport, ReplayError> {
        let core = lock(&self.shared);
        if let Some(e) = &core.error {
            return Err(ReplayError(e.clone()));
        }
        if let Some(&idx) = core.writes.get(core.write_cursor) {
            let e = &core.trace.entries[idx];
            return Err(ReplayError(format!(
                "{}: the driver never sent the message at line {}: > {}",
                core.trace.source,
                e.line,
                hex(&e.bytes)
            )));
        }
        Ok(ReplayReport {
            unread_replies: core.reads.len() - core.read_cursor,
            unordered_sent: core.unordered_sent.clone(),
            elapsed: core.start.elapsed(),
        })
    }

    /// True once every recorded host message has been sent.
    pub fn all_sent(&self) -> bool {
        let core = lock(&self.shared);
        core.write_cursor >= core.writes.len()
    }
}

/// A byte link that plays a recorded stream trace.
pub struct ReplayLink {
    shared: Shared,
    name: String,
}

impl ReplayLink {
    /// Starts replaying `trace`; the handle checks the result.
    pub fn new(trace: Trace, options: ReplayOptions) -> (ReplayLink, ReplayHandle) {
        let name = format!("replay of {}", trace.source);
        let shared: Shared = Arc::new((Mutex::new(Core::new(trace, options)), Condvar::new()));
        (
            ReplayLink {
                shared: shared.clone(),
                name,
            },
            ReplayHandle { shared },
        )
    }
}

impl ByteLink for ReplayLink {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        let result = lock(&self.shared).accept_write(bytes);
        self.shared.1.notify_all();
        result
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        let deadline = Instant::now() + timeout;
        Ok(wait_for(&self.shared, deadline, |core, now| {
            let n = core.take_stream(buf, now);
            (n > 0).then_some(n)
        })
        .unwrap_or(0))
    }

    fn describe(&self) -> String {
        self.name.clone()
    }
}

/// A datagram link that plays a recorded datagram trace.
pub struct ReplayDatagramLink {
    shared: Shared,
    name: String,
}

impl ReplayDatagramLink {
    /// Starts replaying `trace`; the handle checks the result.
    pub fn new(trace: Trace, options: ReplayOptions) -> (ReplayDatagramLink, ReplayHandle) {
        let name = format!("replay of {}", trace.source);
        let shared: Shared = Arc::new((Mutex::new(Core::new(trace, options)), Condvar::new()));
        (
            ReplayDatagramLink {
                shared: shared.clone(),
                name,
            },
            ReplayHandle { shared },
        )
    }
}

impl DatagramLink for ReplayDatagramLink {
    fn send(&mut self, datagram: &[u8]) -> io::Result<()> {
        let result = lock(&self.shared).accept_write(datagram);
        self.shared.1.notify_all();
        result
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        let deadline = Instant::now() + timeout;
        Ok(wait_for(&self.shared, deadline, |core, now| {
            core.take_datagram(buf, now)
        }))
    }

    fn describe(&self) -> String {
        self.name.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(text: &str) -> Trace {
        Trace::parse(text, "t.trace").expect("parse")
    }

    const TEXT: &str = "# fringe-trace 1\n# kind: stream\n# unordered: > 92 04 00 00 50 01\n0.000 > 05 00 00 00 50 01\n0.010 < aa bb\n0.020 < cc\n0.030 > 11 00 00 00 50 01\n0.040 < dd\n";

    fn fast() -> ReplayOptions {
        ReplayOptions {
            speed: f64::INFINITY,
        }
    }

    #[test]
    fn replies_wait_for_the_request_that_caused_them() {
        let (mut link, handle) = ReplayLink::new(trace(TEXT), fast());
        let mut buf = [0u8; 8];
        assert_eq!(
            link.read(&mut buf, Duration::from_millis(20))
                .expect("read"),
            0,
            "no reply before the request"
        );
        link.write_all(&[0x05, 0, 0, 0, 0x50, 0x01]).expect("write");
        let n = link
            .read(&mut buf, Duration::from_millis(20))
            .expect("read");
        assert_eq!(&buf[..n], &[0xaa, 0xbb, 0xcc]);
        link.write_all(&[0x92, 0x04, 0, 0, 0x50, 0x01])
            .expect("keep-alive anywhere");
        link.write_all(&[0x11, 0, 0]).expect("partial");
        link.write_all(&[0, 0x50, 0x01]).expect("rest");
        let n = link
            .read(&mut buf, Duration::from_millis(20))
            .expect("read");
        assert_eq!(&buf[..n], &[0xdd]);
        let report = handle.finish().expect("clean replay");
        assert_eq!(report.unread_replies, 0);
        assert_eq!(report.unordered_sent.len(), 1);
    }

    #[test]
    fn a_wrong_byte_fails_with_a_diff_naming_the_line() {
        let (mut link, handle) = ReplayLink::new(trace(TEXT), fast());
        let err = link
            .write_all(&[0x05, 0, 0, 0, 0x51, 0x01])
            .expect_err("mismatch");
        let text = err.to_string();
        assert!(
            text.contains("trace line 4 expects > 05 00 00 00 50 01"),
            "{text}"
        );
        assert!(
            text.contains("the driver sent         > 05 00 00 00 51 01"),
            "{text}"
        );
        assert!(text.contains("byte 4: expected 50, sent 51"), "{text}");
        assert!(handle.finish().is_err());
    }

    #[test]
    fn unsent_messages_are_reported_at_finish() {
        let (mut link, handle) = ReplayLink::new(trace(TEXT), fast());
        link.write_all(&[0x05, 0, 0, 0, 0x50, 0x01]).expect("write");
        let e = handle.finish().expect_err("second request missing");
        assert!(
            e.to_string().contains("never sent the message at line 7"),
            "{e}"
        );
    }

    #[test]
    fn writes_past_the_end_fail() {
        let (mut link, _h) = ReplayLink::new(trace("# fringe-trace 1\n0.0 > 01\n"), fast());
        link.write_all(&[1]).expect("expected");
        assert!(link
            .write_all(&[2])
            .expect_err("extra")
            .to_string()
            .contains("after the last message"));
    }

    #[test]
    fn paced_replay_keeps_recorded_delays() {
        let text = "# fringe-trace 1\n# kind: datagram\n0.000 > 01 02\n0.050 < 03\n";
        let (mut link, handle) = ReplayDatagramLink::new(trace(text), ReplayOptions::default());
        let mut buf = [0u8; 4];
        link.send(&[1, 2]).expect("send");
        let t0 = Instant::now();
        assert_eq!(
            link.recv(&mut buf, Duration::from_millis(10))
                .expect("recv"),
            None,
            "reply is not due yet"
        );
        assert_eq!(
            link.recv(&mut buf, Duration::from_millis(500))
                .expect("recv"),
            Some(1)
        );
        assert!(
            t0.elapsed() >= Duration::from_millis(45),
            "{:?}",
            t0.elapsed()
        );
        assert!(handle.finish().is_ok());
    }

    #[test]
    fn datagrams_must_match_whole() {
        let text = "# fringe-trace 1\n# kind: datagram\n0.000 > 01 02\n";
        let (mut link, _h) = ReplayDatagramLink::new(trace(text), fast());
        assert!(link.send(&[1]).is_err(), "a short datagram is a mismatch");
    }
}
