//! The one preprocessing: a sensor frame becomes a network input tensor. Used by dataset export,
//! training, evaluation and live inference alike.
//!
//! Steps, driven by the sensor's calibration profile: a square crop of side 2 x crop radius about
//! the profile's optical centre (not the image centre: the reference code's shift did nothing),
//! a circular mask at the crop radius (black outside), an antialiased resize to the network
//! input (224 x 224 by default), grey (ITU-R 601 luma, as PIL's "L", repeated to 3 channels) or
//! RGB, and normalisation with mean 0.5 and std 0.5. Optionally the frame is first turned about
//! the optical centre (augmentation), and [`rotate_contact`] turns its contact label the same way.
//!
//! **Reference mode** reproduces the reference pipeline's tensors for models it trained: the
//! circle about the image centre with its crop diameter (980 px for the layered sensor, 1100 px
//! for the integrated one), PIL's bilinear resize rounded to 8 bits after each pass, then
//! grey, ToTensor and Normalize. Against torchvision's own tensors (`tests/preprocess_torchvision.rs`,
//! 1920x1200 fringe frames, both crop diameters, grey and RGB) at most one 8-bit level differs
//! (0.0078 after normalisation), on 0.02-0.07 % of the values: PIL's fixed-point weights round a
//! few pixels the other way.

mod resample;
mod source;

pub use source::FrameRef;

use fringe_calibration::Profile;
use fringe_rig::store::read_plain;
use fringe_rig::PixelFormat;
use resample::{resample, Scratch, Window};
use source::{pixels, Channels, Dense, Pixels, Rotated};
use std::path::Path;

/// The network input's default side, pixels.
pub(crate) const DEFAULT_INPUT_SIZE: u32 = 224;

/// The network input sides the preprocessing makes, pixels.
pub(crate) const INPUT_SIZES: std::ops::RangeInclusive<u32> = 8..=1024;

/// The largest crop radius, full-frame px: a crop 20 000 px across, twice the side of a 65 MP
/// camera's frame. The resampling's buffers grow with the crop (a window of 1e300 mm once asked
/// for more memory than there is, and the live validation's thread panicked); at this radius
/// they stay within about 120 MB at the largest input.
pub(crate) const MAX_CROP_RADIUS_PX: f64 = 10_000.0;

/// Colour of the network input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Colour {
    /// ITU-R 601 luma repeated to 3 channels (the paper's best models).
    Grey,
    Rgb,
}

impl Colour {
    pub fn name(self) -> &'static str {
        match self {
            Colour::Grey => "grey",
            Colour::Rgb => "rgb",
        }
    }
}

/// Where the crop circle sits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Centre {
    /// At the image centre (the reference pipeline).
    Image,
    /// At a calibrated optical centre, px (pixel centres at i + 0.5).
    At([f64; 2]),
}

/// The reference pipeline's sensors and their crop diameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceSensor {
    /// Sensor 1, layered: 980 px.
    Layered,
    /// Sensor 2, integrated: 1100 px.
    Integrated,
}

impl ReferenceSensor {
    pub fn crop_diameter_px(self) -> f64 {
        match self {
            ReferenceSensor::Layered => 980.0,
            ReferenceSensor::Integrated => 1100.0,
        }
    }
}

/// Why a frame could not be preprocessed.
#[derive(Debug, thiserror::Error)]
pub enum PreprocessError {
    #[error(
        "the frame is {got_w}x{got_h} px but the profile of sensor {sensor} was made on \
         {want_w}x{want_h} px frames: use that sensor's camera settings or recalibrate"
    )]
    FrameSize {
        sensor: String,
        got_w: u32,
        got_h: u32,
        want_w: u32,
        want_h: u32,
    },
    #[error("the frame holds {got} bytes but {w}x{h} {format:?} needs {want}")]
    Bytes {
        got: usize,
        want: usize,
        w: u32,
        h: u32,
        format: PixelFormat,
    },
    #[error(
        "the crop radius {0} px is not a number from 1 to {max} px: recalibrate the sensor",
        max = MAX_CROP_RADIUS_PX
    )]
    Radius(f64),
    #[error("the optical centre ({0}, {1}) px is not a number: recalibrate the sensor")]
    Centre(f64, f64),
    #[error("input size {0} px is outside 8..=1024 px")]
    InputSize(u32),
    #[error("{0}")]
    File(String),
}

