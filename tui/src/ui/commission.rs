//! The Commission screen's side of a commissioning: what `r` starts, and the commissioning on its
//! own thread. Its scans are run by the UI's one scan thread (live view, dialogs and stop keys as
//! for any scan); its lines, progress and rounds are sent to the screen.

use super::state::CommissionView;
use crossbeam_channel::{unbounded, Receiver, Sender};
use fringe_app::commission;
use fringe_app::commission::Accepted;
use fringe_app::commission::Request;
use fringe_app::commission::DEFAULT_BUDGET_MIN;
use fringe_app::commission::{unfinished, CurvePoint};
use fringe_app::commission::{Host, ScanEnded};
use fringe_app::commission::{PressedPoint, UsableDisc};
use fringe_app::session::guarded;
use fringe_app::units;
use fringe_app::workflow_error::BoxError;
use fringe_app::{ProfileUse, RigConfig};
use fringe_rig::RunTarget;
use fringe_rig::ScanProgram;
use fringe_sensor_models::Spec;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Inference threads of the commissioning's computation.
const THREADS: usize = 2;

/// The screen before a commissioning ran from it.
pub fn ready_view(config: &RigConfig) -> CommissionView {
    let mut v = CommissionView {
        thresholds: thresholds(&Spec::paper()),
        ..CommissionView::default()
    };
    let sensor = match config.sensor_id() {
        Ok(s) => s,
        Err(e) => {
            v.sensor = "?".into();
            v.plan = format!("no sensor to commission: {e}");
            return v;
        }
    };
    let base = match config
        .sensor_variant()
        .map_err(|e| e.to_string())
        .and_then(|d| {
            fringe_sensor_models::builtin::commissioning_base(d).map_err(|e| e.to_string())
        }) {
        Ok(b) => b.display().to_string(),
        Err(e) => format!("none ({e})"),
    };
    v.plan = format!(
        "base model {base} · {DEFAULT_BUDGET_MIN} min of bench time for the presses · spec: the paper's custom-CNN row ({})",
        Spec::paper().all.describe()
    );
    v.resumable = unfinished(&config.profile_dir(), &sensor).map(|d| d.display().to_string());
    v.existing = existing(config, &sensor);
    v.sensor = sensor;
    v
}

/// The unit's newest certificate (made here or by `fringe commission`), in words, and whether it
/// passed: what the Commission screen shows before anything is started.
fn existing(config: &RigConfig, sensor: &str) -> Option<(bool, String)> {
    let listed = units::list(config, &fringe_rig::store::now_utc());
    let unit = listed.units.into_iter().find(|u| u.id == sensor)?;
    let c = unit.certificate?;
    let mut said = format!(
        "certificate {} against {}: Fz {:.2} N, contact {:.2} mm, shape {:.1} %",
        c.describe(),
        c.spec_origin,
        c.fz_rmse_n,
        c.contact_rmse_mm,
        100.0 * c.shape_accuracy,
    );
    if let Some(p) = unit.passing {
        said.push_str(&format!(" · last pass {}", p.describe()));
    }
    said.push_str(&format!(" · validate uses {}", unit.validate.describe()));
    Some((c.pass, said))
}

/// The spec's whole-set thresholds.
fn thresholds(spec: &Spec) -> (Option<f64>, Option<f64>, Option<f64>) {
    let t = &spec.all;
    (t.fz_rmse_n, t.contact_rmse_mm, t.shape_accuracy)
}

/// A scan the commissioning asks the UI to run.
pub struct ScanOrder {
    pub program: ScanProgram,
    pub plan_text: String,
    pub target: RunTarget,
    pub profile: ProfileUse,
}

impl ScanOrder {
    /// The run directory the scan writes.
    pub fn run_dir(&self) -> PathBuf {
        self.target.dir()
    }
}

/// What the commissioning thread tells the screen.
pub enum FromWorker {
    /// Its directory and the spec's thresholds, before anything moves.
    Started {
        dir: PathBuf,
        thresholds: (Option<f64>, Option<f64>, Option<f64>),
    },
    /// Run this scan and answer with its end.
    Scan(Box<ScanOrder>),
    Line(String),
    /// The computation's progress as a line; `None` when it is done.
    Progress(Option<String>),
    Learnt {
        curve: Vec<CurvePoint>,
        pressed: Vec<PressedPoint>,
        disc: UsableDisc,
    },
    /// The verdict, or why the commissioning stopped before it.
    Finished(Result<Accepted, String>),
}

