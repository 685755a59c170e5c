//! A stream's summary as the front ends say it: one text for `fringe stream` and the UI's
//! Stream screen.

use fringe_app::stream::{Stage, StreamSummary};

/// What a finished stream did, a line each: frames, what went out, the latency and what
/// dominates it, and on the simulated bench the errors against the truth; the unit's health;
/// the recording. The UI says the same lines.
pub(crate) fn summary_lines(sum: &StreamSummary) -> Vec<String> {
    let mut out = Vec::new();
    let s = &sum.state;
    out.push(format!(
        "streamed {} frames of {} the camera gave ({} skipped: the model was busy; {} lost by the camera) with {} on {}",
        s.ran, s.frames, s.skipped, s.dropped_by_camera, s.backend, s.model
    ));
    if let Some(ns) = &s.namespace {
        let p = &s.published;
        out.push(format!(
            "published under {ns}: wrench {}, contact {}, shape {}, image {}{}",
            p.wrench,
            p.contact,
            p.shape,
            p.image,
            if p.failed > 0 {
                format!(" ({} failed)", p.failed)
            } else {
                String::new()
            }
        ));
    }
    if let Some(l) = &sum.latency {
        out.push(format!(
            "latency, end of exposure to published ({} frames): p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms; most of it {} (p50 {:.1} ms){}",
            l.frames,
            l.p50_ms,
            l.p99_ms,
            l.max_ms,
            l.dominant().name(),
            l.stage_p50_ms[Stage::ALL
                .iter()
                .position(|s| *s == l.dominant())
                .unwrap_or(0)],
            if sum.clock_calibrated {
                ""
            } else {
                "; the camera gave no timestamp latches, so its readout time is not in these figures"
            }
        ));
        let stages: Vec<String> = Stage::ALL
            .iter()
            .zip(l.stage_p50_ms.iter().zip(&l.stage_p99_ms))
            .map(|(s, (p50, p99))| format!("{} {p50:.1}/{p99:.1}", s.name()))
            .collect();
        out.push(format!("  by stage, p50/p99 ms: {}", stages.join(", ")));
    }
    if let Some([p50, p99]) = sum.exposure_error_us {
        out.push(format!(
            "exposure ends placed by the camera clock against the simulator's truth: within {p50:.0} µs (p50), {p99:.0} µs (p99)"
        ));
    }
    if let Some((n, e)) = &sum.truth {
        if e.n > 0 {
            out.push(format!(
                "against the simulator's truth ({n} frames, {} in contact): Fz RMSE {:.3} N, contact RMSE {:.3} mm, shape accuracy {:.1} %",
                e.n_contact,
                e.fz_rmse(),
                e.contact_rmse(),
                100.0 * e.accuracy()
            ));
        } else {
            out.push("against the simulator's truth: no frame matched yet (stream longer)".into());
        }
    }
    if let Some(h) = &s.health {
        out.push(format!(
            "the unit's health on frames the model calls free (at {:.0} s): optical centre ({:+.2}, {:+.2}) px from its profile (moved beyond {:.2} px), brightness {:.1} % of the stream's start, Fz read on them {:+.3} N",
            h.at_s,
            h.centre_shift_px[0],
            h.centre_shift_px[1],
            h.centre_limit_px,
            100.0 * h.brightness_ratio,
            h.free_fz_n
        ));
    }
    if let Some(m) = &sum.mcap {
        out.push(format!("recorded to {}", m.display()));
    }
    out
}
