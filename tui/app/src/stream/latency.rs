//! Where each frame's time went, from the end of its exposure to its messages being out, and the
//! percentiles over the stream.

/// The stages of a frame's way out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Exposure end to the frame's arrival on the host: readout and transfer.
    Camera,
    /// Arrival to the worker taking it: waiting behind earlier frames.
    Waiting,
    /// Preprocessing and the networks.
    Model,
    /// The messages built, put on Zenoh and recorded.
    Publishing,
}

impl Stage {
    pub const ALL: [Stage; 4] = [
        Stage::Camera,
        Stage::Waiting,
        Stage::Model,
        Stage::Publishing,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Camera => "camera readout and transfer",
            Stage::Waiting => "waiting for the model",
            Stage::Model => "preprocessing and the model",
            Stage::Publishing => "publishing",
        }
    }
}

/// One frame's times, ms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FrameLatency {
    /// Per stage, in [`Stage::ALL`]'s order.
    pub stages_ms: [f64; 4],
}

impl FrameLatency {
    /// Exposure end to published, ms.
    pub(crate) fn total_ms(&self) -> f64 {
        self.stages_ms.iter().sum()
    }
}

/// Percentiles of the latency and of each stage, ms.
#[derive(Debug, Clone, PartialEq)]
pub struct LatencyFigures {
    /// Frames measured (those whose exposure the camera clock placed).
    pub frames: usize,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    /// Median of each stage, in [`Stage::ALL`]'s order.
    pub stage_p50_ms: [f64; 4],
    /// 99th percentile of each stage.
    pub stage_p99_ms: [f64; 4],
}

impl LatencyFigures {
    /// The stage with the largest median: what dominates.
    pub fn dominant(&self) -> Stage {
        let mut best = 0;
        for i in 1..4 {
            if self.stage_p50_ms[i] > self.stage_p50_ms[best] {
                best = i;
            }
        }
        Stage::ALL[best]
    }
}

/// The `p`-th percentile (0..=100) of `sorted` by nearest rank; NaN when empty.
pub(crate) fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// The figures of `frames`; `None` when there are none.
pub(crate) fn figures(frames: &[FrameLatency]) -> Option<LatencyFigures> {
    if frames.is_empty() {
        return None;
    }
    let sorted = |f: &dyn Fn(&FrameLatency) -> f64| {
        let mut v: Vec<f64> = frames.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let total = sorted(&|l| l.total_ms());
    let mut stage_p50_ms = [0.0; 4];
    let mut stage_p99_ms = [0.0; 4];
    for i in 0..4 {
        let s = sorted(&|l| l.stages_ms[i]);
        stage_p50_ms[i] = percentile(&s, 50.0);
        stage_p99_ms[i] = percentile(&s, 99.0);
    }
    Some(LatencyFigures {
        frames: frames.len(),
        p50_ms: percentile(&total, 50.0),
        p99_ms: percentile(&total, 99.0),
        max_ms: total.last().copied().unwrap_or(f64::NAN),
        stage_p50_ms,
        stage_p99_ms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_by_nearest_rank_and_the_dominant_stage() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 50.0), 50.0);
        assert_eq!(percentile(&v, 99.0), 99.0);
        assert_eq!(percentile(&v, 100.0), 100.0);
        assert!(percentile(&[], 50.0).is_nan());
        let frames: Vec<FrameLatency> = (0..10)
            .map(|i| FrameLatency {
                stages_ms: [1.0, 0.5, 8.0 + i as f64, 0.2],
            })
            .collect();
        let f = figures(&frames).expect("figures");
        assert_eq!(f.frames, 10);
        assert_eq!(f.dominant(), Stage::Model);
        assert!((f.p50_ms - (1.0 + 0.5 + 12.0 + 0.2)).abs() < 1e-9);
        assert!((f.max_ms - (1.0 + 0.5 + 17.0 + 0.2)).abs() < 1e-9);
    }
}
