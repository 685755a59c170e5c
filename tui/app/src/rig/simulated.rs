//! The simulated bench behind a rig file (cargo feature `sim`, on by default): its configuration
//! from the `[sim]` section and the axis settings, its soft limits, geometry and sensor, and
//! starting it with every device's real driver talking to its emulators.

use crate::rig::error::RigError;
use crate::rig::file::{AxisSection, RigConfig, SimForcePath};
use crate::session::truth_score::TruthScore;
use fringe_rig::atical::Calibration;
use fringe_rig::ConfigError;
use fringe_rig::ContactOrigin;
use fringe_rig::Devices;
use fringe_rig::{scan::FtRating, BenchLimits};
use fringe_rig::{Kinematics, SoftLimits};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Newtons};
use fringe_sim::NetFtEmulatorConfig;
use fringe_sim::TruthSink;
use fringe_sim::TruthSpool;
use fringe_sim::{AxisConfig, Bench};
use fringe_sim::{ForcePath, SimRig, SimRigConfig, SIM_CAL};
use fringe_sim::{SensorConfig, SensorConfigError};
use std::path::Path;
use std::sync::Arc;

/// The running simulated bench of an opened rig.
pub struct SimBench {
    pub rig: SimRig,
    /// What really happens on the bench, until the run filming it takes it (a scan appends it to
    /// the run's `truth.jsonl` after every point).
    pub truth: Arc<TruthSpool>,
}

impl SimBench {
    pub fn bench(&self) -> &Arc<Bench> {
        &self.rig.bench
    }

    pub fn config(&self) -> &SimRigConfig {
        &self.rig.config
    }
}

