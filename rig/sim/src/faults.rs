//! Faults injected on purpose into the simulated bench, to see what a user sees and what a run
//! keeps when a device fails: a cable pulled, a controller that stops answering, a force stream
//! that stalls, loses a burst of datagrams or reboots, a camera that stalls or delivers frames
//! out of order.
//!
//! A rig file lists them under `[[sim.faults]]`; [`SimRig`](crate::SimRig) wraps the real
//! drivers' links (or the device behind a driver) so the drivers meet the fault exactly as they
//! would meet it on the bench: the engine and the drivers know nothing of this module.
//!
//! ```toml
//! [[sim.faults]]
//! device = "z"          # x, y, z, force, camera
//! fault = "unplug"      # unplug, silent, stall (camera), reorder (camera), loss (force),
//!                       # reboot (force)
//! after = 20.0          # seconds after the rig opened ...
//! while_moving = true   # ... at the first moment after that when the axis moves
//! while_streaming = true # force over the Net F/T: ... when the box's stream has started
//! duration = 2.0        # silent / stall / reorder / loss: for how long (s); none = for good;
//!                       # reboot: how long the box is down (s), required
//! ```

use crate::emulators::netft_emulator::PowerSwitch;
use crate::physics::motion::SimMotor;
use fringe_rig::HostTime;
use fringe_rig::{ByteLink, DatagramLink};
use fringe_rig::{Camera, CameraError, CameraInfo, CameraSettings, Frame, TimestampLatch};
use fringe_rig::{ForceError, ForceSample, ForceSensor, StreamStats};
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The device a fault hits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultDevice {
    X,
    Y,
    Z,
    Force,
    Camera,
}

impl FaultDevice {
    pub fn name(self) -> &'static str {
        match self {
            FaultDevice::X => "x",
            FaultDevice::Y => "y",
            FaultDevice::Z => "z",
            FaultDevice::Force => "force",
            FaultDevice::Camera => "camera",
        }
    }
}

/// What happens to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultKind {
    /// The cable is pulled: every read and write fails from then on (as a serial port or socket
    /// whose other end went away). An axis keeps executing the move it was given.
    Unplug,
    /// The device stops answering: writes vanish, nothing arrives, for `duration`.
    Silent,
    /// Camera only: no frame is delivered for `duration` (exposures in that time are lost).
    Stall,
    /// Camera only: each pair of frames arrives swapped for `duration`.
    Reorder,
    /// Force over a Net F/T (`force_path = "netft"`) only: every datagram from the box is lost
    /// for `duration` (a burst of UDP loss).
    Loss,
    /// Force over a Net F/T only: the box reboots (a reset or a power glitch) and is down for
    /// `duration`; then its sample counter starts again, its software bias is gone, the
    /// transducer has a new power-up offset, and it streams only when asked again.
    Reboot,
}

/// One fault of a rig file's `[[sim.faults]]`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    pub device: FaultDevice,
    pub fault: FaultKind,
    /// Seconds after the rig opened.
    #[serde(default)]
    pub after: f64,
    /// Wait, after `after`, for the axis to be moving (axes only).
    #[serde(default)]
    pub while_moving: bool,
    /// Wait, after `after`, for the Net F/T's stream to be running: the driver has had a
    /// record since its last start request and has not asked it to stop (force only). A burst
    /// of loss then falls inside a stream however long the rig took to get there.
    #[serde(default)]
    pub while_streaming: bool,
    /// How long a silent device, a stall or reordering lasts (s); none: for good.
    #[serde(default)]
    pub duration: Option<f64>,
}

impl FaultSpec {
    /// Checks the fault makes sense for its device; the message names the fields.
    pub fn check(&self) -> Result<(), String> {
        let name = self.device.name();
        if !(self.after.is_finite() && self.after >= 0.0) {
            return Err(format!(
                "fault on {name}: after = {} must be >= 0 (s)",
                self.after
            ));
        }
        if let Some(d) = self.duration {
            if !(d.is_finite() && d > 0.0) {
                return Err(format!("fault on {name}: duration = {d} must be > 0 (s)"));
            }
        }
        let axis = matches!(
            self.device,
            FaultDevice::X | FaultDevice::Y | FaultDevice::Z
        );
        if self.while_moving && !axis {
            return Err(format!(
                "fault on {name}: while_moving is for the axes x, y and z"
            ));
        }
        if self.while_streaming && self.device != FaultDevice::Force {
            return Err(format!(
                "fault on {name}: while_streaming is for the force sensor's Net F/T stream (device = \"force\")"
            ));
        }
        let camera_only = matches!(self.fault, FaultKind::Stall | FaultKind::Reorder);
        if camera_only && self.device != FaultDevice::Camera {
            return Err(format!(
                "fault on {name}: {:?} is a camera fault (use unplug or silent)",
                self.fault
            ));
        }
        if self.fault == FaultKind::Loss && self.device != FaultDevice::Force {
            return Err(format!(
                "fault on {name}: loss is a fault of the Net F/T's UDP stream (device = \"force\")"
            ));
        }
        if self.fault == FaultKind::Reboot {
            if self.device != FaultDevice::Force {
                return Err(format!(
                    "fault on {name}: reboot is a fault of the Net F/T box (device = \"force\")"
                ));
            }
            if self.duration.is_none() {
                return Err(format!(
                    "fault on {name}: reboot needs a duration: how long the box is down (s)"
                ));
            }
        }
        Ok(())
    }
}

