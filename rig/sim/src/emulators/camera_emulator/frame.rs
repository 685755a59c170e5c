//! A rendered sensor image turned into the frame the camera delivers: cropped to the ROI, gain
//! applied, converted to the configured pixel format. Pure functions, no threads.

use crate::optics::pixel_format::grey;
use fringe_rig::{CameraSettings, PixelFormat, Roi};

/// The camera's 8-bit gain as a table: `None` at 0 dB.
fn gain_table(gain_db: f64) -> Option<[u8; 256]> {
    if gain_db == 0.0 {
        return None;
    }
    let gain = 10f64.powf(gain_db / 20.0);
    Some(std::array::from_fn(|v| {
        (v as f64 * gain).round().clamp(0.0, 255.0) as u8
    }))
}

/// The pixel format the renderer writes for `settings`: the camera's own, except Mono8 with gain
/// (the gain applies to R, G and B before they are mixed to grey), which is rendered as RGB8.
pub(super) fn render_format(settings: &CameraSettings) -> PixelFormat {
    if settings.pixel_format == PixelFormat::Mono8 && settings.gain.0 != 0.0 {
        PixelFormat::Rgb8
    } else {
        settings.pixel_format
    }
}

/// The frame the camera delivers from a full sensor image `rendered` (`width` pixels wide, in
/// [`render_format`]): cropped to `roi`, gain applied, converted to the configured pixel format.
/// A full frame at 0 dB is handed over as it is (`rendered` is left empty).
pub(super) fn finish_frame(
    rendered: &mut Vec<u8>,
    width: u32,
    settings: &CameraSettings,
    roi: Roi,
) -> Vec<u8> {
    let from = render_format(settings);
    let to = settings.pixel_format;
    let gain = gain_table(settings.gain.0);
    let (bpp, width) = (from.bytes_per_pixel(), width as usize);
    let full = roi.x == 0
        && roi.y == 0
        && roi.width as usize == width
        && (roi.width * roi.height) as usize * bpp == rendered.len();
    if full && gain.is_none() && from == to {
        return std::mem::take(rendered);
    }
    let mut out = Vec::with_capacity((roi.width * roi.height) as usize * to.bytes_per_pixel());
    for row in roi.y as usize..(roi.y + roi.height) as usize {
        let first = (row * width + roi.x as usize) * bpp;
        let Some(line) = rendered.get(first..first + roi.width as usize * bpp) else {
            break;
        };
        match (&gain, from == to) {
            (None, _) => out.extend_from_slice(line),
            (Some(g), true) => out.extend(line.iter().map(|&v| g[usize::from(v)])),
            (Some(g), false) => out.extend(line.chunks_exact(3).map(|p| {
                grey([
                    g[usize::from(p[0])],
                    g[usize::from(p[1])],
                    g[usize::from(p[2])],
                ])
            })),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_frames_at_0_db_are_handed_over_without_a_copy() {
        let s = CameraSettings {
            pixel_format: PixelFormat::Rgb8,
            ..CameraSettings::default()
        };
        let full = Roi {
            x: 0,
            y: 0,
            width: 2,
            height: 2,
        };
        let mut rendered: Vec<u8> = (0..12).collect();
        let at = rendered.as_ptr();
        let frame = finish_frame(&mut rendered, 2, &s, full);
        assert_eq!(frame, (0..12).collect::<Vec<u8>>());
        assert_eq!(frame.as_ptr(), at);
        assert!(rendered.is_empty());
    }

    #[test]
    fn frames_crop_rows_and_apply_gain() {
        // 3x2 RGB image, pixel values 10 * pixel index + channel.
        let image: Vec<u8> = (0..6u8)
            .flat_map(|p| [10 * p, 10 * p + 1, 10 * p + 2])
            .collect();
        let mut s = CameraSettings {
            pixel_format: PixelFormat::Rgb8,
            ..CameraSettings::default()
        };
        let roi = Roi {
            x: 1,
            y: 1,
            width: 2,
            height: 1,
        };
        assert_eq!(
            finish_frame(&mut image.clone(), 3, &s, roi),
            vec![40, 41, 42, 50, 51, 52]
        );
        s.gain = fringe_rig::Decibels(20.0 * 2f64.log10());
        let full = Roi {
            x: 0,
            y: 0,
            width: 3,
            height: 2,
        };
        let doubled: Vec<u8> = image
            .iter()
            .map(|&v| (2 * u32::from(v)).min(255) as u8)
            .collect();
        assert_eq!(finish_frame(&mut image.clone(), 3, &s, full), doubled);
        // Bayer: the mosaic is rendered at full size and cropped in the sensor's pattern.
        s.pixel_format = PixelFormat::BayerRg8;
        assert_eq!(render_format(&s), PixelFormat::BayerRg8);
        let mosaic = [0u8, 1, 2, 3, 4, 5];
        assert_eq!(finish_frame(&mut mosaic.to_vec(), 3, &s, roi), vec![8, 10]);
    }

    #[test]
    fn mono_frames_with_gain_mix_the_amplified_colours() {
        // 2x1 image: orange, grey.
        let rgb = [200, 100, 0, 60, 60, 60];
        let mut s = CameraSettings {
            pixel_format: PixelFormat::Mono8,
            ..CameraSettings::default()
        };
        let full = Roi {
            x: 0,
            y: 0,
            width: 2,
            height: 1,
        };
        assert_eq!(render_format(&s), PixelFormat::Mono8);
        s.gain = fringe_rig::Decibels(20.0 * 2f64.log10());
        assert_eq!(render_format(&s), PixelFormat::Rgb8);
        // Red saturates at 255 before the mix: grey(255, 200, 0), not 2 grey(200, 100, 0).
        assert_eq!(
            finish_frame(&mut rgb.to_vec(), 2, &s, full),
            vec![grey([255, 200, 0]), 120]
        );
        assert_ne!(grey([255, 200, 0]), 2 * grey([200, 100, 0]));
    }
}
