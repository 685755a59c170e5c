//! The sans-io Net F/T box: RDT requests in, datagrams due at a host time out, the box's own
//! sample clock and status word; its configuration and `netftapi2.xml` page text.

use crate::scene::ForceReading;
use fringe_rig::netft::{encode_datagram, Command, Record, Request};
use fringe_rig::ForceError;
use fringe_rig::HostTime;
use fringe_rig::NetFtConfig;
use fringe_rig::Wrench;
use fringe_rig::{newton_metres_per, newtons_per};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

pub(crate) const STATUS_ERROR_SUMMARY: u32 = 0x8000_0000;
/// Net F/T status bit 17: transducer saturation or A/D error.
pub(crate) const STATUS_SATURATION: u32 = 0x0002_0000;
/// Net F/T status bit 16: a monitor (threshold) condition is latched; cleared by command 0x0041.
pub(crate) const STATUS_THRESHOLD_LATCHED: u32 = 0x0001_0000;

/// How the emulated box is set up (what its `netftapi2.xml` says, and its sensor).
#[derive(Debug, Clone, PartialEq)]
pub struct NetFtEmulatorConfig {
    /// `prodname`.
    pub product_name: String,
    /// `setserial`.
    pub serial: String,
    /// Counts per force unit (`cfgcpf`).
    pub counts_per_force: f64,
    /// Counts per torque unit (`cfgcpt`).
    pub counts_per_torque: f64,
    /// Force unit (`scfgfu`), e.g. `N`, `lbf`.
    pub force_unit: String,
    /// Torque unit (`scfgtu`), e.g. `N-m`, `N-mm`, `lbf-in`.
    pub torque_unit: String,
    /// RDT output rate (`comrdtrate`), at most `internal_rate`.
    pub rdt_rate_hz: f64,
    /// The box's internal sample rate (`ft_sequence` counts these).
    pub internal_rate_hz: f64,
    /// Error of the box's clock against host time, parts per million (positive = fast).
    pub clock_ppm: f64,
    /// Records per datagram in buffered mode (`comrdtbsiz`).
    pub buffered_records: usize,
    /// `ft_sequence` at power-up (the emulator's creation).
    pub ft_sequence_at_power_up: u32,
    /// Sensing range |Fx| |Fy| |Fz| (N), |Tx| |Ty| |Tz| (N m): a reading beyond it is reported as
    /// transducer saturation (status 0x80020000). `None`: never saturates.
    pub range: Option<[f64; 6]>,
    /// Threshold monitor on the biased reading (same layout as `range`): exceeding it latches
    /// status 0x80010000 until the reset-threshold-latch command. `None`: no monitor.
    pub threshold: Option<[f64; 6]>,
    /// The first this many start requests are ignored (lost on the network), to exercise retries.
    pub ignore_starts: u32,
}

impl Default for NetFtEmulatorConfig {
    /// A Net F/T with a Mini40 SI-40-2 in N and N m at 7 kHz.
    fn default() -> Self {
        NetFtEmulatorConfig {
            product_name: "Net F/T (fringe emulator)".into(),
            serial: "FT-SIM-0001".into(),
            counts_per_force: 1_000_000.0,
            counts_per_torque: 1_000_000.0,
            force_unit: "N".into(),
            torque_unit: "N-m".into(),
            rdt_rate_hz: 7000.0,
            internal_rate_hz: 7000.0,
            clock_ppm: 0.0,
            buffered_records: 40,
            ft_sequence_at_power_up: 0,
            range: Some([40.0, 40.0, 120.0, 2.0, 2.0, 2.0]),
            threshold: None,
            ignore_starts: 0,
        }
    }
}

/// An emulator configuration that cannot work; says which field and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("Net F/T emulator configuration: {0}")]
pub(crate) struct EmulatorConfigError(pub String);

