//! The one preprocessing: geometry from the profile, mask, formats, rotation with its label.

use fringe_rig::PixelFormat;
use fringe_sensor_models::{
    rotate_contact, Centre, Colour, FrameRef, Preprocessing, Preprocessor, ReferenceSensor,
};
use proptest::prelude::*;

const W: u32 = 640;
const H: u32 = 400;

fn config(centre: [f64; 2], radius: f64, colour: Colour, size: u32) -> Preprocessing {
    Preprocessing {
        centre: Centre::At(centre),
        crop_radius_px: radius,
        frame_size: Some((W, H)),
        sensor: "test".into(),
        input_size: size,
        colour,
        reference: false,
    }
}

/// An RGB frame: black, with a bright Gaussian spot of `sigma` px at `spot` (px).
fn spot_frame(spot: [f64; 2], sigma: f64) -> Vec<u8> {
    let mut data = vec![0u8; (W * H * 3) as usize];
    for y in 0..H {
        for x in 0..W {
            let d2 = (x as f64 + 0.5 - spot[0]).powi(2) + (y as f64 + 0.5 - spot[1]).powi(2);
            let v = (250.0 * (-d2 / (2.0 * sigma * sigma)).exp()).round() as u8;
            let i = ((y * W + x) * 3) as usize;
            data[i..i + 3].copy_from_slice(&[v, v / 2, v / 4]);
        }
    }
    data
}

/// Centroid (x, y) in output pixels of the first channel above -1 (black).
fn centroid(t: &[f32], n: usize) -> [f64; 2] {
    let (mut sx, mut sy, mut s) = (0.0, 0.0, 0.0);
    for y in 0..n {
        for x in 0..n {
            let w = (t[y * n + x] as f64 + 1.0).max(0.0);
            sx += w * (x as f64 + 0.5);
            sy += w * (y as f64 + 0.5);
            s += w;
        }
    }
    [sx / s, sy / s]
}

fn rgb(data: &[u8]) -> FrameRef<'_> {
    FrameRef {
        width: W,
        height: H,
        format: PixelFormat::Rgb8,
        data,
        cutout: None,
    }
}

#[test]
fn the_crop_follows_the_optical_centre_not_the_image_centre() {
    // Spot at the optical centre, 30 px right of the image centre (the reference's shift).
    let centre = [350.0, 200.0];
    let data = spot_frame(centre, 4.0);
    let p = config(centre, 150.0, Colour::Grey, 64);
    let t = p.run(rgb(&data)).expect("preprocess");
    let c = centroid(&t[..64 * 64], 64);
    assert!(
        (c[0] - 32.0).abs() < 0.05 && (c[1] - 32.0).abs() < 0.05,
        "{c:?}"
    );
    // Outside the mask everything is black (-1 after normalisation), in every channel.
    for ch in 0..3 {
        assert_eq!(t[ch * 64 * 64], -1.0);
        assert_eq!(t[ch * 64 * 64 + 63], -1.0);
    }
}

#[test]
fn the_mask_blackens_everything_beyond_the_crop_radius() {
    let data = vec![200u8; (W * H * 3) as usize];
    let n = 100usize;
    let t = config([320.0, 200.0], 150.0, Colour::Rgb, n as u32)
        .run(rgb(&data))
        .expect("preprocess");
    let v = (200.0 / 255.0 - 0.5) / 0.5;
    for y in 0..n {
        for x in 0..n {
            let r = ((x as f64 + 0.5 - 50.0).powi(2) + (y as f64 + 0.5 - 50.0).powi(2)).sqrt();
            let got = t[y * n + x];
            if r < 46.0 {
                assert!((got - v).abs() < 1e-4, "inside at ({x},{y}): {got}");
            } else if r > 51.0 {
                assert_eq!(got, -1.0, "outside at ({x},{y})");
            }
        }
    }
}

#[test]
fn grey_is_the_itu_601_luma_repeated() {
    let data: Vec<u8> = (0..W * H).flat_map(|_| [200u8, 100, 50]).collect();
    let t = config([320.0, 200.0], 150.0, Colour::Grey, 32)
        .run(rgb(&data))
        .expect("preprocess");
    let luma = 0.299 * 200.0 + 0.587 * 100.0 + 0.114 * 50.0;
    let want = (luma / 255.0 - 0.5) / 0.5;
    let mid = 16 * 32 + 16;
    for ch in 0..3 {
        assert!((t[ch * 32 * 32 + mid] - want as f32).abs() < 1e-5);
    }
}

/// A smooth colour pattern as RGB8 and as its BayerRG8 mosaic.
fn pattern() -> (Vec<u8>, Vec<u8>) {
    let mut rgb = Vec::with_capacity((W * H * 3) as usize);
    let mut bayer = Vec::with_capacity((W * H) as usize);
    for y in 0..H {
        for x in 0..W {
            let (fx, fy) = (x as f64 / 37.0, y as f64 / 29.0);
            let p = [
                128.0 + 100.0 * fx.sin(),
                128.0 + 90.0 * (fy + 1.0).cos(),
                128.0 + 80.0 * (fx + fy).sin(),
            ]
            .map(|v: f64| v.round() as u8);
            rgb.extend_from_slice(&p);
            bayer.push(match (x & 1, y & 1) {
                (0, 0) => p[0],
                (1, 1) => p[2],
                _ => p[1],
            });
        }
    }
    (rgb, bayer)
}

