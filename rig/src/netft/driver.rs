//! The Net F/T / Ethernet Axia driver: the RDT codec over any [`DatagramLink`].

use super::config::NetFtConfig;
use super::rdt::{decode_datagram, Command, Record, Request};
use super::stream::{status_meaning, SequenceTracker, Verdict};
use crate::clock::HostTime;
use crate::force::{ForceError, ForceSample, ForceSensor, StreamStats};
use crate::transport::DatagramLink;
use crate::units::Wrench;
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// How the driver zeroes the sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BiasMode {
    /// Send the RDT software-bias command (0x42): the sensor zeroes itself.
    Device,
    /// Take the next sample as the bias and subtract it on the host.
    Host,
}

/// Driver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NetFtOptions {
    /// Real-time (one record per datagram) or buffered streaming.
    pub mode: Command,
    /// How long to wait for the first record after a start request before sending it again.
    pub start_wait: Duration,
    /// Start requests sent before giving up.
    pub start_tries: u32,
    pub bias: BiasMode,
    /// A running stream silent this long gets its start request again, and again after each
    /// such silence: a box that rebooted streams only when asked. The new request restarts
    /// `rdt_sequence`; the records lost across it are counted from the box's sample counter
    /// (`ft_sequence`), which runs on unless the box rebooted.
    pub restart_after: Duration,
}

impl Default for NetFtOptions {
    fn default() -> Self {
        NetFtOptions {
            mode: Command::RealTime,
            start_wait: Duration::from_millis(100),
            start_tries: 5,
            bias: BiasMode::Device,
            restart_after: Duration::from_millis(500),
        }
    }
}

/// An ATI Net F/T or Ethernet Axia streaming RDT records over UDP.
pub struct NetFt<L: DatagramLink> {
    link: L,
    config: NetFtConfig,
    options: NetFtOptions,
    tracker: SequenceTracker,
    /// Records received but not yet handed out, with their host receive time.
    pending: VecDeque<(Record, HostTime)>,
    buf: Vec<u8>,
    host_bias: Wrench,
    streaming: bool,
    /// When the last datagram came (or the last start request went).
    heard: Instant,
    /// `ft_sequence` of the last record handed out.
    last_tick: Option<u32>,
    /// `ft_sequence` steps between consecutive records (the box's internal rate over its RDT
    /// output rate), learnt from the stream.
    stride: Option<u32>,
    /// The start request was sent again in a running stream: the next record's `ft_sequence`
    /// tells how many records the silence took.
    resumed: bool,
    /// Records lost across such restarts that the new stream's `rdt_sequence` cannot show.
    lost_across_restarts: u64,
    restarts: u64,
}

impl<L: DatagramLink> NetFt<L> {
    /// A driver on `link` (connected to the sensor's RDT port) scaling with `config`.
    pub fn new(link: L, config: NetFtConfig, options: NetFtOptions) -> NetFt<L> {
        NetFt {
            link,
            config,
            options,
            tracker: SequenceTracker::new(),
            pending: VecDeque::new(),
            // Buffered mode packs up to 40 records into one datagram; leave room for more.
            buf: vec![0u8; 65536],
            host_bias: Wrench::default(),
            streaming: false,
            heard: Instant::now(),
            last_tick: None,
            stride: None,
            resumed: false,
            lost_across_restarts: 0,
            restarts: 0,
        }
    }

    /// The scaling in use.
    pub fn config(&self) -> &NetFtConfig {
        &self.config
    }

    /// Gives the link back (a replay link to finish, a recorder to flush).
    pub fn into_link(self) -> L {
        self.link
    }

    fn io(&self, e: std::io::Error) -> ForceError {
        ForceError::Io {
            device: self.describe(),
            source: e,
        }
    }

    fn send(&mut self, command: Command) -> Result<(), ForceError> {
        let bytes = Request::new(command).encode();
        self.link.send(&bytes).map_err(|e| self.io(e))
    }

    /// Receives one datagram into `pending`; `Ok(false)` if nothing arrived in `timeout`.
    fn receive(&mut self, timeout: Duration) -> Result<bool, ForceError> {
        let Some(n) = self
            .link
            .recv(&mut self.buf, timeout)
            .map_err(|e| self.io(e))?
        else {
            return Ok(false);
        };
        let at = HostTime::now();
        self.heard = Instant::now();
        let records = decode_datagram(&self.buf[..n]).map_err(|e| ForceError::Device {
            device: self.describe(),
            message: format!("{e}; check that nothing else sends to this UDP port"),
        })?;
        self.pending.extend(records.map(|r| (r, at)));
        Ok(true)
    }