impl NetFtEmulatorConfig {
    fn check(&self) -> Result<(f64, f64), EmulatorConfigError> {
        let err = |m: String| Err(EmulatorConfigError(m));
        for (name, v) in [
            ("counts_per_force", self.counts_per_force),
            ("counts_per_torque", self.counts_per_torque),
            ("rdt_rate_hz", self.rdt_rate_hz),
            ("internal_rate_hz", self.internal_rate_hz),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return err(format!("{name} is {v}; it must be a positive number"));
            }
        }
        if self.rdt_rate_hz > self.internal_rate_hz {
            return err(format!(
                "rdt_rate_hz {} exceeds the internal sample rate {} (the box cannot send samples it does not take)",
                self.rdt_rate_hz, self.internal_rate_hz
            ));
        }
        if !(self.clock_ppm.is_finite() && self.clock_ppm.abs() < 1e5) {
            return err(format!(
                "clock_ppm {} is not a plausible clock error",
                self.clock_ppm
            ));
        }
        if self.buffered_records == 0 {
            return err(
                "buffered_records is 0; a buffered datagram holds at least one record".into(),
            );
        }
        let fu = newtons_per(&self.force_unit).ok_or_else(|| {
            EmulatorConfigError(format!("force unit `{}` is unknown", self.force_unit))
        })?;
        let tu = newton_metres_per(&self.torque_unit).ok_or_else(|| {
            EmulatorConfigError(format!("torque unit `{}` is unknown", self.torque_unit))
        })?;
        Ok((fu, tu))
    }

    /// The box's `netftapi2.xml` page.
    pub fn netftapi2_xml(&self) -> String {
        format!(
            "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<netft>\n<setserial>{}</setserial>\n<prodname>{}</prodname>\n<cfgcpf>{}</cfgcpf>\n<cfgcpt>{}</cfgcpt>\n<scfgfu>{}</scfgfu>\n<scfgtu>{}</scfgtu>\n<comrdtrate>{}</comrdtrate>\n<comrdtbsiz>{}</comrdtbsiz>\n</netft>\n",
            xml_text(&self.serial),
            xml_text(&self.product_name),
            self.counts_per_force,
            self.counts_per_torque,
            xml_text(&self.force_unit),
            xml_text(&self.torque_unit),
            self.rdt_rate_hz,
            self.buffered_records
        )
    }

    /// The scaling a driver gets by reading this box's `netftapi2.xml` (for in-process wiring,
    /// where there is no HTTP server).
    pub fn driver_config(&self) -> Result<NetFtConfig, ForceError> {
        NetFtConfig::from_netftapi2(&self.netftapi2_xml(), "emulated Net F/T netftapi2.xml")
    }
}

fn xml_text(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// What the emulated box did, for tests and for `fringe sim serve` to print.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NetFtReport {
    /// Every valid request received, in order.
    pub requests: Vec<Request>,
    /// Records sent.
    pub records_sent: u64,
    /// Datagrams received that were not valid RDT requests (ignored, like the box does).
    pub invalid_requests: u64,
    /// Times the box rebooted ([`NetFtCore::reboot`]).
    pub reboots: u64,
    /// Datagrams that came while the box was down (lost: nothing was there to take them).
    pub lost_while_down: u64,
}

/// One datagram the box sends now.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Outgoing<P> {
    pub to: P,
    pub bytes: Vec<u8>,
}

#[derive(Debug)]
struct Stream<P> {
    peer: P,
    per_datagram: usize,
    /// Internal sample index (since power-up) of record 0.
    first: u64,
    /// Records evaluated so far.
    evaluated: u64,
    next_rdt: u32,
    remaining: Option<u32>,
    pending: Vec<Record>,
}

/// The sans-io box. `P` identifies a peer (a socket address for UDP, `()` in process).
pub(crate) struct NetFtCore<P> {
    config: NetFtEmulatorConfig,
    reading: Box<dyn ForceReading>,
    power_up: HostTime,
    /// Internal samples per host second (internal rate corrected by the clock error).
    box_hz: f64,
    counts_per_newton: f64,
    counts_per_newton_metre: f64,
    stream: Option<Stream<P>>,
    /// Rebooting: off until this host time.
    down_until: Option<HostTime>,
    bias: Wrench,
    latched: u32,
    injected: Arc<AtomicU32>,
    starts_ignored: u32,
    /// Internal sample index of the last record measured (a new stream never repeats it).
    last_measured: Option<u64>,
    report: NetFtReport,
}

