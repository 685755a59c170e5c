//! `fringe selfcheck`: the hardware-free self-check through the real Net F/T driver.

use std::process::Command;

#[test]
fn selfcheck_runs_the_net_ft_driver_with_no_loss_and_the_simulated_press() {
    let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
        .arg("selfcheck")
        .output()
        .expect("run fringe");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "exit {:?}\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout
        .lines()
        .find(|l| l.contains("Net F/T driver over udp"))
        .unwrap_or_else(|| panic!("no driver line in\n{stdout}"));
    assert!(line.contains(" 0 lost, 0 out of order"), "{line}");
    let peak: f64 = line
        .rsplit("peak |Fz| ")
        .next()
        .and_then(|s| s.trim_end_matches(" N").parse().ok())
        .unwrap_or_else(|| panic!("no peak in {line}"));
    assert!(
        (peak - 5.0).abs() < 0.05,
        "peak |Fz| {peak} N, the simulated press peaks at 5 N"
    );
    let samples: f64 = line
        .split(": ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no sample count in {line}"));
    assert!(samples > 8000.0, "{samples} samples in 2 s at 5 kHz");
}
