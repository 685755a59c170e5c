//! Accuracy of the image-to-stage registration on simulated presses against the simulator's
//! ground truth (`SensorGeometry`: px/mm, rotation, mirror, optical centre): both sensor
//! variants, sharp and heavily blurred (10 px), rotated by 3-7 degrees, mirrored and not, with
//! each indenter (pentagon, rectangle, circular flat punch, sphere) pressing lightly (1.2-1.8 N)
//! on a 3x3 grid over +-6 mm about the centre. Stage positions are the sensor-frame positions plus
//! a stage origin, so the true contact origin is that origin.
//!
//! The background is 4 no-contact frames; each press is located in the mean of 2 frames of its
//! dwell; the optical centre and crop radius come from the optical fit of the background. Also:
//! a misrecorded press is flagged as an outlier, a press that missed the sensor is an error, and
//! presses ever closer to the crop edge are either located within 0.1 mm or refused.
//!
//! `cargo test -p fringe-calibration --test registration_accuracy -- --nocapture` prints the
//! table; `FRINGE_REG_PLOTS=DIR` also writes each case's residual plot and a located press.

use fringe_calibration::draw_spot;
use fringe_calibration::register;
use fringe_calibration::residual_plot;
use fringe_calibration::ContactError;
use fringe_calibration::{find_disc, GreyImage};
use fringe_calibration::{ContactBackground, SpotSettings};
use fringe_calibration::{FitSettings, Press};
use fringe_rig::{Millimetres, Newtons};
use fringe_sim::Renderer;
use fringe_sim::Shape;
use fringe_sim::{Contact, FrameRenderer, Scene};
use fringe_sim::{SensorConfig, Variant};
use image::RgbImage;

const BACKGROUND_FRAMES: u64 = 4;
const FRAMES_PER_PRESS: u64 = 2;

#[derive(Clone, Copy)]
enum Indenter {
    Pentagon,
    Rectangle,
    Circle,
    Sphere,
}

struct Case {
    name: &'static str,
    config: SensorConfig,
    indenter: Indenter,
    /// Stage position over the sensor centre, mm: the true contact origin.
    stage_origin: [f64; 2],
    /// Extra presses: (sensor-frame position, recorded stage error mm).
    extra: Vec<([f64; 2], [f64; 2])>,
    /// Held to the targets (px/mm 0.5 %, rotation 0.2 deg, origin 0.05 mm, each contact 0.1 mm);
    /// otherwise a known limit, held to 3 %, 1 deg, 0.2 mm (mirror right either way).
    strict: bool,
}

fn render(r: &mut Renderer, contact: Option<Contact>, index: u64) -> RgbImage {
    let mut rgb = Vec::new();
    r.render(&Scene { contact }, index, &mut rgb);
    RgbImage::from_raw(r.width(), r.height(), rgb).expect("frame size")
}

fn shape(c: &SensorConfig, i: Indenter, force: f64) -> Shape {
    match i {
        Indenter::Pentagon => c.pentagon(),
        Indenter::Rectangle => c.rectangle(),
        Indenter::Circle => Shape::Circle { radius_mm: 3.0 },
        Indenter::Sphere => c.sphere(force),
    }
}

struct Prepared {
    renderer: Renderer,
    background: ContactBackground,
    centre: [f64; 2],
    sigma_centre: [f64; 2],
    crop: f64,
    first_frame: RgbImage,
}

fn prepare(config: SensorConfig) -> Prepared {
    let variant = config.variant;
    let mut renderer = Renderer::new(config).expect("valid sensor");
    let frames: Vec<RgbImage> = (0..BACKGROUND_FRAMES)
        .map(|k| render(&mut renderer, None, k))
        .collect();
    let grey: Vec<GreyImage> = frames
        .iter()
        .map(|f| GreyImage::from_image(&image::DynamicImage::ImageRgb8(f.clone())))
        .collect();
    let disc = find_disc(&grey).expect("optical fit");
    let centre = [disc.centre_x, disc.centre_y];
    let settings = match variant {
        Variant::Layered => SpotSettings::layered(),
        Variant::Integrated => SpotSettings::integrated(),
    };
    let background = ContactBackground::new(&frames, centre, disc.crop_radius, disc.outside_dn)
        .expect("background")
        .with_settings(settings);
    Prepared {
        renderer,
        background,
        centre,
        sigma_centre: [disc.sigma_x, disc.sigma_y],
        crop: disc.crop_radius,
        first_frame: frames[0].clone(),
    }
}

