//! Net F/T RDT traces replayed through the driver: retried start, scaling, lost and
//! out-of-order packets, error status, software bias, buffered datagrams.
//!
//! The traces under `tests/traces/netft/` are built record by record by
//! [`traces_match_their_generator`]; run it with `FRINGE_REGEN_TRACES=1` to rewrite them after
//! changing a scenario.

use fringe_rig::netft::encode_datagram;
use fringe_rig::{
    netft::{Command, Record, Request},
    NetFt, NetFtConfig, NetFtOptions,
};
use fringe_rig::{ForceError, ForceSensor, StreamStats};
use fringe_rig::{ReplayDatagramLink, ReplayHandle, ReplayOptions, Trace};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;

fn trace_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("traces/netft")
        .join(name)
}

// ---------------------------------------------------------------- trace generator

struct Builder {
    text: String,
    t: f64,
}

const PERIOD: f64 = 1.0 / 7000.0;

impl Builder {
    fn new(comment: &str) -> Builder {
        let mut text = String::from("# fringe-trace 1\n# device: netft\n# endpoint: udp 192.168.1.1:49152\n# kind: datagram\n");
        for line in comment.lines() {
            let _ = writeln!(text, "# {line}");
        }
        Builder { text, t: 0.0 }
    }
    fn line(&mut self, dt: f64, dir: char, bytes: &[u8], note: &str) {
        self.t += dt;
        let hex: Vec<String> = bytes.iter().map(|b| format!("{b:02x}")).collect();
        let _ = write!(self.text, "{:12.6} {dir} {}", self.t, hex.join(" "));
        if !note.is_empty() {
            let _ = write!(self.text, "   # {note}");
        }
        self.text.push('\n');
    }
    fn send(&mut self, dt: f64, command: Command, note: &str) {
        self.line(dt, '>', &Request::new(command).encode(), note);
    }
    fn records(&mut self, dt: f64, records: &[Record], note: &str) {
        self.line(dt, '<', &encode_datagram(records), note);
    }
}

fn rec(rdt: u32, status: u32, counts: [i32; 6]) -> Record {
    Record {
        rdt_sequence: rdt,
        ft_sequence: 500_000 + rdt,
        status,
        counts,
    }
}

/// Counts of the scaling scenario: with 1 000 000 counts per N and 1 000 counts per N mm.
const LOAD: [i32; 6] = [1_500_000, -250_000, 12_000_000, 40_000, -7_500, 1_000];

fn generate() -> Vec<(&'static str, String)> {
    let mut out = Vec::new();

    let mut b = Builder::new(
        "The first start request is lost (no reply within 100 ms); the driver sends it again.",
    );
    b.send(0.0, Command::RealTime, "start, lost");
    b.send(0.1, Command::RealTime, "start, retried");
    for i in 1..=3 {
        b.records(
            0.0004 + PERIOD * (i - 1) as f64,
            &[rec(i, 0, [i as i32 * 100; 6])],
            "",
        );
    }
    b.send(0.001, Command::Stop, "stop");
    out.push(("start_retry.trace", b.text));

    let mut b = Builder::new("A steady stream with a known load: 1.5 N, -0.25 N, 12 N, 0.04 N m, -0.0075 N m, 0.001 N m\nwith cfgcpf 1000000 (N) and cfgcpt 1000 (N-mm).");
    b.send(0.0, Command::RealTime, "start");
    for i in 1..=5 {
        b.records(if i == 1 { 0.0004 } else { PERIOD }, &[rec(i, 0, LOAD)], "");
    }
    b.send(0.001, Command::Stop, "stop");
    out.push(("stream_scaling.trace", b.text));

    let mut b = Builder::new("Records 3, 4, 7, 8 and 9 are lost on the network (5 lost).");
    b.send(0.0, Command::RealTime, "start");
    for i in [1, 2, 5, 6, 10] {
        b.records(PERIOD, &[rec(i, 0, [i as i32; 6])], "");
    }
    b.send(0.001, Command::Stop, "stop");
    out.push(("lost_packets.trace", b.text));

    let mut b =
        Builder::new("Record 3 arrives after record 4: it is dropped, and not counted as lost.");
    b.send(0.0, Command::RealTime, "start");
    for i in [1, 2, 4, 3, 5] {
        b.records(
            PERIOD,
            &[rec(i, 0, [i as i32; 6])],
            if i == 3 { "late" } else { "" },
        );
    }
    b.send(0.001, Command::Stop, "stop");
    out.push(("out_of_order.trace", b.text));

    let mut b = Builder::new(
        "Record 3 carries status 0x40000000 (Axia: out of range); the stream goes on.",
    );
    b.send(0.0, Command::RealTime, "start");
    for i in 1..=4 {
        let status = if i == 3 { 0x4000_0000 } else { 0 };
        b.records(
            PERIOD,
            &[rec(i, status, [i as i32; 6])],
            if i == 3 { "out of range" } else { "" },
        );
    }
    b.send(0.001, Command::Stop, "stop");
    out.push(("status_error.trace", b.text));

    let mut b = Builder::new("Software bias (0x42) while streaming: later records read zero.");
    b.send(0.0, Command::RealTime, "start");
    b.records(0.0004, &[rec(1, 0, LOAD)], "");
    b.records(PERIOD, &[rec(2, 0, LOAD)], "");
    b.send(0.0002, Command::SoftwareBias, "software bias");
    b.records(0.0001, &[rec(3, 0, [0; 6])], "");
    b.records(PERIOD, &[rec(4, 0, [0; 6])], "");
    b.send(0.001, Command::Stop, "stop");
    out.push(("software_bias.trace", b.text));

    let mut b = Builder::new("Buffered mode (0x03): three records per datagram.");
    b.send(0.0, Command::Buffered, "start buffered");
    b.records(
        0.0005,
        &[rec(1, 0, [1; 6]), rec(2, 0, [2; 6]), rec(3, 0, [3; 6])],
        "",
    );
    b.records(
        3.0 * PERIOD,
        &[rec(4, 0, [4; 6]), rec(5, 0, [5; 6]), rec(6, 0, [6; 6])],
        "",
    );
    b.send(0.001, Command::Stop, "stop");
    out.push(("buffered.trace", b.text));

    out
}

