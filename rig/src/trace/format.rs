//! The trace file format (version 1).
//!
//! ```text
//! # fringe-trace 1
//! # device: apt-x
//! # endpoint: serial /dev/ttyUSB0
//! # kind: stream
//! # unordered: > 92 04 00 00 50 01
//!     0.000000 > 05 00 00 00 50 01          # HW_REQ_INFO
//!     0.001875 < 06 00 54 00 81 50 ...
//! ```
//!
//! - Header lines are `# key: value`; the first line must be `# fringe-trace 1`. Keys: `device`
//!   (a name such as `apt-x`), `endpoint` (what the link was: port, address), `kind` (`stream`
//!   for serial/TCP byte streams, `datagram` for UDP), and any number of `unordered` lines naming
//!   a host-to-device message that a replay accepts at any point (periodic keep-alives).
//! - Every other line starting with `#` is a comment; blank lines are ignored.
//! - A data line is: seconds since the trace started (monotonic clock), a direction (`>` host to
//!   device, `<` device to host), the bytes as two-digit hex separated by spaces, and an optional
//!   `# comment`. For a `stream` trace a line is whatever one read or write carried; for a
//!   `datagram` trace it is exactly one datagram.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Which way bytes went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Host to device (`>`).
    ToDevice,
    /// Device to host (`<`).
    FromDevice,
}

impl Direction {
    /// The symbol used in trace files.
    pub fn symbol(self) -> char {
        match self {
            Direction::ToDevice => '>',
            Direction::FromDevice => '<',
        }
    }
}

/// Whether the link carries a byte stream or datagrams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkKind {
    Stream,
    Datagram,
}

impl LinkKind {
    fn name(self) -> &'static str {
        match self {
            LinkKind::Stream => "stream",
            LinkKind::Datagram => "datagram",
        }
    }
}

/// One data line of a trace.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceEntry {
    /// Time since the trace started.
    pub time: Duration,
    pub direction: Direction,
    pub bytes: Vec<u8>,
    /// Line number in the file (1-based), for error messages.
    pub line: usize,
}

/// A parsed trace.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    pub device: String,
    pub endpoint: String,
    pub kind: LinkKind,
    /// Host-to-device messages a replay accepts at any point.
    pub unordered: Vec<Vec<u8>>,
    pub entries: Vec<TraceEntry>,
    /// Where the trace came from (a file path or a name), for error messages.
    pub source: String,
}

/// A trace file that cannot be read, with the file and line.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    #[error("cannot read trace {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{source_name} line {line}: {message}")]
    Syntax {
        source_name: String,
        line: usize,
        message: String,
    },
}

/// Formats bytes as space-separated two-digit hex.
pub(crate) fn hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{b:02x}");
    }
    s
}

/// Parses space-separated two-digit hex (the inverse of [`hex`]).
pub(crate) fn parse_hex(text: &str) -> Result<Vec<u8>, String> {
    text.split_whitespace()
        .map(|tok| {
            if tok.len() != 2 {
                return Err(format!("`{tok}` is not a two-digit hex byte"));
            }
            u8::from_str_radix(tok, 16).map_err(|_| format!("`{tok}` is not a two-digit hex byte"))
        })
        .collect()
}

fn parse_directed_hex(text: &str) -> Result<(Direction, Vec<u8>), String> {
    let text = text.trim();
    let (dir, rest) = match text.chars().next() {
        Some('>') => (Direction::ToDevice, &text[1..]),
        Some('<') => (Direction::FromDevice, &text[1..]),
        _ => {
            return Err(format!(
                "expected `>` or `<` before the bytes, found `{text}`"
            ))
        }
    };
    let bytes = parse_hex(rest)?;
    if bytes.is_empty() {
        return Err("a data line needs at least one byte".into());
    }
    Ok((dir, bytes))
}

