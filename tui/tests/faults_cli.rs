//! Faults injected on the simulated bench (rig file `[[sim.faults]]`) during `fringe scan`: what
//! the user sees (one line naming the device and what to do), the state the bench is left in,
//! what the run keeps (it verifies, nothing lost or recorded twice), and the resume after each.

mod common;

use common::{
    events, fringe, fringe_command, label_rms, only_run, points_in, quick_netft_rig, resume,
    resume_to_the_end, scan_command, scan_files, scratch, text, the_run, wait_for_event, QUICK_RIG,
};
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::Duration;

/// The quick rig with `faults` (TOML `[[sim.faults]]` tables) appended, and the 3-point plan.
fn files_with(dir: &Path, faults: &str) -> (PathBuf, PathBuf, PathBuf) {
    let (clean_rig, plan) = scan_files(dir);
    let faulty = dir.join("faulty-rig.toml");
    std::fs::write(&faulty, format!("{QUICK_RIG}\n{faults}")).expect("rig file");
    (faulty, clean_rig, plan)
}

fn scan(rig: &Path, plan: &Path, root: &Path) -> Output {
    scan_command(rig, root, plan)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .expect("run fringe scan")
}

fn stop_status(run: &Path) -> String {
    std::fs::read_to_string(run.join("stop.json")).expect("stop.json")
}

/// A count field of the run's stop.json.
fn stop_count(run: &Path, key: &str) -> u64 {
    let stop = stop_status(run);
    stop.split(&format!("\"{key}\":"))
        .nth(1)
        .and_then(|s| s.split([',', '}']).next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("{key} in stop.json: {stop}"))
}

/// The run's `end-state` event: what the bench was left in.
fn end_state(run: &Path) -> String {
    events(run)
        .into_iter()
        .find(|e| e.contains("\"kind\":\"end-state\""))
        .expect("the end state is in the run's events")
}

/// Checks a scan that went on through its fault: completed, every point once, verified.
fn completed_run(out: &Output, root: &Path) -> PathBuf {
    let t = text(out);
    assert!(out.status.success(), "{t}");
    assert!(t.contains("completed: 3 of 3 points"), "{t}");
    let run = only_run(root);
    assert_eq!(points_in(&run), vec![0, 1, 2]);
    let verify = fringe(&["verify", run.to_str().expect("path")]);
    assert!(verify.status.success(), "{}", text(&verify));
    run
}

/// The last line fringe printed on stderr (its error).
fn error_line(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .rev()
        .find(|l| l.starts_with("fringe: "))
        .unwrap_or_default()
        .to_string()
}

/// Checks the run a fault ended: closed as failed, verified as it stands, the error one line
/// that names the device, says what to do and how to resume.
fn failed_run(out: &Output, root: &Path, device_words: &[&str], advice: &str) -> PathBuf {
    let t = text(out);
    assert!(!out.status.success(), "the scan should have failed: {t}");
    let line = error_line(out);
    for w in device_words {
        assert!(line.contains(w), "`{w}` not in the error line: {line}\n{t}");
    }
    assert!(line.contains(advice), "`{advice}` not in: {line}");
    let run = only_run(root);
    assert!(
        line.contains(&format!("fringe scan --resume {}", run.display())),
        "{line}"
    );
    assert!(
        stop_status(&run).contains("\"failed\""),
        "{}",
        stop_status(&run)
    );
    let verify = fringe(&["verify", run.to_str().expect("path")]);
    assert!(verify.status.success(), "{}", text(&verify));
    // Whatever was recorded belongs to whole points or to the point the fault cut.
    let _ = points_in(&run);
    run
}

#[test]
fn z_unplugged_mid_move_ends_the_scan_naming_z_and_the_run_resumes() {
    let dir = scratch("z-unplug");
    let (rig, clean, plan) = files_with(
        &dir,
        "[[sim.faults]]\ndevice = \"z\"\nfault = \"unplug\"\nafter = 6.0\nwhile_moving = true\n",
    );
    let root = dir.join("runs");
    let out = scan(&rig, &plan, &root);
    let run = failed_run(&out, &root, &["axis z"], "plug its cable back in");
    let end = end_state(&run);
    assert!(end.contains("z NOT retracted"), "{end}");
    resume_to_the_end(&clean, &run);
    assert!(
        events(&run)
            .iter()
            .any(|e| e.contains("resume-run") && e.contains("the run had failed")),
        "the resume says what it resumed from"
    );
}

