//! The HTML reports open in a browser with nothing else installed: an evaluation's report,
//! rendered headless by chromium, shows its verdict and its plots. (A commissioning's and a
//! check's reports are rendered where a unit is commissioned and checked: `commission_cli.rs`.)

mod common;
use common::{arg, fringe, rendered, scratch, shows_a_report, text};

#[test]
fn an_evaluation_report_is_one_file_that_a_browser_shows() {
    let dir = scratch("report-html");
    let data = dir.join("data");
    let o = fringe(&[
        "sim",
        "dataset",
        "--sensor",
        "layered",
        "--count",
        "6",
        "--seed",
        "1",
        "--out",
        arg(&data),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let report = dir.join("report");
    let o = fringe(&[
        "eval",
        "--spec",
        "paper",
        "--profile",
        arg(&data.join("profile.toml")),
        "--report",
        arg(&report),
        arg(&data),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let html = report.join("report.html");
    assert!(t.contains(arg(&html)), "{t}");
    let page = std::fs::read_to_string(&html).expect("report.html");
    // One file: the plots inside it, nothing fetched from anywhere.
    assert_eq!(page.matches("src=\"data:image/png;base64,").count(), 3);
    assert!(
        !page.contains("http:") && !page.contains("https:"),
        "{page}"
    );
    assert!(page.contains("Verdict: PASS against paper"), "{page}");
    assert!(page.contains("sensor millimetres") && page.contains("stage millimetres"));
    if let Some(shot) = rendered(&html, 1200, 2400) {
        shows_a_report(&shot, true);
        // The plots are drawn: the Fz plot's blue dots (fringe_plot::palette::BLUE).
        assert!(common::pixels_of(&shot, [31, 100, 180]) > 100);
    }
}