/// A sensor build of the simulator that could not be had by its name.
#[derive(Debug, thiserror::Error)]
pub enum SensorNameError {
    /// The sensor file could not be read.
    #[error("{0}")]
    Load(#[source] SensorConfigError),
    /// Neither a build's name nor a file.
    #[error("{0:?}: use layered, integrated or the path of a sensor .toml file")]
    Unknown(String),
}

/// A sensor build of the simulator by name (`layered`, `integrated`), by a built-in unit's id
/// (`layered-2`, ...: `SensorConfig::UNITS`) or file (a `.toml` path or any file): the one
/// reading of a sensor's name, for the rig file, `--unit` and the `--sensor` flags.
pub fn sensor_by_name(name: &str) -> Result<SensorConfig, SensorNameError> {
    if let Some(unit) = SensorConfig::unit(name) {
        return Ok(unit);
    }
    match name {
        "layered" => Ok(SensorConfig::layered()),
        "integrated" => Ok(SensorConfig::integrated()),
        path if path.ends_with(".toml") || Path::new(path).is_file() => {
            SensorConfig::load(Path::new(path)).map_err(SensorNameError::Load)
        }
        other => Err(SensorNameError::Unknown(other.to_string())),
    }
}

/// A sensor build of the simulator by name (layered, integrated) or file, named by a rig file's
/// `sim.sensor`.
pub(crate) fn sim_sensor(name: &str, origin: &str) -> Result<SensorConfig, ConfigError> {
    sensor_by_name(name).map_err(|e| ConfigError {
        origin: origin.into(),
        message: match e {
            SensorNameError::Load(e) => format!("key `sim.sensor`: {e}"),
            SensorNameError::Unknown(other) => format!(
                "key `sim.sensor` = {other:?}: use layered, integrated or the path of a sensor .toml file"
            ),
        },
    })
}

/// The simulated rig's configuration.
pub fn config(rig: &RigConfig) -> Result<SimRigConfig, ConfigError> {
    let s = &rig.file.sim;
    let mut sensor = sim_sensor(&s.sensor, &rig.origin)?;
    if let Some(id) = &rig.file.sensor {
        sensor.id = id.clone();
    }
    if s.image_scale != 1.0 {
        sensor = sensor.scaled(s.image_scale);
    }
    let mut c = SimRigConfig {
        seed: s.seed,
        sensor,
        force_path: match s.force_path {
            SimForcePath::Daq => ForcePath::Daq,
            SimForcePath::Netft => ForcePath::Netft,
        },
        faults: s.faults.clone(),
        camera_trigger: match rig.daq_triggers_camera()? {
            true => Some(rig.camera_settings()?.frame_rate.0),
            false => None,
        },
        session: s.session,
        // The camera shift is given in px of the full frame, like the sensor's geometry.
        ageing: s.ageing.scaled(s.image_scale),
        ..SimRigConfig::default()
    };
    c.ageing
        .check_for(&c.sensor)
        .map_err(|e| rig.err(e.to_string()))?;
    for (section, axis) in [
        (&rig.file.x, &mut c.bench.x),
        (&rig.file.y, &mut c.bench.y),
        (&rig.file.z, &mut c.bench.z),
    ] {
        apply_sim_axis(section, axis);
    }
    Ok(c)
}

/// Soft limits (the axes' travel), kinematics and contact height of the simulated bench.
pub(crate) fn limits(rig: &RigConfig, max_force: Newtons) -> Result<BenchLimits, ConfigError> {
    let c = config(rig)?;
    let b = &c.bench;
    let limits = |name: &str, a: &AxisConfig| {
        SoftLimits::new(Millimetres(0.0), Millimetres(a.travel_mm))
            .map_err(|e| rig.err(format!("[{name}]: {e}")))
    };
    let k = |a: &AxisConfig| Kinematics {
        velocity: MillimetresPerSecond(a.velocity_mm_s),
        acceleration: MillimetresPerSecondSquared(a.acceleration_mm_s2),
    };
    // The y stage is a Modbus drive: its moves (and its homing, at the speed they leave in the
    // drive) run at its register map's profile, which the driver writes with every move.
    let y_motion = fringe_rig::RegisterMap::load(&c.y_map)
        .ok()
        .and_then(|m| m.profile)
        .map_or(k(&b.y), |p| Kinematics {
            velocity: MillimetresPerSecond(p.speed_mm_s),
            acceleration: MillimetresPerSecondSquared(p.accel_mm_s2.min(p.decel_mm_s2)),
        });
    Ok(BenchLimits {
        x: limits("x", &b.x)?,
        y: limits("y", &b.y)?,
        z: limits("z", &b.z)?,
        x_motion: k(&b.x),
        y_motion,
        z_motion: k(&b.z),
        manual_y: false,
        max_force,
        ft_rating: Some(ft_rating(rig, &c)?),
        contact_z: Millimetres(b.geometry.z_touch_mm),
        // A scan opens a new simulated bench, its axes where they power up (mm from the reverse
        // limit switch, where they home).
        start: Some([b.x, b.y, b.z].map(|a| Millimetres(a.power_up_mm))),
    })
}

/// The rated range in Fz of the simulated transducer on the configured force path: the Mini40
/// of the built-in `.cal` (DAQ), or the one the emulated Net F/T box holds.
fn ft_rating(rig: &RigConfig, c: &SimRigConfig) -> Result<FtRating, ConfigError> {
    match c.force_path {
        ForcePath::Daq => {
            let cal = Calibration::parse(SIM_CAL, "simulated Mini40 (built-in .cal)")
                .map_err(|e| rig.err(format!("the simulated F/T sensor: {e}")))?;
            Ok(FtRating {
                transducer: format!(
                    "the simulated {} ({}, serial {})",
                    cal.body_style, cal.part_number, cal.serial
                ),
                fz: Newtons(cal.max_loads[2]),
            })
        }
        ForcePath::Netft => {
            let box_config = NetFtEmulatorConfig::default();
            let range = box_config.range.ok_or_else(|| {
                rig.err("the emulated Net F/T box states no sensing range".into())
            })?;
            Ok(FtRating {
                transducer: format!(
                    "the Mini40 of the emulated {} (serial {})",
                    box_config.product_name, box_config.serial
                ),
                fz: Newtons(range[2]),
            })
        }
    }
}

/// The contact origin: the rig file's geometry keys, else the simulated bench's own.
pub(crate) fn origin(rig: &RigConfig) -> Result<ContactOrigin, ConfigError> {
    let g = &rig.file.geometry;
    let c = config(rig)?;
    Ok(ContactOrigin {
        x: Millimetres(g.x_centre.unwrap_or(c.bench.geometry.x_centre_mm)),
        y: Millimetres(g.y_centre.unwrap_or(c.bench.geometry.y_centre_mm)),
        source: "simulated bench geometry".into(),
    })
}

/// The units the simulated bench can carry (`SensorConfig::UNITS`), each with its design.
pub(crate) fn units() -> Vec<(String, &'static str)> {
    SensorConfig::UNITS
        .iter()
        .filter_map(|id| SensorConfig::unit(id).map(|c| (c.id, c.variant.name())))
        .collect()
}

/// A simulator's sensor file (its id and design), or `None` when `path` is no sensor file.
pub(crate) fn sensor_file(path: &Path) -> Option<(String, &'static str)> {
    SensorConfig::load(path)
        .ok()
        .map(|c| (c.id, c.variant.name()))
}

/// The simulated sensor's id.
pub(crate) fn sensor_id(rig: &RigConfig) -> Result<String, ConfigError> {
    Ok(config(rig)?.sensor.id)
}

/// The simulated sensor's design, `layered` or `integrated`.
pub(crate) fn sensor_variant(rig: &RigConfig) -> Result<&'static str, ConfigError> {
    Ok(config(rig)?.sensor.variant.name())
}

