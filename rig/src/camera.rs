//! The camera abstraction shared by the Aravis backend, recorded camera traces and the
//! simulated camera.

#[cfg(feature = "aravis")]
pub(crate) mod aravis;
pub(crate) mod trace;
pub(crate) mod writer;

use crate::clock::HostTime;
use crate::units::{Decibels, Hertz, Microseconds};
use std::time::Duration;

/// Pixel layout of a frame buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PixelFormat {
    /// 8-bit grey.
    Mono8,
    /// 8-bit RGB, interleaved.
    Rgb8,
    /// 8-bit Bayer RG mosaic (as delivered by colour Basler cameras).
    BayerRg8,
}

impl PixelFormat {
    /// Bytes per pixel.
    pub fn bytes_per_pixel(self) -> usize {
        match self {
            PixelFormat::Mono8 | PixelFormat::BayerRg8 => 1,
            PixelFormat::Rgb8 => 3,
        }
    }
}

/// Name used in CSV files and camera traces for a pixel format.
pub fn format_name(format: PixelFormat) -> &'static str {
    match format {
        PixelFormat::Mono8 => "mono8",
        PixelFormat::Rgb8 => "rgb8",
        PixelFormat::BayerRg8 => "bayerrg8",
    }
}

/// Parses a name written by [`format_name`].
pub fn parse_format_name(name: &str) -> Option<PixelFormat> {
    match name {
        "mono8" => Some(PixelFormat::Mono8),
        "rgb8" => Some(PixelFormat::Rgb8),
        "bayerrg8" => Some(PixelFormat::BayerRg8),
        _ => None,
    }
}

/// How frames are started.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case", tag = "mode", content = "line")]
pub enum TriggerMode {
    /// The camera runs at its frame rate.
    FreeRun,
    /// Each frame is started by [`Camera::trigger`].
    Software,
    /// Each frame is started by a rising edge on a hardware line ("Line1").
    Hardware(String),
}

/// A region of interest in sensor pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Roi {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

/// A part of the camera's frames kept on its own: `roi` cut out of `frame_width` x
/// `frame_height` frames (a run that stores only the square around the disc). Coordinates in the
/// part plus (`roi.x`, `roi.y`) are coordinates in the full frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Cutout {
    pub roi: Roi,
    pub frame_width: u32,
    pub frame_height: u32,
}

/// Everything set on a camera before acquisition.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CameraSettings {
    pub exposure: Microseconds,
    pub gain: Decibels,
    pub frame_rate: Hertz,
    /// `None` = full sensor.
    pub roi: Option<Roi>,
    pub pixel_format: PixelFormat,
    pub trigger: TriggerMode,
    /// Output line that carries the exposure-active signal ("Line2"), if wired to the DAQ.
    pub exposure_active_line: Option<String>,
}

/// Settings that no camera accepts, found before anything is opened or moved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `camera.{key}` = {value}: {allowed}")]
pub struct InvalidCameraSetting {
    pub key: &'static str,
    pub value: f64,
    pub allowed: String,
}

/// The highest frame rate any camera of the bench is asked for, Hz.
pub(crate) const MAX_FRAME_RATE: Hertz = Hertz(1000.0);
/// The gain range accepted before the camera is asked, dB.
pub(crate) const GAIN_RANGE: std::ops::RangeInclusive<f64> = 0.0..=48.0;

impl CameraSettings {
    /// Checks the numbers before any device is touched: a positive frame rate up to
    /// [`MAX_FRAME_RATE`], a positive exposure that fits in one frame period (free run), a gain in
    /// [`GAIN_RANGE`]. The camera itself may still refuse values outside its own range.
    pub fn check(&self) -> Result<(), InvalidCameraSetting> {
        let rate = self.frame_rate.0;
        if !(rate.is_finite() && rate > 0.0 && rate <= MAX_FRAME_RATE.0) {
            return Err(InvalidCameraSetting {
                key: "frame_rate",
                value: rate,
                allowed: format!("must be above 0 and at most {} Hz", MAX_FRAME_RATE.0),
            });
        }
        let exposure = self.exposure.0;
        let period_us = 1e6 / rate;
        if !(exposure.is_finite() && exposure > 0.0) {
            return Err(InvalidCameraSetting {
                key: "exposure_us",
                value: exposure,
                allowed: "must be a positive number of microseconds".into(),
            });
        }
        if self.trigger == TriggerMode::FreeRun && exposure >= period_us {
            return Err(InvalidCameraSetting {
                key: "exposure_us",
                value: exposure,
                allowed: format!(
                    "must be shorter than the frame period at {rate} Hz ({period_us:.0} us): lower the exposure or the frame rate"
                ),
            });
        }
        let gain = self.gain.0;
        if !(gain.is_finite() && GAIN_RANGE.contains(&gain)) {
            return Err(InvalidCameraSetting {
                key: "gain_db",
                value: gain,
                allowed: format!(
                    "must be from {} to {} dB",
                    GAIN_RANGE.start(),
                    GAIN_RANGE.end()
                ),
            });
        }
        Ok(())
    }
}

