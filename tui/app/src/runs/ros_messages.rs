//! A scan run as ROS 2 messages: its topics and what each of its records becomes on them, stamped
//! on Unix time ([`super::run_clock`]). Free of I/O; the MCAP export writes them.
//!
//! | topic | type | one message per |
//! |---|---|---|
//! | `NS/image` | `sensor_msgs/msg/Image` | frame, its pixels as stored (`mono8`, `rgb8`, `bayer_rggb8`) |
//! | `NS/ft` | `geometry_msgs/msg/WrenchStamped` | force sample, raw as the F/T gave it (5 kHz) |
//! | `NS/wrench` | `geometry_msgs/msg/WrenchStamped` | label: the force over the exposure, tared |
//! | `NS/contact` | `geometry_msgs/msg/PointStamped` | label in contact: the contact point, metres |
//! | `NS/shape` | `vision_msgs/msg/Classification` | label: the indenter, or `None` off contact |
//! | `NS/events` | `rcl_interfaces/msg/Log` | event of the run (Foxglove's Log panel) |
//!
//! The label topics have the names `fringe stream` gives its predictions, so one Foxglove layout
//! shows both. Frames are raw `Image`s, not `CompressedImage`s: the pixels are the camera's,
//! lossless, and a BayerRG8 mosaic stays a mosaic that Foxglove and `image_proc` demosaic (a PNG
//! of it would show as a grey checkerboard); the MCAP chunks are compressed with zstd.

use super::run_clock::{part_of, RunClock};
use fringe_rig::reference_layout::NO_CONTACT;
use fringe_rig::store::{Event, FrameRecord, StoredFrame};
use fringe_rig::{ForceSample, PixelFormat};
use fringe_ros2::{
    Classification, Header, Image, Log, NameError, ObjectHypothesis, Point, PointStamped, Time,
    Vector3, Wrench, WrenchStamped,
};

/// The topics of an exported run under a namespace (`/fringe`), and the frames their headers
/// name.
#[derive(Debug, Clone, PartialEq)]
pub struct RunTopics {
    pub image: String,
    pub ft: String,
    pub wrench: String,
    pub contact: String,
    pub shape: String,
    pub events: String,
    /// The sensor's frame: the labels' (`frame_id`).
    pub sensor_frame: String,
    /// The camera's frame: the images' (`<frame_id>_camera`).
    pub camera_frame: String,
    /// The F/T sensor's frame: the raw samples' (`<frame_id>_ft`).
    pub ft_frame: String,
}

impl RunTopics {
    /// The topics under `namespace` (`/fringe`; a missing leading `/` is added, a trailing one
    /// dropped; refused unless ROS 2 would take it), with the sensor's frame `frame_id` (not
    /// empty).
    pub fn new(namespace: &str, frame_id: &str) -> Result<RunTopics, NameError> {
        let ns = fringe_ros2::namespace(namespace)?;
        if frame_id.is_empty() || frame_id.contains(char::is_whitespace) {
            return Err(NameError {
                name: frame_id.to_string(),
                what: "frame id",
                why: "it is empty or holds spaces",
            });
        }
        let ns = ns.trim_end_matches('/');
        let topic = |name: &str| format!("{ns}/{name}");
        Ok(RunTopics {
            image: topic("image"),
            ft: topic("ft"),
            wrench: topic("wrench"),
            contact: topic("contact"),
            shape: topic("shape"),
            events: topic("events"),
            sensor_frame: frame_id.to_string(),
            camera_frame: format!("{frame_id}_camera"),
            ft_frame: format!("{frame_id}_ft"),
        })
    }
}

fn wrench(w: &fringe_rig::Wrench) -> Wrench {
    let [fx, fy, fz, tx, ty, tz] = w.to_array();
    Wrench {
        force: Vector3 {
            x: fx,
            y: fy,
            z: fz,
        },
        torque: Vector3 {
            x: tx,
            y: ty,
            z: tz,
        },
    }
}

