//! Watchers: a thread that checks the bench every 2 ms and stops the scan on its own (real-time
//! when allowed, as the F/T reader: [`crate::realtime`]).
//!
//! - force above the ceiling: trips at once (the press loop stops z and backs off; the scan
//!   retracts);
//! - no F/T data for longer than the silence limit (50 ms): trips, motion stops. The silence
//!   counts only while the watcher itself ran: after a pause of its own thread (the host held
//!   every thread, the F/T path with it), it counts from when it runs again ([`SilenceClock`]);
//! - camera drops above a threshold while filming: trips, the scan pauses;
//! - a pause-now or abort request: trips (so every wait in the scan ends within a poll).
//!
//! A trip sets the shared cancel flag every motion loop checks. The scan resumes only when the
//! alarm's condition has cleared ([`Watchers::condition`]) and the operator agrees.

use super::control::ScanControl;
use crate::acquire::force_stream::ForceMonitor;
use crate::acquire::recorder::RecorderStats;
use crate::clock::HostTime;
use crate::units::Newtons;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The kind of the run's event that records a point pressed again after the watchers
/// interrupted it (camera drops, a stalled F/T stream, the force ceiling), with why and which
/// try it is.
pub const REPRESS_EVENT: &str = "re-press";

/// The kind of the run's event that records a scan stopped because the watchers interrupted one
/// point too many times in a row (the run closes failed: a resume goes on with it).
pub const STOPPED_BY_WATCHERS_EVENT: &str = "stopped-by-watchers";

/// Limits the watchers enforce.
#[derive(Debug, Clone, PartialEq)]
pub struct WatchSettings {
    pub ceiling: Newtons,
    /// Longest gap in the F/T stream tolerated.
    pub force_silence: Duration,
    /// Dropped frames tolerated within `drop_window` while filming.
    pub max_drops: u64,
    pub drop_window: Duration,
}

impl Default for WatchSettings {
    fn default() -> Self {
        WatchSettings {
            ceiling: Newtons(12.0),
            force_silence: Duration::from_millis(50),
            max_drops: 10,
            drop_window: Duration::from_secs(2),
        }
    }
}

/// Why the watchers stopped the scan.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Alarm {
    Ceiling {
        force: Newtons,
        ceiling: Newtons,
    },
    ForceSilent {
        silence: Duration,
    },
    CameraDrops {
        /// Frames dropped within `window`.
        dropped: u64,
        window: Duration,
        /// Frames dropped since the scan (this session of it) started, as the progress shows
        /// them: the one count both say.
        total: u64,
    },
    /// The operator asked to stop now (pause now or abort).
    Requested,
}

impl std::fmt::Display for Alarm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Alarm::Ceiling { force, ceiling } => write!(
                f,
                "force {:.2} N above the ceiling {:.2} N: z stopped and retracted",
                force.0, ceiling.0
            ),
            Alarm::ForceSilent { silence } => write!(
                f,
                "no force/torque data for {} ms: motion stopped (check the F/T cable and stream)",
                silence.as_millis()
            ),
            Alarm::CameraDrops {
                dropped,
                window,
                total,
            } => write!(
                f,
                "camera dropped {dropped} frames within {:.1} s ({total} dropped in this scan so far)",
                window.as_secs_f64()
            ),
            Alarm::Requested => write!(f, "stop requested"),
        }
    }
}

/// How often the watcher thread looks.
const POLL: Duration = Duration::from_millis(2);

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
struct SilenceClock {
    last_look: Option<HostTime>,
    /// The watcher's own pauses over [`OWN_PAUSE`] in the last second: when it ran again and how
    /// much longer than a poll the pause was.
    pauses: VecDeque<(HostTime, Duration)>,
}

impl SilenceClock {
    /// Notes a look at `now`.
    fn look(&mut self, now: HostTime) {
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
    fn silence(&self, now: HostTime, newest: HostTime) -> Duration {
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

/// The pressing force's zero (the tared no-contact Fz, N), shared with the watchers.
#[derive(Debug, Clone, Default)]
pub(crate) struct SharedTare(Arc<AtomicU64>);

impl SharedTare {
    pub(crate) fn set(&self, fz: f64) {
        self.0.store(fz.to_bits(), Ordering::SeqCst);
    }

    pub(crate) fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::SeqCst))
    }
}

struct Shared {
    alarm: Mutex<Option<Alarm>>,
    /// Frames dropped within the drop window, filming or not (how steady the camera is now).
    recent_drops: AtomicU64,
    /// Filming: camera drops count only then.
    filming: AtomicBool,
    stop: AtomicBool,
}

/// The watcher thread.
pub(crate) struct Watchers {
    shared: Arc<Shared>,
    cancel: Arc<AtomicBool>,
    monitor: ForceMonitor,
    tare: SharedTare,
    settings: WatchSettings,
    handle: Option<JoinHandle<()>>,
}

/// Source of the recorder's counters (dropped frames).
pub(crate) type StatsSource = Box<dyn Fn() -> RecorderStats + Send>;

