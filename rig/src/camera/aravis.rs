//! GenICam cameras (USB3 Vision, GigE Vision) through the Aravis library (cargo feature `aravis`).
//!
//! Feature names follow SFNC with fallbacks for older or simulated devices: `ExposureTime` or
//! `ExposureTimeAbs`, `AcquisitionFrameRate` or `AcquisitionFrameRateAbs`, `TimestampLatch` /
//! `TimestampLatchValue` (USB3) or `GevTimestampControlLatch` / `GevTimestampValue` (GigE). A
//! feature that a requested setting needs and the camera lacks fails with an error naming it.
//!
//! Device timestamps are nanoseconds: USB3 cameras count in ns, and Aravis converts GigE ticks
//! with `GevTimestampTickFrequency`; latched GigE ticks are converted the same way here, so
//! [`CameraInfo::tick_frequency`] is always 1e9.
//!
//! Threads: Aravis objects are not thread-safe (apart from stream buffer push/pop). An
//! [`AravisCamera`] owns its Aravis camera and stream and only touches them through `&mut self`,
//! so they are used by one thread at a time; it is `Send` (moving it to another thread is fine)
//! but deliberately not `Sync`.

use super::{
    format_name, Camera, CameraError, CameraInfo, CameraSettings, Frame, PixelFormat, Roi,
    TimestampLatch, TriggerMode,
};
use crate::clock::HostTime;
use ::aravis::prelude::*;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Buffers queued on the stream.
const BUFFER_POOL: usize = 8;

/// One camera found by Aravis.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AravisDevice {
    pub id: String,
    pub vendor: String,
    pub model: String,
    /// `USB3Vision`, `GigEVision` or `Fake`.
    pub protocol: String,
    pub address: String,
}

fn aravis() -> Option<&'static ::aravis::Aravis> {
    static ARAVIS: OnceLock<Option<::aravis::Aravis>> = OnceLock::new();
    ARAVIS
        .get_or_init(|| ::aravis::Aravis::initialize().ok())
        .as_ref()
}

/// Lists the cameras Aravis can see (USB3 Vision and GigE Vision).
pub fn list_cameras() -> Result<Vec<AravisDevice>, CameraError> {
    let a = aravis().ok_or_else(|| CameraError::Device {
        camera: "aravis".into(),
        message: "the Aravis library was initialised outside fringe; cannot list cameras".into(),
    })?;
    Ok(a.get_device_list()
        .into_iter()
        .map(|d| AravisDevice {
            id: d.id.to_string_lossy().into_owned(),
            vendor: d.vendor.to_string_lossy().into_owned(),
            model: d.model.to_string_lossy().into_owned(),
            protocol: d.protocol.to_string_lossy().into_owned(),
            address: d.address.to_string_lossy().into_owned(),
        })
        .collect())
}

/// A camera driven through Aravis.
pub struct AravisCamera {
    camera: ::aravis::Camera,
    stream: Option<::aravis::Stream>,
    info: CameraInfo,
    /// Ticks per second of the device clock used by the timestamp latch.
    latch_tick_frequency: u64,
    applied: Option<CameraSettings>,
    incomplete_buffers: u64,
    /// GigE Vision 1.x block ids are 16 bit and wrap from 65535 to 1: these extend them.
    gv_ids: Option<GvIdUnwrap>,
}

/// Extends wrapping 16-bit GigE Vision block ids (1..=65535) to a monotonic u64.
#[derive(Debug, Clone, Copy, Default)]
struct GvIdUnwrap {
    last_raw: Option<u64>,
    wraps: u64,
}

impl GvIdUnwrap {
    fn extend(&mut self, raw: u64) -> u64 {
        if raw > 0xFFFF {
            return raw; // extended (64-bit) ids: nothing to do
        }
        if let Some(last) = self.last_raw {
            if raw < last && last - raw > 0x8000 {
                self.wraps += 1;
            }
        }
        self.last_raw = Some(raw);
        self.wraps * 0xFFFF + raw
    }
}

