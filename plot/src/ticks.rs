//! Tick values at round numbers (1, 2, 5 x 10^n) and their labels.

/// The round step (1, 2, 5 x 10^n) giving about `target` ticks over `span`.
pub(crate) fn step(span: f64, target: f64) -> f64 {
    let raw = (span / target).abs();
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let e = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * e)
        .find(|v| *v >= raw * 0.999)
        .unwrap_or(10.0 * e)
}

/// The multiples of `step` in [lo, hi].
pub(crate) fn values(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    if last < first || last - first > 1000 {
        return Vec::new();
    }
    (first..=last).map(|k| k as f64 * step).collect()
}

/// Decimals a label at multiples of `step` needs (0.2 -> 1, 0.05 -> 2, 5 -> 0).
pub(crate) fn decimals(step: f64) -> usize {
    if !(step.is_finite() && step > 0.0) {
        return 0;
    }
    (-(step.log10() + 1e-9).floor()).clamp(0.0, 6.0) as usize
}

/// `v` with `decimals` decimals, never "-0".
pub(crate) fn label(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// `YYYY-MM-DD` of `days` since 1970-01-01 (H. Hinnant's civil_from_days; the fraction of a
/// day is dropped).
pub(crate) fn date(days: f64) -> String {
    let z = days.floor() as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_fall_on_round_numbers() {
        assert_eq!(step(10.0, 5.0), 2.0);
        assert_eq!(step(0.37, 4.0), 0.1);
        assert_eq!(step(7.0, 6.0), 2.0);
        assert_eq!(values(0.5, 3.5, 1.0), vec![1.0, 2.0, 3.0]);
        assert_eq!(values(-0.3, 0.3, 0.2).len(), 3);
        assert_eq!(decimals(0.05), 2);
        assert_eq!(date(0.0), "1970-01-01");
        assert_eq!(date(20_428.7), "2025-12-06");
        assert_eq!(decimals(0.2), 1);
        assert_eq!(decimals(5.0), 0);
        assert_eq!(label(-0.0001, 2), "0.00");
        assert_eq!(label(-6.0, 0), "-6");
    }
}