/// Starts the simulated bench, its ground truth recorded.
pub(crate) fn start(rig: &RigConfig) -> Result<(SimBench, Devices), RigError> {
    let config = config(rig)?;
    let truth = TruthSpool::new();
    let sink: Arc<dyn TruthSink> = truth.clone();
    let (sim, devices) = SimRig::start(&config, Some(sink)).map_err(RigError::Sim)?;
    Ok((SimBench { rig: sim, truth }, devices))
}

/// Copies the axis settings a simulated axis understands.
fn apply_sim_axis(s: &AxisSection, a: &mut AxisConfig) {
    if let Some(v) = s.velocity {
        a.velocity_mm_s = v;
    }
    if let Some(v) = s.acceleration {
        a.acceleration_mm_s2 = v;
    }
}

/// Scores the labels of the simulated run in `run_dir` against the ground truth it keeps
/// (`truth.jsonl`); `None` when no labelled frame has a truth record.
pub(crate) fn score_run(
    run_dir: &Path,
) -> Result<Option<TruthScore>, fringe_rig::store::StoreError> {
    let records = fringe_rig::store::RunReader::at(run_dir).frames()?;
    let path = run_dir.join(fringe_sim::ground_truth::TRUTH_FILE);
    let truth = fringe_sim::ground_truth::read_frames(&path).map_err(|e| match e {
        fringe_sim::ground_truth::TruthError::Io { path, source } => {
            fringe_rig::store::StoreError::Io { path, source }
        }
    })?;
    Ok(
        fringe_sim::ground_truth::score_labels(&records, &truth).map(|s| TruthScore {
            frames: s.frames,
            force_rms_n: s.force_rms_n,
            force_max_n: s.force_max_n,
            contact_frames: s.contact_frames,
            contact_rms_mm: s.contact_rms_mm,
            shear_frames: s.shear_frames,
            shear_rms_n: s.shear_rms_n,
            slip_frames: s.slip_frames,
            slip_agree: s.slip_agree,
            onsets: s.onsets,
            onset_max_frames: s.onset_max_frames,
            onsets_missed: s.onsets_missed,
            onsets_false: s.onsets_false,
        }),
    )
}

/// Contact finding tuned for the simulated sensor's construction.
pub(crate) fn spot_settings(
    rig: &RigConfig,
) -> Result<fringe_calibration::SpotSettings, ConfigError> {
    use fringe_calibration::SpotSettings;
    Ok(match config(rig)?.sensor.variant {
        fringe_sim::Variant::Integrated => SpotSettings::integrated(),
        _ => SpotSettings::layered(),
    })
}

/// A calibration from the simulated bench against what the bench really is.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationTruth {
    /// Distance of the fitted disc centre from the true optical centre, px.
    pub centre_off_px: f64,
    /// Fitted minus true disc radius, px.
    pub radius_off_px: f64,
    /// The registration against the true image geometry, when there is one.
    pub registration: Option<RegistrationTruth>,
    /// Measured force offsets minus the F/T sensor's power-up bias (N; includes the simulated
    /// sensor's drift since power-up).
    pub offset_minus_bias_n: Option<[f64; 3]>,
}

/// The image-to-stage registration against the true geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct RegistrationTruth {
    pub px_per_mm_error_pct: f64,
    pub rotation_error_deg: f64,
    pub mirror_right: bool,
    /// Contact origin minus the true sensor centre, stage mm.
    pub origin_off_mm: [f64; 2],
}

