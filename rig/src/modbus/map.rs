//! Register maps: where a Modbus stage keeps its target, speed, trigger, feedback and status.
//!
//! A y stage's registers differ from vendor to vendor, so they come from a TOML file. Two maps
//! ship with fringe (`oriental-az`, `leadshine-pr`, also under `rig/maps/`); any other file can be
//! given by path. See `rig/maps/oriental-az.toml` for a commented example of every key.

use crate::transport::serial::{Parity, SerialSettings};
use serde::Deserialize;
use std::path::Path;

/// The maps built into fringe: name and TOML text.
pub(crate) const BUILTIN_MAPS: &[(&str, &str)] = &[
    ("oriental-az", include_str!("../../maps/oriental-az.toml")),
    ("leadshine-pr", include_str!("../../maps/leadshine-pr.toml")),
];

/// A map that could not be loaded; names the file and what to fix.
#[derive(Debug, thiserror::Error)]
#[error("register map {source_name}: {message}")]
pub struct MapError {
    pub source_name: String,
    pub message: String,
}

/// A register map value that cannot work; names the key and what is allowed. [`MapError`] adds
/// the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum MapCheckError {
    #[error("key steps_per_mm = {0} must be a positive number")]
    StepsPerMm(f64),
    #[error("key {key}.words = {words}: allowed values are 1 (16-bit) and 2 (32-bit)")]
    Words { key: String, words: u8 },
    #[error("key {key}.scale = {scale} must be a positive number")]
    Scale { key: &'static str, scale: f64 },
    #[error("key {key} is set but there is no [profile] section with speed_mm_s, accel_mm_s2, decel_mm_s2")]
    NoProfile { key: &'static str },
    #[error("key {key} = {value} does not fit in {words} register(s) (allowed {min}..={max})")]
    DoesNotFit {
        key: String,
        value: i64,
        words: u8,
        min: i64,
        max: i64,
    },
    #[error("key homing.writes is empty: list at least one write, or remove [homing]")]
    NoHomingWrites,
    #[error("key status.bits has no bit with role = \"moving\" (allowed roles: moving, alarm, ready, homed, info)")]
    NoMovingBit,
    #[error("key status.bits[{index}].mask = 0x{mask:X} must be non-zero and fit in {bits} bits")]
    StatusMask { index: usize, mask: u32, bits: u32 },
}

/// Order of the two registers of a 32-bit value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WordOrder {
    /// Upper 16 bits at the lower address (Oriental Motor, Leadshine, most devices).
    HighFirst,
    /// Lower 16 bits at the lower address.
    LowFirst,
}

impl WordOrder {
    /// The registers holding `value`, in address order.
    pub fn split(self, value: u32) -> [u16; 2] {
        let (hi, lo) = ((value >> 16) as u16, value as u16);
        match self {
            WordOrder::HighFirst => [hi, lo],
            WordOrder::LowFirst => [lo, hi],
        }
    }

    /// The value held by two registers read in address order.
    pub fn join(self, regs: [u16; 2]) -> u32 {
        let (hi, lo) = match self {
            WordOrder::HighFirst => (regs[0], regs[1]),
            WordOrder::LowFirst => (regs[1], regs[0]),
        };
        (u32::from(hi) << 16) | u32::from(lo)
    }
}

/// Serial settings of an RTU stage.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SerialConfig {
    pub baud: u32,
    pub parity: Parity,
    #[serde(default = "one")]
    pub stop_bits: u8,
}

fn one() -> u8 {
    1
}

impl SerialConfig {
    /// The transport's settings, no flow control.
    pub fn settings(&self) -> SerialSettings {
        SerialSettings {
            baud: self.baud,
            parity: self.parity,
            stop_bits: self.stop_bits,
            rts_cts: false,
        }
    }
}

/// A register holding a number: its address, width in registers and scale.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Field {
    pub address: u16,
    /// 1 (16 bits) or 2 (32 bits, in the map's word order).
    #[serde(default = "two")]
    pub words: u8,
    /// Register units per physical unit (per mm/s for speed, per mm/s^2 for acceleration).
    #[serde(default = "unit_scale")]
    pub scale: f64,
    /// When true the register holds `scale / value` (drives that take an acceleration *time*).
    #[serde(default)]
    pub inverse: bool,
}

fn two() -> u8 {
    2
}

fn unit_scale() -> f64 {
    1.0
}