#[test]
fn x_that_stops_answering_ends_the_scan_with_z_retracted_and_the_run_resumes() {
    let dir = scratch("x-silent");
    let (rig, clean, plan) = files_with(
        &dir,
        "[[sim.faults]]\ndevice = \"x\"\nfault = \"silent\"\nafter = 6.0\nwhile_moving = true\n",
    );
    let root = dir.join("runs");
    let out = scan(&rig, &plan, &root);
    let run = failed_run(&out, &root, &["axis x"], "stopped answering");
    let end = end_state(&run);
    assert!(
        end.contains("z retracted to 14.000 mm") && end.contains("x unreachable"),
        "{end}"
    );
    resume_to_the_end(&clean, &run);
}

#[test]
fn a_force_stream_that_stalls_stops_motion_and_the_scan_goes_on() {
    let dir = scratch("force-stall");
    let (rig, _clean, plan) = files_with(
        &dir,
        "[[sim.faults]]\ndevice = \"force\"\nfault = \"silent\"\nafter = 8.0\nduration = 0.5\n",
    );
    let root = dir.join("runs");
    let run = completed_run(&scan(&rig, &plan, &root), &root);
    assert!(
        events(&run)
            .iter()
            .any(|e| e.contains("point-interrupted") && e.contains("no force/torque data")),
        "the stall is in the run's events: {:?}",
        events(&run)
    );
}

#[test]
fn a_camera_that_stalls_and_resumes_costs_frames_not_the_run() {
    let dir = scratch("camera-stall");
    let (rig, _clean, plan) = files_with(
        &dir,
        "[[sim.faults]]\ndevice = \"camera\"\nfault = \"stall\"\nafter = 8.0\nduration = 1.0\n",
    );
    let root = dir.join("runs");
    let run = completed_run(&scan(&rig, &plan, &root), &root);
    // The frames of the stalled second are counted as dropped (the camera's default 50 fps).
    let dropped = stop_count(&run, "dropped_frames");
    assert!((35..=65).contains(&dropped), "{}", stop_status(&run));
}

#[test]
fn frames_out_of_order_are_all_recorded_once_and_not_counted_as_drops() {
    let dir = scratch("camera-reorder");
    let (rig, _clean, plan) = files_with(
        &dir,
        "[[sim.faults]]\ndevice = \"camera\"\nfault = \"reorder\"\nafter = 4.0\nduration = 12.0\n",
    );
    let root = dir.join("runs");
    let run = completed_run(&scan(&rig, &plan, &root), &root);
    let frames = std::fs::read_to_string(run.join("frames.jsonl")).expect("frames");
    let ids: Vec<u64> = frames
        .lines()
        .filter_map(|l| {
            l.split("\"frame_id\":")
                .nth(1)?
                .split([',', '}'])
                .next()?
                .trim()
                .parse()
                .ok()
        })
        .collect();
    assert!(!ids.is_empty());
    let mut sorted = ids.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), ids.len(), "a frame recorded twice");
    assert!(
        ids.windows(2).any(|w| w[1] < w[0]),
        "the frames were recorded in the order they arrived, some out of order"
    );
    // A late frame fills the gap it was first counted in: reordering is not dropping (before,
    // 3 s of reordered frames at 25 fps counted 75 drops).
    assert!(
        stop_count(&run, "dropped_frames") <= 2,
        "{}",
        stop_status(&run)
    );
}

/// The seeds of the SIGKILL test: `FRINGE_KILL_SEEDS` as `A-B` or `A,B,C` (`scripts/kills`
/// runs long campaigns), 1-3 in the normal test run.
fn kill_seeds() -> Vec<u64> {
    let spec = std::env::var("FRINGE_KILL_SEEDS").unwrap_or_else(|_| "1-3".into());
    let parse = |s: &str| -> u64 {
        s.trim()
            .parse()
            .unwrap_or_else(|_| panic!("FRINGE_KILL_SEEDS: `{s}` is not a seed in `{spec}`"))
    };
    match spec.split_once('-') {
        Some((a, b)) => (parse(a)..=parse(b)).collect(),
        None => spec.split(',').map(parse).collect(),
    }
}

