//! Accuracy of the optical calibration on simulated frames against the simulator's ground truth
//! (`SensorConfig::geometry().centre_px`, `geometry.disc_radius_px`): both sensor variants, sharp,
//! blurred and heavily blurred, with extra and saturating hot spots, with the disc shifted off
//! centre; and a frame with no sensor in view.
//!
//! `cargo test -p fringe-calibration --test optical_accuracy -- --nocapture` prints the errors.

use fringe_calibration::{find_disc, GreyImage, OpticalError};
use fringe_sim::Renderer;
use fringe_sim::SensorConfig;
use fringe_sim::{FrameRenderer, Scene};

fn frames(config: SensorConfig, count: u64) -> Vec<GreyImage> {
    let mut renderer = Renderer::new(config).expect("valid sensor");
    let (w, h) = (renderer.width(), renderer.height());
    (0..count)
        .map(|k| {
            let mut rgb = Vec::new();
            renderer.render(&Scene { contact: None }, k, &mut rgb);
            let img = image::RgbImage::from_raw(w, h, rgb).expect("frame size");
            GreyImage::from_image(&image::DynamicImage::ImageRgb8(img))
        })
        .collect()
}

/// Fits `config`'s frames, prints and checks the errors; returns them.
fn check(name: &str, config: SensorConfig, count: u64) -> (f64, f64) {
    check_frames(name, config.clone(), frames(config, count))
}

/// Fits `frames` of `config`, prints and checks the errors; returns them.
fn check_frames(name: &str, config: SensorConfig, frames: Vec<GreyImage>) -> (f64, f64) {
    let count = frames.len();
    let truth = config.geometry().centre_px;
    let r_true = config.geometry.disc_radius_px;
    let fit = find_disc(&frames).unwrap_or_else(|e| panic!("{name}: {e}"));
    let dc = (fit.centre_x - truth[0]).hypot(fit.centre_y - truth[1]);
    let dr = fit.radius - r_true;
    println!(
        "{name:<34} frames {count}  centre ({:.2}, {:.2}) err {dc:.3} px (sigma {:.3}, {:.3})  radius {:.2} err {dr:+.3} px (sigma {:.3}, edge {:.2})  rms {:.3}  inliers {}/{}  crop {}",
        fit.centre_x, fit.centre_y, fit.sigma_x, fit.sigma_y, fit.radius, fit.sigma_radius,
        fit.edge_radius, fit.residual_rms_px, fit.inliers, fit.rays, fit.crop_radius
    );
    assert!(dc < 0.5, "{name}: centre off by {dc:.3} px: {fit:?}");
    assert!(dr.abs() < 1.0, "{name}: radius off by {dr:.3} px: {fit:?}");
    assert!(
        fit.crop_radius < r_true && fit.crop_radius > 0.8 * r_true,
        "{name}: crop radius {}",
        fit.crop_radius
    );
    (dc, dr)
}

#[test]
fn layered_sharp_blurred_and_heavy_blur() {
    let c = SensorConfig::layered();
    check("layered sharp", c.clone(), 1);
    let mut b = c.clone();
    b.optics.blur_px = 4.0;
    check("layered blur 4 px", b, 1);
    let mut h = c;
    h.optics.blur_px = 10.0;
    check("layered heavy blur 10 px", h, 4);
}

#[test]
fn integrated_sharp_blurred_and_heavy_blur() {
    let c = SensorConfig::integrated();
    let mut s = c.clone();
    s.optics.blur_px = 0.0;
    check("integrated sharp", s, 1);
    check("integrated blur 3 px (default)", c.clone(), 1);
    let mut h = c;
    h.optics.blur_px = 10.0;
    check("integrated heavy blur 10 px", h, 4);
}

#[test]
fn hot_spots_and_a_shifted_disc() {
    for base in [SensorConfig::layered(), SensorConfig::integrated()] {
        let name = base.variant.name();
        let mut hot = base.clone();
        hot.leds.count = 24;
        hot.leds.strength_dn = 400.0; // saturates
        hot.leds.radius_factor = 1.0;
        let sharp_crop = {
            let (dc, dr) = check(&format!("{name} 24 saturating hot spots"), hot.clone(), 1);
            (dc, dr)
        };
        let _ = sharp_crop;
        let mut shifted = base.clone();
        shifted.geometry.centre_offset_px = [-63.4, 41.7];
        shifted.seed = 5;
        check(&format!("{name} shifted (-63.4, 41.7) px"), shifted, 1);
    }
}

