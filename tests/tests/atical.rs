//! ATI `.cal` files: both versions, conversion of known voltages, bias, tool transform, units,
//! malformed files, and the calibrated sensor over a gauge source.

use fringe_rig::atical::{
    CalError, CalibratedSensor, Calibration, GaugeReading, GaugeSource, ToolTransform,
};
use fringe_rig::HostTime;
use fringe_rig::Volts;
use fringe_rig::{ForceError, ForceSensor};
use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::Duration;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

const VOLTS: [f64; 6] = [0.1, -0.2, 0.3, 0.05, -0.15, 0.25];
/// Hand-computed from the constructed matrix: row i of values / scale, times VOLTS, with the
/// BasicTransform Dz = 5.5 mm applied (Tx += Dz*Fy, Ty -= Dz*Fx).
const EXPECTED: [f64; 6] = [
    1.4877815625,
    -2.8540909375,
    9.27566,
    -0.02279832015625,
    -0.00821987859375,
    -0.000703,
];

fn assert_close(got: [f64; 6], want: [f64; 6], tol: f64) {
    for i in 0..6 {
        assert!(
            (got[i] - want[i]).abs() <= tol * (1.0 + want[i].abs()),
            "axis {i}: got {got:?}, want {want:?}"
        );
    }
}

#[test]
fn version_1_0_applies_the_basic_transform_to_axis_rows() {
    let cal = Calibration::load(&data("mini40-v1.0.cal")).expect("load");
    assert_eq!(cal.serial, "FT90001");
    assert_eq!(cal.body_style, "Mini40");
    assert_eq!(cal.part_number, "SI-40-2");
    assert_eq!(cal.file_version, "1.0");
    assert!(!cal.user_axes);
    assert_eq!(cal.max_loads, [40.0, 40.0, 120.0, 2.0, 2.0, 2.0]);
    assert_close(cal.convert(VOLTS, [0.0; 6], None), EXPECTED, 1e-9);
    // One gauge alone gives the first column divided by each row's scale (Fz: 18.20346 / 0.5).
    let col = cal.convert([1.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 6], None);
    assert!((col[2] - 36.40692).abs() < 1e-9, "{col:?}");
}

#[test]
fn version_1_1_user_axes_in_imperial_units_give_the_same_newtons() {
    let v10 = Calibration::load(&data("mini40-v1.0.cal")).expect("v1.0");
    let v11 = Calibration::load(&data("mini40-v1.1.cal")).expect("v1.1");
    assert!(v11.user_axes);
    assert_eq!(
        (v11.force_units.as_str(), v11.torque_units.as_str()),
        ("lbf", "lbf-in")
    );
    // The UserAxis rows already hold the 5.5 mm offset: applying it again would shift Tx by
    // another Dz*Fy (about -0.0157 N m here).
    assert_close(v11.convert(VOLTS, [0.0; 6], None), EXPECTED, 1e-8);
    assert_close(
        v11.convert(VOLTS, [0.0; 6], None),
        v10.convert(VOLTS, [0.0; 6], None),
        1e-8,
    );
    assert!(
        (v11.max_loads[2] - 120.0).abs() < 1e-3,
        "rated Fz converted to N: {:?}",
        v11.max_loads
    );
}

#[test]
fn bias_is_subtracted_before_the_matrix() {
    let cal = Calibration::load(&data("mini40-v1.0.cal")).expect("load");
    let bias = [0.5, 0.4, -0.3, 0.2, 0.1, -0.05];
    let shifted: [f64; 6] = std::array::from_fn(|i| VOLTS[i] + bias[i]);
    assert_close(cal.convert(shifted, bias, None), EXPECTED, 1e-9);
    assert_close(cal.convert(bias, bias, None), [0.0; 6], 1e-12);
}