fn to_aravis_format(f: PixelFormat) -> ::aravis::PixelFormat {
    match f {
        PixelFormat::Mono8 => ::aravis::PixelFormat::MONO_8,
        PixelFormat::Rgb8 => ::aravis::PixelFormat::RGB_8_PACKED,
        PixelFormat::BayerRg8 => ::aravis::PixelFormat::BAYER_RG_8,
    }
}

fn from_aravis_format(f: ::aravis::PixelFormat) -> Option<PixelFormat> {
    [PixelFormat::Mono8, PixelFormat::Rgb8, PixelFormat::BayerRg8]
        .into_iter()
        .find(|&p| to_aravis_format(p) == f)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 + 0.01 * b.abs()
}

impl AravisCamera {
    /// Opens the camera with Aravis id `id` (as listed by [`list_cameras`] or `fringe devices`,
    /// e.g. "Basler-acA1440-220uc-12345678") or, for GigE Vision, its IP address; the first camera
    /// found when `None`. Opening a GigE camera by address makes Aravis stream over the route to
    /// that address (needed for the loopback fake camera when other interfaces exist).
    pub fn open(id: Option<&str>) -> Result<AravisCamera, CameraError> {
        let _ = aravis();
        let name = id.unwrap_or("(first camera)").to_string();
        let camera = ::aravis::Camera::new(id).map_err(|e| CameraError::Open {
            camera: name.clone(),
            message: e.to_string(),
        })?;
        let text = |r: Result<::aravis::glib::GString, ::aravis::glib::Error>| {
            r.map(|s| s.to_string()).unwrap_or_default()
        };
        let mut info = CameraInfo {
            vendor: text(camera.vendor_name()),
            model: text(camera.model_name()),
            serial: text(camera.device_serial_number()),
            id: text(camera.device_id()),
            tick_frequency: 1_000_000_000,
        };
        // Name the camera by its Aravis id even when opened by address or as "first".
        let listed = list_cameras().unwrap_or_default();
        let found = match id {
            Some(id) => listed.iter().find(|d| d.id == id || d.address == id),
            None => listed.first(),
        };
        info.id = match (found, id) {
            (Some(d), _) => d.id.clone(),
            (None, Some(id)) => id.to_string(),
            (None, None) if !info.id.is_empty() => info.id.clone(),
            (None, None) => name,
        };
        let mut cam = AravisCamera {
            camera,
            stream: None,
            info,
            latch_tick_frequency: 1_000_000_000,
            applied: None,
            incomplete_buffers: 0,
            gv_ids: None,
        };
        if cam.camera.is_gv_device() {
            cam.gv_ids = Some(GvIdUnwrap::default());
        }
        if cam.available("GevTimestampTickFrequency") {
            let f = cam
                .camera
                .integer("GevTimestampTickFrequency")
                .map_err(|e| cam.feature_err("GevTimestampTickFrequency", "cannot be read", e))?;
            if f > 0 {
                cam.latch_tick_frequency = f as u64;
            }
        }
        Ok(cam)
    }

    /// The settings as read back from the camera after the last [`Camera::configure`].
    pub fn applied_settings(&self) -> Option<&CameraSettings> {
        self.applied.as_ref()
    }

    /// Buffers dropped because they arrived incomplete (missing packets, timeouts).
    pub fn incomplete_buffers(&self) -> u64 {
        self.incomplete_buffers
    }

    fn available(&self, feature: &str) -> bool {
        self.camera.is_feature_available(feature).unwrap_or(false)
    }

