//! The scan engine on the simulated bench: a small grid end to end with labels scored against
//! the simulator's ground truth, pause/resume and abort at every phase of an indentation, the
//! force ceiling watcher, slides (the normal force held, labels where the indenter was, the
//! tangential ceiling, the disc).

use fringe_rig::scan::PressSettings;
use fringe_rig::scan::RunSidecar;
use fringe_rig::scan::WatchSettings;
use fringe_rig::store::verify_run as verify;
use fringe_rig::store::FrameCodec;
use fringe_rig::store::RunReader;
use fringe_rig::store::{Event, ExitStatus, FrameRecord, StartDocument, StopDocument};
use fringe_rig::ContactOrigin;
use fringe_rig::Devices;
use fringe_rig::SoftLimits;
use fringe_rig::SyncMethod;
use fringe_rig::TriggerTiming;
use fringe_rig::{run_scan, RunTarget, ScanOutcome, ScanSetup};
use fringe_rig::{
    scan::{Phase, ScanProgress},
    ScanControl,
};
use fringe_rig::{BenchLimits, Plan};
use fringe_rig::{CameraSettings, TriggerMode};
use fringe_rig::{Hertz, Microseconds, Millimetres, Newtons};
use fringe_rig::{Operator, Prompt, Reply};
use fringe_sim::AxisConfig;
use fringe_sim::{SimRig, SimRigConfig};
use fringe_sim::{TruthLog, TruthSink};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

/// The simulated bench with quick axes and a small image (the engine, not the renderer, is
/// under test).
fn bench(seed: u64) -> (SimRig, Devices, Arc<TruthLog>) {
    bench_with(seed, SimRigConfig::default())
}

/// [`bench`] from `config` (its seed replaced by `seed`).
fn bench_with(seed: u64, config: SimRigConfig) -> (SimRig, Devices, Arc<TruthLog>) {
    let mut config = SimRigConfig { seed, ..config };
    let quick = |a: AxisConfig| AxisConfig {
        velocity_mm_s: 8.0,
        acceleration_mm_s2: 40.0,
        ..a
    };
    config.bench.x = quick(config.bench.x);
    config.bench.y = quick(config.bench.y);
    config.bench.z = quick(config.bench.z);
    let g = &mut config.sensor.geometry;
    g.width = 480;
    g.height = 300;
    g.disc_radius_px /= 4.0;
    g.px_per_mm /= 4.0;
    g.centre_offset_px = [g.centre_offset_px[0] / 4.0, g.centre_offset_px[1] / 4.0];
    let truth = TruthLog::new();
    let sink: Arc<dyn TruthSink> = truth.clone();
    let (rig, devices) = SimRig::start(&config, Some(sink)).expect("simulated bench");
    (rig, devices, truth)
}

fn setup(rig: &SimRig, plan_text: &str) -> ScanSetup {
    let b = rig.bench.config();
    let k = |a: &AxisConfig| a.spec("axis").kinematics;
    let limits = BenchLimits {
        x: SoftLimits::new(Millimetres(0.0), Millimetres(b.x.travel_mm)).expect("x limits"),
        y: SoftLimits::new(Millimetres(0.0), Millimetres(b.y.travel_mm)).expect("y limits"),
        z: SoftLimits::new(Millimetres(0.0), Millimetres(b.z.travel_mm)).expect("z limits"),
        x_motion: k(&b.x),
        y_motion: k(&b.y),
        z_motion: k(&b.z),
        manual_y: false,
        max_force: Newtons(20.0),
        ft_rating: None,
        contact_z: Millimetres(b.geometry.z_touch_mm),
        start: None,
    };
    let plan = Plan::parse(plan_text, "plan.toml").expect("plan");
    let program = plan.program(&limits, "plan.toml").expect("program");
    ScanSetup {
        program,
        plan_text: plan_text.to_string(),
        limits,
        origin: ContactOrigin {
            x: Millimetres(b.geometry.x_centre_mm),
            y: Millimetres(b.geometry.y_centre_mm),
            source: "simulated bench".into(),
        },
        disc_radius: Some(Millimetres(
            rig.config.sensor.geometry.disc_radius_px / rig.config.sensor.geometry.px_per_mm,
        )),
        sync: SyncMethod::Strobe,
        ft_axes: Some(b.mount.axes()),
        trigger: None,
        sensor_id: rig.config.sensor.id.clone(),
        variant: Some(rig.config.sensor.variant.name().into()),
        rig_text: "simulated bench".into(),
        seed: Some(rig.config.seed),
        profile: None,
        camera: CameraSettings::default(),
        cutout: None,
        codec: None,
        press: PressSettings::default(),
        watch: WatchSettings::default(),
        sidecars: Vec::new(),
        offset_check: None,
        taps: Vec::new(),
    }
}

fn plan(xs: &str, ys: &str, targets: &str, dwell: f64) -> String {
    format!(
        r#"
name = "test"
[grid]
x = {xs}
y = {ys}
order = "snake"
[indenters]
shapes = ["pentagon"]
[approach]
safe_z = 14.0
contact_threshold = 0.3
[indentation]
{targets}
ramp_rate = 6.0
dwell = {dwell}
[safety]
force_ceiling = 12.0
"#
    )
}

/// Answers every prompt with `reply`, recording the prompts.
struct Scripted {
    reply: Reply,
    prompts: Arc<Mutex<Vec<Prompt>>>,
}

impl Operator for Scripted {
    fn ask(&mut self, prompt: &Prompt) -> Reply {
        self.prompts
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(prompt.clone());
        match prompt {
            Prompt::Resume { .. } => self.reply,
            _ => Reply::Continue,
        }
    }
}

fn scripted(reply: Reply) -> (Scripted, Arc<Mutex<Vec<Prompt>>>) {
    let prompts = Arc::new(Mutex::new(Vec::new()));
    (
        Scripted {
            reply,
            prompts: prompts.clone(),
        },
        prompts,
    )
}

fn records(dir: &Path) -> Vec<FrameRecord> {
    RunReader::at(dir).frames().expect("frames.jsonl")
}

fn events(dir: &Path) -> Vec<Event> {
    RunReader::at(dir).events().expect("events.jsonl")
}

/// Every point's records are contiguous (one attempt each) and points come in program order.
fn assert_each_point_once(records: &[FrameRecord], points: u64) {
    let mut seen: Vec<u64> = Vec::new();
    for r in records {
        if seen.last() != Some(&r.point) {
            assert!(
                !seen.contains(&r.point),
                "point {} recorded twice (records not contiguous)",
                r.point
            );
            seen.push(r.point);
        }
    }
    assert_eq!(seen, (0..points).collect::<Vec<_>>(), "points recorded");
}