/// The screen's hold on the commissioning thread.
pub struct Worker {
    pub events: Receiver<FromWorker>,
    /// How each scan the thread asked for ended (an error: it could not run).
    pub ends: Sender<Result<ScanEnded, String>>,
    /// The operator's stop, for the computation between scans that can stop with a checkpoint
    /// (full fine-tuning).
    pub stop: Arc<AtomicBool>,
}

/// Starts `request` on the rig on its own thread.
pub fn start(request: Request, config: RigConfig) -> Worker {
    let (tx, events) = unbounded();
    let (ends, ends_rx) = unbounded();
    let stop = Arc::new(AtomicBool::new(false));
    std::thread::Builder::new()
        .name("commission".into())
        .spawn({
            let tx = tx.clone();
            let stop = stop.clone();
            move || {
                // A panic ends the commissioning as an error does: the screen hears why.
                let outcome = guarded("commissioning", || {
                    work(&request, config, &tx, ends_rx, stop).map_err(|e| format!("{e:#}"))
                })
                .and_then(|r| r);
                let _ = tx.send(FromWorker::Finished(outcome));
            }
        })
        .map_or_else(
            |e| {
                let _ = tx.send(FromWorker::Finished(Err(format!(
                    "cannot start the commissioning thread: {e}"
                ))));
            },
            |_| (),
        );
    Worker { events, ends, stop }
}

fn work(
    request: &Request,
    config: RigConfig,
    tx: &Sender<FromWorker>,
    ends: Receiver<Result<ScanEnded, String>>,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<Accepted> {
    let prepared = commission::prepare(request, &config, &mut |w| eprintln!("warning: {w}"))?;
    let _ = tx.send(FromWorker::Started {
        dir: prepared.dir().to_path_buf(),
        thresholds: thresholds(prepared.spec()),
    });
    if let Some(line) = prepared.resumed() {
        let _ = tx.send(FromWorker::Line(line));
    }
    let mut host = UiHost {
        tx: tx.clone(),
        ends,
        shown: None,
        stop,
    };
    Ok(commission::run(prepared, config, THREADS, &mut host)?)
}

/// The UI's side of a commissioning, on its thread.
struct UiHost {
    tx: Sender<FromWorker>,
    ends: Receiver<Result<ScanEnded, String>>,
    /// The progress last sent (what, per cent): a line a per cent, not a frame.
    shown: Option<(&'static str, usize)>,
    /// Set by the screen's stop (read by full fine-tuning, in `torch` builds).
    #[cfg_attr(not(feature = "torch"), allow(dead_code))]
    stop: Arc<AtomicBool>,
}

impl Host for UiHost {
    fn scan(
        &mut self,
        _config: &RigConfig,
        program: ScanProgram,
        plan_text: String,
        target: RunTarget,
        profile: ProfileUse,
    ) -> Result<ScanEnded, BoxError> {
        let _ = self.tx.send(FromWorker::Progress(None));
        let order = ScanOrder {
            program,
            plan_text,
            target,
            profile,
        };
        if self.tx.send(FromWorker::Scan(Box::new(order))).is_err() {
            return Err("the terminal UI closed before the scan".into());
        }
        match self.ends.recv() {
            Ok(Ok(end)) => Ok(end),
            Ok(Err(why)) => Err(why.into()),
            Err(_) => Err("the terminal UI closed during the scan".into()),
        }
    }

    fn say(&mut self, line: String) {
        let _ = self.tx.send(FromWorker::Line(line));
    }

    fn notice(&mut self, line: String) {
        eprintln!("{line}");
    }

    fn frames(&mut self, what: &'static str, done: usize, total: usize) {
        let pct = 100 * done / total.max(1);
        if done < total && self.shown == Some((what, pct)) {
            return;
        }
        self.shown = (done < total).then_some((what, pct));
        let line = (done < total).then(|| format!("{what}: {done} of {total} frames ({pct} %)"));
        let _ = self.tx.send(FromWorker::Progress(line));
    }

    fn stop_requested(&mut self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    fn learnt(&mut self, curve: &[CurvePoint], pressed: &[PressedPoint], disc: &UsableDisc) {
        let _ = self.tx.send(FromWorker::Learnt {
            curve: curve.to_vec(),
            pressed: pressed.to_vec(),
            disc: *disc,
        });
    }
}
