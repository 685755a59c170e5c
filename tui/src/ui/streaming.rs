//! The Stream screen's side of a stream: what it would run before it starts, and the request
//! that starts it, made as `fringe stream` makes its own (the rig's camera and unit, the model
//! fringe picks for the unit, the rig file's `[stream]` settings with `ROS_DOMAIN_ID`).

use super::session::ModelChoice;
use super::state::StreamView;
use fringe_app::models::{choose_model, ChoiceNote, ForSensor};
use fringe_app::stream::{Ros2Settings, StreamRequest};
use fringe_app::RigConfig;
use std::path::{Path, PathBuf};

/// Where recordings made in the UI go: beside the runs folder.
pub const RECORDINGS: &str = "streams";

/// The node's settings: the rig file's `[stream]` section, the domain from `ROS_DOMAIN_ID` when
/// the rig file gives none.
fn settings(config: &RigConfig) -> Result<Ros2Settings, String> {
    let mut ros2 = Ros2Settings::from_rig(config);
    if config.stream_section().domain.is_none() {
        ros2.domain_from_env(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?;
    }
    ros2.check()?;
    Ok(ros2)
}

/// The screen before a stream starts: the model and the node it would run.
pub fn ready_view(config: &RigConfig, model: &str) -> StreamView {
    StreamView {
        model: model.to_string(),
        node: settings(config).map_or_else(|e| format!("cannot publish: {e}"), |s| s.describe()),
        ..StreamView::default()
    }
}

/// A new recording's path: `streams/stream-<UTC time>.mcap` beside the runs folder `runs`.
pub fn recording_path(runs: &Path) -> PathBuf {
    let dir = runs
        .parent()
        .map_or_else(|| PathBuf::from(RECORDINGS), |p| p.join(RECORDINGS));
    dir.join(format!("{}.mcap", fringe_rig::scan::new_run_id("stream")))
}

/// The stream to start: the rig's camera and unit, the model (`model` when the operator named
/// one, else the unit's commissioned model, else its design's), the node's settings, and the
/// recording when `mcap` is given. `note` hears what the choice of model said.
pub fn request(
    config: &RigConfig,
    model: Option<&ModelChoice>,
    model_from_rig: bool,
    mcap: Option<PathBuf>,
    note: &mut dyn FnMut(String),
) -> Result<StreamRequest, String> {
    let unit = config.sensor_id().ok();
    let variant = config.sensor_variant().map_err(|e| e.to_string())?;
    let given = model.filter(|_| !model_from_rig).map(|m| m.path.as_path());
    let chosen = choose_model(
        given,
        &ForSensor {
            profiles: &config.profile_dir(),
            unit: unit.as_deref(),
            variant,
            whose: "this sensor",
        },
        &mut |n| match n {
            ChoiceNote::Commissioned(line) => note(line),
            ChoiceNote::Warning(w) => note(format!("warning: {w}")),
        },
    )
    .map_err(|e| e.to_string())?;
    if let Some(path) = &mcap {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
    }
    Ok(StreamRequest {
        config: config.clone(),
        model: chosen,
        backend: model.map_or(fringe_sensor_models::BackendKind::Tract, |m| m.backend),
        threads: model.map_or(fringe_app::session::THREADS_PER_NETWORK, |m| m.threads),
        ros2: settings(config)?,
        mcap,
        image_hz: config.stream_section().image_hz.unwrap_or(0.0),
        robot_seed: 1,
    })
}
