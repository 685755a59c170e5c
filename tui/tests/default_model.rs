//! The models that ship inside fringe (each design's two-stage model, which eval and validate
//! take for a sensor of that design; the one-network models of both designs; the layered
//! design's commissioning base) against the figures their cards claim: a held-out scan of the simulated
//! bench with that design's sensor (`tui/tests/plans/model-check.toml`: grid points that neither
//! the training frames nor the model-eval plan use), labelled by the F/T through the
//! synchronisation, then `fringe eval` (which takes the shipped model of the run's design unless
//! told) on that run. The figures must be those the card records for this plan and bench, within
//! the noise of one scan; contact and shape must beat the paper's custom CNN row (Table 2) as the
//! cards' do. (The README's figures come from the longer model-eval plan, 5 minutes of scanning:
//! not a test.)

mod common;

use common::{fringe, fringe_command, only_run, printed_figure, scratch, text, Scratch};
use std::path::Path;
use std::process::{Child, Stdio};

const LAYERED_CARD: &str = include_str!("../../sensor-models/models/layered-custom.json");
const INTEGRATED_CARD: &str = include_str!("../../sensor-models/models/integrated-keypoint.json");
const LAYERED_KEYPOINT_CARD: &str =
    include_str!("../../sensor-models/models/layered-keypoint.json");
const LAYERED_TWO_STAGE_CARD: &str =
    include_str!("../../sensor-models/models/layered-two-stage.json");
const INTEGRATED_TWO_STAGE_CARD: &str =
    include_str!("../../sensor-models/models/integrated-two-stage.json");

/// The paper's custom CNN row (Sensor 1, gray, 10 augmentations): Fz RMSE, contact RMSE, shape
/// accuracy.
const PAPER_CUSTOM_CNN: (f64, f64, f64) = (0.4927, 1.4683, 0.9532);

/// Both designs' scans run at once (two full-size benches at 25 fps take about 0.7 of the 2
/// cores and drop no frame), then each run is evaluated and checked against its card.
#[test]
fn the_shipped_models_meet_the_figures_their_cards_claim_on_held_out_scans() {
    // What eval takes for each design: its two-stage model.
    let designs = [
        (
            "layered",
            LAYERED_TWO_STAGE_CARD,
            "keypoint CNN, then keypoint CNN on a 24 mm window placing the contact, then custom \
             CNN on a 24 mm window reading the force",
        ),
        (
            "integrated",
            INTEGRATED_TWO_STAGE_CARD,
            "keypoint CNN, then keypoint CNN on a 24 mm window placing the contact",
        ),
    ];
    let scans: Vec<_> = designs
        .iter()
        .map(|(design, card, _)| start_held_out_scan(design, card))
        .collect();
    let runs: Vec<_> = scans
        .into_iter()
        .map(|(dir, mut child)| {
            let status = child.wait().expect("fringe scan ends");
            let log = std::fs::read_to_string(dir.join("scan.log")).unwrap_or_default();
            assert!(status.success(), "{}: {status}\n{log}", dir.display());
            dir
        })
        .collect();
    for ((design, card, arch), dir) in designs.iter().zip(&runs) {
        evaluation_gives_the_cards_figures(design, card, arch, dir, None);
    }
    // The one-network models, on the same held-out scans: the layered custom CNN (`default`),
    // the layered design's commissioning base, and the integrated keypoint CNN (the first
    // network of that design's two-stage model).
    evaluation_gives_the_cards_figures(
        "layered",
        LAYERED_CARD,
        "custom CNN",
        &runs[0],
        Some("builtin:layered"),
    );
    evaluation_gives_the_cards_figures(
        "layered",
        LAYERED_KEYPOINT_CARD,
        "keypoint CNN",
        &runs[0],
        Some("builtin:layered-keypoint"),
    );
    evaluation_gives_the_cards_figures(
        "integrated",
        INTEGRATED_CARD,
        "keypoint CNN",
        &runs[1],
        Some("builtin:integrated"),
    );
}

/// The bench of the held-out check: the simulated bench with a sensor of `design`, its camera at
/// 25 fps and its x and y axes at the quick bench's 8 mm/s. The frames differ only in number
/// from the default 50 fps (twice the disk and eval time); x and y only carry the indenter between
/// presses, while z, which approaches the disc and presses it, keeps the default bench's speed, so
/// each press is the one the default bench makes.
fn check_rig(design: &str) -> String {
    let mut rig = String::from("[camera]\nframe_rate = 25.0\n");
    for axis in ["x", "y"] {
        rig.push_str(&format!("[{axis}]\nvelocity = 8.0\nacceleration = 40.0\n"));
    }
    rig.push_str(&format!("[sim]\nsensor = \"{design}\"\n"));
    rig
}