/// Runs one case, prints its row, checks the bounds; returns the outlier flags.
fn run(case: Case) -> Vec<bool> {
    let t0 = std::time::Instant::now();
    let mut prep = prepare(case.config.clone());
    let truth = prep.renderer.geometry();
    let mut points: Vec<([f64; 2], [f64; 2])> = Vec::new();
    for j in -1..=1 {
        for i in -1..=1 {
            points.push(([6.0 * i as f64, 6.0 * j as f64], [0.0, 0.0]));
        }
    }
    points.extend(case.extra.iter().copied());
    let mut presses = Vec::new();
    let mut stage = Vec::new();
    let mut worst_spot: f64 = 0.0;
    let mut sum_spot2 = 0.0;
    let mut worst_sigma: f64 = 0.0;
    let mut last_pressed = None;
    for (n, (sensor, stage_error)) in points.iter().enumerate() {
        let force = 1.2 + 0.6 * ((n * 7) % 9) as f64 / 8.0;
        let contact = Contact {
            shape: shape(&case.config, case.indenter, force),
            force: Newtons(force),
            x: Millimetres(sensor[0]),
            y: Millimetres(sensor[1]),
            angle_deg: 0.0,
            shear: None,
        };
        let frames: Vec<RgbImage> = (0..FRAMES_PER_PRESS)
            .map(|k| render(&mut prep.renderer, Some(contact), 100 + 10 * n as u64 + k))
            .collect();
        let spot = prep
            .background
            .locate(&frames)
            .unwrap_or_else(|e| panic!("{}: press {n} at {sensor:?}: {e}", case.name));
        let want = truth.to_pixel(sensor[0], sensor[1]);
        let err = (spot.u_px - want[0]).hypot(spot.v_px - want[1]);
        if std::env::var("FRINGE_REG_VERBOSE").is_ok() {
            println!(
                "  {} press {n} at {sensor:?}: seen ({:.2}, {:.2}) truth ({:.2}, {:.2}) err {err:.2} px sigma {:.3} window {:.0} r90 {:.0} bins {} snr {:.0}",
                case.name, spot.u_px, spot.v_px, want[0], want[1], spot.sigma_px(), spot.window_px, spot.r90_px, spot.bins, spot.snr
            );
        }
        if let (Ok(dir), 0 | 8) = (std::env::var("FRINGE_REG_PLOTS"), n) {
            let slug: String = case
                .name
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
                .collect();
            let dir = std::path::PathBuf::from(dir);
            let pat = prep.background.pattern_image(&frames).expect("pattern");
            let (bu, bv) = ((want[0] / 4.0) as u32 - 50, (want[1] / 4.0) as u32 - 50);
            let crop = image::imageops::crop_imm(&pat, bu, bv, 100, 100).to_image();
            image::imageops::resize(&crop, 400, 400, image::imageops::FilterType::Nearest)
                .save(dir.join(format!("{slug}-pattern-{n}.png")))
                .expect("write pattern");
            image::imageops::crop_imm(&frames[0], bu * 4, bv * 4, 400, 400)
                .to_image()
                .save(dir.join(format!("{slug}-frame-{n}.png")))
                .expect("write frame");
        }
        if stage_error == &[0.0, 0.0] {
            worst_spot = worst_spot.max(err);
            sum_spot2 += err * err;
        }
        worst_sigma = worst_sigma.max(spot.sigma_px());
        let st = [
            sensor[0] + case.stage_origin[0] + stage_error[0],
            sensor[1] + case.stage_origin[1] + stage_error[1],
        ];
        presses.push(Press {
            stage_mm: st,
            pixel: [spot.u_px, spot.v_px],
            sigma_px: spot.sigma_px(),
        });
        stage.push(st);
        last_pressed = Some((frames[0].clone(), spot));
    }
    let reg = register(
        &presses,
        prep.centre,
        prep.sigma_centre,
        &FitSettings::default(),
    )
    .unwrap_or_else(|e| panic!("{}: {e}", case.name));
    let f = &reg.fit;
    let scale_err = (f.px_per_mm - truth.px_per_mm) / truth.px_per_mm;
    let rot_err = (f.rotation_deg - truth.rotation_deg + 540.0).rem_euclid(360.0) - 180.0;
    let o = reg.contact_origin_stage_mm;
    let origin_err = (o[0] - case.stage_origin[0]).hypot(o[1] - case.stage_origin[1]);
    let clean = points.iter().filter(|p| p.1 == [0.0, 0.0]).count();
    println!(
        "| {} | {}/{} | {:.3} ({:.3}) | {:+.3} % (sigma {:.3} %) | {:+.3} (sigma {:.3}) | {} ({}) | {:.4} (sigma {:.4}, {:.4}) | {:.3} | {:.0} | {:.1} s |",
        case.name,
        f.inliers,
        presses.len(),
        (sum_spot2 / clean as f64).sqrt(),
        worst_spot,
        100.0 * scale_err,
        100.0 * f.sigma_px_per_mm / f.px_per_mm,
        rot_err,
        f.sigma_rotation_deg,
        f.mirror,
        if f.mirror == truth.mirror { "right" } else { "WRONG" },
        origin_err,
        reg.sigma_contact_origin_stage_mm[0],
        reg.sigma_contact_origin_stage_mm[1],
        f.residual_rms_px,
        f.mirror_chi2.min(1e9),
        t0.elapsed().as_secs_f64(),
    );
    if let Ok(dir) = std::env::var("FRINGE_REG_PLOTS") {
        let dir = std::path::PathBuf::from(dir);
        let slug: String = case
            .name
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
            .collect();
        residual_plot(f, &stage)
            .expect("draw plot")
            .save(dir.join(format!("{slug}-residuals.png")))
            .expect("write plot");
        if let Some((frame, spot)) = last_pressed {
            draw_spot(&frame, &spot, [255, 255, 0])
                .expect("draw press")
                .save(dir.join(format!("{slug}-press.png")))
                .expect("write press");
        }
    }
    assert_eq!(f.mirror, truth.mirror, "{}: mirror wrong", case.name);
    if !case.strict {
        assert!(
            scale_err.abs() < 0.03 && rot_err.abs() < 1.0 && origin_err < 0.2,
            "{}: beyond its known limit",
            case.name
        );
        return f.residuals.iter().map(|r| r.outlier).collect();
    }
    assert!(
        scale_err.abs() < 0.005,
        "{}: px/mm off by {:.3} %",
        case.name,
        100.0 * scale_err
    );
    assert!(
        rot_err.abs() < 0.2,
        "{}: rotation off by {rot_err:.3} deg",
        case.name
    );
    assert!(
        origin_err < 0.05,
        "{}: contact origin off by {origin_err:.4} mm",
        case.name
    );
    assert!(
        worst_spot < 0.1 * truth.px_per_mm,
        "{}: a contact off by {worst_spot:.2} px",
        case.name
    );
    assert!(prep.crop > 0.0);
    f.residuals.iter().map(|r| r.outlier).collect()
}