    fn first_available<'a>(&self, candidates: &[&'a str]) -> Option<&'a str> {
        candidates.iter().copied().find(|f| self.available(f))
    }

    fn feature_err(&self, feature: &str, what: &str, e: impl std::fmt::Display) -> CameraError {
        CameraError::Feature {
            camera: self.info.id.clone(),
            feature: feature.into(),
            message: format!("{what}: {e}"),
        }
    }

    fn missing(&self, feature: &str, needed_for: &str) -> CameraError {
        CameraError::Feature {
            camera: self.info.id.clone(),
            feature: feature.into(),
            message: format!("is not available on this camera (needed for {needed_for})"),
        }
    }

    fn require(
        &self,
        candidates: &[&'static str],
        needed_for: &str,
    ) -> Result<&'static str, CameraError> {
        self.first_available(candidates)
            .ok_or_else(|| self.missing(&candidates.join(" or "), needed_for))
    }

    fn set_enum(&self, feature: &str, value: &str) -> Result<(), CameraError> {
        self.camera
            .set_string(feature, value)
            .map_err(|e| self.feature_err(feature, &format!("cannot be set to {value}"), e))
    }

    fn set_enum_if_available(&self, feature: &str, value: &str) -> Result<(), CameraError> {
        if self.available(feature) {
            self.set_enum(feature, value)?;
        }
        Ok(())
    }

    fn set_float(&self, feature: &str, value: f64) -> Result<f64, CameraError> {
        self.camera
            .set_float(feature, value)
            .map_err(|e| self.feature_err(feature, &format!("cannot be set to {value}"), e))?;
        self.camera
            .float(feature)
            .map_err(|e| self.feature_err(feature, "cannot be read back", e))
    }

    fn check_close(&self, feature: &str, wanted: f64, got: f64) -> Result<(), CameraError> {
        if close(got, wanted) {
            Ok(())
        } else {
            Err(CameraError::Feature {
                camera: self.info.id.clone(),
                feature: feature.into(),
                message: format!(
                    "was set to {wanted} but reads back {got} (outside the camera's range?)"
                ),
            })
        }
    }

    fn configure_trigger(&self, trigger: &TriggerMode) -> Result<(), CameraError> {
        if self.available("TriggerSelector") {
            self.set_enum("TriggerSelector", "FrameStart")?;
        }
        match trigger {
            TriggerMode::FreeRun => {
                self.set_enum_if_available("TriggerMode", "Off")?;
            }
            TriggerMode::Software | TriggerMode::Hardware(_) => {
                let needed = "a triggered frame start";
                self.require(&["TriggerMode"], needed)?;
                self.require(&["TriggerSource"], needed)?;
                let source = match trigger {
                    TriggerMode::Hardware(line) => line.as_str(),
                    _ => {
                        self.require(&["TriggerSoftware"], "software triggering")?;
                        "Software"
                    }
                };
                self.set_enum("TriggerSource", source)?;
                if let TriggerMode::Hardware(_) = trigger {
                    self.set_enum_if_available("TriggerActivation", "RisingEdge")?;
                }
                self.set_enum("TriggerMode", "On")?;
            }
        }
        Ok(())
    }

    fn configure_exposure_active(&self, line: &str) -> Result<(), CameraError> {
        let needed = "the exposure-active output";
        for f in ["LineSelector", "LineMode", "LineSource"] {
            self.require(&[f], needed)?;
        }
        self.set_enum("LineSelector", line)?;
        self.set_enum("LineMode", "Output")?;
        self.set_enum("LineSource", "ExposureActive")
    }

    fn read_settings(&self, requested: &CameraSettings) -> Result<CameraSettings, CameraError> {
        let exposure_feature = self.require(&["ExposureTime", "ExposureTimeAbs"], "exposure")?;
        let exposure = self
            .camera
            .float(exposure_feature)
            .map_err(|e| self.feature_err(exposure_feature, "cannot be read", e))?;
        let gain = self
            .camera
            .gain()
            .map_err(|e| self.feature_err("Gain", "cannot be read", e))?;
        let rate_feature = self.require(
            &["AcquisitionFrameRate", "AcquisitionFrameRateAbs"],
            "the frame rate",
        )?;
        let frame_rate = self
            .camera
            .float(rate_feature)
            .map_err(|e| self.feature_err(rate_feature, "cannot be read", e))?;
        let (x, y, w, h) = self
            .camera
            .region()
            .map_err(|e| self.feature_err("Width/Height/OffsetX/OffsetY", "cannot be read", e))?;
        let format = self
            .camera
            .pixel_format()
            .map_err(|e| self.feature_err("PixelFormat", "cannot be read", e))?;
        let pixel_format = from_aravis_format(format).ok_or_else(|| CameraError::Feature {
            camera: self.info.id.clone(),
            feature: "PixelFormat".into(),
            message: format!(
                "reads back {format:?}, which fringe does not handle (Mono8, RGB8, BayerRG8)"
            ),
        })?;
        Ok(CameraSettings {
            exposure: crate::units::Microseconds(exposure),
            gain: crate::units::Decibels(gain),
            frame_rate: crate::units::Hertz(frame_rate),
            roi: Some(Roi {
                x: x.max(0) as u32,
                y: y.max(0) as u32,
                width: w.max(0) as u32,
                height: h.max(0) as u32,
            }),
            pixel_format,
            trigger: requested.trigger.clone(),
            exposure_active_line: requested.exposure_active_line.clone(),
        })
    }

    /// Sets the pixel format, then the region (the whole sensor when `s` gives none); the
    /// region set.
    fn set_format_and_region(&self, s: &CameraSettings) -> Result<Roi, CameraError> {
        self.camera
            .set_pixel_format(to_aravis_format(s.pixel_format))
            .map_err(|e| {
                // Say what the camera offers, so the rig file can name one of them.
                let offered = self
                    .camera
                    .dup_available_pixel_formats_as_strings()
                    .map(|names| {
                        let names: Vec<String> = names.iter().map(|n| n.to_string()).collect();
                        format!(
                            " (the camera offers {}; set [camera] pixel_format to mono8, rgb8 \
                             or bayerrg8 among them)",
                            names.join(", ")
                        )
                    })
                    .unwrap_or_default();
                self.feature_err(
                    "PixelFormat",
                    &format!("cannot be set to {}{offered}", format_name(s.pixel_format)),
                    e,
                )
            })?;
        let roi = match s.roi {
            Some(r) => r,
            None => {
                let (w, h) = self.camera.sensor_size().map_err(|e| {
                    self.feature_err("SensorWidth/SensorHeight", "cannot be read", e)
                })?;
                Roi {
                    x: 0,
                    y: 0,
                    width: w.max(0) as u32,
                    height: h.max(0) as u32,
                }
            }
        };
        self.camera
            .set_region(
                roi.x as i32,
                roi.y as i32,
                roi.width as i32,
                roi.height as i32,
            )
            .map_err(|e| {
                self.feature_err(
                    "Width/Height/OffsetX/OffsetY",
                    &format!(
                        "cannot be set to {}x{}+{}+{}",
                        roi.width, roi.height, roi.x, roi.y
                    ),
                    e,
                )
            })?;
        Ok(roi)
    }

    /// Turns automatic exposure and gain off and sets both, checking the exposure read back.
    fn set_exposure_and_gain(&self, s: &CameraSettings) -> Result<(), CameraError> {
        self.set_enum_if_available("ExposureAuto", "Off")?;
        let exposure_feature = self.require(&["ExposureTime", "ExposureTimeAbs"], "exposure")?;
        let got = self.set_float(exposure_feature, s.exposure.value())?;
        self.check_close(exposure_feature, s.exposure.value(), got)?;

        self.set_enum_if_available("GainAuto", "Off")?;
        self.camera.set_gain(s.gain.value()).map_err(|e| {
            self.feature_err(
                "Gain",
                &format!("cannot be set to {} dB", s.gain.value()),
                e,
            )
        })
    }

    /// Enables a fixed frame rate where the camera has the switch and sets it, checking the
    /// rate read back.
    fn set_frame_rate(&self, s: &CameraSettings) -> Result<(), CameraError> {
        if self.available("AcquisitionFrameRateEnable") {
            self.camera
                .set_boolean("AcquisitionFrameRateEnable", true)
                .map_err(|e| self.feature_err("AcquisitionFrameRateEnable", "cannot be set", e))?;
        }
        let rate_feature = self.require(
            &["AcquisitionFrameRate", "AcquisitionFrameRateAbs"],
            "the frame rate",
        )?;
        let got = self.set_float(rate_feature, s.frame_rate.value())?;
        self.check_close(rate_feature, s.frame_rate.value(), got)
    }

    /// Checks that the pixel format, region `roi` and gain read back as `s` set them.
    fn check_applied(
        &self,
        s: &CameraSettings,
        roi: Roi,
        applied: &CameraSettings,
    ) -> Result<(), CameraError> {
        if applied.pixel_format != s.pixel_format {
            return Err(self.feature_err(
                "PixelFormat",
                &format!("was set to {:?}", s.pixel_format),
                format!("reads back {:?}", applied.pixel_format),
            ));
        }
        if applied.roi != Some(roi) {
            return Err(self.feature_err(
                "Width/Height/OffsetX/OffsetY",
                &format!("were set to {roi:?}"),
                format!("read back {:?}", applied.roi),
            ));
        }
        if (applied.gain.value() - s.gain.value()).abs() > 0.1 {
            return Err(self.feature_err(
                "Gain",
                &format!("was set to {} dB", s.gain.value()),
                format!("reads back {} dB", applied.gain.value()),
            ));
        }
        Ok(())
    }

    fn pop_complete(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        let Some(stream) = &self.stream else {
            return Err(CameraError::Device {
                camera: self.info.id.clone(),
                message: "next_frame() before start()".into(),
            });
        };
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(buffer) = stream.timeout_pop_buffer(left.as_micros() as u64) else {
                return Ok(None);
            };
            let host_arrival = HostTime::now();
            if buffer.status() != ::aravis::BufferStatus::Success {
                self.incomplete_buffers += 1;
                stream.push_buffer(buffer);
                if Instant::now() >= deadline {
                    return Ok(None);
                }
                continue;
            }
            let width = buffer.image_width().max(0) as u32;
            let height = buffer.image_height().max(0) as u32;
            let raw_format = buffer.image_pixel_format();
            let Some(format) = from_aravis_format(raw_format) else {
                stream.push_buffer(buffer);
                return Err(CameraError::Device {
                    camera: self.info.id.clone(),
                    message: format!(
                        "delivered pixel format {raw_format:?}; configure Mono8, RGB8 or BayerRG8"
                    ),
                });
            };
            let mut data = buffer.image_data();
            let raw_id = buffer.frame_id();
            let id = match &mut self.gv_ids {
                Some(u) => u.extend(raw_id),
                None => raw_id,
            };
            let device_timestamp = buffer.timestamp();
            stream.push_buffer(buffer);
            let expected = width as usize * height as usize * format.bytes_per_pixel();
            if data.len() < expected {
                return Err(CameraError::Device {
                    camera: self.info.id.clone(),
                    message: format!(
                        "frame {id} has {} bytes, {width}x{height} {format:?} needs {expected}",
                        data.len()
                    ),
                });
            }
            data.truncate(expected);
            return Ok(Some(Frame {
                id,
                device_timestamp,
                host_arrival,
                width,
                height,
                format,
                data,
            }));
        }
    }
}

