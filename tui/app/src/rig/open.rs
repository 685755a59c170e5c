//! Opening the rig a rig file describes: each real device's section becomes a description
//! (`rig::devices`) that the one opener (`device_open`, `force::open_force`) opens, as the
//! bring-up commands do with their flags; or the simulated rig (`rig::simulated`) when the rig is
//! simulated.

use crate::rig::device_open::{open_axis, open_camera, TraceTo};
use crate::rig::error::RigError;
use crate::rig::file::RigConfig;
use crate::rig::force::open_force;
#[cfg(feature = "sim")]
use crate::rig::simulated::SimBench;
use fringe_rig::BenchLimits;
use fringe_rig::CameraSettings;
use fringe_rig::ContactOrigin;
use fringe_rig::Devices;
use fringe_rig::Operator;
use fringe_rig::SyncMethod;
use fringe_rig::TriggerTiming;
use std::path::Path;

/// The rig, opened.
pub struct OpenRig {
    pub devices: Devices,
    pub limits: BenchLimits,
    /// Contact origin from the rig file or the simulated bench (a profile may replace it).
    pub origin: ContactOrigin,
    pub sync: SyncMethod,
    /// The DAQ-triggered camera's timing, when the DAQ triggers the camera (sync `trigger`).
    pub trigger: Option<TriggerTiming>,
    pub sensor_id: String,
    pub camera_settings: CameraSettings,
    /// The rig file's text (or a description of the default simulated bench).
    pub text: String,
    /// The simulated bench, when simulated (kept alive for the devices), and its ground truth.
    #[cfg(feature = "sim")]
    pub sim: Option<SimBench>,
}

/// What opening the rig takes from its file, read and checked before any device is opened.
struct Described {
    limits: BenchLimits,
    origin: ContactOrigin,
    sync: SyncMethod,
    trigger: Option<TriggerTiming>,
    sensor_id: String,
    camera_settings: CameraSettings,
}

impl RigConfig {
    /// Checks what [`RigConfig::open`] reads from the rig file before it opens a device (the
    /// limits, the origin, the synchronisation, the sensor, the camera settings), opening none:
    /// a dry run refuses what the scan would.
    pub fn check_before_open(&self) -> Result<(), RigError> {
        self.described().map(|_| ())
    }

    fn described(&self) -> Result<Described, RigError> {
        Ok(Described {
            limits: self.limits()?,
            origin: self.origin()?,
            sync: self.sync()?,
            trigger: self.trigger_timing()?,
            sensor_id: self.sensor_id()?,
            camera_settings: self.camera_settings()?,
        })
    }

    /// Opens every device: the simulated bench's when the rig is simulated (its ground truth
    /// recorded), else the real drivers; `record_trace` records every real device link to
    /// DIR/<device>.trace. A y stage moved by hand asks `stage_operator`, the front end's.
    pub fn open(
        &self,
        record_trace: Option<&Path>,
        stage_operator: Box<dyn Operator>,
    ) -> Result<OpenRig, RigError> {
        let Described {
            limits,
            origin,
            sync,
            trigger,
            sensor_id,
            camera_settings,
        } = self.described()?;
        let text = self.text.clone();
        if self.simulated {
            #[cfg(feature = "sim")]
            {
                let (sim, devices) = crate::rig::simulated::start(self)?;
                return Ok(OpenRig {
                    devices,
                    limits,
                    origin,
                    sync,
                    trigger,
                    sensor_id,
                    camera_settings,
                    text,
                    sim: Some(sim),
                });
            }
            #[cfg(not(feature = "sim"))]
            return Err(RigError::Config(crate::rig::simulated::refused(self)));
        }
        let mut description = Vec::new();
        let mut stage_operator = Some(stage_operator);
        let mut axis = |name: &str, limits| -> Result<_, RigError> {
            let spec = self.axis_spec(name, limits)?;
            let trace_name = format!("axis-{name}");
            let axis = open_axis(
                &spec,
                TraceTo::new(record_trace, &trace_name),
                stage_operator.take(),
            )?;
            description.push(spec.describe());
            Ok(axis)
        };
        let x = axis("x", &limits.x)?;
        let y = axis("y", &limits.y)?;
        let z = axis("z", &limits.z)?;
        let force_spec = self.force_spec()?;
        let force = open_force(&force_spec, record_trace)?;
        description.push(force_spec.describe());
        let camera_spec = self.camera_spec()?;
        let camera = open_camera(&camera_spec)?;
        description.push(camera_spec.describe());
        Ok(OpenRig {
            devices: Devices {
                x,
                y,
                z,
                force,
                camera,
                description,
            },
            limits,
            origin,
            sync,
            trigger,
            sensor_id,
            camera_settings,
            text,
            #[cfg(feature = "sim")]
            sim: None,
        })
    }
}

/// The rig's camera alone, opened: what a sensor on a robot has (`fringe stream`).
pub struct OpenCamera {
    pub camera: Box<dyn fringe_rig::Camera>,
    /// The rig file's camera settings, free-running: no DAQ triggers the camera here.
    pub settings: CameraSettings,
    /// Set when the rig file has the camera triggered: it free-runs at its frame rate instead.
    pub free_run_note: Option<String>,
    pub sensor_id: String,
    /// The camera as the rig file describes it (or the simulated bench's).
    pub description: String,
    /// The simulated bench, when simulated (it films the sensor; its motors are the simulated
    /// robot's), and its ground truth.
    #[cfg(feature = "sim")]
    pub sim: Option<SimBench>,
}

impl RigConfig {
    /// Opens the camera only (no stage, no force sensor): the simulated bench's camera when the
    /// rig is simulated, else the rig file's `[camera]`. A camera the rig file has triggered (by
    /// the DAQ or a line) free-runs at its frame rate: nothing triggers it without the bench.
    pub fn open_camera(&self) -> Result<OpenCamera, RigError> {
        let sensor_id = self.sensor_id()?;
        let mut settings = self.camera_settings()?;
        let free_run_note = match &settings.trigger {
            fringe_rig::TriggerMode::FreeRun => None,
            other => Some(format!(
                "the rig file has the camera triggered ({other:?}); without the bench it free-runs at {:.0} fps",
                settings.frame_rate.0
            )),
        };
        settings.trigger = fringe_rig::TriggerMode::FreeRun;
        if self.simulated {
            #[cfg(feature = "sim")]
            {
                let (sim, devices) = crate::rig::simulated::start(self)?;
                let description = format!("simulated camera filming sensor {sensor_id}");
                return Ok(OpenCamera {
                    camera: devices.camera,
                    settings,
                    free_run_note,
                    sensor_id,
                    description,
                    sim: Some(sim),
                });
            }
            #[cfg(not(feature = "sim"))]
            return Err(RigError::Config(crate::rig::simulated::refused(self)));
        }
        let spec = self.camera_spec()?;
        let camera = open_camera(&spec)?;
        Ok(OpenCamera {
            camera,
            settings,
            free_run_note,
            sensor_id,
            description: spec.describe(),
            #[cfg(feature = "sim")]
            sim: None,
        })
    }
}