#[test]
fn a_small_grid_scan_runs_end_to_end_with_labels_matching_the_ground_truth() {
    let dir = tempfile_dir("grid");
    let (rig, devices, truth) = bench(11);
    let text = plan(
        "[11.0, 14.0]",
        "[24.0, 26.0]",
        "force_targets = [1.0, 4.0]",
        0.3,
    );
    let setup = setup(&rig, &text);
    let (mut operator, prompts) = scripted(Reply::Continue);
    let control = ScanControl::new();
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "grid".into(),
        },
        &control,
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    assert_eq!(out.points_done, 4);
    assert_eq!(out.lost_force_samples, 0);
    let report = verify(&out.run_dir).expect("verify");
    assert!(report.ok(), "{report:?}");
    let prompts = prompts.lock().unwrap_or_else(|p| p.into_inner()).clone();
    assert_eq!(
        prompts,
        vec![Prompt::ChangeIndenter {
            shape: "pentagon".into()
        }]
    );
    let records = records(&out.run_dir);
    assert_each_point_once(&records, 4);
    // Snake order: row y=24 goes x 11 -> 14, row y=26 comes back.
    let first_x: BTreeMap<u64, f64> = records.iter().map(|r| (r.point, r.commanded.x.0)).collect();
    assert_eq!(
        first_x.values().copied().collect::<Vec<_>>(),
        vec![11.0, 14.0, 14.0, 11.0]
    );

    // Labels against the truth at mid-exposure: normal force and contact point.
    let truths: BTreeMap<u64, _> = truth.frames().into_iter().map(|t| (t.id, t)).collect();
    let mut force_errors = Vec::new();
    let mut in_contact = 0;
    for r in &records {
        let w = r.wrench.expect("every frame labelled");
        let t = truths.get(&r.frame_id).expect("truth of the frame");
        let true_force = t.contact.map_or(0.0, |c| c.0);
        force_errors.push(-w.fz.0 - true_force);
        if w.fz.0.abs() < 0.2 {
            assert_eq!(r.shape, "None");
            assert_eq!(r.contact, None);
        } else {
            in_contact += 1;
            assert_eq!(r.shape, "pentagon");
            let c = r.contact.expect("contact point");
            let (_, tx, ty) = t.contact.expect("truth in contact");
            assert!(
                (c[0] - tx).abs() < 0.05 && (c[1] - ty).abs() < 0.05,
                "contact {c:?} vs truth ({tx}, {ty}) in {r:?} truth {t:?}"
            );
        }
    }
    let rms = (force_errors.iter().map(|e| e * e).sum::<f64>() / force_errors.len() as f64).sqrt();
    let score = fringe_sim::ground_truth::score_labels(&records, &truth.frames()).expect("score");
    assert_eq!(score.frames, records.len());
    assert!((score.force_rms_n - rms).abs() < 1e-9);
    assert!(score.contact_rms_mm < 0.05, "{score:?}");
    assert!(in_contact > 40, "{in_contact} frames in contact");
    assert!(
        rms < 0.15,
        "label RMS error {rms:.3} N over {} frames",
        force_errors.len()
    );
    // Each target was held: some frames near 4 N.
    assert!(records
        .iter()
        .any(|r| r.wrench.is_some_and(|w| (-w.fz.0 - 4.0).abs() < 0.3)));
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The camera triggered by the DAQ's counter (`[camera] trigger = "daq"`): every frame of the scan
/// is labelled by its trigger window, and the labels match the ground truth as the strobe's do.
#[test]
fn a_scan_with_the_camera_triggered_by_the_daq_labels_every_frame_by_its_trigger() {
    let dir = tempfile_dir("trigger");
    let (rig, devices, truth) = bench_with(
        12,
        SimRigConfig {
            camera_trigger: Some(50.0),
            ..SimRigConfig::default()
        },
    );
    let text = plan("[12.0]", "[25.0]", "force_targets = [2.0, 4.0]", 0.3);
    let mut setup = setup(&rig, &text);
    let camera = fringe_sim::SimCameraConfig::default();
    setup.sync = SyncMethod::Trigger;
    setup.camera.trigger = TriggerMode::Hardware("Line1".into());
    setup.trigger = Some(TriggerTiming {
        scan_rate: Hertz(5000.0),
        frame_rate: setup.camera.frame_rate,
        delay: Microseconds(camera.trigger_latency_us + camera.line_response_us),
        exposure: setup.camera.exposure,
    });
    let (mut operator, _) = scripted(Reply::Continue);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "trigger".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    assert_eq!(out.lost_force_samples, 0);
    let records = records(&out.run_dir);
    assert!(records.len() > 50, "{} frames", records.len());
    assert!(
        records.iter().all(|r| r.wrench.is_some()),
        "every frame labelled: {:?}",
        records.iter().find(|r| r.wrench.is_none())
    );
    let score = fringe_sim::ground_truth::score_labels(&records, &truth.frames()).expect("score");
    assert!(score.force_rms_n < 0.15, "{score:?}");
    let start: StartDocument = RunReader::at(&out.run_dir).start().expect("start document");
    assert_eq!(start.sync_method, "trigger");
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A sidecar whose every take hands over one numbered line and notes what its file held then.
#[derive(Debug, Default)]
struct Numbered {
    dir: Mutex<Option<std::path::PathBuf>>,
    seen: Mutex<Vec<usize>>,
}

impl RunSidecar for Numbered {
    fn file_name(&self) -> &str {
        "numbered.jsonl"
    }

    fn take_lines(&self) -> Vec<String> {
        let mut seen = self.seen.lock().unwrap_or_else(|p| p.into_inner());
        let dir = self.dir.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let lines_in_file = dir
            .and_then(|d| std::fs::read_to_string(d.join("numbered.jsonl")).ok())
            .map_or(0, |t| t.lines().count());
        seen.push(lines_in_file);
        vec![format!("{{\"take\":{}}}", seen.len() - 1)]
    }
}

#[test]
fn sidecar_lines_reach_the_run_after_every_point_each_once() {
    let dir = tempfile_dir("sidecar");
    let (rig, devices, _truth) = bench(12);
    let text = plan("[11.0, 14.0, 17.0]", "[25.0]", "force_targets = [1.0]", 0.1);
    let mut setup = setup(&rig, &text);
    let numbered = Arc::new(Numbered::default());
    *numbered.dir.lock().unwrap_or_else(|p| p.into_inner()) = Some(dir.join("sidecar"));
    setup.sidecars = vec![numbered.clone() as Arc<dyn RunSidecar>];
    let (mut operator, _) = scripted(Reply::Continue);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "sidecar".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.points_done, 3);
    // Taken after each of the 3 points and when the run closed; each take found every earlier
    // one already in the run's file.
    let seen = numbered
        .seen
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone();
    assert_eq!(seen, vec![0, 1, 2, 3]);
    let text = std::fs::read_to_string(out.run_dir.join("numbered.jsonl")).expect("sidecar file");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines,
        vec![
            r#"{"take":0}"#,
            r#"{"take":1}"#,
            r#"{"take":2}"#,
            r#"{"take":3}"#
        ]
    );
    assert!(verify(&out.run_dir).expect("verify").ok());
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

fn tempfile_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "fringe-scan-{name}-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn phase_of(k: usize) -> Phase {
    [
        Phase::Moving,
        Phase::Approach,
        Phase::Pressing(0),
        Phase::Dwell(0),
        Phase::Retract,
    ][k]
}

/// Runs a scan that asks `act` at the first time point `at_point` enters `phase`.
fn scan_acting_at(
    name: &str,
    xs: &str,
    phases: Vec<(u64, Phase)>,
    act: fn(&ScanControl),
    reply: Reply,
) -> (ScanOutcome, SimRig) {
    let dir = tempfile_dir(name);
    let (rig, devices, _truth) = bench(21);
    let text = plan(xs, "[25.0]", "force_targets = [2.0]", 0.3);
    let setup = setup(&rig, &text);
    let (mut operator, _) = scripted(reply);
    let control = ScanControl::new();
    let pending = Mutex::new(phases);
    let c = control.clone();
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir,
            run_id: name.into(),
        },
        &control,
        &mut operator,
        &move |p| {
            if let ScanProgress::Phase { point, phase } = p {
                let mut pending = pending.lock().unwrap_or_else(|p| p.into_inner());
                if let Some(i) = pending
                    .iter()
                    .position(|&(pt, ph)| pt == point && ph == phase)
                {
                    pending.remove(i);
                    act(&c);
                }
            }
        },
    )
    .expect("scan");
    (out, rig)
}

#[test]
fn pause_now_at_every_phase_then_resume_records_every_point_once() {
    let phases: Vec<(u64, Phase)> = (0..5).map(|k| (k as u64, phase_of(k))).collect();
    let (out, rig) = scan_acting_at(
        "pause",
        "[9.5, 11.0, 12.5, 14.0, 15.5]",
        phases,
        |c| c.pause_now(),
        Reply::Continue,
    );
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    assert_eq!(out.points_done, 5);
    let events = events(&out.run_dir);
    let interrupted: Vec<u64> = events
        .iter()
        .filter(|e| e.kind == "point-interrupted")
        .filter_map(|e| e.point)
        .collect();
    assert_eq!(
        interrupted,
        vec![0, 1, 2, 3, 4],
        "every phase was interrupted once"
    );
    let records = records(&out.run_dir);
    assert_each_point_once(&records, 5);
    // The records kept are from the attempt after each interruption.
    for p in 0..5u64 {
        let cut = events
            .iter()
            .find(|e| e.kind == "point-interrupted" && e.point == Some(p))
            .map(|e| e.host_ns)
            .unwrap_or(0);
        assert!(records
            .iter()
            .filter(|r| r.point == p)
            .all(|r| r.host_arrival_ns > cut));
    }
    assert!(verify(&out.run_dir).expect("verify").ok());
    drop(rig);
    let _ = std::fs::remove_dir_all(out.run_dir);
}

