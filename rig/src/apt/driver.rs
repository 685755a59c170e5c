//! [`ThorlabsAxis`]: a Thorlabs stepper axis (KST101, KST201, BSC20x) over any [`ByteLink`].
//!
//! One I/O thread per axis owns the link: it reads continuously, decodes frames, keeps the latest
//! status, forwards replies and end-of-move messages to the axis, and (K-Cubes) sends the
//! MOT_ACK_USTATUSUPDATE keep-alive. The [`Axis`] methods send commands to it over a channel.
//! BSC20x controllers get no update messages; the axis polls MOT_REQ_STATUSUPDATE instead.

use super::actuator::Actuator;
use super::codec::encode;
use super::ids::{bay_address, id, USB_UNIT};
use super::message::{HomeParams, HwInfo, Message, Packet, StatusBlock, StopMode as AptStop};
use super::status::{LimitPolarity, StatusBits, FAULT_MASK};
use super::stream::{Flow, StreamDecoder};
use crate::axis::{Axis, AxisError, AxisStatus, SoftLimits, StopMode};
use crate::transport::serial::{Parity, SerialLink, SerialSettings};
use crate::transport::ByteLink;
use crate::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use crossbeam_channel::{bounded, unbounded, Receiver, RecvTimeoutError, Sender};
use std::collections::VecDeque;
use std::fmt;
use std::io;
use std::str::FromStr;
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The controller model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Controller {
    Kst101,
    Kst201,
    Bsc201,
    Bsc202,
    Bsc203,
}

impl Controller {
    /// K-Cubes run on update messages with a keep-alive; BSC20x are polled.
    pub fn uses_update_messages(self) -> bool {
        matches!(self, Controller::Kst101 | Controller::Kst201)
    }

    /// The address of this controller: K-Cubes and a BSC201 without a bay are the USB unit
    /// 0x50; a BSC202/203 channel is a rack bay (0x21 + bay, bay 0 by default).
    pub fn address(self, bay: Option<u8>) -> Option<u8> {
        match (self, bay) {
            (Controller::Kst101 | Controller::Kst201, _) => Some(USB_UNIT),
            (Controller::Bsc201, None) => Some(USB_UNIT),
            (_, Some(b)) => bay_address(b),
            (_, None) => bay_address(0),
        }
    }
}

/// A controller name that is not one of the supported models.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown Thorlabs controller `{0}` (use kst101, kst201, bsc201, bsc202 or bsc203)")]
pub struct UnknownController(pub String);

impl FromStr for Controller {
    type Err = UnknownController;
    fn from_str(s: &str) -> Result<Self, UnknownController> {
        match s.to_ascii_lowercase().as_str() {
            "kst101" => Ok(Controller::Kst101),
            "kst201" => Ok(Controller::Kst201),
            "bsc201" => Ok(Controller::Bsc201),
            "bsc202" => Ok(Controller::Bsc202),
            "bsc203" => Ok(Controller::Bsc203),
            other => Err(UnknownController(other.to_string())),
        }
    }
}

impl fmt::Display for Controller {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Controller::Kst101 => "KST101",
            Controller::Kst201 => "KST201",
            Controller::Bsc201 => "BSC201",
            Controller::Bsc202 => "BSC202",
            Controller::Bsc203 => "BSC203",
        })
    }
}

/// Direction of the homing run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomeDirection {
    Forward = 1,
    Reverse = 2,
}

/// Limit switch the homing run looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomeLimitSwitch {
    Reverse = 1,
    Forward = 4,
}

/// Home parameters, in millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomeConfig {
    pub direction: HomeDirection,
    pub limit_switch: HomeLimitSwitch,
    pub velocity: MillimetresPerSecond,
    pub offset: Millimetres,
}

