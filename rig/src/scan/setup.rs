//! What a scan is given besides the devices: the program, the bench, the run's documents, the
//! camera, synchronisation, press and watcher settings, and what the caller adds to the run.

use crate::acquire::record_tap::RecordTap;
use crate::camera::{CameraSettings, Cutout};
use crate::force::FtAxes;
use crate::scan::offset_check::OffsetCheck;
use crate::scan::origin::ContactOrigin;
use crate::scan::plan::{BenchLimits, ScanProgram};
use crate::scan::press::PressSettings;
use crate::scan::sidecar::RunSidecar;
use crate::scan::watchers::WatchSettings;
use crate::store::documents::ProfileRef;
use crate::store::frames::FrameCodec;
use crate::sync::method::SyncMethod;
use crate::sync::trigger::TriggerTiming;
use crate::units::Millimetres;
use std::sync::Arc;

/// Everything a scan needs besides the devices.
#[derive(Debug, Clone)]
pub struct ScanSetup {
    pub program: ScanProgram,
    /// The plan file's text, stored in the run (and compared on resume).
    pub plan_text: String,
    pub limits: BenchLimits,
    pub origin: ContactOrigin,
    /// The radius of the sensor's disc around `origin`, when known (a calibration profile, the
    /// simulated sensor's design): a plan that slides must stay on it.
    pub disc_radius: Option<Millimetres>,
    pub sync: SyncMethod,
    /// How the F/T's axes sit on the bench, for shear labels in the sensor's frame; `None`
    /// when the rig does not say (frames then carry no shear).
    pub ft_axes: Option<FtAxes>,
    /// The DAQ-triggered camera's timing, for `trigger`.
    pub trigger: Option<TriggerTiming>,
    pub sensor_id: String,
    /// The sensor's design (`layered`, `integrated`), when the rig names or simulates it.
    pub variant: Option<String>,
    /// The rig configuration as used, for the start document.
    pub rig_text: String,
    pub seed: Option<u64>,
    pub profile: Option<ProfileRef>,
    pub camera: CameraSettings,
    /// The part of each frame a new run stores (the square around the disc); `None`: whole
    /// frames. A resumed run stores what it stored before.
    pub cutout: Option<Cutout>,
    /// The codec a new run stores frames in (`None`: the default for the camera's pixel
    /// format). A resumed run stores as it stored before.
    pub codec: Option<FrameCodec>,
    /// Press tuning; the contact threshold, ceiling and approach limit are set from the plan and
    /// the bench.
    pub press: PressSettings,
    pub watch: WatchSettings,
    /// Files the caller adds to the run when it closes (the simulated bench's ground truth).
    pub sidecars: Vec<Arc<dyn RunSidecar>>,
    /// The zero-load check of the sensor's profile, made on the first offset measurement of
    /// each session (new run or resume).
    pub offset_check: Option<Arc<dyn OffsetCheck>>,
    /// What the caller sees of the recording as it happens (live display, live validation).
    pub taps: Vec<Arc<dyn RecordTap>>,
}

impl ScanSetup {
    /// Refuses a plan whose slides would take the indenter off the sensor's disc (either end of
    /// a slide's line farther from the centre than the disc's radius), or that slides where the
    /// disc is not known.
    pub fn check_slides_on_disc(&self) -> Result<(), String> {
        let mut slides = self
            .program
            .points
            .iter()
            .filter_map(|p| Some((p, p.slide?)));
        let Some(radius) = self.disc_radius else {
            return match slides.next() {
                Some(_) => Err(format!(
                    "the plan slides, but the disc of sensor {} is not known here (no calibration profile): calibrate it first (`fringe calibrate --sensor {}`), so that no slide can leave the disc",
                    self.sensor_id, self.sensor_id
                )),
                None => Ok(()),
            };
        };
        for (p, s) in slides {
            let start = self.origin.contact_mm(p.x, p.y);
            let (ex, ey) = s.end_from(p.x, p.y);
            let end = self.origin.contact_mm(ex, ey);
            for (which, c) in [("starts", start), ("ends", end)] {
                let r = c[0].hypot(c[1]);
                if r > radius.0 {
                    return Err(format!(
                        "the plan: the slide of point {} (stage x {:.3}, y {:.3} mm; {:.3} mm at {} degrees) {which} at contact [{:.3}, {:.3}] mm, {r:.3} mm from the sensor centre, off the disc (radius {:.3} mm, {}): shorten slide.distance or move the point",
                        p.index + 1,
                        p.x.0,
                        p.y.0,
                        s.distance.0,
                        s.direction_deg,
                        c[0],
                        c[1],
                        radius.0,
                        self.origin.source
                    ));
                }
            }
        }
        Ok(())
    }
}