#[test]
fn pause_after_the_indentation_finishes_the_point_first() {
    let (out, rig) = scan_acting_at(
        "pause-after",
        "[11.0, 14.0]",
        vec![(0, Phase::Dwell(0))],
        |c| {
            c.pause();
        },
        Reply::Continue,
    );
    assert_eq!(out.status, ExitStatus::Completed);
    let events = events(&out.run_dir);
    assert!(events.iter().all(|e| e.kind != "point-interrupted"));
    let pause = events
        .iter()
        .position(|e| e.kind == "pause")
        .expect("paused");
    let done0 = events
        .iter()
        .position(|e| e.kind == "point-done" && e.point == Some(0))
        .expect("point 0 done");
    assert!(done0 < pause, "point 0 finished before the pause");
    assert_each_point_once(&records(&out.run_dir), 2);
    drop(rig);
    let _ = std::fs::remove_dir_all(out.run_dir);
}

fn abort_at(k: usize) {
    let name = format!("abort-{k}");
    let (out, rig) = scan_acting_at(
        &name,
        "[11.0, 14.0]",
        vec![(0, phase_of(k))],
        |c| c.abort(),
        Reply::Continue,
    );
    assert_eq!(out.status, ExitStatus::Aborted, "{out:?}");
    assert_eq!(out.points_done, 0);
    // Cleanup: z back at the safe height, nothing moving, the run closed and consistent.
    let z = rig.bench.motor_z();
    let now = fringe_rig::HostTime::now();
    assert!(
        (z.true_position_at(now).0 - 14.0).abs() < 0.01,
        "z at {:?}",
        z.true_position_at(now)
    );
    assert!(
        records(&out.run_dir).is_empty(),
        "the interrupted point's frames are cut"
    );
    let report = verify(&out.run_dir).expect("verify");
    assert!(report.ok(), "{report:?}");
    drop(rig);
    let _ = std::fs::remove_dir_all(out.run_dir);
}

#[test]
fn abort_while_moving() {
    abort_at(0);
}

#[test]
fn abort_during_the_approach() {
    abort_at(1);
}

#[test]
fn abort_while_pressing() {
    abort_at(2);
}

#[test]
fn abort_during_the_dwell() {
    abort_at(3);
}

#[test]
fn abort_during_the_retract() {
    abort_at(4);
}

#[test]
fn the_force_ceiling_watcher_stops_and_retracts_at_once() {
    let dir = tempfile_dir("ceiling");
    let (rig, devices, truth) = bench(31);
    // A depth far past what the ceiling allows (about 13 N/mm).
    // A depth plan's ramp_rate is in mm/s.
    let text = plan("[12.5]", "[25.0]", "depth_targets = [2.0]", 0.3)
        .replace("force_ceiling = 12.0", "force_ceiling = 5.0")
        .replace("ramp_rate = 6.0", "ramp_rate = 2.0");
    let setup = setup(&rig, &text);
    let (mut operator, prompts) = scripted(Reply::Abort);
    let control = ScanControl::new();
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "ceiling".into(),
        },
        &control,
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Aborted);
    let events = events(&out.run_dir);
    let e = events
        .iter()
        .find(|e| e.kind == "point-interrupted")
        .expect("interrupted");
    assert!(e.message.contains("above the ceiling"), "{}", e.message);
    // The operator was asked to resume only after the force had gone.
    let prompts = prompts.lock().unwrap_or_else(|p| p.into_inner()).clone();
    assert!(
        matches!(prompts.last(), Some(Prompt::Resume { reason }) if reason.contains("ceiling"))
    );
    let peak = truth
        .frames()
        .iter()
        .filter_map(|t| t.contact.map(|c| c.0))
        .fold(0.0f64, f64::max);
    assert!(peak < 5.0 + 1.5, "true force peaked at {peak:.2} N");
    let now = fringe_rig::HostTime::now();
    assert!((rig.bench.motor_z().true_position_at(now).0 - 14.0).abs() < 0.01);
    drop(rig);
    let _ = std::fs::remove_dir_all(dir);
}

/// A force sensor that goes silent for 150 ms once when asked.
struct Stalling {
    inner: Box<dyn fringe_rig::ForceSensor>,
    stall: Arc<std::sync::atomic::AtomicBool>,
}

impl fringe_rig::ForceSensor for Stalling {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn start(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.start()
    }
    fn next_sample(
        &mut self,
        timeout: std::time::Duration,
    ) -> Result<Option<fringe_rig::ForceSample>, fringe_rig::ForceError> {
        if self.stall.swap(false, std::sync::atomic::Ordering::SeqCst) {
            std::thread::sleep(std::time::Duration::from_millis(150));
        }
        self.inner.next_sample(timeout)
    }
    fn stop(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.stop()
    }
    fn bias(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.bias()
    }
    fn stats(&self) -> fringe_rig::StreamStats {
        self.inner.stats()
    }
}

/// A force sensor that, when asked, goes silent for 150 ms and comes back as a rebooted device:
/// counted as a restart, its zero moved by `shift_n` in Fz.
struct Rebooting {
    inner: Box<dyn fringe_rig::ForceSensor>,
    reboot: Arc<std::sync::atomic::AtomicBool>,
    shift_n: f64,
    rebooted: bool,
}

impl fringe_rig::ForceSensor for Rebooting {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn start(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.start()
    }
    fn next_sample(
        &mut self,
        timeout: std::time::Duration,
    ) -> Result<Option<fringe_rig::ForceSample>, fringe_rig::ForceError> {
        if self.reboot.swap(false, std::sync::atomic::Ordering::SeqCst) {
            std::thread::sleep(std::time::Duration::from_millis(150));
            // What the box measured while it was down never arrives.
            while self.inner.next_sample(std::time::Duration::ZERO)?.is_some() {}
            self.rebooted = true;
        }
        Ok(self.inner.next_sample(timeout)?.map(|mut s| {
            if self.rebooted {
                s.wrench.fz.0 += self.shift_n;
            }
            s
        }))
    }
    fn stop(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.stop()
    }
    fn bias(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.bias()
    }
    fn stats(&self) -> fringe_rig::StreamStats {
        fringe_rig::StreamStats {
            restarts: u64::from(self.rebooted),
            ..self.inner.stats()
        }
    }
}

/// A camera that loses the next frames when asked.
struct Dropping {
    inner: Box<dyn fringe_rig::Camera>,
    drop_next: Arc<std::sync::atomic::AtomicU64>,
}

impl fringe_rig::Camera for Dropping {
    fn info(&self) -> fringe_rig::CameraInfo {
        self.inner.info()
    }
    fn configure(&mut self, s: &CameraSettings) -> Result<(), fringe_rig::CameraError> {
        self.inner.configure(s)
    }
    fn start(&mut self) -> Result<(), fringe_rig::CameraError> {
        self.inner.start()
    }
    fn trigger(&mut self) -> Result<(), fringe_rig::CameraError> {
        self.inner.trigger()
    }
    fn next_frame(
        &mut self,
        timeout: std::time::Duration,
    ) -> Result<Option<fringe_rig::Frame>, fringe_rig::CameraError> {
        use std::sync::atomic::Ordering;
        loop {
            let frame = self.inner.next_frame(timeout)?;
            let lose = frame.is_some()
                && self
                    .drop_next
                    .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
                    .is_ok();
            if !lose {
                return Ok(frame);
            }
        }
    }
    fn stop(&mut self) -> Result<(), fringe_rig::CameraError> {
        self.inner.stop()
    }
    fn latch_timestamp(&mut self) -> Result<fringe_rig::TimestampLatch, fringe_rig::CameraError> {
        self.inner.latch_timestamp()
    }
}