/// One data line `SECONDS > HEX...` (or `<`, with an optional `# comment`): its time, no
/// earlier than `last_time`, its direction and its bytes.
fn parse_data_line(
    line: &str,
    last_time: Duration,
) -> Result<(Duration, Direction, Vec<u8>), String> {
    let body = line.split_once('#').map(|(b, _)| b).unwrap_or(line).trim();
    let (time_text, rest) = body
        .split_once(char::is_whitespace)
        .ok_or_else(|| "expected `SECONDS > HEX...` or `SECONDS < HEX...`".to_string())?;
    let time = parse_time(time_text, last_time)?;
    let (direction, bytes) = parse_directed_hex(rest)?;
    Ok((time, direction, bytes))
}

/// A data line's time in seconds since the trace started, no earlier than `last_time`.
fn parse_time(time_text: &str, last_time: Duration) -> Result<Duration, String> {
    let secs: f64 = time_text
        .parse()
        .map_err(|_| format!("`{time_text}` is not a time in seconds"))?;
    if !secs.is_finite() || secs < 0.0 {
        return Err(format!(
            "time {secs} must be a non-negative number of seconds"
        ));
    }
    let time = Duration::try_from_secs_f64(secs).map_err(|_| {
        format!("time {secs} s is too large (a trace's times count seconds from its start)")
    })?;
    if time < last_time {
        return Err(format!(
            "time {secs} goes backwards (previous line was later)"
        ));
    }
    Ok(time)
}

impl Trace {
    /// Parses trace text; `source_name` names it in errors.
    pub fn parse(text: &str, source_name: &str) -> Result<Trace, TraceError> {
        let err = |line: usize, message: String| TraceError::Syntax {
            source_name: source_name.to_string(),
            line,
            message,
        };
        let mut lines = text.lines().enumerate();
        match lines.next() {
            Some((_, first)) if first.trim() == "# fringe-trace 1" => {}
            _ => return Err(err(1, "the first line must be `# fringe-trace 1`".into())),
        }
        let mut trace = Trace {
            device: String::new(),
            endpoint: String::new(),
            kind: LinkKind::Stream,
            unordered: Vec::new(),
            entries: Vec::new(),
            source: source_name.to_string(),
        };
        let mut last_time = Duration::ZERO;
        for (idx, raw) in lines {
            let lineno = idx + 1;
            let line = raw.trim();
            if line.is_empty() {
                continue;
            }
            if let Some(comment) = line.strip_prefix('#') {
                if let Some((key, value)) = comment.split_once(':') {
                    trace
                        .header_field(key.trim(), value.trim())
                        .map_err(|m| err(lineno, m))?;
                }
                continue;
            }
            let (time, direction, bytes) =
                parse_data_line(line, last_time).map_err(|m| err(lineno, m))?;
            last_time = time;
            trace.entries.push(TraceEntry {
                time,
                direction,
                bytes,
                line: lineno,
            });
        }
        Ok(trace)
    }

    /// Takes one `# key: value` header line; unknown keys are comments.
    fn header_field(&mut self, key: &str, value: &str) -> Result<(), String> {
        match key {
            "device" => self.device = value.to_string(),
            "endpoint" => self.endpoint = value.to_string(),
            "kind" => {
                self.kind = match value {
                    "stream" => LinkKind::Stream,
                    "datagram" => LinkKind::Datagram,
                    other => return Err(format!("kind `{other}`: allowed are stream, datagram")),
                }
            }
            "unordered" => {
                let (dir, bytes) = parse_directed_hex(value)?;
                if dir != Direction::ToDevice {
                    return Err("unordered messages must be host to device (`>`)".into());
                }
                self.unordered.push(bytes);
            }
            _ => {}
        }
        Ok(())
    }