/// `sensor_msgs/image_encodings` name of a stored pixel format.
pub(crate) fn encoding(format: PixelFormat) -> &'static str {
    match format {
        PixelFormat::Mono8 => "mono8",
        PixelFormat::Rgb8 => "rgb8",
        PixelFormat::BayerRg8 => "bayer_rggb8",
    }
}

/// A stored frame as a raw image (the part of the frame the run keeps, as stored).
pub(crate) fn image(frame: StoredFrame, unix_ns: u64, topics: &RunTopics) -> Image {
    let channels = match frame.format {
        PixelFormat::Mono8 | PixelFormat::BayerRg8 => 1,
        PixelFormat::Rgb8 => 3,
    };
    Image {
        header: Header::at_unix_nanos(unix_ns, &topics.camera_frame),
        height: frame.height,
        width: frame.width,
        encoding: encoding(frame.format).into(),
        is_bigendian: 0,
        step: frame.width * channels,
        data: frame.data,
    }
}

/// A raw force sample on `NS/ft`.
pub(crate) fn ft_sample(sample: &ForceSample, unix_ns: u64, topics: &RunTopics) -> WrenchStamped {
    WrenchStamped {
        header: Header::at_unix_nanos(unix_ns, &topics.ft_frame),
        wrench: wrench(&sample.wrench),
    }
}

/// The messages of one frame's label.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LabelMessages {
    pub wrench: WrenchStamped,
    /// Only in contact.
    pub contact: Option<PointStamped>,
    pub shape: Classification,
}

/// Whether `record` has a label to publish: a force over its exposure that can be trusted (the
/// frames the reference export writes).
pub(crate) fn has_label(record: &FrameRecord) -> bool {
    record.valid && record.wrench.is_some()
}

/// The label of `record` (none without one: [`has_label`]), stamped `unix_ns`: the wrench, the
/// contact point in the sensor's frame in metres (REP-103; the run stores millimetres) while in
/// contact, the shape (the indenter's name, or `None` off contact) with probability 1.
pub(crate) fn label(
    record: &FrameRecord,
    unix_ns: u64,
    topics: &RunTopics,
) -> Option<LabelMessages> {
    if !has_label(record) {
        return None;
    }
    let w = record.wrench?;
    let h = Header::at_unix_nanos(unix_ns, &topics.sensor_frame);
    let contact = record
        .contact
        .filter(|_| record.shape != NO_CONTACT)
        .map(|[x, y]| PointStamped {
            header: h.clone(),
            point: Point {
                x: x / 1000.0,
                y: y / 1000.0,
                z: 0.0,
            },
        });
    let class = match contact {
        Some(_) => record.shape.clone(),
        None => NO_CONTACT.to_string(),
    };
    Some(LabelMessages {
        wrench: WrenchStamped {
            header: h.clone(),
            wrench: wrench(&w),
        },
        contact,
        shape: Classification {
            header: h,
            results: vec![ObjectHypothesis {
                class_id: class,
                score: 1.0,
            }],
        },
    })
}

/// The log level of an event of kind `kind`.
fn level(kind: &str) -> u8 {
    match kind {
        "stopped-by-watchers" | "failed" | "error" => Log::ERROR,
        "warning" | "watcher" | "pause" | "point-skipped" | "priority" | "sync" | "resume-run" => {
            Log::WARN
        }
        _ => Log::INFO,
    }
}

/// An event as a log line: its kind as the logger's name (`fringe.pause`), its point and message
/// as the text.
pub(crate) fn event(e: &Event, unix_ns: u64) -> Log {
    let msg = match (e.point, e.message.is_empty()) {
        (Some(p), false) => format!("point {p}: {}", e.message),
        (Some(p), true) => format!("point {p}"),
        (None, _) => e.message.clone(),
    };
    Log {
        stamp: Time::from_unix_nanos(unix_ns),
        level: level(&e.kind),
        name: format!("fringe.{}", e.kind),
        msg,
        file: String::new(),
        function: String::new(),
        line: 0,
    }
}