#[test]
fn tool_translation_along_z_changes_tx_by_dz_times_fy() {
    let cal = Calibration::load(&data("mini40-v1.0.cal")).expect("load");
    let dz = 0.1;
    let tool = ToolTransform::translation(0.0, 0.0, dz);
    let w = cal.convert(VOLTS, [0.0; 6], Some(&tool));
    let base = EXPECTED;
    assert!((w[3] - (base[3] + dz * base[1])).abs() < 1e-9, "{w:?}");
    assert!((w[4] - (base[4] - dz * base[0])).abs() < 1e-9, "{w:?}");
    assert_close(
        [w[0], w[1], w[2], 0.0, 0.0, w[5]],
        [base[0], base[1], base[2], 0.0, 0.0, base[5]],
        1e-12,
    );
}

fn broken(edit: impl Fn(String) -> String) -> CalError {
    let text = std::fs::read_to_string(data("mini40-v1.0.cal")).expect("read");
    Calibration::parse(&edit(text), "broken.cal").expect_err("must fail")
}

#[test]
fn malformed_files_name_the_file_and_element() {
    let e = broken(|t| {
        t.lines()
            .filter(|l| !l.contains("Name=\"Tz\""))
            .collect::<Vec<_>>()
            .join("\n")
    });
    assert_eq!(
        e.to_string(),
        "calibration file broken.cal: <Axis Name=\"Tz\">: element is missing"
    );
    let e = broken(|t| t.replace("values=\"0.00532", "values=\"x0.00532"));
    assert!(
        e.to_string()
            .contains("<Axis Name=\"Tz\">: values: `x0.00532` is not a number"),
        "{e}"
    );
    let e = broken(|t| t.replace("  11.12043\"", "\""));
    assert!(
        e.to_string()
            .contains("<Axis Name=\"Fx\">: values has 5 numbers, expected 6"),
        "{e}"
    );
    let e = broken(|t| t.replace("ForceUnits=\"N\"", "ForceUnits=\"stone\""));
    assert!(
        e.to_string()
            .contains("<Calibration>: ForceUnits `stone` is unknown"),
        "{e}"
    );
    let e = broken(|t| t.replace("scale=\"0.5\"", "scale=\"0\""));
    assert!(
        e.to_string()
            .contains("<Axis Name=\"Fz\">: scale `0` must be a non-zero number"),
        "{e}"
    );
    let e = broken(|t| t.replace("Dz=\"5.5\"", "Dz=\"five\""));
    assert!(
        e.to_string()
            .contains("<BasicTransform>: Dz `five` is not a number"),
        "{e}"
    );
    let e = broken(|t| t.replace("</FTSensor>", ""));
    assert!(
        e.to_string()
            .starts_with("calibration file broken.cal: XML: not valid XML"),
        "{e}"
    );
    let e = Calibration::load(&data("no-such.cal")).expect_err("missing file");
    assert!(e.to_string().contains("no-such.cal"), "{e}");
}

/// A DAQ stand-in delivering scripted scans.
struct Scripted {
    scans: VecDeque<GaugeReading>,
    started: bool,
}

fn scan(index: u64, gauges: [f64; 6], strobe: f64) -> GaugeReading {
    GaugeReading {
        index,
        host_time: HostTime(index * 200_000),
        gauges: gauges.map(Volts),
        strobe: Some(Volts(strobe)),
        lost_before: 0,
    }
}

impl GaugeSource for Scripted {
    fn describe(&self) -> String {
        "scripted daq".into()
    }
    fn start(&mut self) -> Result<(), ForceError> {
        self.started = true;
        Ok(())
    }
    fn next_reading(&mut self, _timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
        Ok(if self.started {
            self.scans.pop_front()
        } else {
            None
        })
    }
    fn stop(&mut self) -> Result<(), ForceError> {
        self.started = false;
        Ok(())
    }
}