impl Camera for AravisCamera {
    fn info(&self) -> CameraInfo {
        self.info.clone()
    }

    fn configure(&mut self, s: &CameraSettings) -> Result<(), CameraError> {
        if self.stream.is_some() {
            return Err(CameraError::Device {
                camera: self.info.id.clone(),
                message: "configure() while acquiring; stop() first".into(),
            });
        }
        // Pixel format and region first: they bound the exposure and the frame rate.
        let roi = self.set_format_and_region(s)?;
        self.set_exposure_and_gain(s)?;
        self.set_frame_rate(s)?;
        self.configure_trigger(&s.trigger)?;
        if let Some(line) = &s.exposure_active_line {
            self.configure_exposure_active(line)?;
        }
        let applied = self.read_settings(s)?;
        self.check_applied(s, roi, &applied)?;
        self.applied = Some(applied);
        Ok(())
    }

    fn start(&mut self) -> Result<(), CameraError> {
        if self.stream.is_some() {
            return Ok(());
        }
        let stream = self
            .camera
            .create_stream()
            .map_err(|e| CameraError::Device {
                camera: self.info.id.clone(),
                message: format!("cannot create the stream: {e}"),
            })?;
        let payload = self
            .camera
            .payload()
            .map_err(|e| self.feature_err("PayloadSize", "cannot be read", e))?;
        for _ in 0..BUFFER_POOL {
            stream.push_buffer(::aravis::Buffer::new_allocate(payload as usize));
        }
        self.camera
            .set_acquisition_mode(::aravis::AcquisitionMode::Continuous)
            .map_err(|e| self.feature_err("AcquisitionMode", "cannot be set to Continuous", e))?;
        self.camera
            .start_acquisition()
            .map_err(|e| self.feature_err("AcquisitionStart", "failed", e))?;
        self.stream = Some(stream);
        Ok(())
    }

