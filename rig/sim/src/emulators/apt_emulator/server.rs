//! Runs an [`EmulatorCore`] on a thread over any [`ByteLink`]: an in-process pair for the
//! default simulated rig, or the master side of a pseudo-terminal whose slave path the real
//! driver or third-party software opens.

use super::core::{AptEmulatorConfig, EmulatorCore, EmulatorCounters};
use crate::physics::motion::SimMotor;
use fringe_rig::apt::encode;
use fringe_rig::apt::Packet;
use fringe_rig::apt::{Decoded, Flow, StreamDecoder};
use fringe_rig::ByteLink;
use fringe_rig::HostTime;
use fringe_rig::PtyDevice;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// Why the emulator thread ended before it was stopped.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EmulatorError {
    #[error("APT emulator {model} on {endpoint}: {what}: {detail}")]
    Link {
        model: String,
        endpoint: String,
        what: &'static str,
        detail: String,
    },
    #[error("APT emulator {model} on {endpoint}: the emulator thread panicked")]
    Panicked { model: String, endpoint: String },
}

#[derive(Default)]
struct Shared {
    counters: EmulatorCounters,
    updates_running: bool,
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

/// Starts emulated APT controllers.
pub struct AptEmulator;

impl AptEmulator {
    /// Runs a controller driving `motor` on `link` until the handle is stopped or dropped.
    pub fn spawn(
        config: AptEmulatorConfig,
        motor: Arc<SimMotor>,
        link: Box<dyn ByteLink>,
    ) -> io::Result<AptEmulatorHandle> {
        Self::spawn_inner(config, motor, link, None)
    }

    /// Runs a controller on a new pseudo-terminal; [`AptEmulatorHandle::slave_path`] is the
    /// port to open (`/dev/pts/N`).
    pub fn spawn_pty(
        config: AptEmulatorConfig,
        motor: Arc<SimMotor>,
    ) -> io::Result<AptEmulatorHandle> {
        let pty = PtyDevice::open()?;
        let path = pty.slave_path().to_string();
        Self::spawn_inner(config, motor, Box::new(pty), Some(path))
    }

    fn spawn_inner(
        config: AptEmulatorConfig,
        motor: Arc<SimMotor>,
        link: Box<dyn ByteLink>,
        slave_path: Option<String>,
    ) -> io::Result<AptEmulatorHandle> {
        let stop = Arc::new(AtomicBool::new(false));
        let shared = Arc::new(Mutex::new(Shared::default()));
        let endpoint = link.describe();
        let model = config.model.clone();
        let runner = Runner {
            core: EmulatorCore::new(config, motor),
            link,
            stop: stop.clone(),
            shared: shared.clone(),
        };
        let thread = std::thread::Builder::new()
            .name(format!("apt-emulator-{model}"))
            .spawn(move || runner.run())?;
        Ok(AptEmulatorHandle {
            stop,
            shared,
            thread: Some(thread),
            endpoint,
            model,
            slave_path,
        })
    }
}

struct Runner {
    core: EmulatorCore,
    link: Box<dyn ByteLink>,
    stop: Arc<AtomicBool>,
    shared: Arc<Mutex<Shared>>,
}

impl Runner {
    fn link_error(&self, what: &'static str, e: io::Error) -> EmulatorError {
        EmulatorError::Link {
            model: self.core.config().model.clone(),
            endpoint: self.link.describe(),
            what,
            detail: e.to_string(),
        }
    }

    fn send(&mut self, packets: Vec<Packet>) -> Result<(), EmulatorError> {
        for p in packets {
            let bytes = encode(&p);
            if let Err(e) = self.link.write_all(&bytes) {
                return Err(self.link_error("writing to the host", e));
            }
        }
        Ok(())
    }

    fn publish(&self) {
        let mut s = lock(&self.shared);
        s.counters = self.core.counters();
        s.updates_running = self.core.updates_running();
    }

    fn run(mut self) -> Result<EmulatorCounters, EmulatorError> {
        let mut decoder = StreamDecoder::new(Flow::ToDevice);
        let mut buf = [0u8; 1024];
        let mut dropped = 0;
        let result = loop {
            if self.stop.load(Ordering::Relaxed) {
                break Ok(());
            }
            let wait = self.core.poll_interval(HostTime::now());
            let n = match self.link.read(&mut buf, wait) {
                Ok(n) => n,
                // The host dropped its end of an in-process link: the session is over.
                Err(e) if e.kind() == io::ErrorKind::BrokenPipe => break Ok(()),
                Err(e) => break Err(self.link_error("reading from the host", e)),
            };
            decoder.push(&buf[..n]);
            let mut replies = Vec::new();
            while let Some(item) = decoder.next_item() {
                match item {
                    Decoded::Packet(p) => replies.extend(self.core.handle(&p, HostTime::now())),
                    Decoded::Unknown { dest, .. } => self.core.note_unknown(dest),
                }
            }
            self.core.note_dropped_bytes(decoder.dropped() - dropped);
            dropped = decoder.dropped();
            replies.extend(self.core.tick(HostTime::now()));
            if let Err(e) = self.send(replies) {
                break Err(e);
            }
            self.publish();
        };
        self.publish();
        result.map(|()| self.core.counters())
    }
}

/// A running emulated controller. Dropping it stops the thread.
pub struct AptEmulatorHandle {
    stop: Arc<AtomicBool>,
    shared: Arc<Mutex<Shared>>,
    thread: Option<JoinHandle<Result<EmulatorCounters, EmulatorError>>>,
    endpoint: String,
    model: String,
    slave_path: Option<String>,
}

impl AptEmulatorHandle {
    /// The counters as of the last loop of the emulator thread.
    pub fn counters(&self) -> EmulatorCounters {
        lock(&self.shared).counters
    }

    /// True while the controller sends update messages.
    pub fn updates_running(&self) -> bool {
        lock(&self.shared).updates_running
    }

    /// The device side of the link ("pty /dev/pts/3", "in-process apt-x-device").
    pub fn endpoint(&self) -> &str {
        &self.endpoint
    }

    /// The pseudo-terminal a client opens, for emulators started by
    /// [`AptEmulator::spawn_pty`].
    pub fn slave_path(&self) -> Option<&str> {
        self.slave_path.as_deref()
    }

    /// True while the emulator thread runs (it also ends when the host's end of an in-process
    /// link is dropped, or on a link error).
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Stops the emulator and returns its final counters, or the link error that ended it
    /// earlier (the host closing an in-process link is a normal end, not an error).
    pub fn stop(mut self) -> Result<EmulatorCounters, EmulatorError> {
        self.finish()
    }

    fn finish(&mut self) -> Result<EmulatorCounters, EmulatorError> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take() {
            Some(t) => t.join().unwrap_or_else(|_| {
                Err(EmulatorError::Panicked {
                    model: self.model.clone(),
                    endpoint: self.endpoint.clone(),
                })
            }),
            None => Ok(self.counters()),
        }
    }
}

impl Drop for AptEmulatorHandle {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}
