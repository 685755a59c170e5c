//! Watchers: a thread that checks the bench every 2 ms and stops the scan on its own (real-time
//! when allowed, as the F/T reader: [`crate::realtime`]).
//!
//! - force above the ceiling: trips at once (the press loop stops z and backs off; the scan
//!   retracts); the same for the tangential force |Fx, Fy| above its ceiling (a slide stops x,
//!   y and z at once; the scan lifts);
//! - no F/T data for longer than the silence limit (50 ms): trips, motion stops. The silence
//!   counts only while the watcher itself ran: after a pause of its own thread (the host held
//!   every thread, the F/T path with it), it counts from when it runs again ([`SilenceClock`]);
//! - camera drops above a threshold while filming: trips, the scan pauses;
//! - a pause-now or abort request: trips (so every wait in the scan ends within a poll).
//!
//! A trip sets the shared cancel flag every motion loop checks. The scan resumes only when the
//! alarm's condition has cleared ([`Watchers::condition`]) and the operator agrees.

use super::control::ScanControl;
use super::silence::{SilenceClock, FORCE_SILENCE, POLL};
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
    /// The largest tangential force |Fx, Fy| of the tared reading.
    pub tangential_ceiling: Newtons,
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
            tangential_ceiling: Newtons(12.0),
            force_silence: FORCE_SILENCE,
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
    /// The tangential force |Fx, Fy| above its ceiling.
    TangentialCeiling {
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
            Alarm::TangentialCeiling { force, ceiling } => write!(
                f,
                "tangential force {:.2} N above the tangential ceiling {:.2} N: motion stopped and z lifted",
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

/// The forces' zero (the no-contact Fx, Fy, Fz, N), shared with the watchers.
#[derive(Debug, Clone, Default)]
pub(crate) struct SharedTare(Arc<Mutex<[f64; 3]>>);

impl SharedTare {
    /// Takes the zero from a no-contact reading (Fx, Fy, Fz, Mx, My, Mz).
    pub(crate) fn set(&self, reading: &[f64; 6]) {
        *self.0.lock().unwrap_or_else(|p| p.into_inner()) = [reading[0], reading[1], reading[2]];
    }

    /// The zero of Fz: the pressing force is this minus Fz.
    pub(crate) fn get(&self) -> f64 {
        self.forces()[2]
    }

    /// The zero of Fx, Fy and Fz.
    pub(crate) fn forces(&self) -> [f64; 3] {
        *self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The tangential force |Fx, Fy| of a reading (Fx, Fy, Fz, ...) against the zero `tare`.
pub(crate) fn tangential_of(mean: &[f64; 6], tare: [f64; 3]) -> Newtons {
    Newtons((mean[0] - tare[0]).hypot(mean[1] - tare[1]))
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
                        let alarm = condition_of(&monitor, tare.forces(), &settings, &clock)
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
            self.tare.forces(),
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

/// Force ceilings and F/T silence (as `clock` counts it), as they are now.
fn condition_of(
    monitor: &ForceMonitor,
    tare: [f64; 3],
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
    let force = Newtons(tare[2] - mean[2]);
    if force > settings.ceiling {
        return Some(Alarm::Ceiling {
            force,
            ceiling: settings.ceiling,
        });
    }
    let tangential = tangential_of(&mean, tare);
    (tangential > settings.tangential_ceiling).then_some(Alarm::TangentialCeiling {
        force: tangential,
        ceiling: settings.tangential_ceiling,
    })
}
