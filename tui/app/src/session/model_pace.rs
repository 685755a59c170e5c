//! Whether a model keeps up with the camera, said before the bench moves: the model's time per
//! frame on this machine against the camera's frame period. Live validation runs the frames in
//! order while a few wait ([`crate::session::live_validation::BACKLOG_FRAMES`]) and skips the oldest
//! when more come: a model slower than the camera skips a share of the frames however long the
//! scan, which the operator should know, with what would keep up, before pressing.

use fringe_rig::Hertz;
use std::time::Duration;

/// Timed runs of the model's networks before the scan (after one to warm up).
pub(crate) const TIMING_RUNS: usize = 5;

/// The share of the frame period the networks may take before frames are likely skipped: the
/// preprocessing of each frame (1-4 ms for a full frame, BENCHMARKS.md "Models: preprocessing
/// and inference") and the rest of the bench need the remainder.
pub(crate) const MARGIN: f64 = 0.8;

/// What the model's machine and settings are, for the advice.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Setting {
    /// Inference threads of each network.
    pub threads: usize,
    /// The machine's cores.
    pub cores: usize,
    /// The model's input size, px.
    pub input_size: u32,
    /// The simulated bench, whose renderer draws every frame on the same cores: there a second
    /// inference thread was measured slower than one (BENCHMARKS.md, "ResNet-18 on a Zen 4
    /// machine"), so it is not advised.
    pub simulated: bool,
}

/// What the operator is told.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Pace {
    /// The networks take at most [`MARGIN`] of the frame period: the figures.
    KeepsUp(String),
    /// They take more: the figures, the share of frames that will be skipped and what would
    /// keep up (`full`), and the figures in one short line for a status display (`short`).
    Behind { full: String, short: String },
}

/// What `per_frame` (the networks' time for one frame) means at `frame_rate`: the figures when
/// the networks take at most [`MARGIN`] of the frame period, otherwise the share of frames that
/// will be skipped (at the least: preprocessing and the rest of the bench come on top) and what
/// would keep up.
pub(crate) fn keeping_up(per_frame: Duration, frame_rate: Hertz, setting: Setting) -> Pace {
    let ms = per_frame.as_secs_f64() * 1e3;
    let period_ms = 1e3 / frame_rate.0;
    let threads = match setting.threads {
        1 => "1 inference thread".to_string(),
        n => format!("{n} inference threads each"),
    };
    let timed = format!(
        "the model's networks take about {ms:.1} ms a frame on this machine ({threads}, timed \
         before the scan), and the camera gives a frame every {period_ms:.1} ms at {:.0} fps",
        frame_rate.0
    );
    if ms <= MARGIN * period_ms {
        return Pace::KeepsUp(format!("live validation: {timed}"));
    }
    // The share of frames skipped when the networks alone take longer than a frame.
    let skipped_pct = (ms > period_ms).then(|| 100.0 * (1.0 - period_ms / ms));
    let outcome = if let Some(pct) = skipped_pct {
        format!(
            "at least {pct:.0} % of the frames will be skipped (validation takes the newest; the \
             run records them all)"
        )
    } else {
        format!(
            "that leaves {:.1} ms of each frame for its preprocessing: frames will be skipped \
             whenever the machine is busy (validation takes the newest; the run records them all)",
            period_ms - ms
        )
    };
    let mut faster = Vec::new();
    if setting.threads < setting.cores && !setting.simulated {
        faster.push(format!(
            "more inference threads (--threads {})",
            setting.cores
        ));
    }
    if setting.input_size > 112 {
        faster.push(format!(
            "a model trained at a smaller --input-size than its {} px (a network's time falls \
             about as its input's pixels: ResNet-18 takes about half its 224 px time at 160 px, \
             BENCHMARKS.md)",
            setting.input_size
        ));
    }
    faster.push(format!(
        "a lower camera frame_rate in the rig file's [camera] section (this model keeps up with \
         about {:.0} fps)",
        (1e3 * MARGIN / ms).floor()
    ));
    // One line a status panel shows whole (the Validate screen's, 90 columns at 180).
    let short = if let Some(pct) = skipped_pct {
        format!(
            "slower than the camera: {ms:.1} ms a frame, {period_ms:.1} ms allowed, at least \
             {pct:.0} % of frames skipped"
        )
    } else {
        format!(
            "near the camera's pace: {ms:.1} ms a frame, {period_ms:.1} ms allowed, frames skipped \
             when busy"
        )
    };
    Pace::Behind {
        full: format!(
            "live validation: {timed}: {outcome}. To keep up: {}",
            faster.join("; ")
        ),
        short,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn note(ms: f64, fps: f64, threads: usize, input_size: u32) -> Pace {
        pace_of(ms, fps, threads, input_size, false)
    }

    fn pace_of(ms: f64, fps: f64, threads: usize, input_size: u32, simulated: bool) -> Pace {
        keeping_up(
            Duration::from_secs_f64(ms / 1e3),
            Hertz(fps),
            Setting {
                threads,
                cores: 2,
                input_size,
                simulated,
            },
        )
    }

    #[test]
    fn on_the_simulated_bench_a_second_inference_thread_is_not_advised() {
        let Pace::Behind { full, .. } = pace_of(48.0, 50.0, 1, 224, true) else {
            panic!("a 48 ms model at 50 fps was not warned about");
        };
        assert!(!full.contains("--threads"), "{full}");
        assert!(
            full.contains("--input-size") && full.contains("frame_rate"),
            "{full}"
        );
    }

    #[test]
    fn a_model_well_inside_the_frame_period_is_only_noted() {
        let Pace::KeepsUp(t) = note(4.3, 50.0, 1, 112) else {
            panic!("a 4.3 ms model at 50 fps was warned about");
        };
        assert!(
            t.contains("4.3 ms a frame") && t.contains("every 20.0 ms at 50 fps"),
            "{t}"
        );
    }

    #[test]
    fn a_model_slower_than_the_camera_is_warned_about_with_the_share_skipped_and_the_remedies() {
        // ResNet-18 at 224 px on one thread here: about 48 ms a frame against 20 ms.
        let Pace::Behind { full: t, short } = note(48.0, 50.0, 1, 224) else {
            panic!("a 48 ms model at 50 fps was not warned about");
        };
        assert_eq!(
            short,
            "slower than the camera: 48.0 ms a frame, 20.0 ms allowed, at least 58 % of frames \
             skipped"
        );
        assert!(
            t.contains("at least 58 % of the frames will be skipped"),
            "{t}"
        );
        assert!(t.contains("--threads 2"), "{t}");
        assert!(t.contains("smaller --input-size than its 224 px"), "{t}");
        assert!(t.contains("keeps up with about 16 fps"), "{t}");
    }

    #[test]
    fn a_model_inside_the_period_but_past_the_margin_is_warned_about_without_a_share() {
        let Pace::Behind { full: t, .. } = note(18.0, 50.0, 2, 112) else {
            panic!("an 18 ms model at 50 fps was not warned about");
        };
        assert!(t.contains("leaves 2.0 ms of each frame"), "{t}");
        assert!(!t.contains("%"), "{t}");
        // Already on both cores and at the smallest input size: only the frame rate is left.
        assert!(
            !t.contains("--threads") && !t.contains("--input-size"),
            "{t}"
        );
        assert!(t.contains("frame_rate"), "{t}");
    }

    #[test]
    fn the_same_model_keeps_up_with_a_slower_camera() {
        assert!(matches!(note(30.0, 25.0, 1, 160), Pace::KeepsUp(_)));
        assert!(matches!(note(30.0, 50.0, 1, 160), Pace::Behind { .. }));
    }
}
