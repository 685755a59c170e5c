//! Slip onsets said in one line, as `fringe eval` and `fringe model slip` print them.

/// Slip onsets found, how far off, the false ones, F1, and the frames' states, in one line.
pub fn onset_summary(s: &fringe_sensor_models::OnsetScore) -> String {
    let tol = fringe_sensor_models::eval::SLIP_ONSET_TOLERANCE_FRAMES;
    let off = match (s.mean_offset(), s.max_offset()) {
        (Some(mean), Some(max)) => format!(", {mean:.2} frames off on average, {max} at most"),
        _ => String::new(),
    };
    format!(
        "{} of {} found within {tol} frames{off}; {} false; F1 {:.3}; state as labelled on {:.1} % of {} frames",
        s.found,
        s.labelled,
        s.false_onsets,
        s.f1(),
        100.0 * s.agree as f64 / s.frames.max(1) as f64,
        s.frames
    )
}