    /// Loads and parses a trace file.
    pub fn load(path: &Path) -> Result<Trace, TraceError> {
        let text = std::fs::read_to_string(path).map_err(|source| TraceError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Trace::parse(&text, &path.display().to_string())
    }

    /// The header text of a trace with these properties.
    pub fn header(device: &str, endpoint: &str, kind: LinkKind, unordered: &[Vec<u8>]) -> String {
        let mut s = format!(
            "# fringe-trace 1\n# device: {device}\n# endpoint: {endpoint}\n# kind: {}\n",
            kind.name()
        );
        for u in unordered {
            let _ = writeln!(s, "# unordered: > {}", hex(u));
        }
        s
    }

    /// Formats one data line (without comment).
    pub fn data_line(time: Duration, direction: Direction, bytes: &[u8]) -> String {
        format!(
            "{:12.6} {} {}\n",
            time.as_secs_f64(),
            direction.symbol(),
            hex(bytes)
        )
    }

    /// Serialises the trace back to text.
    pub fn to_text(&self) -> String {
        let mut s = Trace::header(&self.device, &self.endpoint, self.kind, &self.unordered);
        for e in &self.entries {
            s.push_str(&Trace::data_line(e.time, e.direction, &e.bytes));
        }
        s
    }

    /// All bytes in one direction, concatenated (what a stream carried).
    pub fn bytes(&self, direction: Direction) -> Vec<u8> {
        self.entries
            .iter()
            .filter(|e| e.direction == direction)
            .flat_map(|e| e.bytes.iter().copied())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "# fringe-trace 1\n# device: apt-x\n# endpoint: serial /dev/ttyUSB0\n# kind: stream\n# unordered: > 92 04 00 00 50 01\n# a comment\n\n    0.000000 > 23 02 01 00 50 01   # MOD_IDENTIFY\n    0.010000 < 64 04 01 00 01 50\n";

    #[test]
    fn a_time_too_large_for_a_duration_is_an_error_naming_the_line() {
        // Found by the `trace` fuzz target (fuzz/regressions/trace): it panicked.
        let text = SAMPLE.replace("0.010000 <", "1e300 <");
        let e = Trace::parse(&text, "sample")
            .expect_err("refused")
            .to_string();
        assert!(e.contains("line 9") && e.contains("too large"), "{e}");
    }

    #[test]
    fn parses_header_entries_and_comments() {
        let t = Trace::parse(SAMPLE, "sample").expect("parse");
        assert_eq!(t.device, "apt-x");
        assert_eq!(t.endpoint, "serial /dev/ttyUSB0");
        assert_eq!(t.kind, LinkKind::Stream);
        assert_eq!(t.unordered, vec![vec![0x92, 0x04, 0, 0, 0x50, 0x01]]);
        assert_eq!(t.entries.len(), 2);
        assert_eq!(t.entries[0].bytes, vec![0x23, 0x02, 0x01, 0x00, 0x50, 0x01]);
        assert_eq!(t.entries[0].line, 8);
        assert_eq!(t.entries[1].direction, Direction::FromDevice);
        assert_eq!(t.entries[1].time, Duration::from_millis(10));
    }

    #[test]
    fn round_trips_through_text() {
        let t = Trace::parse(SAMPLE, "sample").expect("parse");
        let again = Trace::parse(&t.to_text(), "again").expect("reparse");
        let key = |t: &Trace| {
            t.entries
                .iter()
                .map(|e| (e.time, e.direction, e.bytes.clone()))
                .collect::<Vec<_>>()
        };
        assert_eq!(key(&t), key(&again));
        assert_eq!(t.unordered, again.unordered);
    }

    #[test]
    fn errors_name_the_line() {
        let bad = "# fringe-trace 1\n0.1 > 12 zz\n";
        let e = Trace::parse(bad, "bad.trace").expect_err("must fail");
        assert_eq!(
            e.to_string(),
            "bad.trace line 2: `zz` is not a two-digit hex byte"
        );
        let back = "# fringe-trace 1\n0.2 > 12\n0.1 < 13\n";
        assert!(Trace::parse(back, "b")
            .expect_err("backwards")
            .to_string()
            .contains("line 3"));
        assert!(Trace::parse("hello\n", "h").is_err());
    }
}