/// Kills `fringe scan` sessions of one run at moments drawn from `seed` (anywhere in a session:
/// opening the rig, homing, taring, moving, pressing, checkpointing, closing), up to three times,
/// each kill followed by `--resume`; then resumes to the end. Returns the kill moments.
fn kill_and_resume(seed: u64) -> Vec<Duration> {
    let dir = scratch(&format!("kills-{seed}"));
    let (rig, plan) = scan_files(&dir);
    let root = dir.join("runs");
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut kills = Vec::new();
    for _ in 0..3 {
        let mut cmd = fringe_command();
        cmd.args(["scan", "--yes", "--rig"]).arg(&rig);
        // Killed before its start document was written, a run is not there to resume: the
        // next session starts it again.
        match the_run(&root) {
            Some(run) => cmd.arg("--resume").arg(run),
            None => cmd.arg("--out").arg(&root).arg(&plan),
        };
        let mut child = cmd
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn");
        // A whole session of the 3-point plan lasts 15-20 s.
        let delay = Duration::from_millis(next() % 16_000);
        let until = std::time::Instant::now() + delay;
        while std::time::Instant::now() < until && child.try_wait().expect("wait").is_none() {
            std::thread::sleep(Duration::from_millis(5));
        }
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        child.kill().expect("kill");
        let _ = child.wait();
        kills.push(delay);
    }
    let out = match the_run(&root) {
        Some(run) => resume(&rig, &run),
        None => scan(&rig, &plan, &root),
    };
    let t = text(&out);
    // The last session may have ended the run already.
    assert!(
        out.status.success() || t.contains("has ended"),
        "seed {seed}, kills {kills:?}: final session: {t}"
    );
    let run = the_run(&root).expect("a run");
    assert_eq!(
        points_in(&run),
        vec![0, 1, 2],
        "seed {seed}, kills {kills:?}"
    );
    let verify = fringe(&["verify", run.to_str().expect("path")]);
    assert!(
        verify.status.success(),
        "seed {seed}, kills {kills:?}: {}",
        text(&verify)
    );
    kills
}

#[test]
fn runs_killed_at_random_moments_end_complete_for_every_seed() {
    for seed in kill_seeds() {
        let kills = kill_and_resume(seed);
        eprintln!("seed {seed}: killed after {kills:?}, then complete and verified");
    }
}

