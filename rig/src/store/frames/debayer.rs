//! The one demosaicing of fringe: bilinear interpolation of a BayerRG8 mosaic (red at even rows
//! and even columns, blue at odd rows and odd columns, green elsewhere, counted from the
//! stored image's top-left pixel: a region cut on even coordinates keeps the pattern).
//!
//! At a pixel, its own colour is the sample itself; a colour found at the four side neighbours
//! is their mean; at the four diagonal neighbours, their mean; at two opposite neighbours (left
//! and right, or above and below), their mean. Edges are mirrored by two pixels, which keeps
//! the colour phase. Preprocessing reads colour from a mosaic with [`rgb_at`]; the reference
//! layout's RGB images are [`to_rgb8`] (the same values rounded to 8 bits).

/// The mosaic's value at (`x`, `y`), mirrored by two pixels at the edges.
#[inline]
fn at(data: &[u8], width: usize, height: usize, x: i64, y: i64) -> f32 {
    let (w, h) = (width as i64, height as i64);
    let reflect = |v: i64, n: i64| {
        let v = if v < 0 {
            v + 2
        } else if v >= n {
            v - 2
        } else {
            v
        };
        v.clamp(0, n - 1)
    };
    let (x, y) = (reflect(x, w), reflect(y, h));
    f32::from(data[(y * w + x) as usize])
}

/// Red, green and blue at pixel (`x`, `y`) of a `width` x `height` mosaic, 0-255.
pub fn rgb_at(data: &[u8], width: usize, height: usize, x: i64, y: i64) -> [f32; 3] {
    let p = |dx: i64, dy: i64| at(data, width, height, x + dx, y + dy);
    let here = p(0, 0);
    let cross = 0.25 * (p(-1, 0) + p(1, 0) + p(0, -1) + p(0, 1));
    let diag = 0.25 * (p(-1, -1) + p(1, -1) + p(-1, 1) + p(1, 1));
    let horiz = 0.5 * (p(-1, 0) + p(1, 0));
    let vert = 0.5 * (p(0, -1) + p(0, 1));
    match (x & 1, y & 1) {
        (0, 0) => [here, cross, diag],
        (1, 1) => [diag, cross, here],
        // Green on a red row: red left and right, blue above and below.
        (1, 0) => [horiz, here, vert],
        _ => [vert, here, horiz],
    }
}

/// The whole mosaic as interleaved RGB8, each value of [`rgb_at`] rounded.
pub fn to_rgb8(data: &[u8], width: usize, height: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(width * height * 3);
    for y in 0..height as i64 {
        for x in 0..width as i64 {
            out.extend(
                rgb_at(data, width, height, x, y).map(|v| v.round().clamp(0.0, 255.0) as u8),
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_colour_comes_back_everywhere_edges_included() {
        // A 6x4 mosaic of one colour (R 200, G 100, B 20).
        let (w, h) = (6, 4);
        let mosaic: Vec<u8> = (0..w * h)
            .map(|i| match ((i / w) & 1, (i % w) & 1) {
                (0, 0) => 200,
                (1, 1) => 20,
                _ => 100,
            })
            .collect();
        let rgb = to_rgb8(&mosaic, w, h);
        assert!(rgb.chunks_exact(3).all(|p| p == [200, 100, 20]), "{rgb:?}");
    }

    #[test]
    fn missing_colours_are_neighbour_means() {
        // 4x4 ramp: value = 10 * x + y.
        let (w, h) = (4, 4);
        let mosaic: Vec<u8> = (0..16).map(|i| (10 * (i % 4) + i / 4) as u8).collect();
        // (1, 1) is blue: red from the diagonals, green from the sides.
        let [r, g, b] = rgb_at(&mosaic, w, h, 1, 1);
        assert_eq!(b, 11.0);
        assert_eq!(r, 0.25 * (0.0 + 20.0 + 2.0 + 22.0));
        assert_eq!(g, 0.25 * (1.0 + 21.0 + 10.0 + 12.0));
        // (1, 0) is green on a red row: red left and right, blue below (and mirrored above).
        assert_eq!(rgb_at(&mosaic, w, h, 1, 0), [10.0, 10.0, 11.0]);
    }
}
