//! How a run stores its frames (`frames/NNNNNNNN.fgl`, or `.png`): the one place that writes
//! and reads them.
//!
//! A run records in its start document how its frames are stored ([`FrameStorage`]): the pixel
//! format the camera delivered, the part of the frame kept (all of it, or the square around the
//! sensor's disc), and the encoding. Readers take all three from the run, never from today's
//! defaults. Encodings, all lossless:
//!
//! - [`Encoding::Fgl`] (the default for one-channel frames, BayerRG8 and Mono8, since layout
//!   3): the pixels as delivered in fringe's own codec ([`fgl`]), which predicts
//!   each pixel from four neighbours of its own colour: about 11 % fewer bytes than the planes
//!   PNG below and less CPU to write, more to read (BENCHMARKS.md, "A context-modelling codec
//!   of our own").
//! - [`Encoding::Png`]: the pixels as delivered: RGB8 in an RGB PNG (RGB8 frames of every
//!   layout, the default for them), Mono8 in a grey PNG (with `[recording] codec = "png"`, and
//!   Mono8 runs of layout 2).
//! - [`Encoding::PngBayerPlanes`]: a BayerRG8 mosaic in a grey PNG of the same size holding its
//!   four colour planes side by side: red (even rows, even columns) top left, the green of the red
//!   rows top right, the green of the blue rows bottom left, blue bottom right. PNG's filters then
//!   predict each pixel from neighbours of its own colour (with `[recording] codec = "png"`, and
//!   BayerRG8 runs of layout 2).
//!
//! PNGs are written with fast deflate (fdeflate) and the Avg filter (the mean of the left and
//! upper neighbours), chosen by that measurement.
//!
//! Runs written before the storage was recorded (layout 1) hold the camera's pixels as they
//! were, whole frames, with [`Encoding::Png`] (a BayerRG8 mosaic as it is, in a grey PNG):
//! `StartDocument::frame_storage` says so for them. Image folders are [`read_plain`].

pub(crate) mod debayer;
pub(crate) mod error;
pub(crate) mod fgl;
pub(crate) mod png;

use self::error::FrameFileError;
use self::fgl::Pattern;
use self::png::{open_image, read_pixels};
use crate::camera::{format_name, Cutout, Frame, PixelFormat, Roi};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::ImageEncoder;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Margin around the disc when only the disc's square is stored and none is named, px: room for
/// the disc to move a little in the image (a knocked camera) before the profile is redone.
pub const DISC_MARGIN_PX: f64 = 40.0;

const RGB8_FGL: &str = "the run says its RGB8 frames are FGL files, which hold one channel: its \
     start document is damaged";

/// How the pixels of a stored frame are encoded in its file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Encoding {
    /// The pixels as delivered, in an RGB or grey PNG.
    Png,
    /// A BayerRG8 mosaic's four colour planes side by side in a grey PNG.
    PngBayerPlanes,
    /// A one-channel frame (BayerRG8 or Mono8) in fringe's lossless codec, FGL.
    Fgl,
}

impl Encoding {
    /// The frame files' extension.
    pub fn extension(self) -> &'static str {
        match self {
            Encoding::Png | Encoding::PngBayerPlanes => "png",
            Encoding::Fgl => "fgl",
        }
    }
}

/// The codec a scan stores frames in (`[recording] codec`; without it, FGL for one-channel
/// frames and PNG for RGB8: [`FrameStorage::new`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameCodec {
    /// PNG (BayerRG8 as its colour planes): read by any tool.
    Png,
    /// FGL, one-channel frames only: about 11 % fewer bytes than PNG and a quarter less CPU to
    /// write, about half again as much to read (BENCHMARKS.md, "A context-modelling codec of
    /// our own").
    Fgl,
}

/// How a run stores its frames; recorded in its start document.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FrameStorage {
    /// What the camera delivered, which the files hold.
    pub pixel_format: PixelFormat,
    /// The part of each frame stored; `None`: the whole frame.
    pub cutout: Option<Cutout>,
    pub encoding: Encoding,
}

