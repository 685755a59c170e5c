//! The controller logic: host packets in, reply packets out, with the host time passed in. No I/O
//! and no threads, so unit tests drive time by hand; [`super::server`] runs it on a link.

use crate::physics::motion::{Kinematics, MotorStatus, SimMotor};
use fringe_rig::apt;
use fringe_rig::apt::LimitPolarity;
use fringe_rig::apt::{bay_address, RACK, USB_UNIT};
use fringe_rig::apt::{Actuator, ACTUATORS};
use fringe_rig::apt::{
    HomeParams, HwInfo, Message, Packet, StatusBlock, StopMode, UStatusBlock, VelParams,
};
use fringe_rig::HostTime;
use fringe_rig::Millimetres;
use fringe_rig::{AptConfig, Controller};
use std::sync::Arc;
use std::time::Duration;

/// Which status message the controller sends while update messages run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UpdateMessage {
    /// MOT_GET_STATUSUPDATE (0x0481), what a real KST101 sends.
    StatusUpdate,
    /// MOT_GET_USTATUSUPDATE (0x0491).
    UStatusUpdate,
}

/// How the controller treats the MOT_ACK_USTATUSUPDATE keep-alive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeepAlive {
    /// K-Cube: update messages stop when no keep-alive arrived for `timeout`.
    Required { timeout: Duration },
    /// BSC20x: keep-alives are ignored and update messages stop `silent_after` the
    /// HW_START_UPDATEMSGS (poll MOT_REQ_STATUSUPDATE instead).
    Ignored { silent_after: Duration },
}

/// What the emulated controller is and how it behaves.
#[derive(Debug, Clone, PartialEq)]
pub struct AptEmulatorConfig {
    /// Model reported by HW_GET_INFO ("KST101").
    pub model: String,
    pub serial_number: u32,
    /// Firmware bytes as sent: `[minor, interim, major, unused]`.
    pub firmware: [u8; 4],
    pub hw_type: u16,
    pub notes: String,
    /// The controller's own address (0x50 for a K-Cube, 0x21.. for a rack bay).
    pub address: u8,
    /// Channel ident put in replies.
    pub channel: u16,
    /// The actuator fitted, which sets the position, velocity and acceleration scales (changed
    /// by MOT_SET_TSTACTUATORTYPE to a known actuator code).
    pub actuator: Actuator,
    /// Period of update messages (real controllers: 100 ms, as the APT protocol documents).
    pub update_period: Duration,
    /// When the first update message goes out after HW_START_UPDATEMSGS. The protocol says
    /// "up to" one period (the controller's own timer runs on): a full period by default, the
    /// latest a real one may take.
    pub first_update: Duration,
    /// Each update message is sent up to this much later than its period says (USB and the
    /// controller's main loop), drawn from `jitter_seed`; 0: on the dot.
    pub update_jitter: Duration,
    pub jitter_seed: u64,
    pub update_message: UpdateMessage,
    pub keepalive: KeepAlive,
    /// Which limit switch status bit 0 stands for.
    pub limit_polarity: LimitPolarity,
    /// Channel enabled at power-up.
    pub enabled_at_power_up: bool,
}

impl AptEmulatorConfig {
    /// A KST101 K-Cube at the USB unit address: update messages with a required keep-alive
    /// (3 s without MOT_ACK_USTATUSUPDATE ends them).
    pub fn kst101(actuator: Actuator) -> Self {
        AptEmulatorConfig {
            model: "KST101".into(),
            serial_number: 26_000_001,
            firmware: [8, 0, 1, 0],
            hw_type: 16,
            notes: "APT Stepper Motor Controller".into(),
            address: USB_UNIT,
            channel: 1,
            actuator,
            update_period: Duration::from_millis(100),
            first_update: Duration::from_millis(100),
            update_jitter: Duration::ZERO,
            jitter_seed: 1,
            update_message: UpdateMessage::StatusUpdate,
            keepalive: KeepAlive::Required {
                timeout: Duration::from_secs(3),
            },
            limit_polarity: LimitPolarity::Bit0Forward,
            enabled_at_power_up: true,
        }
    }

    /// One channel of a BSC20x rack (`model` "BSC202"/"BSC203") in bay `bay` (0..=9): addressed
    /// as 0x21 + bay (or as the rack 0x11); update messages ignore the keep-alive and stop
    /// after 5 s. `None` for a bay past 9.
    pub fn bsc20x_channel(model: &str, bay: u8, actuator: Actuator) -> Option<Self> {
        Some(AptEmulatorConfig {
            model: model.into(),
            serial_number: 70_000_001,
            notes: "APT Stepper Motor Controller (rack)".into(),
            address: bay_address(bay)?,
            keepalive: KeepAlive::Ignored {
                silent_after: Duration::from_secs(5),
            },
            ..AptEmulatorConfig::kst101(actuator)
        })
    }
}