impl SimBench {
    /// Compares a calibration from this bench's runs with the bench itself.
    pub fn calibration_truth(&self, cal: &fringe_calibration::ScanCalibration) -> CalibrationTruth {
        let sim = self.config();
        let g = sim.sensor.geometry();
        let f = &cal.fit;
        let registration = cal.registration.as_ref().ok().map(|r| {
            let b = &sim.bench.geometry;
            RegistrationTruth {
                px_per_mm_error_pct: (r.fit.px_per_mm / g.px_per_mm - 1.0) * 100.0,
                rotation_error_deg: r.fit.rotation_deg - g.rotation_deg,
                mirror_right: r.fit.mirror == g.mirror,
                origin_off_mm: [
                    r.contact_origin_stage_mm[0] - b.x_centre_mm,
                    r.contact_origin_stage_mm[1] - b.y_centre_mm,
                ],
            }
        });
        let bias = self.truth.bias();
        let offset_minus_bias_n = match (&cal.offsets, bias) {
            (Some(o), Some(bias)) => Some([
                o.force_n[0] - bias.fx.0,
                o.force_n[1] - bias.fy.0,
                o.force_n[2] - bias.fz.0,
            ]),
            _ => None,
        };
        CalibrationTruth {
            centre_off_px: (f.centre_x - g.centre_px[0]).hypot(f.centre_y - g.centre_px[1]),
            radius_off_px: f.radius - sim.sensor.geometry.disc_radius_px,
            registration,
            offset_minus_bias_n,
        }
    }
}

impl SimBench {
    /// The simulated sensor's optics as a calibration profile would give them (its design: the
    /// optical centre, the disc radius as the crop radius, the frame size, and the registration
    /// against the bench's stages), for using a model on the simulated bench before a
    /// calibration has been made. Labelled as such in `source`.
    pub fn design_profile(&self, sensor_id: &str) -> fringe_calibration::Profile {
        design_profile(self.config(), sensor_id)
    }
}

/// [`SimBench::design_profile`] of the simulated rig `config` describes, without starting it.
pub(crate) fn design_profile(
    config: &SimRigConfig,
    sensor_id: &str,
) -> fringe_calibration::Profile {
    let b = &config.bench.geometry;
    sensor_profile(
        &config.sensor,
        sensor_id,
        format!(
            "the simulated {} sensor's design geometry",
            config.sensor.id
        ),
        [b.x_centre_mm, b.y_centre_mm],
    )
}

