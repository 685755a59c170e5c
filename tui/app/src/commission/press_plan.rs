//! The scan plan of a commissioning round or acceptance scan: the built-in `commission` plan
//! with its points and indenters replaced.

use crate::session::plans::COMMISSION;

/// The built-in plan could not be rewritten (a broken build).
#[derive(Debug, thiserror::Error)]
#[error("the built-in commissioning plan (tui/app/plans/commission.toml): {0}")]
pub struct PressPlanError(String);

/// The plan text that presses `points` (stage mm) with each of `shapes`, named `name`, headed
/// by a comment saying `why`.
pub(crate) fn press_plan(
    name: &str,
    points: &[[f64; 2]],
    shapes: &[String],
    why: &str,
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
    let body = toml::to_string(&plan).map_err(|e| PressPlanError(e.to_string()))?;
    let why: String = why.lines().map(|l| format!("# {l}\n")).collect();
    Ok(format!("{why}{body}"))
}