/// A fixed register write.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Write {
    pub address: u16,
    #[serde(default = "one")]
    pub words: u8,
    pub value: i64,
    /// Written to the same register right after `value` (to release a pulsed input).
    #[serde(default)]
    pub release: Option<i64>,
    /// What this write is, for messages.
    #[serde(default)]
    pub name: Option<String>,
}

/// The register whose operation type selects absolute or relative positioning.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Operation {
    pub address: u16,
    #[serde(default = "two")]
    pub words: u8,
    pub absolute: i64,
    /// Without it, relative moves are sent as absolute moves to the computed target.
    #[serde(default)]
    pub relative: Option<i64>,
}

/// The register written to start (and optionally stop) a motion.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Trigger {
    pub address: u16,
    #[serde(default = "one")]
    pub words: u8,
    /// Value that starts the motion.
    pub start: i64,
    /// Value written to stop with deceleration.
    #[serde(default)]
    pub stop: Option<i64>,
    /// Value written for an emergency (immediate) stop.
    #[serde(default)]
    pub estop: Option<i64>,
}

/// What a status bit means to the driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Set while the stage moves.
    Moving,
    /// Set when the drive is in alarm: motion is not to be trusted.
    Alarm,
    /// Set when the drive accepts a new command.
    Ready,
    /// Set once homing has completed.
    Homed,
    /// Only reported.
    Info,
}

/// One named bit (or group of bits) of the status register.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatusBit {
    pub name: String,
    pub mask: u32,
    pub role: Role,
}

/// The status register.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Status {
    pub address: u16,
    #[serde(default = "one")]
    pub words: u8,
    pub bits: Vec<StatusBit>,
}

/// The positioning registers.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Registers {
    /// Target position (steps, signed 32-bit).
    pub target_position: u16,
    /// Measured or commanded position read back (steps, signed 32-bit).
    pub feedback_position: u16,
    pub speed: Option<Field>,
    pub acceleration: Option<Field>,
    pub deceleration: Option<Field>,
}

/// Motion profile written with every move.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    pub speed_mm_s: f64,
    pub accel_mm_s2: f64,
    pub decel_mm_s2: f64,
}

/// Homing: the writes that start it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Homing {
    pub writes: Vec<Write>,
}

/// A whole register map.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegisterMap {
    /// Human name of the drive.
    pub name: String,
    /// Default slave (unit) id.
    pub slave: u8,
    pub word_order: WordOrder,
    /// Position register units (steps, pulses) per millimetre of stage travel.
    pub steps_per_mm: f64,
    /// Serial settings for RTU.
    pub serial: Option<SerialConfig>,
    pub profile: Option<Profile>,
    pub registers: Registers,
    pub operation: Option<Operation>,
    /// Fixed writes sent with every move, before the trigger.
    #[serde(default)]
    pub preset: Vec<Write>,
    pub trigger: Trigger,
    pub homing: Option<Homing>,
    pub status: Status,
    /// Position tolerance, in steps, for deciding a move reached its target.
    #[serde(default = "default_tolerance")]
    pub tolerance_steps: u32,
    /// Where the map came from (file path or built-in name); set by the loader.
    #[serde(skip)]
    pub source: String,
}

fn default_tolerance() -> u32 {
    2
}

impl RegisterMap {
    /// Loads a built-in map by name, or a TOML file by path.
    pub fn load(spec: &str) -> Result<RegisterMap, MapError> {
        if let Some((name, text)) = BUILTIN_MAPS.iter().find(|(n, _)| *n == spec) {
            return RegisterMap::parse(text, &format!("{name} (built-in)"));
        }
        let path = Path::new(spec);
        if !path.exists() {
            let names: Vec<&str> = BUILTIN_MAPS.iter().map(|(n, _)| *n).collect();
            return Err(MapError {
                source_name: spec.to_string(),
                message: format!(
                    "no such file and no built-in map of that name (built-in maps: {})",
                    names.join(", ")
                ),
            });
        }
        let text = std::fs::read_to_string(path).map_err(|e| MapError {
            source_name: spec.to_string(),
            message: format!("cannot read: {e}"),
        })?;
        RegisterMap::parse(&text, spec)
    }

    /// Parses and checks map text; `source_name` names it in errors.
    pub fn parse(text: &str, source_name: &str) -> Result<RegisterMap, MapError> {
        let err = |message: String| MapError {
            source_name: source_name.to_string(),
            message,
        };
        let mut map: RegisterMap =
            crate::config_file::parse_toml(text, source_name).map_err(|e| err(e.message))?;
        map.source = source_name.to_string();
        map.check().map_err(|e| err(e.to_string()))?;
        Ok(map)
    }

