//! The simulated six-axis force/torque sensor between the z stage and the indenter.
//!
//! **Frames.** The world (bench) frame has X and Y along the stage axes and Z up, away from the
//! photoelastic sensor. The F/T frame is ATI's tool frame: its z axis points from the sensor body
//! towards the tool (down, at the indenter) when [`FtMount::z_toward_tool`] is set (the default),
//! which makes it the world frame turned 180 degrees about X (x = X, y = -Y, z = -Z), then turned
//! by [`FtMount::rotation_deg`] about its own z. Pressing the indenter into the gel pushes the tool
//! up, a compressive load: **Fz is negative when pressing** (ATI's sign), |Fz| = the normal force.
//!
//! **Moments.** The contact force acts at the indenter tip, `tool_length_mm` below the F/T origin
//! and `offset_x_mm`, `offset_y_mm` beside the F/T axis (an indenter mounted off-centre). The
//! torque at the F/T origin is M = r x F with r from the F/T origin to the contact point, both in
//! the F/T frame: a normal force N on a default mount (offset 0.4 mm, -0.25 mm) gives
//! |M| = N * 0.47 mm, about 4 mN m at 9 N.
//!
//! **Noise, drift, bias** ([`FtNoiseConfig`]): white Gaussian noise of sigma 0.05 N per force axis
//! and 1.5 mN m per torque axis (the 0.2 N noise floor used to call "no contact" is 4 sigma), a
//! random walk drift of 5 mN/sqrt(s) (force) and 0.1 mN m/sqrt(s) (torque), and a power-up bias
//! drawn per power cycle (sigma 2 N, 50 mN m) from the seed and the power-cycle number: the same
//! seed and cycle give the same bias, another cycle another one. A shifted zero
//! ([`FtNoiseConfig::zero_shift_n`], an aged transducer) is added to every power-up bias, and
//! the ground truth's bias includes it. The noise and drift are drawn from the seed, the power
//! cycle and the session ([`FtNoiseConfig::session`]): another session of the same bench has the
//! same bias and other noise.

use crate::ground_truth::records::{TruthRecord, TruthSink};
use crate::scene::{ForceReading, LoadSource};
use crate::session::salted;
use fringe_rig::HostTime;
use fringe_rig::Wrench;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::sync::Arc;

pub use crate::physics::ft_config::FtNoiseConfig;

/// A standard normal deviate (Box-Muller).
pub(crate) fn standard_normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = 1.0 - rng.gen::<f64>(); // (0, 1]
    let u2: f64 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

pub(crate) use fringe_rig::seeded::mix as mix_seed;

/// The sensor reading a [`LoadSource`]: true load + bias + drift + noise.
pub struct SimFtSensor {
    load: Arc<dyn LoadSource>,
    config: FtNoiseConfig,
    power_cycle: u64,
    bias: [f64; 6],
    drift: [f64; 6],
    rng: StdRng,
    last: Option<HostTime>,
    truth: Option<Arc<dyn TruthSink>>,
}

impl SimFtSensor {
    /// A sensor just powered up (power cycle 0).
    pub fn new(load: Arc<dyn LoadSource>, config: FtNoiseConfig) -> SimFtSensor {
        let mut s = SimFtSensor {
            load,
            config,
            power_cycle: 0,
            bias: [0.0; 6],
            drift: [0.0; 6],
            rng: StdRng::seed_from_u64(0),
            last: None,
            truth: None,
        };
        s.power_up(0);
        s
    }

    fn sigmas(&self, force: f64, torque: f64) -> [f64; 6] {
        [force, force, force, torque, torque, torque]
    }

    fn power_up(&mut self, cycle: u64) {
        self.power_cycle = cycle;
        let mut bias_rng = StdRng::seed_from_u64(mix_seed(self.config.seed, 2 * cycle + 1));
        let sig = self.sigmas(self.config.bias_force_n, self.config.bias_torque_nm);
        self.bias = sig.map(|s| s * standard_normal(&mut bias_rng));
        for (b, shift) in self.bias.iter_mut().zip(self.config.zero_shift_n) {
            *b += shift;
        }
        self.drift = [0.0; 6];
        let noise_seed = mix_seed(self.config.seed, 2 * cycle + 2);
        self.rng = StdRng::seed_from_u64(salted(noise_seed, self.config.session));
        self.last = None;
        self.record_bias();
    }

    fn record_bias(&self) {
        if let Some(sink) = &self.truth {
            sink.record(TruthRecord::FtBias {
                t: HostTime::now(),
                power_cycle: self.power_cycle,
                bias: self.bias(),
            });
        }
    }

    /// Records the power-up bias now and at every power cycle into `sink`.
    pub fn with_truth(mut self, sink: Arc<dyn TruthSink>) -> SimFtSensor {
        self.truth = Some(sink);
        self.record_bias();
        self
    }

