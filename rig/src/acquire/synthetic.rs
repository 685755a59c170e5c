//! Synthetic bench streams for the labelers' unit tests: a 5 kHz force sample counter running
//! 100 ppm fast with an exposure strobe channel, delivered in blocks; a camera whose 1 GHz clock
//! runs 100 ppm slow, with frames delivered after a chosen delay; timestamp latches every
//! 250 ms. Everything comes out as events in host arrival order, and Fz equals the host time in
//! seconds, so a label's mean tells where its window lay in true time.

use super::labeler::{FrameLabeler, LabelOutcome};
use crate::camera::{Frame, PixelFormat, TimestampLatch};
use crate::clock::HostTime;
use crate::force::ForceSample;
use crate::seeded::SplitMix64;
use crate::units::{Volts, Wrench};
use crossbeam_channel::Sender;
use std::collections::VecDeque;

/// Host ns of one force sample (a 5 kHz counter running 100 ppm fast).
pub(crate) const SAMPLE_NS: f64 = 200_000.0 * (1.0 - 100e-6);
/// Camera ticks per host ns (100 ppm slow).
const CAMERA_RATE: f64 = 1.0 - 100e-6;
const CAMERA_T0: u64 = 9_000_000_000_000;
/// Host time of force sample 0.
const SAMPLE0_NS: f64 = 1e9;
/// Id of the first frame.
pub(crate) const FIRST_ID: u64 = 1000;
/// Host time of the first exposure start.
const FIRST_EXPOSURE_NS: f64 = 1.1e9;

/// Host ns of force sample `k`.
pub(crate) fn sample_host(k: u64) -> f64 {
    SAMPLE0_NS + k as f64 * SAMPLE_NS
}

/// Fractional force sample index at host ns `t`.
pub(crate) fn sample_at(t: f64) -> f64 {
    (t - SAMPLE0_NS) / SAMPLE_NS
}

fn camera_ticks(host_ns: f64) -> u64 {
    CAMERA_T0 + ((host_ns - SAMPLE0_NS) * CAMERA_RATE).round() as u64
}

/// A delay in ns for frame n, drawn with the bench's generator.
pub(crate) type DelayOfFrame = Box<dyn Fn(u64, &mut SplitMix64) -> f64>;

/// What the synthetic bench does.
pub(crate) struct Bench {
    pub seconds: f64,
    pub frame_period_ns: f64,
    pub exposure_ns: f64,
    /// Exposure end to frame arrival of frame n, ns (raised where needed to keep frames in
    /// order).
    pub delivery_ns: DelayOfFrame,
    /// Force block delivery delay after the block's last sample, ns.
    pub block_delay_ns: Box<dyn Fn(&mut SplitMix64) -> f64>,
    pub latches: bool,
    /// Whether the strobe is recorded.
    pub strobe: bool,
    /// Exposures whose strobe pulse is missing (n in this range).
    pub strobe_lost: std::ops::Range<u64>,
    /// Frames the camera drops (never delivered).
    pub dropped: Vec<u64>,
    /// Force samples that never arrive (k in this range: a reader that fell behind).
    pub samples_lost: std::ops::Range<u64>,
}

impl Bench {
    /// 20 s at 50 Hz, 2 ms exposures, frames 5-8 ms after exposure end, force blocks of 50
    /// samples 0-3 ms late, latches and strobe on.
    pub(crate) fn new() -> Bench {
        Bench {
            seconds: 20.0,
            frame_period_ns: 20e6,
            exposure_ns: 2e6,
            delivery_ns: Box::new(|_, rng| 5e6 + rng.range(0.0..3e6)),
            block_delay_ns: Box::new(|rng| rng.range(0.0..3e6)),
            latches: true,
            strobe: true,
            strobe_lost: 0..0,
            dropped: Vec::new(),
            samples_lost: 0..0,
        }
    }

    pub(crate) fn exposure_start(&self, n: u64) -> f64 {
        FIRST_EXPOSURE_NS + n as f64 * self.frame_period_ns
    }

    fn frames(&self) -> u64 {
        ((self.seconds * 1e9 - 0.2e9) / self.frame_period_ns) as u64
    }

    fn strobe_high(&self, t: f64) -> bool {
        if t < FIRST_EXPOSURE_NS {
            return false;
        }
        let n = ((t - FIRST_EXPOSURE_NS) / self.frame_period_ns) as u64;
        t - self.exposure_start(n) < self.exposure_ns && !self.strobe_lost.contains(&n)
    }
}