    /// The next record that passes sequence accounting, as a sample.
    fn next_accepted(&mut self, timeout: Duration) -> Result<Option<ForceSample>, ForceError> {
        let deadline = Instant::now() + timeout;
        loop {
            while let Some((record, at)) = self.pending.pop_front() {
                match self.tracker.accept(record.rdt_sequence, record.status) {
                    Verdict::Drop => continue,
                    Verdict::Deliver { lost_before } => {
                        self.note_counter(record.ft_sequence, lost_before);
                        return Ok(Some(self.sample(&record, at)));
                    }
                }
            }
            self.restart_if_silent()?;
            let restart_at = self
                .heard
                .checked_add(self.options.restart_after)
                .unwrap_or(deadline);
            let left = deadline
                .min(restart_at)
                .saturating_duration_since(Instant::now());
            if !self.receive(left)? && Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    /// Sends the start request again after [`NetFtOptions::restart_after`] of silence in a
    /// running stream; the new stream numbers its records from 1 again.
    fn restart_if_silent(&mut self) -> Result<(), ForceError> {
        if !self.streaming || self.heard.elapsed() < self.options.restart_after {
            return Ok(());
        }
        self.send(self.options.mode)?;
        self.tracker.restart();
        self.resumed = true;
        self.heard = Instant::now();
        Ok(())
    }

    /// Follows the box's sample counter over delivered records (in order here: the tracker
    /// dropped late ones); `lost_before` records were missing just before this one by
    /// `rdt_sequence`. A counter that went back is a device restart. After a start request
    /// sent again in a running stream, the records lost between the last record of the old
    /// stream and the first of the new one are counted from the counter: the new stream's
    /// `rdt_sequence` only shows those lost after the request.
    fn note_counter(&mut self, ft_sequence: u32, lost_before: u32) {
        let resumed = std::mem::take(&mut self.resumed);
        if let Some(last) = self.last_tick {
            let step = ft_sequence.wrapping_sub(last);
            if step > u32::MAX / 2 {
                self.restarts += 1;
            } else if resumed {
                if let Some(stride) = self.stride {
                    let records = (u64::from(step) + u64::from(stride) / 2) / u64::from(stride);
                    let missing = records.saturating_sub(1);
                    self.lost_across_restarts += missing.saturating_sub(u64::from(lost_before));
                }
            } else if lost_before == 0 && step > 0 {
                self.stride = Some(step);
            }
        }
        self.last_tick = Some(ft_sequence);
    }

    fn sample(&self, record: &Record, at: HostTime) -> ForceSample {
        ForceSample {
            device_tick: u64::from(record.ft_sequence),
            transport_seq: Some(record.rdt_sequence),
            host_time: at,
            wrench: self.config.scale(record) - self.host_bias,
            status: record.status,
            strobe: None,
        }
    }

    fn status_error(&self, s: &ForceSample) -> ForceError {
        ForceError::Status {
            device: self.describe(),
            status: s.status,
            meaning: status_meaning(s.status),
            tick: s.device_tick,
        }
    }

    /// Discards datagrams already waiting (tail of an earlier stream).
    fn drain(&mut self) -> Result<(), ForceError> {
        self.pending.clear();
        while self
            .link
            .recv(&mut self.buf, Duration::ZERO)
            .map_err(|e| self.io(e))?
            .is_some()
        {}
        Ok(())
    }
}

impl<L: DatagramLink> ForceSensor for NetFt<L> {
    fn describe(&self) -> String {
        format!("netft {}", self.link.describe())
    }

    fn start(&mut self) -> Result<(), ForceError> {
        self.drain()?;
        self.tracker.reset();
        self.restarts = 0;
        self.lost_across_restarts = 0;
        self.resumed = false;
        let tries = self.options.start_tries.max(1);
        for _ in 0..tries {
            self.send(self.options.mode)?;
            // The whole wait, even when the link reports nothing early (a datagram lost on the
            // way, an ICMP refusal read back).
            let deadline = Instant::now() + self.options.start_wait;
            loop {
                let left = deadline.saturating_duration_since(Instant::now());
                if self.receive(left)? {
                    self.streaming = true;
                    self.heard = Instant::now();
                    return Ok(());
                }
                if Instant::now() >= deadline {
                    break;
                }
            }
        }
        Err(ForceError::NoData {
            device: self.describe(),
            waited: self.options.start_wait * tries,
            hint: format!(
                "no RDT record after {tries} start requests; check that the sensor is powered and reachable (ping it), that the address and UDP port (default 49152) are right, and that no firewall blocks its replies"
            ),
        })
    }

    fn next_sample(&mut self, timeout: Duration) -> Result<Option<ForceSample>, ForceError> {
        match self.next_accepted(timeout)? {
            Some(s) if s.status != 0 => Err(self.status_error(&s)),
            other => Ok(other),
        }
    }

    fn stop(&mut self) -> Result<(), ForceError> {
        self.send(Command::Stop)?;
        // Records already received stay readable (and records in flight still arrive);
        // `start` discards whatever is left.
        self.streaming = false;
        Ok(())
    }

    fn bias(&mut self) -> Result<(), ForceError> {
        match self.options.bias {
            BiasMode::Device => {
                self.send(Command::SoftwareBias)?;
                self.host_bias = Wrench::default();
                Ok(())
            }
            BiasMode::Host => {
                if !self.streaming {
                    return Err(ForceError::Device {
                        device: self.describe(),
                        message: "host-side bias needs a running stream; call start first".into(),
                    });
                }
                let wait = self.options.start_wait * self.options.start_tries.max(1);
                self.host_bias = Wrench::default();
                match self.next_accepted(wait)? {
                    Some(s) if s.status != 0 => Err(self.status_error(&s)),
                    Some(s) => {
                        self.host_bias = s.wrench;
                        Ok(())
                    }
                    None => Err(ForceError::NoData {
                        device: self.describe(),
                        waited: wait,
                        hint: "no sample arrived to take the bias from; check the stream".into(),
                    }),
                }
            }
        }
    }

    fn stats(&self) -> StreamStats {
        let tracked = self.tracker.stats();
        StreamStats {
            restarts: self.restarts,
            lost: tracked.lost + self.lost_across_restarts,
            ..tracked
        }
    }
}