/// Timing of the driver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timeouts {
    /// How long to wait for the reply to a request.
    pub reply: Duration,
    /// Status poll period while waiting for a BSC20x move.
    pub poll_period: Duration,
    /// Period of MOT_ACK_USTATUSUPDATE on K-Cubes (the controller needs one at least every
    /// second).
    pub keepalive_period: Duration,
    /// How long the I/O thread blocks in one read before looking at commands again.
    pub read_slice: Duration,
}

impl Default for Timeouts {
    fn default() -> Self {
        Timeouts {
            reply: Duration::from_secs(2),
            poll_period: Duration::from_millis(100),
            keepalive_period: Duration::from_millis(900),
            read_slice: Duration::from_millis(5),
        }
    }
}

/// Configuration of one Thorlabs axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AptConfig {
    /// Axis name ("x", "z", "y").
    pub axis: String,
    pub controller: Controller,
    /// Rack bay (0..=9) of a BSC20x channel; `None` for K-Cubes and a BSC201 as a USB unit.
    pub bay: Option<u8>,
    /// Channel ident in messages (1 for single-channel units and bays).
    pub channel: u8,
    pub actuator: Actuator,
    pub velocity: MillimetresPerSecond,
    pub acceleration: MillimetresPerSecondSquared,
    pub home: HomeConfig,
    pub soft_limits: Option<SoftLimits>,
    pub limit_polarity: LimitPolarity,
    pub timeouts: Timeouts,
}

impl AptConfig {
    /// A configuration with conservative defaults: 1 mm/s, 1 mm/s^2, homing in reverse onto the
    /// reverse limit at 1 mm/s with no offset, no soft limits.
    pub fn new(axis: &str, controller: Controller, actuator: Actuator) -> Self {
        AptConfig {
            axis: axis.to_string(),
            controller,
            bay: None,
            channel: 1,
            actuator,
            velocity: MillimetresPerSecond(1.0),
            acceleration: MillimetresPerSecondSquared(1.0),
            home: HomeConfig {
                direction: HomeDirection::Reverse,
                limit_switch: HomeLimitSwitch::Reverse,
                velocity: MillimetresPerSecond(1.0),
                offset: Millimetres(0.0),
            },
            soft_limits: None,
            limit_polarity: LimitPolarity::Bit0Forward,
            timeouts: Timeouts::default(),
        }
    }
}

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

/// What the I/O thread last saw of the axis.
#[derive(Debug, Clone, Copy)]
struct Observed {
    position: i32,
    status: u32,
}

#[derive(Default)]
struct Shared {
    latest: Option<Observed>,
    /// When `latest` arrived.
    latest_at: Option<Instant>,
    /// Status messages seen so far (to tell a fresh status from one older than a motion).
    updates: u64,
    /// `updates` when the last end-of-move message came: a status counted after it is from
    /// after the motion's end.
    updates_at_end: u64,
    link_error: Option<String>,
}

enum Command {
    Write(Vec<u8>, Sender<io::Result<()>>),
    KeepAlive(bool),
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

struct IoThread {
    link: Box<dyn ByteLink>,
    address: u8,
    channel: u16,
    commands: Receiver<Command>,
    events: Sender<Packet>,
    shared: Arc<Mutex<Shared>>,
    timeouts: Timeouts,
    /// Status requests sent whose replies the axis is waiting for.
    status_requests: usize,
}

impl IoThread {
    fn run(mut self) {
        let mut decoder = StreamDecoder::new(Flow::FromDevice);
        let mut buf = [0u8; 512];
        let mut keepalive: Option<Instant> = None;
        let ack = encode(&Packet::to_device(self.address, Message::AckUStatusUpdate));
        loop {
            loop {
                match self.commands.try_recv() {
                    Ok(Command::Write(bytes, reply)) => {
                        let id = u16::from_le_bytes([bytes[0], bytes[1]]);
                        if id == id::MOT_REQ_STATUSUPDATE || id == id::MOT_REQ_USTATUSUPDATE {
                            self.status_requests += 1;
                        }
                        let _ = reply.send(self.link.write_all(&bytes));
                    }
                    Ok(Command::KeepAlive(on)) => {
                        keepalive = on.then(|| Instant::now() + self.timeouts.keepalive_period);
                    }
                    Err(crossbeam_channel::TryRecvError::Empty) => break,
                    Err(crossbeam_channel::TryRecvError::Disconnected) => return,
                }
            }
            if let Some(due) = keepalive {
                if Instant::now() >= due {
                    if let Err(e) = self.link.write_all(&ack) {
                        lock(&self.shared).link_error =
                            Some(format!("sending the keep-alive: {e}"));
                        return;
                    }
                    keepalive = Some(due + self.timeouts.keepalive_period);
                }
            }
            match self.link.read(&mut buf, self.timeouts.read_slice) {
                Ok(0) => {}
                Ok(n) => {
                    decoder.push(&buf[..n]);
                    while let Some(p) = decoder.next_packet() {
                        self.handle(p);
                    }
                }
                Err(e) => {
                    lock(&self.shared).link_error = Some(format!("reading: {e}"));
                    return;
                }
            }
        }
    }