#[test]
fn bayer_mono_and_rgb_frames_give_the_same_tensor_within_the_mosaic_error() {
    let (rgb_data, bayer) = pattern();
    for (colour, n) in [(Colour::Rgb, 64), (Colour::Grey, 64), (Colour::Rgb, 256)] {
        let p = config([322.0, 198.5], 160.0, colour, n);
        let a = p.run(rgb(&rgb_data)).expect("rgb");
        let b = p
            .run(FrameRef {
                width: W,
                height: H,
                format: PixelFormat::BayerRg8,
                data: &bayer,
                cutout: None,
            })
            .expect("bayer");
        // Inside the disc (the mask's edge falls on whole superpixels, so its last ring of
        // output pixels differs by how much of it the mosaic covers).
        let n = n as usize;
        let inside = |i: usize| {
            let (x, y) = ((i % (n * n)) % n, (i % (n * n)) / n);
            let r = (x as f64 + 0.5 - n as f64 / 2.0).hypot(y as f64 + 0.5 - n as f64 / 2.0);
            r < 0.45 * n as f64
        };
        let max = a
            .iter()
            .zip(&b)
            .enumerate()
            .filter(|(i, _)| inside(*i))
            .map(|(_, (x, y))| (x - y).abs())
            .fold(0.0, f32::max);
        // The superpixel (n = 64) and bilinear (n = 256, an upscale) paths both stay within a
        // few grey levels of the true colours on a smooth pattern.
        assert!(max < 0.06, "{colour:?} {n}: max difference {max}");
    }
    let grey: Vec<u8> = rgb_data.chunks_exact(3).map(|p| p[1]).collect();
    let green_rgb: Vec<u8> = grey.iter().flat_map(|&g| [g, g, g]).collect();
    let p = config([320.0, 200.0], 150.0, Colour::Grey, 48);
    let m = p
        .run(FrameRef {
            width: W,
            height: H,
            format: PixelFormat::Mono8,
            data: &grey,
            cutout: None,
        })
        .expect("mono");
    let r = p.run(rgb(&green_rgb)).expect("rgb");
    let max = m
        .iter()
        .zip(&r)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    assert!(max < 1e-4, "mono vs grey rgb: {max}");
}

#[test]
fn bad_frames_are_refused_with_what_is_wrong() {
    let p = config([320.0, 200.0], 150.0, Colour::Grey, 32);
    let data = vec![0u8; 10];
    let e = p.run(rgb(&data)).expect_err("short").to_string();
    assert!(e.contains("holds 10 bytes"), "{e}");
    let big = vec![0u8; 800 * 600 * 3];
    let e = p
        .run(FrameRef {
            width: 800,
            height: 600,
            format: PixelFormat::Rgb8,
            data: &big,
            cutout: None,
        })
        .expect_err("size")
        .to_string();
    assert!(
        e.contains("800x600") && e.contains("640x400") && e.contains("test"),
        "{e}"
    );
    let mut bad = p.clone();
    bad.crop_radius_px = f64::NAN;
    let e = Preprocessing::reference(ReferenceSensor::Layered, Colour::Grey, 4)
        .expect_err("size")
        .to_string();
    assert!(e.contains("input size 4"), "{e}");
    assert!(bad
        .run(rgb(&vec![0u8; (W * H * 3) as usize]))
        .is_err_and(|e| e.to_string().contains("crop radius")));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Turning the frame and its contact label together keeps them on each other: the spot
    /// of the turned frame lands where the turned label says.
    #[test]
    fn rotation_turns_image_and_label_together(
        angle in 0.0f64..360.0,
        r in 20.0f64..110.0,
        phi in 0.0f64..std::f64::consts::TAU,
    ) {
        let centre = [331.0, 197.0];
        // The label, in px (+y up in the camera view).
        let label = [r * phi.cos(), r * phi.sin()];
        let spot = [centre[0] + label[0], centre[1] - label[1]];
        let data = spot_frame(spot, 3.0);
        let n = 128usize;
        let radius = 150.0;
        let mut pre = Preprocessor::new(config(centre, radius, Colour::Grey, n as u32));
        let mut t = vec![0.0; 3 * n * n];
        pre.run_into(rgb(&data), angle, &mut t).expect("preprocess");
        let got = centroid(&t[..n * n], n);
        let turned = rotate_contact(label, angle);
        let k = n as f64 / (2.0 * radius);
        let want = [n as f64 / 2.0 + turned[0] * k, n as f64 / 2.0 - turned[1] * k];
        prop_assert!(
            (got[0] - want[0]).abs() < 0.15 && (got[1] - want[1]).abs() < 0.15,
            "angle {angle}: spot at {got:?}, label says {want:?}"
        );
    }
}