    fn trigger(&mut self) -> Result<(), CameraError> {
        self.camera.software_trigger().map_err(|e| {
            self.feature_err(
                "TriggerSoftware",
                "failed (is the trigger mode Software?)",
                e,
            )
        })
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        self.pop_complete(timeout)
    }

    fn stop(&mut self) -> Result<(), CameraError> {
        if self.stream.take().is_some() {
            self.camera
                .stop_acquisition()
                .map_err(|e| self.feature_err("AcquisitionStop", "failed", e))?;
        }
        Ok(())
    }

    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError> {
        let (latch, value) = if self.available("TimestampLatch")
            && self.available("TimestampLatchValue")
        {
            ("TimestampLatch", "TimestampLatchValue")
        } else if self.available("GevTimestampControlLatch") && self.available("GevTimestampValue")
        {
            ("GevTimestampControlLatch", "GevTimestampValue")
        } else {
            return Err(self.missing(
                "TimestampLatch (or GevTimestampControlLatch)",
                "the timestamp latch",
            ));
        };
        let host_before = HostTime::now();
        self.camera
            .execute_command(latch)
            .map_err(|e| self.feature_err(latch, "failed", e))?;
        let host_after = HostTime::now();
        let ticks = self
            .camera
            .integer(value)
            .map_err(|e| self.feature_err(value, "cannot be read", e))?;
        let ticks = ticks.max(0) as u128;
        let ns = ticks * 1_000_000_000 / self.latch_tick_frequency.max(1) as u128;
        Ok(TimestampLatch {
            host_before,
            device_ticks: ns as u64,
            host_after,
        })
    }
}

impl Drop for AravisCamera {
    fn drop(&mut self) {
        if self.stream.take().is_some() {
            let _ = self.camera.stop_acquisition();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::GvIdUnwrap;

    #[test]
    fn gige_block_ids_are_extended_across_the_wrap() {
        let mut u = GvIdUnwrap::default();
        let ids: Vec<u64> = [65533, 65535, 1, 3]
            .into_iter()
            .map(|r| u.extend(r))
            .collect();
        assert_eq!(ids, vec![65533, 65535, 65536, 65538]);
        // A gap across the wrap stays visible: 65535 -> 1 is consecutive, 65534 -> 2 misses two.
        let mut u = GvIdUnwrap::default();
        assert_eq!(u.extend(65534), 65534);
        assert_eq!(u.extend(2), 65537);
    }
}
