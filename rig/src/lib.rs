//! `fringe-rig`: everything that talks to the indentation bench.
//!
//! Its modules (private unless named public below):
//! - `units`, `clock`: quantities and the host time base.
//! - `transport`: serial, pseudo-terminal, TCP and UDP links behind two small traits.
//! - `trace`: recording what crosses a link and replaying it against a driver.
//! - `axis`, `force`, `camera`: the device traits every real, simulated or replayed device
//!   implements; `devices` holds one bench's set of them.
//! - [`apt`], [`modbus`], [`netft`], [`atical`], [`nidaqmx`], `manual`: the drivers (Thorlabs APT
//!   axes, Modbus y stages, the ATI Net F/T box, strain gauges through an ATI `.cal` matrix read
//!   by an NI-DAQmx device, a y stage moved by hand), each a pure codec plus a driver over a
//!   link; `ft_units` for the F/T unit codes.
//! - `sync`, `acquire`: matching frames to force samples (strobe, clock fit, host time) and the
//!   recording threads; `realtime`: real-time scheduling for the threads that keep its time.
//! - `operator`: the person at the bench ([`Operator`]), asked by the scan and by a stage moved
//!   by hand.
//! - [`scan`]: scan plans and the scan engine; [`store`]: the run directory it writes;
//!   [`reference_layout`]: the reference pipeline's dataset layout (`0.images/`, `0.labels.csv`).
//! - `config_file`, [`seeded`]: the one TOML loader and the one seeded generator.
//!
//! Protocol codecs are pure (bytes <-> messages, no I/O); drivers combine a codec with a link.
//!
//! The surface is curated: what other crates use is re-exported here, at the root (the units
//! and host time, the device traits with their errors and settings, the links and traces, the
//! drivers a rig file names, the recording threads, the scan engine's entry point [`run_scan`]
//! with [`ScanSetup`], [`ScanProgram`] and [`ScanControl`]), except where a group of items is a
//! namespace of its own; those top-level modules stay public, each with its own list:
//! - the drivers' codecs and tables: [`apt`] (messages, frame codec, stream decoder, status
//!   bits, actuators), [`modbus`] (frames, PDUs, register maps), [`netft`] (RDT datagrams, the
//!   box's configuration page), [`nidaqmx`] (the C API's types, constants and status codes),
//!   [`atical`] (the `.cal` file and the calibrated sensor);
//! - [`scan`]: the scan's parts a front end drives by itself (control phases and requests, the
//!   press moves, the plan's targets);
//! - [`store`]: the run store (its two doors [`store::RunReader`] and [`store::RunWriter`], the
//!   documents, frame files and their codecs);
//! - [`reference_layout`] and [`seeded`], whose names (`IMAGES`, `mix`) only read well with
//!   their module's.
//!
//! Every type the public API hands out (errors, reports, plan sections) is re-exported too, so
//! all of it can be named (`unnameable_types` is warned). No other module is public. Inside
//! this crate, files import from the defining module, never through these re-exports (no import
//! circle between files).
#![warn(unreachable_pub)]
#![warn(unnameable_types)]

mod acquire;
pub mod apt;
pub mod atical;
mod axis;
mod camera;
mod clock;
mod config_file;
mod devices;
mod force;
mod ft_units;
mod manual;
pub mod modbus;
pub mod netft;
pub mod nidaqmx;
mod operator;
mod realtime;
pub mod reference_layout;
pub mod scan;
pub mod seeded;
mod slip;
pub mod store;
mod sync;
mod trace;
mod transport;
mod units;

pub use acquire::camera_stream::CameraStream;
pub use acquire::force_stream::{ForceMonitor, ForceStream};
pub use acquire::frame_gaps::FrameGaps;
pub use acquire::labeler::{ExposureLabel, FrameLabeler, LabelOutcome};
pub use acquire::record_tap::RecordTap;
pub use acquire::recorder::{
    Filming, FrameContext, PendingCheckpoint, Recorder, RecorderError, RecorderFailure,
    RecorderStats, SlidePath,
};
pub use apt::{AptConfig, Controller, ThorlabsAxis};
pub use axis::{Axis, AxisError, AxisStatus, InvalidSoftLimits, Kinematics, SoftLimits, StopMode};
#[cfg(feature = "aravis")]
pub use camera::aravis::AravisDevice;
#[cfg(feature = "aravis")]
pub use camera::aravis::{list_cameras, AravisCamera};
pub use camera::trace::{
    CameraTrace, CameraTraceError, CameraTraceWriter, RecordingCamera, ReplayCamera, ReplayPace,
    TraceFieldError, TraceFrame, TraceLatch,
};
pub use camera::writer::FrameWriter;
pub use camera::{
    format_name, parse_format_name, Camera, CameraError, CameraInfo, CameraSettings, Cutout, Frame,
    InvalidCameraSetting, PixelFormat, Roi, TimestampLatch, TriggerMode,
};
pub use clock::HostTime;
pub use config_file::{load_toml, parse_toml, ConfigError};
pub use devices::Devices;
pub use force::{ForceError, ForceSample, ForceSensor, FtAxes, StreamStats};
pub use ft_units::{newton_metres_per, newtons_per};
pub use manual::ManualStage;
pub use modbus::{Framing, ModbusStage, RegisterMap, StageOptions};
pub use netft::{NetFt, NetFtConfig, NetFtOptions};
pub use operator::{Operator, Prompt, Reply};
pub use realtime::{raise_current_thread, RealtimeRefused};
pub use scan::control::ScanControl;
pub use scan::engine::{run_scan, RunTarget, ScanOutcome};
pub use scan::failure::ScanError;
pub use scan::origin::ContactOrigin;
pub use scan::plan::{BenchLimits, Plan, ScanProgram};
pub use scan::setup::ScanSetup;
pub use slip::{partial_slip_onset, slip_labels, Slip};
pub use sync::camera_clock::{CameraClock, CameraClockOptions, Exposure};
pub use sync::method::SyncMethod;
pub use sync::strobe::StrobeWindow;
pub use sync::trigger::TriggerTiming;
pub use sync::window::{mean_over, WindowError, WindowMean};
pub use trace::format::{Direction, LinkKind, TraceEntry, TraceError};
pub use trace::replay::ReplayError;
pub use trace::{
    record_datagrams, record_stream, RecordingGauges, ReplayDatagramLink, ReplayHandle, ReplayLink,
    ReplayOptions, ReplayReport, Trace,
};
pub use transport::memory::{byte_pair, datagram_pair, MemoryByteLink, MemoryDatagramLink};
pub use transport::pty::PtyDevice;
pub use transport::serial::{
    list_ports, Parity, PortInfo, PortOpenError, SerialLink, SerialSettings,
};
pub use transport::tcp::TcpLink;
pub use transport::udp::UdpLink;
pub use transport::{ByteLink, DatagramLink};
pub use units::{
    Decibels, Hertz, Microseconds, Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared,
    NewtonMetres, Newtons, Volts, Wrench,
};
