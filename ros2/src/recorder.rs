//! Recording to MCAP as ROS 2 does (feature `mcap`): the `ros2` profile, each type's schema as
//! its `ros2msg` definition with every dependency ([`crate::msg_definition`]), each channel's
//! messages as the CDR ROS 2 puts on the wire, chunks compressed with zstd, and the summary and
//! index written when the recording finishes. Foxglove, `rosbags` and the `mcap` readers open it.

use crate::messages::{encode, EncodeError, RosMessage};
use crate::names::{Qos, Reliability};
use crate::type_hash::msg_definition;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

/// Why a recording failed: the file, and what went wrong.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("{}: cannot create the MCAP file: {source}", path.display())]
    Create {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: {what}: {message}", path.display())]
    Write {
        path: PathBuf,
        what: String,
        message: String,
    },
    #[error(transparent)]
    Encode(#[from] EncodeError),
}

/// An MCAP recording under way.
pub struct Recorder {
    writer: mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    /// Schema ids by type name.
    schemas: HashMap<&'static str, u16>,
}

/// A topic of the recording, for messages of type `M`.
pub struct Channel<M> {
    id: u16,
    sequence: u32,
    _message: PhantomData<fn(M)>,
}

/// `rosbag2`'s `offered_qos_profiles` for `qos` (Jazzy's form).
fn qos_yaml(qos: Qos) -> String {
    let reliability = match qos.reliability {
        Reliability::Reliable => "reliable",
        Reliability::BestEffort => "best_effort",
    };
    let infinite = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: keep_last\n  depth: {}\n  reliability: {reliability}\n  durability: volatile\n  deadline:{infinite}\n  lifespan:{infinite}\n  liveliness: automatic\n  liveliness_lease_duration:{infinite}\n  avoid_ros_namespace_conventions: false",
        qos.depth
    )
}

impl Recorder {
    /// Creates `path` (replacing a file there) and writes its header.
    pub fn create(path: &Path) -> Result<Recorder, RecordError> {
        let file = File::create(path).map_err(|source| RecordError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .compression(Some(mcap::Compression::Zstd))
            .create(BufWriter::new(file))
            .map_err(|e| RecordError::Write {
                path: path.to_path_buf(),
                what: "the header".into(),
                message: e.to_string(),
            })?;
        Ok(Recorder {
            writer,
            path: path.to_path_buf(),
            schemas: HashMap::new(),
        })
    }

    fn failed(&self, what: impl Into<String>, e: mcap::McapError) -> RecordError {
        RecordError::Write {
            path: self.path.clone(),
            what: what.into(),
            message: e.to_string(),
        }
    }

    /// A channel of `M` on the fully qualified topic `topic` (`/fringe/wrench`), offered with
    /// `qos`.
    pub fn channel<M: RosMessage>(
        &mut self,
        topic: &str,
        qos: Qos,
    ) -> Result<Channel<M>, RecordError> {
        let t = M::TYPE;
        let schema = match self.schemas.get(t.name) {
            Some(id) => *id,
            None => {
                let id = self
                    .writer
                    .add_schema(t.name, "ros2msg", msg_definition(t).as_bytes())
                    .map_err(|e| self.failed(format!("the schema of {}", t.name), e))?;
                self.schemas.insert(t.name, id);
                id
            }
        };
        let metadata = BTreeMap::from([("offered_qos_profiles".to_string(), qos_yaml(qos))]);
        let id = self
            .writer
            .add_channel(schema, topic, "cdr", &metadata)
            .map_err(|e| self.failed(format!("the channel {topic}"), e))?;
        Ok(Channel {
            id,
            sequence: 0,
            _message: PhantomData,
        })
    }

    /// Writes `m` on `channel`, received at `log_ns` and sent at `publish_ns` (ns since the
    /// Unix epoch).
    pub fn write<M: RosMessage>(
        &mut self,
        channel: &mut Channel<M>,
        m: &M,
        log_ns: u64,
        publish_ns: u64,
    ) -> Result<(), RecordError> {
        let bytes = encode(m)?;
        channel.sequence = channel.sequence.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence: channel.sequence,
            log_time: log_ns,
            publish_time: publish_ns,
        };
        self.writer
            .write_to_known_channel(&header, &bytes)
            .map_err(|e| self.failed(format!("a message of {}", M::TYPE.name), e))
    }