impl<P: Clone> NetFtCore<P> {
    /// A box powered up at `power_up`, reading its load from `reading`.
    pub(crate) fn new(
        config: NetFtEmulatorConfig,
        reading: Box<dyn ForceReading>,
        power_up: HostTime,
    ) -> Result<NetFtCore<P>, EmulatorConfigError> {
        let (newtons_per_unit, newton_metres_per_unit) = config.check()?;
        Ok(NetFtCore {
            box_hz: config.internal_rate_hz * (1.0 + config.clock_ppm * 1e-6),
            counts_per_newton: config.counts_per_force / newtons_per_unit,
            counts_per_newton_metre: config.counts_per_torque / newton_metres_per_unit,
            config,
            reading,
            power_up,
            stream: None,
            down_until: None,
            bias: Wrench::default(),
            latched: 0,
            injected: Arc::new(AtomicU32::new(0)),
            starts_ignored: 0,
            last_measured: None,
            report: NetFtReport::default(),
        })
    }

    /// A status word OR-ed into every record from now on (fault injection); 0 clears it.
    pub(crate) fn injected_status(&self) -> Arc<AtomicU32> {
        self.injected.clone()
    }

    /// What the box did so far.
    pub(crate) fn report(&self) -> &NetFtReport {
        &self.report
    }

    /// Host time of internal sample `n` (counted from power-up).
    pub(crate) fn sample_time(&self, n: u64) -> HostTime {
        HostTime(self.power_up.0 + (n as f64 * 1e9 / self.box_hz).round() as u64)
    }

    /// The internal sample taken last at or before `t`.
    pub(crate) fn sample_index_at(&self, t: HostTime) -> u64 {
        let mut n = (t.since(self.power_up).as_nanos() as f64 * self.box_hz / 1e9).floor() as u64;
        // Guard the float rounding at sample boundaries: n must be the last sample at or before t.
        while n > 0 && self.sample_time(n) > t {
            n -= 1;
        }
        while self.sample_time(n + 1) <= t {
            n += 1;
        }
        n
    }

    /// `ft_sequence` of internal sample `n`.
    pub(crate) fn ft_sequence(&self, n: u64) -> u32 {
        self.config.ft_sequence_at_power_up.wrapping_add(n as u32)
    }

    fn record_index(&self, stream: &Stream<P>, k: u64) -> u64 {
        let step = self.config.internal_rate_hz / self.config.rdt_rate_hz;
        stream.first + (k as f64 * step + 1e-9).floor() as u64
    }

    /// When the next datagram is due, if a stream runs.
    pub(crate) fn next_due(&self) -> Option<HostTime> {
        let s = self.stream.as_ref()?;
        // The datagram being filled goes out with its last record; `pending` is always shorter
        // than a datagram between polls.
        let missing = (s.per_datagram - s.pending.len().min(s.per_datagram - 1)) as u64;
        let mut last = s.evaluated + missing - 1;
        if let Some(r) = s.remaining {
            last = last.min(s.evaluated + u64::from(r).saturating_sub(1));
        }
        Some(self.sample_time(self.record_index(s, last)))
    }

    /// The box loses its power at `now` and is up again `down` later, as after a reset or a
    /// power glitch: the stream stops, the software bias and a latched threshold are forgotten,
    /// the transducer is powered up again (a new power-up bias) and `ft_sequence` starts again
    /// from its power-up value. Requests while it is down are lost; once up, it streams only
    /// when asked again.
    pub(crate) fn reboot(&mut self, now: HostTime, down: std::time::Duration) {
        let down_ns = u64::try_from(down.as_nanos()).unwrap_or(u64::MAX);
        let up = HostTime(now.0.saturating_add(down_ns));
        self.stream = None;
        self.down_until = Some(up);
        self.power_up = up;
        self.bias = Wrench::default();
        self.latched = 0;
        self.last_measured = None;
        self.reading.power_cycle();
        self.report.reboots += 1;
    }

