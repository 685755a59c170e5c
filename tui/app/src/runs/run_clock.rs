//! A run's host times on the Unix time base, so its messages line up with a robot's logs.
//!
//! Every time a run records (a frame's arrival and exposure, a force sample, an event) is on the
//! host clock: nanoseconds since the start of the process that wrote it, monotonic, with no fixed
//! relation to the wall clock (`fringe_rig::HostTime`). What ties them to Unix time is the
//! events: each carries its host time and the wall-clock time (UTC, to the millisecond, cut
//! down, never rounded) read at the same instant. Within one process the offset between the two
//! is one number; each event bounds it to a window one millisecond wide,
//! `[utc - host, utc + 1 ms - host)`, and the run's offset is the middle of the windows'
//! intersection (half a millisecond or better, tighter as the events spread over the
//! millisecond). When the windows do not meet (the wall clock was stepped or slewed during the
//! run), the median of their middles is taken and the spread said.
//!
//! A run resumed after a crash was written by several processes, each with its own host clock,
//! which starts again near zero: each stream (events, frames, force samples) is cut where its
//! host time goes back, and the n-th part of a stream takes the offset of the n-th part of the
//! events. A run with no events (none is written before the scan's first prompt) takes its
//! start document's time for host time zero, to a fraction of a second.

use fringe_rig::store::{utc_days, Event, StartDocument};

/// Nanoseconds in a millisecond: the resolution of an event's wall-clock time.
const MS: i64 = 1_000_000;

/// Where the offsets came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClockSource {
    /// The events' wall-clock times.
    Events,
    /// No event: the start document's time for host time zero.
    StartDocument,
}

/// The host clock of one process that wrote the run, on Unix time.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    /// Unix time minus host time, ns.
    offset_ns: i64,
    /// Half the width of the window the offset is known to lie in, ns.
    uncertainty_ns: i64,
}

/// A run's host clock on Unix time: one offset per process that wrote the run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunClock {
    segments: Vec<Segment>,
    source: ClockSource,
}

/// Unix nanoseconds of an RFC 3339 UTC time as the run store writes it
/// (`2026-12-06T17:50:56.530Z`); `None` when it is not one.
pub(crate) fn unix_ns(utc: &str) -> Option<i64> {
    let days = utc_days(utc)?;
    let time = utc.get(11..)?.strip_suffix('Z')?;
    let (hms, fraction) = time.split_once('.').unwrap_or((time, ""));
    let mut parts = hms.split(':');
    let h: i64 = parts.next()?.parse().ok()?;
    let m: i64 = parts.next()?.parse().ok()?;
    let s: i64 = parts.next()?.parse().ok()?;
    if parts.next().is_some() || h > 23 || m > 59 || s > 60 || fraction.len() > 9 {
        return None;
    }
    let frac_ns: i64 = if fraction.is_empty() {
        0
    } else {
        let digits: i64 = fraction.parse().ok()?;
        digits * 10i64.pow(9 - fraction.len() as u32)
    };
    Some(((days * 86_400 + h * 3_600 + m * 60 + s) * 1_000_000_000) + frac_ns)
}

/// Indices at which a stream of host times starts a new part (its host time goes back): the
/// start of each part after the first.
pub(crate) fn restarts(host_ns: impl IntoIterator<Item = u64>) -> Vec<usize> {
    let mut out = Vec::new();
    let mut last = None;
    for (k, t) in host_ns.into_iter().enumerate() {
        if last.is_some_and(|l| t < l) {
            out.push(k);
        }
        last = Some(t);
    }
    out
}

/// The part of a stream that item `k` lies in, given where its parts start ([`restarts`]).
pub(crate) fn part_of(restarts: &[usize], k: usize) -> usize {
    restarts.partition_point(|&r| r <= k)
}

/// The offset of one process from its events' `(host ns, unix ns cut to the millisecond)`.
fn segment(anchors: &[(i64, i64)]) -> Segment {
    let lows: Vec<i64> = anchors.iter().map(|(host, unix)| unix - host).collect();
    let lo = lows.iter().copied().max().unwrap_or(0);
    let hi = lows.iter().copied().min().unwrap_or(0) + MS;
    if lo < hi {
        return Segment {
            offset_ns: lo + (hi - lo) / 2,
            uncertainty_ns: (hi - lo) / 2,
        };
    }
    // The windows do not meet: the wall clock moved during the run.
    let mut middles: Vec<i64> = lows.iter().map(|l| l + MS / 2).collect();
    middles.sort_unstable();
    let median = middles[middles.len() / 2];
    let spread = middles[middles.len() - 1] - middles[0];
    Segment {
        offset_ns: median,
        uncertainty_ns: spread / 2 + MS / 2,
    }
}