    /// Checks the map as a whole: steps per mm, then each section.
    fn check(&self) -> Result<(), MapCheckError> {
        if !(self.steps_per_mm.is_finite() && self.steps_per_mm > 0.0) {
            return Err(MapCheckError::StepsPerMm(self.steps_per_mm));
        }
        self.check_profile_registers()?;
        self.check_operation()?;
        self.check_trigger()?;
        self.check_writes()?;
        self.check_status()
    }

    /// Checks the speed, acceleration and deceleration registers: widths, positive scales,
    /// and a motion profile to write them to.
    fn check_profile_registers(&self) -> Result<(), MapCheckError> {
        for (key, f) in [
            ("registers.speed", &self.registers.speed),
            ("registers.acceleration", &self.registers.acceleration),
            ("registers.deceleration", &self.registers.deceleration),
        ] {
            if let Some(f) = f {
                check_words(key, f.words)?;
                if !(f.scale.is_finite() && f.scale > 0.0) {
                    return Err(MapCheckError::Scale {
                        key,
                        scale: f.scale,
                    });
                }
                if self.profile.is_none() {
                    return Err(MapCheckError::NoProfile { key });
                }
            }
        }
        Ok(())
    }

    /// Checks that the operation codes, if any, fit the operation register.
    fn check_operation(&self) -> Result<(), MapCheckError> {
        if let Some(op) = &self.operation {
            check_words("operation", op.words)?;
            fits("operation.absolute", op.absolute, op.words)?;
            if let Some(r) = op.relative {
                fits("operation.relative", r, op.words)?;
            }
        }
        Ok(())
    }

    /// Checks that the start, stop and emergency stop values fit the trigger register.
    fn check_trigger(&self) -> Result<(), MapCheckError> {
        check_words("trigger", self.trigger.words)?;
        fits("trigger.start", self.trigger.start, self.trigger.words)?;
        for (key, v) in [
            ("trigger.stop", self.trigger.stop),
            ("trigger.estop", self.trigger.estop),
        ] {
            if let Some(v) = v {
                fits(key, v, self.trigger.words)?;
            }
        }
        Ok(())
    }

    /// Checks the preset and homing writes (homing needs at least one): each value and release
    /// value fits its register.
    fn check_writes(&self) -> Result<(), MapCheckError> {
        let mut writes: Vec<(String, &Write)> = self
            .preset
            .iter()
            .enumerate()
            .map(|(i, w)| (format!("preset[{i}]"), w))
            .collect();
        if let Some(h) = &self.homing {
            if h.writes.is_empty() {
                return Err(MapCheckError::NoHomingWrites);
            }
            writes.extend(
                h.writes
                    .iter()
                    .enumerate()
                    .map(|(i, w)| (format!("homing.writes[{i}]"), w)),
            );
        }
        for (key, w) in writes {
            check_words(&key, w.words)?;
            fits(&format!("{key}.value"), w.value, w.words)?;
            if let Some(r) = w.release {
                fits(&format!("{key}.release"), r, w.words)?;
            }
        }
        Ok(())
    }

    /// Checks the status register: a moving bit, and every mask non-zero and within its width.
    fn check_status(&self) -> Result<(), MapCheckError> {
        check_words("status", self.status.words)?;
        if !self.status.bits.iter().any(|b| b.role == Role::Moving) {
            return Err(MapCheckError::NoMovingBit);
        }
        for (i, b) in self.status.bits.iter().enumerate() {
            if b.mask == 0 || (self.status.words == 1 && b.mask > 0xFFFF) {
                return Err(MapCheckError::StatusMask {
                    index: i,
                    mask: b.mask,
                    bits: 16 * u32::from(self.status.words),
                });
            }
        }
        Ok(())
    }

    /// Serial settings for RTU, with an optional baud override.
    pub fn serial_settings(&self, baud: Option<u32>) -> SerialSettings {
        let mut s = self
            .serial
            .as_ref()
            .map(SerialConfig::settings)
            .unwrap_or_else(|| SerialSettings::plain(9600));
        if let Some(b) = baud {
            s.baud = b;
        }
        s
    }

    /// Registers for a number: one register, or two in the map's word order.
    pub fn encode(&self, value: i64, words: u8) -> Vec<u16> {
        if words == 1 {
            vec![value as u16]
        } else {
            self.word_order.split(value as u32).to_vec()
        }
    }

