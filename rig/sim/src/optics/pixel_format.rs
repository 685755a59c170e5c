//! The simulated camera's pixel formats as samples of the rendered 8-bit RGB image.
//!
//! - RGB8: the image itself, interleaved.
//! - BayerRG8: the RG mosaic of the RGB image: red at even rows and even columns, blue at odd rows
//!   and odd columns, green elsewhere, counted from the sensor's top-left pixel (a region of
//!   interest keeps the sensor's pattern).
//! - Mono8: the integer luma (77 R + 150 G + 29 B) / 256 of the 8-bit values.
//!
//! The renderer writes BayerRG8 and Mono8 directly with these functions (no RGB frame in between);
//! [`from_rgb`] converts an RGB image for renderers that only write RGB.

use fringe_rig::PixelFormat;

/// The colour channel (0 red, 1 green, 2 blue) a BayerRG8 sensor records at (`row`, `col`).
#[inline(always)]
pub(crate) fn bayer_channel(row: usize, col: usize) -> usize {
    (row & 1) + (col & 1)
}

/// The Mono8 value of an RGB pixel.
#[inline(always)]
pub(crate) fn grey(rgb: [u8; 3]) -> u8 {
    ((77 * u32::from(rgb[0]) + 150 * u32::from(rgb[1]) + 29 * u32::from(rgb[2])) >> 8) as u8
}

/// Converts an interleaved RGB image `width` pixels wide (full sensor rows from the top) to
/// `format`, into `out` (resized to width * rows * bytes per pixel).
pub(crate) fn from_rgb(rgb: &[u8], width: usize, format: PixelFormat, out: &mut Vec<u8>) {
    out.clear();
    match format {
        PixelFormat::Rgb8 => out.extend_from_slice(rgb),
        PixelFormat::Mono8 => out.extend(rgb.chunks_exact(3).map(|p| grey([p[0], p[1], p[2]]))),
        PixelFormat::BayerRg8 => {
            for (row, line) in rgb.chunks_exact(3 * width.max(1)).enumerate() {
                out.extend(
                    line.chunks_exact(3)
                        .enumerate()
                        .map(|(col, p)| p[bayer_channel(row, col)]),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bayer_rg_pattern_starts_red_at_the_top_left() {
        assert_eq!(bayer_channel(0, 0), 0);
        assert_eq!(bayer_channel(0, 1), 1);
        assert_eq!(bayer_channel(1, 0), 1);
        assert_eq!(bayer_channel(1, 1), 2);
        assert_eq!(bayer_channel(6, 9), 1);
        assert_eq!(bayer_channel(7, 9), 2);
    }

    #[test]
    fn rgb_converts_to_mono_and_bayer() {
        // 2x2 image: red, green / blue, white.
        let rgb = [255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255];
        let mut out = vec![9; 3];
        from_rgb(&rgb, 2, PixelFormat::BayerRg8, &mut out);
        assert_eq!(out, vec![255, 255, 0, 255]);
        from_rgb(&rgb, 2, PixelFormat::Mono8, &mut out);
        assert_eq!(out, vec![76, 149, 28, 255]);
        from_rgb(&rgb, 2, PixelFormat::Rgb8, &mut out);
        assert_eq!(out, rgb.to_vec());
    }
}