#[test]
fn uneven_background_and_heavy_blur_in_one_frame() {
    // Housing lit unevenly: a ramp from 0 at the left to 40 DN at the right plus a bright glare
    // patch in a corner, added to the rendered frame.
    for base in [SensorConfig::layered(), SensorConfig::integrated()] {
        let name = base.variant.name();
        let mut f = frames(base.clone(), 1);
        let (w, h) = (f[0].width, f[0].height);
        for j in 0..h {
            for i in 0..w {
                let glare = 60.0
                    * (-(((i as f64).powi(2) + (j as f64).powi(2)) / (2.0 * 150.0f64.powi(2))))
                        .exp();
                f[0].data[j * w + i] += (40.0 * i as f64 / w as f64 + glare) as f32;
            }
        }
        check_frames(&format!("{name} uneven background"), base.clone(), f);
        let mut heavy = base;
        heavy.optics.blur_px = 10.0;
        check(&format!("{name} heavy blur 10 px, one frame"), heavy, 1);
    }
}

#[test]
fn no_leds_give_a_larger_crop_radius_than_hot_spots() {
    let mut dark = SensorConfig::layered();
    dark.leds.count = 0;
    let clean = find_disc(&frames(dark, 1)).expect("disc");
    let lit = find_disc(&frames(SensorConfig::layered(), 1)).expect("disc");
    println!(
        "crop radius without LEDs {} px, with 12 LEDs {} px",
        clean.crop_radius, lit.crop_radius
    );
    assert!(
        clean.crop_radius > lit.crop_radius + 5.0,
        "{} vs {}",
        clean.crop_radius,
        lit.crop_radius
    );
}

#[test]
fn no_sensor_in_view_is_an_error() {
    // Housing only: the disc far outside the image.
    let mut away = SensorConfig::layered();
    away.geometry.centre_offset_px = [4000.0, 0.0];
    away.leds.count = 0;
    let e = find_disc(&frames(away, 1)).expect_err("no disc");
    println!("disc out of view: {e}");
    assert!(matches!(e, OpticalError::NoSensor(_)), "{e}");
    // Flat noisy background with a gradient.
    let (w, h) = (640usize, 400usize);
    let mut s = 3u64;
    let data: Vec<f32> = (0..w * h)
        .map(|k| {
            let (i, j) = ((k % w) as f64, (k / w) as f64);
            let n = fringe_rig::seeded::uniform(&mut s) - 0.5;
            (40.0 + 0.05 * i + 0.02 * j + 12.0 * n) as f32
        })
        .collect();
    let flat = GreyImage::from_values(w, h, data).expect("image");
    let e = find_disc(&[flat]).expect_err("no disc");
    println!("flat noisy gradient: {e}");
    assert!(matches!(e, OpticalError::NoSensor(_)), "{e}");
}

#[test]
fn a_straight_bright_edge_is_not_a_disc() {
    // A bright rectangle filling the left 40 % of the frame: strong contrast, no circle.
    let (w, h) = (640usize, 400usize);
    let mut s = 9u64;
    let data: Vec<f32> = (0..w * h)
        .map(|k| {
            let n = fringe_rig::seeded::uniform(&mut s) - 0.5;
            let level = if k % w < 256 { 120.0 } else { 10.0 };
            (level + 4.0 * n) as f32
        })
        .collect();
    let e = find_disc(&[GreyImage::from_values(w, h, data).expect("image")]).expect_err("no disc");
    println!("straight edge: {e}");
    assert!(matches!(e, OpticalError::NoSensor(_)), "{e}");
}

#[test]
fn a_unit_filmed_at_a_quarter_of_the_frame_size_and_less_is_found() {
    // `sim.image_scale`: the same unit through a camera of lower resolution. Every length in
    // px scales with it, the rim ring's and the LED hot spots' widths included (when they kept
    // their full-size widths, no edge was found from a quarter of the size down).
    let unit = SensorConfig::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../rig/sim/sensors/layered-3.toml"
    )))
    .expect("unit");
    for k in [0.25, 0.1] {
        check(&format!("layered-3 at image scale {k}"), unit.scaled(k), 4);
    }
}