/// Pixels of `format` as an image: grey as grey, RGB as RGB, a Bayer mosaic demosaiced to RGB;
/// `None` when `data` does not hold `width` x `height` of them. The one reading of a frame's
/// pixels as a picture (a stored frame's, a live frame's).
pub fn pixels_to_image(
    width: u32,
    height: u32,
    format: PixelFormat,
    data: Vec<u8>,
) -> Option<image::DynamicImage> {
    match format {
        PixelFormat::Mono8 => image::GrayImage::from_raw(width, height, data).map(Into::into),
        PixelFormat::Rgb8 => image::RgbImage::from_raw(width, height, data).map(Into::into),
        PixelFormat::BayerRg8 => image::RgbImage::from_raw(
            width,
            height,
            debayer::to_rgb8(&data, width as usize, height as usize),
        )
        .map(Into::into),
    }
}

/// A stored frame read back: the pixels as the camera delivered them (inside the cutout).
#[derive(Debug, Clone, PartialEq)]
pub struct StoredFrame {
    pub width: u32,
    pub height: u32,
    pub format: PixelFormat,
    pub data: Vec<u8>,
    /// Where the image lies in the camera's frame; `None`: it is the whole frame.
    pub cutout: Option<Cutout>,
}

/// The pixels of a stored cutout placed back in a frame of the camera's size, black elsewhere
/// (nothing was recorded there): `pixels` is `width` columns of `bytes_per_pixel` bytes each,
/// in any pixel format, as stored or after demosaicing. `None` when the cutout does not fit the
/// frame it names.
pub fn in_whole_frame(
    pixels: &[u8],
    width: u32,
    bytes_per_pixel: usize,
    cutout: Cutout,
) -> Option<Vec<u8>> {
    let frame_row = cutout.frame_width as usize * bytes_per_pixel;
    let mut full = vec![0u8; frame_row * cutout.frame_height as usize];
    let row = width as usize * bytes_per_pixel;
    if row == 0 {
        return Some(full);
    }
    let rows = pixels.len() / row;
    let fits = cutout.roi.x as usize + width as usize <= cutout.frame_width as usize
        && cutout.roi.y as usize + rows <= cutout.frame_height as usize;
    if !fits {
        return None;
    }
    for (y, line) in pixels.chunks_exact(row).enumerate() {
        let at = (cutout.roi.y as usize + y) * frame_row + cutout.roi.x as usize * bytes_per_pixel;
        full.get_mut(at..at + row)?.copy_from_slice(line);
    }
    Some(full)
}

/// A cutout that cannot be stored, with what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct CutoutError(pub String);

impl FrameStorage {
    /// How frames of `format` are stored, whole or as `cutout`, in the default codec: FGL for
    /// one-channel frames (BayerRG8, Mono8), PNG for RGB8 ([`FrameStorage::with_codec`] asks for
    /// another). A Bayer cutout must start on even coordinates and have an even size (the
    /// mosaic's pattern stays RG), and a cutout must lie inside the frame.
    pub fn new(format: PixelFormat, cutout: Option<Cutout>) -> Result<FrameStorage, CutoutError> {
        if let Some(c) = cutout {
            let r = c.roi;
            let inside = r.width > 0
                && r.height > 0
                && u64::from(r.x) + u64::from(r.width) <= u64::from(c.frame_width)
                && u64::from(r.y) + u64::from(r.height) <= u64::from(c.frame_height);
            if !inside {
                return Err(CutoutError(format!(
                    "the stored region {}x{} at ({}, {}) does not lie inside the {}x{} frame",
                    r.width, r.height, r.x, r.y, c.frame_width, c.frame_height
                )));
            }
            if format == PixelFormat::BayerRg8 && (r.x | r.y | r.width | r.height) & 1 == 1 {
                return Err(CutoutError(format!(
                    "the stored region {}x{} at ({}, {}) of a BayerRG8 frame must start on even \
                     coordinates and have an even size",
                    r.width, r.height, r.x, r.y
                )));
            }
        }
        Ok(FrameStorage {
            pixel_format: format,
            cutout,
            encoding: match format {
                PixelFormat::BayerRg8 | PixelFormat::Mono8 => Encoding::Fgl,
                PixelFormat::Rgb8 => Encoding::Png,
            },
        })
    }