    fn handle(&mut self, p: Packet) {
        if p.source != self.address {
            return;
        }
        let observed = match &p.message {
            Message::GetStatusUpdate(b)
            | Message::MoveCompleted {
                status: Some(b), ..
            }
            | Message::MoveStopped {
                status: Some(b), ..
            } => Some((
                b.channel,
                Observed {
                    position: b.position,
                    status: b.status,
                },
            )),
            Message::GetUStatusUpdate(u) => Some((
                u.channel,
                Observed {
                    position: u.position,
                    status: u.status,
                },
            )),
            _ => None,
        };
        if let Some((channel, o)) = observed {
            if channel == self.channel {
                let mut shared = lock(&self.shared);
                shared.latest = Some(o);
                shared.latest_at = Some(Instant::now());
                shared.updates += 1;
            }
        }
        if is_end_of_move(&p) {
            let mut shared = lock(&self.shared);
            shared.updates_at_end = shared.updates;
        }
        let is_update = matches!(
            p.message,
            Message::GetStatusUpdate(_) | Message::GetUStatusUpdate(_)
        );
        if is_update {
            if self.status_requests == 0 {
                return;
            }
            self.status_requests -= 1;
        }
        let _ = self.events.send(p);
    }
}

/// What the axis is doing.
#[derive(Debug, Clone)]
enum Pending {
    Home,
    Move(String),
    Stop(String),
}

impl Pending {
    fn what(&self) -> String {
        match self {
            Pending::Home => "homing".to_string(),
            Pending::Move(d) => d.clone(),
            Pending::Stop(d) => format!("stopping ({d})"),
        }
    }
}

/// What a stop sent to a stage at rest is waiting for.
const IDLE_STOP: &str = "stopping at rest";

/// A Thorlabs stepper axis.
pub struct ThorlabsAxis {
    config: AptConfig,
    address: u8,
    endpoint: String,
    info: Option<HwInfo>,
    commands: Option<Sender<Command>>,
    events: Receiver<Packet>,
    backlog: VecDeque<Packet>,
    shared: Arc<Mutex<Shared>>,
    thread: Option<JoinHandle<()>>,
    pending: Option<Pending>,
    /// Stops sent whose MOT_MOVE_STOPPED has not arrived yet: a late acknowledgement of an
    /// earlier stop must not be taken for the end of a new move.
    unacked_stops: u32,
    /// Status messages seen when the current motion was sent.
    updates_at_start: u64,
    /// When the current motion was sent: a K-Cube's silence is measured from here or from its
    /// last status, whichever is later (its first status may come a whole period after
    /// HW_START_UPDATEMSGS, and then one every 100 ms).
    motion_sent: Instant,
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
        let a = self.config.actuator;
        let wanted = super::message::VelParams {
            channel: self.config.channel as u16,
            min_velocity: 0,
            acceleration: a
                .acceleration_to_device(self.config.acceleration)
                .map_err(|e| self.device(e.to_string()))?,
            max_velocity: a
                .velocity_to_device(self.config.velocity)
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
                self.config.acceleration,
                got.acceleration,
                a.acceleration_from_device(got.acceleration)
            ));
        }
        if got.max_velocity != wanted.max_velocity {
            diffs.push(format!(
                "max velocity: expected {} ({:.4}), read back {} ({:.4})",
                wanted.max_velocity,
                self.config.velocity,
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
    fn next_event(
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
    fn silent_since_motion(&self) -> bool {
        let heard = lock(&self.shared).latest_at;
        let since = heard.map_or(self.motion_sent, |at| at.max(self.motion_sent));
        since.elapsed() > self.config.timeouts.reply
    }

    /// The first status a K-Cube sent after the last end-of-move message (MOT_MOVE_HOMED carries
    /// none, and the update before it may be from during the motion), waiting at most the reply
    /// timeout for it.
    fn next_status(&self, what: &str) -> Result<Observed, AxisError> {
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
    fn silent(&self, what: &str) -> AxisError {
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

    fn latest_flags(&self) -> Vec<&'static str> {
        self.latest()
            .map(|o| StatusBits(o.status).names(self.config.limit_polarity))
            .unwrap_or_default()
    }

    /// Current position and status: the latest update message (K-Cubes), or a
    /// MOT_REQ_STATUSUPDATE poll (BSC20x).
    fn observe(&mut self) -> Result<Observed, AxisError> {
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
        AxisStatus {
            position: self.config.actuator.to_mm(o.position),
            moving: bits.moving(),
            homed: bits.homed(),
            flags: bits.names(polarity),
            faults: bits.move_faults(polarity),
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

    fn fault(&self, what: String, flags: Vec<&'static str>) -> AxisError {
        AxisError::Fault {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            what,
            flags,
        }
    }
}

/// Waiting for the end of a motion, in [`Axis::wait_idle`].
impl ThorlabsAxis {
    /// The end-of-move message of `pending`, waited for until `timeout`; fails on a fault or a
    /// silent K-Cube. The motion stays pending when the time runs out.
    fn wait_end_of_move(
        &mut self,
        pending: &Pending,
        timeout: Duration,
    ) -> Result<Packet, AxisError> {
        let polled = !self.config.controller.uses_update_messages();
        let deadline = Instant::now() + timeout;
        loop {
            let now = Instant::now();
            if now >= deadline {
                // The motion stays pending: a later wait continues it (a scan polls with short
                // waits while it watches the force); a new command or a stop replaces it.
                return Err(self.end_of_move_timeout(pending, timeout));
            }
            let slice_end = if polled {
                (now + self.config.timeouts.poll_period).min(deadline)
            } else {
                (now + Duration::from_millis(20)).min(deadline)
            };
            if let Some(p) = self.next_event(slice_end, is_end_of_move)? {
                if self.late_stop_ack(&p, pending) {
                    continue;
                }
                return Ok(p);
            }
            self.check_during_move(pending, polled)?;
        }
    }

    /// The timeout error naming the end-of-move message `pending` waits for.
    fn end_of_move_timeout(&self, pending: &Pending, timeout: Duration) -> AxisError {
        let expected = match pending {
            Pending::Home => "MOT_MOVE_HOMED",
            Pending::Move(_) => "MOT_MOVE_COMPLETED",
            Pending::Stop(_) => "MOT_MOVE_STOPPED",
        };
        AxisError::Timeout {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            what: format!("{expected} while {}", pending.what()),
            timeout,
            flags: self.latest_flags(),
        }
    }

    /// Counts a MOT_MOVE_STOPPED against the stops sent; true when it is the late
    /// acknowledgement of a stop sent before this motion began, not the end of `pending`.
    fn late_stop_ack(&mut self, p: &Packet, pending: &Pending) -> bool {
        let stop_ack = matches!(p.message, Message::MoveStopped { .. });
        if stop_ack && self.unacked_stops > 0 {
            self.unacked_stops -= 1;
            return !matches!(pending, Pending::Stop(_));
        }
        false
    }

    /// Between events: fails when a K-Cube went silent, or when the latest status since the
    /// motion started shows a fault (which ends the motion).
    fn check_during_move(&mut self, pending: &Pending, polled: bool) -> Result<(), AxisError> {
        if !polled && self.silent_since_motion() {
            return Err(self.silent(&format!("status while {}", pending.what())));
        }
        let o = if polled {
            Some(self.observe()?)
        } else {
            // Only a status sent after the motion started says something about it.
            let shared = lock(&self.shared);
            shared
                .latest
                .filter(|_| shared.updates > self.updates_at_start)
        };
        if let Some(o) = o {
            if o.status & FAULT_MASK != 0 {
                self.pending = None;
                let flags = StatusBits(o.status).move_faults(self.config.limit_polarity);
                return Err(self.fault(pending.what(), flags));
            }
        }
        Ok(())
    }

    /// Position and status at the end of a motion: carried by the end message, or else asked
    /// of a polled controller or heard at a K-Cube's next update.
    fn final_status(&mut self, end: &Packet) -> Result<Observed, AxisError> {
        let polled = !self.config.controller.uses_update_messages();
        Ok(match &end.message {
            Message::MoveCompleted {
                status: Some(b), ..
            }
            | Message::MoveStopped {
                status: Some(b), ..
            } => Observed {
                position: b.position,
                status: b.status,
            },
            // A polled controller is asked; one on update messages is heard at its next update.
            _ if polled => self.observe()?,
            _ => self.next_status("status update after the end of the motion")?,
        })
    }

    /// Fails when the motion `pending` ended with faults in `bits`, or was stopped by the
    /// controller (`stopped`) when it was not a stop.
    fn check_end(
        &self,
        pending: Pending,
        bits: StatusBits,
        stopped: bool,
    ) -> Result<(), AxisError> {
        let polarity = self.config.limit_polarity;
        match pending {
            Pending::Home => {
                let faults = bits.faults(polarity);
                if stopped || !faults.is_empty() {
                    let mut flags = faults;
                    if flags.is_empty() {
                        flags = bits.names(polarity);
                    }
                    return Err(self.fault(
                        "homing (the controller stopped the homing run)".into(),
                        flags,
                    ));
                }
            }
            Pending::Move(what) => {
                let faults = bits.move_faults(polarity);
                if !faults.is_empty() {
                    return Err(self.fault(what, faults));
                }
                if stopped {
                    return Err(self.fault(
                        format!("{what}: the controller stopped the move (MOT_MOVE_STOPPED)"),
                        bits.names(polarity),
                    ));
                }
            }
            Pending::Stop(what) => {
                let faults = bits.faults(polarity);
                if !faults.is_empty() {
                    return Err(self.fault(format!("stopping ({what})"), faults));
                }
            }
        }
        Ok(())
    }
}

fn is_end_of_move(p: &Packet) -> bool {
    matches!(
        p.message,
        Message::MoveCompleted { .. } | Message::MoveStopped { .. } | Message::MoveHomed { .. }
    )
}

impl Drop for ThorlabsAxis {
    fn drop(&mut self) {
        self.commands = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
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
        self.clear_events();
        self.send(Message::MoveHome {
            channel: self.config.channel,
        })?;
        self.pending = Some(Pending::Home);
        Ok(())
    }

    fn begin_move_to(&mut self, target: Millimetres) -> Result<(), AxisError> {
        if let Some(limits) = &self.config.soft_limits {
            limits.check(&self.config.axis, target)?;
        }
        let position = self
            .config
            .actuator
            .to_steps(target)
            .map_err(|e| self.device(e.to_string()))?;
        self.finish_stop()?;
        self.clear_events();
        self.send(Message::MoveAbsolute {
            channel: self.config.channel as u16,
            position,
        })?;
        self.pending = Some(Pending::Move(format!("moving to {target:.4}")));
        Ok(())
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