/// When one fault is on: fired once its time (and motion) condition first holds, then on for
/// its duration.
pub struct FaultTrigger {
    spec: FaultSpec,
    opened: Instant,
    motor: Option<Arc<SimMotor>>,
    fired: Mutex<Option<Instant>>,
    /// Whether [`FaultTrigger::newly_active`] has reported it.
    reported: AtomicBool,
}

impl FaultTrigger {
    /// A trigger counting from now; `motor` is the axis `while_moving` watches.
    pub fn new(spec: FaultSpec, motor: Option<Arc<SimMotor>>) -> Arc<FaultTrigger> {
        Arc::new(FaultTrigger {
            spec,
            opened: Instant::now(),
            motor,
            fired: Mutex::new(None),
            reported: AtomicBool::new(false),
        })
    }

    pub fn spec(&self) -> &FaultSpec {
        &self.spec
    }

    /// True once: the first time the fault is found on (for faults that are an event, such as a
    /// reboot, rather than a state).
    pub fn newly_active(&self, streaming: bool) -> bool {
        self.active_if_streaming(streaming) && !self.reported.swap(true, Ordering::SeqCst)
    }

    /// Whether the fault is on now.
    pub fn active(&self) -> bool {
        self.active_if_streaming(true)
    }

    /// Whether the fault is on now, `streaming` telling whether the force stream runs (for
    /// [`FaultSpec::while_streaming`]).
    pub fn active_if_streaming(&self, streaming: bool) -> bool {
        let now = Instant::now();
        let mut fired = self.fired.lock().unwrap_or_else(|e| e.into_inner());
        let at = match *fired {
            Some(at) => at,
            None => {
                if now.duration_since(self.opened).as_secs_f64() < self.spec.after {
                    return false;
                }
                let moving = match (&self.motor, self.spec.while_moving) {
                    (Some(m), true) => m.status_at(HostTime::now()).moving,
                    _ => true,
                };
                if !moving || (self.spec.while_streaming && !streaming) {
                    return false;
                }
                *fired = Some(now);
                now
            }
        };
        match (self.spec.fault, self.spec.duration) {
            (FaultKind::Unplug, _) | (_, None) => true,
            (_, Some(d)) => now.duration_since(at).as_secs_f64() < d,
        }
    }
}

/// The faults on one device.
#[derive(Default)]
pub struct Faults(Vec<Arc<FaultTrigger>>);

impl Faults {
    pub fn new(triggers: Vec<Arc<FaultTrigger>>) -> Faults {
        Faults(triggers)
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Whether a fault of `kind` is on now.
    pub fn on(&self, kind: FaultKind) -> bool {
        self.on_if_streaming(kind, true)
    }

    /// Whether a fault of `kind` is on now, `streaming` telling whether the force stream runs.
    pub fn on_if_streaming(&self, kind: FaultKind, streaming: bool) -> bool {
        self.0
            .iter()
            .any(|f| f.spec.fault == kind && f.active_if_streaming(streaming))
    }

    /// A fault of `kind` that has just come on (each reported once).
    pub fn newly_on(&self, kind: FaultKind, streaming: bool) -> Option<&FaultSpec> {
        self.0
            .iter()
            .find(|f| f.spec.fault == kind && f.newly_active(streaming))
            .map(|f| &f.spec)
    }
}

fn unplugged(what: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::BrokenPipe,
        format!("{what}: the device is gone (cable unplugged or power lost)"),
    )
}

/// A byte link (serial port, in-process pipe) with a fault between driver and device.
pub(crate) struct FaultyLink<L: ByteLink> {
    inner: L,
    faults: Faults,
}

