//! The learning rate over a training (`fringe train --schedule`): constant (the reference's),
//! or a cosine decay from the base rate to a hundredth of it over the epochs, one rate per
//! epoch. The rate of an epoch depends only on its index and the number of epochs, so a resumed
//! training continues it (one extended with more `--epochs` stretches the rest of the cosine).

use std::f64::consts::PI;

/// How the learning rate changes from epoch to epoch.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Schedule {
    /// The base rate throughout (the reference's Adam at 1e-3).
    #[default]
    Constant,
    /// Half a cosine from the base rate (first epoch) down to a hundredth of it (after the
    /// last): large steps while the loss falls fast, small ones to settle.
    Cosine,
}

/// The last rate of a cosine schedule, as a share of the base rate.
const COSINE_FLOOR: f64 = 0.01;

impl Schedule {
    pub const ALL: [Schedule; 2] = [Schedule::Constant, Schedule::Cosine];

    pub fn name(self) -> &'static str {
        match self {
            Schedule::Constant => "constant",
            Schedule::Cosine => "cosine",
        }
    }

    /// The rate of epoch `epoch` (0 for the first) of `epochs`, from the base rate `base`.
    pub fn lr(self, base: f64, epoch: usize, epochs: usize) -> f64 {
        match self {
            Schedule::Constant => base,
            Schedule::Cosine => {
                let t = epoch.min(epochs) as f64 / epochs.max(1) as f64;
                let floor = base * COSINE_FLOOR;
                floor + (base - floor) * 0.5 * (1.0 + (PI * t).cos())
            }
        }
    }
}

impl std::str::FromStr for Schedule {
    type Err = String;
    fn from_str(s: &str) -> Result<Schedule, String> {
        Schedule::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown schedule `{s}`: use constant or cosine"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cosine_falls_from_the_base_rate_towards_a_hundredth_and_constant_stays() {
        let cos = |e| Schedule::Cosine.lr(1e-3, e, 10);
        assert!((cos(0) - 1e-3).abs() < 1e-12);
        // Halfway: the mean of the base and the floor.
        assert!((cos(5) - 0.5 * (1e-3 + 1e-5)).abs() < 1e-12);
        assert!(cos(9) < 5e-5 && cos(9) > 1e-5, "{}", cos(9));
        assert!((1..10).all(|e| cos(e) < cos(e - 1)));
        assert!((0..10).all(|e| Schedule::Constant.lr(1e-3, e, 10) == 1e-3));
        assert_eq!("cosine".parse::<Schedule>(), Ok(Schedule::Cosine));
        assert!("step".parse::<Schedule>().is_err());
    }
}
