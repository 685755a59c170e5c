//! A force/torque sensor read on its own thread.
//!
//! The thread owns the sensor and never waits on anyone: every sample is sent on an unbounded
//! channel (the recorder drains it) and kept in a short ring that control loops and watchers read
//! through a [`ForceMonitor`] without blocking the stream. Errors end the stream and are kept for
//! the monitor to report. The thread asks for real-time scheduling ([`crate::realtime`]): late
//! F/T data stop the scan (the watchers' silence limit).

use crate::clock::HostTime;
use crate::force::{ForceError, ForceSample, ForceSensor, StreamStats};
use crate::realtime::RealtimeRefused;
use crossbeam_channel::{bounded, unbounded, Receiver, Sender};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

/// Samples kept for monitors (0.4 s at 5 kHz).
const RING: usize = 2000;

#[derive(Debug, Default)]
struct Shared {
    ring: VecDeque<ForceSample>,
    stats: StreamStats,
    error: Option<String>,
    ended: bool,
}

/// Read access to the latest samples of a running stream; cheap to clone.
#[derive(Debug, Clone)]
pub struct ForceMonitor {
    shared: Arc<Mutex<Shared>>,
    device: String,
}

impl ForceMonitor {
    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The sensor's name.
    pub fn device(&self) -> &str {
        &self.device
    }

    /// The newest sample, if any arrived.
    pub fn latest(&self) -> Option<ForceSample> {
        self.lock().ring.back().copied()
    }

    /// The mean of the newest `n` samples (fewer if fewer arrived), with the newest's host time.
    pub fn mean_of_last(&self, n: usize) -> Option<(HostTime, [f64; 6])> {
        let shared = self.lock();
        let newest = shared.ring.back()?.host_time;
        let take = n.clamp(1, shared.ring.len());
        let mut sum = [0.0; 6];
        for s in shared.ring.iter().rev().take(take) {
            for (acc, v) in sum.iter_mut().zip(s.wrench.to_array()) {
                *acc += v;
            }
        }
        Some((newest, sum.map(|v| v / take as f64)))
    }

    /// How many of the newest `n` samples there are and their per-channel standard deviation
    /// (0 for fewer than two).
    pub fn spread_of_last(&self, n: usize) -> (usize, [f64; 6]) {
        let shared = self.lock();
        let take = n.min(shared.ring.len());
        if take < 2 {
            return (take, [0.0; 6]);
        }
        let (mut sum, mut sq) = ([0.0; 6], [0.0; 6]);
        for s in shared.ring.iter().rev().take(take) {
            for (k, v) in s.wrench.to_array().into_iter().enumerate() {
                sum[k] += v;
                sq[k] += v * v;
            }
        }
        let t = take as f64;
        let sd = std::array::from_fn(|k| {
            let mean = sum[k] / t;
            ((sq[k] - t * mean * mean).max(0.0) / (t - 1.0)).sqrt()
        });
        (take, sd)
    }

    /// Samples received after host time `after`, oldest first (at most the ring's length).
    pub fn since(&self, after: HostTime) -> Vec<ForceSample> {
        self.lock()
            .ring
            .iter()
            .filter(|s| s.host_time > after)
            .copied()
            .collect()
    }

    /// How many of the samples in the ring arrived after host time `after`.
    pub fn count_since(&self, after: HostTime) -> usize {
        self.lock()
            .ring
            .iter()
            .rev()
            .take_while(|s| s.host_time > after)
            .count()
    }

    /// How long ago the newest sample arrived (`None` before the first).
    pub fn silence(&self) -> Option<Duration> {
        self.latest().map(|s| HostTime::now().since(s.host_time))
    }

    /// Counters of the stream.
    pub fn stats(&self) -> StreamStats {
        self.lock().stats
    }

    /// The error that ended the stream, if one did.
    pub fn error(&self) -> Option<String> {
        self.lock().error.clone()
    }

    /// Whether the reading thread has ended (error or stop).
    pub fn ended(&self) -> bool {
        self.lock().ended
    }
}

/// A running force stream.
pub struct ForceStream {
    monitor: ForceMonitor,
    samples: Receiver<ForceSample>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Box<dyn ForceSensor>>>,
    /// Whether the reading thread got real-time scheduling.
    priority: Result<(), RealtimeRefused>,
}

impl ForceStream {
    /// Starts `sensor` and reads it on a new thread.
    pub fn spawn(mut sensor: Box<dyn ForceSensor>) -> Result<ForceStream, ForceError> {
        let device = sensor.describe();
        sensor.start()?;
        let shared = Arc::new(Mutex::new(Shared::default()));
        let (tx, rx) = unbounded();
        let stop = Arc::new(AtomicBool::new(false));
        let (raised_tx, raised_rx) = bounded(1);
        let thread = {
            let shared = shared.clone();
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("force-stream".into())
                .spawn(move || {
                    let _ = raised_tx.send(crate::realtime::raise_current_thread("F/T reader"));
                    read_loop(sensor, shared, tx, stop)
                })
                .map_err(|source| ForceError::Io {
                    device: device.clone(),
                    source,
                })?
        };
        // The thread answers before it reads anything; a thread that died at once (it cannot
        // have) is the reader's concern, not the priority's.
        let priority = raised_rx.recv().unwrap_or(Ok(()));
        Ok(ForceStream {
            monitor: ForceMonitor { shared, device },
            samples: rx,
            stop,
            thread: Some(thread),
            priority,
        })
    }

    /// Why the reading thread runs at normal priority, if real-time scheduling was refused
    /// ([`crate::realtime`]).
    pub fn priority_refused(&self) -> Option<&RealtimeRefused> {
        self.priority.as_ref().err()
    }