impl<L: ByteLink> FaultyLink<L> {
    pub(crate) fn new(inner: L, faults: Faults) -> FaultyLink<L> {
        FaultyLink { inner, faults }
    }
}

impl<L: ByteLink> ByteLink for FaultyLink<L> {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(unplugged(&self.inner.describe()));
        }
        if self.faults.on(FaultKind::Silent) {
            return Ok(());
        }
        self.inner.write_all(bytes)
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(unplugged(&self.inner.describe()));
        }
        if self.faults.on(FaultKind::Silent) {
            // Whatever the device sent before it went quiet is lost with it.
            let _ = self.inner.read(buf, Duration::ZERO);
            std::thread::sleep(timeout);
            return Ok(0);
        }
        self.inner.read(buf, timeout)
    }

    fn purge(&mut self) -> io::Result<()> {
        self.inner.purge()
    }

    fn describe(&self) -> String {
        self.inner.describe()
    }
}

/// A datagram link (the Net F/T's UDP socket) that can be cut, go quiet or lose bursts, with
/// the switch that reboots the box at its other end.
pub struct FaultyDatagrams<L: DatagramLink> {
    inner: L,
    faults: Faults,
    power: Option<PowerSwitch>,
    /// The driver has had a record since its last request, which was not a stop.
    streaming: bool,
}

impl<L: DatagramLink> FaultyDatagrams<L> {
    pub fn new(inner: L, faults: Faults) -> FaultyDatagrams<L> {
        FaultyDatagrams {
            inner,
            faults,
            power: None,
            streaming: false,
        }
    }

    /// Reboot faults act through `power`, the box's switch.
    pub fn with_power_switch(mut self, power: PowerSwitch) -> FaultyDatagrams<L> {
        self.power = Some(power);
        self
    }

    /// Reboots the box when a reboot fault comes on (checked whenever the driver uses the link).
    fn reboot_if_due(&self) {
        let due = self.faults.newly_on(FaultKind::Reboot, self.streaming);
        if let (Some(power), Some(spec)) = (&self.power, due) {
            let down = spec.duration.unwrap_or_default().max(0.0);
            power.reboot(Duration::try_from_secs_f64(down).unwrap_or(Duration::MAX));
        }
    }
}

impl<L: DatagramLink> DatagramLink for FaultyDatagrams<L> {
    fn send(&mut self, datagram: &[u8]) -> io::Result<()> {
        self.reboot_if_due();
        if self
            .faults
            .on_if_streaming(FaultKind::Unplug, self.streaming)
        {
            return Err(unplugged(&self.inner.describe()));
        }
        // A stop request ends the stream; a start request begins one once a record arrives.
        self.streaming = false;
        if self
            .faults
            .on_if_streaming(FaultKind::Silent, self.streaming)
        {
            return Ok(());
        }
        self.inner.send(datagram)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        self.reboot_if_due();
        if self
            .faults
            .on_if_streaming(FaultKind::Unplug, self.streaming)
        {
            return Err(unplugged(&self.inner.describe()));
        }
        let got = self.inner.recv(buf, timeout)?;
        let lost = self.faults.on_if_streaming(FaultKind::Loss, self.streaming)
            || self
                .faults
                .on_if_streaming(FaultKind::Silent, self.streaming);
        if got.is_some() && lost {
            // Lost on the way: the caller sees a timeout.
            return Ok(None);
        }
        if got.is_some() {
            self.streaming = true;
        }
        Ok(got)
    }

    fn describe(&self) -> String {
        self.inner.describe()
    }
}

/// A force sensor whose stream can be cut (unplug) or go quiet (silent).
pub(crate) struct FaultyForce {
    inner: Box<dyn ForceSensor>,
    faults: Faults,
}

impl FaultyForce {
    pub(crate) fn new(inner: Box<dyn ForceSensor>, faults: Faults) -> FaultyForce {
        FaultyForce { inner, faults }
    }

    fn gone(&self) -> ForceError {
        ForceError::Io {
            device: self.inner.describe(),
            source: unplugged("force sensor link"),
        }
    }
}

impl ForceSensor for FaultyForce {
    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn start(&mut self) -> Result<(), ForceError> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(self.gone());
        }
        self.inner.start()
    }

    fn next_sample(&mut self, timeout: Duration) -> Result<Option<ForceSample>, ForceError> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(self.gone());
        }
        if self.faults.on(FaultKind::Silent) {
            // Samples made while the stream is quiet never arrive.
            while let Ok(Some(_)) = self.inner.next_sample(Duration::ZERO) {}
            std::thread::sleep(timeout);
            return Ok(None);
        }
        self.inner.next_sample(timeout)
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        self.inner.stop()
    }

    fn bias(&mut self) -> Result<(), ForceError> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(self.gone());
        }
        self.inner.bias()
    }

    fn stats(&self) -> StreamStats {
        self.inner.stats()
    }
}

