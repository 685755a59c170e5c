//! Where preprocessing reads pixels from: a camera frame in its own pixel format (RGB8, Mono8 or
//! the BayerRG8 mosaic), seen as rows of 1 or 3 float channels (0-255), optionally rotated about
//! a centre.
//!
//! A Bayer mosaic is read as 2x2 superpixels (R, mean of the two G, B) at half resolution when
//! the output is at least 2x smaller than the crop: no full-size demosaic is made. Otherwise it
//! is demosaiced bilinearly, pixel by pixel, as rows are asked for.

use fringe_rig::store;
use fringe_rig::{Cutout, PixelFormat};

/// A frame's bytes as the camera delivered them.
#[derive(Debug, Clone, Copy)]
pub struct FrameRef<'a> {
    pub width: u32,
    pub height: u32,
    pub format: PixelFormat,
    pub data: &'a [u8],
    /// Where these pixels lie in the camera's frame when they are a part of it (a run that
    /// stored only the disc's square); `None`: the whole frame.
    pub cutout: Option<Cutout>,
}

impl<'a> From<&'a fringe_rig::Frame> for FrameRef<'a> {
    /// A whole frame as the camera delivered it.
    fn from(frame: &'a fringe_rig::Frame) -> FrameRef<'a> {
        FrameRef {
            width: frame.width,
            height: frame.height,
            format: frame.format,
            data: &frame.data,
            cutout: None,
        }
    }
}

impl FrameRef<'_> {
    /// The camera frame's size: the cutout's frame, or this image's own.
    pub fn frame_size(&self) -> (u32, u32) {
        self.cutout.map_or((self.width, self.height), |c| {
            (c.frame_width, c.frame_height)
        })
    }

    /// Full-frame coordinates of this image's top-left corner.
    pub fn origin(&self) -> [f64; 2] {
        self.cutout
            .map_or([0.0, 0.0], |c| [f64::from(c.roi.x), f64::from(c.roi.y)])
    }
}

/// What each pixel is turned into.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Channels {
    /// One value: the ITU-R 601 luma of a colour pixel, or a grey pixel as it is.
    Luma,
    /// R, G, B (a grey pixel repeated).
    Rgb,
}

impl Channels {
    pub(crate) fn count(self) -> usize {
        match self {
            Channels::Luma => 1,
            Channels::Rgb => 3,
        }
    }
}

/// ITU-R 601 luma weights (those of PIL's "L" conversion).
pub(crate) const LUMA: [f32; 3] = [0.299, 0.587, 0.114];

/// Pixels by row, in a resolution of their own (`scale` source pixels per full-frame pixel).
pub(crate) trait Pixels {
    /// Width and height in this source's pixels.
    fn size(&self) -> (i64, i64);
    /// Source pixels per full-frame pixel (0.5 for Bayer superpixels).
    fn scale(&self) -> f64;
    fn channels(&self) -> Channels;
    /// Writes pixels `x0..x0 + out.len() / channels` of row `y` into `out`; the range lies
    /// inside the source.
    fn row(&self, y: i64, x0: i64, out: &mut [f32]);
}

/// The frame read in `channels`, at full resolution, or as Bayer superpixels when `half` is
/// allowed.
pub(crate) fn pixels<'a>(
    frame: FrameRef<'a>,
    channels: Channels,
    half: bool,
) -> Box<dyn Pixels + 'a> {
    match frame.format {
        PixelFormat::Rgb8 => Box::new(Rgb8 { frame, channels }),
        PixelFormat::Mono8 => Box::new(Mono8 { frame, channels }),
        PixelFormat::BayerRg8 if half && frame.width >= 2 && frame.height >= 2 => {
            Box::new(BayerHalf { frame, channels })
        }
        PixelFormat::BayerRg8 => Box::new(BayerFull { frame, channels }),
    }
}

fn put(channels: Channels, rgb: [f32; 3], out: &mut [f32]) {
    match channels {
        Channels::Luma => out[0] = LUMA[0] * rgb[0] + LUMA[1] * rgb[1] + LUMA[2] * rgb[2],
        Channels::Rgb => out[..3].copy_from_slice(&rgb),
    }
}

struct Rgb8<'a> {
    frame: FrameRef<'a>,
    channels: Channels,
}

