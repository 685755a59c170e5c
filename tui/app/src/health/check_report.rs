//! A check's report as one self-contained HTML page (`<profiles>/<sensor>.checks/<time>.html`):
//! the verdict and its evidence, every figure against its threshold ("ok" where nothing moved),
//! the model's errors now and at acceptance, and the unit's history plotted over the checks'
//! dates, the picture embedded. It opens in any browser with nothing else installed.

use crate::health::figures::{Rule, Verdict};
use crate::health::history::Entry;
use crate::health::history_plot::plot;
use crate::workflow_error::{Context, WorkflowError};
use fringe_plot::html::Page;
use std::path::{Path, PathBuf};

/// The folder of a unit's check reports.
pub(crate) fn reports_dir(profiles: &Path, sensor: &str) -> PathBuf {
    profiles.join(format!("{sensor}.checks"))
}

/// Writes the report of `entry`, the newest of `history`; its path.
pub(crate) fn write(
    profiles: &Path,
    entry: &Entry,
    history: &[Entry],
) -> Result<PathBuf, WorkflowError> {
    let dir = reports_dir(profiles, &entry.sensor_id);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot make {}", dir.display()))?;
    let stamp: String = entry
        .checked_utc
        .chars()
        .map(|c| if c == ':' || c == '.' { '-' } else { c })
        .collect();
    let path = dir.join(format!("check-{stamp}.html"));
    let page = page(entry, history).with_context(|| format!("cannot draw {}", path.display()))?;
    std::fs::write(&path, page.finish())
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

/// The page.
fn page(entry: &Entry, history: &[Entry]) -> Result<Page, fringe_plot::PlotError> {
    let a = &entry.assessment;
    let mut page = Page::new(format!("Health check of sensor {}", entry.sensor_id));
    page.verdict(
        a.verdict == Verdict::Ok,
        &format!("Verdict: {}", a.verdict.advice()),
    );
    if a.verdict != Verdict::Ok {
        page.paragraph(&format!("Because {}.", a.diagnosis));
    }
    page.heading("The check");
    let mut rows = vec![
        vec!["sensor".to_string(), entry.sensor_id.clone()],
        vec!["checked (UTC)".to_string(), entry.checked_utc.clone()],
        vec![
            "against the commissioning".to_string(),
            entry.certificate.clone(),
        ],
        vec!["the check's run".to_string(), entry.run.clone()],
        vec!["bench time".to_string(), format!("{:.0} s", entry.bench_s)],
        vec!["fringe".to_string(), entry.fringe_version.clone()],
    ];
    for (what, e) in [
        ("the model now", &entry.model_now),
        ("the model at acceptance", &entry.model_then),
    ] {
        if let Some(e) = e {
            rows.push(vec![
                format!("{what}, at the check's positions"),
                format!(
                    "Fz RMSE {:.3} N, contact RMSE {:.2} mm, shape accuracy {:.1} % ({} frames)",
                    e.fz_rmse_n,
                    e.contact_rmse_mm,
                    100.0 * e.shape_accuracy,
                    e.frames
                ),
            ]);
        }
    }
    page.table(&["", ""], &rows);
    page.note("Coordinates: the check presses some of the acceptance positions, given in stage millimetres (where the stage put the indenter); the model's contact error is in sensor millimetres (on the sensor's surface from its centre).");
    page.heading("Figures against their thresholds");
    let rows: Vec<Vec<String>> = a
        .figures
        .iter()
        .map(|f| {
            let (name, unit) = f.name_and_unit();
            let with_unit = |v: f64| {
                if unit.is_empty() {
                    format!("{v:.3}")
                } else {
                    format!("{v:.3} {unit}")
                }
            };
            vec![
                name,
                with_unit(f.value),
                format!(
                    "{} {}",
                    match f.rule {
                        Rule::AtMost => "at most",
                        Rule::AtLeast => "at least",
                    },
                    with_unit(f.threshold)
                ),
                if f.moved {
                    format!("MOVED ({})", f.action.name())
                } else {
                    "ok".to_string()
                },
                f.finding.clone(),
            ]
        })
        .collect();
    page.table(&["figure", "value", "threshold", "", "what it says"], &rows);
    page.heading("The unit's history");
    page.paragraph(&format!(
        "{} {} of sensor {}: every figure over the checks' dates, its threshold dashed in red.",
        history.len(),
        if history.len() == 1 {
            "check"
        } else {
            "checks"
        },
        entry.sensor_id
    ));
    page.image("Every figure over the checks' dates", &plot(history)?)?;
    Ok(page)
}
