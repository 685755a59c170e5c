//! The F/T stream's silence as a thread that watches it can vouch for it.
//!
//! The watchers look every [`POLL`] while the bench moves; the press loop looks before it reads a
//! force with z at rest ([`await_fresh_sample`]). Both count a gap in the stream only while they
//! themselves ran ([`SilenceClock`]): a pause of the whole host is not the sensor going quiet.

use crate::acquire::force_stream::ForceMonitor;
use crate::clock::HostTime;
use std::collections::VecDeque;
use std::time::Duration;

/// The longest gap in the F/T stream tolerated by default (5 kHz: 250 samples).
pub(crate) const FORCE_SILENCE: Duration = Duration::from_millis(50);

/// How often the watcher thread looks.
pub(crate) const POLL: Duration = Duration::from_millis(2);

/// A pause of the watcher's own thread longer than this (ten polls) is the host's: the machine
/// ran none of the bench's threads for that long.
const OWN_PAUSE: Duration = Duration::from_millis(20);

/// The F/T silence the watcher can vouch for.
///
/// A host that stops running the process for a while (measured on the 2-core CI machine, a
/// virtual machine: 70 ms with every thread of the scan held, camera and F/T alike) leaves the
/// newest F/T sample as old as the pause when the threads run again. Whichever runs first, the
/// watcher or the F/T reader, decides whether that reads as silence; the sensor did not go quiet
/// while anyone watched. So the silence the watcher counts leaves out its own longest pause (past
/// its poll period) since the newest sample: a stream that really stopped trips the limit once
/// the watcher has watched it that long, and a pause of the host alone does not. Only one pause is
/// left out, so a watcher the machine keeps holding (one refused real-time priority, on a busy
/// machine) still trips a dead stream, one pause late at most.
#[derive(Debug, Clone, Default)]
pub(crate) struct SilenceClock {
    last_look: Option<HostTime>,
    /// The watcher's own pauses over [`OWN_PAUSE`] in the last second: when it ran again and how
    /// much longer than a poll the pause was.
    pauses: VecDeque<(HostTime, Duration)>,
}

impl SilenceClock {
    /// Notes a look at `now`.
    pub(crate) fn look(&mut self, now: HostTime) {
        if let Some(last) = self.last_look {
            let gap = now.since(last);
            if gap > OWN_PAUSE {
                self.pauses.push_back((now, gap.saturating_sub(POLL)));
            }
        }
        self.last_look = Some(now);
        while self
            .pauses
            .front()
            .is_some_and(|(at, _)| now.since(*at) > Duration::from_secs(1))
        {
            self.pauses.pop_front();
        }
    }

    /// The silence at `now` of a stream whose newest sample arrived at `newest`.
    pub(crate) fn silence(&self, now: HostTime, newest: HostTime) -> Duration {
        let paused = self
            .pauses
            .iter()
            .filter(|(resumed, _)| *resumed > newest)
            .map(|(_, excess)| *excess)
            .max()
            .unwrap_or_default();
        now.since(newest).saturating_sub(paused)
    }
}

/// Why no fresh sample came.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Silent {
    /// The stream has delivered nothing yet.
    NoSamples,
    /// The newest sample is this old.
    For(Duration),
    /// The stream's reader reported an error.
    Failed(String),
    /// `stop` said to give up waiting.
    Stopped,
}

/// Waits until the stream's newest sample is at most `limit` old, for at most `limit` of this
/// thread's own running time: a stream the host held (its reader not run for a while) delivers
/// what it buffered meanwhile, and a stream that is dead is said so once this thread has watched
/// it for the limit. `stop` is asked at every look.
pub(crate) fn await_fresh_sample(
    monitor: &ForceMonitor,
    limit: Duration,
    stop: impl Fn() -> bool,
) -> Result<(), Silent> {
    let asked = HostTime::now();
    let mut clock = SilenceClock::default();
    loop {
        if let Some(e) = monitor.error() {
            return Err(Silent::Failed(e));
        }
        let now = HostTime::now();
        clock.look(now);
        let newest = monitor.latest().map(|s| s.host_time);
        if newest.is_some_and(|n| now.since(n) <= limit) {
            return Ok(());
        }
        // Counted from the ask at the earliest: what came before it was not watched here.
        let watched_from = newest.map_or(asked, |n| n.max(asked));
        if clock.silence(now, watched_from) > limit {
            return Err(newest.map_or(Silent::NoSamples, |n| Silent::For(now.since(n))));
        }
        if stop() {
            return Err(Silent::Stopped);
        }
        std::thread::sleep(POLL);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(ms: u64) -> HostTime {
        HostTime(ms * 1_000_000)
    }

    /// Looks every `every` ms from `from` to `to` (ms).
    fn polls(clock: &mut SilenceClock, from: u64, to: u64, every: u64) {
        let mut t = from;
        while t <= to {
            clock.look(at(t));
            t += every;
        }
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn a_stream_that_stops_while_the_watcher_runs_trips_after_the_limit() {
        let mut clock = SilenceClock::default();
        polls(&mut clock, 0, 100, 2);
        // The newest sample came at 40 ms; the watcher looked all along.
        assert_eq!(clock.silence(at(100), at(40)), ms(60));
        assert_eq!(clock.silence(at(100), at(98)), ms(2));
    }

    #[test]
    fn a_pause_of_the_host_alone_is_not_silence() {
        let mut clock = SilenceClock::default();
        polls(&mut clock, 0, 100, 2);
        // Nothing ran from 100 to 170 ms: the newest sample is from 98 ms when the watcher runs
        // again, before the reader has delivered what came in meanwhile.
        clock.look(at(170));
        assert_eq!(clock.silence(at(170), at(98)), ms(4));
        // The reader catches up: the stream's own gaps count again.
        polls(&mut clock, 172, 200, 2);
        assert_eq!(clock.silence(at(200), at(196)), ms(4));
    }

    #[test]
    fn a_stream_dead_across_a_host_pause_trips_once_the_watcher_has_watched_the_limit() {
        let mut clock = SilenceClock::default();
        polls(&mut clock, 0, 100, 2);
        clock.look(at(170));
        polls(&mut clock, 172, 222, 2);
        let limit = FORCE_SILENCE;
        // The stream's newest sample stays at 98 ms: 4 ms watched before the pause.
        assert!(clock.silence(at(214), at(98)) <= limit);
        assert!(clock.silence(at(218), at(98)) > limit);
    }

    #[test]
    fn a_watcher_the_machine_keeps_holding_still_trips_a_dead_stream() {
        // Refused real-time priority on a busy machine: it looks every 30 ms.
        let mut clock = SilenceClock::default();
        polls(&mut clock, 0, 150, 30);
        let limit = FORCE_SILENCE;
        // Newest sample at 0 ms: one 28 ms pause is left out, not every one.
        assert_eq!(clock.silence(at(150), at(0)), ms(122));
        assert!(clock.silence(at(90), at(0)) > limit);
    }

    #[test]
    fn polls_late_by_less_than_ten_periods_are_the_watcher_running() {
        let mut clock = SilenceClock::default();
        polls(&mut clock, 0, 100, 2);
        // A busy machine holds the watcher 15 ms: it still vouches for the silence.
        clock.look(at(115));
        assert_eq!(clock.silence(at(115), at(40)), ms(75));
    }
}