/// A camera that can be unplugged, stall, or deliver frames out of order.
pub(crate) struct FaultyCamera {
    inner: Box<dyn Camera>,
    faults: Faults,
    /// Reordering: the frame waiting for the next one to overtake it.
    held: Option<Frame>,
    /// Reordering: the overtaken frame, delivered at the next call.
    release: Option<Frame>,
}

impl FaultyCamera {
    pub(crate) fn new(inner: Box<dyn Camera>, faults: Faults) -> FaultyCamera {
        FaultyCamera {
            inner,
            faults,
            held: None,
            release: None,
        }
    }

    fn gone(&self) -> CameraError {
        CameraError::Io {
            camera: self.inner.info().model,
            source: unplugged("camera link"),
        }
    }
}

impl Camera for FaultyCamera {
    fn info(&self) -> CameraInfo {
        self.inner.info()
    }

    fn configure(&mut self, settings: &CameraSettings) -> Result<(), CameraError> {
        self.inner.configure(settings)
    }

    fn start(&mut self) -> Result<(), CameraError> {
        self.inner.start()
    }

    fn trigger(&mut self) -> Result<(), CameraError> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(self.gone());
        }
        self.inner.trigger()
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(self.gone());
        }
        if self.faults.on(FaultKind::Stall) || self.faults.on(FaultKind::Silent) {
            self.held = None;
            self.release = None;
            while let Ok(Some(_)) = self.inner.next_frame(Duration::ZERO) {}
            std::thread::sleep(timeout);
            return Ok(None);
        }
        if let Some(older) = self.release.take() {
            return Ok(Some(older));
        }
        if self.faults.on(FaultKind::Reorder) {
            let Some(frame) = self.inner.next_frame(timeout)? else {
                return Ok(None);
            };
            match self.held.take() {
                // The newer frame now, the older one at the next call.
                Some(older) => {
                    self.release = Some(older);
                    return Ok(Some(frame));
                }
                None => {
                    self.held = Some(frame);
                    return Ok(None);
                }
            }
        }
        if let Some(older) = self.held.take() {
            return Ok(Some(older));
        }
        self.inner.next_frame(timeout)
    }

    fn stop(&mut self) -> Result<(), CameraError> {
        self.inner.stop()
    }

    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError> {
        if self.faults.on(FaultKind::Unplug) {
            return Err(self.gone());
        }
        self.inner.latch_timestamp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(device: FaultDevice, fault: FaultKind, duration: Option<f64>) -> FaultSpec {
        FaultSpec {
            device,
            fault,
            after: 1.0,
            while_moving: false,
            while_streaming: false,
            duration,
        }
    }

    #[test]
    fn a_fault_that_does_not_fit_its_device_is_refused_naming_the_field() {
        let cases = [
            (
                spec(FaultDevice::Force, FaultKind::Reboot, None),
                "reboot needs a duration",
            ),
            (
                spec(FaultDevice::Z, FaultKind::Reboot, Some(1.0)),
                "reboot is a fault of the Net F/T box",
            ),
            (
                spec(FaultDevice::Camera, FaultKind::Loss, Some(1.0)),
                "loss is a fault of the Net F/T's UDP stream",
            ),
            (
                spec(FaultDevice::X, FaultKind::Stall, Some(1.0)),
                "is a camera fault",
            ),
            (
                spec(FaultDevice::Force, FaultKind::Silent, Some(-1.0)),
                "duration = -1 must be > 0",
            ),
        ];
        for (spec, words) in cases {
            let e = spec.check().expect_err("refused");
            assert!(e.contains(words), "{e}");
        }
        assert_eq!(
            spec(FaultDevice::Force, FaultKind::Reboot, Some(2.0)).check(),
            Ok(())
        );
    }

    #[test]
    fn a_reboot_is_reported_once_when_it_comes_on() {
        let trigger = FaultTrigger::new(
            FaultSpec {
                after: 0.0,
                ..spec(FaultDevice::Force, FaultKind::Reboot, Some(5.0))
            },
            None,
        );
        let faults = Faults::new(vec![trigger]);
        assert!(faults.newly_on(FaultKind::Reboot, true).is_some());
        assert!(faults.newly_on(FaultKind::Reboot, true).is_none());
        assert!(faults.on(FaultKind::Reboot), "still on for its duration");
    }
}
