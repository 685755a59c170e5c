#![cfg(feature = "sim")]
//! The health check's no-contact figures on frames the simulator renders of the `layered-3` unit
//! at half the frame size, as a rig file's `[sim.ageing]` ages it: in ten sessions each (the
//! camera's noise and drift of another session), an unchanged unit raises no figure, and a camera
//! knocked by 5 px (of the full frame), a dead LED and a scratch across the disc are each told
//! apart with the right verdict and the figure behind it, with the default thresholds. (The F/T
//! zero and the model's errors need the bench: `tui/tests/check_cli.rs` and
//! `scripts/health-trials`.)

use fringe_app::health::{assess, Measured, Thresholds, Verdict};
use fringe_app::RigConfig;
use fringe_calibration::health::Change;
use fringe_calibration::health::Signature;
use fringe_calibration::GreyImage;
use fringe_sim::Renderer;
use fringe_sim::{FrameRenderer, Scene};
use std::path::Path;

/// No-contact frames measured per signature (a check measures up to 24).
const FRAMES: u64 = 8;

/// The unit's rig at half the frame size, in `session`, aged by `ageing` (a `[sim.ageing]` body).
fn rig(session: u64, ageing: &str) -> RigConfig {
    let sensor = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../rig/sim/sensors/layered-3.toml");
    let text = format!(
        "[sim]\nsensor = \"{}\"\nimage_scale = 0.5\nsession = {session}\n[sim.ageing]\n{ageing}",
        sensor.display()
    );
    RigConfig::parse(&text, "health-signals.toml").expect("rig")
}

/// The signature of no-contact frames of the unit as `rig` builds it, frames spread over a
/// minute of the session.
fn signature(rig: &RigConfig, session: u64) -> Signature {
    let built = fringe_app::rig::sim_config(rig)
        .expect("sim config")
        .as_built()
        .expect("as built");
    let mut renderer = Renderer::new(built.sensor).expect("renderer");
    renderer.set_session(session);
    let (w, h) = (renderer.width() as usize, renderer.height() as usize);
    let frames: Vec<GreyImage> = (0..FRAMES)
        .map(|k| {
            let mut rgb = Vec::new();
            renderer.render(&Scene { contact: None }, 100 + 400 * k, &mut rgb);
            let grey = rgb
                .chunks(3)
                .map(|p| (f32::from(p[0]) + f32::from(p[1]) + f32::from(p[2])) / 3.0)
                .collect();
            GreyImage::from_values(w, h, grey).expect("frame")
        })
        .collect();
    Signature::of_frames("rendered".into(), &frames).expect("signature")
}

/// The verdict and its figure for the unit aged by `ageing`, against the unit as accepted (in
/// session 0), in `session`.
fn judged(accepted: &Signature, session: u64, ageing: &str) -> (Verdict, String) {
    let now = signature(&rig(session, ageing), session);
    let change = Change::between(accepted, &now).expect("change");
    let a = assess(
        &Measured {
            change: &change,
            radius_px: accepted.fit.radius,
            radius_sigma_px: accepted.fit.sigma_radius.hypot(now.fit.sigma_radius),
            force_offset_n: None,
            model_now: None,
            model_then: None,
        },
        &Thresholds::default(),
    );
    (a.verdict, a.cause)
}

fn trials(ageing: &str, want: Verdict, cause: &str) {
    let accepted = signature(&rig(0, ""), 0);
    let right = (1..=10)
        .filter(|&s| {
            let got = judged(&accepted, s, ageing);
            let ok = got.0 == want && got.1 == cause;
            if !ok {
                eprintln!("session {s}: {got:?}");
            }
            ok
        })
        .count();
    assert!(right >= 9, "{ageing:?}: {right} of 10 right");
}

#[test]
fn an_unchanged_unit_raises_no_figure_in_ten_sessions() {
    let accepted = signature(&rig(0, ""), 0);
    for s in 1..=10 {
        assert_eq!(
            judged(&accepted, s, ""),
            (Verdict::Ok, String::new()),
            "session {s}"
        );
    }
}

#[test]
fn a_knocked_camera_is_to_be_calibrated_again() {
    trials(
        "camera_shift_px = [5.0, 0.0]\n",
        Verdict::Recalibrate,
        "centre_shift_px",
    );
}

#[test]
fn a_dead_led_is_to_be_repaired() {
    trials("leds_out = [3]\n", Verdict::Replace, "darkest_rim");
}

#[test]
fn a_scratch_across_the_disc_is_to_be_replaced() {
    trials(
        "[[sim.ageing.scratches]]\nfrom_mm = [-20.0, -8.0]\nto_mm = [20.0, 8.0]\n",
        Verdict::Replace,
        "surface_cells",
    );
}