impl AptEmulatorConfig {
    /// The controller a driver configuration expects: same model, address, channel, actuator
    /// and limit polarity (a BSC201 reports itself as "SCC201", as the real one does). `None`
    /// when the configured bay is not a rack bay.
    pub fn matching(driver: &AptConfig) -> Option<Self> {
        let address = driver.controller.address(driver.bay)?;
        let mut c = match driver.controller {
            Controller::Kst101 | Controller::Kst201 => AptEmulatorConfig::kst101(driver.actuator),
            Controller::Bsc201 | Controller::Bsc202 | Controller::Bsc203 => {
                AptEmulatorConfig::bsc20x_channel("BSC203", 0, driver.actuator)?
            }
        };
        c.model = match driver.controller {
            Controller::Bsc201 => "SCC201".to_string(),
            other => other.to_string(),
        };
        c.address = address;
        c.channel = u16::from(driver.channel);
        c.limit_polarity = driver.limit_polarity;
        Some(c)
    }
}

/// What the controller has seen and done, for tests and the `sim serve` report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmulatorCounters {
    /// Host messages addressed to this controller and understood.
    pub messages: u64,
    /// Well-formed frames of message ids the controller does not implement (ignored).
    pub unknown: u64,
    /// Messages addressed to another controller (ignored).
    pub not_for_us: u64,
    /// Bytes dropped while resynchronising on garbage.
    pub dropped_bytes: u64,
    /// Packets sent to the host (replies, end-of-move and update messages).
    pub sent: u64,
    /// Unsolicited status update messages sent.
    pub status_updates: u64,
    /// MOT_ACK_USTATUSUPDATE received.
    pub keepalives: u64,
    /// Times update messages stopped for want of a keep-alive.
    pub updates_lapsed: u64,
    /// Move and home commands accepted.
    pub motions: u64,
    /// Move and home commands refused because the channel was disabled.
    pub refused: u64,
    /// MOD_IDENTIFY received (the front-panel LED would flash).
    pub identify: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HomeStage {
    /// Travelling to the home switch.
    Seeking,
    /// Moving by the home offset; the counter is zeroed at the end.
    Offset,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Motion {
    Move { target: i32 },
    Home(HomeStage),
    Stop,
}

#[derive(Debug, Clone, Copy)]
struct Updates {
    started: HostTime,
    last_ack: HostTime,
    next_due: HostTime,
}

/// The emulated controller state.
#[derive(Debug)]
pub(crate) struct EmulatorCore {
    config: AptEmulatorConfig,
    motor: Arc<SimMotor>,
    actuator: Actuator,
    enabled: bool,
    vel: VelParams,
    home: HomeParams,
    abs_param: i32,
    rel_param: i32,
    actuator_code: Option<u8>,
    updates: Option<Updates>,
    /// xorshift state for the update jitter.
    jitter_state: u64,
    end_of_move_msgs: bool,
    motion: Option<Motion>,
    /// Sign of the last commanded motion (+1 forward, -1 reverse).
    direction: f64,
    /// The controller has completed a homing run since power-up.
    homed: bool,
    /// Move kinematics to restore after a forward homing run (which runs at the home velocity).
    saved_kinematics: Option<Kinematics>,
    counters: EmulatorCounters,
}

fn after(t: HostTime, d: Duration) -> HostTime {
    HostTime(t.0.saturating_add(d.as_nanos() as u64))
}

fn saturate_i32(x: f64) -> i32 {
    x.round().clamp(i32::MIN as f64, i32::MAX as f64) as i32
}

impl EmulatorCore {
    /// A controller at power-up driving `motor`; velocity and home parameters start from the
    /// motor's kinematics in the actuator's device units.
    pub(crate) fn new(config: AptEmulatorConfig, motor: Arc<SimMotor>) -> EmulatorCore {
        let a = config.actuator;
        let k = motor.kinematics();
        let channel = config.channel;
        let velocity = saturate_i32(k.velocity.0 * a.microsteps_per_mm * VEL);
        EmulatorCore {
            vel: VelParams {
                channel,
                min_velocity: 0,
                acceleration: saturate_i32(k.acceleration.0 * a.microsteps_per_mm * ACC),
                max_velocity: velocity,
            },
            home: HomeParams {
                channel,
                direction: 2,
                limit_switch: 1,
                velocity,
                offset: 0,
            },
            actuator: a,
            enabled: config.enabled_at_power_up,
            abs_param: 0,
            rel_param: 0,
            actuator_code: a.type_code,
            updates: None,
            jitter_state: config.jitter_seed | 1,
            end_of_move_msgs: true,
            motion: None,
            direction: 1.0,
            homed: false,
            saved_kinematics: None,
            counters: EmulatorCounters::default(),
            config,
            motor,
        }
    }

    /// The configuration.
    pub(crate) fn config(&self) -> &AptEmulatorConfig {
        &self.config
    }

    /// The counters so far.
    pub(crate) fn counters(&self) -> EmulatorCounters {
        self.counters
    }

    /// Adds bytes dropped by the stream decoder to the counters.
    pub(crate) fn note_dropped_bytes(&mut self, n: u64) {
        self.counters.dropped_bytes += n;
    }

    /// Counts a well-formed frame, sent to `dest`, of a message id the controller does not
    /// implement.
    pub(crate) fn note_unknown(&mut self, dest: u8) {
        if self.accepts(dest) {
            self.counters.unknown += 1;
        } else {
            self.counters.not_for_us += 1;
        }
    }

    /// True while update messages run.
    pub(crate) fn updates_running(&self) -> bool {
        self.updates.is_some()
    }

    /// How long the server may wait for host bytes before calling [`EmulatorCore::tick`].
    pub(crate) fn poll_interval(&self, now: HostTime) -> Duration {
        let mut wait = Duration::from_millis(20);
        if self.motion.is_some() {
            wait = Duration::from_millis(2);
        }
        if let Some(u) = &self.updates {
            wait = wait.min(u.next_due.since(now).max(Duration::from_millis(1)));
        }
        wait
    }

    fn accepts(&self, dest: u8) -> bool {
        let a = self.config.address;
        dest == a || (dest == RACK && (0x21..=0x2A).contains(&a))
    }

    fn reply(&mut self, message: Message) -> Packet {
        self.counters.sent += 1;
        Packet::from_device(self.config.address, message)
    }

    fn steps(&self, mm: Millimetres) -> i32 {
        saturate_i32(mm.0 * self.actuator.microsteps_per_mm)
    }

    fn mm(&self, steps: i32) -> Millimetres {
        self.actuator.to_mm(steps)
    }

    fn apply_kinematics(&self) {
        self.motor.set_kinematics(Kinematics {
            velocity: self.actuator.velocity_from_device(self.vel.max_velocity),
            acceleration: self
                .actuator
                .acceleration_from_device(self.vel.acceleration),
        });
    }

    /// The status word for a motor reading.
    pub(crate) fn status_word(&self, st: &MotorStatus) -> u32 {
        let (fwd, rev) = match self.config.limit_polarity {
            LimitPolarity::Bit0Forward => (apt::LIMIT_BIT0, apt::LIMIT_BIT1),
            LimitPolarity::Bit0Reverse => (apt::LIMIT_BIT1, apt::LIMIT_BIT0),
        };
        let mut w = apt::MOTOR_CONNECTED;
        if st.forward_limit {
            w |= fwd;
        }
        if st.reverse_limit {
            w |= rev;
        }
        let homing = matches!(self.motion, Some(Motion::Home(_)));
        if st.moving || homing {
            let v = st.velocity.0;
            let forward = if v.abs() > 1e-12 {
                v > 0.0
            } else {
                self.direction > 0.0
            };
            w |= if forward {
                apt::MOVING_FORWARD
            } else {
                apt::MOVING_REVERSE
            };
        }
        if homing {
            w |= apt::HOMING;
        } else if self.homed {
            w |= apt::HOMED;
        }
        if self.enabled {
            w |= apt::CHANNEL_ENABLED;
        }
        w
    }

    fn status_block(&self, st: &MotorStatus) -> StatusBlock {
        StatusBlock {
            channel: self.config.channel,
            position: self.steps(st.position),
            encoder: 0,
            status: self.status_word(st),
        }
    }

    fn ustatus_block(&self, st: &MotorStatus) -> UStatusBlock {
        let v = st.velocity.0 * self.actuator.microsteps_per_mm * VEL;
        UStatusBlock {
            channel: self.config.channel,
            position: self.steps(st.position),
            // The 16-bit field cannot hold stepper velocities in device units: saturated.
            velocity: v.round().clamp(i16::MIN as f64, i16::MAX as f64) as i16,
            current_ma: if st.moving { 300 } else { 100 },
            status: self.status_word(st),
        }
    }

    fn homes_forward(&self) -> bool {
        self.home.direction == 1
    }

    fn restore_kinematics(&mut self) {
        if let Some(k) = self.saved_kinematics.take() {
            self.motor.set_kinematics(k);
        }
    }

    fn start_motion(&mut self, now: HostTime, motion: Motion) -> bool {
        if !self.enabled {
            self.counters.refused += 1;
            return false;
        }
        self.restore_kinematics();
        let here = self.steps(self.motor.status_at(now).position);
        match motion {
            Motion::Move { target } => {
                self.direction = if target >= here { 1.0 } else { -1.0 };
                self.motor.move_to(now, self.mm(target));
            }
            Motion::Home(_) => {
                let v = self.actuator.velocity_from_device(self.home.velocity);
                if self.homes_forward() {
                    // Onto the forward limit switch at the home velocity; the counter is
                    // zeroed there when the run ends.
                    self.direction = 1.0;
                    let k = self.motor.kinematics();
                    self.saved_kinematics = Some(k);
                    self.motor.set_kinematics(Kinematics {
                        velocity: v,
                        acceleration: k.acceleration,
                    });
                    let beyond = 2.0 * self.motor.spec().travel.0 + 1.0;
                    self.motor.move_by(now, Millimetres(beyond));
                } else {
                    self.direction = -1.0;
                    self.motor.home(now, v);
                }
            }
            Motion::Stop => {}
        }
        self.counters.motions += 1;
        self.motion = Some(motion);
        true
    }

    fn relative_target(&self, now: HostTime, distance: i32) -> i32 {
        let here = self.steps(self.motor.status_at(now).position);
        here.saturating_add(distance)
    }

    /// Handles one host packet arriving at `now`; returns the replies.
    pub(crate) fn handle(&mut self, packet: &Packet, now: HostTime) -> Vec<Packet> {
        if !self.accepts(packet.dest) {
            self.counters.not_for_us += 1;
            return Vec::new();
        }
        let channel = self.config.channel;
        let mut out = Vec::new();
        let mut understood = true;
        match &packet.message {
            Message::HwReqInfo => {
                let info = HwInfo {
                    serial_number: self.config.serial_number,
                    model: self.config.model.clone(),
                    hw_type: self.config.hw_type,
                    firmware: self.config.firmware,
                    notes: self.config.notes.clone(),
                    hw_version: 1,
                    mod_state: 0,
                    channels: 1,
                };
                out.push(self.reply(Message::HwGetInfo(info)));
            }
            Message::ModIdentify { .. } => self.counters.identify += 1,
            Message::HwNoFlashProgramming => {}
            Message::HwStartUpdateMsgs => {
                let first = after(now, self.config.first_update);
                self.updates = Some(Updates {
                    started: now,
                    last_ack: now,
                    next_due: after(first, self.jitter()),
                });
            }
            Message::HwStopUpdateMsgs => self.updates = None,
            Message::AckUStatusUpdate => {
                self.counters.keepalives += 1;
                if let Some(u) = &mut self.updates {
                    u.last_ack = now;
                }
            }
            Message::SetChanEnableState { enable, .. } => {
                self.enabled = *enable;
                if !*enable && self.motion.is_some() {
                    self.restore_kinematics();
                    self.motor.stop(now, true);
                    self.motion = Some(Motion::Stop);
                }
            }
            Message::ReqChanEnableState { .. } => {
                let enabled = self.enabled;
                out.push(self.reply(Message::GetChanEnableState {
                    channel: channel as u8,
                    enabled,
                }));
            }
            Message::SetTstActuatorType { actuator } => {
                self.actuator_code = Some(*actuator);
                if let Some(a) = ACTUATORS.iter().find(|a| a.type_code == Some(*actuator)) {
                    self.actuator = *a;
                    self.apply_kinematics();
                }
            }
            Message::SetVelParams(v) => {
                self.vel = VelParams { channel, ..*v };
                self.apply_kinematics();
            }
            Message::ReqVelParams { .. } => {
                let v = self.vel;
                out.push(self.reply(Message::GetVelParams(v)));
            }
            Message::SetHomeParams(h) => self.home = HomeParams { channel, ..*h },
            Message::ReqHomeParams { .. } => {
                let h = self.home;
                out.push(self.reply(Message::GetHomeParams(h)));
            }
            Message::SetPosCounter { position, .. } => {
                let mm = self.mm(*position);
                self.motor.set_position_counter(now, mm);
            }
            Message::ReqPosCounter { .. } => {
                let position = self.steps(self.motor.status_at(now).position);
                out.push(self.reply(Message::GetPosCounter { channel, position }));
            }
            Message::SetMoveAbsParams { position, .. } => self.abs_param = *position,
            Message::ReqMoveAbsParams { .. } => {
                let position = self.abs_param;
                out.push(self.reply(Message::GetMoveAbsParams { channel, position }));
            }
            Message::SetMoveRelParams { distance, .. } => self.rel_param = *distance,
            Message::ReqMoveRelParams { .. } => {
                let distance = self.rel_param;
                out.push(self.reply(Message::GetMoveRelParams { channel, distance }));
            }
            Message::MoveHome { .. } => {
                self.start_motion(now, Motion::Home(HomeStage::Seeking));
            }
            Message::MoveAbsolute { position, .. } => {
                self.start_motion(now, Motion::Move { target: *position });
            }
            Message::MoveAbsoluteStored { .. } => {
                let target = self.abs_param;
                self.start_motion(now, Motion::Move { target });
            }
            Message::MoveRelative { distance, .. } => {
                let target = self.relative_target(now, *distance);
                self.start_motion(now, Motion::Move { target });
            }
            Message::MoveRelativeStored { .. } => {
                let target = self.relative_target(now, self.rel_param);
                self.start_motion(now, Motion::Move { target });
            }
            Message::MoveStop { mode, .. } => {
                self.restore_kinematics();
                self.motor.stop(now, *mode == StopMode::Immediate);
                self.motion = Some(Motion::Stop);
            }
            Message::ReqStatusUpdate { .. } => {
                let st = self.motor.status_at(now);
                let b = self.status_block(&st);
                out.push(self.reply(Message::GetStatusUpdate(b)));
            }
            Message::ReqUStatusUpdate { .. } => {
                let st = self.motor.status_at(now);
                let u = self.ustatus_block(&st);
                out.push(self.reply(Message::GetUStatusUpdate(u)));
            }
            Message::ReqStatusBits { .. } => {
                let st = self.motor.status_at(now);
                let status = self.status_word(&st);
                out.push(self.reply(Message::GetStatusBits { channel, status }));
            }
            Message::SuspendEndOfMoveMsgs => self.end_of_move_msgs = false,
            Message::ResumeEndOfMoveMsgs => self.end_of_move_msgs = true,
            // Controller-to-host messages sent to a controller: nothing to do.
            Message::HwGetInfo(_)
            | Message::HwResponse { .. }
            | Message::HwRichResponse { .. }
            | Message::GetChanEnableState { .. }
            | Message::MoveHomed { .. }
            | Message::GetHomeParams(_)
            | Message::MoveCompleted { .. }
            | Message::MoveStopped { .. }
            | Message::GetStatusUpdate(_)
            | Message::GetUStatusUpdate(_)
            | Message::GetStatusBits { .. }
            | Message::GetVelParams(_)
            | Message::GetPosCounter { .. }
            | Message::GetMoveAbsParams { .. }
            | Message::GetMoveRelParams { .. } => understood = false,
        }
        if understood {
            self.counters.messages += 1;
        } else {
            self.counters.unknown += 1;
        }
        out
    }

    /// Advances to `now`: end-of-move messages for motions that finished, and the update
    /// message when one is due (or stops them when the keep-alive lapsed).
    pub(crate) fn tick(&mut self, now: HostTime) -> Vec<Packet> {
        let mut out = Vec::new();
        let st = self.motor.status_at(now);
        if let Some(motion) = self.motion {
            if !st.moving {
                let end = match motion {
                    Motion::Home(HomeStage::Seeking) => {
                        self.restore_kinematics();
                        if self.homes_forward() {
                            self.motor.set_position_counter(now, Millimetres(0.0));
                        }
                        if self.home.offset != 0 {
                            // The offset leads away from the home switch.
                            let offset = self.mm(self.home.offset);
                            let target = if self.homes_forward() {
                                Millimetres(-offset.0)
                            } else {
                                offset
                            };
                            self.direction = if target.0 >= 0.0 { 1.0 } else { -1.0 };
                            self.motor.move_to(now, target);
                            self.motion = Some(Motion::Home(HomeStage::Offset));
                            None
                        } else {
                            self.homed = true;
                            Some(Message::MoveHomed {
                                channel: self.config.channel as u8,
                            })
                        }
                    }
                    Motion::Home(HomeStage::Offset) => {
                        self.motor.set_position_counter(now, Millimetres(0.0));
                        self.homed = true;
                        Some(Message::MoveHomed {
                            channel: self.config.channel as u8,
                        })
                    }
                    Motion::Move { target } => {
                        let b = self.status_block(&st);
                        let blocked = (st.forward_limit || st.reverse_limit)
                            && (i64::from(b.position) - i64::from(target)).abs() > 1;
                        let (channel, status) = (self.config.channel, Some(b));
                        Some(if blocked {
                            Message::MoveStopped { channel, status }
                        } else {
                            Message::MoveCompleted { channel, status }
                        })
                    }
                    Motion::Stop => Some(Message::MoveStopped {
                        channel: self.config.channel,
                        status: Some(self.status_block(&st)),
                    }),
                };
                if let Some(m) = end {
                    self.motion = None;
                    // Update messages keep their own cadence: the status that shows the end of
                    // the motion comes with the next one, as on a real controller (the short
                    // MOVE_HOMED carries none).
                    if self.end_of_move_msgs {
                        out.push(self.reply(m));
                    }
                }
            }
        }
        out.extend(self.due_update(now));
        out
    }

    /// The update message, if update messages run and one is due at `now`; stops them when the
    /// keep-alive lapsed.
    fn due_update(&mut self, now: HostTime) -> Option<Packet> {
        let u = self.updates?;
        let lapsed = match self.config.keepalive {
            KeepAlive::Required { timeout } => now.since(u.last_ack) > timeout,
            KeepAlive::Ignored { silent_after } => now.since(u.started) > silent_after,
        };
        if lapsed {
            self.updates = None;
            self.counters.updates_lapsed += 1;
            return None;
        }
        if now < u.next_due {
            return None;
        }
        let st = self.motor.status_at(now);
        let m = match self.config.update_message {
            UpdateMessage::StatusUpdate => Message::GetStatusUpdate(self.status_block(&st)),
            UpdateMessage::UStatusUpdate => Message::GetUStatusUpdate(self.ustatus_block(&st)),
        };
        self.counters.status_updates += 1;
        // The controller's timer runs on a fixed period; jitter delays a message, not the timer.
        let period = self.config.update_period;
        let mut tick = after(u.started, self.config.first_update);
        let since = now.since(tick);
        if now >= tick {
            let periods = since.as_nanos() / period.as_nanos().max(1) + 1;
            tick = after(
                tick,
                Duration::from_nanos((periods * period.as_nanos()) as u64),
            );
        }
        let next = after(tick, self.jitter());
        if let Some(u) = &mut self.updates {
            u.next_due = next;
        }
        Some(self.reply(m))
    }

    /// A delay in [0, update_jitter] for the next update message.
    fn jitter(&mut self) -> Duration {
        let max = self.config.update_jitter.as_nanos() as u64;
        if max == 0 {
            return Duration::ZERO;
        }
        let mut x = self.jitter_state;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.jitter_state = x;
        Duration::from_nanos(x % (max + 1))
    }
}

const VEL: f64 = fringe_rig::apt::VELOCITY_SCALE;
const ACC: f64 = fringe_rig::apt::ACCELERATION_SCALE;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::motion::MotorSpec;
    use fringe_rig::apt::{HOST, USB_UNIT};
    use fringe_rig::{MillimetresPerSecond, MillimetresPerSecondSquared};

    fn zfs25() -> Actuator {
        Actuator::by_name("ZFS25B").expect("ZFS25 is known")
    }

    /// Ticks the controller every 10 ms from `t0` for up to `steps` ticks; the time at which it
    /// sent MOVE_HOMED.
    fn first_homed(c: &mut EmulatorCore, t0: HostTime, steps: u32) -> Option<HostTime> {
        (1..steps).map(|i| at(t0, f64::from(i) * 0.01)).find(|&t| {
            c.tick(t)
                .iter()
                .any(|p| p.message == Message::MoveHomed { channel: 1 })
        })
    }

    fn setup() -> (EmulatorCore, Arc<SimMotor>, HostTime) {
        let motor = Arc::new(SimMotor::new(MotorSpec {
            name: "x".into(),
            travel: Millimetres(25.0),
            power_up_position: Millimetres(1.0),
            kinematics: Kinematics {
                velocity: MillimetresPerSecond(2.0),
                acceleration: MillimetresPerSecondSquared(4.0),
            },
        }));
        let mut config = AptEmulatorConfig::kst101(zfs25());
        config.keepalive = KeepAlive::Required {
            timeout: Duration::from_secs(1),
        };
        (
            EmulatorCore::new(config, motor.clone()),
            motor,
            HostTime::now(),
        )
    }

    fn at(t0: HostTime, s: f64) -> HostTime {
        after(t0, Duration::from_secs_f64(s))
    }

    fn host(m: Message) -> Packet {
        Packet::to_device(USB_UNIT, m)
    }

    #[test]
    fn identity_enable_and_parameters_read_back() {
        let (mut c, _, t0) = setup();
        let r = c.handle(&host(Message::HwReqInfo), t0);
        let [Packet {
            dest: HOST,
            source: USB_UNIT,
            message: Message::HwGetInfo(info),
        }] = r.as_slice()
        else {
            panic!("{r:?}")
        };
        assert_eq!(info.model, "KST101");
        let vel = VelParams {
            channel: 1,
            min_velocity: 0,
            acceleration: 4506,
            max_velocity: 21_987_328,
        };
        assert!(c.handle(&host(Message::SetVelParams(vel)), t0).is_empty());
        let r = c.handle(&host(Message::ReqVelParams { channel: 1 }), t0);
        assert_eq!(r[0].message, Message::GetVelParams(vel));
        c.handle(
            &host(Message::SetChanEnableState {
                channel: 1,
                enable: false,
            }),
            t0,
        );
        let r = c.handle(&host(Message::ReqChanEnableState { channel: 1 }), t0);
        assert_eq!(
            r[0].message,
            Message::GetChanEnableState {
                channel: 1,
                enabled: false
            }
        );
        // A message addressed to a rack bay is not for a K-Cube.
        assert!(c
            .handle(&Packet::to_device(0x21, Message::HwReqInfo), t0)
            .is_empty());
        assert_eq!(c.counters().not_for_us, 1);
    }

    #[test]
    fn absolute_move_completes_at_the_end_of_the_trapezoid() {
        let (mut c, _, t0) = setup();
        let a = zfs25();
        let target = a.to_steps(Millimetres(5.0)).expect("steps");
        c.handle(
            &host(Message::MoveAbsolute {
                channel: 1,
                position: target,
            }),
            t0,
        );
        // 5 mm at 2 mm/s and 4 mm/s^2: 0.5 s ramps, 2 s cruise = 3 s.
        assert!(c.tick(at(t0, 2.99)).is_empty());
        let r = c.tick(at(t0, 3.001));
        let Some(Message::MoveCompleted {
            channel: 1,
            status: Some(b),
        }) = r.first().map(|p| p.message.clone())
        else {
            panic!("{r:?}")
        };
        assert!((b.position - target).abs() <= 1, "{b:?}");
        assert_eq!(b.status & (apt::MOVING_FORWARD | apt::MOVING_REVERSE), 0);
        assert!(c.tick(at(t0, 3.2)).is_empty(), "only one MOVE_COMPLETED");
    }

    #[test]
    fn a_disabled_channel_refuses_to_move() {
        let (mut c, motor, t0) = setup();
        c.handle(
            &host(Message::SetChanEnableState {
                channel: 1,
                enable: false,
            }),
            t0,
        );
        c.handle(
            &host(Message::MoveRelative {
                channel: 1,
                distance: 100_000,
            }),
            t0,
        );
        assert!(c.tick(at(t0, 0.5)).is_empty());
        assert_eq!(motor.status_at(at(t0, 0.5)).position, Millimetres(0.0));
        assert_eq!(c.counters().refused, 1);
    }

    #[test]
    fn update_messages_need_the_keepalive() {
        let (mut c, _, t0) = setup();
        c.handle(&host(Message::HwStartUpdateMsgs), t0);
        let mut sent = 0;
        for i in 0..=300u64 {
            // 3 s in 10 ms steps, acknowledging every 0.9 s.
            let t = after(t0, Duration::from_millis(10 * i));
            if i % 90 == 80 {
                c.handle(&host(Message::AckUStatusUpdate), t);
            }
            sent += c.tick(t).len();
        }
        assert_eq!(
            sent, 30,
            "one update per 100 ms while acknowledged, the first 100 ms after the start"
        );
        assert!(c.updates_running());
        // No acknowledgement after 2.4 s: 1 s later the updates stop.
        let mut late = 0;
        for i in 31..=40 {
            late += c.tick(at(t0, i as f64 * 0.1)).len();
        }
        assert!(!c.updates_running());
        assert!(late < 10, "{late}");
        assert_eq!(c.counters().updates_lapsed, 1);
    }

    /// The times (ms after HW_START_UPDATEMSGS) of the update messages sent in `seconds`,
    /// ticking every millisecond and acknowledging every 0.9 s.
    fn update_times(c: &mut EmulatorCore, t0: HostTime, seconds: u64) -> Vec<u64> {
        c.handle(&host(Message::HwStartUpdateMsgs), t0);
        let mut times = Vec::new();
        for ms in 0..=seconds * 1000 {
            let t = after(t0, Duration::from_millis(ms));
            if ms % 900 == 899 {
                c.handle(&host(Message::AckUStatusUpdate), t);
            }
            let n = c
                .tick(t)
                .iter()
                .filter(|p| matches!(p.message, Message::GetStatusUpdate(_)))
                .count();
            times.extend(std::iter::repeat_n(ms, n));
        }
        times
    }

    #[test]
    fn update_messages_start_a_period_after_the_request_and_keep_a_100_ms_cadence() {
        let (mut c, _, t0) = setup();
        let times = update_times(&mut c, t0, 2);
        assert_eq!(times.first(), Some(&100), "the first update: {times:?}");
        assert!(times.windows(2).all(|w| w[1] - w[0] == 100), "{times:?}");
        // A motion's end is not announced with an extra update: the cadence runs on.
        let (mut c, motor, t0) = setup();
        c.handle(&host(Message::HwStartUpdateMsgs), t0);
        c.handle(
            &host(Message::MoveRelative {
                channel: 1,
                distance: zfs25().to_steps(Millimetres(0.05)).expect("steps"),
            }),
            at(t0, 0.05),
        );
        let mut updates = Vec::new();
        for ms in 0..=1000u64 {
            let t = after(t0, Duration::from_millis(ms));
            for p in c.tick(t) {
                if matches!(p.message, Message::GetStatusUpdate(_)) {
                    updates.push(ms);
                }
            }
        }
        assert!(!motor.status_at(at(t0, 1.0)).moving);
        assert!(updates.iter().all(|ms| ms % 100 == 0), "{updates:?}");
    }

    #[test]
    fn jittered_updates_come_late_by_at_most_the_jitter_and_keep_the_period_on_average() {
        let (mut c, _, t0) = setup();
        c.config.update_jitter = Duration::from_millis(30);
        c.jitter_state = 0x5eed;
        let times = update_times(&mut c, t0, 10);
        assert!((100..=130).contains(&times[0]), "{times:?}");
        for (k, t) in times.iter().enumerate() {
            let tick = 100 * (k as u64 + 1);
            assert!(
                (tick..=tick + 30).contains(t),
                "update {k} at {t} ms: {times:?}"
            );
        }
        let gaps: Vec<u64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(gaps.iter().any(|g| *g != 100), "jitter seen: {gaps:?}");
        assert!((99..=100).contains(&times.len()), "{}", times.len());
    }

    #[test]
    fn homing_with_an_offset_zeroes_the_counter_at_the_offset() {
        let (mut c, motor, t0) = setup();
        let a = zfs25();
        let mut home = c.home;
        home.offset = a.to_steps(Millimetres(0.5)).expect("steps");
        c.handle(&host(Message::SetHomeParams(home)), t0);
        c.handle(&host(Message::MoveHome { channel: 1 }), t0);
        let st = motor.status_at(at(t0, 0.2));
        assert_ne!(c.status_word(&st) & apt::HOMING, 0);
        let t = first_homed(&mut c, t0, 400).expect("MOVE_HOMED within 4 s");
        let st = motor.status_at(t);
        assert!(st.position.0.abs() < 1e-9);
        let true_pos = motor.true_position_at(t).0;
        assert!((true_pos - 0.5).abs() < 1e-6, "{true_pos} {st:?}");
        assert_ne!(c.status_word(&st) & apt::HOMED, 0);
    }

    #[test]
    fn forward_homing_zeroes_at_the_forward_switch_and_keeps_the_move_speed() {
        let (mut c, motor, t0) = setup();
        let a = zfs25();
        let mut home = c.home;
        home.direction = 1;
        home.limit_switch = 4;
        home.velocity = a
            .velocity_to_device(MillimetresPerSecond(8.0))
            .expect("device units");
        c.handle(&host(Message::SetHomeParams(home)), t0);
        let before = motor.kinematics();
        c.handle(&host(Message::MoveHome { channel: 1 }), t0);
        let st = motor.status_at(at(t0, 1.0));
        let w = c.status_word(&st);
        assert_ne!(w & apt::HOMING, 0);
        assert_ne!(w & apt::MOVING_FORWARD, 0);
        // 24 mm to the forward switch at 8 mm/s with 4 mm/s^2: 5 s.
        let t = first_homed(&mut c, t0, 700).expect("MOVE_HOMED within 7 s");
        let st = motor.status_at(t);
        assert!(st.position.0.abs() < 1e-9 && st.forward_limit, "{st:?}");
        assert!((motor.true_position_at(t).0 - 25.0).abs() < 1e-9);
        assert_ne!(c.status_word(&st) & apt::HOMED, 0);
        assert_eq!(
            motor.kinematics(),
            before,
            "moves run at the move velocity again"
        );
    }

    #[test]
    fn the_matching_controller_has_the_driver_s_address_and_model() {
        let mut d = AptConfig::new("y", Controller::Bsc203, zfs25());
        d.bay = Some(2);
        let c = AptEmulatorConfig::matching(&d).expect("bay 2");
        assert_eq!((c.model.as_str(), c.address), ("BSC203", 0x23));
        assert!(matches!(c.keepalive, KeepAlive::Ignored { .. }));
        d.controller = Controller::Bsc201;
        d.bay = None;
        let c = AptEmulatorConfig::matching(&d).expect("USB unit");
        assert_eq!((c.model.as_str(), c.address), ("SCC201", USB_UNIT));
        let c = AptEmulatorConfig::matching(&AptConfig::new("x", Controller::Kst201, zfs25()))
            .expect("K-Cube");
        assert_eq!((c.model.as_str(), c.address), ("KST201", USB_UNIT));
        assert!(matches!(c.keepalive, KeepAlive::Required { .. }));
        d.bay = Some(10);
        d.controller = Controller::Bsc202;
        assert_eq!(AptEmulatorConfig::matching(&d), None);
    }

    #[test]
    fn a_move_past_the_travel_stops_on_the_limit_switch() {
        let (mut c, _, t0) = setup();
        c.handle(
            &host(Message::MoveAbsolute {
                channel: 1,
                position: zfs25().to_steps(Millimetres(-5.0)).expect("steps"),
            }),
            t0,
        );
        let r = c.tick(at(t0, 5.0));
        let Some(Message::MoveStopped {
            status: Some(b), ..
        }) = r.first().map(|p| p.message.clone())
        else {
            panic!("{r:?}")
        };
        // Bit 0 is the forward limit by default, so the reverse limit is bit 1.
        assert_eq!(b.status & 0x3, apt::LIMIT_BIT1);
    }
}