    /// Switches the sensor off and on: a new power-up bias, drift restarts from zero.
    pub fn power_cycle(&mut self) {
        self.power_up(self.power_cycle + 1);
    }

    /// Power cycles since creation.
    pub fn power_cycles(&self) -> u64 {
        self.power_cycle
    }

    /// The power-up bias in effect (ground truth).
    pub fn bias(&self) -> Wrench {
        Wrench::from_array(self.bias)
    }

    /// The drift accumulated so far (ground truth).
    pub fn drift(&self) -> Wrench {
        Wrench::from_array(self.drift)
    }

    pub fn config(&self) -> &FtNoiseConfig {
        &self.config
    }
}

impl ForceReading for SimFtSensor {
    fn reading_at(&mut self, t: HostTime) -> Wrench {
        let dt = match self.last {
            Some(l) if t > l => t.since(l).as_secs_f64(),
            _ => 0.0,
        };
        if !matches!(self.last, Some(l) if t <= l) {
            self.last = Some(t);
        }
        let walk = self.sigmas(
            self.config.force_drift_n_per_sqrt_s,
            self.config.torque_drift_nm_per_sqrt_s,
        );
        let noise = self.sigmas(self.config.force_noise_n, self.config.torque_noise_nm);
        let truth = self.load.true_wrench_at(t).to_array();
        let mut out = [0.0; 6];
        for i in 0..6 {
            if dt > 0.0 {
                self.drift[i] += walk[i] * dt.sqrt() * standard_normal(&mut self.rng);
            }
            out[i] =
                truth[i] + self.bias[i] + self.drift[i] + noise[i] * standard_normal(&mut self.rng);
        }
        Wrench::from_array(out)
    }