fn config(
    base: SensorConfig,
    blur: f64,
    rotation: f64,
    mirror: bool,
    px_per_mm: f64,
) -> SensorConfig {
    let mut c = base;
    c.optics.blur_px = blur;
    c.geometry.rotation_deg = rotation;
    c.geometry.mirror = mirror;
    c.geometry.px_per_mm = px_per_mm;
    c
}

#[test]
fn layered_sharp_and_heavy_blur() {
    let outliers = run(Case {
        name: "layered, sharp, pentagon, rot 5, mirrored",
        config: config(SensorConfig::layered(), 0.0, 5.0, true, 18.3),
        indenter: Indenter::Pentagon,
        stage_origin: [23.4, 18.9],
        // One press recorded 0.5 mm off in stage x: must be flagged.
        extra: vec![([3.0, -3.0], [0.5, 0.0])],
        strict: true,
    });
    assert_eq!(outliers.iter().filter(|&&o| o).count(), 1);
    assert!(outliers[9], "the misrecorded press is not the one flagged");
    let outliers = run(Case {
        name: "layered, blur 10 px, rectangle, rot -4, not mirrored",
        config: config(SensorConfig::layered(), 10.0, -4.0, false, 17.2),
        indenter: Indenter::Rectangle,
        stage_origin: [21.0, 26.5],
        extra: vec![],
        strict: true,
    });
    assert!(outliers.iter().all(|&o| !o), "{outliers:?}");
}

#[test]
fn layered_circle_and_sphere() {
    let outliers = run(Case {
        name: "layered, sharp, circle r 3 mm, rot 3, not mirrored",
        config: config(SensorConfig::layered(), 0.0, 3.0, false, 18.3),
        indenter: Indenter::Circle,
        stage_origin: [24.8, 20.1],
        extra: vec![],
        strict: true,
    });
    assert!(outliers.iter().all(|&o| !o), "{outliers:?}");
    let outliers = run(Case {
        name: "layered, blur 4 px, sphere r 5 mm, rot 7, mirrored",
        config: config(SensorConfig::layered(), 4.0, 7.0, true, 18.3),
        indenter: Indenter::Sphere,
        stage_origin: [19.6, 23.3],
        extra: vec![],
        strict: true,
    });
    assert!(outliers.iter().all(|&o| !o), "{outliers:?}");
}