/// A gauge at the limit of the DAQ's input range is clipped there: the forces the matrix makes
/// of it are nonsense (on the simulated bench, a 4 N press read as 280 N pulling while a slide
/// pushed sideways), so the sensor refuses the scan, naming the gauge and what to do.
#[test]
fn a_saturated_gauge_is_refused_not_converted() {
    let cal = Calibration::load(&data("mini40-v1.0.cal")).expect("load");
    let fine = [0.5, 0.4, -0.3, 0.2, 0.1, -0.05];
    // Near the rail, as a large offset can leave a gauge, is still a reading.
    let mut near = fine;
    near[3] = -9.97;
    let mut clipped = fine;
    clipped[3] = -10.0;
    let scans = VecDeque::from(vec![
        scan(1, fine, 0.0),
        scan(2, near, 0.0),
        scan(3, clipped, 0.0),
        scan(4, fine, 0.0),
    ]);
    let mut sensor = CalibratedSensor::new(
        Scripted {
            scans,
            started: false,
        },
        cal,
    )
    .with_saturation(Volts(10.0));
    sensor.start().expect("start");
    for _ in 0..2 {
        assert!(sensor
            .next_sample(Duration::from_millis(10))
            .expect("a scan within range converts")
            .is_some());
    }
    let err = sensor
        .next_sample(Duration::from_millis(10))
        .expect_err("a clipped gauge is refused")
        .to_string();
    assert!(
        err.contains("gauge 4")
            && err.contains("-10.000 V")
            && err.contains("saturated")
            && err.contains("force.range_v"),
        "{err}"
    );
    // Without a known range (a replay of old traces), scans convert as before.
    let cal = Calibration::load(&data("mini40-v1.0.cal")).expect("load");
    let mut blind = CalibratedSensor::new(
        Scripted {
            scans: VecDeque::from(vec![scan(1, clipped, 0.0)]),
            started: false,
        },
        cal,
    );
    blind.start().expect("start");
    assert!(blind
        .next_sample(Duration::from_millis(10))
        .expect("converted")
        .is_some());
}

#[test]
fn calibrated_sensor_biases_converts_and_passes_the_strobe_through() {
    let cal = Calibration::load(&data("mini40-v1.0.cal")).expect("load");
    let rest = [0.5, 0.4, -0.3, 0.2, 0.1, -0.05];
    let rest2 = rest.map(|v| v + 0.02);
    let loaded: [f64; 6] = std::array::from_fn(|i| rest[i] + 0.01 + VOLTS[i]);
    let scans = VecDeque::from(vec![
        scan(10, rest, 0.0),
        scan(11, rest2, 0.0),
        scan(12, loaded, 4.8),
        scan(15, loaded, 0.1), // 13 and 14 never arrived
    ]);
    let mut sensor = CalibratedSensor::new(
        Scripted {
            scans,
            started: false,
        },
        cal,
    )
    .with_bias_scans(2);
    sensor.start().expect("start");
    sensor.bias().expect("bias averages two scans");
    assert_close(sensor.bias_volts(), rest.map(|v| v + 0.01), 1e-12);
    let s = sensor
        .next_sample(Duration::from_millis(10))
        .expect("ok")
        .expect("sample");
    assert_eq!(s.device_tick, 12);
    assert_eq!(s.strobe, Some(Volts(4.8)));
    assert_eq!(s.host_time, HostTime(12 * 200_000));
    assert_close(s.wrench.to_array(), EXPECTED, 1e-9);
    let s = sensor
        .next_sample(Duration::from_millis(10))
        .expect("ok")
        .expect("sample");
    assert_eq!((s.device_tick, s.strobe), (15, Some(Volts(0.1))));
    assert_eq!(sensor.stats().lost, 2);
    assert_eq!(sensor.stats().received, 4);
    assert!(sensor
        .next_sample(Duration::from_millis(1))
        .expect("ok")
        .is_none());
    let e = sensor.bias().expect_err("no scans left");
    assert!(e.to_string().contains("scripted daq"), "{e}");
}