/// The preprocessing of one sensor and one network input.
#[derive(Debug, Clone, PartialEq)]
pub struct Preprocessing {
    pub centre: Centre,
    /// Crop radius (half the crop side and the mask radius), full-frame px.
    pub crop_radius_px: f64,
    /// The frame size the geometry belongs to, when known (a profile's).
    pub frame_size: Option<(u32, u32)>,
    /// The sensor the geometry belongs to, for messages.
    pub sensor: String,
    pub input_size: u32,
    pub colour: Colour,
    /// Round to 8 bits as PIL does (reference mode).
    pub reference: bool,
}

impl Preprocessing {
    /// From a sensor's calibration profile: its optical centre, crop radius and frame size.
    pub fn from_profile(
        profile: &Profile,
        colour: Colour,
        input_size: u32,
    ) -> Result<Preprocessing, PreprocessError> {
        let p = Preprocessing {
            centre: Centre::At([profile.optical.centre_x_px, profile.optical.centre_y_px]),
            crop_radius_px: profile.optical.crop_radius_px,
            frame_size: Some((profile.image.width, profile.image.height)),
            sensor: profile.sensor_id.clone(),
            input_size,
            colour,
            reference: false,
        };
        p.check()?;
        Ok(p)
    }

    /// The reference pipeline's preprocessing for `sensor`.
    pub fn reference(
        sensor: ReferenceSensor,
        colour: Colour,
        input_size: u32,
    ) -> Result<Preprocessing, PreprocessError> {
        let p = Preprocessing {
            centre: Centre::Image,
            crop_radius_px: sensor.crop_diameter_px() / 2.0,
            frame_size: None,
            sensor: format!("{sensor:?} (reference)").to_lowercase(),
            input_size,
            colour,
            reference: true,
        };
        p.check()?;
        Ok(p)
    }

    pub(crate) fn check(&self) -> Result<(), PreprocessError> {
        if !(1.0..=MAX_CROP_RADIUS_PX).contains(&self.crop_radius_px) {
            return Err(PreprocessError::Radius(self.crop_radius_px));
        }
        if let Centre::At([x, y]) = self.centre {
            if !(x.is_finite() && y.is_finite()) {
                return Err(PreprocessError::Centre(x, y));
            }
        }
        if !INPUT_SIZES.contains(&self.input_size) {
            return Err(PreprocessError::InputSize(self.input_size));
        }
        Ok(())
    }

    /// Values in one tensor: 3 x input x input.
    pub fn tensor_len(&self) -> usize {
        3 * (self.input_size as usize).pow(2)
    }

    /// One frame as a CHW tensor.
    pub fn run(&self, frame: FrameRef) -> Result<Vec<f32>, PreprocessError> {
        let mut out = vec![0.0; self.tensor_len()];
        Preprocessor::new(self.clone()).run_into(frame, 0.0, &mut out)?;
        Ok(out)
    }

    /// An image file (PNG, TIFF, ...) as a CHW tensor; grey files are read as Mono8.
    /// When a `width` x `height` frame covers less than half the crop across (a thumbnail, a
    /// 1x1 image through the reference geometry), what that means: most of the model's input
    /// is black padding, and its prediction means nothing.
    pub fn coverage_warning(&self, width: u32, height: u32) -> Option<String> {
        let across = 2.0 * self.crop_radius_px;
        let side = f64::from(width.min(height));
        (side < 0.5 * across).then(|| {
            format!(
                "the frame is {width}x{height} px but the crop of sensor {} is {across:.0} px \
                 across: most of the model's input lies outside the frame (black), so the \
                 prediction means nothing",
                self.sensor
            )
        })
    }

    pub fn run_file(&self, path: &Path) -> Result<Vec<f32>, PreprocessError> {
        let f = read_plain(path).map_err(|e| PreprocessError::File(e.to_string()))?;
        self.run(FrameRef {
            width: f.width,
            height: f.height,
            format: f.format,
            data: &f.data,
            cutout: None,
        })
    }
}

