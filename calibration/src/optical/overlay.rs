//! The fit drawn over the averaged frame, for reports and displays: the fitted disc (green), the
//! crop circle (yellow) and the centre (red cross), drawn by [`fringe_plot::overlay`].

use super::grey::GreyImage;
use super::DiscFit;
use fringe_plot::{Mark, PlotError};
use image::{Rgb, RgbImage};

/// Half-length of the centre cross, px.
const CROSS_PX: f64 = 20.0;

/// `g` as an RGB picture with `f` drawn on it.
pub fn overlay(g: &GreyImage, f: &DiscFit) -> Result<RgbImage, PlotError> {
    overlay_scaled(g, f, 1.0)
}

/// As [`overlay`], the picture `scale` times the frame's size (a preview: each pixel samples the
/// frame, the circles are drawn at the picture's own resolution so they stay thin).
pub fn overlay_scaled(g: &GreyImage, f: &DiscFit, scale: f64) -> Result<RgbImage, PlotError> {
    let scale = if scale.is_finite() && scale > 0.0 {
        scale.min(1.0)
    } else {
        1.0
    };
    let w = ((g.width as f64 * scale).round() as u32).max(1);
    let h = ((g.height as f64 * scale).round() as u32).max(1);
    let frame = RgbImage::from_fn(w, h, |i, j| {
        let x = ((i as f64 + 0.5) / scale) as usize;
        let y = ((j as f64 + 0.5) / scale) as usize;
        let v = g
            .at(
                x.min(g.width.saturating_sub(1)),
                y.min(g.height.saturating_sub(1)),
            )
            .clamp(0.0, 255.0) as u8;
        Rgb([v, v, v])
    });
    let centre = [f.centre_x * scale, f.centre_y * scale];
    fringe_plot::overlay(
        &frame,
        &[
            Mark::Circle {
                centre,
                radius: f.radius * scale,
                colour: [0, 255, 0],
            },
            Mark::Circle {
                centre,
                radius: f.crop_radius * scale,
                colour: [255, 220, 0],
            },
            Mark::Cross {
                centre,
                arm: (CROSS_PX * scale).round().max(2.0),
                colour: [255, 0, 0],
            },
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(centre: (f64, f64), radius: f64, crop: f64) -> DiscFit {
        DiscFit {
            width: 200,
            height: 100,
            frames: 1,
            centre_x: centre.0,
            centre_y: centre.1,
            radius,
            sigma_x: 0.0,
            sigma_y: 0.0,
            sigma_radius: 0.0,
            edge_radius: radius,
            residual_rms_px: 0.0,
            inliers: 720,
            rays: 720,
            crop_radius: crop,
            edge_blur_px: None,
            inside_dn: 40.0,
            outside_dn: 10.0,
            noise_dn: 1.0,
        }
    }

    #[test]
    fn the_circles_and_centre_land_where_the_fit_is_at_any_scale() {
        let g = GreyImage::from_values(200, 100, vec![40.0; 200 * 100]).expect("image");
        let f = fit((120.0, 50.0), 40.0, 30.0);
        for scale in [1.0, 0.5, 0.25] {
            let img = overlay_scaled(&g, &f, scale).expect("draws");
            assert_eq!(
                img.dimensions(),
                ((200.0 * scale) as u32, (100.0 * scale) as u32)
            );
            let at = |x: f64, y: f64| *img.get_pixel((x * scale) as u32, (y * scale) as u32);
            assert_eq!(at(120.0, 50.0), Rgb([255, 0, 0]), "centre at scale {scale}");
            assert_eq!(
                at(160.0, 50.0),
                Rgb([0, 255, 0]),
                "disc edge at scale {scale}"
            );
            assert_eq!(
                at(150.0, 50.0),
                Rgb([255, 220, 0]),
                "crop edge at scale {scale}"
            );
            assert_eq!(at(10.0, 90.0), Rgb([40, 40, 40]), "frame elsewhere");
        }
    }
}
