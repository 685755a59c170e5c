//! [`ThorlabsAxis`]: a Thorlabs stepper axis (KST101, KST201, BSC20x) over any [`ByteLink`].
//!
//! One I/O thread per axis owns the link (`io_thread.rs`): it reads continuously, decodes frames,
//! keeps the latest status, forwards replies and end-of-move messages to the axis, and (K-Cubes)
//! sends the MOT_ACK_USTATUSUPDATE keep-alive. The [`Axis`] methods send commands to it over a
//! channel; [`Axis::wait_idle`] waits for the end of the motion (`end_of_move.rs`). BSC20x
//! controllers get no update messages; the axis polls MOT_REQ_STATUSUPDATE instead.

use super::codec::encode;
use super::config::{AptConfig, HomeLimitSwitch};
use super::ids::id;
use super::io_thread::{is_end_of_move, lock, Command, IoThread, Observed, Shared};
use super::message::{HomeParams, HwInfo, Message, Packet, StatusBlock, StopMode as AptStop};
use super::pending::{Pending, IDLE_STOP};
use super::status::StatusBits;
use crate::axis::{Axis, AxisError, AxisStatus, Kinematics, StopMode};
use crate::transport::serial::{Parity, SerialLink, SerialSettings};
use crate::transport::ByteLink;
use crate::units::Millimetres;
use crossbeam_channel::{bounded, unbounded, Receiver, RecvTimeoutError, Sender};
use std::collections::VecDeque;
use std::io;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How near its home position (0 after homing) a homed axis still rests on its home switch, mm:
/// there the switch's bit is where the axis belongs, not a fault.
const HOME_SWITCH_MM: f64 = 0.05;

/// Opens a Thorlabs controller's serial port: 115200 8N1 with RTS/CTS, then the open sequence
/// (wait 50 ms, purge both buffers, wait 50 ms, pulse RTS).
pub fn open_serial(path: &str) -> io::Result<SerialLink> {
    let settings = SerialSettings {
        baud: 115_200,
        parity: Parity::None,
        stop_bits: 1,
        rts_cts: true,
    };
    let mut link = SerialLink::open(path, &settings)?;
    std::thread::sleep(Duration::from_millis(50));
    link.purge()?;
    std::thread::sleep(Duration::from_millis(50));
    // Pseudo-terminals and some adapters refuse modem-line control; the controller works
    // without the pulse, so a refusal is not an error.
    if link.set_rts(false).is_ok() {
        std::thread::sleep(Duration::from_millis(5));
        let _ = link.set_rts(true);
    }
    Ok(link)
}

/// A Thorlabs stepper axis.
pub struct ThorlabsAxis {
    pub(super) config: AptConfig,
    pub(super) address: u8,
    pub(super) endpoint: String,
    pub(super) info: Option<HwInfo>,
    pub(super) commands: Option<Sender<Command>>,
    pub(super) events: Receiver<Packet>,
    pub(super) backlog: VecDeque<Packet>,
    pub(super) shared: Arc<Mutex<Shared>>,
    pub(super) thread: Option<JoinHandle<()>>,
    pub(super) pending: Option<Pending>,
    /// Stops sent whose MOT_MOVE_STOPPED has not arrived yet: a late acknowledgement of an
    /// earlier stop must not be taken for the end of a new move.
    pub(super) unacked_stops: u32,
    /// Status messages seen when the current motion was sent.
    pub(super) updates_at_start: u64,
    /// When the current motion was sent: a K-Cube's silence is measured from here or from its
    /// last status, whichever is later (its first status may come a whole period after
    /// HW_START_UPDATEMSGS, and then one every 100 ms).
    pub(super) motion_sent: Instant,
    /// The velocity parameters the controller holds when they are not the configured ones (a
    /// move at a chosen speed set them): the next move at the configured kinematics sets those
    /// back first.
    pub(super) kinematics_set: Option<Kinematics>,
}