    /// The same storage with the frames in `codec` (`None`: the default of
    /// [`FrameStorage::new`]): [`FrameCodec::Fgl`] takes one-channel frames only (Mono8,
    /// BayerRG8).
    pub fn with_codec(self, codec: Option<FrameCodec>) -> Result<FrameStorage, CutoutError> {
        let encoding = match (codec, self.pixel_format) {
            (None, _) => return Ok(self),
            (Some(FrameCodec::Png), PixelFormat::BayerRg8) => Encoding::PngBayerPlanes,
            (Some(FrameCodec::Png), PixelFormat::Mono8 | PixelFormat::Rgb8) => Encoding::Png,
            (Some(FrameCodec::Fgl), PixelFormat::Mono8 | PixelFormat::BayerRg8) => Encoding::Fgl,
            (Some(FrameCodec::Fgl), PixelFormat::Rgb8) => {
                return Err(CutoutError(
                    "key `recording.codec` = \"fgl\" stores one-channel frames (mono8, \
                     bayerrg8) but the camera delivers rgb8: set `camera.pixel_format` to \
                     bayerrg8 or mono8, or use codec = \"png\""
                        .into(),
                ))
            }
        };
        Ok(FrameStorage { encoding, ..self })
    }

    /// The square around a disc of `radius_px` centred at `centre_px` (full-frame px), widened by
    /// `margin_px`, on even coordinates, cut to the frame. Fails when the disc and its margin do
    /// not fit in the frame (the profile belongs to another camera setting, or the disc is at the
    /// edge: store whole frames).
    pub fn disc_square(
        centre_px: [f64; 2],
        radius_px: f64,
        margin_px: f64,
        frame_width: u32,
        frame_height: u32,
    ) -> Result<Cutout, CutoutError> {
        let half = radius_px + margin_px;
        let finite = centre_px
            .iter()
            .chain([&radius_px, &margin_px])
            .all(|v| v.is_finite());
        let fits = finite
            && radius_px > 0.0
            && margin_px >= 0.0
            && centre_px[0] - half >= 0.0
            && centre_px[1] - half >= 0.0
            && centre_px[0] + half <= f64::from(frame_width)
            && centre_px[1] + half <= f64::from(frame_height);
        if !fits {
            return Err(CutoutError(format!(
                "the disc (centre ({:.0}, {:.0}) px, radius {radius_px:.0} px) with a margin of \
                 {margin_px:.0} px does not lie inside the {frame_width}x{frame_height} frame: \
                 recalibrate the sensor, lower the margin, or store whole frames",
                centre_px[0], centre_px[1]
            )));
        }
        let even_down = |v: f64| (v.floor().max(0.0) as u32) & !1;
        let even_up = |v: f64| (v.ceil() as u32).div_ceil(2) * 2;
        let x0 = even_down(centre_px[0] - half);
        let y0 = even_down(centre_px[1] - half);
        let x1 = even_up(centre_px[0] + half).min(frame_width & !1);
        let y1 = even_up(centre_px[1] + half).min(frame_height & !1);
        Ok(Cutout {
            roi: Roi {
                x: x0,
                y: y0,
                width: x1 - x0,
                height: y1 - y0,
            },
            frame_width,
            frame_height,
        })
    }

