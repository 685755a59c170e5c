//! A camera read on its own thread: frames go to a channel as they arrive.
//!
//! Optionally the same thread latches the camera's clock every `latch_period` between two frame
//! reads ([`CameraStream::spawn_with_latches`]): the camera is only ever touched from this one
//! thread (Aravis objects are not thread-safe), a latch delays the next frame read by its round
//! trip only (frames wait in the camera's buffers meanwhile), and every exchange goes to each
//! subscriber ([`CameraStream::subscribe_latches`]: the labelers that place frames by clock). A camera that cannot latch (the first error) stops
//! being asked; the error is kept for the run's notes, the frame stream goes on.

use crate::camera::{Camera, CameraError, CameraSettings, Frame, TimestampLatch};
use crossbeam_channel::{unbounded, Receiver, Sender};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A running camera stream.
pub struct CameraStream {
    frames: Receiver<Frame>,
    latch_subscribers: Arc<Mutex<Vec<Sender<TimestampLatch>>>>,
    stop: Arc<AtomicBool>,
    error: Arc<Mutex<Option<String>>>,
    latch_error: Arc<Mutex<Option<String>>>,
    thread: Option<JoinHandle<Box<dyn Camera>>>,
}

impl CameraStream {
    /// Configures and starts `camera` and reads it on a new thread.
    pub fn spawn(
        camera: Box<dyn Camera>,
        settings: &CameraSettings,
    ) -> Result<CameraStream, CameraError> {
        CameraStream::start(camera, settings, None)
    }

    /// As [`CameraStream::spawn`], and latches the camera clock every `latch_period` on the
    /// stream thread, between frame reads (see the module documentation).
    pub fn spawn_with_latches(
        camera: Box<dyn Camera>,
        settings: &CameraSettings,
        latch_period: Duration,
    ) -> Result<CameraStream, CameraError> {
        CameraStream::start(camera, settings, Some(latch_period))
    }

    fn start(
        mut camera: Box<dyn Camera>,
        settings: &CameraSettings,
        latch_period: Option<Duration>,
    ) -> Result<CameraStream, CameraError> {
        camera.configure(settings)?;
        camera.start()?;
        let (tx, rx) = unbounded();
        let latch_subscribers: Arc<Mutex<Vec<Sender<TimestampLatch>>>> = Arc::default();
        let stop = Arc::new(AtomicBool::new(false));
        let error = Arc::new(Mutex::new(None));
        let latch_error = Arc::new(Mutex::new(None));
        let name = camera.info().id;
        let thread = {
            let (stop, error, latch_error) = (stop.clone(), error.clone(), latch_error.clone());
            let subscribers = latch_subscribers.clone();
            std::thread::Builder::new()
                .name("camera-stream".into())
                .spawn(move || {
                    let mut latching = latch_period;
                    let mut next_latch = Instant::now();
                    while !stop.load(Ordering::SeqCst) {
                        if let Some(period) = latching {
                            if Instant::now() >= next_latch {
                                next_latch += period;
                                match camera.latch_timestamp() {
                                    // A closed receiver only means that subscriber left.
                                    Ok(l) => subscribers
                                        .lock()
                                        .unwrap_or_else(|p| p.into_inner())
                                        .retain(|s| s.send(l).is_ok()),
                                    Err(e) => {
                                        *latch_error.lock().unwrap_or_else(|p| p.into_inner()) =
                                            Some(e.to_string());
                                        latching = None;
                                    }
                                }
                            }
                        }
                        match camera.next_frame(Duration::from_millis(50)) {
                            Ok(Some(frame)) => {
                                if tx.send(frame).is_err() {
                                    break;
                                }
                            }
                            Ok(None) => {}
                            Err(e) => {
                                *error.lock().unwrap_or_else(|p| p.into_inner()) =
                                    Some(e.to_string());
                                break;
                            }
                        }
                    }
                    camera
                })
                .map_err(|source| CameraError::Io {
                    camera: name,
                    source,
                })?
        };
        Ok(CameraStream {
            frames: rx,
            latch_subscribers,
            stop,
            error,
            latch_error,
            thread: Some(thread),
        })
    }

    /// Frames in arrival order.
    pub fn frames(&self) -> &Receiver<Frame> {
        &self.frames
    }

    /// A new receiver of every timestamp-latch exchange taken from now on, in the order taken
    /// (none unless started with latches).
    pub fn subscribe_latches(&self) -> Receiver<TimestampLatch> {
        let (tx, rx) = unbounded();
        self.latch_subscribers
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(tx);
        rx
    }

    /// Why the camera stopped being latched, if it failed to latch.
    pub fn latch_error(&self) -> Option<String> {
        self.latch_error
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// The error that ended the stream, if any.
    pub fn error(&self) -> Option<String> {
        self.error.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Stops reading and the camera.
    pub fn stop(mut self) -> Result<(), CameraError> {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            if let Ok(mut camera) = t.join() {
                camera.stop()?;
            }
        }
        Ok(())
    }
}

impl Drop for CameraStream {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            if let Ok(mut camera) = t.join() {
                let _ = camera.stop();
            }
        }
    }
}
