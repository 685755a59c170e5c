//! Errors as a user meets them: every class of mistake a user can make from the command line
//! (bad or missing files, a directory that is not a run, an unwritable output directory, a
//! device path that is absent or is not the device, an unreachable sensor) ends the command with
//! a non-zero status and exactly one line that names the file, key or device and says what to
//! do. The scan's own failures (a device lost mid-run, a full disk) are in `faults_cli.rs`.

mod common;

use common::{fringe_command, scratch, text};
use std::path::Path;

/// Runs `fringe args` in `dir`; checks the one-line error and that it holds every `needle`.
fn refused(dir: &Path, args: &[&str], needles: &[&str]) {
    let out = fringe_command()
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run fringe");
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "fringe {args:?}:\n{all}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    let errors: Vec<&&str> = lines.iter().filter(|l| l.starts_with("fringe: ")).collect();
    assert_eq!(errors.len(), 1, "fringe {args:?}: one error line:\n{all}");
    assert_eq!(
        lines.last(),
        Some(*errors.first().expect("one")),
        "fringe {args:?}: the error is the last line:\n{all}"
    );
    for needle in needles {
        assert!(
            errors[0].contains(needle),
            "fringe {args:?}: {needle:?} missing from:\n{}",
            errors[0]
        );
    }
}

#[test]
fn bad_and_missing_files_name_the_file_and_what_to_do() {
    let dir = scratch("files");
    std::fs::write(dir.join("broken.toml"), "name = \"x\"\n[grid\n").expect("plan");
    std::fs::write(dir.join("rig.toml"), "[camera]\nframe_rat = 50\n").expect("rig");
    std::fs::write(dir.join("model.pth"), "not a model").expect("model");
    // A plan that cannot be found, one that is not TOML.
    refused(
        &dir,
        &["scan", "absent.toml", "--dry-run"],
        &[
            "absent.toml: cannot read the plan",
            "check the path",
            "built-in plans",
        ],
    );
    refused(
        &dir,
        &["scan", "broken.toml", "--dry-run"],
        &["broken.toml", "line 2"],
    );
    // A rig file that cannot be found; a key it does not know, with the keys it does.
    refused(
        &dir,
        &["scan", "--rig", "absent-rig.toml", "--dry-run"],
        &[
            "absent-rig.toml",
            "cannot read the rig file",
            "tui/app/rigs/",
        ],
    );
    refused(
        &dir,
        &["scan", "--rig", "rig.toml", "--dry-run"],
        &[
            "rig.toml: line 2, section [camera]",
            "frame_rat",
            "frame_rate",
        ],
    );
    // Model files: absent, not a model.
    refused(
        &dir,
        &["model", "info", "absent.pth"],
        &["absent.pth: no such model file", "`default`"],
    );
    refused(
        &dir,
        &["model", "info", "model.pth"],
        &["model.pth: not a PyTorch or safetensors file"],
    );
    // A spec that holds a model to nothing (it would pass any model): refused before any data
    // is read, naming the file and what to add.
    std::fs::write(dir.join("empty.toml"), "").expect("spec");
    refused(
        &dir,
        &["eval", "--spec", "empty.toml", "absent"],
        &["spec empty.toml: no threshold", "add at least one of"],
    );
    std::fs::write(
        dir.join("range.toml"),
        "[[force_range]]\nfrom_n = 0.0\nto_n = 3.0\n",
    )
    .expect("spec");
    refused(
        &dir,
        &["eval", "--spec", "range.toml", "absent"],
        &["spec range.toml: `force_range[0]`", "has no threshold"],
    );
    // A camera trace that is not there.
    refused(
        &dir,
        &["camera", "--replay", "no-trace", "grab", "--out", "frames"],
        &["no-trace", "--record-trace"],
    );
}

#[test]
fn a_directory_that_is_not_a_run_says_where_runs_are_listed() {
    let dir = scratch("not-a-run");
    std::fs::create_dir_all(dir.join("empty")).expect("dir");
    for args in [
        &["scan", "--resume", "empty", "--yes"][..],
        &["verify", "empty"],
        &["export", "empty", "--out", "dataset"],
        &["export", "absent", "--out", "dataset"],
    ] {
        refused(&dir, args, &["is not a run", "fringe runs"]);
    }
    for args in [&["eval", "absent"][..], &["eval", "empty"]] {
        refused(&dir, args, &["run", "dataset"]);
    }
    refused(
        &dir,
        &["eval", "absent"],
        &["absent: no such run or dataset", "fringe runs"],
    );
    refused(
        &dir,
        &["runs", "--root", "absent"],
        &["absent: no such directory", "--root"],
    );
}

#[test]
fn an_output_directory_that_cannot_be_made_names_it_and_the_option() {
    let dir = scratch("out");
    // /proc refuses new directories even to root.
    refused(
        &dir,
        &["scan", "--yes", "--out", "/proc/fringe-runs"],
        &[
            "/proc/fringe-runs",
            "cannot make the directory for the runs",
            "--out",
        ],
    );
}

#[test]
fn absent_or_wrong_devices_name_the_device_and_what_to_check() {
    let dir = scratch("devices");
    // A serial port that does not exist, and a path that is not a serial port at all.
    refused(
        &dir,
        &[
            "axis",
            "--port",
            "/dev/ttyFRINGE-ABSENT",
            "--actuator",
            "ZFS25",
            "status",
        ],
        &["/dev/ttyFRINGE-ABSENT", "fringe devices", "dialout"],
    );
    refused(
        &dir,
        &[
            "axis",
            "--port",
            "/dev/null",
            "--actuator",
            "ZFS25",
            "status",
        ],
        &["/dev/null", "fringe devices"],
    );
    refused(
        &dir,
        &["ystage", "--modbus-rtu", "/dev/ttyFRINGE-ABSENT", "status"],
        &["/dev/ttyFRINGE-ABSENT", "fringe devices"],
    );
    // Nothing listening: a Modbus TCP stage, an F/T sensor; a name that cannot resolve.
    let closed = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port();
    let stage = format!("127.0.0.1:{closed}");
    refused(
        &dir,
        &["ystage", "--modbus-tcp", &stage, "status"],
        &[&stage, "powered"],
    );
    refused(
        &dir,
        &["ft", "--netft", "fringe-absent.invalid", "bias"],
        &["cannot resolve fringe-absent.invalid", "IP address"],
    );
}
