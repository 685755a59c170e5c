//! `fringe sim serve` in one process, driven by fringe's own bring-up commands in others, through
//! the endpoints it prints.

mod common;

use common::{fringe, text};
use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

struct Serve(Child);

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `fringe sim serve` with the x controller also at `link` (and the Net F/T at
/// `netft`); the server and the endpoints it printed.
fn serve(link: &std::path::Path, netft: &str) -> (Serve, HashMap<String, String>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .args([
            "sim",
            "serve",
            "--netft",
            netft,
            "--modbus",
            "127.0.0.1:0",
            "--seconds",
            "60",
            "--apt-x",
        ])
        .arg(link)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start fringe sim serve");
    let stdout = child.stdout.take().expect("stdout");
    let serve = Serve(child);
    let mut endpoints = HashMap::new();
    for line in BufReader::new(stdout).lines() {
        let line = line.expect("line");
        if line == "ready" {
            break;
        }
        let (k, v) = line.split_once(' ').expect("`name value`");
        endpoints.insert(k.to_string(), v.to_string());
    }
    (serve, endpoints)
}

#[test]
fn served_devices_answer_the_bring_up_commands() {
    let link = std::env::temp_dir().join(format!("fringe-apt-x-{}", std::process::id()));
    let (_serve, endpoints) = serve(&link, "127.0.0.1:0");
    for key in [
        "apt-x",
        "apt-z",
        "netft",
        "netft-http",
        "modbus-tcp",
        "modbus-rtu",
    ] {
        assert!(
            endpoints.contains_key(key),
            "{key} missing from {endpoints:?}"
        );
    }

    // The x controller through the stable link name.
    let out = fringe(&[
        "axis",
        "--port",
        link.to_str().expect("utf-8"),
        "--actuator",
        "ZFS25",
        "--velocity",
        "2",
        "--acceleration",
        "4",
        "move-rel",
        "1.5",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("KST101"), "{}", text(&out));

    let csv = std::env::temp_dir().join(format!("fringe-serve-ft-{}.csv", std::process::id()));
    let out = fringe(&[
        "ft",
        "--netft",
        &endpoints["netft"],
        "--cpf",
        "1000000",
        "--cpt",
        "1000000",
        "stream",
        "--seconds",
        "1",
        "--csv",
        csv.to_str().expect("utf-8"),
    ]);
    let report = text(&out);
    assert!(out.status.success(), "{report}");
    assert!(report.contains("lost packets: 0"), "{report}");
    let rows = std::fs::read_to_string(&csv).expect("csv").lines().count();
    assert!(rows > 5000, "{rows} rows in 1 s at 7 kHz");
    let _ = std::fs::remove_file(&csv);
    // As the README shows it: the scaling read from the box, whose page the server puts on TCP
    // at the RDT port (nothing listens on port 80 here, where a real box serves it).
    let (ip, port) = endpoints["netft"].rsplit_once(':').expect("ip:port");
    assert_eq!(
        endpoints["netft-http"],
        format!("http://{ip}:{port}/netftapi2.xml")
    );
    let out = fringe(&[
        "ft",
        "--netft",
        &endpoints["netft"],
        "stream",
        "--seconds",
        "1",
        "--csv",
        csv.to_str().expect("utf-8"),
    ]);
    let report = text(&out);
    assert!(out.status.success(), "{report}");
    assert!(report.contains("lost packets: 0"), "{report}");
    let _ = std::fs::remove_file(&csv);

    let out = fringe(&[
        "ystage",
        "--modbus-tcp",
        &endpoints["modbus-tcp"],
        "--map",
        "leadshine-pr",
        "move",
        "3",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let out = fringe(&[
        "ystage",
        "--modbus-rtu",
        &endpoints["modbus-rtu"],
        "--map",
        "leadshine-pr",
        "status",
    ]);
    let status = text(&out);
    assert!(out.status.success(), "{status}");
    // The RTU and TCP ports drive the same simulated stage.
    assert!(status.contains("position 3.0000"), "{status}");
    drop(_serve);
    std::thread::sleep(std::time::Duration::from_millis(200));
}

/// `fringe axis` keeps a ZFS25 within its 25 mm travel unless told otherwise, and a homed axis
/// resting on its home switch (the emulated controller reports the switch, as a real one does)
/// shows no fault.
#[test]
fn an_axis_keeps_to_its_travel_and_rests_on_its_home_switch_without_a_fault() {
    let link = std::env::temp_dir().join(format!("fringe-apt-travel-{}", std::process::id()));
    let (_serve, _) = serve(&link, "127.0.0.1:0");
    let axis = |args: &[&str]| {
        let mut full = vec![
            "axis",
            "--port",
            link.to_str().expect("utf-8"),
            "--actuator",
            "ZFS25",
            "--velocity",
            "2",
            "--acceleration",
            "4",
        ];
        full.extend_from_slice(args);
        fringe(&full)
    };
    let out = axis(&["home"]);
    let homed = text(&out);
    assert!(out.status.success(), "{homed}");
    assert!(homed.contains("position: 0.0000"), "{homed}");
    assert!(homed.contains("homed: true"), "{homed}");
    assert!(
        !homed.contains("faults:"),
        "a normal home is no fault:\n{homed}"
    );
    let out = axis(&["status"]);
    let status = text(&out);
    assert!(out.status.success(), "{status}");
    // The switch is still reported as what it is, among the status bits.
    assert!(status.contains("reverse limit switch"), "{status}");
    assert!(!status.contains("faults:"), "{status}");
    // Past the travel: refused before anything moves, naming the travel and the override.
    let out = axis(&["move", "40"]);
    let refused = text(&out);
    assert!(!out.status.success(), "{refused}");
    for needle in [
        "outside the soft limits 0.0000 mm .. 25.0000 mm",
        "nothing was sent",
        "ZFS25's travel is 25 mm",
        "--min MM --max MM",
    ] {
        assert!(refused.contains(needle), "{needle:?} missing:\n{refused}");
    }
    let out = axis(&["status"]);
    assert!(text(&out).contains("position: 0.0000"), "{}", text(&out));
    // Within the travel the move runs; off the switch the status is clean too.
    let out = axis(&["move", "1.5"]);
    let moved = text(&out);
    assert!(out.status.success(), "{moved}");
    assert!(moved.contains("position: 1.5000"), "{moved}");
    assert!(!moved.contains("limit switch"), "{moved}");
}