/// Host time (ns) at which the force stream's part holding `samples` reached device tick
/// `tick`, interpolated between the samples around it; `None` outside them.
fn tick_host_ns(samples: &[ForceSample], tick: f64) -> Option<f64> {
    let after = samples.partition_point(|s| (s.device_tick as f64) < tick);
    let b = samples.get(after)?;
    if after == 0 {
        return (b.device_tick as f64 == tick).then_some(b.host_time.0 as f64);
    }
    let a = &samples[after - 1];
    let span = b.device_tick as f64 - a.device_tick as f64;
    let f = if span > 0.0 {
        (tick - a.device_tick as f64) / span
    } else {
        0.0
    };
    Some(a.host_time.0 as f64 + f * (b.host_time.0 as f64 - a.host_time.0 as f64))
}

/// The host instant a frame stands for (ns): the middle of its exposure on the host clock when
/// the run placed it there, else the middle of its window in the force stream mapped through the
/// samples' host times (strobe synchronisation records only that), else its arrival.
pub(crate) fn frame_host_ns(record: &FrameRecord, force_part: &[ForceSample]) -> f64 {
    if let Some(e) = record.exposure {
        return 0.5 * (e.start_ns + e.end_ns);
    }
    if let Some([a, b]) = record.exposure_ticks {
        if let Some(t) = tick_host_ns(force_part, 0.5 * (a + b)) {
            return t;
        }
    }
    record.host_arrival_ns as f64
}

/// The host times of a run on Unix time, for each of its streams: where each stream's parts
/// (the processes that wrote it) begin, and the clock.
pub(crate) struct RunTimes<'a> {
    pub clock: &'a RunClock,
    pub frame_restarts: Vec<usize>,
    pub force_restarts: Vec<usize>,
    pub event_restarts: Vec<usize>,
}