/// A simulated sensor build's design geometry as a calibration profile, dated now: the optical
/// centre and shift, the disc radius (also the crop radius) and frame size, and the exact
/// image-to-stage registration of its `SensorGeometry` (px/mm, rotation, mirror; no uncertainty)
/// for a stage whose position `contact_origin_stage_mm` presses the disc centre (`[0, 0]` when
/// the stage coordinates are the sensor frame itself, as in `fringe sim dataset` labels).
pub fn sensor_profile(
    sensor: &SensorConfig,
    sensor_id: &str,
    source: String,
    contact_origin_stage_mm: [f64; 2],
) -> fringe_calibration::Profile {
    use fringe_calibration::{ImageSize, Optical, Profile, Registration};
    let g = &sensor.geometry;
    let geometry = sensor.geometry();
    let centre = geometry.centre_px;
    let [ox, oy] = contact_origin_stage_mm;
    Profile {
        sensor_id: sensor_id.to_string(),
        created_utc: fringe_rig::store::now_utc(),
        source,
        image: ImageSize {
            width: g.width,
            height: g.height,
        },
        optical: Optical {
            centre_x_px: centre[0],
            centre_y_px: centre[1],
            shift_x_px: g.centre_offset_px[0],
            shift_y_px: g.centre_offset_px[1],
            radius_px: g.disc_radius_px,
            crop_radius_px: g.disc_radius_px,
            sigma_x_px: 0.0,
            sigma_y_px: 0.0,
            sigma_radius_px: 0.0,
            residual_rms_px: 0.0,
            frames: 0,
        },
        registration: Some(Registration {
            px_per_mm: geometry.px_per_mm,
            sigma_px_per_mm: 0.0,
            rotation_deg: geometry.rotation_deg,
            sigma_rotation_deg: 0.0,
            mirror: geometry.mirror,
            // The stage origin lies at sensor-frame (-ox, -oy).
            offset_px: geometry.to_pixel(-ox, -oy),
            contact_origin_stage_mm,
            sigma_contact_origin_stage_mm: [0.0, 0.0],
            residual_rms_px: 0.0,
            presses: 0,
            outliers: 0,
        }),
        force_offsets: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rig file's `sim.image_scale` films the same unit at a lower resolution: its disc is
    /// found where the simulator put it (at a quarter of the frame size the rim ring and the LED
    /// hot spots kept their full-size widths, and a calibration found no disc).
    #[test]
    fn a_unit_filmed_at_a_quarter_of_the_frame_size_is_found_where_it_is() {
        use fringe_calibration::GreyImage;
        use fringe_sim::Renderer;
        use fringe_sim::{FrameRenderer, Scene};
        let sensor = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../rig/sim/sensors/layered-3.toml"
        );
        let text = format!("[sim]\nsensor = \"{sensor}\"\nimage_scale = 0.25\n");
        let c = config(&RigConfig::parse(&text, "rig.toml").expect("rig file")).expect("sim");
        let full = sim_sensor(sensor, "rig.toml").expect("sensor");
        assert_eq!(c.sensor, full.scaled(0.25));
        let truth = c.sensor.geometry().centre_px;
        let radius = c.sensor.geometry.disc_radius_px;
        let mut renderer = Renderer::new(c.sensor).expect("renderer");
        let (w, h) = (renderer.width(), renderer.height());
        assert_eq!((w, h), (480, 300));
        let frames: Vec<GreyImage> = (0..3)
            .map(|k| {
                let mut rgb = Vec::new();
                renderer.render(&Scene { contact: None }, k, &mut rgb);
                let img = image::RgbImage::from_raw(w, h, rgb).expect("frame size");
                GreyImage::from_image(&image::DynamicImage::ImageRgb8(img))
            })
            .collect();
        let fit = fringe_calibration::find_disc(&frames).expect("the disc is found");
        assert!(
            (fit.centre_x - truth[0]).hypot(fit.centre_y - truth[1]) < 0.5,
            "{fit:?} {truth:?}"
        );
        assert!((fit.radius - radius).abs() < 1.0, "{fit:?} {radius}");
    }

    /// `[sim]` session and ageing reach the simulated bench: the camera shift scaled with the
    /// image, the rest as written, applied to the sensor and the F/T sensor when it is built.
    #[test]
    fn the_rig_files_ageing_and_session_reach_the_simulated_bench() {
        let text = "[sim]\nimage_scale = 0.25\nsession = 2\n[sim.ageing]\n\
                    camera_shift_px = [8.0, -4.0]\nleds_out = [2]\nft_offset_n = [0.0, 0.5, 1.5]\n\
                    fringe_value_pct = 10.0\n";
        let rig = RigConfig::parse(text, "rig.toml").expect("rig file");
        let c = config(&rig).expect("sim config");
        assert_eq!(c.session, 2);
        assert_eq!(c.ageing.camera_shift_px, [2.0, -1.0]);
        let built = c.as_built().expect("as built");
        let plain =
            config(&RigConfig::parse("[sim]\nimage_scale = 0.25\n", "rig.toml").expect("plain"))
                .expect("plain config");
        let (a, p) = (&built.sensor.geometry, &plain.sensor.geometry);
        assert_eq!(
            [
                a.centre_offset_px[0] - p.centre_offset_px[0],
                a.centre_offset_px[1] - p.centre_offset_px[1]
            ],
            [2.0, -1.0]
        );
        assert_eq!(built.sensor.leds.out, vec![2]);
        assert!(
            (built.sensor.layer.f_sigma_n_per_m / plain.sensor.layer.f_sigma_n_per_m - 1.1).abs()
                < 1e-12
        );
        assert_eq!(built.bench.ft_noise.zero_shift_n, [0.0, 0.5, 1.5]);
        assert_eq!(built.bench.ft_noise.session, 2);
        assert_eq!(plain.as_built().expect("plain built").sensor, plain.sensor);

        let rig = RigConfig::parse(
            "[sim]\nsensor = \"integrated\"\n[sim.ageing]\nleds_out = [16]\n",
            "rig.toml",
        )
        .expect("parses: the LED count is the sensor's");
        let e = config(&rig).expect_err("16 LEDs: 0..16").to_string();
        assert!(
            e.contains("rig.toml") && e.contains("sim.ageing.leds_out") && e.contains("0..16"),
            "{e}"
        );
    }
}
