//! The rig with a named unit on it. The simulated bench carries any of its units (or a
//! simulator's sensor file): the rig is the same with `sim.sensor` set to that unit, so its runs
//! store a rig file that says so and resume on it. A real rig must hold the unit: the unit is
//! the rig file's `sensor`, or the rig file names none and the unit is taken as the one mounted.

use crate::rig::file::RigConfig;
use crate::rig::simulated;
use crate::units::error::UnitError;
use crate::units::listing::known_ids;
use crate::units::unit_ref::UnitRef;

/// `config` with `unit` on it, or why it cannot be.
pub fn carrying(config: RigConfig, unit: &UnitRef) -> Result<RigConfig, UnitError> {
    let rig = config.sensor_id().ok();
    if config.is_simulated() {
        let sim_sensor = match &unit.sim_sensor {
            Some(file) => file.display().to_string(),
            None if rig.as_deref() == Some(unit.id.as_str()) => return Ok(config),
            None if simulated::units().iter().any(|(id, _)| *id == unit.id) => unit.id.clone(),
            None => {
                return Err(UnitError::Unknown {
                    unit: unit.id.clone(),
                    known: known_ids(&config),
                    rig,
                })
            }
        };
        return rewritten(&config, &unit.id, |t| {
            // The simulated unit says its id and design itself.
            t.remove("sensor");
            t.remove("variant");
            let sim = t
                .entry("sim")
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            if let Some(sim) = sim.as_table_mut() {
                sim.insert("sensor".into(), toml::Value::String(sim_sensor));
            }
        });
    }
    if let Some(path) = &unit.sim_sensor {
        return Err(UnitError::SimulatedOnly {
            path: path.clone(),
            unit: unit.id.clone(),
        });
    }
    match rig {
        Some(r) if r == unit.id => Ok(config),
        Some(r) => Err(UnitError::NotOnRig {
            unit: unit.id.clone(),
            rig: r,
            origin: config.origin.clone(),
        }),
        None => rewritten(&config, &unit.id, |t| {
            t.insert("sensor".into(), toml::Value::String(unit.id.clone()));
        }),
    }
}

/// The rig file of `config` changed by `edit`, read again (and checked) under its own name.
fn rewritten(
    config: &RigConfig,
    unit: &str,
    edit: impl FnOnce(&mut toml::Table),
) -> Result<RigConfig, UnitError> {
    // The default simulated bench's text is a comment: an empty table.
    let mut table: toml::Table = config.text.parse().unwrap_or_default();
    edit(&mut table);
    let body = toml::to_string(&table).map_err(|e| fringe_rig::ConfigError {
        origin: config.origin.clone(),
        message: format!("cannot write the rig with unit {unit} on it: {e}"),
    })?;
    let text = format!("# {}, with unit {unit} on it\n{body}", config.origin);
    Ok(RigConfig::parse(&text, &config.origin)?)
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;

    fn unit(id: &str) -> UnitRef {
        UnitRef::parse(id).expect("id")
    }

    #[test]
    fn the_simulated_bench_carries_the_unit_named_and_refuses_an_unknown_one() {
        let rig = carrying(RigConfig::simulated(), &unit("layered-2")).expect("layered-2");
        assert_eq!(rig.sensor_id().expect("id"), "layered-2");
        assert_eq!(rig.sensor_variant().expect("design"), Some("layered"));
        assert!(rig.is_simulated());
        // The runs store a rig file that carries it.
        assert!(rig.text.contains("sensor = \"layered-2\""), "{}", rig.text);
        let rig = carrying(rig, &unit("integrated-3")).expect("integrated-3");
        assert_eq!(rig.sensor_variant().expect("design"), Some("integrated"));
        let e = carrying(rig, &unit("layered-9")).expect_err("unknown");
        let text = e.to_string();
        assert!(
            text.contains("unit layered-9 is not known here")
                && text.contains("the rig's sensor is integrated-3")
                && text.contains("layered-2"),
            "{text}"
        );
    }

    #[test]
    fn a_real_rig_must_hold_the_unit() {
        let text = include_str!("../../rigs/paper-bench.toml");
        let config = RigConfig::parse(text, "paper-bench.toml").expect("example");
        let e = carrying(config.clone(), &unit("layered-02")).expect_err("other unit");
        assert!(
            e.to_string().contains("the rig's sensor is layered-01"),
            "{e}"
        );
        assert!(carrying(config.clone(), &unit("layered-01")).is_ok());
        // A rig file that names no sensor takes the unit as the one mounted.
        let unnamed = text.replace("sensor = \"layered-01\"", "");
        let config = RigConfig::parse(&unnamed, "lab.toml").expect("unnamed");
        let config = carrying(config, &unit("layered-02")).expect("named");
        assert_eq!(config.sensor_id().expect("id"), "layered-02");
    }
}