impl RunTimes<'_> {
    /// Unix ns of frame `k` (record `record`) of the run whose force samples are `force`.
    pub(crate) fn frame_unix_ns(
        &self,
        k: usize,
        record: &FrameRecord,
        force: &[ForceSample],
    ) -> u64 {
        let part = part_of(&self.frame_restarts, k);
        let from = match part {
            0 => 0,
            p => self
                .force_restarts
                .get(p - 1)
                .copied()
                .unwrap_or(force.len()),
        };
        let to = self
            .force_restarts
            .get(part)
            .copied()
            .unwrap_or(force.len());
        let samples = force.get(from..to.max(from)).unwrap_or(&[]);
        self.clock.unix_ns(part, frame_host_ns(record, samples))
    }

    /// Unix ns of force sample `k`.
    pub(crate) fn force_unix_ns(&self, k: usize, sample: &ForceSample) -> u64 {
        self.clock
            .unix_ns(part_of(&self.force_restarts, k), sample.host_time.0 as f64)
    }

    /// Unix ns of event `k`.
    pub(crate) fn event_unix_ns(&self, k: usize, e: &Event) -> u64 {
        self.clock
            .unix_ns(part_of(&self.event_restarts, k), e.host_ns as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::store::Position;
    use fringe_rig::{HostTime, Millimetres, NewtonMetres, Newtons};

    fn record(contact: Option<[f64; 2]>, shape: &str) -> FrameRecord {
        let p = Position {
            x: Millimetres(0.0),
            y: Millimetres(0.0),
            z: Millimetres(0.0),
        };
        FrameRecord {
            index: 3,
            frame_id: 3,
            file: "frames/00000003.fgl".into(),
            device_timestamp: 0,
            host_arrival_ns: 9_000,
            exposure: None,
            exposure_ticks: Some([10.0, 12.0]),
            point: 0,
            commanded: p,
            measured: p,
            wrench: Some(fringe_rig::Wrench {
                fx: Newtons(0.25),
                fy: Newtons(-0.5),
                fz: Newtons(-3.0),
                tx: NewtonMetres(0.001),
                ty: NewtonMetres(0.0),
                tz: NewtonMetres(-0.002),
            }),
            shear: None,
            shape: shape.into(),
            contact,
            valid: true,
            notes: vec![],
        }
    }

    #[test]
    fn a_label_becomes_wrench_contact_in_metres_and_shape() {
        let topics = RunTopics::new("fringe/", "fringe_sensor").expect("topics");
        assert_eq!(topics.wrench, "/fringe/wrench");
        assert_eq!(
            RunTopics::new("/", "s").expect("the root namespace").image,
            "/image"
        );
        assert!(RunTopics::new("/my robot", "s").is_err());
        assert!(RunTopics::new("/fringe", "").is_err());
        assert_eq!(topics.image, "/fringe/image");
        let m = label(
            &record(Some([1.5, -2.25]), "pentagon"),
            1_000_000_007,
            &topics,
        )
        .expect("a label");
        assert_eq!(m.wrench.header.stamp, Time { sec: 1, nanosec: 7 });
        assert_eq!(m.wrench.header.frame_id, "fringe_sensor");
        assert_eq!(m.wrench.wrench.force.z, -3.0);
        assert_eq!(m.wrench.wrench.torque.z, -0.002);
        let c = m.contact.expect("in contact");
        assert_eq!((c.point.x, c.point.y, c.point.z), (0.0015, -0.00225, 0.0));
        assert_eq!(m.shape.results.len(), 1);
        assert_eq!(m.shape.results[0].class_id, "pentagon");
        assert_eq!(m.shape.results[0].score, 1.0);

        let off = label(&record(None, "None"), 5, &topics).expect("a label");
        assert!(off.contact.is_none());
        assert_eq!(off.shape.results[0].class_id, "None");
        let mut invalid = record(Some([1.0, 1.0]), "pentagon");
        invalid.valid = false;
        assert!(label(&invalid, 5, &topics).is_none());
    }

    #[test]
    fn a_strobe_window_is_placed_between_the_samples_around_it() {
        let sample = |tick: u64, host: u64| ForceSample {
            device_tick: tick,
            transport_seq: None,
            host_time: HostTime(host),
            wrench: fringe_rig::Wrench::default(),
            status: 0,
            strobe: None,
        };
        let samples: Vec<ForceSample> = (0..20).map(|k| sample(k, 1_000 + 200 * k)).collect();
        // The window [10, 12] has its middle at tick 11: host 1000 + 2200.
        assert_eq!(frame_host_ns(&record(None, "None"), &samples), 3_200.0);
        let mut r = record(None, "None");
        r.exposure_ticks = Some([10.5, 11.0]);
        assert_eq!(frame_host_ns(&r, &samples), 3_150.0);
        // Outside the samples: the frame's arrival.
        r.exposure_ticks = Some([30.0, 32.0]);
        assert_eq!(frame_host_ns(&r, &samples), 9_000.0);
    }

    #[test]
    fn events_are_log_lines_at_their_level() {
        let e = Event {
            host_ns: 0,
            utc: String::new(),
            kind: "pause".into(),
            point: Some(4),
            message: "the operator paused".into(),
        };
        let log = event(&e, 2_500_000_000);
        assert_eq!(log.level, Log::WARN);
        assert_eq!(log.name, "fringe.pause");
        assert_eq!(log.msg, "point 4: the operator paused");
        assert_eq!(
            log.stamp,
            Time {
                sec: 2,
                nanosec: 500_000_000
            }
        );
        let done = Event {
            kind: "point-done".into(),
            point: None,
            ..e
        };
        assert_eq!(event(&done, 0).level, Log::INFO);
    }
}