impl Pixels for Rgb8<'_> {
    fn size(&self) -> (i64, i64) {
        (self.frame.width as i64, self.frame.height as i64)
    }
    fn scale(&self) -> f64 {
        1.0
    }
    fn channels(&self) -> Channels {
        self.channels
    }
    fn row(&self, y: i64, x0: i64, out: &mut [f32]) {
        let c = self.channels.count();
        let start = (y as usize * self.frame.width as usize + x0 as usize) * 3;
        let n = out.len() / c;
        let bytes = &self.frame.data[start..start + 3 * n];
        match self.channels {
            Channels::Rgb => {
                for (o, &b) in out.iter_mut().zip(bytes) {
                    *o = b as f32;
                }
            }
            Channels::Luma => {
                for (o, p) in out.iter_mut().zip(bytes.chunks_exact(3)) {
                    *o = LUMA[0] * p[0] as f32 + LUMA[1] * p[1] as f32 + LUMA[2] * p[2] as f32;
                }
            }
        }
    }
}

struct Mono8<'a> {
    frame: FrameRef<'a>,
    channels: Channels,
}

impl Pixels for Mono8<'_> {
    fn size(&self) -> (i64, i64) {
        (self.frame.width as i64, self.frame.height as i64)
    }
    fn scale(&self) -> f64 {
        1.0
    }
    fn channels(&self) -> Channels {
        self.channels
    }
    fn row(&self, y: i64, x0: i64, out: &mut [f32]) {
        let c = self.channels.count();
        let start = y as usize * self.frame.width as usize + x0 as usize;
        let n = out.len() / c;
        for (o, &b) in out
            .chunks_exact_mut(c)
            .zip(&self.frame.data[start..start + n])
        {
            o.fill(b as f32);
        }
    }
}

/// BayerRG8 as 2x2 superpixels: R at (0, 0), G at (1, 0) and (0, 1), B at (1, 1).
struct BayerHalf<'a> {
    frame: FrameRef<'a>,
    channels: Channels,
}

impl Pixels for BayerHalf<'_> {
    fn size(&self) -> (i64, i64) {
        (self.frame.width as i64 / 2, self.frame.height as i64 / 2)
    }
    fn scale(&self) -> f64 {
        0.5
    }
    fn channels(&self) -> Channels {
        self.channels
    }
    fn row(&self, y: i64, x0: i64, out: &mut [f32]) {
        let c = self.channels.count();
        let w = self.frame.width as usize;
        let top = 2 * y as usize * w;
        let (even, odd) = (
            &self.frame.data[top..top + w],
            &self.frame.data[top + w..top + 2 * w],
        );
        for (k, o) in out.chunks_exact_mut(c).enumerate() {
            let x = 2 * (x0 as usize + k);
            let rgb = [
                even[x] as f32,
                0.5 * (even[x + 1] as f32 + odd[x] as f32),
                odd[x + 1] as f32,
            ];
            put(self.channels, rgb, o);
        }
    }
}

/// BayerRG8 demosaiced at full resolution ([`debayer`], fringe's one demosaicing).
struct BayerFull<'a> {
    frame: FrameRef<'a>,
    channels: Channels,
}

impl BayerFull<'_> {
    fn rgb(&self, x: i64, y: i64) -> [f32; 3] {
        let f = self.frame;
        store::rgb_at(f.data, f.width as usize, f.height as usize, x, y)
    }
}

impl Pixels for BayerFull<'_> {
    fn size(&self) -> (i64, i64) {
        (self.frame.width as i64, self.frame.height as i64)
    }
    fn scale(&self) -> f64 {
        1.0
    }
    fn channels(&self) -> Channels {
        self.channels
    }
    fn row(&self, y: i64, x0: i64, out: &mut [f32]) {
        let c = self.channels.count();
        for (k, o) in out.chunks_exact_mut(c).enumerate() {
            put(self.channels, self.rgb(x0 + k as i64, y), o);
        }
    }
}

/// The square of `base` about `centre` (its pixel coordinates) that a rotation about it within
/// `radius` reads, read once into memory: a turned copy samples four pixels for each one it
/// makes, so reading them from the frame each time (a colour conversion, a superpixel's
/// average) cost four times the work. The values are the base's own, so a rotation reads the
/// same numbers.
pub(crate) struct Dense {
    size: (i64, i64),
    scale: f64,
    channels: Channels,
    /// The region's first column and row, and its width and height, in the base's pixels.
    x0: i64,
    y0: i64,
    w: usize,
    h: usize,
    data: Vec<f32>,
}

