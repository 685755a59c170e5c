//! Helpers shared by the command-line tests (one set for every test file of this crate).
#![allow(dead_code)] // each test binary uses its own subset

use fringe_sensor_models::read_weights;
use fringe_sensor_models::write_safetensors;
use fringe_sensor_models::StateDict;
use fringe_sensor_models::Tensor;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

/// The `fringe` binary as a command to add arguments to.
pub fn fringe_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fringe"))
}

/// `fringe scan --yes --rig RIG --out ROOT PLAN`, output not captured (for scans a test spawns
/// and watches, or kills).
pub fn scan_command(rig: &Path, root: &Path, plan: &Path) -> Command {
    let mut cmd = fringe_command();
    cmd.args(["scan", "--yes", "--rig"])
        .arg(rig)
        .arg("--out")
        .arg(root)
        .arg(plan)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null());
    cmd
}

/// Runs the `fringe` binary with `args`.
pub fn fringe(args: &[&str]) -> Output {
    fringe_command().args(args).output().expect("run fringe")
}

/// Standard output then standard error, as text.
pub fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The one run directory a scan wrote under `runs` (the tests give each scan its own `--out`).
pub fn only_run(runs: &Path) -> PathBuf {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(runs)
        .unwrap_or_else(|e| panic!("{}: {e}", runs.display()))
        .map(|e| e.expect("runs entry").path())
        .collect();
    assert_eq!(dirs.len(), 1, "one run in {}: {dirs:?}", runs.display());
    dirs.remove(0)
}