/// Runs a 2-point scan where `fault` is set when point 0 starts its dwell; the operator agrees
/// to resume. Returns the run's events.
fn scan_with_fault(
    name: &str,
    fault: impl Fn() + Send + Sync + 'static,
    wrap: impl FnOnce(Devices) -> Devices,
) -> (ScanOutcome, Vec<Event>) {
    let dir = tempfile_dir(name);
    let (rig, devices, _truth) = bench(41);
    let devices = wrap(devices);
    let text = plan("[11.0, 14.0]", "[25.0]", "force_targets = [2.0]", 0.6);
    let setup = setup(&rig, &text);
    let (mut operator, _) = scripted(Reply::Continue);
    let control = ScanControl::new();
    // A scan that never ends (a pause whose condition never clears) is aborted, and fails below.
    let watchdog = control.clone();
    std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_secs(90));
        watchdog.abort();
    });
    let fired = std::sync::atomic::AtomicBool::new(false);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir,
            run_id: name.into(),
        },
        &control,
        &mut operator,
        &move |p| {
            if p == (ScanProgress::Phase {
                point: 0,
                phase: Phase::Dwell(0),
            }) && !fired.swap(true, std::sync::atomic::Ordering::SeqCst)
            {
                fault();
            }
        },
    )
    .expect("scan");
    let events = events(&out.run_dir);
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    assert_each_point_once(&records(&out.run_dir), 2);
    drop(rig);
    (out, events)
}

#[test]
fn no_force_data_for_50_ms_stops_motion_and_the_point_is_done_again() {
    let stall = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let s = stall.clone();
    let (out, events) = scan_with_fault(
        "silence",
        move || s.store(true, std::sync::atomic::Ordering::SeqCst),
        |mut d| {
            d.force = Box::new(Stalling {
                inner: d.force,
                stall,
            });
            d
        },
    );
    let e = events
        .iter()
        .find(|e| e.kind == "point-interrupted")
        .expect("interrupted");
    assert_eq!(e.point, Some(0));
    assert!(e.message.contains("no force/torque data"), "{}", e.message);
    assert!(events.iter().any(|e| e.kind == "resume"));
    let _ = std::fs::remove_dir_all(out.run_dir);
}

#[test]
fn a_device_restart_with_a_zero_moved_past_the_ceiling_is_retared_not_taken_for_a_load() {
    // Fz 20 N lower reads as 20 N of pressing against the 12 N ceiling until the zero is taken
    // again; mid-dwell, with the indenter pressing.
    let reboot = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let r = reboot.clone();
    let (out, events) = scan_with_fault(
        "restart",
        move || r.store(true, std::sync::atomic::Ordering::SeqCst),
        |mut d| {
            d.force = Box::new(Rebooting {
                inner: d.force,
                reboot,
                shift_n: -20.0,
                rebooted: false,
            });
            d
        },
    );
    let kinds: Vec<&str> = events.iter().map(|e| e.kind.as_str()).collect();
    let interrupted = events
        .iter()
        .filter(|e| e.kind == "point-interrupted")
        .count();
    assert_eq!(interrupted, 1, "{kinds:?}");
    assert!(
        events
            .iter()
            .any(|e| e.kind == "warning" && e.message.contains("the device restarted")),
        "{kinds:?}"
    );
    // Every label is tared by its own point: the no-contact frames read about 0 N after the
    // shift as before it.
    for r in records(&out.run_dir) {
        let fz = r.wrench.map(|w| w.fz.0).unwrap_or_default();
        assert!(fz.abs() < 5.0, "frame {} labelled {fz} N", r.index);
    }
    let _ = std::fs::remove_dir_all(out.run_dir);
}

#[test]
fn camera_drops_above_the_threshold_pause_the_scan() {
    let drop_next = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let d2 = drop_next.clone();
    let (out, events) = scan_with_fault(
        "drops",
        move || d2.store(15, std::sync::atomic::Ordering::SeqCst),
        |mut d| {
            d.camera = Box::new(Dropping {
                inner: d.camera,
                drop_next,
            });
            d
        },
    );
    let e = events
        .iter()
        .find(|e| e.kind == "point-interrupted")
        .expect("interrupted");
    assert!(e.message.contains("camera dropped"), "{}", e.message);
    assert!(out.dropped_frames >= 15);
    let _ = std::fs::remove_dir_all(out.run_dir);
}

/// An offset check that remembers what it was asked and always finds the offset moved.
#[derive(Debug, Default)]
struct Moved {
    asked: Mutex<Vec<[f64; 6]>>,
}

impl fringe_rig::scan::OffsetCheck for Moved {
    fn check(&self, mean: [f64; 6], standard_error: [f64; 6]) -> Vec<String> {
        assert!(
            standard_error.iter().all(|s| *s > 0.0 && *s < 0.01),
            "{standard_error:?}"
        );
        self.asked
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(mean);
        vec![format!("Fz offset moved to {:.3} N", mean[2])]
    }
}

/// The profile's zero-load check is made once, on the first no-contact offset of the session,
/// with that offset; its warning is shown and kept in the run.
#[test]
fn the_zero_load_check_sees_the_first_offset_and_its_warning_is_recorded() {
    let dir = tempfile_dir("zero-load");
    let (rig, devices, _truth) = bench(47);
    let text = plan("[11.0, 14.0]", "[25.0]", "force_targets = [1.0]", 0.1);
    let mut setup = setup(&rig, &text);
    let check = Arc::new(Moved::default());
    setup.offset_check = Some(check.clone());
    let (mut operator, _) = scripted(Reply::Continue);
    let shown = Mutex::new(Vec::new());
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir,
            run_id: "zero-load".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|p| {
            if let ScanProgress::Message(m) = p {
                shown.lock().unwrap_or_else(|p| p.into_inner()).push(m);
            }
        },
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    let asked = check
        .asked
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone();
    assert_eq!(asked.len(), 1, "checked once per session");
    let events = events(&out.run_dir);
    let first_offset = events
        .iter()
        .find(|e| e.kind == "force-offset")
        .expect("offset measured");
    assert!(
        first_offset
            .message
            .contains(&format!("Fz {:.4} N", asked[0][2])),
        "{} vs {:?}",
        first_offset.message,
        asked[0]
    );
    let warnings: Vec<&Event> = events.iter().filter(|e| e.kind == "warning").collect();
    assert_eq!(warnings.len(), 1);
    assert!(warnings[0].message.contains("Fz offset moved"));
    assert!(shown
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .iter()
        .any(|m| m.starts_with("warning: Fz offset moved")));
    drop(rig);
    let _ = std::fs::remove_dir_all(out.run_dir);
}

/// A camera that keeps losing frames interrupts the same point again and again: with an
/// operator who always agrees to resume (`--yes`), the scan ends after three tries instead of
/// repeating the point for ever, and says why. Each try after the first is recorded as a
/// re-press; the stop is the engine's, not the operator's: the run closes failed (issue 62: a
/// resume goes on from the points done; it closed aborted, which a commissioning set aside and
/// pressed again whole).
#[test]
fn a_point_interrupted_three_times_in_a_row_ends_the_scan() {
    let dir = tempfile_dir("drops-forever");
    let (rig, mut devices, _truth) = bench(43);
    let drop_next = Arc::new(std::sync::atomic::AtomicU64::new(0));
    devices.camera = Box::new(Dropping {
        inner: devices.camera,
        drop_next: drop_next.clone(),
    });
    let text = plan("[11.0, 14.0]", "[25.0]", "force_targets = [2.0]", 0.6);
    let setup = setup(&rig, &text);
    let (mut operator, _) = scripted(Reply::Continue);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir,
            run_id: "drops-forever".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &move |p| {
            if let ScanProgress::Phase {
                point: 0,
                phase: Phase::Dwell(0),
            } = p
            {
                drop_next.store(15, std::sync::atomic::Ordering::SeqCst);
            }
        },
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Failed, "{out:?}");
    assert!(
        out.reason.contains("interrupted 3 times in a row")
            && out.reason.contains("camera dropped")
            && out.reason.contains("resume the run"),
        "{}",
        out.reason
    );
    assert_eq!(out.points_done, 0);
    let events = events(&out.run_dir);
    assert_eq!(
        events
            .iter()
            .filter(|e| e.kind == "point-interrupted")
            .count(),
        3
    );
    let represses: Vec<&str> = events
        .iter()
        .filter(|e| e.kind == fringe_rig::scan::REPRESS_EVENT)
        .map(|e| e.message.as_str())
        .collect();
    assert_eq!(represses.len(), 2, "{represses:?}");
    assert!(
        represses[1].contains("camera dropped") && represses[1].contains("try 3 of at most 3"),
        "{represses:?}"
    );
    assert_eq!(
        events
            .iter()
            .filter(|e| e.kind == fringe_rig::scan::STOPPED_BY_WATCHERS_EVENT)
            .count(),
        1
    );
    drop(rig);
    let _ = std::fs::remove_dir_all(out.run_dir);
}

