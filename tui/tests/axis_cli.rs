//! `fringe axis` end to end on a pseudo-terminal, with a scripted APT responder on the master
//! side (it answers requests with fixed replies; it is not a motion simulator).

use fringe_rig::apt::encode;
use fringe_rig::apt::USB_UNIT;
use fringe_rig::apt::{Flow, StreamDecoder};
use fringe_rig::apt::{HwInfo, Message, Packet, StatusBlock};
use fringe_rig::ByteLink;
use fringe_rig::PtyDevice;
use fringe_rig::Trace;
use std::process::{Command, Output};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

const ENABLED_HOMED: u32 = 0x8000_0000 | 0x1000_0000 | 0x400;
const ONE_MM_ZFS: i32 = 2_184_533;

/// Answers the connect sequence and absolute moves until `stop` is set.
fn responder(mut pty: PtyDevice, stop: Arc<AtomicBool>) {
    let mut decoder = StreamDecoder::new(Flow::ToDevice);
    let mut buf = [0u8; 256];
    let mut vel = None;
    let mut home = None;
    let reply = |pty: &mut PtyDevice, m: Message| {
        let _ = pty.write_all(&encode(&Packet::from_device(USB_UNIT, m)));
    };
    let block = |position| StatusBlock {
        channel: 1,
        position,
        encoder: 0,
        status: ENABLED_HOMED,
    };
    while !stop.load(Ordering::Relaxed) {
        let n = pty.read(&mut buf, Duration::from_millis(20)).unwrap_or(0);
        decoder.push(&buf[..n]);
        while let Some(p) = decoder.next_packet() {
            match p.message {
                Message::HwReqInfo => reply(
                    &mut pty,
                    Message::HwGetInfo(HwInfo {
                        serial_number: 26_000_042,
                        model: "KST101".into(),
                        hw_type: 16,
                        firmware: [4, 0, 1, 0],
                        notes: String::new(),
                        hw_version: 1,
                        mod_state: 0,
                        channels: 1,
                    }),
                ),
                Message::ReqChanEnableState { channel } => reply(
                    &mut pty,
                    Message::GetChanEnableState {
                        channel,
                        enabled: true,
                    },
                ),
                Message::SetVelParams(v) => vel = Some(v),
                Message::ReqVelParams { .. } => {
                    if let Some(v) = vel {
                        reply(&mut pty, Message::GetVelParams(v))
                    }
                }
                Message::SetHomeParams(h) => home = Some(h),
                Message::ReqHomeParams { .. } => {
                    if let Some(h) = home {
                        reply(&mut pty, Message::GetHomeParams(h))
                    }
                }
                Message::HwStartUpdateMsgs => {
                    reply(&mut pty, Message::GetStatusUpdate(block(ONE_MM_ZFS)))
                }
                Message::MoveAbsolute { channel, position } => {
                    reply(&mut pty, Message::GetStatusUpdate(block(position)));
                    reply(
                        &mut pty,
                        Message::MoveCompleted {
                            channel,
                            status: Some(block(position)),
                        },
                    );
                }
                _ => {}
            }
        }
    }
}

fn fringe(args: &[&str], answer: bool) -> Output {
    fringe_on_pty(
        |path| {
            let mut full = vec!["axis", "--port", path, "--actuator", "ZFS25B"];
            full.extend_from_slice(args);
            full.into_iter().map(String::from).collect()
        },
        answer,
    )
}

/// Runs fringe with the arguments `make(pty path)` against the responder on a pseudo-terminal.
fn fringe_on_pty(make: impl Fn(&str) -> Vec<String>, answer: bool) -> Output {
    let pty = PtyDevice::open().expect("pseudo-terminal");
    let path = pty.slave_path().to_string();
    let stop = Arc::new(AtomicBool::new(false));
    let worker = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            if answer {
                responder(pty, stop)
            } else {
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(10));
                }
                drop(pty);
            }
        })
    };
    let full = make(&path);
    let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .args(&full)
        .output()
        .expect("run fringe");
    stop.store(true, Ordering::Relaxed);
    worker.join().expect("responder");
    out
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn status_prints_position_and_named_bits_and_records_a_trace() {
    let dir = std::env::temp_dir().join(format!("fringe-axis-cli-{}", std::process::id()));
    let dir_text = dir.to_string_lossy().into_owned();
    let out = fringe(&["--record-trace", &dir_text, "status"], true);
    let stdout = text(&out.stdout);
    assert!(
        out.status.success(),
        "stdout: {stdout}\nstderr: {}",
        text(&out.stderr)
    );
    assert!(
        stdout.contains("controller: KST101 serial 26000042 firmware 1.0.4"),
        "{stdout}"
    );
    assert!(stdout.contains("position: 1.0000 mm"), "{stdout}");
    assert!(
        stdout.contains("status bits: homed, power ok, channel enabled"),
        "{stdout}"
    );
    let trace_text = std::fs::read_to_string(dir.join("apt.trace")).expect("DIR/apt.trace written");
    let trace = Trace::parse(&trace_text, "apt.trace").expect("recorded trace parses");
    let sent: Vec<&[u8]> = trace.entries.iter().map(|e| e.bytes.as_slice()).collect();
    assert!(
        sent.contains(&&[0x05u8, 0x00, 0x00, 0x00, 0x50, 0x01][..]),
        "HW_REQ_INFO recorded"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn move_prints_the_final_position() {
    let out = fringe(&["--min", "0", "--max", "10", "move", "2.5"], true);
    let stdout = text(&out.stdout);
    assert!(
        out.status.success(),
        "stdout: {stdout}\nstderr: {}",
        text(&out.stderr)
    );
    assert!(stdout.contains("position: 2.5000 mm"), "{stdout}");
}

#[test]
fn a_move_outside_the_soft_limits_fails_in_one_line() {
    let out = fringe(&["--min", "0", "--max", "10", "move", "12"], true);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("outside the soft limits") && stderr.contains("nothing was sent"),
        "{stderr}"
    );
}

#[test]
fn a_silent_controller_fails_in_one_line_naming_what_to_check() {
    let out = fringe(&["status"], false);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("HW_GET_INFO") && stderr.contains("is the controller powered"),
        "{stderr}"
    );
}

#[test]
fn a_thorlabs_axis_serves_as_the_y_stage() {
    let out = fringe_on_pty(
        |path| {
            [
                "ystage",
                "--apt",
                path,
                "--actuator",
                "ZFS25B",
                "--min",
                "0",
                "--max",
                "10",
            ]
            .iter()
            .map(|s| s.to_string())
            .chain(["move".to_string(), "2.5".to_string()])
            .collect()
        },
        true,
    );
    let stdout = text(&out.stdout);
    assert!(
        out.status.success(),
        "stdout: {stdout}\nstderr: {}",
        text(&out.stderr)
    );
    assert!(stdout.contains("2.5000 mm"), "{stdout}");
}
