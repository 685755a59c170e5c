//! Numbers given on the command line, checked when they are parsed: no command sees a nan, an
//! infinity or a duration no clock can hold, and clap names the option in the error.

use std::time::Duration;

/// The longest duration any option accepts (a week): longer is a typo, not a plan.
pub const MAX_SECONDS: f64 = 7.0 * 24.0 * 3600.0;

/// A positive number of seconds up to [`MAX_SECONDS`].
pub fn seconds(text: &str) -> Result<Duration, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number of seconds"))?;
    if !(v.is_finite() && v > 0.0 && v <= MAX_SECONDS) {
        return Err(format!(
            "{text} s: give a positive number of seconds up to {MAX_SECONDS} (a week)"
        ));
    }
    Ok(Duration::from_secs_f64(v))
}

/// A finite number of millimetres.
pub fn millimetres(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .trim()
        .trim_end_matches("mm")
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number of millimetres"))?;
    if !v.is_finite() {
        return Err(format!("{text}: give a finite number of millimetres"));
    }
    Ok(v)
}

/// The smallest and largest rounding step of an export, N (and N m, mm): below, the rows hold
/// digits no sensor measures; above, every force of the bench rounds to 0.
pub const ROUND_STEPS: (f64, f64) = (1e-6, 1.0);

/// An export's rounding step, within [`ROUND_STEPS`].
pub fn round_step(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    let (lo, hi) = ROUND_STEPS;
    if !(v.is_finite() && (lo..=hi).contains(&v)) {
        return Err(format!(
            "{text}: give a step from {lo:e} to {hi} (N, N m and mm; the reference rounds to 0.1)"
        ));
    }
    Ok(v)
}

/// A count of worker threads: at least 1 and at most 1024 (more is a typo); more than the
/// machine's cores are given only the cores (see [`cap_threads`]).
pub fn threads(text: &str) -> Result<usize, String> {
    let v: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a whole number of threads"))?;
    if !(1..=1024).contains(&v) {
        return Err(format!("{text}: give 1 to 1024 threads"));
    }
    Ok(v)
}

/// `asked` threads, or the cores this process may use when that is fewer (said on stderr):
/// more threads than cores only slow inference down and starve the rest of the bench.
pub fn cap_threads(asked: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if asked > cores {
        eprintln!("--threads {asked}: this machine has {cores} cores; using {cores}");
        cores
    } else {
        asked.max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_steps_outside_what_makes_sense_are_refused() {
        assert_eq!(round_step("0.1"), Ok(0.1));
        for bad in ["5", "1e308", "1e-300", "0", "-0.1", "nan", "x"] {
            assert!(round_step(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn threads_are_capped_at_the_cores() {
        assert!(threads("0").is_err() && threads("100000").is_err());
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(cap_threads(1000), cores);
        assert_eq!(cap_threads(1), 1);
    }

    #[test]
    fn durations_are_positive_finite_and_bounded() {
        assert_eq!(seconds("1.5"), Ok(Duration::from_millis(1500)));
        for bad in ["0", "-1", "nan", "inf", "1e300", "ten"] {
            assert!(seconds(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn positions_are_finite() {
        assert_eq!(millimetres("-2.5"), Ok(-2.5));
        assert_eq!(millimetres("3mm"), Ok(3.0));
        for bad in ["nan", "inf", "-inf", "x"] {
            assert!(millimetres(bad).is_err(), "{bad}");
        }
    }
}
