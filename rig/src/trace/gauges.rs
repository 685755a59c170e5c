//! A DAQ's gauge scans in a trace: recorded from any [`GaugeSource`] and played back as one.
//!
//! The file is an ordinary `datagram` trace (`docs/trace-format.md`): the DAQ delivers scans, not
//! bytes on a link, so each [`GaugeReading`] is one device-to-host datagram, and starting and
//! stopping acquisition are host-to-device datagrams (`> 01` start, `> 00` stop) that a replay
//! expects in the recorded order. A line's time is the reading's host time since the trace
//! started (all scans of one block share it). A reading's datagram (82 bytes, little-endian):
//!
//! | bytes | field |
//! |---|---|
//! | 0 | record version, 1 |
//! | 1..9 | `index`: the DAQ's sample index (u64) |
//! | 9..17 | host time since the trace started, ns (u64) |
//! | 17..65 | the six gauge voltages (f64 each) |
//! | 65 | 1 when a strobe voltage follows, else 0 |
//! | 66..74 | the strobe voltage (f64; 0 when none) |
//! | 74..82 | `lost_before`: scans lost just before this one (u64) |
//!
//! Voltages are stored as their exact bits, so a replay converts them to the same forces.

#[cfg(test)]
use super::format::{hex, Trace, TraceError};
use super::format::{Direction, LinkKind};
use super::record::TraceWriter;
#[cfg(test)]
use super::replay::{ReplayDatagramLink, ReplayHandle, ReplayOptions};
use crate::atical::{GaugeReading, GaugeSource};
use crate::clock::HostTime;
use crate::force::ForceError;
#[cfg(test)]
use crate::transport::DatagramLink;
#[cfg(test)]
use crate::units::Volts;
use std::io;
use std::path::Path;
use std::time::Duration;

/// Bytes of one reading's datagram.
pub(crate) const READING_BYTES: usize = 82;
const VERSION: u8 = 1;
/// The host-to-device datagrams marking acquisition started and stopped.
pub(crate) const START: [u8; 1] = [1];
pub(crate) const STOP: [u8; 1] = [0];

/// A reading as a datagram; `host_offset` is its host time since the trace started.
pub(crate) fn encode_reading(r: &GaugeReading, host_offset: Duration) -> [u8; READING_BYTES] {
    let mut b = [0u8; READING_BYTES];
    b[0] = VERSION;
    b[1..9].copy_from_slice(&r.index.to_le_bytes());
    let nanos = u64::try_from(host_offset.as_nanos()).unwrap_or(u64::MAX);
    b[9..17].copy_from_slice(&nanos.to_le_bytes());
    for (i, v) in r.gauges.iter().enumerate() {
        b[17 + 8 * i..25 + 8 * i].copy_from_slice(&v.0.to_le_bytes());
    }
    if let Some(s) = r.strobe {
        b[65] = 1;
        b[66..74].copy_from_slice(&s.0.to_le_bytes());
    }
    b[74..82].copy_from_slice(&r.lost_before.to_le_bytes());
    b
}

/// A datagram back as a reading whose host time is `origin` plus the recorded offset.
#[cfg(test)]
pub(crate) fn decode_reading(bytes: &[u8], origin: HostTime) -> Result<GaugeReading, String> {
    if bytes.len() != READING_BYTES {
        return Err(format!(
            "a gauge reading is {READING_BYTES} bytes, this datagram has {}",
            bytes.len()
        ));
    }
    if bytes[0] != VERSION {
        return Err(format!(
            "gauge reading version {} (this fringe reads version {VERSION})",
            bytes[0]
        ));
    }
    let u64_at = |at: usize| {
        let mut a = [0u8; 8];
        a.copy_from_slice(&bytes[at..at + 8]);
        u64::from_le_bytes(a)
    };
    let f64_at = |at: usize| f64::from_bits(u64_at(at));
    let strobe = match bytes[65] {
        0 => None,
        1 => Some(Volts(f64_at(66))),
        other => return Err(format!("strobe flag {other}: must be 0 or 1")),
    };
    Ok(GaugeReading {
        index: u64_at(1),
        host_time: HostTime(origin.0.saturating_add(u64_at(9))),
        gauges: std::array::from_fn(|i| Volts(f64_at(17 + 8 * i))),
        strobe,
        lost_before: u64_at(74),
    })
}

/// A gauge source whose every reading, start and stop goes to a trace file.
pub struct RecordingGauges<S> {
    inner: S,
    writer: TraceWriter,
    /// Host time of the trace's start (time 0 of its lines).
    origin: HostTime,
    /// Time of the last line written (lines never go backwards).
    last: Duration,
}