impl Default for CameraSettings {
    /// The reference rig: free run at 50 fps, 2000 us exposure, gain 0, full frame in the
    /// colour camera's native BayerRG8 (one byte per pixel: the daA1920-160uc reaches its full
    /// rate over USB3 only in 8-bit Bayer; RGB8 is interpolated in the camera from the mosaic).
    fn default() -> Self {
        CameraSettings {
            exposure: Microseconds(2000.0),
            gain: Decibels(0.0),
            frame_rate: Hertz(50.0),
            roi: None,
            pixel_format: PixelFormat::BayerRg8,
            trigger: TriggerMode::FreeRun,
            exposure_active_line: None,
        }
    }
}

/// One frame with its timing.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The camera's frame id (gaps mean dropped frames).
    pub id: u64,
    /// Device timestamp in device ticks (ns on Basler ace USB).
    pub device_timestamp: u64,
    /// Host monotonic time at which the frame arrived.
    pub host_arrival: HostTime,
    pub width: u32,
    pub height: u32,
    pub format: PixelFormat,
    pub data: Vec<u8>,
}

/// A `width` x `height` frame of `format` with varied bytes, for the crate's unit tests.
#[cfg(test)]
pub(crate) fn test_frame(format: PixelFormat, width: u32, height: u32) -> Frame {
    Frame {
        id: 7,
        device_timestamp: 123,
        host_arrival: HostTime(9),
        width,
        height,
        format,
        data: (0..(width * height) as usize * format.bytes_per_pixel())
            .map(|i| (i * 37 % 251) as u8)
            .collect(),
    }
}

/// One timestamp-latch exchange: the device clock read between two host times.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimestampLatch {
    pub host_before: HostTime,
    pub device_ticks: u64,
    pub host_after: HostTime,
}

/// Identification of a camera.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CameraInfo {
    pub vendor: String,
    pub model: String,
    pub serial: String,
    pub id: String,
    /// Device timestamp ticks per second.
    pub tick_frequency: u64,
}

/// Errors from a camera, naming the device.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    #[error("camera {camera}: {message}")]
    Device { camera: String, message: String },
    /// The camera was not found or would not open.
    #[error("camera {camera}: cannot open: {message}")]
    Open { camera: String, message: String },
    #[error("camera {camera}: feature {feature} {message}")]
    Feature {
        camera: String,
        feature: String,
        message: String,
    },
    #[error("camera {camera}: no frame for {waited:?} (check the trigger mode, the cable and the frame rate)")]
    NoFrame { camera: String, waited: Duration },
    #[error("camera {camera}: {source}")]
    Io {
        camera: String,
        #[source]
        source: std::io::Error,
    },
}

/// A camera that delivers timestamped frames.
pub trait Camera: Send {
    /// Identification.
    fn info(&self) -> CameraInfo;

    /// Applies settings (exposure, gain, rate, ROI, format, trigger, strobe output) and reads them
    /// back; fails if the camera refuses one.
    fn configure(&mut self, settings: &CameraSettings) -> Result<(), CameraError>;

    /// Starts acquisition.
    fn start(&mut self) -> Result<(), CameraError>;

    /// Issues a software trigger (only in [`TriggerMode::Software`]).
    fn trigger(&mut self) -> Result<(), CameraError>;

    /// Returns the next frame, or `None` if none arrived within `timeout`.
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError>;

    /// Stops acquisition.
    fn stop(&mut self) -> Result<(), CameraError>;

    /// Latches the device clock and reads it, bracketed by host times.
    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError>;
}