/// A fresh, empty scratch directory for one test (named for the test binary, the test and the
/// process, so parallel tests and runs never share one). Removed when the test passes (scans of
/// the full-size simulated camera write gigabytes of frames); kept when it fails, for a look.
pub fn scratch(name: &str) -> Scratch {
    let binary = std::env::current_exe()
        .ok()
        .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .unwrap_or_else(|| "test".into());
    let dir = std::env::temp_dir().join(format!("fringe-{binary}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    Scratch(dir)
}

/// A directory of data that tests share, made by `make` (into the empty directory it is given)
/// once per build of `fringe`: nextest runs every test in a process of its own, so a static
/// would make it once per test and leave each copy behind. It lives in cargo's scratch space
/// for integration tests (`CARGO_TARGET_TMPDIR`) under `name` and the binary's size and time;
/// copies made by earlier builds are removed. Processes that make it at once each make their
/// own and the first to finish is kept.
pub fn shared(name: &str, make: impl FnOnce(&Path)) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let binary = std::fs::metadata(env!("CARGO_BIN_EXE_fringe")).expect("the fringe binary");
    let built = binary
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    let prefix = format!("{name}-");
    let dir = root.join(format!("{prefix}{:x}-{built:x}", binary.len()));
    if !dir.is_dir() {
        // Each maker its own: processes (nextest) and threads (cargo test) alike.
        static MAKERS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let partial = root.join(format!(
            "{}.partial-{}-{}",
            dir.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            std::process::id(),
            MAKERS.fetch_add(1, std::sync::atomic::Ordering::SeqCst)
        ));
        let _ = std::fs::remove_dir_all(&partial);
        std::fs::create_dir_all(&partial).expect("shared test data directory");
        make(&partial);
        if std::fs::rename(&partial, &dir).is_err() {
            // Another process finished first: use its copy.
            assert!(dir.is_dir(), "cannot move {} into place", partial.display());
            let _ = std::fs::remove_dir_all(&partial);
        }
        for old in std::fs::read_dir(&root).into_iter().flatten().flatten() {
            let n = old.file_name().to_string_lossy().into_owned();
            if n.starts_with(&prefix) && !n.contains(".partial-") && old.path() != dir {
                let _ = std::fs::remove_dir_all(old.path());
            }
        }
    }
    dir
}

/// A test's scratch directory: removed on drop unless the test is failing (panicking).
#[derive(Debug)]
pub struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for Scratch {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("kept for a look: {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A run written through the run store, as the scan engine writes one: a checkpoint before each
/// point, then 3 frame records per point. Frame `3p`: a force label without contact; `3p + 1`:
/// contact at (1.5, -2.0) mm with the rectangle, Fz = -2.5 N; `3p + 2`: no force label (left out
/// of an export). Unfinished runs stop after the records of the last point, which the last
/// checkpoint does not count (the point a crash interrupted).
pub struct TestRun<'a> {
    pub id: &'a str,
    pub points: u64,
    pub finish: bool,
    /// The plan stored in start.json (what `fringe scan --resume` compares).
    pub plan: &'a str,
    pub sync: &'a str,
}

impl<'a> TestRun<'a> {
    /// A finished run of one point.
    pub fn finished(id: &'a str) -> TestRun<'a> {
        TestRun {
            id,
            points: 1,
            finish: true,
            plan: "",
            sync: "host",
        }
    }

    /// Writes the run under `root`; returns its directory.
    pub fn write(&self, root: &Path) -> PathBuf {
        use fringe_rig::store::RunWriter;
        use fringe_rig::store::{
            now_utc, ExitStatus, FrameRecord, Position, StartDocument, StopDocument,
        };
        use fringe_rig::HostTime;
        use fringe_rig::{Frame, PixelFormat};
        use fringe_rig::{Millimetres, Newtons, Wrench};
        let start = StartDocument {
            layout_version: fringe_rig::store::LAYOUT_VERSION,
            run_id: self.id.into(),
            started_utc: now_utc(),
            software: "test".into(),
            sensor_id: "integrated-02".into(),
            variant: Some("integrated".into()),
            plan: self.plan.into(),
            rig: String::new(),
            calibration_profile: None,
            seed: None,
            ft_axes: None,
            sync_method: self.sync.into(),
            frames: Some(
                fringe_rig::store::FrameStorage::new(PixelFormat::Mono8, None).expect("storage"),
            ),
        };
        let mut w = RunWriter::create(root, &start).expect("create");
        for point in 0..self.points {
            w.checkpoint_at(point).expect("checkpoint");
            for _ in 0..3 {
                let id = w.next_index();
                let frame = Frame {
                    id,
                    device_timestamp: id,
                    host_arrival: HostTime(id),
                    width: 4,
                    height: 2,
                    format: PixelFormat::Mono8,
                    data: vec![id as u8; 8],
                };
                let file = w.save_frame_image(&frame, id).expect("save");
                let p = Position {
                    x: Millimetres(0.0),
                    y: Millimetres(0.0),
                    z: Millimetres(0.0),
                };
                let kind = id % 3;
                w.append_frame(&FrameRecord {
                    index: id,
                    frame_id: id,
                    file,
                    device_timestamp: id,
                    host_arrival_ns: id,
                    exposure: None,
                    exposure_ticks: None,
                    point,
                    commanded: p,
                    measured: p,
                    wrench: (kind < 2).then(|| Wrench {
                        fz: Newtons(-(kind as f64) * 2.5),
                        ..Wrench::default()
                    }),
                    shear: None,
                    shape: if kind == 1 { "rectangle" } else { "None" }.into(),
                    contact: (kind == 1).then_some([1.5, -2.0]),
                    valid: true,
                    notes: vec![],
                })
                .expect("record");
            }
        }
        let dir = w.dir().to_path_buf();
        if self.finish {
            w.finish(&StopDocument {
                exit_status: ExitStatus::Completed,
                reason: "done".into(),
                stopped_utc: now_utc(),
                frames: 3 * self.points,
                dropped_frames: 0,
                force_samples: 0,
                lost_force_samples: 0,
                points_done: self.points,
                sync_method: Some(self.sync.into()),
                sync_error_ns: None,
            })
            .expect("finish");
        } else {
            w.checkpoint().expect("checkpoint");
        }
        dir
    }
}

/// Every file under `dir` (relative path, content), to show that a command changed nothing.
pub fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(here) = stack.pop() {
        for entry in std::fs::read_dir(&here).expect("read dir") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path
                    .strip_prefix(dir)
                    .expect("inside")
                    .display()
                    .to_string();
                out.insert(rel, std::fs::read(&path).expect("read"));
            }
        }
    }
    out
}