#[test]
fn integrated_sharp_and_heavy_blur() {
    let outliers = run(Case {
        name: "integrated, blur 3 px, sphere r 5 mm, rot -6, mirrored",
        config: config(SensorConfig::integrated(), 3.0, -6.0, true, 18.3),
        indenter: Indenter::Sphere,
        stage_origin: [22.2, 19.7],
        extra: vec![],
        strict: true,
    });
    assert!(outliers.iter().all(|&o| !o), "{outliers:?}");
    let outliers = run(Case {
        name: "integrated, sharp, circle r 3 mm, rot 6.5, not mirrored",
        config: config(SensorConfig::integrated(), 0.0, 6.5, false, 18.3),
        indenter: Indenter::Circle,
        stage_origin: [24.1, 17.3],
        extra: vec![],
        strict: true,
    });
    assert!(outliers.iter().all(|&o| !o), "{outliers:?}");
    let outliers = run(Case {
        name: "integrated, blur 10 px, pentagon, rot 3, mirrored",
        config: config(SensorConfig::integrated(), 10.0, 3.0, true, 19.1),
        indenter: Indenter::Pentagon,
        stage_origin: [25.0, 25.0],
        extra: vec![],
        strict: true,
    });
    assert!(outliers.iter().all(|&o| !o), "{outliers:?}");
}

#[test]
fn a_press_that_missed_the_sensor_is_an_error() {
    let mut prep = prepare(config(SensorConfig::layered(), 0.0, 5.0, true, 18.3));
    let missed = Contact {
        shape: prep.renderer.config().pentagon(),
        force: Newtons(1.5),
        x: Millimetres(45.0),
        y: Millimetres(0.0),
        angle_deg: 0.0,
        shear: None,
    };
    let frames: Vec<RgbImage> = (0..2)
        .map(|k| render(&mut prep.renderer, Some(missed), 50 + k))
        .collect();
    let e = prep.background.locate(&frames).expect_err("no contact");
    println!("press off the disc: {e}");
    assert!(matches!(e, ContactError::NoContact { .. }), "{e}");
    // A plain no-contact frame of a later moment (drifted gain and offset) too.
    let e = prep
        .background
        .locate(&[render(&mut prep.renderer, None, 77)])
        .expect_err("no contact");
    assert!(matches!(e, ContactError::NoContact { .. }), "{e}");
    // And the first background frame itself.
    let e = prep
        .background
        .locate(std::slice::from_ref(&prep.first_frame))
        .expect_err("no contact");
    assert!(e.to_string().starts_with("no contact visible"), "{e}");
}

#[test]
fn presses_towards_the_crop_edge_are_located_or_refused() {
    for (base, settings_name) in [
        (SensorConfig::layered(), "layered"),
        (SensorConfig::integrated(), "integrated"),
    ] {
        let mut prep = prepare(config(base, 0.0, 5.0, true, 18.3));
        let truth = prep.renderer.geometry();
        let crop_mm = prep.crop / truth.px_per_mm;
        let mut located_to_12 = 0;
        for r_mm in [8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0] {
            let (x, y) = (r_mm * 0.6, -r_mm * 0.8);
            let c = Contact {
                shape: prep.renderer.config().pentagon(),
                force: Newtons(1.5),
                x: Millimetres(x),
                y: Millimetres(y),
                angle_deg: 0.0,
                shear: None,
            };
            let frames: Vec<RgbImage> = (0..2)
                .map(|k| render(&mut prep.renderer, Some(c), 300 + k))
                .collect();
            let want = truth.to_pixel(x, y);
            match prep.background.locate(&frames) {
                Ok(s) => {
                    let err = (s.u_px - want[0]).hypot(s.v_px - want[1]);
                    println!(
                        "{settings_name} (crop {crop_mm:.1} mm): press {r_mm} mm from the centre: error {err:.2} px, sigma {:.2} px, window {:.0} px",
                        s.sigma_px(),
                        s.window_px
                    );
                    // Located means located: never silently off.
                    assert!(
                        err < 0.1 * truth.px_per_mm,
                        "{settings_name}: press at {r_mm} mm off by {err:.2} px"
                    );
                    if r_mm <= 12.0 {
                        located_to_12 += 1;
                    }
                }
                Err(e) => {
                    println!("{settings_name} (crop {crop_mm:.1} mm): press {r_mm} mm from the centre: {e}");
                    assert!(
                        matches!(
                            e,
                            ContactError::OutlineCut { .. } | ContactError::NearCropEdge { .. }
                        ),
                        "{e}"
                    );
                }
            }
        }
        assert_eq!(
            located_to_12, 3,
            "{settings_name}: presses within 12 mm must be located"
        );
    }
}