/// A [`Preprocessing`] with its buffers, for many frames (one per thread).
#[derive(Debug)]
pub struct Preprocessor {
    pub config: Preprocessing,
    scratch: Scratch,
    resized: Vec<f32>,
}

impl Preprocessor {
    pub fn new(config: Preprocessing) -> Preprocessor {
        Preprocessor {
            config,
            scratch: Scratch::default(),
            resized: Vec::new(),
        }
    }

    /// Preprocesses `frame`, turned by `rotation_deg` (counter-clockwise on screen) about the
    /// crop centre, into `out` (CHW, `tensor_len()` values).
    pub fn run_into(
        &mut self,
        frame: FrameRef,
        rotation_deg: f64,
        out: &mut [f32],
    ) -> Result<(), PreprocessError> {
        let cfg = &self.config;
        cfg.check()?;
        check_bytes(frame)?;
        cfg.check_frame_size(frame)?;
        let n = cfg.input_size as usize;
        assert_eq!(out.len(), 3 * n * n, "output buffer of the wrong size");
        // Reference mode filters RGB and converts after the resize, rounding as PIL does; the
        // float path converts first (the same linear map, a third of the work).
        let channels = match (cfg.colour, cfg.reference) {
            (Colour::Grey, false) => Channels::Luma,
            _ => Channels::Rgb,
        };
        let (src, window) = cfg.crop(frame, channels, rotation_deg);
        let c = channels.count();
        self.resized.resize(n * n * c, 0.0);
        resample(src.as_ref(), window, &mut self.scratch, &mut self.resized);
        normalise_into_planes(&self.resized, c, cfg.colour, out);
        Ok(())
    }
}

impl Preprocessing {
    /// Refuses a frame of another size than the profile's camera gives, if the profile says.
    fn check_frame_size(&self, frame: FrameRef) -> Result<(), PreprocessError> {
        if let Some((w, h)) = self.frame_size {
            let (got_w, got_h) = frame.frame_size();
            if (w, h) != (got_w, got_h) {
                return Err(PreprocessError::FrameSize {
                    sensor: self.sensor.clone(),
                    got_w,
                    got_h,
                    want_w: w,
                    want_h: h,
                });
            }
        }
        Ok(())
    }

    /// What the network input is resampled from: `frame` read in `channels` (as superpixels
    /// when the output is at least 2x smaller than the crop), turned by `rotation_deg` about
    /// the crop centre, and the masked crop window in its coordinates.
    fn crop<'a>(
        &self,
        frame: FrameRef<'a>,
        channels: Channels,
        rotation_deg: f64,
    ) -> (Box<dyn Pixels + 'a>, Window) {
        let n = self.input_size as usize;
        let (frame_w, frame_h) = frame.frame_size();
        let in_frame = match self.centre {
            Centre::Image => [f64::from(frame_w) / 2.0, f64::from(frame_h) / 2.0],
            Centre::At(c) => c,
        };
        // The centre in this image's pixels (a stored cutout starts inside the frame).
        let origin = frame.origin();
        let full_centre = [in_frame[0] - origin[0], in_frame[1] - origin[1]];
        // Superpixels when the output is at least 2x smaller than the crop.
        let half = 2.0 * self.crop_radius_px >= 2.0 * n as f64 && !self.reference;
        let base = pixels(frame, channels, half);
        let s = base.scale();
        let centre = [full_centre[0] * s, full_centre[1] * s];
        // A turned crop reads within its masked circle only (the window below masks it).
        let src: Box<dyn Pixels> = if rotation_deg != 0.0 {
            Box::new(Rotated {
                base: Dense::around(base.as_ref(), centre, self.crop_radius_px * s),
                centre,
                angle: rotation_deg.to_radians(),
            })
        } else {
            base
        };
        let window = Window {
            centre,
            radius: self.crop_radius_px * s,
            out: n,
            quantise: self.reference,
            mask: true,
        };
        (src, window)
    }
}