    /// Whether the box is down (rebooting) at `now`.
    pub(crate) fn is_down(&self, now: HostTime) -> bool {
        self.down_until.is_some_and(|up| now < up)
    }

    /// Handles one received datagram at `now` (after sending what was due before it).
    pub(crate) fn handle(
        &mut self,
        now: HostTime,
        bytes: &[u8],
        from: P,
        out: &mut Vec<Outgoing<P>>,
    ) {
        if self.is_down(now) {
            self.report.lost_while_down += 1;
            return;
        }
        self.poll(now, out);
        let Ok(request) = Request::decode(bytes) else {
            self.report.invalid_requests += 1;
            return;
        };
        self.report.requests.push(request);
        match request.command {
            Command::RealTime | Command::Buffered => {
                if self.starts_ignored < self.config.ignore_starts {
                    self.starts_ignored += 1;
                    return;
                }
                let per_datagram = if request.command == Command::Buffered {
                    self.config.buffered_records
                } else {
                    1
                };
                self.stream = Some(Stream {
                    peer: from,
                    per_datagram,
                    // The sample just taken, unless the previous stream already sent it.
                    first: match self.last_measured {
                        Some(last) => self.sample_index_at(now).max(last + 1),
                        None => self.sample_index_at(now),
                    },
                    evaluated: 0,
                    next_rdt: 1,
                    remaining: (request.sample_count > 0).then_some(request.sample_count),
                    pending: Vec::with_capacity(per_datagram),
                });
                // The first record is the sample just taken: due at once.
                self.poll(now, out);
            }
            Command::Stop => self.stream = None,
            Command::SoftwareBias => {
                let n = self.sample_index_at(now);
                self.bias = self.reading.reading_at(self.sample_time(n));
            }
            Command::ResetThresholdLatch => self.latched = 0,
            // Multi-unit streaming is for several boxes on one network: not emulated, ignored.
            Command::MultiUnit => {}
        }
    }

    /// Sends everything due at `now`.
    pub(crate) fn poll(&mut self, now: HostTime, out: &mut Vec<Outgoing<P>>) {
        let Some(mut s) = self.stream.take() else {
            return;
        };
        loop {
            if s.remaining == Some(0) {
                break;
            }
            let n = self.record_index(&s, s.evaluated);
            let t = self.sample_time(n);
            if t > now {
                break;
            }
            let record = self.measure(n, t, s.next_rdt);
            s.pending.push(record);
            s.evaluated += 1;
            s.next_rdt = s.next_rdt.wrapping_add(1);
            if let Some(r) = s.remaining.as_mut() {
                *r -= 1;
            }
            if s.pending.len() >= s.per_datagram || s.remaining == Some(0) {
                self.report.records_sent += s.pending.len() as u64;
                out.push(Outgoing {
                    to: s.peer.clone(),
                    bytes: encode_datagram(&s.pending),
                });
                s.pending.clear();
            }
        }
        if s.remaining != Some(0) {
            self.stream = Some(s);
        }
    }

