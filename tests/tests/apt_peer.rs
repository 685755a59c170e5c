//! Cross-checks the APT codec against an independent implementation: the PyPI package
//! thorlabs-apt-protocol, driven by tests/python/apt_peer.py with the interpreter in
//! FRINGE_PYTHON (set by scripts/test; falls back to python3).

use fringe_rig::apt::USB_UNIT;
use fringe_rig::apt::{decode, encode};
use fringe_rig::apt::{
    HomeParams, HwInfo, Message, Packet, StatusBlock, StopMode, UStatusBlock, VelParams,
};
use fringe_tests::{python, python_script};
use std::collections::HashMap;
use std::io::Write;
use std::process::{Command, Stdio};

/// Runs the Python peer on `commands`, one answer line per command.
fn peer(commands: &[String]) -> Vec<String> {
    let python = python();
    let script = python_script("apt_peer.py");
    let mut child = Command::new(&python)
        .arg(&script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| {
            panic!("cannot start {python} ({e}); run scripts/test, which sets FRINGE_PYTHON")
        });
    {
        let mut stdin = child.stdin.take().expect("stdin");
        for c in commands {
            writeln!(stdin, "{c}").expect("write to the peer");
        }
    }
    let out = child.wait_with_output().expect("peer output");
    assert!(
        out.status.success(),
        "the Python APT peer failed ({}): {}\nrun scripts/test to install thorlabs-apt-protocol into .venv",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect();
    assert_eq!(
        lines.len(),
        commands.len(),
        "one answer per command: {lines:?}"
    );
    lines
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn unhex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).expect("hex from the peer"))
        .collect()
}

#[test]
fn host_messages_encode_to_the_same_bytes_and_decode_back() {
    // (our packet, the peer's pack function and arguments after dest and source)
    let mut cases: Vec<(Packet, String)> = Vec::new();
    for dest in [USB_UNIT, 0x22] {
        let mut add = |m: Message, call: &str| {
            let (f, args) = call.split_once(' ').unwrap_or((call, ""));
            cases.push((
                Packet::to_device(dest, m),
                format!("pack {f} {dest} 1 {args}"),
            ));
        };
        add(Message::ModIdentify { channel: 1 }, "mod_identify 1");
        add(
            Message::SetChanEnableState {
                channel: 1,
                enable: true,
            },
            "mod_set_chanenablestate 1 1",
        );
        add(
            Message::SetChanEnableState {
                channel: 2,
                enable: false,
            },
            "mod_set_chanenablestate 2 2",
        );
        add(
            Message::ReqChanEnableState { channel: 1 },
            "mod_req_chanenablestate 1",
        );
        add(Message::HwReqInfo, "hw_req_info");
        add(Message::HwStartUpdateMsgs, "hw_start_updatemsgs");
        add(Message::HwStopUpdateMsgs, "hw_stop_updatemsgs");
        add(Message::HwNoFlashProgramming, "hw_no_flash_programming");
        add(Message::MoveHome { channel: 1 }, "mot_move_home 1");
        add(
            Message::ReqHomeParams { channel: 1 },
            "mot_req_homeparams 1",
        );
        add(Message::ReqVelParams { channel: 1 }, "mot_req_velparams 1");
        add(
            Message::ReqPosCounter { channel: 1 },
            "mot_req_poscounter 1",
        );
        add(
            Message::ReqStatusUpdate { channel: 1 },
            "mot_req_statusupdate 1",
        );
        add(
            Message::ReqUStatusUpdate { channel: 1 },
            "mot_req_dcstatusupdate 1",
        );
        add(Message::AckUStatusUpdate, "mot_ack_dcstatusupdate");
        add(
            Message::MoveStop {
                channel: 1,
                mode: StopMode::Immediate,
            },
            "mot_move_stop 1 1",
        );
        add(
            Message::MoveStop {
                channel: 1,
                mode: StopMode::Profiled,
            },
            "mot_move_stop 1 2",
        );
        add(Message::SuspendEndOfMoveMsgs, "mot_suspend_endofmovemsges");
        add(Message::ResumeEndOfMoveMsgs, "mot_resume_endofmovemsges");
        // The peer packs short parameters as signed bytes, so only codes below 0x80 go through it.
        for code in [0x30u8, 0x42, 0x51] {
            add(
                Message::SetTstActuatorType { actuator: code },
                &format!("mot_set_tssactuatortype {code}"),
            );
        }
        for v in [0i32, 1, 2048, -2048, 27_306_600, i32::MAX, i32::MIN] {
            add(
                Message::MoveAbsolute {
                    channel: 1,
                    position: v,
                },
                &format!("mot_move_absolute 1 {v}"),
            );
            add(
                Message::MoveRelative {
                    channel: 1,
                    distance: v,
                },
                &format!("mot_move_relative 1 {v}"),
            );
            add(
                Message::SetPosCounter {
                    channel: 1,
                    position: v,
                },
                &format!("mot_set_poscounter 1 {v}"),
            );
        }
        for (a, v) in [(4506, 21_987_328), (13_744, 13_421_773), (0, -1)] {
            add(
                Message::SetVelParams(VelParams {
                    channel: 1,
                    min_velocity: 0,
                    acceleration: a,
                    max_velocity: v,
                }),
                &format!("mot_set_velparams 1 0 {a} {v}"),
            );
        }
        for (dir, lim, vel, off) in [(2u16, 1u16, 21_987_328, 0), (1, 4, 117_265_749, -409_600)] {
            add(
                Message::SetHomeParams(HomeParams {
                    channel: 1,
                    direction: dir,
                    limit_switch: lim,
                    velocity: vel,
                    offset: off,
                }),
                &format!("mot_set_homeparams 1 {dir} {lim} {vel} {off}"),
            );
        }
    }
    let answers = peer(&cases.iter().map(|(_, c)| c.clone()).collect::<Vec<_>>());
    for ((packet, call), answer) in cases.iter().zip(&answers) {
        assert!(!answer.starts_with("error"), "{call}: {answer}");
        let ours = encode(packet);
        assert_eq!(
            hex(&ours),
            *answer,
            "{call}: our {} differs from the peer",
            packet.message.name()
        );
        let theirs = unhex(answer);
        assert_eq!(
            decode(&theirs).as_ref(),
            Ok(packet),
            "{call}: the peer's frame decodes differently"
        );
    }
}