/// Replaces line `k` (from 0) of `path` with what `edit` makes of it; `None` removes the line.
pub fn edit_line(path: &Path, k: usize, edit: impl FnOnce(&str) -> Option<String>) {
    let text = std::fs::read_to_string(path).expect("read");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    match edit(&lines[k]) {
        Some(line) => lines[k] = line,
        None => {
            lines.remove(k);
        }
    }
    let mut out = lines.join("\n");
    out.push('\n');
    std::fs::write(path, out).expect("write");
}

pub const CONSTANT_FZ_N: f64 = 2.0;
pub const CONSTANT_CONTACT_MM: [f64; 2] = [0.5, -0.5];

/// The custom CNN with every head weight zero: it answers Fz = 2 N, shape "pentagon" and contact
/// (0.5, -0.5) mm whatever it sees.
pub fn constant_model(dir: &Path) -> PathBuf {
    constant_model_of_class(dir, 1, "constant.safetensors")
}

/// As [`constant_model`], answering the shape class `class` (0 `None`, 1 `pentagon`, 2
/// `rectangle`) whatever it sees, written to `dir/name`.
pub fn constant_model_of_class(dir: &Path, class: usize, name: &str) -> PathBuf {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sensor-models/tests/fixtures/custom/model.safetensors");
    let sd = read_weights(&fixture).expect("fixture weights");
    let mut out = StateDict::new();
    for (k, t) in sd.iter() {
        let mut t = t.clone();
        if k.ends_with("_head.weight") {
            t.data.iter_mut().for_each(|v| *v = 0.0);
        }
        match k {
            "force_head.bias" => {
                t.data.iter_mut().for_each(|v| *v = 0.0);
                t.data[2] = CONSTANT_FZ_N as f32;
            }
            "class_head.bias" => {
                t.data.iter_mut().for_each(|v| *v = 0.0);
                t.data[class] = 10.0;
            }
            "point_head.bias" => t.data = CONSTANT_CONTACT_MM.map(|v| v as f32).to_vec(),
            _ => {}
        }
        out.insert(k, Tensor::new(t.shape.clone(), t.data).expect("same shape"));
    }
    let path = dir.join(name);
    write_safetensors(&path, &out).expect("write model");
    path
}

/// A one-point plan (one press to 3 N) for validation tests.
pub const VALIDATE_PLAN: &str = r#"
name = "validate-test"
[grid]
x = [12.5]
y = [25.0]
[indenters]
shapes = ["pentagon"]
[approach]
safe_z = 14.0
contact_threshold = 0.3
[indentation]
force_targets = [3.0]
ramp_rate = 6.0
dwell = 0.6
[safety]
force_ceiling = 12.0
"#;

/// A simulated rig with quick axes, so the tests spend their time scanning, not homing.
pub const QUICK_RIG: &str = r#"
name = "quick simulated bench"
sync = "strobe"
[x]
driver = "sim"
velocity = 8.0
acceleration = 40.0
[y]
driver = "sim"
velocity = 8.0
acceleration = 40.0
[z]
driver = "sim"
velocity = 8.0
acceleration = 40.0
[camera]
driver = "sim"
[force]
driver = "sim"
[sim]
seed = 5
image_scale = 0.25
"#;

/// [`QUICK_RIG`] with its simulated camera at `scale` of the full frame size.
pub fn quick_rig_at(scale: f64) -> String {
    QUICK_RIG.replace("image_scale = 0.25", &format!("image_scale = {scale}"))
}

