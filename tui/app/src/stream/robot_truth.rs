//! On the simulated bench the simulator plays a robot: it presses the sensor at random places,
//! forces and indenters (`fringe_sim::Robot`, driving the bench's motors), and the simulator's
//! ground truth of every frame (the normal force and contact point at mid-exposure) is kept
//! beside the stream. Each streamed prediction is scored against it with the label rules and
//! the scoring `fringe eval` applies to a run's frames: Fz, contact and shape, per frame, no
//! smoothing.

use crate::rig::simulated::SimBench;
use crate::stream::latency::percentile;
use crate::stream::stream_error::StreamError;
use fringe_rig::reference_layout::NO_CONTACT;
use fringe_rig::HostTime;
use fringe_sensor_models::dataset::{label, Sample};
use fringe_sensor_models::eval::score;
use fringe_sensor_models::{Errors, Prediction, Scored};
use fringe_sim::ground_truth::{FrameTruth, TruthRecord};
use fringe_sim::{Robot, RobotConfig, RobotPress, TruthSpool};
use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

/// How often the robot is advanced.
const TICK: Duration = Duration::from_millis(5);
/// How often the ground truth is gathered.
const GATHER_EVERY: usize = 200;

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// A frame the stream sent out, kept for the truth.
pub(crate) struct Streamed {
    /// Its device timestamp (exposure start, camera ticks): the truth's key.
    pub ticks: u64,
    /// Its header stamp, Unix ns.
    pub stamp_unix_ns: i64,
    /// Its exposure on the host clock as the camera clock placed it, ns (`None` before the
    /// clock was fitted).
    pub exposure_host_ns: Option<[f64; 2]>,
    /// Seconds since the stream started when it was sent (the live chart's time).
    pub t_s: f64,
    pub prediction: Prediction,
}

/// The stream scored against the truth.
pub(crate) struct ScoredStream {
    /// Each frame matched: its header stamp (Unix ns) and its true label.
    pub frames: Vec<(i64, Sample)>,
    pub errors: Errors,
    /// How far the placed exposure ends were from the true ones: median and 99th percentile,
    /// µs (`None` when no frame was placed).
    pub exposure_error_us: Option<[f64; 2]>,
}

/// The stream scored as it goes: the frames matched so far and their errors, and the true Fz
/// of the last seconds for a live chart.
#[derive(Debug, Default)]
pub(crate) struct LiveScore {
    /// The first streamed frame not judged yet.
    next: usize,
    /// Frames scored, and their errors as `fringe eval` computes them.
    pub n: usize,
    pub errors: Errors,
    /// (seconds since the stream started, true Fz in N) of the last [`LIVE_SECONDS`].
    pub true_fz: VecDeque<(f64, f64)>,
}

/// How much of the true Fz the live score keeps, s.
pub(crate) const LIVE_SECONDS: f64 = 10.0;

/// What the robot did and what the bench really showed, shared with the stream.
#[derive(Default)]
struct Truth {
    presses: Vec<RobotPress>,
    /// Frames' truth by exposure start (camera ticks), as a run's labels are matched.
    frames: HashMap<u64, FrameTruth>,
    /// The latest exposure start gathered: a frame before it without truth never gets any.
    latest_ticks: Option<u64>,
}

/// One streamed frame against its truth.
struct Judged {
    /// How far the camera clock placed its exposure end from the true one, µs.
    placed_off_us: Option<f64>,
    /// Its true label and its scores (`None`: a frame the robot's presses do not explain, or of
    /// a shape the model does not know).
    scored: Option<(Sample, Scored)>,
}

impl Truth {
    /// Judges `f` against the truth (`None`: no truth for it, yet or ever).
    fn judge(&self, classes: &[String], f: &Streamed) -> Option<Judged> {
        let t = self.frames.get(&f.ticks)?;
        let placed_off_us = f
            .exposure_host_ns
            .map(|[_, end]| (end - t.exposure_end.0 as f64).abs() * 1e-3);
        let scored = sample_of(t, &self.presses).and_then(|sample| {
            let shape_true = classes.iter().position(|c| *c == sample.shape)?;
            let scored = score(classes, shape_true, &sample, &f.prediction);
            Some((sample, scored))
        });
        Some(Judged {
            placed_off_us,
            scored,
        })
    }
}

/// The robot at work and the truth it leaves.
pub(crate) struct RobotTruth {
    stop: Arc<AtomicBool>,
    truth: Arc<Mutex<Truth>>,
    spool: Arc<TruthSpool>,
    thread: Option<JoinHandle<()>>,
    /// The indenters it presses.
    pub shapes: Vec<String>,
}

