//! What the scan thread's events change on screen: the log, the progress, the phase, the
//! operator's dialog; and how the scan ended, for the screens that wait on it.

use super::session::Event;
use super::state::{Dialog, Phase, ScanView, UiState};
use fringe_app::Note;
use fringe_rig::scan::ScanProgress;
use fringe_rig::Prompt;
use std::path::PathBuf;

/// How a scan ended, for the screens that wait on it (the calibration fits its run).
pub enum ScanEnd {
    Ended {
        completed: bool,
        summary: String,
        run_dir: PathBuf,
    },
    Failed(String),
}

/// Shows `e`; how the scan ended when it did.
pub fn apply(state: &mut UiState, e: Event) -> Option<ScanEnd> {
    let scan = &mut state.scan;
    match e {
        Event::Note(Note::Info(t)) => scan.log(t.trim().to_string()),
        Event::Note(Note::Warning(t)) => scan.log(format!("warning: {t}")),
        Event::Geometry {
            origin_mm,
            disc_radius_mm,
        } => {
            scan.origin_mm = origin_mm;
            scan.disc_radius_mm = disc_radius_mm;
        }
        Event::Progress(p) => show_progress(scan, p),
        Event::Prompt(p) => {
            let title = match &p {
                Prompt::ChangeIndenter { .. } => "change the indenter",
                Prompt::MoveY { .. } => "move the y stage",
                Prompt::Resume { .. } => "scan paused",
            };
            if let Prompt::Resume { reason } = &p {
                scan.phase = Phase::Paused(reason.clone());
            }
            state.dialog = Some(Dialog {
                title: title.to_string(),
                message: p.message(),
            });
        }
        Event::Ended {
            completed,
            summary,
            run_dir,
        } => {
            scan.log(summary.clone());
            if completed {
                scan.done = scan.total;
            }
            scan.current = None;
            scan.phase = Phase::Finished {
                completed,
                summary: summary.clone(),
            };
            state.dialog = None;
            return Some(ScanEnd::Ended {
                completed,
                summary,
                run_dir,
            });
        }
        Event::Failed(why) => {
            scan.log(format!("failed: {why}"));
            scan.phase = Phase::Failed(why.clone());
            scan.current = None;
            state.dialog = None;
            state.error = Some(why.clone());
            return Some(ScanEnd::Failed(why));
        }
    }
    None
}

/// Shows the scan's progress: a message, the point's phase, the counts, a pause or resume.
fn show_progress(scan: &mut ScanView, p: ScanProgress) {
    match p {
        ScanProgress::Message(m) => {
            if let Some(dir) = m.strip_prefix("run directory ") {
                scan.run_dir = Some(dir.to_string());
            }
            scan.log(m);
        }
        ScanProgress::Phase { point, phase } => {
            scan.current = Some((point, phase.name()));
        }
        ScanProgress::Status(s) => {
            scan.done = s.points_done;
            scan.total = s.points_total;
            scan.eta = s.eta;
            scan.force_n = s.force_n;
            scan.frame_rate_hz = s.frame_rate_hz;
            scan.frames = s.frames_recorded;
            scan.dropped = s.dropped_frames;
        }
        ScanProgress::Paused { reason } => {
            scan.log(format!("paused: {reason}"));
            scan.phase = Phase::Paused(reason);
        }
        ScanProgress::Resumed => {
            scan.log("resumed");
            scan.phase = Phase::Running;
        }
    }
}
