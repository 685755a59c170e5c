//! The simulated camera: a Basler-like USB3 camera behind the [`Camera`] trait.
//!
//! - **Device clock**: 1 GHz ticks (1 tick = 1 ns, as on ace USB), with its own offset and drift:
//!   ticks = ticks_at_ref + (t_host - ref)(1 + drift_ppm 1e-6), ref = host time 0 (the process
//!   epoch). [`DeviceClock`].
//! - **Free run**: exposure k starts at device time t0 + k / frame_rate (exactly 20 000 000 ticks
//!   apart at 50 Hz) and lasts the exposure time in device ticks. **Software trigger**: exposure
//!   starts `trigger_latency_us` after [`Camera::trigger`]; triggers faster than
//!   `max_frame_rate_hz` are ignored (counted). **Hardware trigger** (`Line1`, wired with
//!   [`SimCamera::with_trigger_input`]): exposure starts `trigger_latency_us` plus
//!   `line_response_us` after each rising edge (Basler's total start delay: the exposure start
//!   delay plus the input line's response time).
//! - Every exposure gets the next frame id (from 0 at each start) and is written to the shared
//!   [`ExposureSchedule`] before it starts (free run: two periods ahead), which the DAQ emulator
//!   samples as the ExposureActive strobe.
//! - After the exposure ends, the frame is dropped with `drop_probability` (its id is skipped) or
//!   handed to the render thread, which renders [`SceneSource::scene_at`] the middle of the
//!   exposure in the configured pixel format ([`FrameRenderer::render_as`]; a full frame at 0 dB
//!   is delivered as rendered, without a copy). Up to [`FRAME_MEMORY`] exposures wait for the
//!   renderer (the camera's frame memory: a moment when the host takes the cores delays those
//!   frames a little instead of losing them); an exposure ending while the memory is full is
//!   dropped (counted as `render_busy`), so a renderer that is too slow drops frames instead of
//!   delaying the schedule without bound.
//! - A delivery thread hands the frame to the host at exposure end + `readout_ms` + a uniform
//!   jitter in [0, `arrival_jitter_ms`] (or when rendering finishes, if later). Frames the host
//!   does not fetch fill `host_buffers`; further frames are dropped (`no_buffer`).
//! - `device_timestamp` is the device clock at exposure start (Basler's chunk timestamp).
//! - [`Camera::latch_timestamp`] takes about `latch_round_trip_us` and latches the device clock at
//!   a random instant inside the host bracket.
//! - [`timing`]: the device clock and the exposure schedule the DAQ emulator reads.
//! - [`camera`]: [`SimCamera`], the camera on threads (timing, render, delivery) behind the
//!   [`Camera`] trait.
//! - `frame`: a rendered sensor image turned into the delivered frame (ROI, gain, pixel format).
//!
//! [`Camera`]: fringe_rig::Camera
//! [`Camera::trigger`]: fringe_rig::Camera::trigger
//! [`Camera::latch_timestamp`]: fringe_rig::Camera::latch_timestamp
//! [`SceneSource::scene_at`]: crate::scene::SceneSource::scene_at
//! [`FrameRenderer::render_as`]: crate::scene::FrameRenderer::render_as

pub(crate) mod camera;
mod frame;
pub(crate) mod timing;

pub use self::camera::{SimCamera, SimCameraConfig, FRAME_MEMORY};
pub use self::timing::ExposureSchedule;
pub(crate) use self::timing::{ExposureWindow, TriggerInput};