    fn power_cycle(&mut self) {
        SimFtSensor::power_cycle(self);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::ft_config::FtMount;

    struct Constant(Wrench);
    impl LoadSource for Constant {
        fn true_wrench_at(&self, _t: HostTime) -> Wrench {
            self.0
        }
    }

    #[test]
    fn moments_are_r_cross_f_for_an_off_centre_tip() {
        let mount = FtMount {
            tool_length_mm: 40.0,
            offset_x_mm: 2.0,
            offset_y_mm: -1.0,
            rotation_deg: 0.0,
            z_toward_tool: true,
        };
        let w = mount.wrench_from_normal_force(9.0);
        // Sensor frame = world turned about X: r = (2, 1, 40) mm, F = (0, 0, -9) N.
        let (r, f) = ([0.002, 0.001, 0.040], [0.0, 0.0, -9.0]);
        let m = [
            r[1] * f[2] - r[2] * f[1],
            r[2] * f[0] - r[0] * f[2],
            r[0] * f[1] - r[1] * f[0],
        ];
        let got = w.to_array();
        assert_eq!(got[2], -9.0);
        for i in 0..3 {
            assert!((got[3 + i] - m[i]).abs() < 1e-12, "{got:?} vs {m:?}");
        }
        // A lateral force on the tip gives a moment through the tool length.
        let w = mount.wrench_from_tip_force([1.0, 0.0, 0.0]);
        assert!((w.ty.0 - 0.040).abs() < 1e-12, "{w:?}");
        // Rotating the sensor 90 degrees turns the stage X force onto the sensor's -y.
        let turned = FtMount {
            rotation_deg: 90.0,
            z_toward_tool: false,
            ..mount
        };
        let w = turned.wrench_from_tip_force([1.0, 0.0, 0.0]);
        assert!(
            (w.fy.0 + 1.0).abs() < 1e-12 && w.fx.0.abs() < 1e-12,
            "{w:?}"
        );
    }

    fn samples(s: &mut SimFtSensor, n: usize) -> Vec<[f64; 6]> {
        (0..n)
            .map(|k| {
                s.reading_at(HostTime(1_000_000_000 + k as u64 * 200_000))
                    .to_array()
            })
            .collect()
    }

    #[test]
    fn noise_has_the_configured_sigma_and_stays_under_the_floor_after_bias() {
        let cfg = FtNoiseConfig::default();
        let mut s = SimFtSensor::new(Arc::new(Constant(Wrench::default())), cfg);
        let data = samples(&mut s, 5000); // 1 s at 5 kHz
        let bias: [f64; 6] =
            std::array::from_fn(|i| data[..500].iter().map(|d| d[i]).sum::<f64>() / 500.0);
        let mean_z = data.iter().map(|d| d[2]).sum::<f64>() / data.len() as f64;
        let sd_z =
            (data.iter().map(|d| (d[2] - mean_z).powi(2)).sum::<f64>() / data.len() as f64).sqrt();
        assert!((sd_z - 0.05).abs() < 0.006, "sigma Fz {sd_z}");
        let mut over = 0;
        for d in &data {
            let f =
                ((d[0] - bias[0]).powi(2) + (d[1] - bias[1]).powi(2) + (d[2] - bias[2]).powi(2))
                    .sqrt();
            if f >= 0.2 {
                over += 1;
            }
        }
        assert!(
            over < data.len() / 100,
            "{over} of {} samples over 0.2 N",
            data.len()
        );
        // A 20 ms frame average of the tared signal is far below the floor.
        let avg: f64 = data[4000..4100].iter().map(|d| d[2] - bias[2]).sum::<f64>() / 100.0;
        assert!(avg.abs() < 0.05, "{avg}");
        // Bias is real: the untared reading is off by the power-up bias.
        assert!((mean_z - s.bias().fz.0).abs() < 0.05);
    }

    #[test]
    fn power_cycles_change_the_bias_and_the_seed_reproduces_it() {
        let cfg = FtNoiseConfig::default();
        let load: Arc<dyn LoadSource> = Arc::new(Constant(Wrench::default()));
        let mut a = SimFtSensor::new(load.clone(), cfg);
        let mut b = SimFtSensor::new(load.clone(), cfg);
        assert_eq!(a.bias(), b.bias());
        assert_eq!(samples(&mut a, 10), samples(&mut b, 10));
        let first = a.bias();
        a.power_cycle();
        assert_ne!(a.bias(), first);
        assert!((a.bias().fz.0 - first.fz.0).abs() > 1e-3);
        b.power_cycle();
        assert_eq!(a.bias(), b.bias());
        // The ground truth hears of every power-up bias.
        let log = crate::ground_truth::records::TruthLog::new();
        let mut c = SimFtSensor::new(load.clone(), cfg).with_truth(log.clone());
        c.power_cycle();
        let biases: Vec<(u64, Wrench)> = log
            .records()
            .into_iter()
            .filter_map(|r| match r {
                TruthRecord::FtBias {
                    power_cycle, bias, ..
                } => Some((power_cycle, bias)),
                _ => None,
            })
            .collect();
        assert_eq!(biases, vec![(0, first), (1, a.bias())]);
        let other = SimFtSensor::new(load, FtNoiseConfig { seed: 2, ..cfg });
        assert_ne!(other.bias(), first);
    }

    #[test]
    fn drift_wanders_as_a_random_walk() {
        let cfg = FtNoiseConfig {
            force_noise_n: 0.0,
            ..FtNoiseConfig::default()
        };
        // Many independent sensors: the drift variance after 100 s is 100 * 0.005^2.
        let mut sum2 = 0.0;
        let n = 200;
        for seed in 0..n {
            let mut s = SimFtSensor::new(
                Arc::new(Constant(Wrench::default())),
                FtNoiseConfig { seed, ..cfg },
            );
            let b = s.bias().fz.0;
            s.reading_at(HostTime(0));
            for k in 1..=100u64 {
                s.reading_at(HostTime(k * 1_000_000_000));
            }
            let d = s.reading_at(HostTime(100_000_000_000)).fz.0 - b;
            sum2 += d * d;
        }
        let sd = (sum2 / n as f64).sqrt();
        assert!((sd - 0.05).abs() < 0.012, "drift after 100 s {sd}");
    }

    #[test]
    fn a_shifted_zero_moves_every_reading_and_the_recorded_bias() {
        let cfg = FtNoiseConfig::default();
        let shift = [0.3, -0.2, 1.5];
        let load: Arc<dyn LoadSource> = Arc::new(Constant(Wrench::default()));
        let log = crate::ground_truth::records::TruthLog::new();
        let mut plain = SimFtSensor::new(load.clone(), cfg);
        let mut aged = SimFtSensor::new(
            load,
            FtNoiseConfig {
                zero_shift_n: shift,
                ..cfg
            },
        )
        .with_truth(log.clone());
        for cycle in 0..2 {
            let (a, b) = (samples(&mut plain, 500), samples(&mut aged, 500));
            for (p, q) in a.iter().zip(&b) {
                for i in 0..6 {
                    let expected = if i < 3 { shift[i] } else { 0.0 };
                    assert!(
                        (q[i] - p[i] - expected).abs() < 1e-9,
                        "cycle {cycle}: {p:?} {q:?}"
                    );
                }
            }
            let mean_fz = |d: &[[f64; 6]]| d.iter().map(|v| v[2]).sum::<f64>() / d.len() as f64;
            assert!((mean_fz(&b) - mean_fz(&a) - 1.5).abs() < 1e-9);
            plain.power_cycle();
            aged.power_cycle();
        }
        let recorded: Vec<Wrench> = log
            .records()
            .into_iter()
            .filter_map(|r| match r {
                TruthRecord::FtBias { bias, .. } => Some(bias),
                _ => None,
            })
            .collect();
        assert_eq!(recorded.len(), 3, "{recorded:?}");
        assert_eq!(recorded.last(), Some(&aged.bias()));
        assert!((aged.bias().fz.0 - plain.bias().fz.0 - 1.5).abs() < 1e-12);
    }
}