    /// Writes `frame` (its cutout) to `path`. A frame in another pixel format than the run's, or
    /// of another size than its cutout's frame, is refused: the camera's setting changed.
    pub fn write(&self, frame: &Frame, path: &Path) -> Result<(), FrameFileError> {
        let content = |message: String| FrameFileError::Content {
            path: path.to_path_buf(),
            message,
        };
        let expected =
            frame.width as usize * frame.height as usize * frame.format.bytes_per_pixel();
        if frame.data.len() != expected {
            return Err(content(format!(
                "frame {} has {} bytes but {}x{} {} needs {expected}",
                frame.id,
                frame.data.len(),
                frame.width,
                frame.height,
                format_name(frame.format)
            )));
        }
        if frame.format != self.pixel_format {
            return Err(content(format!(
                "frame {} is {} but the run stores {}: the camera's pixel format changed during \
                 the run",
                frame.id,
                format_name(frame.format),
                format_name(self.pixel_format)
            )));
        }
        let (width, height, pixels) = match self.cutout {
            None => (
                frame.width,
                frame.height,
                std::borrow::Cow::Borrowed(&frame.data[..]),
            ),
            Some(c) => {
                if (frame.width, frame.height) != (c.frame_width, c.frame_height) {
                    return Err(content(format!(
                        "frame {} is {}x{} but the run stores a region of {}x{} frames: the \
                         camera's frame size changed during the run",
                        frame.id, frame.width, frame.height, c.frame_width, c.frame_height
                    )));
                }
                (
                    c.roi.width,
                    c.roi.height,
                    std::borrow::Cow::Owned(cut(frame, c.roi)),
                )
            }
        };
        let io = |source: io::Error| FrameFileError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = super::own_file::create(path).map_err(io)?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        let png = |pixels: &[u8], out: &mut BufWriter<File>| {
            let colour = match self.pixel_format {
                PixelFormat::Rgb8 => image::ExtendedColorType::Rgb8,
                PixelFormat::Mono8 | PixelFormat::BayerRg8 => image::ExtendedColorType::L8,
            };
            PngEncoder::new_with_quality(out, CompressionType::Fast, FilterType::Avg)
                .write_image(pixels, width, height, colour)
                .map_err(|source| FrameFileError::Image {
                    path: path.to_path_buf(),
                    source,
                })
        };
        match self.encoding {
            Encoding::Png => png(&pixels, &mut out)?,
            Encoding::PngBayerPlanes => png(&to_planes(&pixels, width, height), &mut out)?,
            Encoding::Fgl => {
                let pattern = self.pattern().ok_or_else(|| content(RGB8_FGL.into()))?;
                let bytes = fgl::encode(&pixels, width, height, pattern)
                    .map_err(|e| content(format!("frame {}: {e}", frame.id)))?;
                out.write_all(&bytes).map_err(io)?;
            }
        }
        out.flush().map_err(io)
    }

    /// How the colours of a one-channel frame lie, for FGL; `None` for RGB8, which FGL does
    /// not store.
    fn pattern(&self) -> Option<Pattern> {
        match self.pixel_format {
            PixelFormat::Mono8 => Some(Pattern::Mono),
            PixelFormat::BayerRg8 => Some(Pattern::Mosaic2x2),
            PixelFormat::Rgb8 => None,
        }
    }

    /// Reads a frame file written by [`FrameStorage::write`].
    pub fn read(&self, path: &Path) -> Result<StoredFrame, FrameFileError> {
        let (width, height, data) = match self.encoding {
            Encoding::Png | Encoding::PngBayerPlanes => {
                read_pixels(path, self.pixel_format, "the run stores")?
            }
            Encoding::Fgl => {
                let bytes = std::fs::read(path).map_err(|source| FrameFileError::Io {
                    path: path.to_path_buf(),
                    source,
                })?;
                let content = |message: String| FrameFileError::Content {
                    path: path.to_path_buf(),
                    message,
                };
                let image = fgl::decode(&bytes).map_err(|e| content(e.to_string()))?;
                let want = self.pattern().ok_or_else(|| content(RGB8_FGL.into()))?;
                if image.pattern != want {
                    return Err(content(format!(
                        "the image's colour pattern is {:?} but the run stores {}",
                        image.pattern,
                        format_name(self.pixel_format)
                    )));
                }
                (image.width, image.height, image.pixels)
            }
        };
        if let Some(c) = self.cutout {
            if (width, height) != (c.roi.width, c.roi.height) {
                return Err(FrameFileError::Content {
                    path: path.to_path_buf(),
                    message: format!(
                        "image is {width}x{height} but the run stores {}x{} regions",
                        c.roi.width, c.roi.height
                    ),
                });
            }
        }
        let data = match self.encoding {
            Encoding::Png | Encoding::Fgl => data,
            Encoding::PngBayerPlanes => {
                if width % 2 == 1 || height % 2 == 1 {
                    return Err(FrameFileError::Content {
                        path: path.to_path_buf(),
                        message: format!(
                            "image is {width}x{height}: Bayer planes need an even size"
                        ),
                    });
                }
                from_planes(&data, width, height)
            }
        };
        Ok(StoredFrame {
            width,
            height,
            format: self.pixel_format,
            data,
            cutout: self.cutout,
        })
    }

