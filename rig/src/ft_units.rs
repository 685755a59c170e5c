//! Force, torque and length unit names used by ATI sensors (Net F/T web configuration, `.cal`
//! files), normalised to N, N m and metres.
//!
//! Names are matched case-insensitively, ignoring `-`, `.`, `*`, `_`, `·` and spaces, so `N-m`,
//! `Nm` and `N.m` are the same unit.

fn key(name: &str) -> String {
    name.chars()
        .filter(|c| !matches!(c, '-' | '.' | '*' | '_' | '·' | ' ' | '\t'))
        .flat_map(char::to_lowercase)
        .collect()
}

const LBF: f64 = 4.448_221_615_260_5;
const G0: f64 = 9.806_65;
const INCH: f64 = 0.0254;
const FOOT: f64 = 0.3048;

/// Newtons per one unit of the named force unit (`lbf`, `klbf`, `N`, `kN`, `mN`, `gf`, `kgf`).
pub fn newtons_per(name: &str) -> Option<f64> {
    Some(match key(name).as_str() {
        "lbf" | "lb" | "lbs" => LBF,
        "klbf" | "klb" => 1000.0 * LBF,
        "n" => 1.0,
        "kn" => 1000.0,
        "mn" => 1e-3,
        "gf" | "g" => G0 * 1e-3,
        "kgf" | "kg" => G0,
        _ => return None,
    })
}

/// Newton metres per one unit of the named torque unit (`lbf-in`, `lbf-ft`, `klbf-in`, `N-m`,
/// `N-mm`, `N-cm`, `kN-m`, `gf-cm`, `kgf-cm`, `kgf-m`).
pub fn newton_metres_per(name: &str) -> Option<f64> {
    Some(match key(name).as_str() {
        "lbfin" | "inlbf" | "lbin" | "inlb" => LBF * INCH,
        "lbfft" | "ftlbf" | "lbft" | "ftlb" => LBF * FOOT,
        "klbfin" | "inklbf" | "klbin" => 1000.0 * LBF * INCH,
        "nm" => 1.0,
        "nmm" => 1e-3,
        "ncm" => 1e-2,
        "knm" => 1000.0,
        "gfcm" | "gcm" => G0 * 1e-3 * 1e-2,
        "kgfcm" | "kgcm" => G0 * 1e-2,
        "kgfm" | "kgm" => G0,
        _ => return None,
    })
}

/// Metres per one unit of the named length unit (`m`, `cm`, `mm`, `in`, `ft`).
pub(crate) fn metres_per(name: &str) -> Option<f64> {
    Some(match key(name).as_str() {
        "m" => 1.0,
        "cm" => 1e-2,
        "mm" => 1e-3,
        "in" | "inch" | "inches" => INCH,
        "ft" | "foot" | "feet" => FOOT,
        _ => return None,
    })
}

/// The force unit names accepted, for error messages.
pub(crate) const FORCE_UNITS: &str = "lbf, klbf, N, kN, mN, gf, kgf";
/// The torque unit names accepted, for error messages.
pub(crate) const TORQUE_UNITS: &str =
    "lbf-in, lbf-ft, klbf-in, N-m, N-mm, N-cm, kN-m, gf-cm, kgf-cm, kgf-m";
/// The length unit names accepted, for error messages.
pub(crate) const LENGTH_UNITS: &str = "m, cm, mm, in, ft";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_normalise() {
        assert_eq!(newtons_per("N"), Some(1.0));
        assert_eq!(newtons_per("kN"), Some(1000.0));
        assert!((newtons_per("lbf").expect("lbf") - 4.4482216).abs() < 1e-6);
        assert!((newtons_per("gf").expect("gf") - 0.00980665).abs() < 1e-12);
        assert!((newtons_per("KGF").expect("kgf") - 9.80665).abs() < 1e-12);
        for nm in ["N-m", "Nm", "N.m", "n m", "N*m"] {
            assert_eq!(newton_metres_per(nm), Some(1.0), "{nm}");
        }
        assert_eq!(newton_metres_per("N-mm"), Some(1e-3));
        assert_eq!(newton_metres_per("kN-m"), Some(1000.0));
        assert!((newton_metres_per("lbf-in").expect("lbf-in") - 0.112984829).abs() < 1e-8);
        assert!((newton_metres_per("lbf-ft").expect("lbf-ft") - 1.355817948).abs() < 1e-8);
        assert_eq!(metres_per("mm"), Some(1e-3));
        assert_eq!(metres_per("in"), Some(0.0254));
        assert_eq!(newtons_per("furlong"), None);
        assert_eq!(newton_metres_per("N"), None);
    }
}
