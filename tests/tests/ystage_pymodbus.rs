//! The Modbus y stage driver against an independent peer: a pymodbus server emulating a stage
//! (tests/python/modbus_stage_server.py) over Modbus TCP on loopback and over Modbus RTU on a
//! pseudo-terminal pair made by socat. The simulated stage ramps its feedback position with the
//! moving bit set, so the driver's wait logic really runs.

use fringe_tests::{python, require_python_module};

use fringe_rig::Millimetres;
use fringe_rig::SerialLink;
use fringe_rig::TcpLink;
use fringe_rig::{Axis, AxisError, SoftLimits};
use fringe_rig::{Framing, ModbusStage, RegisterMap, StageOptions};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A running child process, killed on drop.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The simulated stage: the process and the register writes it has printed.
struct Server {
    _proc: Proc,
    writes: Arc<Mutex<Vec<String>>>,
}

impl Server {
    fn start(args: &[&str]) -> Server {
        require_python_module("pymodbus");
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/modbus_stage_server.py");
        let mut child = Command::new(python())
            .arg(script)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start the pymodbus stage server");
        let stdout = child.stdout.take().expect("stdout piped");
        let writes = Arc::new(Mutex::new(Vec::new()));
        let (tx, rx) = mpsc::channel();
        let sink = writes.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if line == "SERVING" {
                    let _ = tx.send(());
                } else if let Some(w) = line.strip_prefix("WRITE ") {
                    sink.lock().expect("lock").push(w.to_string());
                }
            }
        });
        rx.recv_timeout(Duration::from_secs(20))
            .expect("the pymodbus server started (SERVING)");
        Server {
            _proc: Proc(child),
            writes,
        }
    }

    fn writes(&self) -> Vec<String> {
        self.writes.lock().expect("lock").clone()
    }
}