    /// Checks that the frame file at `path` is whole, without keeping its pixels: an FGL file by
    /// its checksum (version 2; a file of version 1, which has none, is decoded whole), a PNG by
    /// decoding it (its chunks' CRCs and its stream's checksum). The error names the file.
    pub fn check_file(&self, path: &Path) -> Result<(), FrameFileError> {
        match self.encoding {
            Encoding::Png | Encoding::PngBayerPlanes => self.read(path).map(|_| ()),
            Encoding::Fgl => {
                let bytes = super::own_file::read(path).map_err(|source| FrameFileError::Io {
                    path: path.to_path_buf(),
                    source,
                })?;
                fgl::check(&bytes).map_err(|e| FrameFileError::Content {
                    path: path.to_path_buf(),
                    message: e.to_string(),
                })
            }
        }
    }

    /// Expected bytes of one stored frame: its pixels times the bytes per pixel measured with
    /// this codec on rendered fringe frames (BENCHMARKS.md, "Recording"; the main job's frames
    /// stored in FGL take 0.934 MB, this gives 0.968 MB). No margin: the estimates of a run's
    /// size are meant to hold, and the room a scan asks for adds its own margin
    /// (`fringe-app`'s `disk_space`). `frame_px` is the camera frame's pixel count, used when
    /// the whole frame is stored.
    pub fn expected_frame_bytes(&self, frame_px: u64) -> u64 {
        let px = self.cutout.map_or(frame_px, |c| {
            u64::from(c.roi.width) * u64::from(c.roi.height)
        });
        // Measured (frame_codec_bench): BayerRG8 planes 0.48 B/px over whole frames, 0.60 B/px
        // over the disc square (where the fringes are); Mono8 0.41 and 0.51 B/px; RGB8 1.49 and
        // 1.85 B/px.
        // FGL: BayerRG8 0.42 and 0.53 B/px (0.969 MB over 1920x1200, 0.541 MB over the
        // 1012x1012 square), Mono8 0.35 and 0.44 B/px.
        let fgl = self.encoding == Encoding::Fgl;
        let per_px = match (self.pixel_format, self.cutout.is_some()) {
            (PixelFormat::BayerRg8, false) if fgl => 0.42,
            (PixelFormat::BayerRg8, true) if fgl => 0.53,
            (PixelFormat::Mono8, false) if fgl => 0.35,
            (PixelFormat::Mono8, true) if fgl => 0.44,
            (PixelFormat::BayerRg8, false) => 0.48,
            (PixelFormat::BayerRg8, true) => 0.60,
            (PixelFormat::Mono8, false) => 0.41,
            (PixelFormat::Mono8, true) => 0.51,
            (PixelFormat::Rgb8, false) => 1.49,
            (PixelFormat::Rgb8, true) => 1.85,
        };
        (px as f64 * per_px).ceil() as u64
    }
}

/// Width and height of a stored frame file (FGL or an ordinary image), from its header; `None`
/// when it cannot be read.
pub(crate) fn stored_dimensions(path: &Path) -> Option<(u32, u32)> {
    let mut head = [0u8; fgl::HEADER_BYTES];
    let mut file = File::open(path).ok()?;
    if io::Read::read_exact(&mut file, &mut head).is_ok() {
        if let Ok((width, height, _)) = fgl::header(&head) {
            return Some((width, height));
        }
    }
    image::ImageReader::open(path)
        .ok()?
        .with_guessed_format()
        .ok()?
        .into_dimensions()
        .ok()
}