/// With a y stage moved by hand, the grid is grouped by y, the operator is asked once per row
/// (through the scan's operator, not the stage's own prompt), and the records carry the row's y.
#[test]
fn a_manual_y_stage_is_asked_once_per_row_and_never_prompts_by_itself() {
    use fringe_rig::ManualStage;
    let dir = tempfile_dir("manual-y");
    let (rig, mut devices, _truth) = bench(17);
    // The stage's own operator has no answer: if the engine asked the stage anything, the scan
    // would fail with "cancelled".
    devices.y = Box::new(ManualStage::new("y", Box::new(NoAnswers), None));
    let text = plan("[11.0, 14.0]", "[25.0, 24.0]", "force_targets = [1.0]", 0.1);
    let mut setup = setup(&rig, &text);
    setup.limits.manual_y = true;
    let plan = Plan::parse(&text, "plan.toml").expect("plan");
    setup.program = plan.program(&setup.limits, "plan.toml").expect("program");
    let (mut operator, prompts) = scripted(Reply::Continue);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "manual-y".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    assert_eq!(out.points_done, 4);
    let asked: Vec<f64> = prompts
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .iter()
        .filter_map(|p| match p {
            Prompt::MoveY { y_mm } => Some(*y_mm),
            _ => None,
        })
        .collect();
    assert_eq!(asked.len(), 2, "one prompt per row: {asked:?}");
    let records = records(&out.run_dir);
    for r in &records {
        assert_eq!(r.measured.y, r.commanded.y, "{r:?}");
    }
    assert_eq!(
        asked,
        {
            let mut rows: Vec<f64> = Vec::new();
            for r in &records {
                if rows.last() != Some(&r.commanded.y.0) {
                    rows.push(r.commanded.y.0);
                }
            }
            rows
        },
        "rows in the order they were asked for"
    );
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `clock-fit` or `host` run through the engine (one point): every frame labelled with a
/// host-time window; returns the records and the run's documents.
fn scan_with_sync(sync: SyncMethod) -> (Vec<FrameRecord>, StopDocument, StartDocument) {
    let dir = tempfile_dir(sync.name());
    let (rig, devices, truth) = bench(23);
    let text = plan("[12.5]", "[25.0]", "force_targets = [3.0]", 0.4);
    let mut setup = setup(&rig, &text);
    setup.sync = sync;
    let (mut operator, _) = scripted(Reply::Continue);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: sync.name().into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    assert!(verify(&out.run_dir).expect("verify").ok());
    let records = records(&out.run_dir);
    let stop: StopDocument = RunReader::at(&out.run_dir)
        .stop()
        .expect("stop document")
        .expect("the run ended");
    let start: StartDocument = RunReader::at(&out.run_dir).start().expect("start document");
    let truths: BTreeMap<u64, _> = truth.frames().into_iter().map(|t| (t.id, t)).collect();
    for r in &records {
        assert!(r.wrench.is_some(), "{r:?}");
        let e = r.exposure.expect("host-time window");
        let t = truths.get(&r.frame_id).expect("truth");
        let err = 0.5 * (e.start_ns + e.end_ns)
            - 0.5 * (t.exposure_start.0 as f64 + t.exposure_end.0 as f64);
        if sync == SyncMethod::ClockFit {
            assert!(err.abs() < 500_000.0, "frame {}: {err} ns", r.frame_id);
        } else {
            // The host baseline sees the arrival, milliseconds after the exposure.
            assert!(err > 2e6, "frame {}: {err} ns", r.frame_id);
        }
    }
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
    (records, stop, start)
}

/// `clock-fit` and `host` chosen by the engine: frames labelled, the method and its error
/// estimate in the run's start and stop documents; clock-fit windows close to the truth.
#[test]
fn clock_fit_and_host_scans_label_every_frame_and_record_method_and_error() {
    for sync in [SyncMethod::ClockFit, SyncMethod::Host] {
        let (records, stop, start) = scan_with_sync(sync);
        assert!(records.len() > 10, "{sync}: {} records", records.len());
        assert_eq!(start.sync_method, sync.name());
        assert_eq!(stop.sync_method.as_deref(), Some(sync.name()));
        let e = stop.sync_error_ns.expect("error estimate");
        assert!(e > 0.0 && e < 5e6, "{sync}: estimate {e} ns");
    }
}

/// An operator with nothing to say: every question is cancelled.
struct NoAnswers;

impl Operator for NoAnswers {
    fn ask(&mut self, _prompt: &Prompt) -> Reply {
        Reply::Abort
    }

    fn answer(&mut self, _question: &str) -> std::io::Result<Option<String>> {
        Ok(None)
    }
}

/// Keeps every frame the camera delivered that became a record, by record index.
#[derive(Debug, Default)]
struct Delivered(Mutex<BTreeMap<u64, fringe_rig::Frame>>);

impl fringe_rig::RecordTap for Delivered {
    fn recorded(&self, frame: &fringe_rig::Frame, record: &FrameRecord) {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .insert(record.index, frame.clone());
    }
    fn cut(&self, first: u64) {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .retain(|&i, _| i < first);
    }
}

#[test]
fn the_run_holds_bit_for_bit_what_the_camera_delivered_whole_or_the_disc_square_in_each_codec() {
    use fringe_rig::store::{Encoding, FrameStorage};
    use fringe_rig::PixelFormat;
    // Whole frames in PNG planes (asked for); the disc's square in the default FGL.
    for (disc, codec) in [(false, Some(FrameCodec::Png)), (true, None)] {
        let name = if disc {
            "bits-disc-fgl"
        } else {
            "bits-whole-png"
        };
        let dir = tempfile_dir(name);
        let (rig, devices, _truth) = bench(31);
        let text = plan("[12.0]", "[25.0]", "force_targets = [3.0]", 0.2);
        let mut setup = setup(&rig, &text);
        setup.codec = codec;
        let g = &rig.config.sensor.geometry;
        if disc {
            setup.cutout = Some(
                FrameStorage::disc_square(
                    [
                        f64::from(g.width) / 2.0 + g.centre_offset_px[0],
                        f64::from(g.height) / 2.0 + g.centre_offset_px[1],
                    ],
                    g.disc_radius_px,
                    10.0,
                    g.width,
                    g.height,
                )
                .expect("the disc fits"),
            );
        }
        let delivered = Arc::new(Delivered::default());
        setup.taps.push(delivered.clone());
        let (mut operator, _) = scripted(Reply::Continue);
        let out = run_scan(
            &setup,
            devices,
            RunTarget::New {
                root: dir.clone(),
                run_id: name.into(),
            },
            &ScanControl::new(),
            &mut operator,
            &|_| {},
        )
        .expect("scan");
        assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
        let start: StartDocument = RunReader::at(&out.run_dir).start().expect("start");
        let storage = start.frames.expect("the run records how it stores frames");
        // The simulated camera delivers its native format by default, stored as colour planes
        // or in FGL.
        assert_eq!(storage.pixel_format, PixelFormat::BayerRg8);
        let (encoding, extension) = match codec {
            Some(FrameCodec::Png) => (Encoding::PngBayerPlanes, ".png"),
            _ => (Encoding::Fgl, ".fgl"),
        };
        assert_eq!(storage.encoding, encoding);
        assert_eq!(storage.cutout, setup.cutout);
        let records = records(&out.run_dir);
        let delivered = delivered.0.lock().unwrap_or_else(|p| p.into_inner());
        assert_eq!(delivered.len(), records.len());
        assert!(records.len() > 20, "{} records", records.len());
        for r in &records {
            assert!(r.file.ends_with(extension), "{}", r.file);
            let camera = &delivered[&r.index];
            let stored = storage
                .read(&r.file_in(&out.run_dir).expect("file"))
                .expect("stored frame");
            let (x0, y0, w, h) = match storage.cutout {
                None => (0, 0, camera.width, camera.height),
                Some(c) => (c.roi.x, c.roi.y, c.roi.width, c.roi.height),
            };
            assert_eq!((stored.width, stored.height), (w, h));
            let expected: Vec<u8> = (y0..y0 + h)
                .flat_map(|y| {
                    let at = (y * camera.width + x0) as usize;
                    camera.data[at..at + w as usize].iter().copied()
                })
                .collect();
            assert!(
                stored.data == expected,
                "{name}: record {} differs",
                r.index
            );
        }
        assert!(verify(&out.run_dir).expect("verify").ok());
        drop(rig);
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// A force sensor that reads `shift_n` more in Fz (compression: a pressing load) from when
/// `loaded` is set: a load the engine can only tell from the F/T.
struct Loading {
    inner: Box<dyn fringe_rig::ForceSensor>,
    loaded: Arc<std::sync::atomic::AtomicBool>,
    shift_n: f64,
}

impl fringe_rig::ForceSensor for Loading {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn start(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.start()
    }
    fn next_sample(
        &mut self,
        timeout: std::time::Duration,
    ) -> Result<Option<fringe_rig::ForceSample>, fringe_rig::ForceError> {
        let loaded = self.loaded.load(std::sync::atomic::Ordering::SeqCst);
        Ok(self.inner.next_sample(timeout)?.map(|mut s| {
            if loaded {
                s.wrench.fz.0 += self.shift_n;
            }
            s
        }))
    }
    fn stop(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.stop()
    }
    fn bias(&mut self) -> Result<(), fringe_rig::ForceError> {
        self.inner.bias()
    }
    fn stats(&self) -> fringe_rig::StreamStats {
        self.inner.stats()
    }
}

/// The true x and z of the simulated bench now, mm.
fn true_xz(rig: &SimRig) -> (f64, f64) {
    let now = fringe_rig::HostTime::now();
    (
        rig.bench.motor_x().true_position_at(now).0,
        rig.bench.motor_z().true_position_at(now).0,
    )
}

/// The no-contact offsets (tares) a run took, by point.
fn tares(events: &[Event]) -> Vec<Option<u64>> {
    events
        .iter()
        .filter(|e| e.kind == "force-offset")
        .map(|e| e.point)
        .collect()
}

#[test]
fn a_safe_height_past_the_sensor_surface_is_refused_before_the_run_exists_and_nothing_moves() {
    // The issue's plan: two points 4 mm apart, safe_z 16 with the surface at 15 mm, handed to
    // the engine past the plan's check: the approach must not turn round and search upwards.
    let dir = tempfile_dir("past-surface");
    let (rig, devices, _truth) = bench(51);
    let text = plan("[10.5, 14.5]", "[25.0]", "force_targets = [2.0]", 0.3);
    let mut setup = setup(&rig, &text);
    setup.program.plan.approach.safe_z = 16.0;
    let before = true_xz(&rig);
    let (mut operator, _) = scripted(Reply::Continue);
    let err = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "past".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect_err("refused");
    let t = err.to_string();
    assert!(
        t.contains(
            "approach.safe_z: 16 mm is at or past the sensor surface (first contact at z = 15 mm"
        ),
        "{t}"
    );
    assert!(!dir.join("past").exists(), "a run was made: {t}");
    std::thread::sleep(std::time::Duration::from_millis(200));
    assert_eq!(true_xz(&rig), before, "something moved");
    drop(rig);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_load_on_the_way_to_the_safe_height_stops_z_before_any_tare_or_lateral_move() {
    // The rig's contact height is wrong (17 mm; the surface is at 15): a plan's safe height of
    // 16 mm passes the plan's check but lies 1 mm inside the sensor.
    let dir = tempfile_dir("load-at-safe");
    let (rig, devices, _truth) = bench(52);
    let text = plan("[10.5, 14.5]", "[25.0]", "force_targets = [2.0]", 0.3)
        .replace("safe_z = 14.0", "safe_z = 16.0");
    let mut setup = setup(
        &rig,
        &plan("[10.5]", "[25.0]", "force_targets = [2.0]", 0.3),
    );
    setup.limits.contact_z = Millimetres(17.0);
    setup.program = Plan::parse(&text, "plan.toml")
        .expect("plan")
        .program(&setup.limits, "plan.toml")
        .expect("a safe height short of the rig's (wrong) contact height");
    setup.plan_text = text;
    let (mut operator, _) = scripted(Reply::Continue);
    let err = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "load".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect_err("refused under load");
    let t = err.to_string();
    assert!(
        t.contains("of load at z") && t.contains("the move down to the safe height was stopped"),
        "{t}"
    );
    let run = dir.join("load");
    let events = events(&run);
    assert_eq!(
        tares(&events),
        Vec::<Option<u64>>::new(),
        "a tare under load"
    );
    let stop: StopDocument = RunReader::at(&run)
        .stop()
        .expect("stop")
        .expect("the run ended");
    assert_eq!(stop.exit_status, ExitStatus::Failed);
    assert_eq!(stop.points_done, 0);
    // x stayed where homing left it, and z was lifted off the sensor to the top of its travel.
    let (x, z) = true_xz(&rig);
    assert!(x.abs() < 1e-6, "x moved to {x}");
    assert!(z.abs() < 0.01, "z left at {z}");
    drop(rig);
    let _ = std::fs::remove_dir_all(dir);
}

/// Runs the 2-point plan with the F/T reading 5 N of load from `phase` of point `point` on
/// (after a pause of `delay_ms` in its own thread); the error and the run's events.
fn scan_loaded_from(
    name: &str,
    point: u64,
    phase: Phase,
    delay_ms: u64,
) -> (String, Vec<Event>, SimRig) {
    let dir = tempfile_dir(name);
    let (rig, mut devices, _truth) = bench(53);
    let loaded = Arc::new(std::sync::atomic::AtomicBool::new(false));
    devices.force = Box::new(Loading {
        inner: devices.force,
        loaded: loaded.clone(),
        shift_n: -5.0,
    });
    let text = plan("[11.0, 14.0]", "[25.0]", "force_targets = [2.0]", 0.3);
    let setup = setup(&rig, &text);
    let (mut operator, _) = scripted(Reply::Continue);
    let err = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: name.into(),
        },
        &ScanControl::new(),
        &mut operator,
        &move |p| {
            if p == (ScanProgress::Phase { point, phase }) {
                let loaded = loaded.clone();
                let set = move || {
                    std::thread::sleep(std::time::Duration::from_millis(delay_ms));
                    loaded.store(true, std::sync::atomic::Ordering::SeqCst);
                };
                if delay_ms == 0 {
                    set();
                    // The loaded samples reach the stream before the engine reads it again.
                    std::thread::sleep(std::time::Duration::from_millis(60));
                } else {
                    std::thread::spawn(set);
                }
            }
        },
    )
    .expect_err("refused under load");
    let events = events(&dir.join(name));
    (err.to_string(), events, rig)
}

#[test]
fn a_lateral_move_under_load_is_refused_and_z_lifted() {
    let (t, events, rig) = scan_loaded_from("lateral-load", 1, Phase::Moving, 0);
    assert!(
        t.contains("N of load at z") && t.contains("the lateral move was not started"),
        "{t}"
    );
    // Point 1 was tared before the load came; x never left point 0.
    assert_eq!(tares(&events), vec![Some(0), Some(1)]);
    let (x, z) = true_xz(&rig);
    assert!((x - 11.0).abs() < 1e-6, "x moved to {x}");
    assert!(z.abs() < 0.01, "z left at {z}");
}

#[test]
fn a_load_during_a_lateral_move_stops_it_at_once() {
    let (t, _events, rig) = scan_loaded_from("lateral-moving", 1, Phase::Moving, 150);
    assert!(t.contains("the lateral move was stopped at once"), "{t}");
    let (x, _) = true_xz(&rig);
    assert!(x > 11.05 && x < 13.95, "x at {x}: not stopped on the way");
}

#[test]
fn no_no_contact_offset_is_taken_under_load() {
    // The load comes while point 0 retracts: the tare of point 1 would take it as the zero.
    let (t, events, rig) = scan_loaded_from("tare-load", 0, Phase::Retract, 0);
    assert!(
        t.contains("the no-contact offset (tare) was not taken"),
        "{t}"
    );
    assert_eq!(tares(&events), vec![Some(0)], "a tare under load");
    let (x, _) = true_xz(&rig);
    assert!((x - 11.0).abs() < 1e-6, "x moved to {x}");
}

/// A plan at `x`, `y` (stage mm) pressing to `force` N, then sliding as `slide` says.
fn slide_plan(x: f64, y: f64, force: f64, slide: &str, tangential_ceiling: f64) -> String {
    format!(
        "{}tangential_ceiling = {tangential_ceiling}\n[slide]\n{slide}\n",
        plan(
            &format!("[{x}]"),
            &format!("[{y}]"),
            &format!("force_targets = [{force}]"),
            0.3
        )
    )
}

/// The stage position over the sensor centre on the simulated bench.
fn centre(rig: &SimRig) -> (f64, f64) {
    let g = &rig.bench.config().geometry;
    (g.x_centre_mm, g.y_centre_mm)
}

#[test]
fn a_slide_holds_the_normal_force_and_every_frame_is_labelled_where_the_indenter_was() {
    let dir = tempfile_dir("slide");
    let (rig, devices, truth) = bench(61);
    let (cx, cy) = centre(&rig);
    // From 1 mm left of the centre, 2 mm along +x at 1 mm/s, holding 3 N.
    let text = slide_plan(
        cx - 1.0,
        cy,
        3.0,
        "directions = [\"x\"]\ndistance = 2.0\nspeeds = [1.0]\ndwell = 0.3",
        12.0,
    );
    let setup = setup(&rig, &text);
    let (mut operator, _) = scripted(Reply::Continue);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "slide".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    let report = verify(&out.run_dir).expect("verify");
    assert!(report.ok(), "{report:?}");
    let events = events(&out.run_dir);
    let slid = events
        .iter()
        .find(|e| e.kind == "slide")
        .expect("a slide event");
    assert!(
        slid.message
            .starts_with("slid 2.000 mm at 0 degrees at 1.000 mm/s holding 3.00 N"),
        "{}",
        slid.message
    );
    let records = records(&out.run_dir);
    let truths: BTreeMap<u64, _> = truth.frames().into_iter().map(|t| (t.id, t)).collect();
    // The frames of the slide: commanded x strictly between where it started and ended.
    let sliding: Vec<_> = records
        .iter()
        .filter(|r| r.commanded.x.0 > cx - 0.999 && r.commanded.x.0 < cx + 0.999)
        .collect();
    assert!(
        sliding.len() > 60,
        "{} frames while sliding 2 s",
        sliding.len()
    );
    let (mut normal_sq, mut contact_worst, mut gross, mut tangential_err_sq) =
        (0.0f64, 0.0f64, 0usize, 0.0f64);
    for r in &sliding {
        let w = r.wrench.expect("every sliding frame labelled");
        let t = truths.get(&r.frame_id).expect("truth of the frame");
        let (p, tx, ty) = t.contact.expect("in contact all along the slide");
        normal_sq += (-w.fz.0 - 3.0).powi(2);
        // The label's contact is where the slide had taken the indenter mid-exposure.
        let c = r.contact.expect("contact label");
        contact_worst = contact_worst.max((c[0] - tx).hypot(c[1] - ty));
        let (q, slip) = t.shear.expect("a sheared contact");
        if slip == fringe_rig::Slip::GrossSlip {
            gross += 1;
        }
        // The F/T's tangential force is the push on the surface, as large.
        tangential_err_sq += (w.fx.0.hypot(w.fy.0) - q[0].hypot(q[1])).powi(2);
        assert!(p > 1.5, "normal force {p} N while sliding");
    }
    let n = sliding.len() as f64;
    let normal_rms = (normal_sq / n).sqrt();
    let tangential_rms = (tangential_err_sq / n).sqrt();
    eprintln!(
        "slide: {n} frames, normal force RMS {normal_rms:.3} N off 3 N, contact label at most {contact_worst:.4} mm off, tangential label RMS {tangential_rms:.3} N, {gross} frames of gross slip"
    );
    assert!(
        normal_rms < 0.3,
        "normal force RMS {normal_rms:.3} N off 3 N while sliding"
    );
    assert!(
        contact_worst < 0.05,
        "contact label {contact_worst:.3} mm off the truth"
    );
    assert!(
        tangential_rms < 0.15,
        "tangential label RMS {tangential_rms:.3} N off the truth"
    );
    assert!(gross > 20, "{gross} frames of gross slip in a 2 mm slide");
    // It ended where it was sent, and the frames after it say so.
    let last = records
        .iter()
        .rev()
        .find(|r| r.contact.is_some())
        .expect("last contact");
    // (Positions are stored as 32-bit floats.)
    assert!((last.commanded.x.0 - (cx + 1.0)).abs() < 1e-5, "{last:?}");
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_slides_frames_carry_its_signed_shear_and_when_it_slipped() {
    use fringe_rig::Slip;
    let dir = tempfile_dir("slide-labels");
    let (rig, devices, truth) = bench(73);
    let (cx, cy) = centre(&rig);
    // 2 mm at 120 degrees (up and to the left), holding 3 N, then half a second at rest.
    let text = slide_plan(
        cx + 0.5,
        cy - 0.9,
        3.0,
        "directions = [120.0]\ndistance = 2.0\nspeeds = [1.0]\ndwell = 0.5",
        12.0,
    );
    let setup = setup(&rig, &text);
    let (mut operator, _) = scripted(Reply::Continue);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "slide-labels".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Completed, "{out:?}");
    let start = RunReader::at(&out.run_dir).start().expect("start");
    assert_eq!(start.ft_axes, Some(rig.bench.config().mount.axes()));
    let records = records(&out.run_dir);
    let slips = fringe_rig::slip_labels(&records);
    let truths: BTreeMap<u64, _> = truth.frames().into_iter().map(|t| (t.id, t)).collect();
    let (mut sq, mut n, mut largest) = ([0.0f64; 2], 0usize, [0.0f64; 2]);
    // Frames in order with their label and the truth, where both know the contact.
    let mut states: Vec<(Option<Slip>, Slip)> = Vec::new();
    for (r, label) in records.iter().zip(&slips) {
        let Some(t) = truths.get(&r.frame_id) else {
            continue;
        };
        let (Some(_), Some((q, slip))) = (r.contact, t.shear) else {
            continue;
        };
        let shear = r.shear.expect("a shear label on every labelled frame");
        for k in 0..2 {
            sq[k] += (shear[k] - q[k]).powi(2);
            if q[k].abs() > largest[k].abs() {
                largest[k] = q[k];
            }
        }
        n += 1;
        states.push((*label, slip));
    }
    let rms = sq.map(|s| (s / n as f64).sqrt());
    // The push is along 120 degrees: -x and +y in the sensor's frame.
    assert!(largest[0] < -1.0 && largest[1] > 1.8, "{largest:?}");
    let onset_label = states
        .iter()
        .position(|s| s.0 == Some(Slip::GrossSlip))
        .expect("gross slip labelled");
    let onset_truth = states
        .iter()
        .position(|s| s.1 == Slip::GrossSlip)
        .expect("gross slip in the truth");
    let agree = states.iter().filter(|s| s.0 == Some(s.1)).count();
    let gross_agree = states
        .iter()
        .filter(|s| (s.0 == Some(Slip::GrossSlip)) == (s.1 == Slip::GrossSlip))
        .count();
    eprintln!(
        "slide at 120 degrees: {n} frames in contact; shear label RMS {:.3} N (x), {:.3} N (y) off the truth; largest push {largest:?} N; gross slip from frame {onset_label} (truth {onset_truth}); slip state agrees on {agree} of {} frames, gross slip or not on {gross_agree}",
        rms[0],
        rms[1],
        states.len()
    );
    assert!(
        rms[0] < 0.1 && rms[1] < 0.1,
        "shear labels RMS {rms:?} N off the truth"
    );
    assert!(
        onset_label.abs_diff(onset_truth) <= 2,
        "gross slip labelled from frame {onset_label}, truly from {onset_truth}"
    );
    assert!(
        gross_agree as f64 >= 0.95 * states.len() as f64,
        "gross slip or not agrees on {gross_agree} of {} frames",
        states.len()
    );
    // Stick, partial slip, gross slip: the frames that differ are the few after the indenter
    // stops, which the simulator still slides while the push relaxes at the friction limit
    // (nothing the bench records shows it).
    assert!(
        agree as f64 >= 0.9 * states.len() as f64,
        "the slip state agrees on {agree} of {} frames",
        states.len()
    );
    // Before the slide, the press sticks, and the label says so.
    assert!(states[..10]
        .iter()
        .all(|s| s == &(Some(Slip::Stick), Slip::Stick)));
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A slide that pushes a gauge of the DAQ to the limit of its input range: the clipped gauge
/// would make the force nonsense (the servo would press on, the ceilings would not see it), so
/// the force path stops, and with it the slide; the true normal force never ran away.
#[test]
fn a_gauge_saturated_by_a_slide_stops_the_scan_before_the_force_runs_away() {
    let dir = tempfile_dir("saturated");
    // An indenter on a long tool (120 mm): a push of a newton or two turns the F/T enough to
    // drive a gauge to the DAQ's +-10 V.
    let mut config = SimRigConfig::default();
    config.bench.mount.tool_length_mm = 120.0;
    let (rig, devices, _truth) = bench_with(79, config);
    let (cx, cy) = centre(&rig);
    let text = slide_plan(
        cx - 1.0,
        cy,
        3.0,
        "directions = [\"x\"]\ndistance = 2.0\nspeeds = [1.0]",
        12.0,
    );
    let setup = setup(&rig, &text);
    let watching = Arc::new(std::sync::atomic::AtomicBool::new(true));
    let watcher = {
        let (bench, watching) = (rig.bench.clone(), watching.clone());
        std::thread::spawn(move || {
            let (mut normal, mut push) = (0.0f64, 0.0f64);
            while watching.load(std::sync::atomic::Ordering::SeqCst) {
                let t = bench.truth_at(fringe_rig::HostTime::now());
                normal = normal.max(t.normal_force.0);
                push = push.max(t.shear_n[0].hypot(t.shear_n[1]));
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            (normal, push)
        })
    };
    let (mut operator, _) = scripted(Reply::Abort);
    let result = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "saturated".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    );
    watching.store(false, std::sync::atomic::Ordering::SeqCst);
    let (normal, push) = watcher.join().expect("watcher");
    let said = match &result {
        Ok(out) => format!("{out:?}"),
        Err(e) => e.to_string(),
    };
    eprintln!("saturated gauge: {said}; true normal force at most {normal:.2} N, push {push:.2} N");
    assert!(said.contains("saturated"), "{said}");
    assert!(
        push > 0.5,
        "the slide never pushed ({push:.2} N): nothing was tested"
    );
    assert!(
        normal < 3.0 + 1.0,
        "the normal force ran away to {normal:.2} N"
    );
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_tangential_force_over_its_ceiling_stops_the_slide_at_once_and_lifts() {
    let dir = tempfile_dir("tangential-ceiling");
    let (rig, devices, _truth) = bench(67);
    let (cx, cy) = centre(&rig);
    // 4 N pressed: the contact sticks up to about 4 N of push, far past a 1.5 N ceiling.
    let text = slide_plan(
        cx - 1.0,
        cy,
        4.0,
        "directions = [\"x\"]\ndistance = 2.0\nspeeds = [1.0]",
        1.5,
    );
    let setup = setup(&rig, &text);
    // The bench's true push, every millisecond of the scan.
    let watching = Arc::new(std::sync::atomic::AtomicBool::new(true));
    let watcher = {
        let (bench, watching) = (rig.bench.clone(), watching.clone());
        std::thread::spawn(move || {
            let mut peak = 0.0f64;
            while watching.load(std::sync::atomic::Ordering::SeqCst) {
                let q = bench.truth_at(fringe_rig::HostTime::now()).shear_n;
                peak = peak.max(q[0].hypot(q[1]));
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            peak
        })
    };
    let (mut operator, prompts) = scripted(Reply::Abort);
    let out = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "tangential".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect("scan");
    assert_eq!(out.status, ExitStatus::Aborted);
    let events = events(&out.run_dir);
    let e = events
        .iter()
        .find(|e| e.kind == "point-interrupted")
        .expect("interrupted");
    assert!(
        e.message
            .contains("above the tangential ceiling 1.50 N: motion stopped and z lifted"),
        "{}",
        e.message
    );
    let prompts = prompts.lock().unwrap_or_else(|p| p.into_inner()).clone();
    assert!(
        matches!(prompts.last(), Some(Prompt::Resume { reason }) if reason.contains("tangential")),
        "{prompts:?}"
    );
    // Never more than 1 N past the ceiling, in the bench's truth.
    watching.store(false, std::sync::atomic::Ordering::SeqCst);
    let peak = watcher.join().expect("watcher");
    eprintln!("tangential ceiling 1.5 N: the push peaked at {peak:.3} N");
    assert!(
        peak > 1.5,
        "the push reached {peak:.2} N: the ceiling was never tested"
    );
    assert!(peak < 1.5 + 1.0, "the push peaked at {peak:.2} N");
    // x stopped short of the slide's end; z back at the safe height.
    let now = fringe_rig::HostTime::now();
    let x = rig.bench.motor_x().true_position_at(now).0;
    assert!(x < cx + 0.9, "x went on to {x}");
    assert!((rig.bench.motor_z().true_position_at(now).0 - 14.0).abs() < 0.01);
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_slide_that_would_leave_the_disc_is_refused_before_the_run_exists() {
    let dir = tempfile_dir("off-disc");
    let (rig, devices, _truth) = bench(71);
    let (cx, cy) = centre(&rig);
    // A sensor with a disc 20 mm across (the simulated one, 54 mm, is wider than the stage's
    // travel): from 8 mm off its centre along +y, 3 mm further, 1 mm past its edge.
    let radius = 10.0;
    let distance = 3.0;
    let text = slide_plan(
        cx,
        cy + 8.0,
        3.0,
        &format!("directions = [\"y\"]\ndistance = {distance}\nspeeds = [1.0]"),
        12.0,
    );
    let setup = ScanSetup {
        disc_radius: Some(Millimetres(radius)),
        ..setup(&rig, &text)
    };
    let (mut operator, _) = scripted(Reply::Continue);
    let err = run_scan(
        &setup,
        devices,
        RunTarget::New {
            root: dir.clone(),
            run_id: "off".into(),
        },
        &ScanControl::new(),
        &mut operator,
        &|_| {},
    )
    .expect_err("refused");
    let t = err.to_string();
    assert!(
        t.contains("the slide of point 1")
            && t.contains(&format!(
                "ends at contact [0.000, {:.3}] mm, {:.3} mm from the sensor centre, off the disc (radius {radius:.3} mm",
                radius + 1.0,
                radius + 1.0
            )),
        "{t}"
    );
    assert!(!dir.join("off").exists(), "the run was made");
    let now = fringe_rig::HostTime::now();
    let x0 = rig.config.bench.x.power_up_mm;
    assert!(
        (rig.bench.motor_x().true_position_at(now).0 - x0).abs() < 1e-9,
        "x moved"
    );
    drop(rig);
    let _ = std::fs::remove_dir_all(&dir);
}
