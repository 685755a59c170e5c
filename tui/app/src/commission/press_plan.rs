//! The scan plan of a commissioning round or acceptance scan: the built-in `commission` plan
//! with its points and indenters replaced, storing only the square around the unit's disc (all
//! the model reads; the profile that places it is the calibration step's).

use crate::session::plans::COMMISSION;
use fringe_calibration::Profile;
use fringe_rig::store::FrameStorage;

/// The margin about the disc a round's square keeps when the frame has room for it, px. The
/// model reads the crop radius (inside the disc) about the optical centre, known to a hundredth
/// of a pixel by the calibration just made: 8 px is room enough, and stores a tenth fewer bytes
/// than the recording's default of 40 px (BENCHMARKS.md, "Its cost, said first and kept small").
const DISC_MARGIN_PX: f64 = 8.0;

/// The margin (px, at most [`DISC_MARGIN_PX`]) with which the square around the disc of
/// `profile` lies inside its frame: the rounds and the acceptance scan store that square. `None`
/// when not even the bare square does (a disc at the frame's edge): whole frames are stored.
pub(crate) fn disc_margin(profile: &Profile) -> Option<f64> {
    let o = &profile.optical;
    let fits = |m: f64| {
        FrameStorage::disc_square(
            [o.centre_x_px, o.centre_y_px],
            o.radius_px,
            m,
            profile.image.width,
            profile.image.height,
        )
        .is_ok()
    };
    let mut m = DISC_MARGIN_PX;
    while m >= 0.0 {
        if fits(m) {
            return Some(m);
        }
        m -= 2.0;
    }
    None
}

/// The built-in plan could not be rewritten (a broken build).
#[derive(Debug, thiserror::Error)]
#[error("the built-in commissioning plan (tui/app/plans/commission.toml): {0}")]
pub struct PressPlanError(String);

/// The plan text that presses `points` (stage mm) with each of `shapes`, named `name`, headed
/// by a comment saying `why`; its frames stored as the disc's square with `disc_margin` px about
/// it when given (`[recording] store = "disc"`, about half the bytes of whole frames; see
/// [`disc_margin`]), else whole.
pub(crate) fn press_plan(
    name: &str,
    points: &[[f64; 2]],
    shapes: &[String],
    why: &str,
    disc_margin: Option<f64>,
) -> Result<String, PressPlanError> {
    let mut plan: toml::Table = COMMISSION
        .text
        .parse()
        .map_err(|e: toml::de::Error| PressPlanError(e.to_string()))?;
    let set = |plan: &mut toml::Table, section: &str, key: &str, value: toml::Value| {
        if let Some(toml::Value::Table(t)) = plan.get_mut(section) {
            t.insert(key.into(), value);
        }
    };
    let pairs = points
        .iter()
        .map(|p| toml::Value::Array(vec![toml::Value::Float(p[0]), toml::Value::Float(p[1])]))
        .collect();
    set(&mut plan, "grid", "points", toml::Value::Array(pairs));
    let names = shapes
        .iter()
        .map(|s| toml::Value::String(s.clone()))
        .collect();
    set(&mut plan, "indenters", "shapes", toml::Value::Array(names));
    plan.insert("name".into(), toml::Value::String(name.to_string()));
    if let Some(margin) = disc_margin {
        let mut recording = toml::Table::new();
        recording.insert("store".into(), toml::Value::String("disc".into()));
        recording.insert("disc_margin_px".into(), toml::Value::Float(margin));
        plan.insert("recording".into(), toml::Value::Table(recording));
    }
    let body = toml::to_string(&plan).map_err(|e| PressPlanError(e.to_string()))?;
    let why: String = why.lines().map(|l| format!("# {l}\n")).collect();
    Ok(format!("{why}{body}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_press_plan_presses_its_points_with_each_indenter_and_stores_the_disc_square() {
        let shapes = ["pentagon".to_string(), "rectangle".to_string()];
        let text = press_plan(
            "round-1",
            &[[12.0, 25.0], [14.0, 25.0]],
            &shapes,
            "why\nand how",
            Some(40.0),
        )
        .expect("plan");
        assert!(text.starts_with("# why\n# and how\n"), "{text}");
        let plan = fringe_rig::Plan::parse(&text, "round-1").expect("parses");
        assert_eq!(plan.name, "round-1");
        let table: toml::Table = text.parse().expect("toml");
        assert_eq!(table["recording"]["store"].as_str(), Some("disc"), "{text}");
        assert_eq!(table["grid"]["points"].as_array().map(Vec::len), Some(2));
        assert_eq!(
            table["indenters"]["shapes"].as_array().map(Vec::len),
            Some(2)
        );
        let whole = press_plan("round-1", &[[12.0, 25.0]], &shapes, "why", None).expect("plan");
        assert!(!whole.contains("[recording]"), "{whole}");
    }
}