#[test]
fn a_second_process_cannot_write_a_run_being_written_and_a_killed_writers_lock_is_taken_over() {
    let dir = scratch("two-writers");
    let (rig, plan) = scan_files(&dir);
    let root = dir.join("runs");
    let mut first = scan_command(&rig, &root, &plan).spawn().expect("spawn");
    // Once the first point is under way, a resume of the same run is refused, naming the pid.
    let run = wait_for_event(&root, &mut first, |e| e.contains("\"kind\":\"contact\""));
    let second = resume(&rig, &run);
    let t = text(&second);
    assert!(!second.status.success(), "a second writer ran: {t}");
    assert!(
        t.contains("in use") && t.contains(&format!("pid {}", first.id())),
        "{t}"
    );
    // Nor can the run be exported while it is written.
    let export = fringe(&[
        "export",
        run.to_str().expect("path"),
        "--out",
        dir.join("export").to_str().expect("path"),
    ]);
    assert!(!export.status.success());
    assert!(text(&export).contains("in use"), "{}", text(&export));
    // The writer is killed: its lock goes with it, and the resume takes the run over.
    first.kill().expect("kill -9");
    let _ = first.wait();
    // A resume on a rig that films at another size is refused before the run is touched.
    let other = dir.join("other-size.toml");
    std::fs::write(
        &other,
        QUICK_RIG.replace("image_scale = 0.25", "image_scale = 0.125"),
    )
    .expect("rig file");
    let frames_before = std::fs::read(run.join("frames.jsonl")).expect("frames");
    let refused = resume(&other, &run);
    let t = text(&refused);
    assert!(!refused.status.success(), "{t}");
    assert!(t.contains("sim.image_scale: 0.25 -> 0.125"), "{t}");
    assert_eq!(
        std::fs::read(run.join("frames.jsonl")).expect("frames"),
        frames_before
    );
    resume_to_the_end(&rig, &run);
    assert!(
        !run.join(".lock").exists(),
        "the lock file is gone with its writer"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The disk filling up during a run: the runs directory is a tmpfs mounted in a private mount
/// namespace (`unshare -rm`: no root needed where user namespaces are allowed), of 2 GB while
/// the scan checks for room before it starts (a size limit, not memory taken), shrunk to 3 MB
/// once the run exists (the rig is homing: nothing filmed yet), made large again before the
/// resume.
#[test]
fn a_full_disk_stops_the_scan_saying_so_and_the_run_resumes_once_there_is_space() {
    let dir = scratch("disk-full");
    let (rig, plan) = scan_files(&dir);
    let root = dir.join("runs");
    std::fs::create_dir_all(&root).expect("runs dir");
    let script = r#"
set -u
mount -t tmpfs -o size=2g fringe-test "$ROOT" || exit 90
"$FRINGE" scan --yes --rig "$RIG" --out "$ROOT" "$PLAN" >"$DIR/first.txt" 2>&1 &
scan=$!
while [ -z "$(ls -A "$ROOT")" ] && kill -0 "$scan" 2>/dev/null; do sleep 0.02; done
mount -o remount,size=3m "$ROOT" || exit 92
wait "$scan"
echo $? >"$DIR/first.rc"
run=$(ls -d "$ROOT"/*/ | head -n 1)
echo "$run" >"$DIR/run.txt"
"$FRINGE" verify "$run" >"$DIR/verify-first.txt" 2>&1
echo $? >"$DIR/verify-first.rc"
mount -o remount,size=2g "$ROOT" || exit 91
"$FRINGE" scan --yes --rig "$RIG" --resume "$run" >"$DIR/resume.txt" 2>&1
echo $? >"$DIR/resume.rc"
"$FRINGE" verify "$run" >"$DIR/verify.txt" 2>&1
echo $? >"$DIR/verify.rc"
cp "$run/frames.jsonl" "$run/events.jsonl" "$DIR/"
"#;
    let status = std::process::Command::new("unshare")
        .args(["-rm", "sh", "-c", script])
        .env("ROOT", &root)
        .env("DIR", &dir)
        .env("RIG", &rig)
        .env("PLAN", &plan)
        .env("FRINGE", env!("CARGO_BIN_EXE_fringe"))
        .status()
        .expect("unshare (util-linux) runs the test in its own mount namespace");
    assert!(
        status.success(),
        "the namespace script failed ({status}): 90 = tmpfs mount refused, 91 or 92 = remount refused"
    );
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    let first = read("first.txt");
    assert_ne!(read("first.rc").trim(), "0", "{first}");
    let line = first
        .lines()
        .rev()
        .find(|l| l.starts_with("fringe: "))
        .unwrap_or_default();
    assert!(line.contains("free space on the disk"), "{first}");
    assert!(line.contains("fringe scan --resume"), "{line}");
    assert_eq!(
        read("verify-first.rc").trim(),
        "0",
        "{}",
        read("verify-first.txt")
    );
    assert_eq!(read("resume.rc").trim(), "0", "{}", read("resume.txt"));
    assert!(read("resume.txt").contains("completed: 3 of 3 points"));
    assert_eq!(read("verify.rc").trim(), "0", "{}", read("verify.txt"));
    // Every point once, in order (frames.jsonl copied out of the namespace into `dir`).
    assert_eq!(points_in(&dir), vec![0, 1, 2]);
}

#[test]
fn a_burst_of_udp_loss_from_the_net_ft_is_counted_and_the_scan_goes_on() {
    let dir = scratch("udp-loss");
    let (_, plan) = scan_files(&dir);
    let rig = dir.join("netft-rig.toml");
    let text_rig = quick_netft_rig()
        + "\n[[sim.faults]]\ndevice = \"force\"\nfault = \"loss\"\nafter = 8.0\nwhile_streaming = true\nduration = 0.3\n";
    std::fs::write(&rig, text_rig).expect("rig file");
    let root = dir.join("runs");
    let run = completed_run(&scan(&rig, &plan, &root), &root);
    // 0.3 s of the simulated Net F/T's 7000 Hz stream (one record per datagram). The burst
    // lands inside the scan's stream (`while_streaming`): on a loaded machine the rig can take
    // longer than `after` to open and home, and a burst that overlaps the stream's start
    // request loses records the stream never counted (it numbers its records from its start).
    let lost = stop_count(&run, "lost_force_samples");
    assert!((1750..=2450).contains(&lost), "{}", stop_status(&run));
}

#[test]
fn a_net_ft_box_that_reboots_is_asked_to_stream_again_and_the_labels_stay_true() {
    let dir = scratch("netft-reboot");
    let (_, plan) = scan_files(&dir);
    let rig = dir.join("netft-rig.toml");
    let text_rig = quick_netft_rig()
        + "\n[[sim.faults]]\ndevice = \"force\"\nfault = \"reboot\"\nafter = 11.0\nduration = 1.5\n";
    std::fs::write(&rig, text_rig).expect("rig file");
    let root = dir.join("runs");
    let out = scan(&rig, &plan, &root);
    let run = completed_run(&out, &root);
    let t = text(&out);
    // What the user sees: motion stopped while the box was down, then the restart named, with
    // what it means and what to check.
    let events = events(&run);
    assert!(
        events
            .iter()
            .any(|e| e.contains("point-interrupted") && e.contains("no force/torque data")),
        "{events:?}"
    );
    let warning = t
        .lines()
        .find(|l| l.contains("warning: force sensor") && l.contains("restarted"))
        .unwrap_or_else(|| panic!("no restart warning in\n{t}"));
    for words in ["netft", "1 time(s)", "tare", "check the box's power supply"] {
        assert!(warning.contains(words), "`{words}` not in: {warning}");
    }
    assert!(
        events
            .iter()
            .any(|e| e.contains("\"warning\"") && e.contains("restarted")),
        "{events:?}"
    );
    // The transducer came back with another zero; every point's own tare keeps the labels true.
    let rms = label_rms(&t);
    assert!(rms < 0.1, "labels off by {rms} N RMS after the reboot\n{t}");
}

/// libfaketime's multi-threaded preload library (Debian: `apt install faketime`).
fn libfaketime() -> PathBuf {
    std::fs::read_dir("/usr/lib")
        .into_iter()
        .flatten()
        .filter_map(Result::ok)
        .map(|e| e.path().join("faketime/libfaketimeMT.so.1"))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("libfaketime is not installed: apt install faketime"))
}

/// The value of a `"key": "..."` string field of a run document.
fn utc_field(doc: &str, key: &str) -> String {
    doc.split(&format!("\"{key}\": \""))
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap_or_else(|| panic!("{key} in {doc}"))
        .to_string()
}

#[test]
fn the_wall_clock_stepping_back_an_hour_mid_scan_changes_nothing_but_the_utc_strings() {
    let dir = scratch("clock-step");
    let (rig, plan) = scan_files(&dir);
    // libfaketime moves the process's wall clock (CLOCK_REALTIME) by what the file says, read
    // again every second; the monotonic clock stays true, as NTP or `date -s` leave it.
    let offset = dir.join("faketime");
    std::fs::write(&offset, "+0\n").expect("offset file");
    let root = dir.join("runs");
    let mut child = scan_command(&rig, &root, &plan)
        .env("LD_PRELOAD", libfaketime())
        .env("FAKETIME_TIMESTAMP_FILE", &offset)
        .env("FAKETIME_CACHE_DURATION", "1")
        .env("DONT_FAKE_MONOTONIC", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run fringe scan");
    // Mid-scan: after the first point's contact.
    wait_for_event(&root, &mut child, |e| e.contains("\"kind\":\"contact\""));
    std::fs::write(&offset, "-1h\n").expect("step the clock");
    let out = child.wait_with_output().expect("fringe scan");
    let run = completed_run(&out, &root);
    // The step happened: the run's documents carry the wall clock as it was, an hour back at
    // the end (RFC 3339 UTC strings of one format compare as times).
    let started = utc_field(
        &std::fs::read_to_string(run.join("start.json")).expect("start"),
        "started_utc",
    );
    let stopped = utc_field(&stop_status(&run), "stopped_utc");
    assert!(stopped < started, "stopped {stopped}, started {started}");
    // Nothing else: every point once (checked above), no frame dropped, the labels as true as
    // on a steady clock.
    assert_eq!(
        stop_count(&run, "dropped_frames"),
        0,
        "{}",
        stop_status(&run)
    );
    let t = text(&out);
    let rms = label_rms(&t);
    assert!(rms < 0.1, "labels off by {rms} N RMS\n{t}");
}