impl ThorlabsAxis {
    /// Connects over `link`: HW_NO_FLASH_PROGRAMMING, HW_STOP_UPDATEMSGS, HW_REQ_INFO, channel
    /// enable (read back), actuator type, velocity and home parameters (each read back; a
    /// mismatch refuses the connection), then update messages with keep-alive (K-Cubes).
    pub fn connect(link: Box<dyn ByteLink>, config: AptConfig) -> Result<ThorlabsAxis, AxisError> {
        let endpoint = link.describe();
        let address = config
            .controller
            .address(config.bay)
            .ok_or_else(|| AxisError::Device {
                axis: config.axis.clone(),
                endpoint: endpoint.clone(),
                message: format!("bay {:?} is not a rack bay (use 0..=9)", config.bay),
            })?;
        let (cmd_tx, cmd_rx) = unbounded();
        let (ev_tx, ev_rx) = unbounded();
        let shared = Arc::new(Mutex::new(Shared::default()));
        let io = IoThread {
            link,
            address,
            channel: config.channel as u16,
            commands: cmd_rx,
            events: ev_tx,
            shared: shared.clone(),
            timeouts: config.timeouts,
            status_requests: 0,
        };
        let thread = std::thread::Builder::new()
            .name(format!("apt-{}", config.axis))
            .spawn(move || io.run())
            .map_err(|e| AxisError::Io {
                axis: config.axis.clone(),
                endpoint: endpoint.clone(),
                source: e,
            })?;
        let mut axis = ThorlabsAxis {
            config,
            address,
            endpoint,
            info: None,
            commands: Some(cmd_tx),
            events: ev_rx,
            backlog: VecDeque::new(),
            shared,
            thread: Some(thread),
            pending: None,
            unacked_stops: 0,
            updates_at_start: 0,
            motion_sent: Instant::now(),
            kinematics_set: None,
        };
        axis.initialise()?;
        Ok(axis)
    }

    /// What the controller reported for HW_REQ_INFO.
    pub fn info(&self) -> Option<&HwInfo> {
        self.info.as_ref()
    }

    /// Flashes the controller's front-panel LED (MOD_IDENTIFY), to find it on the bench.
    pub fn identify(&mut self) -> Result<(), AxisError> {
        self.send(Message::ModIdentify {
            channel: self.config.channel,
        })
    }

    /// The configuration this axis runs with.
    pub fn config(&self) -> &AptConfig {
        &self.config
    }

    fn initialise(&mut self) -> Result<(), AxisError> {
        let ch = self.config.channel;
        self.send(Message::HwNoFlashProgramming)?;
        self.send(Message::HwStopUpdateMsgs)?;
        let reply = self.request(
            Message::HwReqInfo,
            id::HW_GET_INFO,
            "HW_GET_INFO (identify)",
        )?;
        if let Message::HwGetInfo(info) = reply.message {
            self.info = Some(info);
        }
        self.send(Message::SetChanEnableState {
            channel: ch,
            enable: true,
        })?;
        let reply = self.request(
            Message::ReqChanEnableState { channel: ch },
            id::MOD_GET_CHANENABLESTATE,
            "MOD_GET_CHANENABLESTATE",
        )?;
        if let Message::GetChanEnableState { enabled: false, .. } = reply.message {
            return Err(self.mismatch(format!(
                "channel {ch} enable state: expected enabled, read back disabled"
            )));
        }
        if let Some(code) = self.config.actuator.type_code {
            self.send(Message::SetTstActuatorType { actuator: code })?;
        }
        self.set_velocity_params()?;
        self.set_home_params()?;
        if self.config.controller.uses_update_messages() {
            self.send(Message::HwStartUpdateMsgs)?;
            self.command(Command::KeepAlive(true))?;
        }
        Ok(())
    }

    fn set_velocity_params(&mut self) -> Result<(), AxisError> {
        self.write_velocity_params(Kinematics {
            velocity: self.config.velocity,
            acceleration: self.config.acceleration,
        })
    }

