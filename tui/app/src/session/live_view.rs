//! What a front end shows of a scan as it runs: the newest frame as a small picture and the
//! labels as they are written. The recorder hands frames to a one-frame mailbox at most
//! [`MAX_RATE_HZ`] times a second; a worker thread makes the picture, so neither the recorder nor
//! the front end's drawing ever downscales a frame.

use fringe_rig::store::FrameRecord;
use fringe_rig::Frame;
use fringe_rig::RecordTap;
use fringe_sensor_models::{thumbnail, FrameRef};
use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Pictures made per second at most.
pub(crate) const MAX_RATE_HZ: f64 = 10.0;
/// Labels kept for the force chart.
pub(crate) const LABELS: usize = 500;

/// A label as the chart needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelPoint {
    /// Seconds since the view started.
    pub t_s: f64,
    /// Tared Fz and |F|, N.
    pub fz_n: f64,
    pub f_n: f64,
}

/// The newest picture and labels.
#[derive(Debug, Clone, Default)]
pub struct ViewState {
    pub picture: Option<image::RgbImage>,
    pub frame_id: u64,
    pub labels: VecDeque<LabelPoint>,
}

#[derive(Default)]
struct Mailbox {
    next: Option<Frame>,
    last_taken: Option<Instant>,
    closed: bool,
}

struct Shared {
    mailbox: Mutex<Mailbox>,
    wake: Condvar,
    state: Mutex<ViewState>,
    started: Instant,
    side: u32,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

struct ViewTap(Arc<Shared>);

impl std::fmt::Debug for ViewTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("LiveView")
    }
}

impl RecordTap for ViewTap {
    fn seen(&self, frame: &Frame) {
        let mut m = lock(&self.0.mailbox);
        let due = m
            .last_taken
            .is_none_or(|t| t.elapsed() >= Duration::from_secs_f64(1.0 / MAX_RATE_HZ));
        if m.closed || !due || m.next.is_some() {
            return;
        }
        m.last_taken = Some(Instant::now());
        m.next = Some(frame.clone());
        drop(m);
        self.0.wake.notify_one();
    }

    fn recorded(&self, _frame: &Frame, record: &FrameRecord) {
        let Some(w) = record.wrench else {
            return;
        };
        let [fx, fy, fz, ..] = w.to_array();
        let mut s = lock(&self.0.state);
        if s.labels.len() == LABELS {
            s.labels.pop_front();
        }
        let t_s = self.0.started.elapsed().as_secs_f64();
        s.labels.push_back(LabelPoint {
            t_s,
            fz_n: fz,
            f_n: (fx * fx + fy * fy + fz * fz).sqrt(),
        });
    }
}

/// A live view of a scan.
pub struct LiveView {
    shared: Arc<Shared>,
    worker: Option<JoinHandle<()>>,
}

impl LiveView {
    /// Starts the picture worker (pictures `side` px square); the tap goes into the scan's setup.
    pub fn start(side: u32) -> std::io::Result<(LiveView, Arc<dyn RecordTap>)> {
        let shared = Arc::new(Shared {
            mailbox: Mutex::new(Mailbox::default()),
            wake: Condvar::new(),
            state: Mutex::new(ViewState::default()),
            started: Instant::now(),
            side,
        });
        let worker_shared = shared.clone();
        let worker = std::thread::Builder::new()
            .name("live-view".into())
            .spawn(move || picture_worker(&worker_shared))?;
        let tap = Arc::new(ViewTap(shared.clone())) as Arc<dyn RecordTap>;
        Ok((
            LiveView {
                shared,
                worker: Some(worker),
            },
            tap,
        ))
    }

    /// The state now (a copy).
    pub fn state(&self) -> ViewState {
        lock(&self.shared.state).clone()
    }
}

fn picture_worker(shared: &Shared) {
    loop {
        let frame = {
            let mut m = lock(&shared.mailbox);
            loop {
                if let Some(f) = m.next.take() {
                    break f;
                }
                if m.closed {
                    return;
                }
                m = shared.wake.wait(m).unwrap_or_else(|p| p.into_inner());
            }
        };
        let fref = FrameRef::from(&frame);
        // A frame of the wrong size for its format is skipped; the recorder reports it.
        if let Ok(picture) = thumbnail(fref, shared.side) {
            let mut s = lock(&shared.state);
            s.picture = Some(picture);
            s.frame_id = frame.id;
        }
    }
}

impl Drop for LiveView {
    fn drop(&mut self) {
        lock(&self.shared.mailbox).closed = true;
        self.shared.wake.notify_all();
        if let Some(h) = self.worker.take() {
            let _ = h.join();
        }
    }
}
