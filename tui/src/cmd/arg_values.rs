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

#[cfg(test)]
mod tests {
    use super::*;

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