fn options() -> StageOptions {
    StageOptions {
        response_timeout: Duration::from_secs(1),
        poll_interval: Duration::from_millis(20),
        limits: Some(SoftLimits {
            min: Millimetres(-10.0),
            max: Millimetres(20.0),
        }),
        ..StageOptions::default()
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .expect("bind")
        .local_addr()
        .expect("addr")
        .port()
}

fn connect(port: u16) -> TcpLink {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        match TcpLink::connect(&format!("127.0.0.1:{port}"), Duration::from_millis(200)) {
            Ok(link) => return link,
            Err(e) if Instant::now() > deadline => {
                panic!("cannot connect to the pymodbus server: {e}")
            }
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

#[test]
fn oriental_az_over_modbus_tcp() {
    let port = free_port();
    let server = Server::start(&["--profile", "az", "--tcp", &port.to_string()]);
    let link = connect(port);
    let map = RegisterMap::load("oriental-az").expect("map");
    let mut y = ModbusStage::new("y", Box::new(link), Framing::Tcp, map, options());

    let start = Instant::now();
    let status = y
        .move_to(Millimetres(2.5), Duration::from_secs(5))
        .expect("absolute move");
    assert!(
        start.elapsed() >= Duration::from_millis(350),
        "the move takes 0.4 s on the simulated stage"
    );
    assert_eq!(status.position, Millimetres(2.5));
    assert!(
        status.flags.contains(&"READY") && !status.moving,
        "{status}"
    );

    let status = y
        .move_by(Millimetres(-1.0), Duration::from_secs(5))
        .expect("relative move");
    assert_eq!(status.position, Millimetres(1.5));
    assert_eq!(y.status().expect("status").position, Millimetres(1.5));

    // Registers the server saw: direct data block then trigger, twice.
    let w = server.writes();
    assert_eq!(
        w,
        vec![
            // data no 0, type 1 absolute, position 500, speed 1000 Hz, accel/decel 10000, current 1000
            format!("16 {} 0 0 0 1 0 500 0 1000 0 10000 0 10000 0 1000", 0x58),
            format!("16 {} 0 1", 0x66),
            // type 2 incremental, position -200 steps (0xFFFF 0xFF38)
            format!(
                "16 {} 0 0 0 2 65535 65336 0 1000 0 10000 0 10000 0 1000",
                0x58
            ),
            format!("16 {} 0 1", 0x66),
        ]
    );

    // A wait shorter than the motion times out, naming the axis and the target.
    y.begin_move_to(Millimetres(0.0)).expect("start move");
    let err = y
        .wait_idle(Duration::from_millis(100))
        .expect_err("the move takes 0.4 s");
    assert!(matches!(err, AxisError::Timeout { .. }), "{err:?}");
    assert!(err.to_string().contains("moving to 0.0000 mm"), "{err}");
    assert_eq!(
        y.wait_idle(Duration::from_secs(5))
            .expect("finishes")
            .position,
        Millimetres(0.0)
    );

    // Soft limits: nothing is written.
    let before = server.writes().len();
    assert!(matches!(
        y.begin_move_to(Millimetres(25.0)),
        Err(AxisError::SoftLimit { .. })
    ));
    std::thread::sleep(Duration::from_millis(50));
    assert_eq!(server.writes().len(), before);
}

/// A socat-made pseudo-terminal pair: `a` and `b` are linked.
struct PtyPair {
    _proc: Proc,
    _dir: PathBuf,
    a: PathBuf,
    b: PathBuf,
}

fn pty_pair(tag: &str) -> PtyPair {
    let dir = std::env::temp_dir().join(format!("fringe-ystage-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let child = Command::new("socat")
        .arg(format!("pty,raw,echo=0,link={}", a.display()))
        .arg(format!("pty,raw,echo=0,link={}", b.display()))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("socat is needed for the RTU test (apt install socat; .ci/run installs it)");
    let proc = Proc(child);
    let deadline = Instant::now() + Duration::from_secs(10);
    while !(a.exists() && b.exists()) {
        assert!(
            Instant::now() < deadline,
            "socat did not create {} and {}",
            a.display(),
            b.display()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    PtyPair {
        _proc: proc,
        _dir: dir,
        a,
        b,
    }
}

#[test]
fn leadshine_pr_over_modbus_rtu_on_a_pty() {
    let pair = pty_pair("rtu");
    let server = Server::start(&[
        "--profile",
        "leadshine",
        "--serial",
        pair.a.to_str().expect("utf8 path"),
        "--baud",
        "38400",
        "--parity",
        "N",
    ]);
    let map = RegisterMap::load("leadshine-pr").expect("map");
    let link = SerialLink::open(
        pair.b.to_str().expect("utf8 path"),
        &map.serial_settings(None),
    )
    .expect("open pty");
    let mut y = ModbusStage::new("y", Box::new(link), Framing::Rtu, map, options());

    // The server may still be opening its end: retry the first status read briefly.
    let deadline = Instant::now() + Duration::from_secs(10);
    while y.status().is_err() {
        assert!(
            Instant::now() < deadline,
            "no answer from the pymodbus RTU server"
        );
    }
    let before = server.writes().len();
    assert_eq!(before, 0, "status reads write nothing");

    let status = y.home(Duration::from_secs(5)).expect("homing");
    assert!(
        status.homed && status.flags.contains(&"homing completed"),
        "{status}"
    );
    assert_eq!(status.position, Millimetres(0.0));

    let status = y
        .move_to(Millimetres(1.0), Duration::from_secs(5))
        .expect("absolute move");
    assert_eq!(status.position, Millimetres(1.0));
    let status = y
        .move_by(Millimetres(0.25), Duration::from_secs(5))
        .expect("relative move");
    assert_eq!(status.position, Millimetres(1.25));

    assert_eq!(
        server.writes(),
        vec![
            format!("6 {} {}", 0x6002, 0x20),
            // absolute, 2000 pulses, 60 rpm, 1667 ms/1000 rpm
            format!("16 {} 1 0 2000 60 1667 1667", 0x6200),
            format!("6 {} {}", 0x6002, 0x10),
            // relative (0x41), +500 pulses
            format!("16 {} 65 0 500 60 1667 1667", 0x6200),
            format!("6 {} {}", 0x6002, 0x10),
        ]
    );
}

#[test]
fn a_recorded_session_replays_through_the_driver() {
    use fringe_rig::{record_stream, ReplayLink, ReplayOptions, Trace};
    let port = free_port();
    let _server = Server::start(&["--profile", "az", "--tcp", &port.to_string()]);
    let dir = std::env::temp_dir().join(format!("fringe-ystage-record-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let link = record_stream(Box::new(connect(port)), Some(&dir), "ystage").expect("recording");
    let map = RegisterMap::load("oriental-az").expect("map");
    let mut y = ModbusStage::new("y", link, Framing::Tcp, map.clone(), options());
    y.move_to(Millimetres(1.0), Duration::from_secs(5))
        .expect("move");
    y.move_by(Millimetres(0.5), Duration::from_secs(5))
        .expect("move");
    drop(y);

    // The same calls against the recording: the driver must send the recorded frames exactly.
    let trace = Trace::load(&dir.join("ystage.trace")).expect("recorded trace");
    assert!(
        trace.entries.len() >= 12,
        "writes and several polls recorded"
    );
    let (link, handle) = ReplayLink::new(
        trace,
        ReplayOptions {
            speed: f64::INFINITY,
        },
    );
    let mut y = ModbusStage::new("y", Box::new(link), Framing::Tcp, map, options());
    assert_eq!(
        y.move_to(Millimetres(1.0), Duration::from_secs(5))
            .expect("replayed move")
            .position,
        Millimetres(1.0)
    );
    assert_eq!(
        y.move_by(Millimetres(0.5), Duration::from_secs(5))
            .expect("replayed move")
            .position,
        Millimetres(1.5)
    );
    handle.finish().expect("replay matches the recording");
    let _ = std::fs::remove_dir_all(&dir);
}