    /// A monitor of this stream.
    pub fn monitor(&self) -> ForceMonitor {
        self.monitor.clone()
    }

    /// Every sample, in arrival order, for the recorder.
    pub fn samples(&self) -> &Receiver<ForceSample> {
        &self.samples
    }

    /// Stops the thread and the sensor; returns the sensor for reuse.
    pub fn stop(mut self) -> Result<Box<dyn ForceSensor>, ForceError> {
        self.stop.store(true, Ordering::SeqCst);
        let device = self.monitor.device.clone();
        let mut sensor = self
            .thread
            .take()
            .map(|t| t.join())
            .transpose()
            .map_err(|_| ForceError::Device {
                device: device.clone(),
                message: "the force reading thread panicked".into(),
            })?
            .ok_or_else(|| ForceError::Device {
                device,
                message: "the force stream was already stopped".into(),
            })?;
        sensor.stop()?;
        Ok(sensor)
    }
}

impl Drop for ForceStream {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            if let Ok(mut sensor) = t.join() {
                let _ = sensor.stop();
            }
        }
    }
}

fn read_loop(
    mut sensor: Box<dyn ForceSensor>,
    shared: Arc<Mutex<Shared>>,
    tx: Sender<ForceSample>,
    stop: Arc<AtomicBool>,
) -> Box<dyn ForceSensor> {
    let lock = || shared.lock().unwrap_or_else(|e| e.into_inner());
    while !stop.load(Ordering::SeqCst) {
        let asked = std::time::Instant::now();
        match sensor.next_sample(Duration::from_millis(20)) {
            Ok(Some(sample)) => {
                let stats = sensor.stats();
                {
                    let mut s = lock();
                    if s.ring.len() == RING {
                        s.ring.pop_front();
                    }
                    s.ring.push_back(sample);
                    s.stats = stats;
                }
                // The recorder may have gone; the monitor still serves control loops.
                let _ = tx.send(sample);
            }
            Ok(None) => {
                lock().stats = sensor.stats();
                // A sensor that answers "nothing yet" without waiting would make this
                // (possibly real-time) thread spin and hold a core: wait a little instead.
                if asked.elapsed() < Duration::from_millis(1) {
                    std::thread::sleep(Duration::from_millis(1));
                }
            }
            Err(e) => {
                let mut s = lock();
                s.error = Some(e.to_string());
                s.stats = sensor.stats();
                break;
            }
        }
    }
    lock().ended = true;
    sensor
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::{Newtons, Wrench};

    /// A sensor producing Fz = -index / 1000 N every 200 us, failing after `fail_after` samples.
    struct Counting {
        n: u64,
        fail_after: u64,
        stopped: Arc<AtomicBool>,
    }

    impl ForceSensor for Counting {
        fn describe(&self) -> String {
            "counting".into()
        }
        fn start(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
        fn next_sample(&mut self, _timeout: Duration) -> Result<Option<ForceSample>, ForceError> {
            if self.n >= self.fail_after {
                return Err(ForceError::Device {
                    device: "counting".into(),
                    message: "cable pulled".into(),
                });
            }
            std::thread::sleep(Duration::from_micros(200));
            self.n += 1;
            let wrench = Wrench {
                fz: Newtons(-(self.n as f64) / 1000.0),
                ..Wrench::default()
            };
            Ok(Some(ForceSample {
                device_tick: self.n,
                transport_seq: None,
                host_time: HostTime::now(),
                wrench,
                status: 0,
                strobe: None,
            }))
        }
        fn stop(&mut self) -> Result<(), ForceError> {
            self.stopped.store(true, Ordering::SeqCst);
            Ok(())
        }
        fn bias(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
        fn stats(&self) -> StreamStats {
            StreamStats {
                received: self.n,
                ..StreamStats::default()
            }
        }
    }

    #[test]
    fn every_sample_reaches_the_channel_and_the_monitor_sees_the_newest() {
        let stopped = Arc::new(AtomicBool::new(false));
        let stream = ForceStream::spawn(Box::new(Counting {
            n: 0,
            fail_after: u64::MAX,
            stopped: stopped.clone(),
        }))
        .expect("spawn");
        let monitor = stream.monitor();
        std::thread::sleep(Duration::from_millis(100));
        let latest = monitor.latest().expect("samples arrived");
        let (_, mean) = monitor.mean_of_last(10).expect("mean");
        // The mean of ticks k-9..=k is -(k - 4.5) / 1000 for the newest tick k at that moment.
        let k = -mean[2] * 1000.0 + 4.5;
        assert!(
            (k - k.round()).abs() < 1e-6,
            "{mean:?} is not a mean of 10 consecutive samples"
        );
        assert!(
            k.round() as u64 >= latest.device_tick,
            "{k} < {}",
            latest.device_tick
        );
        assert!(monitor.silence().expect("silence") < Duration::from_millis(50));
        let _sensor = stream.stop().expect("stop");
        assert!(stopped.load(Ordering::SeqCst));
    }

    #[test]
    fn channel_keeps_order_and_an_error_ends_the_stream_visibly() {
        let stream = ForceStream::spawn(Box::new(Counting {
            n: 0,
            fail_after: 50,
            stopped: Arc::new(AtomicBool::new(false)),
        }))
        .expect("spawn");
        let monitor = stream.monitor();
        let ticks: Vec<u64> = stream
            .samples()
            .iter()
            .take(50)
            .map(|s| s.device_tick)
            .collect();
        assert_eq!(ticks, (1..=50).collect::<Vec<_>>());
        let deadline = std::time::Instant::now() + Duration::from_secs(2);
        while !monitor.ended() && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(monitor.ended());
        assert!(monitor
            .error()
            .expect("error kept")
            .contains("cable pulled"));
        assert_eq!(monitor.stats().received, 50);
    }
}
