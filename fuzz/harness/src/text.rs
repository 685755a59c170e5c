//! Targets over the text files users write or edit by hand, and those devices serve: the Net F/T
//! configuration page, ATI `.cal` files, register maps, plans, rig files, sensor files,
//! profiles, trace files. Invalid UTF-8 is read as the lossy text a user's editor would show.

use std::borrow::Cow;
use std::path::Path;

use fringe_app::RigConfig;
use fringe_calibration::Profile;
use fringe_rig::atical::Calibration;
use fringe_rig::netft::parse_http_response;
use fringe_rig::parse_toml;
use fringe_rig::NetFtConfig;
use fringe_rig::Plan;
use fringe_rig::RegisterMap;
use fringe_rig::Trace;
use fringe_sim::SensorConfig;

const ORIGIN: &str = "fuzz";

fn text(data: &[u8]) -> Cow<'_, str> {
    String::from_utf8_lossy(data)
}

/// The Net F/T box's HTTP reply and its `netftapi2.xml` configuration.
pub fn netft_xml(data: &[u8]) {
    let _ = parse_http_response(data);
    let _ = NetFtConfig::from_netftapi2(&text(data), ORIGIN);
}

/// An ATI calibration file.
pub fn cal_file(data: &[u8]) {
    let _ = Calibration::parse(&text(data), ORIGIN);
}

/// A Modbus stage's register map.
pub fn register_map(data: &[u8]) {
    let _ = RegisterMap::parse(&text(data), ORIGIN);
}

/// A scan plan, then its program and duration estimate on the simulated bench's limits (what a
/// dry run does with it).
pub fn plan(data: &[u8]) {
    let Ok(plan) = Plan::parse(&text(data), ORIGIN) else {
        return;
    };
    let Ok(limits) = RigConfig::simulated().limits() else {
        panic!("the simulated rig's own limits are refused");
    };
    if let Ok(program) = plan.program(&limits, ORIGIN) {
        let _ = program.estimate(&limits);
    }
}

/// A rig file, then every part of it that opening the rig reads.
pub fn rig_file(data: &[u8]) {
    let Ok(rig) = RigConfig::parse(&text(data), ORIGIN) else {
        return;
    };
    let _ = rig.sync();
    let _ = rig.limits();
    let _ = rig.origin();
    let _ = rig.sensor_id();
    let _ = rig.camera_settings();
}

/// A simulated sensor's file.
pub fn sensor_file(data: &[u8]) {
    let _ = SensorConfig::from_toml_str(&text(data), ORIGIN);
}

/// A sensor profile.
pub fn profile(data: &[u8]) {
    if let Ok(profile) = parse_toml::<Profile>(&text(data), ORIGIN) {
        let _ = profile.age_days(std::time::SystemTime::now());
    }
}

/// A recorded device trace and a camera trace's index.
pub fn trace(data: &[u8]) {
    let text = text(data);
    let _ = Trace::parse(&text, ORIGIN);
    let _ = fringe_rig::CameraTrace::parse(&text, Path::new("/nonexistent/fuzz"));
}