    fn measure(&mut self, n: u64, t: HostTime, rdt_sequence: u32) -> Record {
        self.last_measured = Some(n);
        let raw = self.reading.reading_at(t);
        let biased = raw - self.bias;
        let exceeds = |limits: &Option<[f64; 6]>, w: &Wrench| {
            limits.is_some_and(|l| w.to_array().iter().zip(l).any(|(v, l)| v.abs() > l))
        };
        let mut status = self.injected.load(Ordering::Relaxed);
        if exceeds(&self.config.range, &raw) {
            status |= STATUS_ERROR_SUMMARY | STATUS_SATURATION;
        }
        if exceeds(&self.config.threshold, &biased) {
            self.latched = STATUS_ERROR_SUMMARY | STATUS_THRESHOLD_LATCHED;
        }
        status |= self.latched;
        let v = biased.to_array();
        let counts = std::array::from_fn(|i| {
            let per = if i < 3 {
                self.counts_per_newton
            } else {
                self.counts_per_newton_metre
            };
            // Saturating float-to-int conversion: a reading beyond i32 counts clips.
            (v[i] * per).round() as i32
        });
        Record {
            rdt_sequence,
            ft_sequence: self.ft_sequence(n),
            status,
            counts,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::netft::decode_datagram;

    fn at(s: f64) -> HostTime {
        HostTime((1e9 + s * 1e9) as u64)
    }

    fn core(config: NetFtEmulatorConfig) -> NetFtCore<u8> {
        let reading = |t: HostTime| Wrench::from_arrays([t.seconds(), -1.0, 2.0], [0.1, 0.0, -0.2]);
        NetFtCore::new(config, Box::new(reading), at(0.0)).expect("config")
    }

    fn start(
        c: &mut NetFtCore<u8>,
        now: HostTime,
        command: Command,
        count: u32,
    ) -> Vec<Outgoing<u8>> {
        let mut out = Vec::new();
        let req = Request {
            command,
            sample_count: count,
        };
        c.handle(now, &req.encode(), 7, &mut out);
        out
    }

    fn records(out: &[Outgoing<u8>]) -> Vec<Record> {
        out.iter()
            .flat_map(|d| {
                decode_datagram(&d.bytes)
                    .expect("datagram")
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    #[test]
    fn pacing_has_no_drift_over_a_minute() {
        let mut c = core(NetFtEmulatorConfig {
            ft_sequence_at_power_up: 4_000_000_000,
            ..NetFtEmulatorConfig::default()
        });
        let mut out = start(&mut c, at(1.0), Command::RealTime, 0);
        assert_eq!(
            out.len(),
            1,
            "the first record answers the start request at once"
        );
        let mut sent = 1u64;
        let mut last: Option<Record> = None;
        // Poll at irregular instants, as a busy thread would.
        let mut t: f64 = 1.0;
        while t < 61.0 {
            t += 0.000_37 + 0.003 * ((t * 977.0).sin().abs());
            out.clear();
            c.poll(at(t), &mut out);
            for r in records(&out) {
                if let Some(l) = last {
                    assert_eq!(r.rdt_sequence, l.rdt_sequence + 1);
                    assert_eq!(
                        r.ft_sequence,
                        l.ft_sequence.wrapping_add(1),
                        "wraps past u32::MAX"
                    );
                }
                last = Some(r);
                sent += 1;
            }
        }
        let expected = (at(t).since(at(1.0)).as_secs_f64() * 7000.0) as u64 + 1;
        assert!(
            sent.abs_diff(expected) <= 1,
            "{sent} records vs {expected} due"
        );
        assert_eq!(c.report().records_sent, sent);
    }

    #[test]
    fn records_carry_the_reading_at_their_sample_time() {
        let mut c = core(NetFtEmulatorConfig {
            rdt_rate_hz: 1000.0,
            ..NetFtEmulatorConfig::default()
        });
        start(&mut c, at(2.0), Command::RealTime, 0);
        let mut out = Vec::new();
        c.poll(at(2.5), &mut out);
        let recs = records(&out);
        assert_eq!(recs.len(), 500);
        for r in &recs {
            // ft_sequence runs at 7 kHz; 1 kHz output takes every 7th sample.
            let t = c.sample_time(u64::from(r.ft_sequence));
            assert_eq!(r.counts[0], (t.seconds() * 1e6).round() as i32);
            assert_eq!(
                &r.counts[1..],
                &[-1_000_000, 2_000_000, 100_000, 0, -200_000]
            );
        }
        assert!(recs
            .windows(2)
            .all(|w| w[1].ft_sequence == w[0].ft_sequence + 7));
    }

    #[test]
    fn a_fast_box_clock_runs_ahead_and_readings_follow_it() {
        let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
        let log = seen.clone();
        let reading = move |t: HostTime| {
            log.lock().expect("log").push(t);
            Wrench::default()
        };
        let config = NetFtEmulatorConfig {
            clock_ppm: 100.0,
            ..NetFtEmulatorConfig::default()
        };
        let mut c: NetFtCore<u8> = NetFtCore::new(config, Box::new(reading), at(0.0)).expect("c");
        let mut out = start(&mut c, at(0.0), Command::RealTime, 0);
        c.poll(at(10.0), &mut out);
        let recs = records(&out);
        // 10 s of host time on a clock 100 ppm fast: 70007 samples after the first.
        assert_eq!(recs.len(), 1 + 70_007);
        let times = seen.lock().expect("log").clone();
        assert_eq!(times.len(), recs.len());
        for (r, t) in recs.iter().zip(&times) {
            assert_eq!(
                c.sample_time(u64::from(r.ft_sequence)),
                *t,
                "read at its sample time"
            );
        }
        assert!(times.windows(2).all(|w| w[1] > w[0]));
    }

    #[test]
    fn buffered_mode_sample_count_and_stop() {
        let mut c = core(NetFtEmulatorConfig {
            buffered_records: 10,
            ..NetFtEmulatorConfig::default()
        });
        let out = start(&mut c, at(1.0), Command::Buffered, 25);
        assert!(out.is_empty(), "the first datagram waits for 10 records");
        let mut out = Vec::new();
        c.poll(at(1.1), &mut out);
        assert_eq!(
            out.iter().map(|d| d.bytes.len() / 36).collect::<Vec<_>>(),
            [10, 10, 5]
        );
        assert_eq!(c.next_due(), None, "25 records sent, stream over");
        let recs = records(&out);
        assert_eq!(recs.last().map(|r| r.rdt_sequence), Some(25));
        // A new stream restarts rdt_sequence but not ft_sequence.
        let out = start(&mut c, at(2.0), Command::RealTime, 0);
        let first = records(&out)[0];
        assert_eq!(first.rdt_sequence, 1);
        assert_eq!(u64::from(first.ft_sequence), c.sample_index_at(at(2.0)));
        let mut out = Vec::new();
        c.handle(at(2.01), &Request::new(Command::Stop).encode(), 7, &mut out);
        assert_eq!(records(&out).len(), 70, "what was due before the stop");
        out.clear();
        c.poll(at(3.0), &mut out);
        assert!(out.is_empty(), "nothing after a stop");
        assert_eq!(c.report().requests.len(), 3);
    }

    #[test]
    fn saturation_threshold_latch_and_injection_set_the_status() {
        let mut c = core(NetFtEmulatorConfig {
            range: Some([40.0, 40.0, 120.0, 2.0, 2.0, 2.0]),
            threshold: Some([100.0, 100.0, 1.5, 10.0, 10.0, 10.0]),
            rdt_rate_hz: 100.0,
            ..NetFtEmulatorConfig::default()
        });
        // Fx = t: within range until 40 s; Fz = 2 N is over the 1.5 N threshold.
        let out = start(&mut c, at(30.0), Command::RealTime, 0);
        assert_eq!(records(&out)[0].status, 0x8001_0000, "threshold latched");
        let mut out = Vec::new();
        c.handle(
            at(30.005),
            &Request::new(Command::SoftwareBias).encode(),
            7,
            &mut out,
        );
        c.handle(
            at(30.006),
            &Request::new(Command::ResetThresholdLatch).encode(),
            7,
            &mut out,
        );
        out.clear();
        c.poll(at(30.5), &mut out);
        let recs = records(&out);
        assert!(
            recs.iter().all(|r| r.status == 0),
            "latch reset, bias removed Fz"
        );
        assert!(recs
            .iter()
            .all(|r| r.counts[2] == 0 && r.counts[0].abs() < 600_000));
        c.injected_status().store(0x0000_0004, Ordering::Relaxed);
        out.clear();
        c.poll(at(30.6), &mut out);
        assert!(records(&out).iter().all(|r| r.status == 4));
        c.injected_status().store(0, Ordering::Relaxed);
        out.clear();
        c.poll(at(41.0), &mut out);
        let last = *records(&out).last().expect("records");
        assert_eq!(
            last.status,
            STATUS_ERROR_SUMMARY | STATUS_SATURATION,
            "Fx = 41 N > 40 N"
        );
    }

    /// A transducer whose power-up offset is 10 N in Fy per power cycle, Fz = 3 N.
    struct Cycling(u32);

    impl ForceReading for Cycling {
        fn reading_at(&mut self, _t: HostTime) -> Wrench {
            Wrench::from_arrays([0.0, 10.0 * f64::from(self.0), 3.0], [0.0; 3])
        }

        fn power_cycle(&mut self) {
            self.0 += 1;
        }
    }

    #[test]
    fn a_reboot_stops_the_stream_forgets_the_bias_and_starts_the_counter_again() {
        let config = NetFtEmulatorConfig {
            rdt_rate_hz: 1000.0,
            ft_sequence_at_power_up: 100,
            ..NetFtEmulatorConfig::default()
        };
        let mut c: NetFtCore<u8> =
            NetFtCore::new(config, Box::new(Cycling(0)), at(0.0)).expect("config");
        start(&mut c, at(5.0), Command::RealTime, 0);
        let mut out = Vec::new();
        c.handle(
            at(5.0),
            &Request::new(Command::SoftwareBias).encode(),
            7,
            &mut out,
        );
        out.clear();
        c.poll(at(6.0), &mut out);
        let before = records(&out);
        let last = *before.last().expect("records before the reboot");
        assert_eq!(last.counts[2], 0, "biased: Fz reads 0");
        assert!(last.ft_sequence > 40_000);

        c.reboot(at(6.0), std::time::Duration::from_secs(2));
        out.clear();
        c.poll(at(7.0), &mut out);
        assert!(out.is_empty(), "nothing streams from a box that is down");
        assert!(start(&mut c, at(7.5), Command::RealTime, 0).is_empty());
        assert_eq!(c.report().lost_while_down, 1);
        out.clear();
        c.poll(at(8.5), &mut out);
        assert!(out.is_empty(), "up again, it streams only when asked");

        let out = start(&mut c, at(8.5), Command::RealTime, 0);
        let first = records(&out)[0];
        assert_eq!(first.rdt_sequence, 1);
        // 0.5 s after power-up at 7 kHz, counted from the power-up value again.
        assert_eq!(first.ft_sequence, 100 + 3500);
        assert_eq!(
            first.counts[..3],
            [0, 10_000_000, 3_000_000],
            "bias forgotten, new power-up offset"
        );
        assert_eq!(c.report().reboots, 1);
    }

    #[test]
    fn ignored_starts_and_bad_requests() {
        let mut c = core(NetFtEmulatorConfig {
            ignore_starts: 1,
            ..NetFtEmulatorConfig::default()
        });
        assert!(start(&mut c, at(1.0), Command::RealTime, 0).is_empty());
        let mut out = Vec::new();
        c.handle(at(1.0), &[0x12, 0x34, 0x00], 7, &mut out);
        assert!(out.is_empty());
        assert_eq!(c.report().invalid_requests, 1);
        assert_eq!(start(&mut c, at(1.1), Command::RealTime, 0).len(), 1);
    }

    #[test]
    fn units_and_configuration_page_agree() {
        let config = NetFtEmulatorConfig {
            counts_per_force: 1000.0,
            counts_per_torque: 500.0,
            force_unit: "lbf".into(),
            torque_unit: "N-mm".into(),
            rdt_rate_hz: 1000.0,
            ..NetFtEmulatorConfig::default()
        };
        let driver = config.driver_config().expect("page parses");
        assert_eq!(driver.rdt_rate.map(|r| r.0), Some(1000.0));
        let mut c = core(config);
        let out = start(&mut c, at(1.0), Command::RealTime, 0);
        let w = driver.scale(&records(&out)[0]);
        let expected = [c.sample_time(7000).seconds(), -1.0, 2.0, 0.1, 0.0, -0.2];
        for (got, want) in w.to_array().iter().zip(expected) {
            // One count is 1/1000 lbf (4.4 mN) or 1/500 N mm.
            assert!(
                (got - want).abs() < 3e-3,
                "{:?} vs {expected:?}",
                w.to_array()
            );
        }
        assert!(NetFtEmulatorConfig {
            rdt_rate_hz: 8000.0,
            ..NetFtEmulatorConfig::default()
        }
        .check()
        .is_err());
    }
}
