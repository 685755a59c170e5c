//! The I/O thread of an APT axis: it owns the link, reads continuously, decodes frames, keeps the
//! latest status, forwards replies and end-of-move messages to the axis, and (K-Cubes) sends the
//! MOT_ACK_USTATUSUPDATE keep-alive; the axis sends it [`Command`]s over a channel.

use super::codec::encode;
use super::config::Timeouts;
use super::ids::id;
use super::message::{Message, Packet};
use super::stream::{Flow, StreamDecoder};
use crate::transport::ByteLink;
use crossbeam_channel::{Receiver, Sender};
use std::io;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

/// What the I/O thread last saw of the axis.
#[derive(Debug, Clone, Copy)]
pub(super) struct Observed {
    pub(super) position: i32,
    pub(super) status: u32,
}

#[derive(Default)]
pub(super) struct Shared {
    pub(super) latest: Option<Observed>,
    /// When `latest` arrived.
    pub(super) latest_at: Option<Instant>,
    /// Status messages seen so far (to tell a fresh status from one older than a motion).
    pub(super) updates: u64,
    /// `updates` when the last end-of-move message came: a status counted after it is from
    /// after the motion's end.
    pub(super) updates_at_end: u64,
    pub(super) link_error: Option<String>,
}

pub(super) enum Command {
    Write(Vec<u8>, Sender<io::Result<()>>),
    KeepAlive(bool),
}

pub(super) fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

pub(super) struct IoThread {
    pub(super) link: Box<dyn ByteLink>,
    pub(super) address: u8,
    pub(super) channel: u16,
    pub(super) commands: Receiver<Command>,
    pub(super) events: Sender<Packet>,
    pub(super) shared: Arc<Mutex<Shared>>,
    pub(super) timeouts: Timeouts,
    /// Status requests sent whose replies the axis is waiting for.
    pub(super) status_requests: usize,
}

impl IoThread {
    pub(super) fn run(mut self) {
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

pub(super) fn is_end_of_move(p: &Packet) -> bool {
    matches!(
        p.message,
        Message::MoveCompleted { .. } | Message::MoveStopped { .. } | Message::MoveHomed { .. }
    )
}
