//! The default simulated rig end to end: real drivers over in-process links to the emulators.

use fringe_rig::ForceStream;
use fringe_rig::Millimetres;
use fringe_sim::{SimRig, SimRigConfig};
use std::time::Duration;

#[test]
fn lowering_z_over_the_sensor_presses_through_the_real_drivers() {
    let mut config = SimRigConfig::default();
    // Start z just above the surface and x near the centre so the test moves little.
    config.bench.z.power_up_mm = config.bench.geometry.z_touch_mm - 1.0;
    config.bench.x.power_up_mm = config.bench.geometry.x_centre_mm - 1.0;
    let (rig, devices) = SimRig::start(&config, None).expect("sim rig");
    let mut x = devices.x;
    let mut z = devices.z;
    let t = Duration::from_secs(30);
    // Not homed: the counters read zero at power-up.
    x.move_by(Millimetres(1.0), t).expect("x");
    let stream = ForceStream::spawn(devices.force).expect("force");
    let monitor = stream.monitor();
    std::thread::sleep(Duration::from_millis(300));
    let (_, before) = monitor.mean_of_last(500).expect("samples");
    z.move_by(Millimetres(1.5), t).expect("z");
    std::thread::sleep(Duration::from_millis(200));
    let (_, after) = monitor.mean_of_last(500).expect("samples");
    let truth = rig.bench.truth_at(fringe_rig::HostTime::now());
    assert!(truth.depth.0 > 0.45 && truth.depth.0 < 0.55, "{truth:?}");
    assert!(
        truth.x.0.abs() < 1e-3 && truth.y.0.abs() < 1e-3,
        "{truth:?}"
    );
    let pressing = before[2] - after[2];
    assert!(
        pressing > 1.0,
        "pressing force {pressing} N; truth {truth:?}"
    );
    assert!(
        (pressing - truth.normal_force.0).abs() < 0.3,
        "{pressing} vs {truth:?}"
    );
}