/// Yaq status flag names and the bits they stand for (bit 0 = forward, as the peer has it).
const FLAG_BITS: &[(&str, u32)] = &[
    ("forward_limit_switch", 0x1),
    ("reverse_limit_switch", 0x2),
    ("moving_forward", 0x10),
    ("moving_reverse", 0x20),
    ("motor_connected", 0x100),
    ("homing", 0x200),
    ("homed", 0x400),
    ("settled", 0x2000),
    ("motion_error", 0x4000),
    ("overcurrent", 0x400_0000),
    ("power_ok", 0x1000_0000),
    ("error", 0x4000_0000),
    ("channel_enabled", 0x8000_0000),
];

fn fields(line: &str) -> HashMap<String, String> {
    line.split_whitespace()
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

fn check_flags(f: &HashMap<String, String>, status: u32, what: &str) {
    for (name, bit) in FLAG_BITS {
        let expected = if status & bit != 0 { "true" } else { "false" };
        assert_eq!(
            f.get(*name).map(String::as_str),
            Some(expected),
            "{what}: flag {name}"
        );
    }
}

#[test]
fn device_messages_we_encode_unpack_to_the_same_fields_in_the_peer() {
    let info = HwInfo {
        serial_number: 26_000_001,
        model: "KST101".into(),
        hw_type: 16,
        firmware: [4, 0, 1, 0],
        notes: "APT Stepper Motor Controller".into(),
        hw_version: 3,
        mod_state: 0,
        channels: 1,
    };
    let block = StatusBlock {
        channel: 1,
        position: -409_600,
        encoder: 1234,
        status: 0x9000_4411,
    };
    let ublock = UStatusBlock {
        channel: 1,
        position: 27_306_600,
        velocity: -300,
        current_ma: 250,
        status: 0x8000_2420,
    };
    let vel = VelParams {
        channel: 1,
        min_velocity: 0,
        acceleration: 4506,
        max_velocity: 21_987_328,
    };
    let home = HomeParams {
        channel: 1,
        direction: 2,
        limit_switch: 1,
        velocity: 117_265_749,
        offset: -7,
    };
    let messages = vec![
        Message::HwGetInfo(info.clone()),
        Message::GetChanEnableState {
            channel: 1,
            enabled: true,
        },
        Message::MoveHomed { channel: 1 },
        Message::MoveCompleted {
            channel: 1,
            status: None,
        },
        Message::MoveCompleted {
            channel: 1,
            status: Some(StatusBlock {
                encoder: 0,
                ..block
            }),
        },
        Message::MoveStopped {
            channel: 1,
            status: Some(StatusBlock {
                encoder: 0,
                ..block
            }),
        },
        Message::GetStatusUpdate(block),
        Message::GetUStatusUpdate(ublock),
        Message::GetStatusBits {
            channel: 1,
            status: 0x8000_4002,
        },
        Message::GetVelParams(vel),
        Message::GetHomeParams(home),
        Message::GetPosCounter {
            channel: 1,
            position: -123_456,
        },
    ];
    let packets: Vec<Packet> = messages
        .into_iter()
        .map(|m| Packet::from_device(0x22, m))
        .collect();
    let commands: Vec<String> = packets
        .iter()
        .map(|p| format!("unpack {}", hex(&encode(p))))
        .collect();
    let answers = peer(&commands);
    for (p, answer) in packets.iter().zip(&answers) {
        assert!(
            !answer.starts_with("error"),
            "{}: {answer}",
            p.message.name()
        );
        let f = fields(answer);
        let name = p.message.name();
        let get = |k: &str| {
            f.get(k)
                .cloned()
                .unwrap_or_else(|| panic!("{name}: the peer gave no {k}: {answer}"))
        };
        assert_eq!(get("msgid"), p.message.id().to_string(), "{name}");
        assert_eq!(get("source"), "34", "{name}");
        assert_eq!(get("dest"), "1", "{name}");
        match &p.message {
            Message::HwGetInfo(i) => {
                assert_eq!(get("serial_number"), i.serial_number.to_string());
                assert_eq!(get("model_number"), i.model);
                assert_eq!(get("type"), i.hw_type.to_string());
                // The peer lists the three version bytes major first and drops the unused 4th.
                let fw: Vec<String> = i.firmware[..3].iter().rev().map(u8::to_string).collect();
                assert_eq!(get("firmware_version"), fw.join(","));
                assert_eq!(i.firmware_version(), fw.join("."));
                assert_eq!(get("hw_version"), i.hw_version.to_string());
                assert_eq!(get("mod_state"), i.mod_state.to_string());
                assert_eq!(get("nchs"), i.channels.to_string());
            }
            Message::GetChanEnableState { channel, enabled } => {
                assert_eq!(get("chan_ident"), channel.to_string());
                assert_eq!(get("enabled"), enabled.to_string());
            }
            Message::MoveHomed { channel } => assert_eq!(get("chan_ident"), channel.to_string()),
            Message::MoveCompleted { channel, status }
            | Message::MoveStopped { channel, status } => {
                assert_eq!(get("chan_ident"), channel.to_string());
                if let Some(b) = status {
                    assert_eq!(get("position"), b.position.to_string());
                    check_flags(&f, b.status, name);
                }
            }
            Message::GetStatusUpdate(b) => {
                assert_eq!(get("chan_ident"), b.channel.to_string());
                assert_eq!(get("position"), b.position.to_string());
                assert_eq!(get("enc_count"), b.encoder.to_string());
                check_flags(&f, b.status, name);
            }
            Message::GetUStatusUpdate(u) => {
                assert_eq!(get("position"), u.position.to_string());
                assert_eq!(get("velocity"), u.velocity.to_string());
                check_flags(&f, u.status, name);
            }
            Message::GetStatusBits { channel, status } => {
                assert_eq!(get("chan_ident"), channel.to_string());
                check_flags(&f, *status, name);
            }
            Message::GetVelParams(v) => {
                assert_eq!(get("min_velocity"), v.min_velocity.to_string());
                assert_eq!(get("acceleration"), v.acceleration.to_string());
                assert_eq!(get("max_velocity"), v.max_velocity.to_string());
            }
            Message::GetHomeParams(h) => {
                assert_eq!(get("home_dir"), h.direction.to_string());
                assert_eq!(get("limit_switch"), h.limit_switch.to_string());
                assert_eq!(get("home_velocity"), h.velocity.to_string());
                assert_eq!(get("offset_distance"), h.offset.to_string());
            }
            Message::GetPosCounter { channel, position } => {
                assert_eq!(get("chan_ident"), channel.to_string());
                assert_eq!(get("position"), position.to_string());
            }
            other => panic!("no check for {other:?}"),
        }
    }
}