/// `p` as a command-line argument.
pub fn arg(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Runs `fringe args` in `dir`; asserts that it fails and returns what it printed.
pub fn refused_in(dir: &Path, args: &[&str]) -> String {
    let o = fringe_command()
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run fringe");
    assert!(!o.status.success(), "{}", text(&o));
    text(&o)
}

/// [`QUICK_RIG`] with the simulated `layered-3` unit (rig/sim/sensors/layered-3.toml) at
/// `scale` of the full frame size, its profiles in `dir/profiles`, written to `dir/rig.toml`.
pub fn unit_rig_at(dir: &Path, scale: f64) -> PathBuf {
    let sensor = Path::new(env!("CARGO_MANIFEST_DIR")).join("../rig/sim/sensors/layered-3.toml");
    let rig = quick_rig_at(scale)
        .replace(
            "name = \"quick simulated bench\"",
            &format!(
                "name = \"quick layered-3\"\nprofiles = \"{}\"",
                dir.join("profiles").display()
            ),
        )
        .replace(
            "[sim]\n",
            &format!("[sim]\nsensor = \"{}\"\n", sensor.display()),
        );
    let path = dir.join("rig.toml");
    std::fs::write(&path, rig).expect("rig file");
    path
}

/// `fringe commission` of the unit on `rig` (from [`unit_rig_at`]) in `dir` on the smallest
/// bench budget that adapts (1.5 min, 3 positions a round, 3 acceptance positions) against a
/// loose spec (`dir/spec.toml`): the tests are of the jobs, not of the figures.
pub fn quick_commission(dir: &Path, rig: &Path) -> Command {
    let spec = dir.join("spec.toml");
    std::fs::write(&spec, "fz_rmse_n = 3.0\ncontact_rmse_mm = 6.0\n").expect("spec");
    let mut c = fringe_command();
    c.args(["commission", "--rig", arg(rig), "--yes", "--budget", "1.5"])
        .args(["--round-presses", "3", "--acceptance-presses", "3"])
        .args(["--spec", arg(&spec)])
        .current_dir(dir);
    c
}

/// [`QUICK_RIG`] with its force through the emulated Net F/T (RDT datagrams, in process), which
/// records no exposure strobe: frames are placed by the clock fit.
pub fn quick_netft_rig() -> String {
    QUICK_RIG.replace("sync = \"strobe\"", "sync = \"clock-fit\"") + "force_path = \"netft\"\n"
}

/// The normal force RMS of the labels against the simulator's truth that a scan of the simulated
/// bench printed, N.
pub fn label_rms(printed: &str) -> f64 {
    printed
        .split("normal force RMS ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no label score in: {printed}"))
}

/// A plan over x positions `xs` (a TOML list) at y 25 mm, 1 and 3 N.
pub fn scan_plan(xs: &str) -> String {
    format!(
        r#"
name = "cli"
[grid]
x = {xs}
y = [25.0]
[indenters]
shapes = ["pentagon"]
[approach]
safe_z = 14.0
[indentation]
force_targets = [1.0, 3.0]
ramp_rate = 6.0
dwell = 0.4
[safety]
force_ceiling = 10.0
"#
    )
}

/// The quick rig and a 3-point plan written into `dir`: (rig file, plan file).
pub fn scan_files(dir: &Path) -> (PathBuf, PathBuf) {
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, QUICK_RIG).expect("rig file");
    let plan_path = dir.join("plan.toml");
    std::fs::write(&plan_path, scan_plan("[11.0, 12.5, 14.0]")).expect("plan file");
    (rig, plan_path)
}

/// The lines of a run's events.jsonl.
pub fn events(run: &Path) -> Vec<String> {
    std::fs::read_to_string(run.join("events.jsonl"))
        .unwrap_or_default()
        .lines()
        .map(str::to_string)
        .collect()
}

/// The run under `root` (once its start.json is there).
pub fn the_run(root: &Path) -> Option<PathBuf> {
    std::fs::read_dir(root)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.join("start.json").is_file())
}