impl RobotTruth {
    /// Starts the robot on `sim`, pressing with the indenters among `classes` the sensor has.
    pub(crate) fn start(
        sim: &SimBench,
        classes: &[String],
        seed: u64,
    ) -> Result<RobotTruth, StreamError> {
        let sensor = sim.config().sensor.clone();
        let shapes: Vec<String> = classes
            .iter()
            .filter(|c| c.as_str() != NO_CONTACT && sensor.indenter_tip(c).is_some())
            .cloned()
            .collect();
        let mut robot = Robot::new(
            sim.bench().clone(),
            sensor,
            RobotConfig {
                seed,
                shapes: shapes.clone(),
                ..RobotConfig::default()
            },
        )?;
        let stop = Arc::new(AtomicBool::new(false));
        let truth = Arc::new(Mutex::new(Truth::default()));
        let spool = sim.truth.clone();
        spool.pass_over_unfilmed();
        let thread = {
            let (stop, truth, spool) = (stop.clone(), truth.clone(), spool.clone());
            std::thread::Builder::new()
                .name("sim-robot".into())
                .spawn(move || {
                    let mut n = 0usize;
                    while !stop.load(Ordering::Relaxed) {
                        robot.tick(HostTime::now());
                        n += 1;
                        if n == GATHER_EVERY {
                            n = 0;
                            gather(&spool, &truth, robot.presses());
                        }
                        std::thread::sleep(TICK);
                    }
                    gather(&spool, &truth, robot.presses());
                })
                .map_err(|source| StreamError::Thread {
                    what: "simulated robot",
                    source,
                })?
        };
        Ok(RobotTruth {
            stop,
            truth,
            spool,
            thread: Some(thread),
            shapes,
        })
    }

    /// Stops the robot (where it is) and gathers the last of the truth.
    pub(crate) fn stop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let presses = lock(&self.truth).presses.clone();
        gather(&self.spool, &self.truth, &presses);
    }

    /// Presses made so far.
    pub(crate) fn presses(&self) -> usize {
        lock(&self.truth).presses.len()
    }

    /// Scores the `streamed` predictions (device timestamp, header stamp, prediction) against
    /// the truth: each frame matched with its true label, and the errors as `fringe eval`
    /// computes them.
    pub(crate) fn score(&self, classes: &[String], streamed: &[Streamed]) -> ScoredStream {
        let truth = lock(&self.truth);
        let mut errors = Errors::default();
        let mut frames = Vec::new();
        let mut placed_off_us = Vec::new();
        for f in streamed {
            let Some(judged) = truth.judge(classes, f) else {
                continue;
            };
            placed_off_us.extend(judged.placed_off_us);
            if let Some((sample, scored)) = judged.scored {
                errors.add(&scored);
                frames.push((f.stamp_unix_ns, sample));
            }
        }
        placed_off_us.sort_by(f64::total_cmp);
        let exposure_error_us = (!placed_off_us.is_empty()).then(|| {
            [
                percentile(&placed_off_us, 50.0),
                percentile(&placed_off_us, 99.0),
            ]
        });
        ScoredStream {
            frames,
            errors,
            exposure_error_us,
        }
    }

    /// Scores the frames streamed since the last call whose truth has been gathered into
    /// `live` (a frame waits for its truth, gathered about once a second; one the truth has
    /// passed without a record is left out, as [`RobotTruth::score`] leaves it out).
    pub(crate) fn score_new(
        &self,
        classes: &[String],
        streamed: &[Streamed],
        live: &mut LiveScore,
    ) {
        let truth = lock(&self.truth);
        for f in streamed.get(live.next..).unwrap_or_default() {
            match truth.judge(classes, f) {
                Some(judged) => {
                    if let Some((sample, scored)) = judged.scored {
                        live.errors.add(&scored);
                        live.n += 1;
                        live.true_fz.push_back((f.t_s, sample.fz()));
                    }
                }
                None if truth.latest_ticks.is_some_and(|l| l >= f.ticks) => {}
                None => break,
            }
            live.next += 1;
        }
        if let Some(&(newest, _)) = live.true_fz.back() {
            while live
                .true_fz
                .front()
                .is_some_and(|(t, _)| newest - t > LIVE_SECONDS)
            {
                live.true_fz.pop_front();
            }
        }
    }
}

impl Drop for RobotTruth {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Takes the frame records waiting in `spool` into `truth`, and the robot's presses.
fn gather(spool: &TruthSpool, truth: &Mutex<Truth>, presses: &[RobotPress]) {
    let records = spool.take();
    let mut t = lock(truth);
    for r in records {
        if let TruthRecord::Frame(f) = r {
            t.latest_ticks = t.latest_ticks.max(Some(f.exposure_start_ticks));
            t.frames.insert(f.exposure_start_ticks, f);
        }
    }
    t.presses = presses.to_vec();
}

/// The label a run would give this frame, from the truth: the normal force at mid-exposure,
/// the contact point, and the indenter of the press under way (the label rules of
/// `fringe_sensor_models::dataset::label`). `None` for a frame the robot's presses do not
/// explain (touching before the first press).
fn sample_of(t: &FrameTruth, presses: &[RobotPress]) -> Option<Sample> {
    let (force, shape, contact) = match t.contact {
        Some((fz, x, y)) => {
            let press = presses.iter().rev().find(|p| p.start <= t.exposure_start)?;
            label([0.0, 0.0, fz, 0.0, 0.0, 0.0], &press.shape, Some([x, y]))
        }
        None => label([0.0; 6], NO_CONTACT, None),
    };
    Some(Sample {
        image: Default::default(),
        storage: None,
        force,
        shape,
        contact,
        shear: None,
        slip: None,
        press: String::new(),
        stage_mm: None,
    })
}