/// Reads an ordinary image file as a whole camera frame: RGB as RGB8, grey as Mono8 (image
/// folders and the reference layout).
pub fn read_plain(path: &Path) -> Result<StoredFrame, FrameFileError> {
    let img = open_image(path)?;
    let (width, height) = (img.width(), img.height());
    let (data, format) = match img {
        image::DynamicImage::ImageLuma8(g) => (g.into_raw(), PixelFormat::Mono8),
        image::DynamicImage::ImageLuma16(_) | image::DynamicImage::ImageLumaA8(_) => {
            (img.to_luma8().into_raw(), PixelFormat::Mono8)
        }
        other => (other.to_rgb8().into_raw(), PixelFormat::Rgb8),
    };
    Ok(StoredFrame {
        width,
        height,
        format,
        data,
        cutout: None,
    })
}

/// The pixels of `roi` of `frame`.
fn cut(frame: &Frame, roi: Roi) -> Vec<u8> {
    let bpp = frame.format.bytes_per_pixel();
    let row_bytes = roi.width as usize * bpp;
    let mut out = Vec::with_capacity(row_bytes * roi.height as usize);
    for y in roi.y..roi.y + roi.height {
        let start = (y as usize * frame.width as usize + roi.x as usize) * bpp;
        out.extend_from_slice(&frame.data[start..start + row_bytes]);
    }
    out
}

/// A `width` x `height` mosaic (both even) as its colour planes side by side:
/// [R | G of red rows] over [G of blue rows | B].
pub(crate) fn to_planes(mosaic: &[u8], width: u32, height: u32) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let (hw, hh) = (w / 2, h / 2);
    let mut out = vec![0; w * h];
    for (row, line) in mosaic.chunks_exact(w.max(1)).enumerate().take(2 * hh) {
        let target = (row & 1) * hh + row / 2;
        let dst = &mut out[target * w..(target + 1) * w];
        let (even, odd) = dst.split_at_mut(hw);
        for (k, pair) in line.chunks_exact(2).enumerate() {
            even[k] = pair[0];
            odd[k] = pair[1];
        }
    }
    out
}