impl RunClock {
    /// The clock of the run that began with `start` and recorded `events` (in file order).
    pub fn of_run(start: &StartDocument, events: &[Event]) -> RunClock {
        let mut parts: Vec<Vec<(i64, i64)>> = Vec::new();
        let mut last = None;
        for e in events {
            let Some(unix) = unix_ns(&e.utc) else {
                continue;
            };
            if parts.is_empty() || last.is_some_and(|l| e.host_ns < l) {
                parts.push(Vec::new());
            }
            last = Some(e.host_ns);
            if let Some(part) = parts.last_mut() {
                part.push((e.host_ns as i64, unix));
            }
        }
        if parts.is_empty() {
            return RunClock {
                segments: vec![Segment {
                    offset_ns: unix_ns(&start.started_utc).unwrap_or(0),
                    uncertainty_ns: 0,
                }],
                source: ClockSource::StartDocument,
            };
        }
        RunClock {
            segments: parts.iter().map(|p| segment(p)).collect(),
            source: ClockSource::Events,
        }
    }

    /// Unix nanoseconds of host time `host_ns` of part `part` of a stream (0 unless the run was
    /// resumed: [`restarts`], [`part_of`]); a part beyond the events' takes their last offset.
    pub fn unix_ns(&self, part: usize, host_ns: f64) -> u64 {
        let s = self.segments[part.min(self.segments.len() - 1)];
        // In integers: a Unix time in ns as an f64 would be kept only to 256 ns.
        s.offset_ns.saturating_add(host_ns.round() as i64).max(0) as u64
    }

    /// How far the mapping may be off (the widest window), ns; 0 for [`ClockSource::StartDocument`],
    /// whose error is not known.
    pub fn uncertainty_ns(&self) -> u64 {
        self.segments
            .iter()
            .map(|s| s.uncertainty_ns.max(0) as u64)
            .max()
            .unwrap_or(0)
    }

    /// The processes that wrote the run, as the events tell (1 unless it was resumed).
    pub fn processes(&self) -> usize {
        self.segments.len()
    }

