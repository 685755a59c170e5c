//! `fringe stream [--rig FILE] [--unit FILE|ID] [--model M] [--seconds N] [--mcap FILE]
//! [--connect ENDPOINT]... [--listen ENDPOINT]... [--namespace NS] [--domain ID] [--no-ros2]`:
//! the camera and the unit's model, nothing else; each frame's prediction published as a ROS 2
//! node over Zenoh (rmw_zenoh's wire protocol) and recorded to MCAP. A status line a second;
//! at the end (after --seconds, or Ctrl-C) the frames, the latency and, on the simulated bench,
//! the errors against the simulator's truth.

use crate::cmd::model::choose_model;
use crate::cmd::unit_arg::UnitArg;
use crate::signals::{self, Again, Signal};
use anyhow::{bail, Context, Result};
use fringe_app::models::ForSensor;
use fringe_app::stream::{Ros2Settings, Stream, StreamRequest, StreamState, StreamSummary};
use fringe_app::RigConfig;
use fringe_sensor_models::BackendKind;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(clap::Args)]
pub struct StreamArgs {
    /// The rig file: its camera and sensor (default: ./rig.toml if present, else the simulated
    /// bench, where the simulator's robot presses the sensor). Its `[stream]` section may set
    /// namespace, domain, frame_id, connect, listen and image_hz.
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    #[command(flatten)]
    unit: UnitArg,
    /// The model: a model file or `builtin:NAME`. Default: the unit's commissioned model, else
    /// its design's model. A model of another design is refused.
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// Stop cleanly after N seconds (default: until Ctrl-C).
    #[arg(long, value_name = "N")]
    seconds: Option<f64>,
    /// Record the messages (ROS 2 CDR, schemas included) to this MCAP file.
    #[arg(long, value_name = "FILE")]
    mcap: Option<PathBuf>,
    /// A Zenoh endpoint to connect to (repeatable; default tcp/localhost:7447, rmw_zenoh's
    /// router `ros2 run rmw_zenoh_cpp rmw_zenohd`).
    #[arg(long, value_name = "ENDPOINT")]
    connect: Vec<String>,
    /// A Zenoh endpoint to listen on for peers (repeatable; default tcp/localhost:0).
    #[arg(long, value_name = "ENDPOINT")]
    listen: Vec<String>,
    /// The ROS 2 namespace of the node and its topics (default /fringe).
    #[arg(long, value_name = "NS")]
    namespace: Option<String>,
    /// The ROS 2 domain id (default 0, or ROS_DOMAIN_ID).
    #[arg(long, value_name = "ID")]
    domain: Option<u32>,
    /// The frame id in every message's header (default fringe_sensor).
    #[arg(long, value_name = "ID")]
    frame_id: Option<String>,
    /// Publish the camera's frames as <ns>/image/compressed (PNG) this many times a second
    /// (default 0: none).
    #[arg(long, value_name = "HZ")]
    image_hz: Option<f64>,
    /// Do not publish over Zenoh (record with --mcap only).
    #[arg(long)]
    no_ros2: bool,
    /// Inference backend: tract (built in), onnxruntime or torch (cargo features).
    #[arg(long, default_value = "tract")]
    backend: BackendKind,
    /// Inference threads of each network.
    #[arg(
        long,
        default_value_t = fringe_app::session::THREADS_PER_NETWORK,
        value_parser = crate::cmd::arg_values::threads
    )]
    threads: usize,
    /// On the simulated bench: the seed of the robot's presses.
    #[arg(long, default_value_t = 1)]
    robot_seed: u64,
}