    /// The number held by `regs` (one or two registers), unsigned.
    pub fn decode_unsigned(&self, regs: &[u16]) -> u32 {
        match regs {
            [a] => u32::from(*a),
            [a, b] => self.word_order.join([*a, *b]),
            _ => 0,
        }
    }
}

/// Checks that register `key` is one or two words wide.
fn check_words(key: &str, words: u8) -> Result<(), MapCheckError> {
    if words == 1 || words == 2 {
        Ok(())
    } else {
        Err(MapCheckError::Words {
            key: key.to_string(),
            words,
        })
    }
}

/// Checks that `value` fits a register field of `words` registers (signed or unsigned).
fn fits(key: &str, value: i64, words: u8) -> Result<(), MapCheckError> {
    let (min, max) = if words == 1 {
        (i64::from(i16::MIN), i64::from(u16::MAX))
    } else {
        (i64::from(i32::MIN), i64::from(u32::MAX))
    };
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(MapCheckError::DoesNotFit {
            key: key.to_string(),
            value,
            words,
            min,
            max,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_maps_load() {
        let az = RegisterMap::load("oriental-az").expect("az");
        assert_eq!(az.registers.target_position, 0x005C);
        assert_eq!(az.trigger.address, 0x0066);
        assert_eq!(az.word_order, WordOrder::HighFirst);
        assert_eq!(az.serial_settings(None).parity, Parity::Even);
        assert!(az.homing.is_none());
        let ls = RegisterMap::load("leadshine-pr").expect("leadshine");
        assert_eq!(ls.serial_settings(None).baud, 38400);
        assert_eq!(ls.trigger.estop, Some(0x40));
        assert_eq!(ls.operation.as_ref().map(|o| o.address), Some(0x6200));
    }

    #[test]
    fn shipped_files_equal_embedded_maps() {
        for (name, text) in BUILTIN_MAPS {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/maps/").to_string() + name + ".toml";
            assert_eq!(
                std::fs::read_to_string(&path).expect("map file"),
                *text,
                "{path}"
            );
        }
    }

    #[test]
    fn unknown_key_names_file_and_allowed_keys() {
        let text = BUILTIN_MAPS[0]
            .1
            .replace("steps_per_mm", "steps_per_millimetre");
        let e = RegisterMap::parse(&text, "my-stage.toml").expect_err("unknown key");
        let msg = e.to_string();
        assert!(msg.contains("my-stage.toml"), "{msg}");
        assert!(
            msg.contains("steps_per_millimetre") && msg.contains("steps_per_mm"),
            "{msg}"
        );
    }

    #[test]
    fn bad_word_order_lists_allowed_values() {
        let text = BUILTIN_MAPS[0]
            .1
            .replace("word_order = \"high-first\"", "word_order = \"big\"");
        let msg = RegisterMap::parse(&text, "x.toml")
            .expect_err("bad order")
            .to_string();
        assert!(
            msg.contains("high-first") && msg.contains("low-first"),
            "{msg}"
        );
    }

    #[test]
    fn type_errors_name_line_and_key() {
        let text = BUILTIN_MAPS[1]
            .1
            .replace("role = \"moving\"", "role = \"busy\"");
        let msg = RegisterMap::parse(&text, "s.toml")
            .expect_err("bad role")
            .to_string();
        assert!(
            msg.contains("key status.role") && msg.contains("`moving`, `alarm`"),
            "{msg}"
        );
        let text = BUILTIN_MAPS[1].1.replace("slave = 1", "slave = \"one\"");
        let msg = RegisterMap::parse(&text, "s.toml")
            .expect_err("bad slave")
            .to_string();
        assert!(
            msg.starts_with("register map s.toml: line 7, key slave: invalid type"),
            "{msg}"
        );
    }

    #[test]
    fn missing_file_lists_builtin_maps() {
        let msg = RegisterMap::load("/nonexistent/stage.toml")
            .expect_err("missing")
            .to_string();
        assert!(
            msg.contains("oriental-az") && msg.contains("leadshine-pr"),
            "{msg}"
        );
    }

    #[test]
    fn word_orders_round_trip() {
        assert_eq!(WordOrder::HighFirst.split(0x0001_0002), [1, 2]);
        assert_eq!(WordOrder::LowFirst.split(0x0001_0002), [2, 1]);
        for o in [WordOrder::HighFirst, WordOrder::LowFirst] {
            assert_eq!(o.join(o.split(0xDEAD_BEEF)), 0xDEAD_BEEF);
        }
    }
}