impl Dense {
    /// Reads the pixels of `base` within `radius` (plus the two a bilinear sample reaches past
    /// it) of `centre`.
    pub(crate) fn around(base: &dyn Pixels, centre: [f64; 2], radius: f64) -> Dense {
        let (bw, bh) = base.size();
        let c = base.channels().count();
        let span = |mid: f64, len: i64| {
            let lo = ((mid - radius).floor() as i64 - 2).clamp(0, len);
            let hi = ((mid + radius).ceil() as i64 + 2).clamp(lo, len);
            (lo, hi)
        };
        let (x0, x1) = span(centre[0], bw);
        let (y0, y1) = span(centre[1], bh);
        let (w, h) = ((x1 - x0) as usize, (y1 - y0) as usize);
        let mut data = vec![0f32; w * h * c];
        if w > 0 {
            for (k, row) in data.chunks_exact_mut(w * c).enumerate() {
                base.row(y0 + k as i64, x0, row);
            }
        }
        Dense {
            size: (bw, bh),
            scale: base.scale(),
            channels: base.channels(),
            x0,
            y0,
            w,
            h,
            data,
        }
    }

    /// Pixel (x, y) of the base, if the region holds it.
    fn at(&self, x: i64, y: i64) -> Option<&[f32]> {
        let (cx, cy) = (x - self.x0, y - self.y0);
        if cx < 0 || cy < 0 || cx as usize >= self.w || cy as usize >= self.h {
            return None;
        }
        let c = self.channels.count();
        let i = (cy as usize * self.w + cx as usize) * c;
        Some(&self.data[i..i + c])
    }
}

/// `base` rotated by `angle` (radians, counter-clockwise as seen on screen) about `centre`
/// (in the base's pixel coordinates, pixel centres at i + 0.5), sampled bilinearly; outside the
/// base reads black.
pub(crate) struct Rotated {
    pub(crate) base: Dense,
    pub(crate) centre: [f64; 2],
    pub(crate) angle: f64,
}

impl Pixels for Rotated {
    fn size(&self) -> (i64, i64) {
        self.base.size
    }
    fn scale(&self) -> f64 {
        self.base.scale
    }
    fn channels(&self) -> Channels {
        self.base.channels
    }
    fn row(&self, y: i64, x0: i64, out: &mut [f32]) {
        let c = self.channels().count();
        let (w, h) = self.base.size;
        let (sin, cos) = self.angle.sin_cos();
        let dy = y as f64 + 0.5 - self.centre[1];
        for (k, o) in out.chunks_exact_mut(c).enumerate() {
            let dx = (x0 + k as i64) as f64 + 0.5 - self.centre[0];
            // A screen-counter-clockwise turn by `angle` in image axes (y down) maps the source
            // offset (sx, sy) to (sx cos + sy sin, -sx sin + sy cos); invert it.
            let sx = dx * cos - dy * sin;
            let sy = dx * sin + dy * cos;
            let (fx, fy) = (self.centre[0] + sx - 0.5, self.centre[1] + sy - 0.5);
            let (ix, iy) = (fx.floor() as i64, fy.floor() as i64);
            let (tx, ty) = ((fx - ix as f64) as f32, (fy - iy as f64) as f32);
            o.fill(0.0);
            for (cx, cy, wgt) in [
                (ix, iy, (1.0 - tx) * (1.0 - ty)),
                (ix + 1, iy, tx * (1.0 - ty)),
                (ix, iy + 1, (1.0 - tx) * ty),
                (ix + 1, iy + 1, tx * ty),
            ] {
                if wgt == 0.0 || cx < 0 || cy < 0 || cx >= w || cy >= h {
                    continue;
                }
                // Within the rotation's radius, so inside the region read (the crop's mask
                // reads no pixel past it).
                let Some(corner) = self.base.at(cx, cy) else {
                    debug_assert!(false, "a turned copy read ({cx}, {cy}) past its region");
                    continue;
                };
                for (v, s) in o.iter_mut().zip(corner) {
                    *v += wgt * s;
                }
            }
        }
    }
}