#[test]
fn traces_match_their_generator() {
    let regen = std::env::var_os("FRINGE_REGEN_TRACES").is_some();
    for (name, text) in generate() {
        let path = trace_path(name);
        if regen {
            std::fs::write(&path, &text).expect("write trace");
        }
        let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
        assert_eq!(on_disk, text, "{} differs from its generator: run FRINGE_REGEN_TRACES=1 cargo test -p fringe-tests --test netft_replay", path.display());
    }
}

// ---------------------------------------------------------------- replays

fn config() -> NetFtConfig {
    NetFtConfig::new(1_000_000.0, 1_000.0, "N", "N-mm", "test").expect("config")
}

fn replay(name: &str, options: NetFtOptions) -> (NetFt<ReplayDatagramLink>, ReplayHandle) {
    let trace = Trace::load(&trace_path(name)).expect("load trace");
    let (link, handle) = ReplayDatagramLink::new(
        trace,
        ReplayOptions {
            speed: f64::INFINITY,
        },
    );
    (NetFt::new(link, config(), options), handle)
}

const WAIT: Duration = Duration::from_millis(200);

fn drain(ft: &mut NetFt<ReplayDatagramLink>) -> Vec<u32> {
    let mut seqs = Vec::new();
    while let Some(s) = ft.next_sample(Duration::from_millis(20)).expect("sample") {
        seqs.push(s.transport_seq.expect("rdt sequence"));
    }
    seqs
}

#[test]
fn a_lost_start_request_is_sent_again() {
    let (mut ft, handle) = replay("start_retry.trace", NetFtOptions::default());
    let t0 = std::time::Instant::now();
    ft.start().expect("start after one retry");
    assert!(
        t0.elapsed() >= Duration::from_millis(100),
        "waited for the first start: {:?}",
        t0.elapsed()
    );
    assert_eq!(drain(&mut ft), vec![1, 2, 3]);
    ft.stop().expect("stop");
    handle
        .finish()
        .expect("the driver sent both start requests and the stop");
}

#[test]
fn start_gives_up_with_a_message_naming_the_address() {
    let text = "# fringe-trace 1\n# kind: datagram\n0.0 > 12 34 00 02 00 00 00 00\n0.03 > 12 34 00 02 00 00 00 00\n";
    let (link, handle) = ReplayDatagramLink::new(
        Trace::parse(text, "silent.trace").expect("parse"),
        ReplayOptions {
            speed: f64::INFINITY,
        },
    );
    let options = NetFtOptions {
        start_wait: Duration::from_millis(30),
        start_tries: 2,
        ..NetFtOptions::default()
    };
    let mut ft = NetFt::new(link, config(), options);
    let e = ft.start().expect_err("no records");
    let text = e.to_string();
    assert!(matches!(e, ForceError::NoData { .. }), "{text}");
    assert!(
        text.contains("silent.trace")
            && text.contains("2 start requests")
            && text.contains("49152"),
        "{text}"
    );
    handle.finish().expect("two tries sent");
}

