//! Tests of [`super`] (in a file of their own: they use the crate's test helpers, which use
//! the renderer).

use super::*;
use crate::optics::render::Renderer;
use crate::optics::sensor::SensorConfig;
use crate::physics::ft_sensor::{FtNoiseConfig, SimFtSensor};
use crate::scene::FrameRenderer;
use crate::scene::{ForceReading, LoadSource};
use crate::test_support::{disc_pixels, grey, quiet, render, small};
use fringe_rig::HostTime;
use fringe_rig::Wrench;
use std::sync::Arc;

#[test]
fn session_zero_keeps_the_seed_and_others_change_it() {
    for seed in [0, 1, 7, u64::MAX] {
        assert_eq!(salted(seed, 0), seed);
        assert_ne!(salted(seed, 1), seed);
        assert_ne!(salted(seed, 1), salted(seed, 2));
        assert_eq!(salted(seed, 3), salted(seed, 3));
    }
    assert_eq!(drift_frames(0), 0);
    assert_ne!(drift_frames(1), drift_frames(2));
    assert!(drift_frames(5) < 1_000_000);
}

#[test]
fn session_zero_renders_the_bytes_of_a_renderer_that_never_heard_of_sessions() {
    let c = small(SensorConfig::layered());
    let mut plain = Renderer::new(c.clone()).expect("renderer");
    let mut zero = Renderer::new(c).expect("renderer");
    zero.set_session(4);
    let other = render(&mut zero, None, 9);
    zero.set_session(0);
    for frame in [0, 9, 1234] {
        assert!(render(&mut plain, None, frame) == render(&mut zero, None, frame));
    }
    assert!(render(&mut plain, None, 9) != other);
}

#[test]
fn two_sessions_film_the_same_unit_with_other_noise() {
    let mut c = small(SensorConfig::layered());
    // Drift off: the sessions' mean images then agree within the noise's own spread.
    c.noise.gain_drift = 0.0;
    c.noise.offset_drift_dn = 0.0;
    c.noise.flicker = 0.0;
    let mut clean = Renderer::new(quiet(SensorConfig::layered())).expect("renderer");
    let truth = render(&mut clean, None, 0);
    let mut r = Renderer::new(c).expect("renderer");
    let pixels = disc_pixels(&r, 0.9);
    let w = r.width() as usize;
    let mean = |img: &[u8]| {
        pixels.iter().map(|&(i, j)| grey(img, w, i, j)).sum::<f64>() / pixels.len() as f64
    };
    let mut frames = Vec::new();
    for session in [1, 2] {
        r.set_session(session);
        frames.push(render(&mut r, None, 5));
        // The same session, frame and scene: the same bytes.
        assert!(render(&mut r, None, 5) == frames[frames.len() - 1]);
    }
    let differ = pixels
        .iter()
        .filter(|&&(i, j)| grey(&frames[0], w, i, j) != grey(&frames[1], w, i, j))
        .count();
    let (m1, m2, m0) = (mean(&frames[0]), mean(&frames[1]), mean(&truth));
    eprintln!(
        "{differ} of {} disc pixels differ; means {m1} {m2}, noise-free {m0}",
        pixels.len()
    );
    assert!(differ > pixels.len() / 2, "{differ}");
    assert!(
        (m1 - m2).abs() < 0.3 && (m1 - m0).abs() < 0.3,
        "{m1} {m2} {m0}"
    );
}

struct Still;
impl LoadSource for Still {
    fn true_wrench_at(&self, _t: HostTime) -> Wrench {
        Wrench::default()
    }
}

fn readings(config: FtNoiseConfig) -> (Wrench, Vec<f64>) {
    let mut s = SimFtSensor::new(Arc::new(Still), config);
    let fz = (0..2000)
        .map(|k| s.reading_at(HostTime(1_000_000_000 + k * 200_000)).fz.0)
        .collect();
    (s.bias(), fz)
}

#[test]
fn sessions_keep_the_ft_bias_and_change_its_noise() {
    let base = FtNoiseConfig::default();
    let (bias0, zero) = readings(base);
    let (bias_default, again) = readings(FtNoiseConfig { session: 0, ..base });
    assert_eq!((bias0, &zero), (bias_default, &again));
    let (bias1, one) = readings(FtNoiseConfig { session: 1, ..base });
    let (bias2, two) = readings(FtNoiseConfig { session: 2, ..base });
    assert_eq!(bias1, bias0);
    assert_eq!(bias2, bias0);
    assert_ne!(one, two);
    assert_ne!(one, zero);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    // 2000 samples of sigma 0.05 N over 0.4 s of drift: the means agree within 0.02 N.
    assert!(
        (mean(&one) - mean(&two)).abs() < 0.02,
        "{} {}",
        mean(&one),
        mean(&two)
    );
    assert!((mean(&one) - bias0.fz.0).abs() < 0.02);
}