    /// Writes a metadata record `name` holding `entries` (what the recording is of: a run's id,
    /// its sensor, how its times were placed); readers list them with the file's summary.
    pub fn metadata(
        &mut self,
        name: &str,
        entries: BTreeMap<String, String>,
    ) -> Result<(), RecordError> {
        let record = mcap::records::Metadata {
            name: name.to_string(),
            metadata: entries,
        };
        self.writer
            .write_metadata(&record)
            .map_err(|e| self.failed(format!("the metadata {name}"), e))
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the summary and the index and closes the file: its path.
    pub fn finish(mut self) -> Result<PathBuf, RecordError> {
        self.writer
            .finish()
            .map_err(|e| self.failed("the summary", e))?;
        Ok(self.path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::{
        Classification, Header, ObjectHypothesis, Time, Vector3, Wrench, WrenchStamped,
    };

    /// A recording read back: the ros2 profile, each topic's schema with its definition, every
    /// message's CDR bytes and times, and the summary written.
    #[test]
    fn a_recording_reads_back_as_ros_2_bags_do() {
        let dir = std::env::temp_dir().join(format!("fringe-ros2-mcap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("stream.mcap");
        let header = |k: u64| Header {
            stamp: Time::from_unix_nanos(1_000_000_000 + k),
            frame_id: "fringe_sensor".into(),
        };
        let wrench = |k: u64| WrenchStamped {
            header: header(k),
            wrench: Wrench {
                force: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: -(k as f64),
                },
                torque: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                },
            },
        };
        let mut r = Recorder::create(&path).expect("create");
        let mut w = r
            .channel::<WrenchStamped>("/fringe/wrench", Qos::DEFAULT)
            .expect("w");
        let mut s = r
            .channel::<Classification>("/fringe/shape", Qos::DEFAULT)
            .expect("s");
        for k in 0..5u64 {
            r.write(&mut w, &wrench(k), 2_000 + k, 1_000 + k)
                .expect("write");
        }
        let shape = Classification {
            header: header(9),
            results: vec![ObjectHypothesis {
                class_id: "pentagon".into(),
                score: 1.0,
            }],
        };
        r.write(&mut s, &shape, 3_000, 3_000).expect("write");
        assert_eq!(r.finish().expect("finish"), path);

        let bytes = std::fs::read(&path).expect("read");
        let summary = mcap::Summary::read(&bytes)
            .expect("summary")
            .expect("a summary");
        assert_eq!(summary.stats.map(|s| s.message_count), Some(6));
        let messages: Vec<mcap::Message> = mcap::MessageStream::new(&bytes)
            .expect("stream")
            .collect::<Result<_, _>>()
            .expect("messages");
        assert_eq!(messages.len(), 6);
        let first = &messages[0];
        assert_eq!(first.channel.topic, "/fringe/wrench");
        assert_eq!(first.channel.message_encoding, "cdr");
        let schema = first.channel.schema.as_ref().expect("schema");
        assert_eq!(schema.name, "geometry_msgs/msg/WrenchStamped");
        assert_eq!(schema.encoding, "ros2msg");
        assert_eq!(
            schema.data.as_ref(),
            msg_definition(WrenchStamped::TYPE).as_bytes()
        );
        assert!(first.channel.metadata["offered_qos_profiles"].contains("depth: 10"));
        for (k, m) in messages.iter().take(5).enumerate() {
            assert_eq!(
                m.data.as_ref(),
                encode(&wrench(k as u64)).expect("encode").as_slice()
            );
            assert_eq!(
                (m.log_time, m.publish_time),
                (2_000 + k as u64, 1_000 + k as u64)
            );
            assert_eq!(m.sequence, k as u32 + 1);
        }
        assert_eq!(messages[5].channel.topic, "/fringe/shape");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn metadata_is_listed_in_the_summary() {
        let dir = std::env::temp_dir().join(format!("fringe-ros2-meta-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("run.mcap");
        let mut r = Recorder::create(&path).expect("create");
        r.metadata(
            "fringe_run",
            BTreeMap::from([("run_id".to_string(), "cli-1".to_string())]),
        )
        .expect("metadata");
        r.finish().expect("finish");
        let bytes = std::fs::read(&path).expect("read");
        let summary = mcap::Summary::read(&bytes)
            .expect("summary")
            .expect("a summary");
        assert_eq!(summary.metadata_indexes.len(), 1);
        let index = &summary.metadata_indexes[0];
        assert_eq!(index.name, "fringe_run");
        let m = mcap::read::metadata(&bytes, index).expect("metadata");
        assert_eq!(m.metadata["run_id"], "cli-1");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