/// Waits until an event line of the run under `root` satisfies `pred`.
pub fn wait_for_event(root: &Path, child: &mut Child, pred: impl Fn(&str) -> bool) -> PathBuf {
    let until = Instant::now() + Duration::from_secs(90);
    loop {
        if let Some(run) = the_run(root) {
            if events(&run).iter().any(|e| pred(e)) {
                return run;
            }
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("fringe scan ended early: {status}");
        }
        assert!(Instant::now() < until, "event not seen in time");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The points of a run's frame records in order; fails on a point recorded twice.
pub fn points_in(run: &Path) -> Vec<u64> {
    let text = std::fs::read_to_string(run.join("frames.jsonl")).expect("frames.jsonl");
    let mut points: Vec<u64> = Vec::new();
    for line in text.lines() {
        let point = line
            .split("\"point\":")
            .nth(1)
            .and_then(|s| s.split([',', '}']).next())
            .and_then(|s| s.trim().parse().ok())
            .expect("point field");
        if points.last() != Some(&point) {
            assert!(!points.contains(&point), "point {point} recorded twice");
            points.push(point);
        }
    }
    points
}

/// `fringe scan --yes --rig RIG --resume RUN`.
pub fn resume(rig: &Path, run: &Path) -> Output {
    fringe(&[
        "scan",
        "--yes",
        "--rig",
        rig.to_str().expect("path"),
        "--resume",
        run.to_str().expect("path"),
    ])
}

/// Resumes `run` with `fringe scan --resume` on `rig` and checks it ends complete (the 3-point
/// plan of [`scan_files`]) and verified, every point recorded once; returns what fringe printed.
pub fn resume_to_the_end(rig: &Path, run: &Path) -> String {
    let out = resume(rig, run);
    let t = text(&out);
    assert!(out.status.success(), "resume failed: {t}");
    assert!(t.contains("completed: 3 of 3 points"), "{t}");
    assert_eq!(points_in(run), vec![0, 1, 2]);
    let verify = fringe(&["verify", run.to_str().expect("path")]);
    assert!(verify.status.success(), "{}", text(&verify));
    t
}

/// The number after `key` at the start of a line of what fringe printed (eval's "Fz RMSE:",
/// ft's "Fz N:", ...).
pub fn printed_figure(printed: &str, key: &str) -> f64 {
    printed
        .lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no `{key}` figure in:\n{printed}"))
}

/// A sensor of `design` with a coarser fringe-field grid: renderer start-up stays short in a
/// debug build, the images stay full size.
pub fn coarse_sensor(dir: &Path, design: &str) -> PathBuf {
    let path = dir.join(format!("coarse-{design}.toml"));
    std::fs::write(
        &path,
        format!("variant = \"{design}\"\n[field]\ncells = 128\ncell_mm = 0.75\n"),
    )
    .expect("write sensor file");
    path
}

/// `html` rendered headless by Debian's `chromium` into a `width` x `height` screenshot (kept
/// beside it as `<name>.png`, for a look). `None` when chromium is not installed and this is
/// not CI; under CI (`CI` set: `.ci/run` sets it and installs chromium) its absence fails.
pub fn rendered(html: &Path, width: u32, height: u32) -> Option<image::RgbImage> {
    let found = |b: &&&str| {
        Command::new("which")
            .arg(b)
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let Some(browser) = ["chromium", "chromium-browser"].iter().find(found) else {
        assert!(
            std::env::var_os("CI").is_none(),
            "chromium is not installed, and CI renders the HTML reports: apt-get install chromium (.ci/run does)"
        );
        eprintln!(
            "skipped: chromium is not installed (apt-get install chromium renders the reports)"
        );
        return None;
    };
    let shot = html.with_extension("png");
    let profile = html.with_extension("chromium-profile");
    let html = std::fs::canonicalize(html).expect("the report");
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("--window-size={width},{height}"))
        .arg(format!("file://{}", html.display()))
        .output()
        .expect("run chromium");
    let _ = std::fs::remove_dir_all(&profile);
    assert!(shot.is_file(), "no screenshot: {}", text(&out));
    Some(image::open(&shot).expect("the screenshot").to_rgb8())
}

/// The pixels of `img` of colour `c`.
pub fn pixels_of(img: &image::RgbImage, c: [u8; 3]) -> usize {
    img.pixels().filter(|p| p.0 == c).count()
}

/// A report page's screenshot shows the report: far from blank, and its verdict box (the pale
/// green of a pass or pale red of a fail, `fringe_plot::html`) drawn.
pub fn shows_a_report(img: &image::RgbImage, pass: bool) {
    let white = pixels_of(img, [255, 255, 255]);
    let total = (img.width() * img.height()) as usize;
    assert!(
        white < total * 97 / 100,
        "blank: {white} of {total} px white"
    );
    let verdict = if pass {
        [0xd9, 0xf2, 0xd9]
    } else {
        [0xfd, 0xe0, 0xe0]
    };
    assert!(
        pixels_of(img, verdict) > 5_000,
        "no verdict box ({}) drawn",
        if pass { "pass" } else { "fail" }
    );
}
