//! A camera read on its own thread: frames go to a channel as they arrive.

use crate::camera::{Camera, CameraError, CameraSettings, Frame};
use crossbeam_channel::{unbounded, Receiver};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// A running camera stream.
pub struct CameraStream {
    frames: Receiver<Frame>,
    stop: Arc<AtomicBool>,
    error: Arc<Mutex<Option<String>>>,
    thread: Option<JoinHandle<Box<dyn Camera>>>,
}

impl CameraStream {
    /// Configures and starts `camera` and reads it on a new thread.
    pub fn spawn(
        mut camera: Box<dyn Camera>,
        settings: &CameraSettings,
    ) -> Result<CameraStream, CameraError> {
        camera.configure(settings)?;
        camera.start()?;
        let (tx, rx) = unbounded();
        let stop = Arc::new(AtomicBool::new(false));
        let error = Arc::new(Mutex::new(None));
        let name = camera.info().id;
        let thread = {
            let (stop, error) = (stop.clone(), error.clone());
            std::thread::Builder::new()
                .name("camera-stream".into())
                .spawn(move || {
                    while !stop.load(Ordering::SeqCst) {
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
            stop,
            error,
            thread: Some(thread),
        })
    }

    /// Frames in arrival order.
    pub fn frames(&self) -> &Receiver<Frame> {
        &self.frames
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