    /// Sets the controller's velocity parameters to `k` (MOT_SET_VELPARAMS) and reads them back
    /// (MOT_REQ_VELPARAMS): a difference is a configuration mismatch.
    fn write_velocity_params(&mut self, k: Kinematics) -> Result<(), AxisError> {
        let a = self.config.actuator;
        let wanted = super::message::VelParams {
            channel: self.config.channel as u16,
            min_velocity: 0,
            acceleration: a
                .acceleration_to_device(k.acceleration)
                .map_err(|e| self.device(e.to_string()))?,
            max_velocity: a
                .velocity_to_device(k.velocity)
                .map_err(|e| self.device(e.to_string()))?,
        };
        self.send(Message::SetVelParams(wanted))?;
        let reply = self.request(
            Message::ReqVelParams {
                channel: self.config.channel,
            },
            id::MOT_GET_VELPARAMS,
            "MOT_GET_VELPARAMS",
        )?;
        let Message::GetVelParams(got) = reply.message else {
            return Err(self.device("MOT_GET_VELPARAMS reply was not velocity parameters".into()));
        };
        let mut diffs = Vec::new();
        if got.min_velocity != wanted.min_velocity {
            diffs.push(format!(
                "min velocity: expected {}, read back {}",
                wanted.min_velocity, got.min_velocity
            ));
        }
        if got.acceleration != wanted.acceleration {
            diffs.push(format!(
                "acceleration: expected {} ({:.4}), read back {} ({:.4})",
                wanted.acceleration,
                k.acceleration,
                got.acceleration,
                a.acceleration_from_device(got.acceleration)
            ));
        }
        if got.max_velocity != wanted.max_velocity {
            diffs.push(format!(
                "max velocity: expected {} ({:.4}), read back {} ({:.4})",
                wanted.max_velocity,
                k.velocity,
                got.max_velocity,
                a.velocity_from_device(got.max_velocity)
            ));
        }
        if diffs.is_empty() {
            Ok(())
        } else {
            Err(self.mismatch(format!("velocity parameters: {}", diffs.join("; "))))
        }
    }

    fn set_home_params(&mut self) -> Result<(), AxisError> {
        let a = self.config.actuator;
        let h = self.config.home;
        let wanted = HomeParams {
            channel: self.config.channel as u16,
            direction: h.direction as u16,
            limit_switch: h.limit_switch as u16,
            velocity: a
                .velocity_to_device(h.velocity)
                .map_err(|e| self.device(e.to_string()))?,
            offset: a
                .to_steps(h.offset)
                .map_err(|e| self.device(e.to_string()))?,
        };
        self.send(Message::SetHomeParams(wanted))?;
        let reply = self.request(
            Message::ReqHomeParams {
                channel: self.config.channel,
            },
            id::MOT_GET_HOMEPARAMS,
            "MOT_GET_HOMEPARAMS",
        )?;
        let Message::GetHomeParams(got) = reply.message else {
            return Err(self.device("MOT_GET_HOMEPARAMS reply was not home parameters".into()));
        };
        let mut diffs = Vec::new();
        let mut cmp = |name: &str, w: i64, g: i64| {
            if w != g {
                diffs.push(format!("{name}: expected {w}, read back {g}"));
            }
        };
        cmp(
            "home direction",
            wanted.direction.into(),
            got.direction.into(),
        );
        cmp(
            "home limit switch",
            wanted.limit_switch.into(),
            got.limit_switch.into(),
        );
        cmp("home velocity", wanted.velocity.into(), got.velocity.into());
        cmp("home offset", wanted.offset.into(), got.offset.into());
        if diffs.is_empty() {
            Ok(())
        } else {
            Err(self.mismatch(format!("home parameters: {}", diffs.join("; "))))
        }
    }

    fn device(&self, message: String) -> AxisError {
        AxisError::Device {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            message,
        }
    }

    fn mismatch(&self, message: String) -> AxisError {
        AxisError::Mismatch {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            message: format!(
                "{message}; refusing to continue (check the controller and the configuration)"
            ),
        }
    }

    fn link_error(&self, what: &str) -> AxisError {
        let detail = lock(&self.shared)
            .link_error
            .clone()
            .unwrap_or_else(|| "the I/O thread ended".into());
        AxisError::Io {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            source: io::Error::new(io::ErrorKind::BrokenPipe, format!("{what}: {detail}")),
        }
    }

    fn command(&self, c: Command) -> Result<(), AxisError> {
        match &self.commands {
            Some(tx) if tx.send(c).is_ok() => Ok(()),
            _ => Err(self.link_error("sending a command")),
        }
    }

    /// Sends one message to this axis's controller.
    fn send(&mut self, message: Message) -> Result<(), AxisError> {
        let name = message.name();
        let bytes = encode(&Packet::to_device(self.address, message));
        let (tx, rx) = bounded(1);
        self.command(Command::Write(bytes, tx))?;
        match rx.recv_timeout(self.config.timeouts.reply) {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(AxisError::Io {
                axis: self.config.axis.clone(),
                endpoint: self.endpoint.clone(),
                source: io::Error::new(e.kind(), format!("sending {name}: {e}")),
            }),
            Err(_) => Err(self.link_error(&format!("sending {name}"))),
        }
    }

