//! Force offsets against the simulated F/T sensor (`fringe_sim::SimFtSensor`: 0.05 N white
//! noise, random-walk drift, a power-up bias) with a known added linear drift: the bias within
//! 0.01 N of the truth, the drift slope recovered, the zero-load check warning after a power
//! cycle.

use fringe_calibration::{
    offsets::{bias, drift, zero_load_check, Bias, ForceOffsets},
    ZeroTolerance,
};
use fringe_rig::HostTime;
use fringe_rig::Wrench;
use fringe_sim::{ForceReading, LoadSource};
use fringe_sim::{FtNoiseConfig, SimFtSensor};
use std::sync::Arc;

struct NoContact;
impl LoadSource for NoContact {
    fn true_wrench_at(&self, _t: HostTime) -> Wrench {
        Wrench::default()
    }
}

/// A 0.2 s no-contact window at 5 kHz starting at `t0` s.
fn window(s: &mut SimFtSensor, t0: f64) -> Vec<(f64, Wrench)> {
    (0..1000)
        .map(|k| {
            let t = t0 + k as f64 / 5000.0;
            (t, s.reading_at(HostTime((t * 1e9) as u64)))
        })
        .collect()
}

#[test]
fn bias_within_0_01_n_and_drift_slope_recovered() {
    let mut worst = 0.0f64;
    for seed in 1..=5 {
        let cfg = FtNoiseConfig {
            seed,
            ..FtNoiseConfig::default()
        };
        let mut s = SimFtSensor::new(Arc::new(NoContact), cfg);
        let w = window(&mut s, 1.0);
        let b = bias(&w).expect("samples");
        // Truth: power-up bias plus the drift accumulated in the 0.2 s window (a few mN).
        let truth = s.bias().to_array();
        let d = s.drift().to_array();
        for ch in 0..3 {
            let err = (b.mean[ch] - truth[ch] - 0.5 * d[ch]).abs();
            worst = worst.max(err);
            assert!(err < 0.01, "seed {seed} {ch}: {err}");
            // 0.05 N / sqrt(1000)
            assert!((b.standard_error[ch] - 0.0016).abs() < 0.0004, "{b:?}");
        }
    }
    println!("worst bias error over 5 power-ups: {worst:.4} N");

    // A run of 600 s with a retract every 30 s and a known linear drift of 2 mN/s added to Fz on
    // top of the sensor's own random walk (5 mN/sqrt(s), ~0.12 N over the run).
    let mut s = SimFtSensor::new(Arc::new(NoContact), FtNoiseConfig::default());
    let slope = 0.002;
    let mut truth_offsets = Vec::new();
    let biases: Vec<_> = (0..20)
        .map(|k| {
            let t0 = 30.0 * k as f64;
            let mut w = window(&mut s, t0);
            for (t, x) in w.iter_mut() {
                x.fz.0 += slope * *t;
            }
            let b = bias(&w).expect("samples");
            truth_offsets.push(Bias {
                mean: std::array::from_fn(|i| {
                    s.bias().to_array()[i]
                        + s.drift().to_array()[i]
                        + if i == 2 { slope * b.t_s } else { 0.0 }
                }),
                standard_error: [1e-3; 6],
                ..b
            });
            b
        })
        .collect();
    let d = drift(&biases).expect("fit");
    // The line through the true offsets (bias + walk + added drift) at the same times.
    let t = drift(&truth_offsets).expect("truth fit");
    println!(
        "Fz drift slope {:.6} +- {:.6} N/s; true offsets' line {:.6} N/s (added {slope}); residual {:.4} N",
        d.slope_per_s[2], d.slope_sigma[2], t.slope_per_s[2], d.residual_rms[2]
    );
    assert!(
        (d.slope_per_s[2] - t.slope_per_s[2]).abs() < 2e-5,
        "{d:?} vs {t:?}"
    );
    // Without the random walk the added slope itself comes back.
    let mut quiet = SimFtSensor::new(
        Arc::new(NoContact),
        FtNoiseConfig {
            force_drift_n_per_sqrt_s: 0.0,
            ..FtNoiseConfig::default()
        },
    );
    let quiet_biases: Vec<_> = (0..20)
        .map(|k| {
            let mut w = window(&mut quiet, 30.0 * k as f64);
            for (t, x) in w.iter_mut() {
                x.fz.0 += slope * *t;
            }
            bias(&w).expect("samples")
        })
        .collect();
    let q = drift(&quiet_biases).expect("fit");
    println!(
        "without the random walk: {:.6} +- {:.6} N/s",
        q.slope_per_s[2], q.slope_sigma[2]
    );
    assert!(
        (q.slope_per_s[2] - slope).abs() < 3.0 * q.slope_sigma[2] && q.slope_sigma[2] < 2e-5,
        "{q:?}"
    );

    // Zero-load check: the same power-up passes, a power cycle warns.
    let profile = ForceOffsets::from_bias(&biases[0], Some(&d));
    let again = bias(&window(&mut s, 601.0)).expect("samples");
    let mut fresh = SimFtSensor::new(Arc::new(NoContact), FtNoiseConfig::default());
    let first = bias(&window(&mut fresh, 0.0)).expect("samples");
    let same = ForceOffsets::from_bias(&first, None);
    assert!(zero_load_check(
        &same,
        &bias(&window(&mut fresh, 1.0)).expect("w"),
        ZeroTolerance::default()
    )
    .is_empty());
    fresh.power_cycle();
    let after = bias(&window(&mut fresh, 2.0)).expect("samples");
    let w = zero_load_check(&same, &after, ZeroTolerance::default());
    assert!(!w.is_empty() && w.iter().any(|m| m.contains("Fz")), "{w:?}");
    // 600 s of 2 mN/s drift moved Fz by ~1.2 N: warned.
    let w = zero_load_check(&profile, &again, ZeroTolerance::default());
    assert!(w.iter().any(|m| m.starts_with("Fz offset moved")), "{w:?}");
}