#[test]
fn records_are_scaled_and_stamped() {
    let (mut ft, handle) = replay("stream_scaling.trace", NetFtOptions::default());
    ft.start().expect("start");
    let mut previous = None;
    for seq in 1..=5u32 {
        let s = ft.next_sample(WAIT).expect("ok").expect("sample");
        assert_eq!(s.transport_seq, Some(seq));
        assert_eq!(s.device_tick, 500_000 + u64::from(seq));
        assert_eq!(s.status, 0);
        assert_eq!(
            s.wrench.to_array(),
            [1.5, -0.25, 12.0, 0.04, -0.0075, 0.001]
        );
        if let Some(p) = previous {
            assert!(s.host_time >= p, "host receive times are monotonic");
        }
        previous = Some(s.host_time);
    }
    ft.stop().expect("stop");
    assert_eq!(
        ft.stats(),
        StreamStats {
            received: 5,
            lost: 0,
            out_of_order: 0,
            errored: 0,
            restarts: 0
        }
    );
    handle.finish().expect("replay matched");
}

#[test]
fn sequence_gaps_count_lost_packets() {
    let (mut ft, handle) = replay("lost_packets.trace", NetFtOptions::default());
    ft.start().expect("start");
    assert_eq!(drain(&mut ft), vec![1, 2, 5, 6, 10]);
    ft.stop().expect("stop");
    assert_eq!(
        ft.stats(),
        StreamStats {
            received: 5,
            lost: 5,
            out_of_order: 0,
            errored: 0,
            restarts: 0
        }
    );
    handle.finish().expect("replay matched");
}

#[test]
fn a_late_packet_is_dropped() {
    let (mut ft, handle) = replay("out_of_order.trace", NetFtOptions::default());
    ft.start().expect("start");
    assert_eq!(drain(&mut ft), vec![1, 2, 4, 5]);
    ft.stop().expect("stop");
    assert_eq!(
        ft.stats(),
        StreamStats {
            received: 4,
            lost: 0,
            out_of_order: 1,
            errored: 0,
            restarts: 0
        }
    );
    handle.finish().expect("replay matched");
}

#[test]
fn a_non_zero_status_is_an_error_naming_its_meaning() {
    let (mut ft, handle) = replay("status_error.trace", NetFtOptions::default());
    ft.start().expect("start");
    assert_eq!(
        ft.next_sample(WAIT)
            .expect("1")
            .and_then(|s| s.transport_seq),
        Some(1)
    );
    assert_eq!(
        ft.next_sample(WAIT)
            .expect("2")
            .and_then(|s| s.transport_seq),
        Some(2)
    );
    let e = ft.next_sample(WAIT).expect_err("record 3 is out of range");
    match &e {
        ForceError::Status {
            status,
            tick,
            meaning,
            ..
        } => {
            assert_eq!(*status, 0x4000_0000);
            assert_eq!(*tick, 500_003);
            assert!(meaning.contains("out of range"), "{meaning}");
        }
        other => panic!("expected a status error, got {other}"),
    }
    assert!(e.to_string().contains("0x40000000"), "{e}");
    assert_eq!(
        ft.next_sample(WAIT)
            .expect("4")
            .and_then(|s| s.transport_seq),
        Some(4),
        "the stream goes on"
    );
    ft.stop().expect("stop");
    assert_eq!(ft.stats().errored, 1);
    handle.finish().expect("replay matched");
}

#[test]
fn software_bias_sends_0x42() {
    let (mut ft, handle) = replay("software_bias.trace", NetFtOptions::default());
    ft.start().expect("start");
    assert_eq!(
        ft.next_sample(WAIT).expect("ok").expect("1").wrench.fz.0,
        12.0
    );
    assert_eq!(
        ft.next_sample(WAIT).expect("ok").expect("2").wrench.fz.0,
        12.0
    );
    ft.bias().expect("bias");
    let s = ft.next_sample(WAIT).expect("ok").expect("3");
    assert_eq!(s.wrench.to_array(), [0.0; 6]);
    assert_eq!(drain(&mut ft), vec![4]);
    ft.stop().expect("stop");
    handle
        .finish()
        .expect("the bias command was sent between records 2 and 3");
}

#[test]
fn buffered_datagrams_yield_every_record() {
    let options = NetFtOptions {
        mode: Command::Buffered,
        ..NetFtOptions::default()
    };
    let (mut ft, handle) = replay("buffered.trace", options);
    ft.start().expect("start");
    let mut fx = Vec::new();
    while let Some(s) = ft.next_sample(Duration::from_millis(20)).expect("sample") {
        fx.push(s.wrench.fx.0 * 1e6);
    }
    assert_eq!(fx, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    ft.stop().expect("stop");
    assert_eq!(ft.stats().received, 6);
    handle.finish().expect("replay matched");
}