pub fn run(a: StreamArgs) -> Result<()> {
    if let Some(s) = a.seconds {
        if !(s.is_finite() && s > 0.0) {
            bail!("--seconds {s}: give a positive number of seconds");
        }
    }
    if a.no_ros2 && a.mcap.is_none() {
        bail!("--no-ros2 without --mcap FILE sends the predictions nowhere: give --mcap FILE, or leave out --no-ros2");
    }
    let (config, source) = RigConfig::resolve(a.rig.as_deref())?;
    let config = a.unit.on(config)?;
    let unit = config.sensor_id().ok();
    let model = choose_model(
        a.model.as_deref(),
        &ForSensor {
            profiles: &config.profile_dir(),
            unit: unit.as_deref(),
            variant: config.sensor_variant()?,
            whose: "this sensor",
        },
    )?;
    let mut ros2 = Ros2Settings::from_rig(&config);
    if let Some(ns) = &a.namespace {
        ros2.namespace = ns.clone();
    }
    match a.domain {
        Some(d) => ros2.domain = d,
        None => ros2
            .domain_from_env(std::env::var("ROS_DOMAIN_ID").ok().as_deref())
            .map_err(anyhow::Error::msg)?,
    }
    if let Some(f) = &a.frame_id {
        ros2.frame_id = f.clone();
    }
    if !a.connect.is_empty() {
        ros2.connect = a.connect.clone();
    }
    if !a.listen.is_empty() {
        ros2.listen = a.listen.clone();
    }
    ros2.publish = !a.no_ros2;
    let image_hz = a
        .image_hz
        .or(config.stream_section().image_hz)
        .unwrap_or(0.0);
    if !(image_hz.is_finite() && image_hz >= 0.0) {
        bail!("--image-hz {image_hz}: give a rate of 0 (no images) or more");
    }
    if let Some(m) = &a.mcap {
        fringe_rig::store::outside_runs(m).context("--mcap")?;
    }
    println!(
        "fringe {}: rig: {}",
        env!("CARGO_PKG_VERSION"),
        source.describe()
    );
    println!("model: {} ({})", model.path.display(), model.describe());
    let stop = signals::catch(
        &[Signal::Interrupt, Signal::Terminate, Signal::HangUp],
        Again::Ends,
    );
    let (stream, notes) = Stream::start(StreamRequest {
        config,
        model,
        backend: a.backend,
        threads: crate::cmd::arg_values::cap_threads(a.threads),
        ros2,
        mcap: a.mcap.clone(),
        image_hz,
        robot_seed: a.robot_seed,
    })?;
    for n in notes {
        println!("{n}");
    }
    match a.seconds {
        Some(s) => println!("streaming for {s} s (Ctrl-C stops it sooner)"),
        None => println!("streaming until Ctrl-C"),
    }
    let started = Instant::now();
    let mut said = 0usize;
    let mut last_line = Instant::now();
    let mut connected: Option<bool> = None;
    loop {
        std::thread::sleep(Duration::from_millis(50));
        let state = stream.state();
        for w in &state.warnings[said.min(state.warnings.len())..] {
            eprintln!("warning: {w}");
        }
        said = state.warnings.len();
        if state.connected != connected {
            match (connected, state.connected) {
                (_, Some(true)) => println!("Zenoh: connected"),
                (Some(true), Some(false)) => println!("Zenoh: disconnected; publishing goes on, reconnecting in the background"),
                (None, Some(false)) => println!("Zenoh: no router or peer yet at the endpoints; publishing anyway, connecting in the background"),
                _ => {}
            }
            connected = state.connected;
        }
        if state.failure.is_some() {
            break;
        }
        if signals::stop_requested() || stop.load(std::sync::atomic::Ordering::SeqCst) {
            println!("stopping (signal)");
            break;
        }
        if a.seconds
            .is_some_and(|s| started.elapsed().as_secs_f64() >= s)
        {
            break;
        }
        if last_line.elapsed() >= Duration::from_secs(1) {
            last_line = Instant::now();
            println!("{}", status_line(&state));
        }
    }
    let summary = stream.finish()?;
    print_summary(&summary);
    if let Some(why) = &summary.state.failure {
        bail!("the stream stopped: {why}");
    }
    Ok(())
}

/// One line a second: frames, rate, the newest prediction and its latency, what went out.
fn status_line(s: &StreamState) -> String {
    let latest = match &s.latest {
        Some(p) => format!(
            "Fz {:5.2} N, {} {:3.0} %{}",
            p.force.fz.value(),
            p.shape,
            100.0 * p.confidence(),
            p.contact.map_or(String::new(), |[x, y]| format!(
                " at ({:+.1}, {:+.1}) mm",
                x.value(),
                y.value()
            ))
        ),
        None => "no prediction yet".into(),
    };
    let latency = s
        .latest_latency_ms
        .map_or(String::new(), |l| format!(", {l:.0} ms"));
    let robot = s
        .robot_presses
        .map_or(String::new(), |n| format!("; robot presses {n}"));
    let published = match s.namespace {
        Some(_) => format!("  published {}", s.published.wrench),
        None => String::new(),
    };
    format!(
        "{:6.1} s  {:4.0} Hz  frames {} (skipped {}, camera lost {})  {latest}{latency}{published}{robot}",
        s.elapsed_s, s.rate_hz, s.ran, s.skipped, s.dropped_by_camera,
    )
}

fn print_summary(sum: &StreamSummary) {
    for line in crate::stream_text::summary_lines(sum) {
        println!("{line}");
    }
}