/// Refuses a frame whose bytes are not its width x height pixels of its format.
fn check_bytes(frame: FrameRef) -> Result<(), PreprocessError> {
    let want = frame.width as usize * frame.height as usize * frame.format.bytes_per_pixel();
    if frame.data.len() != want {
        return Err(PreprocessError::Bytes {
            got: frame.data.len(),
            want,
            w: frame.width,
            h: frame.height,
            format: frame.format,
        });
    }
    Ok(())
}

/// The resampled crop (`c` channels per pixel, 8-bit levels) normalised into the three CHW
/// planes of `out`, grey repeated in each (converted from RGB as PIL's "L" in `Grey` colour).
fn normalise_into_planes(resized: &[f32], c: usize, colour: Colour, out: &mut [f32]) {
    let plane = out.len() / 3;
    let (r, rest) = out.split_at_mut(plane);
    let (g, b) = rest.split_at_mut(plane);
    let norm = |v: f32| (v / 255.0 - 0.5) / 0.5;
    match (c, colour) {
        (1, _) => {
            for (i, &v) in resized.iter().enumerate() {
                let x = norm(v);
                (r[i], g[i], b[i]) = (x, x, x);
            }
        }
        (_, Colour::Rgb) => {
            for (i, p) in resized.chunks_exact(3).enumerate() {
                (r[i], g[i], b[i]) = (norm(p[0]), norm(p[1]), norm(p[2]));
            }
        }
        (_, Colour::Grey) => {
            // PIL's "L": (R 19595 + G 38470 + B 7471 + 2^15) >> 16 on the 8-bit values.
            for (i, p) in resized.chunks_exact(3).enumerate() {
                let l =
                    (p[0] as u32 * 19595 + p[1] as u32 * 38470 + p[2] as u32 * 7471 + 0x8000) >> 16;
                let x = norm(l as f32);
                (r[i], g[i], b[i]) = (x, x, x);
            }
        }
    }
}

/// A whole frame as a small RGB picture for displays: the square about the frame's centre that
/// holds all of it (letterboxed in black), resampled as the network input is, without the mask.
pub fn thumbnail(frame: FrameRef, side: u32) -> Result<image::RgbImage, PreprocessError> {
    check_bytes(frame)?;
    if !INPUT_SIZES.contains(&side) {
        return Err(PreprocessError::InputSize(side));
    }
    let n = side as usize;
    let radius = f64::from(frame.width.max(frame.height)) / 2.0;
    let base = pixels(frame, Channels::Rgb, radius >= n as f64);
    let s = base.scale();
    let window = Window {
        centre: [
            f64::from(frame.width) / 2.0 * s,
            f64::from(frame.height) / 2.0 * s,
        ],
        radius: radius * s,
        out: n,
        quantise: false,
        mask: false,
    };
    let mut rgb = vec![0f32; n * n * 3];
    resample(base.as_ref(), window, &mut Scratch::default(), &mut rgb);
    let bytes = rgb
        .iter()
        .map(|v| v.round().clamp(0.0, 255.0) as u8)
        .collect();
    Ok(image::RgbImage::from_raw(side, side, bytes).expect("side x side x 3 bytes"))
}

/// A network input tensor (CHW, normalised) as the picture it holds.
pub fn tensor_image(tensor: &[f32], size: u32) -> Option<image::RgbImage> {
    let plane = (size as usize).pow(2);
    if tensor.len() != 3 * plane {
        return None;
    }
    let byte = |v: f32| ((v * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
    let mut bytes = Vec::with_capacity(3 * plane);
    for i in 0..plane {
        bytes.extend([
            byte(tensor[i]),
            byte(tensor[plane + i]),
            byte(tensor[2 * plane + i]),
        ]);
    }
    image::RgbImage::from_raw(size, size, bytes)
}

/// A contact label (mm from the sensor centre, +x right, +y up in the camera view) turned with
/// the image by `rotation_deg` counter-clockwise on screen.
pub fn rotate_contact(contact_mm: [f64; 2], rotation_deg: f64) -> [f64; 2] {
    let (sin, cos) = rotation_deg.to_radians().sin_cos();
    let [x, y] = contact_mm;
    [x * cos - y * sin, x * sin + y * cos]
}