    /// Sends `message` and waits for a reply with id `reply_id`.
    fn request(
        &mut self,
        message: Message,
        reply_id: u16,
        what: &str,
    ) -> Result<Packet, AxisError> {
        self.send(message)?;
        let deadline = Instant::now() + self.config.timeouts.reply;
        match self.next_event(deadline, |p| p.message.id() == reply_id)? {
            Some(p) => Ok(p),
            None => Err(AxisError::NotAnswering {
                axis: self.config.axis.clone(),
                endpoint: self.endpoint.clone(),
                what: format!(
                    "no {what} within {:?} (is the controller powered and the port right?)",
                    self.config.timeouts.reply
                ),
                waited: self.config.timeouts.reply,
            }),
        }
    }

    /// The first event matching `want` before `deadline`; others are kept for later. A
    /// controller error report (HW_RESPONSE / HW_RICHRESPONSE) ends the wait with an error.
    pub(super) fn next_event(
        &mut self,
        deadline: Instant,
        want: impl Fn(&Packet) -> bool,
    ) -> Result<Option<Packet>, AxisError> {
        if let Some(i) = self.backlog.iter().position(&want) {
            return Ok(self.backlog.remove(i));
        }
        loop {
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            match self.events.recv_timeout(deadline - now) {
                Ok(p) if want(&p) => return Ok(Some(p)),
                Ok(p) => {
                    match &p.message {
                        Message::HwRichResponse { message_id, code, notes } => {
                            return Err(self.device(format!(
                                "controller reported error {code} about message 0x{message_id:04x}: {notes}"
                            )))
                        }
                        Message::HwResponse { param1, param2 } => {
                            return Err(self.device(format!(
                                "controller reported an error (HW_RESPONSE {param1:#04x} {param2:#04x})"
                            )))
                        }
                        _ => {}
                    }
                    if self.backlog.len() >= 64 {
                        self.backlog.pop_front();
                    }
                    self.backlog.push_back(p);
                }
                Err(RecvTimeoutError::Timeout) => return Ok(None),
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(self.link_error("waiting for the controller"))
                }
            }
        }
    }

    fn latest(&self) -> Option<Observed> {
        lock(&self.shared).latest
    }

    /// The latest status if it is younger than the reply timeout.
    fn fresh_status(&self) -> Option<Observed> {
        let shared = lock(&self.shared);
        let fresh = shared
            .latest_at
            .is_some_and(|at| at.elapsed() <= self.config.timeouts.reply);
        shared.latest.filter(|_| fresh)
    }

    /// Whether a K-Cube has sent no status for longer than the reply timeout, counted from its
    /// last status or from the start of the current motion, whichever came later.
    pub(super) fn silent_since_motion(&self) -> bool {
        let heard = lock(&self.shared).latest_at;
        let since = heard.map_or(self.motion_sent, |at| at.max(self.motion_sent));
        since.elapsed() > self.config.timeouts.reply
    }

    /// The first status a K-Cube sent after the last end-of-move message (MOT_MOVE_HOMED carries
    /// none, and the update before it may be from during the motion), waiting at most the reply
    /// timeout for it.
    pub(super) fn next_status(&self, what: &str) -> Result<Observed, AxisError> {
        let seen = lock(&self.shared).updates_at_end;
        let deadline = Instant::now() + self.config.timeouts.reply;
        loop {
            {
                let shared = lock(&self.shared);
                if shared.updates > seen {
                    if let Some(o) = shared.latest {
                        return Ok(o);
                    }
                }
                if shared.link_error.is_some() {
                    drop(shared);
                    return Err(self.link_error("waiting for status"));
                }
            }
            if Instant::now() >= deadline {
                return Err(self.silent(what));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// The error for a controller that sent nothing of `what` it should have.
    pub(super) fn silent(&self, what: &str) -> AxisError {
        let age = lock(&self.shared).latest_at.map(|at| at.elapsed());
        let what = match age {
            Some(age) => format!(
                "no {what}: the last status came {:.1} s ago (is it on, is the cable in?)",
                age.as_secs_f64()
            ),
            None => format!(
                "no {what} within {:?} (check that the controller is on and the cable is in)",
                self.config.timeouts.reply
            ),
        };
        AxisError::NotAnswering {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            what,
            waited: self.config.timeouts.reply,
        }
    }

    pub(super) fn latest_flags(&self) -> Vec<&'static str> {
        self.latest()
            .map(|o| StatusBits(o.status).names(self.config.limit_polarity))
            .unwrap_or_default()
    }

    /// Current position and status: the latest update message (K-Cubes), or a
    /// MOT_REQ_STATUSUPDATE poll (BSC20x).
    pub(super) fn observe(&mut self) -> Result<Observed, AxisError> {
        if !self.config.controller.uses_update_messages() {
            let reply = self.request(
                Message::ReqStatusUpdate {
                    channel: self.config.channel,
                },
                id::MOT_GET_STATUSUPDATE,
                "MOT_GET_STATUSUPDATE",
            )?;
            if let Message::GetStatusUpdate(StatusBlock {
                position, status, ..
            }) = reply.message
            {
                return Ok(Observed { position, status });
            }
        }
        let deadline = Instant::now() + self.config.timeouts.reply;
        loop {
            // A K-Cube sends its status every 100 ms: one older than the reply timeout means
            // the controller has gone quiet.
            if let Some(o) = self.fresh_status() {
                return Ok(o);
            }
            if Instant::now() >= deadline {
                return Err(self.silent("a status update message"));
            }
            if lock(&self.shared).link_error.is_some() {
                return Err(self.link_error("waiting for status"));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    fn to_status(&self, o: Observed) -> AxisStatus {
        let bits = StatusBits(o.status);
        let polarity = self.config.limit_polarity;
        let position = self.config.actuator.to_mm(o.position);
        // A homed axis at rest where homing left it sits on its home switch: no fault.
        let home_reverse = self.config.home.limit_switch == HomeLimitSwitch::Reverse;
        let at_home = bits.homed() && !bits.moving() && position.0.abs() <= HOME_SWITCH_MM;
        AxisStatus {
            position,
            moving: bits.moving(),
            homed: bits.homed(),
            flags: bits.names(polarity),
            faults: if at_home {
                bits.faults_resting_home(polarity, home_reverse)
            } else {
                bits.move_faults(polarity)
            },
        }
    }

    /// A stop still waiting for its MOT_MOVE_STOPPED is finished before a new motion starts, so
    /// the late stop message is not taken for the end of the new move.
    fn finish_stop(&mut self) -> Result<(), AxisError> {
        let Some(Pending::Stop(what)) = &self.pending else {
            return Ok(());
        };
        if what == IDLE_STOP {
            // Controllers need not acknowledge a stop of a stage at rest.
            match self.wait_idle(Duration::from_millis(250)) {
                Err(AxisError::Timeout { .. }) => {
                    self.pending = None;
                    self.unacked_stops = 0;
                    Ok(())
                }
                other => other.map(|_| ()),
            }
        } else {
            self.wait_idle(Duration::from_secs(10)).map(|_| ())
        }
    }

    /// Forgets stale end-of-move messages before a new motion starts.
    fn clear_events(&mut self) {
        self.updates_at_start = lock(&self.shared).updates;
        self.motion_sent = Instant::now();
        let mut stop_acks = 0u32;
        self.backlog.retain(|p| {
            stop_acks += u32::from(matches!(p.message, Message::MoveStopped { .. }));
            !is_end_of_move(p)
        });
        while let Ok(p) = self.events.try_recv() {
            if !is_end_of_move(&p) {
                self.backlog.push_back(p);
            } else if matches!(p.message, Message::MoveStopped { .. }) {
                stop_acks += 1;
            }
        }
        self.unacked_stops = self.unacked_stops.saturating_sub(stop_acks);
    }

    pub(super) fn fault(&self, what: String, flags: Vec<&'static str>) -> AxisError {
        AxisError::Fault {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            what,
            flags,
        }
    }
}

impl Drop for ThorlabsAxis {
    fn drop(&mut self) {
        self.commands = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl ThorlabsAxis {
    /// Starts MOT_MOVE_ABSOLUTE to `target`, at `motion` when given (its velocity parameters set
    /// and read back first), else at the configured kinematics.
    fn start_move_to(
        &mut self,
        target: Millimetres,
        motion: Option<Kinematics>,
    ) -> Result<(), AxisError> {
        if let Some(limits) = &self.config.soft_limits {
            limits.check(&self.config.axis, target)?;
        }
        if let Some(k) = motion {
            k.check_within(&self.config.axis, &self.configured())?;
        }
        let position = self
            .config
            .actuator
            .to_steps(target)
            .map_err(|e| self.device(e.to_string()))?;
        self.finish_stop()?;
        match motion.filter(|k| *k != self.configured()) {
            None => self.configured_kinematics()?,
            Some(k) if self.kinematics_set != Some(k) => {
                self.write_velocity_params(k)?;
                self.kinematics_set = Some(k);
            }
            Some(_) => {}
        }
        self.clear_events();
        self.send(Message::MoveAbsolute {
            channel: self.config.channel as u16,
            position,
        })?;
        let at = match motion {
            Some(k) => format!(" at {:.3}", k.velocity),
            None => String::new(),
        };
        self.pending = Some(Pending::Move(format!("moving to {target:.4}{at}")));
        Ok(())
    }

    /// The configured speed and acceleration.
    fn configured(&self) -> Kinematics {
        Kinematics {
            velocity: self.config.velocity,
            acceleration: self.config.acceleration,
        }
    }

    /// Sets the configured velocity parameters back when a move at a chosen speed changed them.
    fn configured_kinematics(&mut self) -> Result<(), AxisError> {
        if self.kinematics_set.is_some() {
            self.set_velocity_params()?;
            self.kinematics_set = None;
        }
        Ok(())
    }
}

impl Axis for ThorlabsAxis {
    fn name(&self) -> &str {
        &self.config.axis
    }

    fn endpoint(&self) -> String {
        self.endpoint.clone()
    }

    fn begin_home(&mut self) -> Result<(), AxisError> {
        self.finish_stop()?;
        self.configured_kinematics()?;
        self.clear_events();
        self.send(Message::MoveHome {
            channel: self.config.channel,
        })?;
        self.pending = Some(Pending::Home);
        Ok(())
    }

    fn begin_move_to(&mut self, target: Millimetres) -> Result<(), AxisError> {
        self.start_move_to(target, None)
    }

    fn begin_move_to_at(
        &mut self,
        target: Millimetres,
        motion: Kinematics,
    ) -> Result<(), AxisError> {
        self.start_move_to(target, Some(motion))
    }

    fn begin_move_by(&mut self, delta: Millimetres) -> Result<(), AxisError> {
        let distance = self
            .config
            .actuator
            .to_steps(delta)
            .map_err(|e| self.device(e.to_string()))?;
        self.finish_stop()?;
        let here_steps = self.observe()?.position;
        let here = self.config.actuator.to_mm(here_steps);
        let target = here + delta;
        if let Some(limits) = &self.config.soft_limits {
            limits.check(&self.config.axis, target)?;
        }
        self.configured_kinematics()?;
        self.clear_events();
        self.send(Message::MoveRelative {
            channel: self.config.channel as u16,
            distance,
        })?;
        self.pending = Some(Pending::Move(format!(
            "moving by {delta:.4} to {target:.4}"
        )));
        Ok(())
    }

    fn wait_idle(&mut self, timeout: Duration) -> Result<AxisStatus, AxisError> {
        let Some(pending) = self.pending.clone() else {
            let o = self.observe()?;
            return Ok(self.to_status(o));
        };
        let end = self.wait_end_of_move(&pending, timeout)?;
        self.pending = None;
        let final_status = self.final_status(&end)?;
        let status = self.to_status(final_status);
        let stopped = matches!(end.message, Message::MoveStopped { .. });
        self.check_end(pending, StatusBits(final_status.status), stopped)?;
        Ok(status)
    }

    fn stop(&mut self, mode: StopMode) -> Result<(), AxisError> {
        let apt = match mode {
            StopMode::Profiled => AptStop::Profiled,
            StopMode::Immediate => AptStop::Immediate,
        };
        self.send(Message::MoveStop {
            channel: self.config.channel,
            mode: apt,
        })?;
        self.unacked_stops += 1;
        // A stop sent while idle may still be acknowledged with MOT_MOVE_STOPPED: wait for it
        // (briefly) before the next motion too.
        self.pending = Some(Pending::Stop(
            self.pending
                .take()
                .map_or_else(|| IDLE_STOP.to_string(), |p| p.what()),
        ));
        Ok(())
    }

    fn status(&mut self) -> Result<AxisStatus, AxisError> {
        let o = self.observe()?;
        Ok(self.to_status(o))
    }
}
