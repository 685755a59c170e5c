//! The terminal UI end to end: the real `fringe` binary in a tmux pane (its own tmux server),
//! driven with `send-keys` and read with `capture-pane`, on the simulated bench. Needs tmux
//! (`apt install tmux`; `.ci/run` installs it).

mod common;

use common::{quick_netft_rig, scratch};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// One tmux server (own socket) with one 160x48 pane running a command; killed on drop.
struct Pane {
    socket: String,
    _serial: MutexGuard<'static, ()>,
}

/// One UI at a time: each runs the simulated bench in real time, and two would share 2 cores.
static SERIAL: Mutex<()> = Mutex::new(());

impl Pane {
    fn start(name: &str, dir: &Path, command: &str) -> Pane {
        let serial = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
        let socket = format!("fringe-{name}-{}", std::process::id());
        let pane = Pane {
            socket,
            _serial: serial,
        };
        // The shell prints the exit status and stays, so the screen after quitting can be read.
        let script = format!("{command}; echo \"fringe exited $?\"; sleep 600");
        let out = pane.tmux(&[
            "new-session",
            "-d",
            "-x",
            "160",
            "-y",
            "48",
            "-c",
            &dir.display().to_string(),
            "sh",
            "-c",
            &script,
        ]);
        assert!(
            out.status.success(),
            "tmux new-session: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        pane
    }

    fn tmux(&self, args: &[&str]) -> Output {
        Command::new("tmux")
            .args(["-L", &self.socket, "-f", "/dev/null"])
            .args(args)
            .env_remove("TMUX")
            .output()
            .unwrap_or_else(|e| panic!("tmux (apt install tmux): {e}"))
    }

    fn keys(&self, keys: &str) {
        let out = self.tmux(&["send-keys", "-t", "0", keys]);
        assert!(out.status.success(), "send-keys {keys}");
    }

    fn screen(&self) -> String {
        String::from_utf8_lossy(&self.tmux(&["capture-pane", "-p", "-t", "0"]).stdout).into_owned()
    }

    fn flag(&self, name: &str) -> String {
        let out = self.tmux(&["display-message", "-p", "-t", "0", &format!("#{{{name}}}")]);
        String::from_utf8_lossy(&out.stdout).trim().to_string()
    }

    /// Waits until the screen shows `text`; the screen on success, a failure with the last
    /// screen otherwise.
    fn wait_for(&self, text: &str, timeout: Duration) -> String {
        self.wait_until(text, timeout, |s| s.contains(text))
    }

    fn wait_until(&self, what: &str, timeout: Duration, ok: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let screen = self.screen();
            if ok(&screen) {
                return screen;
            }
            if start.elapsed() > timeout {
                panic!("waited {timeout:?} for {what}; the screen:\n{screen}");
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Waits for `text` while the scan runs, continuing it when the engine's watchers pause it
    /// (a loaded test machine can drop frames: the real rig's safety, not the UI's).
    fn wait_answering(&self, text: &str, timeout: Duration) -> String {
        let start = Instant::now();
        loop {
            let screen = self.screen();
            if screen.contains(text) {
                return screen;
            }
            if screen.contains("resume?") {
                self.keys("Enter");
            }
            if start.elapsed() > timeout {
                panic!("waited {timeout:?} for {text}; the screen:\n{screen}");
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// Quits with `q` and checks the terminal is back: primary screen, cursor shown, exit 0.
    /// The screen after quitting.
    fn quit_cleanly(&self) -> String {
        self.keys("q");
        let screen = self.wait_for("fringe exited", Duration::from_secs(30));
        assert!(screen.contains("fringe exited 0"), "{screen}");
        assert!(
            !screen.contains("1 Scan"),
            "the UI is left on screen:\n{screen}"
        );
        assert_eq!(self.flag("alternate_on"), "0", "alternate screen left on");
        assert_eq!(self.flag("cursor_flag"), "1", "cursor left hidden");
        screen
    }
}

impl Drop for Pane {
    fn drop(&mut self) {
        let _ = self.tmux(&["kill-server"]);
    }
}

fn fringe() -> String {
    env!("CARGO_BIN_EXE_fringe").to_string()
}

/// The runs written under `dir/runs`, with their stop.json.
fn runs(dir: &Path) -> Vec<(PathBuf, serde_json::Value)> {
    let Ok(entries) = std::fs::read_dir(dir.join("runs")) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| e.ok())
        .map(|e| {
            let stop = std::fs::read_to_string(e.path().join("stop.json"))
                .ok()
                .and_then(|s| serde_json::from_str(&s).ok())
                .unwrap_or(serde_json::Value::Null);
            (e.path(), stop)
        })
        .collect()
}

#[test]
fn the_built_in_scan_runs_from_the_ui_with_a_pause_and_the_terminal_is_restored() {
    let dir = scratch("scan");
    // The quick bench: frames at a quarter of the full size and axes at 8 mm/s (the UI flow
    // under test is the same at any frame size and speed; the full-size bench's scan is
    // demo_cli's and default_model's, and the Bench screen's test opens the default bench).
    std::fs::write(dir.join("rig.toml"), common::QUICK_RIG).expect("rig file");
    let pane = Pane::start("scan", &dir, &fringe());
    let screen = pane.wait_for("ready: press r to run", Duration::from_secs(30));
    // Before it runs, the plan is drawn on the unit's disc (its design's, on the simulated
    // bench), close up: the plan is small on it.
    assert!(
        screen.contains("short-grid: 6 points · ×") && screen.contains("d: whole disc"),
        "{screen}"
    );
    pane.keys("r");
    pane.wait_for("point 1 of 6", Duration::from_secs(30));
    // Pause after the current press: the scan stops with z up and asks to resume.
    pane.keys("p");
    let screen = pane.wait_for("scan paused", Duration::from_secs(60));
    assert!(screen.contains("resume?"), "{screen}");
    pane.keys("c");
    pane.wait_for("resumed", Duration::from_secs(10));
    let screen = pane.wait_answering("completed:", Duration::from_secs(240));
    assert!(screen.contains("100 %"), "{screen}");
    // While nothing runs, the Runs screen lists the run the UI recorded.
    pane.keys("3");
    let runs_screen = pane.wait_for("completed", Duration::from_secs(5));
    let recorded = runs(&dir);
    assert_eq!(recorded.len(), 1, "{runs_screen}");
    let (run, stop) = &recorded[0];
    assert_eq!(stop["exit_status"], "completed", "{}", run.display());
    let name = run.file_name().map(|n| n.to_string_lossy().into_owned());
    assert!(
        runs_screen.contains(name.as_deref().unwrap_or("?")),
        "{runs_screen}"
    );
    // Verify it from the UI, then evaluate the model that ships on it.
    pane.keys("Enter");
    pane.wait_for("ok:", Duration::from_secs(60));
    pane.keys("e");
    let figures = pane.wait_until(
        "the model's figures on the run",
        Duration::from_secs(180),
        |s| s.contains(" mm · shape "),
    );
    assert!(figures.contains("Fz "), "{figures}");
    assert!(!figures.contains("cannot evaluate"), "{figures}");
    // Export it in the reference layout from the UI.
    pane.keys("x");
    let exported = pane.wait_until("the export", Duration::from_secs(180), |s| {
        s.contains("exported ") || s.contains("cannot export")
    });
    assert!(!exported.contains("cannot export"), "{exported}");
    let out = dir.join("exports").join(name.as_deref().unwrap_or("?"));
    let labels = std::fs::read_to_string(out.join("0.labels.csv"))
        .unwrap_or_else(|e| panic!("{}: {e}\n{exported}", out.display()));
    assert!(
        labels.lines().count() > 100,
        "{} label lines",
        labels.lines().count()
    );
    // Quitting says where the session's run went.
    let after = pane.quit_cleanly();
    assert!(after.contains("fringe: 1 scan in this session:"), "{after}");
    assert!(
        after.contains("short-grid: completed: 6 of 6 points")
            && after.contains(name.as_deref().unwrap_or("?")),
        "{after}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The z row of the Bench screen's device table: its position, mm.
fn z_position(screen: &str) -> Option<f64> {
    chosen_position(screen, "z")
}

/// The position of the chosen `axis` (marked ▶) in the Bench screen's device table, mm.
fn chosen_position(screen: &str, axis: &str) -> Option<f64> {
    let mark = format!("▶ {axis}");
    let line = screen.lines().find(|l| l.contains(&mark))?;
    let after = line.split(&mark).nth(1)?;
    after.split_whitespace().next()?.parse().ok()
}

/// The Bench screen's F/T Fz, N.
fn bench_fz(screen: &str) -> Option<f64> {
    let line = screen.lines().find(|l| l.contains("F/T  Fz"))?;
    let after = line.split("F/T  Fz").nth(1)?;
    after.split_whitespace().next()?.parse().ok()
}

/// The right-hand column of the Bench screen (the frame, then the messages, newest first) as
/// one line: a message wrapped over several lines of the pane reads whole.
fn bench_said(screen: &str) -> String {
    let text: Vec<String> = screen
        .lines()
        .map(|l| {
            l.chars()
                .skip(96)
                .collect::<String>()
                .trim_matches(|c: char| c == '│' || c.is_whitespace())
                .to_string()
        })
        .collect();
    text.join(" ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// Waits until z, chosen, was homed and rests at its home (0 mm), then a second more: the bench
/// takes a motion as finished only from a status polled 0.3 s after it began, and z as at its
/// home (where the F/T's no-contact reading is taken) from then.
fn z_homed(pane: &Pane) -> String {
    let screen = pane.wait_until("z homed, idle at 0 mm", Duration::from_secs(60), |s| {
        s.lines().any(|l| {
            l.contains("▶ z")
                && l.contains("homed")
                && !l.contains("not homed")
                && l.contains("idle")
        }) && z_position(s).is_some_and(|p| p.abs() < 0.01)
    });
    std::thread::sleep(Duration::from_secs(1));
    screen
}

/// Waits until z, chosen, rests at `mm`.
fn z_rests_at(pane: &Pane, mm: f64) -> String {
    pane.wait_until(&format!("z at {mm} mm"), Duration::from_secs(30), |s| {
        s.lines().any(|l| l.contains("▶ z") && l.contains("idle"))
            && z_position(s).is_some_and(|p| (p - mm).abs() < 0.01)
    })
}

#[test]
fn the_bench_screen_homes_and_jogs_z_within_its_soft_limits() {
    let dir = scratch("bench");
    let pane = Pane::start("bench", &dir, &fringe());
    pane.wait_for("ready: press r to run", Duration::from_secs(30));
    pane.keys("4");
    let screen = pane.wait_until("the bench open", Duration::from_secs(30), |s| {
        s.contains("bench open") && z_position(s).is_some()
    });
    assert!(screen.contains("soft limits"), "{screen}");
    assert!(screen.contains("fps"), "{screen}");
    // Home z, then jog it by 1 mm (the step goes 0.1 -> 1 mm with s).
    pane.keys("h");
    pane.wait_for("z: homing", Duration::from_secs(10));
    let homed = pane.wait_until("z homed and idle", Duration::from_secs(60), |s| {
        s.lines()
            .any(|l| l.contains("▶ z") && !l.contains("not homed") && l.contains("idle"))
    });
    let start = z_position(&homed).expect("z position");
    pane.keys("s");
    pane.wait_for("jog step 1 mm", Duration::from_secs(5));
    pane.keys("Right");
    pane.wait_for("z: moving by +1.000 mm", Duration::from_secs(10));
    let moved = pane.wait_until("z 1 mm further", Duration::from_secs(30), |s| {
        z_position(s).is_some_and(|p| (p - start - 1.0).abs() < 0.01)
    });
    // The F/T streams at its rate and the camera films while nothing scans.
    assert!(!moved.contains(" 0 Hz"), "{moved}");
    // A jog past the soft limit (5 mm up from 1 mm above home) is refused, naming the axis and
    // the limits, and z stays where it was.
    pane.keys("s");
    pane.wait_for("jog step 5 mm", Duration::from_secs(5));
    pane.keys("Left");
    let refused = pane.wait_for("outside the soft limits", Duration::from_secs(10));
    assert!(refused.contains("axis z"), "{refused}");
    let still = z_position(&refused).expect("z position");
    assert!((still - start - 1.0).abs() < 0.01, "z moved to {still}");
    // Leaving the screen releases the bench; quitting leaves the terminal clean.
    pane.keys("1");
    pane.wait_for("ready: press r to run", Duration::from_secs(10));
    let _ = pane.quit_cleanly();
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 59: on the Bench screen x and y were refused only over the force ceiling, so with the
/// indenter pressed into the gel under the ceiling `x` `→` dragged it across, and `t` tared the
/// load away. Now both are refused in contact, saying why and to lift with z; lifting (homing
/// z) always goes, and then both work. Before z was homed the F/T's no-contact reading is not
/// known (the simulated F/T is not tared), so both wait, saying to home z.
#[test]
fn the_bench_screen_refuses_moves_across_the_sensor_and_the_tare_in_contact() {
    let dir = scratch("bench-contact");
    // The quick bench: axes at 8 mm/s; the gel's surface at z 15 mm, the ceiling 20 N.
    std::fs::write(dir.join("rig.toml"), common::QUICK_RIG).expect("rig file");
    let pane = Pane::start("bench-contact", &dir, &fringe());
    pane.wait_for("ready: press r to run", Duration::from_secs(30));
    pane.keys("4");
    pane.wait_until("the bench open", Duration::from_secs(30), |s| {
        s.contains("bench open") && z_position(s).is_some() && bench_fz(s).is_some()
    });
    // Before z was homed: nothing tells a load from the F/T's zero.
    pane.keys("x");
    pane.keys("Right");
    let unknown = pane.wait_for("is refused", Duration::from_secs(10));
    let said = bench_said(&unknown);
    assert!(
        said.contains(
            "x: a move across the sensor is refused: the F/T's no-contact reading is not known yet"
        ) && said.contains("home z first (z, then h)"),
        "{unknown}"
    );
    // Home z (its no-contact reading is taken there), then press it 5, 5, 5 mm down to the
    // gel's surface and on by 1 mm steps until the F/T reads a load.
    pane.keys("z");
    pane.keys("h");
    pane.wait_for("z: homing", Duration::from_secs(10));
    z_homed(&pane);
    let fz_clear = bench_fz(&pane.screen()).expect("Fz");
    pane.keys("s");
    pane.keys("s");
    pane.wait_for("jog step 5 mm", Duration::from_secs(5));
    for k in 1..=3 {
        pane.keys("Right");
        z_rests_at(&pane, 5.0 * k as f64);
    }
    pane.keys("s");
    pane.keys("s");
    pane.keys("s");
    pane.wait_for("jog step 1 mm", Duration::from_secs(5));
    let mut pressed = None;
    for k in 1..=4 {
        pane.keys("Right");
        z_rests_at(&pane, 15.0 + k as f64);
        std::thread::sleep(Duration::from_millis(500));
        let screen = pane.screen();
        let fz = bench_fz(&screen).expect("Fz");
        if (fz - fz_clear).abs() > 1.0 {
            pressed = Some(screen);
            break;
        }
    }
    let pressed = pressed.unwrap_or_else(|| panic!("no load 4 mm past the gel's surface"));
    assert!(!pressed.contains("over the ceiling"), "{pressed}");
    let z_pressed = z_position(&pressed).expect("z");
    // In contact, under the ceiling: x is not moved, and says why and what to do.
    pane.keys("x");
    let chosen = pane.wait_until("x chosen", Duration::from_secs(5), |s| {
        chosen_position(s, "x").is_some()
    });
    let x_before = chosen_position(&chosen, "x").expect("x position");
    pane.keys("Right");
    let refused = pane.wait_until("the move across refused", Duration::from_secs(10), |s| {
        bench_said(s).contains("x: a move across the sensor is refused while the F/T reads a load")
    });
    let said = bench_said(&refused);
    assert!(
        said.contains("the indenter is in contact and a move across would drag it through the gel")
            && said.contains("lift it with z first (z, then ←, or h to home z)"),
        "{refused}"
    );
    assert!(!said.contains("x: moving by"), "{refused}");
    std::thread::sleep(Duration::from_millis(1000));
    let x_after = chosen_position(&pane.screen(), "x").expect("x position");
    assert!(
        (x_after - x_before).abs() < 1e-3,
        "x moved from {x_before} to {x_after} mm in contact"
    );
    // The tare is refused too: it would hide the load.
    pane.keys("t");
    let tare = pane.wait_until("the tare refused", Duration::from_secs(10), |s| {
        bench_said(s).contains(
            "the tare (the F/T's no-contact offset) is refused while the F/T reads a load",
        )
    });
    assert!(
        bench_said(&tare).contains("a tare would hide that load"),
        "{tare}"
    );
    assert!(!tare.contains("F/T sensor tared"), "{tare}");
    // Lifting always goes: z homed from the gel; then x moves and the F/T tares.
    pane.keys("z");
    pane.keys("h");
    let lifted = z_homed(&pane);
    assert!(z_pressed > 15.0, "{lifted}");
    pane.keys("x");
    pane.keys("Right");
    pane.wait_for("x: moving by +1.000 mm", Duration::from_secs(10));
    pane.wait_until("x 1 mm further", Duration::from_secs(30), |s| {
        chosen_position(s, "x").is_some_and(|p| (p - x_before - 1.0).abs() < 0.01)
    });
    pane.keys("t");
    pane.wait_for("F/T sensor tared", Duration::from_secs(10));
    pane.keys("1");
    pane.wait_for("ready: press r to run", Duration::from_secs(10));
    let _ = pane.quit_cleanly();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_bench_screen_says_when_the_net_ft_box_rebooted_and_tares_again_on_t() {
    let dir = scratch("bench-reboot");
    // The UI opens the rig file of its working directory.
    let rig = quick_netft_rig()
        + "\n[[sim.faults]]\ndevice = \"force\"\nfault = \"reboot\"\nafter = 3.0\nduration = 1.0\n";
    std::fs::write(dir.join("rig.toml"), rig).expect("rig file");
    let pane = Pane::start("bench-reboot", &dir, &fringe());
    pane.wait_for("ready: press r to run", Duration::from_secs(30));
    pane.keys("4");
    pane.wait_for("bench open", Duration::from_secs(30));
    let said = pane.wait_for("the F/T sensor restarted", Duration::from_secs(30));
    assert!(said.contains("press t to tare again"), "{said}");
    // The stream is back: the force rate is not zero.
    let back = pane.wait_until("the F/T streaming again", Duration::from_secs(10), |s| {
        !s.contains(" 0 Hz") && s.contains("Hz")
    });
    assert!(back.contains("bias is gone"), "{back}");
    // Its zero moved: the tare waits for the no-contact reading, taken with z at its home.
    pane.keys("z");
    pane.keys("h");
    pane.wait_for("z: homing", Duration::from_secs(10));
    z_homed(&pane);
    pane.keys("t");
    pane.wait_for("F/T sensor tared", Duration::from_secs(10));
    pane.keys("1");
    pane.wait_for("ready: press r to run", Duration::from_secs(10));
    let _ = pane.quit_cleanly();
}

#[test]
fn the_calibrate_screen_fits_a_profile_from_its_scan_and_writes_it_on_w() {
    let dir = scratch("calibrate");
    // The quick bench at half the frame size (the full-size calibration is calibrate_rig_cli's;
    // a quarter, where the disc is found too, is optical_accuracy's).
    std::fs::write(dir.join("rig.toml"), common::quick_rig_at(0.5)).expect("rig file");
    let pane = Pane::start("calibrate", &dir, &fringe());
    pane.wait_for("ready: press r to run", Duration::from_secs(30));
    pane.keys("5");
    pane.wait_for(
        "ready: press r to run the calibration scan",
        Duration::from_secs(10),
    );
    pane.keys("r");
    pane.wait_for("calibration scan: press", Duration::from_secs(30));
    pane.wait_answering("fitted: press w", Duration::from_secs(400));
    // The fit's last lines, once drawn (a capture can land while the frame is half written).
    let fitted = pane.wait_for("force offsets", Duration::from_secs(10));
    assert!(fitted.contains("fitted: press w"), "{fitted}");
    assert!(fitted.contains("crop radius"), "{fitted}");
    assert!(fitted.contains("px/mm"), "registration shown:\n{fitted}");
    let profiles = dir.join("profiles");
    assert!(!profiles.exists(), "nothing written before w");
    pane.keys("w");
    let written = pane.wait_for("written: ", Duration::from_secs(60));
    let files: Vec<PathBuf> = std::fs::read_dir(&profiles)
        .unwrap_or_else(|e| panic!("{}: {e}\n{written}", profiles.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    let profile = files
        .iter()
        .find(|p| p.extension().is_some_and(|x| x == "toml"))
        .unwrap_or_else(|| panic!("no profile in {files:?}\n{written}"));
    let text = std::fs::read_to_string(profile).expect("profile");
    assert!(text.contains("crop_radius_px"), "{text}");
    assert!(
        text.contains("px_per_mm"),
        "the registration is in the profile:\n{text}"
    );
    assert!(
        profile.with_extension("png").exists(),
        "report image in {files:?}"
    );
    let _ = pane.quit_cleanly();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn live_validation_in_the_ui_with_the_default_model_shows_metrics_that_move() {
    let dir = scratch("validate");
    // The quick bench at the full frame size, which the model that ships was trained on (at
    // half the size it is warned about, and its shape is wrong more often than right).
    std::fs::write(dir.join("rig.toml"), common::quick_rig_at(1.0)).expect("rig file");
    let plan = dir.join("plan.toml");
    std::fs::write(&plan, common::VALIDATE_PLAN).expect("plan");
    // No --model: the model that ships with fringe.
    let command = format!("{} validate --plan {}", fringe(), plan.display());
    let pane = Pane::start("validate", &dir, &command);
    pane.wait_for(
        "press r to run the scan plan with live",
        Duration::from_secs(30),
    );
    pane.keys("r");
    // The metrics appear and the frame count grows.
    let frames = |s: &str| -> Option<u64> {
        let rest = &s[s.find("over ")? + 5..];
        rest.split_whitespace().next()?.parse().ok()
    };
    let first = pane.wait_until("validated frames", Duration::from_secs(60), |s| {
        frames(s).is_some_and(|n| n > 0)
    });
    let n0 = frames(&first).unwrap_or(0);
    let later = pane.wait_until("more validated frames", Duration::from_secs(60), |s| {
        frames(s).is_some_and(|n| n > n0)
    });
    assert!(later.contains("Fz RMSE"), "{later}");
    assert!(later.contains("predictions/s"), "{later}");
    assert!(later.contains("builtin:layered"), "{later}");
    // Once the indenter presses, the model reads its shape.
    pane.wait_until(
        "the pressed shape, as the default model reads it",
        Duration::from_secs(60),
        |s| s.contains("shape: pentagon"),
    );
    // The scan ends; the validation stays on screen.
    pane.keys("1");
    pane.wait_answering("completed:", Duration::from_secs(120));
    pane.keys("2");
    let end = pane.wait_for("Fz RMSE", Duration::from_secs(5));
    assert!(frames(&end).is_some_and(|n| n > n0), "{end}");
    let _ = pane.quit_cleanly();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn quitting_is_refused_while_a_scan_runs_and_ctrl_c_aborts_it_with_z_retracted() {
    let dir = scratch("abort");
    let pane = Pane::start("abort", &dir, &fringe());
    pane.wait_for("ready: press r to run", Duration::from_secs(30));
    pane.keys("r");
    pane.wait_for("point 1 of 6", Duration::from_secs(30));
    pane.keys("q");
    pane.wait_for("a scan is running", Duration::from_secs(5));
    pane.keys("C-c");
    let screen = pane.wait_for("fringe exited", Duration::from_secs(60));
    assert!(screen.contains("fringe exited 0"), "{screen}");
    assert_eq!(pane.flag("alternate_on"), "0");
    let recorded = runs(&dir);
    assert_eq!(recorded.len(), 1);
    assert_eq!(recorded[0].1["exit_status"], "aborted", "{:?}", recorded[0]);
}

#[test]
fn a_hung_up_terminal_interrupts_the_scan_resumable_and_the_process_exits() {
    let dir = scratch("hangup");
    // The UI opens the rig file of its working directory (quick axes) and the built-in plan.
    let (rig, _) = common::scan_files(&dir);
    let pane = Pane::start("hangup", &dir, &fringe());
    pane.wait_for("ready: press r to run", Duration::from_secs(30));
    let shell = pane.flag("pane_pid");
    let child = Command::new("pgrep")
        .args(["-P", &shell])
        .output()
        .expect("pgrep");
    let pid = String::from_utf8_lossy(&child.stdout).trim().to_string();
    assert!(
        !pid.is_empty(),
        "fringe's pid under the pane's shell {shell}"
    );
    pane.keys("r");
    pane.wait_for("point 1 of 6", Duration::from_secs(30));
    // The terminal goes away (ssh dropped, window closed): SIGHUP and a dead tty.
    let _ = pane.tmux(&["kill-server"]);
    let start = Instant::now();
    while Path::new(&format!("/proc/{pid}")).exists() {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "fringe (pid {pid}) still runs 30 s after its terminal hung up"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    // A hang-up is an interruption, not the operator's decision: z retracted and the run closed
    // resumable (before, it was closed as aborted and could not be resumed).
    let recorded = runs(&dir);
    assert_eq!(recorded.len(), 1);
    let (run, stop) = &recorded[0];
    assert_eq!(stop["exit_status"], "failed", "{stop}");
    let reason = stop["reason"].as_str().unwrap_or_default();
    assert!(reason.contains("interrupted"), "{reason}");
    let out = common::resume(&rig, run);
    let t = common::text(&out);
    assert!(out.status.success(), "{t}");
    assert!(t.contains("completed: 6 of 6 points"), "{t}");
    let verify = common::fringe(&["verify", run.to_str().expect("path")]);
    assert!(verify.status.success(), "{}", common::text(&verify));
}

#[test]
fn a_commissioning_from_the_ui_stops_resumable_and_goes_on_without_pressing_again() {
    let dir = scratch("commission");
    // The quick bench with the layered-3 unit at half size, profiles in dir/profiles.
    common::unit_rig_at(&dir, 0.5);
    let pane = Pane::start("commission", &dir, &fringe());
    pane.wait_for("ready: press r to run", Duration::from_secs(30));
    pane.keys("6");
    pane.wait_for("ready: r commissions the sensor", Duration::from_secs(10));
    pane.keys("r");
    pane.wait_for("step 1: calibration", Duration::from_secs(30));
    pane.wait_answering("point 3 of 9", Duration::from_secs(120));
    // Stopped mid-calibration: the scan is closed resumable and the commissioning says how to
    // go on.
    pane.keys("s");
    pane.wait_answering("stopped: ", Duration::from_secs(60));
    // The stop and the way on, on one screen within seconds of the stop showing. (Once, on a
    // clean-clone CI run, the first screen with the stop had no hint under it; the cause was not
    // found, so the hint is waited for rather than read off that first screen.)
    let stopped = pane.wait_until(
        "the stop with the key that goes on",
        Duration::from_secs(10),
        |s| s.contains("stopped: ") && s.contains("c go on with the unfinished one"),
    );
    let profiles = dir.join("profiles");
    let commissioning = std::fs::read_dir(&profiles)
        .expect("profiles")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.is_dir())
        .unwrap_or_else(|| panic!("no commissioning directory\n{stopped}"));
    let run = commissioning.join("runs/calibration-layered-3");
    let stop: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("stop.json")).expect("stop.json"))
            .expect("stop.json is JSON");
    assert_eq!(stop["exit_status"], "failed", "closed resumable: {stop}");
    let done_before = stop["points_done"].as_u64().expect("points_done");
    assert!(done_before >= 2, "{stop}");
    // Taken up again: the calibration run resumes from its checkpoint and the unit's profile is
    // written.
    pane.keys("c");
    pane.wait_for("resuming the run", Duration::from_secs(30));
    let resumed = pane.wait_answering(
        "step 2: presses over the usable disc",
        Duration::from_secs(180),
    );
    assert!(resumed.contains("wrote "), "{resumed}");
    let stop: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("stop.json")).expect("stop.json"))
            .expect("stop.json is JSON");
    assert_eq!(stop["exit_status"], "completed", "{stop}");
    assert_eq!(stop["points_done"], 9, "{stop}");
    let events = std::fs::read_to_string(run.join("events.jsonl")).expect("events");
    // Each point done once: those done before the stop were not pressed again.
    let pressed = events.matches("\"kind\":\"point-done\"").count();
    assert_eq!(pressed, 9, "each calibration point done once:\n{events}");
    let aside: Vec<_> = std::fs::read_dir(commissioning.join("runs"))
        .expect("runs")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".stopped-"))
        .collect();
    assert!(aside.is_empty(), "nothing set aside to press again");
    assert!(
        profiles.join("layered-3.toml").is_file(),
        "the unit's profile"
    );
    // Stopped again in its first round, then the UI quits cleanly.
    pane.keys("s");
    pane.wait_answering("stopped: ", Duration::from_secs(120));
    let _ = pane.quit_cleanly();
    let _ = std::fs::remove_dir_all(&dir);
}

/// The pane's terminal settings, as `stty -a` prints them.
fn terminal_modes(pane: &Pane) -> String {
    let tty = pane.flag("pane_tty");
    let out = Command::new("stty")
        .args(["-F", &tty, "-a"])
        .output()
        .expect("stty");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A worker thread's panic during a scan (the live validation's, as a card with a window of
/// 1e300 mm once made it: injected here by `FRINGE_INJECT_PANIC`, once): the UI says so on its
/// screen, stops the scan (z retracts, the run closed resumable), keeps the terminal raw and
/// its keys: a second scan is aborted with `a` alone (no Enter), `q` quits, the terminal is
/// back in line mode and the panic is said again on the normal screen. Before, ratatui's hook
/// restored the terminal from the worker's thread and printed over the UI; `a` did nothing
/// until Enter while the scan pressed on, and `q` never quit.
#[test]
fn a_workers_panic_is_shown_in_the_ui_the_scan_stops_and_the_keys_still_work() {
    let dir = scratch("worker-panic");
    std::fs::write(dir.join("rig.toml"), common::quick_rig_at(1.0)).expect("rig file");
    let plan = dir.join("plan.toml");
    // Two points: the second scan is still pressing when `a` comes.
    let two_points = common::VALIDATE_PLAN.replace("x = [12.5]", "x = [12.5, 14.5]");
    assert_ne!(two_points, common::VALIDATE_PLAN);
    std::fs::write(&plan, two_points).expect("plan");
    let command = format!(
        "FRINGE_INJECT_PANIC=live-validation {} validate --plan {}",
        fringe(),
        plan.display()
    );
    let pane = Pane::start("worker-panic", &dir, &command);
    pane.wait_for(
        "press r to run the scan plan with live",
        Duration::from_secs(30),
    );
    pane.keys("r");
    // The failure on the Validate screen, in the UI's own lines.
    let failed = pane.wait_for(
        "the live validation thread failed: a panic injected",
        Duration::from_secs(120),
    );
    assert!(
        !failed.contains("RUST_BACKTRACE"),
        "printed over:\n{failed}"
    );
    assert_eq!(pane.flag("alternate_on"), "1", "the UI left its screen");
    let modes = terminal_modes(&pane);
    assert!(
        modes.contains("-icanon") && modes.contains("-echo"),
        "the terminal is back in line mode under the UI: {modes}"
    );
    // The scan stops by itself, resumable.
    pane.keys("1");
    let stopped = pane.wait_answering("stopped: ", Duration::from_secs(60));
    assert!(stopped.contains("panicked"), "{stopped}");
    let first = runs(&dir);
    assert_eq!(first.len(), 1, "{stopped}");
    assert_eq!(first[0].1["exit_status"], "failed", "{:?}", first[0]);
    let reason = first[0].1["reason"].as_str().unwrap_or_default();
    assert!(reason.contains("interrupted"), "closed resumable: {reason}");
    // The keys work without Enter: a second scan, aborted with `a`.
    pane.keys("r");
    pane.wait_until("the second scan pressing", Duration::from_secs(60), |s| {
        s.contains("point 1 of 2: ") && !s.contains("stopped: ")
    });
    pane.keys("a");
    pane.wait_answering("stopped: ", Duration::from_secs(60));
    let both = runs(&dir);
    assert_eq!(both.len(), 2);
    let aborted = both
        .iter()
        .find(|(run, _)| *run != first[0].0)
        .expect("the second run");
    assert_eq!(aborted.1["exit_status"], "aborted", "{:?}", aborted);
    // `q` quits; the terminal is back, and the panic is said on the normal screen.
    pane.keys("q");
    let end = pane.wait_for("fringe exited", Duration::from_secs(30));
    assert!(end.contains("fringe exited 1"), "{end}");
    assert!(
        end.contains("while the UI ran, thread 'live-validation' panicked"),
        "{end}"
    );
    assert_eq!(pane.flag("alternate_on"), "0", "alternate screen left on");
    assert_eq!(pane.flag("cursor_flag"), "1", "cursor left hidden");
    let modes = terminal_modes(&pane);
    assert!(
        modes.contains(" icanon") && modes.contains(" echo"),
        "line mode after the UI: {modes}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The frames the Stream screen says ran ("N of M frames run").
fn streamed_frames(screen: &str) -> Option<u64> {
    let at = screen.find(" of ")?;
    let before = &screen[..at];
    let start = before.rfind(|c: char| !c.is_ascii_digit())? + 1;
    let n: u64 = before[start..].parse().ok()?;
    screen[at..].contains("frames run").then_some(n)
}

#[test]
fn the_stream_screen_streams_records_holds_the_camera_from_scans_and_says_its_summary() {
    let dir = scratch("stream");
    // The quick bench at 25 fps and the constant model, so that a debug build keeps up; the
    // node publishes to a free port of its own (no router there: it publishes anyway).
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port");
    let rig = format!(
        "{}[stream]\nconnect = [\"tcp/127.0.0.1:{port}\"]\nlisten = [\"tcp/127.0.0.1:0\"]\nnamespace = \"/left_finger\"\n",
        common::QUICK_RIG.replace("[camera]\ndriver = \"sim\"\n", "[camera]\ndriver = \"sim\"\nframe_rate = 25.0\n")
    );
    std::fs::write(dir.join("rig.toml"), rig).expect("rig file");
    let model = common::constant_model(&dir);
    // Named as it lies in the pane's working directory: a scratch directory's long path would
    // wrap on the screen.
    let name = model
        .file_name()
        .and_then(|n| n.to_str())
        .expect("the model's file name");
    let command = format!("{} validate --model {name}", fringe());
    let pane = Pane::start("stream", &dir, &command);
    pane.wait_for("press r to run the scan plan", Duration::from_secs(30));
    pane.keys("9");
    let ready = pane.wait_for("s streams: the camera", Duration::from_secs(10));
    assert!(ready.contains("constant.safetensors"), "{ready}");
    assert!(
        ready.contains("/left_finger/fringe_stream on domain"),
        "{ready}"
    );
    // m: stream and record.
    pane.keys("m");
    let first = pane.wait_until("streamed frames", Duration::from_secs(60), |s| {
        streamed_frames(s).is_some_and(|n| n > 0)
    });
    let n0 = streamed_frames(&first).unwrap_or(0);
    let later = pane.wait_until("more streamed frames", Duration::from_secs(30), |s| {
        streamed_frames(s).is_some_and(|n| n > n0 + 25)
    });
    assert!(
        later.contains("Fz  +2.000 N"),
        "the constant model's Fz: {later}"
    );
    assert!(later.contains("/left_finger/wrench"), "{later}");
    assert!(later.contains("recording to "), "{later}");
    assert!(
        later.contains("latency, exposure end to published"),
        "{later}"
    );
    // The simulator's truth scores the stream as it goes.
    pane.wait_until("the stream scored", Duration::from_secs(30), |s| {
        s.contains("against the simulator's truth (")
    });
    // A scan waits for the stream (it holds the camera), and so does the bench.
    pane.keys("r");
    pane.wait_for("the stream holds the camera", Duration::from_secs(5));
    pane.keys("4");
    pane.wait_for(
        "the stream holds the camera: stop it",
        Duration::from_secs(5),
    );
    assert!(runs(&dir).is_empty(), "no scan ran");
    // Back, and stop it: its summary.
    pane.keys("9");
    pane.keys("s");
    let stopped = pane.wait_for("recorded to streams/", Duration::from_secs(30));
    assert!(
        stopped.contains("s stream · m stream and record"),
        "{stopped}"
    );
    let recordings: Vec<PathBuf> = std::fs::read_dir(dir.join("streams"))
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    assert_eq!(recordings.len(), 1, "{stopped}");
    let recording = &recordings[0];
    assert_eq!(recording.extension().and_then(|e| e.to_str()), Some("mcap"));
    let bytes = std::fs::read(recording).expect("the recording");
    assert!(
        bytes.starts_with(b"\x89MCAP0\r\n") && bytes.ends_with(b"\x89MCAP0\r\n"),
        "a whole MCAP file"
    );
    let after = pane.quit_cleanly();
    assert!(
        after.contains("fringe: a stream in this session:"),
        "{after}"
    );
    assert!(after.contains("recorded to "), "{after}");
    assert!(after.contains("  streamed "), "{after}");
    assert!(
        after.contains("published under /left_finger: wrench"),
        "{after}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
