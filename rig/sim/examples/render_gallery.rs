//! The contact sheet of simulated frames in the README (docs/img/sim-frames.png).
//!
//! `cargo run --release -p fringe-sim --example render_gallery [-- OUT.png]`
//!
//! Rows: layered pentagon, layered rectangle, integrated pentagon, integrated rectangle. Columns:
//! 1, 4 and 9 N. Every frame is a full 1920x1200 render with the shipped sensor defaults (noise,
//! LED hot spots, drift, seed 1, frame 0) of a contact at (4, 3) mm turned by 15 degrees, cropped
//! to the disc and its LED ring and downscaled to 320x320.

use fringe_rig::{Millimetres, Newtons};
use fringe_sim::Renderer;
use fringe_sim::SensorConfig;
use fringe_sim::{Contact, FrameRenderer, Scene};
use image::imageops::FilterType;
use image::RgbImage;

const TILE: u32 = 320;
const FORCES: [f64; 3] = [1.0, 4.0, 9.0];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "docs/img/sim-frames.png".into());
    let mut sheet = RgbImage::new(TILE * FORCES.len() as u32, TILE * 4);
    let mut row = 0;
    for config in [SensorConfig::layered(), SensorConfig::integrated()] {
        let mut renderer = Renderer::new(config)?;
        let g = renderer.geometry();
        // Square around the optical centre that holds the disc and the LED ring.
        let (cu, cv) = (g.centre_px[0].round() as u32, g.centre_px[1].round() as u32);
        let (w, h) = (renderer.width(), renderer.height());
        let half = ((1.1 * renderer.config().geometry.disc_radius_px).round() as u32)
            .min(cv)
            .min(h - cv);
        let shapes = [renderer.config().pentagon(), renderer.config().rectangle()];
        for shape in shapes {
            for (col, &force) in FORCES.iter().enumerate() {
                let contact = Contact {
                    shape,
                    force: Newtons(force),
                    x: Millimetres(4.0),
                    y: Millimetres(3.0),
                    angle_deg: 15.0,
                    shear: None,
                };
                let mut rgb = Vec::new();
                renderer.render(
                    &Scene {
                        contact: Some(contact),
                    },
                    0,
                    &mut rgb,
                );
                let frame = RgbImage::from_raw(w, h, rgb).ok_or("frame size mismatch")?;
                let (u0, v0) = (cu.saturating_sub(half), cv.saturating_sub(half));
                let side = (2 * half).min(w - u0).min(h - v0);
                let crop = image::imageops::crop_imm(&frame, u0, v0, side, side).to_image();
                let tile = image::imageops::resize(&crop, TILE, TILE, FilterType::Triangle);
                image::imageops::replace(
                    &mut sheet,
                    &tile,
                    i64::from(col as u32 * TILE),
                    i64::from(row * TILE),
                );
            }
            row += 1;
        }
    }
    sheet.save(&out)?;
    println!("wrote {out}");
    Ok(())
}