impl Watchers {
    /// Starts watching; `cancel` is the flag every motion loop of the scan checks.
    pub(crate) fn spawn(
        monitor: ForceMonitor,
        recorder: StatsSource,
        control: ScanControl,
        tare: SharedTare,
        settings: WatchSettings,
        cancel: Arc<AtomicBool>,
    ) -> Watchers {
        let shared = Arc::new(Shared {
            alarm: Mutex::new(None),
            recent_drops: AtomicU64::new(0),
            filming: AtomicBool::new(false),
            stop: AtomicBool::new(false),
        });
        let handle = {
            let (shared, cancel, monitor, tare, settings) = (
                shared.clone(),
                cancel.clone(),
                monitor.clone(),
                tare.clone(),
                settings.clone(),
            );
            std::thread::Builder::new()
                .name("watchers".into())
                .spawn(move || {
                    // Refused with the F/T reader's refusal (the same permission), which the
                    // run records.
                    let _ = crate::realtime::raise_current_thread("watchers");
                    let mut drops: VecDeque<(Instant, u64)> = VecDeque::new();
                    let mut filmed_from: Option<u64> = None;
                    let mut clock = SilenceClock::default();
                    while !shared.stop.load(Ordering::SeqCst) {
                        clock.look(HostTime::now());
                        let filming = shared.filming.load(Ordering::SeqCst);
                        let dropped = recorder().dropped_frames;
                        let now = Instant::now();
                        drops.push_back((now, dropped));
                        while drops
                            .front()
                            .is_some_and(|(t, _)| now.duration_since(*t) > settings.drop_window)
                        {
                            drops.pop_front();
                        }
                        // A late frame lowers the count it was first counted in.
                        let recent = dropped.saturating_sub(drops.front().map_or(dropped, |d| d.1));
                        shared.recent_drops.store(recent, Ordering::SeqCst);
                        // While filming, only the drops since filming began count.
                        let filmed_from = filmed_from.get_or_insert(dropped);
                        if !filming {
                            *filmed_from = dropped;
                        }
                        let since = drops.front().map_or(dropped, |d| d.1).max(*filmed_from);
                        let recent = dropped.saturating_sub(since);
                        let alarm = condition_of(&monitor, tare.get(), &settings, &clock)
                            .or_else(|| {
                                (filming && recent > settings.max_drops).then_some(
                                    Alarm::CameraDrops {
                                        dropped: recent,
                                        window: settings.drop_window,
                                        total: dropped,
                                    },
                                )
                            })
                            .or_else(|| control.stop_now().then_some(Alarm::Requested));
                        if let Some(alarm) = alarm {
                            let mut slot = shared.alarm.lock().unwrap_or_else(|p| p.into_inner());
                            if slot.is_none() {
                                *slot = Some(alarm);
                            }
                            cancel.store(true, Ordering::SeqCst);
                        }
                        std::thread::sleep(POLL);
                    }
                })
                .ok()
        };
        Watchers {
            shared,
            cancel,
            monitor,
            tare,
            settings,
            handle,
        }
    }

    /// The alarm that tripped, if any.
    pub(crate) fn alarm(&self) -> Option<Alarm> {
        self.shared
            .alarm
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// The force and stream conditions as they are now (None: all clear).
    pub(crate) fn condition(&self) -> Option<Alarm> {
        condition_of(
            &self.monitor,
            self.tare.get(),
            &self.settings,
            &SilenceClock::default(),
        )
    }

    /// Frames the camera dropped within the drop window (filming or not), and the window.
    pub(crate) fn recent_drops(&self) -> (u64, Duration) {
        (
            self.shared.recent_drops.load(Ordering::SeqCst),
            self.settings.drop_window,
        )
    }

    /// Tells the watchers whether frames are being filmed (camera drops count only then).
    pub(crate) fn set_filming(&self, filming: bool) {
        self.shared.filming.store(filming, Ordering::SeqCst);
    }

    /// Clears the alarm and the cancel flag (after the operator agreed to resume).
    pub(crate) fn reset(&self) {
        *self.shared.alarm.lock().unwrap_or_else(|p| p.into_inner()) = None;
        self.cancel.store(false, Ordering::SeqCst);
    }

    /// True when the watcher thread could be started.
    pub(crate) fn running(&self) -> bool {
        self.handle.is_some()
    }
}

impl Drop for Watchers {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// Force ceiling and F/T silence (as `clock` counts it), as they are now.
fn condition_of(
    monitor: &ForceMonitor,
    tare_fz: f64,
    settings: &WatchSettings,
    clock: &SilenceClock,
) -> Option<Alarm> {
    // No sample yet: the scan waits for the stream before it moves.
    if let Some(newest) = monitor.latest() {
        let silence = clock.silence(HostTime::now(), newest.host_time);
        if silence > settings.force_silence {
            return Some(Alarm::ForceSilent { silence });
        }
    }
    let (_, mean) = monitor.mean_of_last(5)?;
    let force = Newtons(tare_fz - mean[2]);
    (force > settings.ceiling).then_some(Alarm::Ceiling {
        force,
        ceiling: settings.ceiling,
    })
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
        let limit = WatchSettings::default().force_silence;
        // The stream's newest sample stays at 98 ms: 4 ms watched before the pause.
        assert!(clock.silence(at(214), at(98)) <= limit);
        assert!(clock.silence(at(218), at(98)) > limit);
    }

    #[test]
    fn a_watcher_the_machine_keeps_holding_still_trips_a_dead_stream() {
        // Refused real-time priority on a busy machine: it looks every 30 ms.
        let mut clock = SilenceClock::default();
        polls(&mut clock, 0, 150, 30);
        let limit = WatchSettings::default().force_silence;
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