/// The mosaic back from [`to_planes`].
pub(crate) fn from_planes(planes: &[u8], width: u32, height: u32) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let (hw, hh) = (w / 2, h / 2);
    let mut out = vec![0; w * h];
    for (row, line) in out.chunks_exact_mut(w.max(1)).enumerate().take(2 * hh) {
        let source = (row & 1) * hh + row / 2;
        let src = &planes[source * w..(source + 1) * w];
        let (even, odd) = src.split_at(hw);
        for (k, pair) in line.chunks_exact_mut(2).enumerate() {
            pair[0] = even[k];
            pair[1] = odd[k];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Grey stays grey, RGB stays RGB, a Bayer mosaic is demosaiced to RGB of the same size;
    /// pixels that do not fill the size are no image.
    #[test]
    fn pixels_read_as_an_image_of_their_format() {
        let grey = pixels_to_image(4, 2, PixelFormat::Mono8, (0..8).collect()).expect("grey");
        assert_eq!(grey.as_luma8().map(|g| g.get_pixel(3, 1).0), Some([7]));
        let rgb = pixels_to_image(2, 1, PixelFormat::Rgb8, vec![1, 2, 3, 4, 5, 6]).expect("rgb");
        assert_eq!(rgb.as_rgb8().map(|g| g.get_pixel(1, 0).0), Some([4, 5, 6]));
        // A flat mosaic: red sites 200, green 100, blue 50, read back as that colour.
        let mosaic: Vec<u8> = (0..16)
            .map(|i| match (i / 4 % 2, i % 2) {
                (0, 0) => 200,
                (1, 1) => 50,
                _ => 100,
            })
            .collect();
        let bayer = pixels_to_image(4, 4, PixelFormat::BayerRg8, mosaic).expect("bayer");
        let rgb = bayer.as_rgb8().expect("demosaiced to RGB");
        assert_eq!((rgb.width(), rgb.height()), (4, 4));
        assert_eq!(rgb.get_pixel(1, 1).0, [200, 100, 50]);
        assert!(pixels_to_image(4, 4, PixelFormat::Mono8, vec![0; 15]).is_none());
    }

    /// A stored cutout goes back where the camera saw it, in a frame black elsewhere; one that
    /// does not fit the frame it names is refused.
    #[test]
    fn a_cutout_is_placed_back_in_the_whole_frame() {
        let cutout = Cutout {
            roi: Roi {
                x: 1,
                y: 1,
                width: 2,
                height: 1,
            },
            frame_width: 4,
            frame_height: 3,
        };
        // Two RGB pixels.
        let full = in_whole_frame(&[1, 2, 3, 4, 5, 6], 2, 3, cutout).expect("fits");
        let mut want = vec![0u8; 4 * 3 * 3];
        want[(4 + 1) * 3..(4 + 3) * 3].copy_from_slice(&[1, 2, 3, 4, 5, 6]);
        assert_eq!(full, want);
        let outside = Cutout {
            roi: Roi { x: 3, ..cutout.roi },
            ..cutout
        };
        assert_eq!(in_whole_frame(&[1, 2], 2, 1, outside), None);
    }

    fn frame(format: PixelFormat, w: u32, h: u32) -> Frame {
        crate::camera::test_frame(format, w, h)
    }

    fn temp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("fringe-frame-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        dir.join(name)
    }

    #[test]
    fn planes_put_each_colour_in_its_quarter_and_come_back() {
        // 4x2 mosaic: R G R G / G B G B.
        let mosaic = [1, 2, 3, 4, 5, 6, 7, 8];
        let planes = to_planes(&mosaic, 4, 2);
        assert_eq!(planes, vec![1, 3, 2, 4, 5, 7, 6, 8]);
        assert_eq!(from_planes(&planes, 4, 2), mosaic);
    }

    #[test]
    fn every_format_comes_back_bit_for_bit_whole_and_cut() {
        for format in [PixelFormat::Mono8, PixelFormat::Rgb8, PixelFormat::BayerRg8] {
            let f = frame(format, 10, 6);
            let whole = FrameStorage::new(format, None).expect("storage");
            let path = temp(&format!("{}.png", format_name(format)));
            whole.write(&f, &path).expect("write");
            let back = whole.read(&path).expect("read");
            assert_eq!((back.width, back.height, back.format), (10, 6, format));
            assert_eq!(back.data, f.data);

            let cutout = Cutout {
                roi: Roi {
                    x: 2,
                    y: 2,
                    width: 6,
                    height: 4,
                },
                frame_width: 10,
                frame_height: 6,
            };
            let cut_storage = FrameStorage::new(format, Some(cutout)).expect("storage");
            cut_storage.write(&f, &path).expect("write cut");
            let back = cut_storage.read(&path).expect("read cut");
            assert_eq!(back.cutout, Some(cutout));
            let bpp = format.bytes_per_pixel();
            for y in 0..4usize {
                let row = &back.data[y * 6 * bpp..(y + 1) * 6 * bpp];
                let start = ((y + 2) * 10 + 2) * bpp;
                assert_eq!(row, &f.data[start..start + 6 * bpp], "{format:?} row {y}");
            }
        }
    }

    #[test]
    fn fgl_frames_come_back_bit_for_bit_and_rgb8_is_refused() {
        for format in [PixelFormat::Mono8, PixelFormat::BayerRg8] {
            let f = frame(format, 12, 8);
            let storage = FrameStorage::new(format, None)
                .and_then(|s| s.with_codec(Some(FrameCodec::Fgl)))
                .expect("storage");
            assert_eq!(storage.encoding, Encoding::Fgl);
            let path = temp(&format!("{}.fgl", format_name(format)));
            storage.write(&f, &path).expect("write");
            assert_eq!(stored_dimensions(&path), Some((12, 8)));
            let back = storage.read(&path).expect("read");
            assert_eq!(
                (back.width, back.height, back.data),
                (12, 8, f.data.clone())
            );
            // A run that says Mono8 does not take a mosaic's file, nor the reverse.
            let other = if format == PixelFormat::Mono8 {
                PixelFormat::BayerRg8
            } else {
                PixelFormat::Mono8
            };
            let wrong = FrameStorage::new(other, None)
                .and_then(|s| s.with_codec(Some(FrameCodec::Fgl)))
                .expect("storage");
            let e = wrong.read(&path).expect_err("another pattern");
            assert!(e.to_string().contains("colour pattern"), "{e}");
        }
        let e = FrameStorage::new(PixelFormat::Rgb8, None)
            .expect("storage")
            .with_codec(Some(FrameCodec::Fgl))
            .expect_err("rgb8 in fgl");
        assert!(e.to_string().contains("recording.codec"), "{e}");
        let damaged = temp("damaged.fgl");
        std::fs::write(&damaged, b"FGL1\x05").expect("write");
        let storage = FrameStorage::new(PixelFormat::Mono8, None)
            .and_then(|s| s.with_codec(Some(FrameCodec::Fgl)))
            .expect("storage");
        let e = storage.read(&damaged).expect_err("cut short");
        assert!(e.to_string().contains("damaged.fgl"), "{e}");
    }

    #[test]
    fn one_bit_flipped_in_an_fgl_frame_is_an_error_naming_the_file() {
        let storage = FrameStorage::new(PixelFormat::BayerRg8, None).expect("storage");
        assert_eq!(storage.encoding, Encoding::Fgl);
        let path = temp("flipped.fgl");
        storage
            .write(&frame(PixelFormat::BayerRg8, 16, 10), &path)
            .expect("write");
        storage.check_file(&path).expect("whole");
        let mut bytes = std::fs::read(&path).expect("read");
        let at = bytes.len() * 2 / 3;
        bytes[at] ^= 0x04;
        std::fs::write(&path, &bytes).expect("flip");
        for e in [
            storage.read(&path).expect_err("read"),
            storage.check_file(&path).expect_err("check"),
        ] {
            let text = e.to_string();
            assert!(
                text.contains("flipped.fgl") && text.contains("checksum does not match"),
                "{text}"
            );
        }
    }

    #[test]
    fn a_frame_unlike_the_run_is_refused_naming_what_changed() {
        let storage = FrameStorage::new(PixelFormat::BayerRg8, None).expect("storage");
        let path = temp("refused.png");
        let e = storage
            .write(&frame(PixelFormat::Rgb8, 4, 4), &path)
            .expect_err("another format");
        assert!(e.to_string().contains("pixel format changed"), "{e}");
        let cutout = FrameStorage::disc_square([50.0, 40.0], 20.0, 4.0, 100, 80).expect("fits");
        assert_eq!(
            cutout.roi,
            Roi {
                x: 26,
                y: 16,
                width: 48,
                height: 48
            }
        );
        let cut = FrameStorage::new(PixelFormat::BayerRg8, Some(cutout)).expect("storage");
        let e = cut
            .write(&frame(PixelFormat::BayerRg8, 90, 80), &path)
            .expect_err("another size");
        assert!(e.to_string().contains("frame size changed"), "{e}");
    }

    #[test]
    fn a_cutout_must_hold_the_disc_and_keep_the_bayer_pattern() {
        let e = FrameStorage::disc_square([30.0, 40.0], 35.0, 4.0, 100, 80).expect_err("off");
        assert!(e.to_string().contains("does not lie inside"), "{e}");
        let odd = Cutout {
            roi: Roi {
                x: 1,
                y: 0,
                width: 4,
                height: 4,
            },
            frame_width: 10,
            frame_height: 6,
        };
        assert!(FrameStorage::new(PixelFormat::BayerRg8, Some(odd)).is_err());
        assert!(FrameStorage::new(PixelFormat::Mono8, Some(odd)).is_ok());
        let outside = Cutout {
            frame_width: 4,
            ..odd
        };
        assert!(FrameStorage::new(PixelFormat::Mono8, Some(outside)).is_err());
    }

    #[test]
    fn plain_files_are_read_as_their_colour_type() {
        let f = frame(PixelFormat::Rgb8, 6, 4);
        let path = temp("plain.png");
        FrameStorage::new(PixelFormat::Rgb8, None)
            .expect("storage")
            .write(&f, &path)
            .expect("write");
        let rgb = read_plain(&path).expect("read");
        assert_eq!((rgb.format, &rgb.data), (PixelFormat::Rgb8, &f.data));
    }
}