/// One thing arriving at the host.
pub(crate) enum Event {
    Samples(Vec<ForceSample>),
    /// A frame and its true exposure start (host ns).
    Frame(Frame, f64),
    Latch(TimestampLatch),
}

/// The bench's events in host arrival order.
pub(crate) fn events(bench: &Bench, seed: u64) -> Vec<Event> {
    let mut rng = SplitMix64::new(seed);
    let mut timed: Vec<(f64, Event)> = Vec::new();
    let end = SAMPLE0_NS + bench.seconds * 1e9;
    let mut k = 0u64;
    while sample_host(k + 49) < end {
        let arrival = sample_host(k + 49) + (bench.block_delay_ns)(&mut rng);
        let block = (k..k + 50)
            .filter(|j| !bench.samples_lost.contains(j))
            .map(|j| ForceSample {
                device_tick: j,
                transport_seq: None,
                host_time: HostTime(arrival as u64),
                wrench: Wrench::from_array([0.0, 0.0, sample_host(j) * 1e-9, 0.0, 0.0, 0.0]),
                status: 0,
                strobe: bench.strobe.then(|| {
                    Volts(if bench.strobe_high(sample_host(j)) {
                        3.3
                    } else {
                        0.0
                    })
                }),
            })
            .collect();
        timed.push((arrival, Event::Samples(block)));
        k += 50;
    }
    // Frames leave the camera in order (a FIFO): none arrives before the one exposed before it.
    let mut previous = 0.0f64;
    for n in 0..bench.frames() {
        let start = bench.exposure_start(n);
        let arrival =
            (start + bench.exposure_ns + (bench.delivery_ns)(n, &mut rng)).max(previous + 1e3);
        previous = arrival;
        if bench.dropped.contains(&n) {
            continue;
        }
        let frame = Frame {
            // The camera ran before: ids do not start at 0.
            id: FIRST_ID + n,
            device_timestamp: camera_ticks(start),
            host_arrival: HostTime(arrival as u64),
            width: 1,
            height: 1,
            format: PixelFormat::Mono8,
            data: Vec::new(),
        };
        timed.push((arrival, Event::Frame(frame, start)));
    }
    if bench.latches {
        let mut before = SAMPLE0_NS + 0.05e9;
        while before < end {
            let rtt = rng.range(75e3..225e3);
            let at = before + rng.range(0.0..rtt);
            timed.push((
                before + rtt,
                Event::Latch(TimestampLatch {
                    host_before: HostTime(before as u64),
                    device_ticks: camera_ticks(at),
                    host_after: HostTime((before + rtt) as u64),
                }),
            ));
            before += 250e6;
        }
    }
    timed.sort_by(|a, b| a.0.total_cmp(&b.0));
    timed.into_iter().map(|(_, e)| e).collect()
}

/// A frame and what its labeler said.
pub(crate) struct Labelled {
    pub id: u64,
    /// True exposure start, host ns.
    pub true_start: f64,
    pub outcome: LabelOutcome,
}

/// Feeds `events` to `labeler` as the recorder would (latches into `latches`, frames shown as
/// they arrive and asked for their label until it is ready) and returns every frame's outcome.
pub(crate) fn run(
    labeler: &mut dyn FrameLabeler,
    events: Vec<Event>,
    latches: &Sender<TimestampLatch>,
) -> Vec<Labelled> {
    let mut pending: VecDeque<(Frame, f64)> = VecDeque::new();
    let mut out = Vec::new();
    for event in events {
        match event {
            Event::Samples(block) => block.iter().for_each(|s| labeler.push_sample(s)),
            Event::Frame(frame, start) => {
                labeler.observe_frame(&frame);
                pending.push_back((frame, start));
            }
            Event::Latch(l) => {
                let _ = latches.send(l);
            }
        }
        while let Some((frame, _)) = pending.front() {
            let outcome = labeler.label(frame);
            if outcome == LabelOutcome::NotYet {
                break;
            }
            if let Some((frame, true_start)) = pending.pop_front() {
                out.push(Labelled {
                    id: frame.id,
                    true_start,
                    outcome,
                });
            }
        }
    }
    out.extend(pending.into_iter().map(|(frame, true_start)| Labelled {
        id: frame.id,
        true_start,
        outcome: LabelOutcome::NotYet,
    }));
    out
}