impl<S: GaugeSource> RecordingGauges<S> {
    /// Wraps `inner`, recording to `path` under the device name `device`.
    pub fn new(inner: S, path: &Path, device: &str) -> io::Result<Self> {
        let mut writer = TraceWriter::create(path, device, &inner.describe(), LinkKind::Datagram)?;
        writer.comment(
            "gauge scans of a DAQ (fringe_rig::trace::gauges): > 01 start, > 00 stop; each < line one scan,\n\
             version 1, index u64, host ns u64, 6 gauge volts f64, strobe flag u8 + volts f64, lost_before u64 (little-endian)",
        )?;
        Ok(RecordingGauges {
            inner,
            writer,
            origin: HostTime::now(),
            last: Duration::ZERO,
        })
    }

    /// The recorded source.
    pub fn inner(&self) -> &S {
        &self.inner
    }

    fn write(
        &mut self,
        at: Duration,
        direction: Direction,
        bytes: &[u8],
    ) -> Result<(), ForceError> {
        self.last = self.last.max(at);
        self.writer
            .append_at(self.last, direction, bytes)
            .map_err(|e| ForceError::Device {
                device: self.inner.describe(),
                message: format!(
                    "cannot write the trace {}: {e} (check the --record-trace directory's disc)",
                    self.writer.path().display()
                ),
            })
    }
}

impl<S: GaugeSource> GaugeSource for RecordingGauges<S> {
    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn start(&mut self) -> Result<(), ForceError> {
        let now = HostTime::now().since(self.origin);
        self.write(now, Direction::ToDevice, &START)?;
        self.inner.start()
    }

    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        let r = self.inner.next_reading(timeout)?;
        if let Some(r) = &r {
            let offset = r.host_time.since(self.origin);
            self.write(offset, Direction::FromDevice, &encode_reading(r, offset))?;
        }
        Ok(r)
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        let now = HostTime::now().since(self.origin);
        self.write(now, Direction::ToDevice, &STOP)?;
        self.inner.stop()
    }
}

/// A gauge source playing a recorded gauge trace: the readings as recorded (host times shifted
/// to the replay's start), paced as recorded unless the speed says otherwise; starting and
/// stopping must come in the recorded order ([`ReplayHandle::finish`] checks).
#[cfg(test)]
pub(crate) struct ReplayGauges {
    link: ReplayDatagramLink,
    origin: HostTime,
    name: String,
    buffer: Vec<u8>,
}

#[cfg(test)]
impl ReplayGauges {
    /// Replays `trace` after checking every reading in it decodes (an error names the line).
    pub(crate) fn new(
        trace: Trace,
        options: ReplayOptions,
    ) -> Result<(ReplayGauges, ReplayHandle), TraceError> {
        let syntax = |line: usize, message: String| TraceError::Syntax {
            source_name: trace.source.clone(),
            line,
            message,
        };
        if trace.kind != LinkKind::Datagram {
            return Err(syntax(
                1,
                "a gauge trace has `# kind: datagram` (one scan a datagram)".into(),
            ));
        }
        for e in &trace.entries {
            match e.direction {
                Direction::FromDevice => {
                    decode_reading(&e.bytes, HostTime(0)).map_err(|m| syntax(e.line, m))?;
                }
                Direction::ToDevice if e.bytes != START && e.bytes != STOP => {
                    return Err(syntax(
                        e.line,
                        format!(
                            "> {}: a gauge trace's host lines are > 01 (start) and > 00 (stop)",
                            hex(&e.bytes)
                        ),
                    ))
                }
                Direction::ToDevice => {}
            }
        }
        let name = format!("replay of {} ({})", trace.source, trace.endpoint);
        let origin = HostTime::now();
        let (link, handle) = ReplayDatagramLink::new(trace, options);
        Ok((
            ReplayGauges {
                link,
                origin,
                name,
                buffer: vec![0; READING_BYTES + 1],
            },
            handle,
        ))
    }

    /// Loads `path` and replays it.
    pub(crate) fn load(
        path: &Path,
        options: ReplayOptions,
    ) -> Result<(ReplayGauges, ReplayHandle), TraceError> {
        ReplayGauges::new(Trace::load(path)?, options)
    }

    fn link_error(&self, e: io::Error) -> ForceError {
        ForceError::Io {
            device: self.name.clone(),
            source: e,
        }
    }
}

#[cfg(test)]
impl GaugeSource for ReplayGauges {
    fn describe(&self) -> String {
        self.name.clone()
    }

    fn start(&mut self) -> Result<(), ForceError> {
        self.link.send(&START).map_err(|e| self.link_error(e))
    }

    fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        let mut buffer = std::mem::take(&mut self.buffer);
        let got = self.link.recv(&mut buffer, timeout);
        let reading = match got {
            Ok(Some(n)) => decode_reading(&buffer[..n], self.origin)
                .map(Some)
                .map_err(|message| ForceError::Device {
                    device: self.name.clone(),
                    message,
                }),
            Ok(None) => Ok(None),
            Err(e) => Err(self.link_error(e)),
        };
        self.buffer = buffer;
        reading
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        self.link.send(&STOP).map_err(|e| self.link_error(e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atical::{CalibratedSensor, Calibration};
    use crate::force::ForceSensor;
    use std::collections::VecDeque;

    /// A gauge source playing scripted readings, in blocks sharing a host time.
    struct Scripted {
        readings: VecDeque<GaugeReading>,
    }

    impl GaugeSource for Scripted {
        fn describe(&self) -> String {
            "scripted DAQ".into()
        }
        fn start(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
        fn next_reading(&mut self, _: Duration) -> Result<Option<GaugeReading>, ForceError> {
            Ok(self.readings.pop_front())
        }
        fn stop(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
    }

    fn scripted(strobe: bool) -> Scripted {
        let t0 = HostTime::now();
        let mut readings = VecDeque::new();
        let mut index = 0;
        for block in 0..5u64 {
            // Block 3 follows an overrun: 40 scans lost.
            let lost = if block == 3 { 40 } else { 0 };
            index += lost;
            for k in 0..50u64 {
                let x = (index as f64) * 1e-3;
                readings.push_back(GaugeReading {
                    index,
                    host_time: HostTime(t0.0 + 10_000_000 * (block + 1)),
                    gauges: std::array::from_fn(|g| {
                        Volts(0.1 * g as f64 + (x * (g + 1) as f64).sin() / 3.0)
                    }),
                    strobe: strobe.then_some(Volts(if k % 10 < 3 { 4.9 } else { 0.01 })),
                    lost_before: if k == 0 { lost } else { 0 },
                });
                index += 1;
            }
        }
        Scripted { readings }
    }

    fn calibration() -> Calibration {
        let text = include_str!("../../../tests/data/mini40-v1.1.cal");
        Calibration::parse(text, "mini40-v1.1.cal").expect("the Mini40 .cal parses")
    }

    fn stream(sensor: &mut dyn ForceSensor, n: usize) -> Vec<crate::force::ForceSample> {
        sensor.start().expect("start");
        let mut out = Vec::new();
        while out.len() < n {
            match sensor
                .next_sample(Duration::from_millis(500))
                .expect("sample")
            {
                Some(s) => out.push(s),
                None => break,
            }
        }
        sensor.stop().expect("stop");
        out
    }

    #[test]
    fn a_recorded_gauge_stream_replays_to_the_same_forces() {
        for strobe in [true, false] {
            let dir = std::env::temp_dir().join(format!(
                "fringe-gauge-trace-{}-{strobe}",
                std::process::id()
            ));
            let path = dir.join("force.trace");
            let recorder = RecordingGauges::new(scripted(strobe), &path, "force").expect("record");
            let mut live = CalibratedSensor::new(recorder, calibration());
            let recorded = stream(&mut live, 250);
            assert_eq!(recorded.len(), 250);
            assert_eq!(
                live.stats().lost,
                40,
                "the overrun's scans are counted lost"
            );
            drop(live);

            let (replay, handle) = ReplayGauges::load(
                &path,
                ReplayOptions {
                    speed: f64::INFINITY,
                },
            )
            .expect("the trace reads back");
            let mut again = CalibratedSensor::new(replay, calibration());
            let replayed = stream(&mut again, 250);
            assert_eq!(replayed.len(), recorded.len());
            for (a, b) in recorded.iter().zip(&replayed) {
                assert_eq!(a.wrench, b.wrench, "scan {}", a.device_tick);
                assert_eq!(a.device_tick, b.device_tick);
                assert_eq!(a.strobe, b.strobe);
            }
            // Host times keep their recorded spacing.
            let gap = |s: &[crate::force::ForceSample]| s[249].host_time.since(s[0].host_time);
            assert_eq!(gap(&recorded), gap(&replayed));
            assert_eq!(again.stats().lost, 40);
            let report = handle.finish().expect("started and stopped as recorded");
            assert_eq!(report.unread_replies, 0);
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    #[test]
    fn a_damaged_gauge_trace_is_refused_naming_the_line() {
        let r = GaugeReading {
            index: 7,
            host_time: HostTime(5),
            gauges: [Volts(1.0); 6],
            strobe: None,
            lost_before: 0,
        };
        let good = hex(&encode_reading(&r, Duration::from_micros(5)));
        let text = format!(
            "# fringe-trace 1\n# kind: datagram\n0.0 > 01\n0.1 < {good}\n0.2 < {}\n",
            &good[..good.len() - 3]
        );
        let e = ReplayGauges::new(
            Trace::parse(&text, "force.trace").expect("parses"),
            ReplayOptions::default(),
        )
        .err()
        .expect("short datagram refused")
        .to_string();
        assert!(
            e.starts_with("force.trace line 5:") && e.contains("82 bytes"),
            "{e}"
        );
        let back = decode_reading(
            &encode_reading(&r, Duration::from_nanos(1234)),
            HostTime(10),
        )
        .expect("decodes");
        assert_eq!(back.host_time, HostTime(1244));
        assert_eq!((back.index, back.gauges, back.strobe), (7, r.gauges, None));
    }
}