/// The card's held-out figures on the model-check plan.
fn claim(card: &serde_json::Value) -> &serde_json::Value {
    &card["held_out"]["model-check"]
}

/// Starts the model-check plan's scan on the simulated bench with a sensor of `design` (the
/// bench `card` records) in a new scratch directory, which it returns with the running scan.
fn start_held_out_scan(design: &str, card: &str) -> (Scratch, Child) {
    let card: serde_json::Value = serde_json::from_str(card).expect("the shipped card is JSON");
    assert_eq!(card["variant"].as_str(), Some(design), "the card's design");
    let dir = scratch(&format!("held-out-{design}"));
    let plan = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/plans/model-check.toml");
    let rig = dir.join("rig.toml");
    let rig_text = check_rig(design);
    assert_eq!(
        claim(&card)["rig"].as_str(),
        Some(rig_text.as_str()),
        "the card's figures are for this bench"
    );
    std::fs::write(&rig, &rig_text).expect("rig file");
    let log = std::fs::File::create(dir.join("scan.log")).expect("scan log");
    let child = fringe_command()
        .current_dir(&dir)
        .arg("scan")
        .arg(&plan)
        .arg("--rig")
        .arg(&rig)
        .arg("--yes")
        .arg("--out")
        .arg(dir.join("runs"))
        // To a file: the other scan's output is not read while this one runs.
        .stdout(Stdio::from(log.try_clone().expect("scan log")))
        .stderr(Stdio::from(log))
        .spawn()
        .expect("start fringe scan");
    (dir, child)
}

/// `fringe eval` of the scan in `dir` with `model` (else the model fringe picks for its design),
/// against `card`'s figures.
fn evaluation_gives_the_cards_figures(
    design: &str,
    card: &str,
    arch: &str,
    dir: &Path,
    model: Option<&str>,
) {
    let card: serde_json::Value = serde_json::from_str(card).expect("the shipped card is JSON");
    let claim = claim(&card);
    let claimed = |k: &str| {
        claim[k]
            .as_f64()
            .unwrap_or_else(|| panic!("{design} card: held_out.model-check.{k}"))
    };
    let run = only_run(&dir.join("runs"));

    let name = model.map_or_else(|| format!("builtin:{design}-two-stage"), str::to_string);
    let report = dir.join(format!("report-{}", name.replace(':', "-")));
    let mut args = vec![
        "eval",
        run.to_str().expect("utf-8 path"),
        "--report",
        report.to_str().expect("utf-8 path"),
    ];
    if let Some(m) = model {
        args.extend(["--model", m]);
    }
    let out = fringe(&args);
    let eval = text(&out);
    assert!(out.status.success(), "{eval}");
    assert!(eval.contains(&format!("{name} ({arch})")), "{eval}");
    let fz = printed_figure(&eval, "Fz RMSE:");
    let contact = printed_figure(&eval, "contact RMSE:");
    let accuracy = printed_figure(&eval, "shape accuracy:");

    // The card's figures, within the noise of one scan (the bench's F/T noise and frame timing
    // differ between runs; the model and the plan do not).
    assert!(
        (fz - claimed("fz_rmse_n")).abs() <= 0.25 * claimed("fz_rmse_n") + 0.02,
        "{design}: Fz RMSE {fz} N, card {}\n{eval}",
        claimed("fz_rmse_n")
    );
    assert!(
        (contact - claimed("contact_rmse_mm")).abs() <= 0.25 * claimed("contact_rmse_mm") + 0.05,
        "{design}: contact RMSE {contact} mm, card {}\n{eval}",
        claimed("contact_rmse_mm")
    );
    assert!(
        (accuracy - claimed("shape_accuracy")).abs() <= 0.02,
        "{design}: shape accuracy {accuracy}, card {}\n{eval}",
        claimed("shape_accuracy")
    );
    // Where the card's figures beat the paper's custom CNN row (contact, shape), the scan must too.
    let (_, paper_contact, paper_accuracy) = PAPER_CUSTOM_CNN;
    assert!(contact < paper_contact, "contact RMSE {contact} mm\n{eval}");
    assert!(
        accuracy > paper_accuracy,
        "shape accuracy {accuracy}\n{eval}"
    );
}