    /// Where the offsets came from.
    pub fn source(&self) -> ClockSource {
        self.source
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start(utc: &str) -> StartDocument {
        StartDocument {
            layout_version: fringe_rig::store::LAYOUT_VERSION,
            run_id: "r".into(),
            started_utc: utc.into(),
            software: "test".into(),
            sensor_id: "s".into(),
            variant: None,
            plan: String::new(),
            rig: String::new(),
            calibration_profile: None,
            seed: None,
            ft_axes: None,
            sync_method: "host".into(),
            frames: None,
        }
    }

    /// `unix` as the run store writes it: UTC, milliseconds cut down.
    fn utc(unix: i64) -> String {
        let secs = unix.div_euclid(1_000_000_000);
        let ms = unix.rem_euclid(1_000_000_000) / MS;
        let days = secs.div_euclid(86_400);
        let rem = secs.rem_euclid(86_400);
        format!(
            "{}T{:02}:{:02}:{:02}.{ms:03}Z",
            fringe_rig::store::utc_date(days),
            rem / 3600,
            rem / 60 % 60,
            rem % 60
        )
    }

    fn event(host_ns: u64, unix: i64) -> Event {
        Event {
            host_ns,
            utc: utc(unix),
            kind: "prompt".into(),
            point: None,
            message: String::new(),
        }
    }

    #[test]
    fn utc_times_read_as_unix_nanoseconds() {
        assert_eq!(unix_ns("1970-01-01T00:00:00.000Z"), Some(0));
        assert_eq!(
            unix_ns("2026-12-06T17:50:56.530Z"),
            Some(1_796_579_456_530_000_000)
        );
        assert_eq!(
            unix_ns("2026-12-06T17:50:56Z"),
            Some(1_796_579_456_000_000_000)
        );
        assert_eq!(
            unix_ns("2026-12-06T17:50:56.53Z"),
            Some(1_796_579_456_530_000_000)
        );
        assert_eq!(unix_ns("2026-12-06 17:50:56.530"), None);
        assert_eq!(unix_ns("2026-12-06T25:50:56.530Z"), None);
        // What the helper above writes reads back to the millisecond.
        assert_eq!(
            unix_ns(&utc(1_796_579_456_530_999_999)),
            Some(1_796_579_456_530_000_000)
        );
    }

    /// A process whose host clock started at a Unix time with a sub-millisecond part: every
    /// host time maps to its Unix time within the half millisecond the events allow, and within
    /// a few microseconds once the events' host times spread over the millisecond.
    #[test]
    fn host_times_map_to_unix_time_within_what_the_events_allow() {
        let epoch: i64 = 1_796_579_448_398_123_456; // Unix ns at host time 0
        let host = [8_131_890_624u64, 13_571_321_949, 15_087_659_093];
        let events: Vec<Event> = host.iter().map(|&h| event(h, epoch + h as i64)).collect();
        let clock = RunClock::of_run(&start("2026-12-06T17:50:48.702Z"), &events);
        assert_eq!(clock.source(), ClockSource::Events);
        assert_eq!(clock.processes(), 1);
        assert!(clock.uncertainty_ns() <= 500_000, "{clock:?}");
        for h in [0.0, 1e9, 13_286_237_096.0] {
            let err = clock.unix_ns(0, h) as i64 - (epoch + h as i64);
            assert!(err.abs() <= clock.uncertainty_ns() as i64, "{err} ns");
        }
        // Events every 37.1 us over a second: their windows pin the offset to a few us.
        let events: Vec<Event> = (0..27_000u64)
            .map(|k| {
                event(
                    1_000_000_000 + k * 37_100,
                    epoch + 1_000_000_000 + (k * 37_100) as i64,
                )
            })
            .collect();
        let clock = RunClock::of_run(&start("2026-12-06T17:50:48.702Z"), &events);
        assert!(clock.uncertainty_ns() <= 40_000, "{clock:?}");
        let err = clock.unix_ns(0, 2e9) as i64 - (epoch + 2_000_000_000);
        assert!(err.abs() <= 40_000, "{err} ns");
    }

    /// A resumed run: the second process's host clock starts again near zero, an hour later;
    /// each part of a stream takes its own process's offset.
    #[test]
    fn each_process_of_a_resumed_run_has_its_own_offset() {
        let first: i64 = 1_796_579_448_398_123_456;
        let second = first + 3_600_000_000_000 + 777_777;
        let events = vec![
            event(8_000_000_000, first + 8_000_000_000),
            event(20_000_000_000, first + 20_000_000_000),
            event(5_000_000_000, second + 5_000_000_000),
            event(9_000_000_000, second + 9_000_000_000),
        ];
        let clock = RunClock::of_run(&start("2026-12-06T17:50:48.702Z"), &events);
        assert_eq!(clock.processes(), 2);
        let err0 = clock.unix_ns(0, 10e9) as i64 - (first + 10_000_000_000);
        let err1 = clock.unix_ns(1, 10e9) as i64 - (second + 10_000_000_000);
        assert!(
            err0.abs() <= 500_000 && err1.abs() <= 500_000,
            "{err0} {err1}"
        );
        // A stream's parts: its host times going back mark the second process.
        let frames = [
            7_000_000_000u64,
            9_000_000_000,
            6_000_000_000,
            6_500_000_000,
        ];
        let cuts = restarts(frames);
        assert_eq!(cuts, vec![2]);
        assert_eq!(
            (0..4).map(|k| part_of(&cuts, k)).collect::<Vec<_>>(),
            [0, 0, 1, 1]
        );
    }

    /// The wall clock stepped by 50 ms during the run: the windows do not meet, the median is
    /// taken and the uncertainty says how far apart they were.
    #[test]
    fn a_stepped_wall_clock_is_said_not_hidden() {
        let epoch: i64 = 1_796_579_448_398_123_456;
        let events = vec![
            event(1_000_000_000, epoch + 1_000_000_000),
            event(2_000_000_000, epoch + 2_000_000_000),
            event(3_000_000_000, epoch + 3_050_000_000),
        ];
        let clock = RunClock::of_run(&start("2026-12-06T17:50:48.702Z"), &events);
        assert!(clock.uncertainty_ns() >= 25_000_000, "{clock:?}");
        let err = clock.unix_ns(0, 1.5e9) as i64 - (epoch + 1_500_000_000);
        assert!(err.abs() <= 1_000_000, "{err} ns");
    }

    #[test]
    fn a_run_without_events_starts_at_its_start_document() {
        let clock = RunClock::of_run(&start("2026-12-06T17:50:48.702Z"), &[]);
        assert_eq!(clock.source(), ClockSource::StartDocument);
        assert_eq!(clock.unix_ns(0, 1e9), 1_796_579_449_702_000_000);
    }
}
