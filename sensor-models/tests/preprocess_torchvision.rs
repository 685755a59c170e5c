//! Reference mode against the reference pipeline's own tensors (PIL + torchvision, run by
//! `tests/python/reference_preprocess.py`): the difference is stated in `preprocess.rs`.

mod common;

use fringe_rig::PixelFormat;
use fringe_sensor_models::{Colour, FrameRef, Preprocessing, ReferenceSensor};
use std::process::Command;

/// A 1920x1200 frame of fine colour fringes about an off-centre disc, with noise.
fn fringe_frame() -> Vec<u8> {
    let (w, h) = (1920usize, 1200usize);
    let mut data = Vec::with_capacity(w * h * 3);
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f64 - 990.0, y as f64 - 610.0);
            let r = (dx * dx + dy * dy).sqrt();
            let phase = r / 6.5 + 0.002 * dx * dy / 40.0;
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let noise = (seed % 9) as f64 - 4.0;
            let px = [
                128.0 + 110.0 * phase.sin() + noise,
                128.0 + 100.0 * (1.3 * phase).cos() + noise,
                120.0 + 90.0 * (0.7 * phase + 1.0).sin() + noise,
            ];
            data.extend(px.map(|v: f64| v.round().clamp(0.0, 255.0) as u8));
        }
    }
    data
}

#[test]
fn reference_mode_matches_torchvision() {
    let python = common::torch_python();
    let dir = common::scratch("torchvision");
    let data = fringe_frame();
    let png = dir.join("frame.png");
    image::RgbImage::from_raw(1920, 1200, data.clone())
        .expect("image")
        .save(&png)
        .expect("save");
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/python/reference_preprocess.py"
    );
    for (sensor, colour) in [
        (ReferenceSensor::Layered, Colour::Grey),
        (ReferenceSensor::Integrated, Colour::Grey),
        (ReferenceSensor::Layered, Colour::Rgb),
    ] {
        let out = dir.join("ref.f32");
        let mut cmd = Command::new(&python);
        cmd.arg(script)
            .arg(&png)
            .arg(&out)
            .args(["--diameter", &format!("{}", sensor.crop_diameter_px())]);
        if colour == Colour::Rgb {
            cmd.arg("--rgb");
        }
        let status = cmd.status().expect("run python");
        assert!(status.success(), "reference_preprocess.py failed");
        let bytes = std::fs::read(&out).expect("read tensor");
        let want: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let p = Preprocessing::reference(sensor, colour, 224).expect("config");
        let got = p
            .run(FrameRef {
                width: 1920,
                height: 1200,
                format: PixelFormat::Rgb8,
                data: &data,
                cutout: None,
            })
            .expect("preprocess");
        assert_eq!(got.len(), want.len());
        let diffs: Vec<f32> = got.iter().zip(&want).map(|(a, b)| (a - b).abs()).collect();
        let max = diffs.iter().copied().fold(0.0, f32::max);
        let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
        let step = 2.0 / 255.0; // one 8-bit level after normalisation
        let off = diffs.iter().filter(|d| **d > 1e-6).count() as f64 / diffs.len() as f64;
        eprintln!(
            "{sensor:?} {colour:?}: max |diff| {max:.5} ({:.2} levels), mean {mean:.6}, {:.3} % of values differ",
            max / step,
            100.0 * off
        );
        // PIL rounds with fixed-point weights and the mask edge is rasterised: at most one
        // 8-bit level apart, and rarely.
        assert!(max <= step * 1.01, "max difference {max}");
        assert!(off < 0.005, "{:.3} % of values differ", 100.0 * off);
    }
}
