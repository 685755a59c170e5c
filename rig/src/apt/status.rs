//! The 32 APT motor status bits, by name.
//!
//! Drivers disagree whether bit 0 is the forward or the reverse limit switch, so the polarity is
//! configurable per stage ([`LimitPolarity`]); it applies to the hardware (bits 0/1) and software
//! (bits 2/3) limit pairs alike.

use serde::{Deserialize, Serialize};

/// Which limit bit 0 (and 2) stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LimitPolarity {
    /// Bit 0 is the forward (clockwise) limit, bit 1 the reverse one.
    #[default]
    Bit0Forward,
    /// Bit 0 is the reverse limit, bit 1 the forward one.
    Bit0Reverse,
}

pub const LIMIT_BIT0: u32 = 0x1;
pub const LIMIT_BIT1: u32 = 0x2;
pub const SOFT_LIMIT_BIT2: u32 = 0x4;
pub const SOFT_LIMIT_BIT3: u32 = 0x8;
pub const MOVING_FORWARD: u32 = 0x10;
pub const MOVING_REVERSE: u32 = 0x20;
pub const JOGGING_FORWARD: u32 = 0x40;
pub const JOGGING_REVERSE: u32 = 0x80;
pub const MOTOR_CONNECTED: u32 = 0x100;
pub const HOMING: u32 = 0x200;
pub const HOMED: u32 = 0x400;
pub const INITIALISING: u32 = 0x800;
pub const TRACKING: u32 = 0x1000;
pub const SETTLED: u32 = 0x2000;
pub const MOTION_ERROR: u32 = 0x4000;
pub const INSTRUMENT_ERROR: u32 = 0x8000;
pub const INTERLOCK: u32 = 0x1_0000;
pub const OVER_TEMPERATURE: u32 = 0x2_0000;
pub const VOLTAGE_FAULT: u32 = 0x4_0000;
pub const COMMUTATION_ERROR: u32 = 0x8_0000;
pub const DIGITAL_INPUT_1: u32 = 0x10_0000;
pub const DIGITAL_INPUT_2: u32 = 0x20_0000;
pub const DIGITAL_INPUT_3: u32 = 0x40_0000;
pub const DIGITAL_INPUT_4: u32 = 0x80_0000;
pub const CURRENT_LIMIT: u32 = 0x100_0000;
pub const ENCODER_FAULT: u32 = 0x200_0000;
pub const OVERCURRENT: u32 = 0x400_0000;
pub const CURRENT_FAULT: u32 = 0x800_0000;
pub const POWER_OK: u32 = 0x1000_0000;
pub const ACTIVE: u32 = 0x2000_0000;
pub const ERROR: u32 = 0x4000_0000;
pub const CHANNEL_ENABLED: u32 = 0x8000_0000;

const FORWARD_LIMIT: &str = "forward limit switch";
const REVERSE_LIMIT: &str = "reverse limit switch";
const FORWARD_SOFT: &str = "forward software limit";
const REVERSE_SOFT: &str = "reverse software limit";

/// Names of bits 4..31 (bit 4 first).
const NAMES: [&str; 28] = [
    "moving forward",
    "moving reverse",
    "jogging forward",
    "jogging reverse",
    "motor connected",
    "homing",
    "homed",
    "initialising",
    "tracking",
    "settled",
    "motion error",
    "instrument error",
    "interlock",
    "over-temperature",
    "voltage fault",
    "commutation error",
    "digital input 1",
    "digital input 2",
    "digital input 3",
    "digital input 4",
    "current limit",
    "encoder fault",
    "overcurrent",
    "current fault",
    "power ok",
    "active",
    "error",
    "channel enabled",
];

/// Bits that mean the axis cannot be trusted (hardware limits are classified separately).
pub const FAULT_MASK: u32 = MOTION_ERROR
    | INSTRUMENT_ERROR
    | INTERLOCK
    | OVER_TEMPERATURE
    | VOLTAGE_FAULT
    | COMMUTATION_ERROR
    | CURRENT_LIMIT
    | ENCODER_FAULT
    | OVERCURRENT
    | CURRENT_FAULT
    | ERROR;

/// A status word as sent by the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StatusBits(pub u32);

impl StatusBits {
    /// True if `bit` (one of the constants of this module) is set.
    pub fn has(self, bit: u32) -> bool {
        self.0 & bit != 0
    }

    /// The name of a single bit under `polarity`.
    pub fn bit_name(bit_index: u32, polarity: LimitPolarity) -> &'static str {
        let fwd0 = polarity == LimitPolarity::Bit0Forward;
        match bit_index {
            0 => {
                if fwd0 {
                    FORWARD_LIMIT
                } else {
                    REVERSE_LIMIT
                }
            }
            1 => {
                if fwd0 {
                    REVERSE_LIMIT
                } else {
                    FORWARD_LIMIT
                }
            }
            2 => {
                if fwd0 {
                    FORWARD_SOFT
                } else {
                    REVERSE_SOFT
                }
            }
            3 => {
                if fwd0 {
                    REVERSE_SOFT
                } else {
                    FORWARD_SOFT
                }
            }
            i => NAMES.get(i as usize - 4).copied().unwrap_or("unknown bit"),
        }
    }

    /// Names of every set bit, lowest first.
    pub fn names(self, polarity: LimitPolarity) -> Vec<&'static str> {
        (0..32)
            .filter(|i| self.0 & (1 << i) != 0)
            .map(|i| Self::bit_name(i, polarity))
            .collect()
    }

    /// Moving or jogging in either direction, or homing.
    pub fn moving(self) -> bool {
        self.0 & (MOVING_FORWARD | MOVING_REVERSE | JOGGING_FORWARD | JOGGING_REVERSE | HOMING) != 0
    }

    pub fn homed(self) -> bool {
        self.has(HOMED)
    }

    /// True if the forward hardware limit switch is active.
    pub fn forward_limit(self, polarity: LimitPolarity) -> bool {
        match polarity {
            LimitPolarity::Bit0Forward => self.has(LIMIT_BIT0),
            LimitPolarity::Bit0Reverse => self.has(LIMIT_BIT1),
        }
    }

    /// True if the reverse hardware limit switch is active.
    pub fn reverse_limit(self, polarity: LimitPolarity) -> bool {
        match polarity {
            LimitPolarity::Bit0Forward => self.has(LIMIT_BIT1),
            LimitPolarity::Bit0Reverse => self.has(LIMIT_BIT0),
        }
    }

    /// Names of the set fault bits (motion error, overcurrent, ...), hardware limits excluded.
    pub fn faults(self, polarity: LimitPolarity) -> Vec<&'static str> {
        StatusBits(self.0 & FAULT_MASK).names(polarity)
    }

    /// Names of the set hardware limit bits.
    pub fn limits(self, polarity: LimitPolarity) -> Vec<&'static str> {
        StatusBits(self.0 & (LIMIT_BIT0 | LIMIT_BIT1)).names(polarity)
    }

    /// Faults plus hardware limits: what makes a finished move (not a homing run) suspect.
    pub fn move_faults(self, polarity: LimitPolarity) -> Vec<&'static str> {
        StatusBits(self.0 & (FAULT_MASK | LIMIT_BIT0 | LIMIT_BIT1)).names(polarity)
    }

    /// The bit of the reverse (`reverse` true) or forward hardware limit switch.
    pub fn limit_bit(polarity: LimitPolarity, reverse: bool) -> u32 {
        match (polarity, reverse) {
            (LimitPolarity::Bit0Forward, true) | (LimitPolarity::Bit0Reverse, false) => LIMIT_BIT1,
            (LimitPolarity::Bit0Forward, false) | (LimitPolarity::Bit0Reverse, true) => LIMIT_BIT0,
        }
    }

    /// [`StatusBits::move_faults`] of an axis that homing left resting on its home switch (the
    /// reverse one when `home_reverse`): that switch is where the axis belongs, not a fault.
    pub fn faults_resting_home(
        self,
        polarity: LimitPolarity,
        home_reverse: bool,
    ) -> Vec<&'static str> {
        StatusBits(self.0 & !Self::limit_bit(polarity, home_reverse)).move_faults(polarity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bit_has_a_distinct_name() {
        let names = StatusBits(u32::MAX).names(LimitPolarity::Bit0Forward);
        assert_eq!(names.len(), 32);
        let mut unique = names.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), 32);
        assert!(!names.contains(&"unknown bit"));
        assert_eq!(
            StatusBits::bit_name(31, LimitPolarity::Bit0Forward),
            "channel enabled"
        );
        assert_eq!(
            StatusBits::bit_name(14, LimitPolarity::Bit0Forward),
            "motion error"
        );
    }

    #[test]
    fn limit_polarity_swaps_the_limit_names() {
        let s = StatusBits(LIMIT_BIT0 | SOFT_LIMIT_BIT3);
        assert_eq!(
            s.names(LimitPolarity::Bit0Forward),
            vec!["forward limit switch", "reverse software limit"]
        );
        assert_eq!(
            s.names(LimitPolarity::Bit0Reverse),
            vec!["reverse limit switch", "forward software limit"]
        );
        assert!(s.forward_limit(LimitPolarity::Bit0Forward));
        assert!(s.reverse_limit(LimitPolarity::Bit0Reverse));
    }

    #[test]
    fn faults_exclude_ordinary_bits_and_limits() {
        let s = StatusBits(CHANNEL_ENABLED | MOTION_ERROR | LIMIT_BIT1 | HOMED | OVERCURRENT);
        assert_eq!(
            s.faults(LimitPolarity::Bit0Forward),
            vec!["motion error", "overcurrent"]
        );
        assert_eq!(
            s.move_faults(LimitPolarity::Bit0Forward),
            vec!["reverse limit switch", "motion error", "overcurrent"]
        );
        assert!(StatusBits(CHANNEL_ENABLED | HOMED | SETTLED)
            .faults(LimitPolarity::Bit0Forward)
            .is_empty());
        // Homed and resting on the home switch: the switch is no fault, the others still are.
        let home = StatusBits(CHANNEL_ENABLED | LIMIT_BIT1 | HOMED | OVERCURRENT);
        assert_eq!(
            home.faults_resting_home(LimitPolarity::Bit0Forward, true),
            vec!["overcurrent"]
        );
        assert_eq!(
            home.faults_resting_home(LimitPolarity::Bit0Forward, false),
            vec!["reverse limit switch", "overcurrent"]
        );
        assert_eq!(
            StatusBits(LIMIT_BIT0 | HOMED).faults_resting_home(LimitPolarity::Bit0Reverse, true),
            Vec::<&str>::new()
        );
        assert!(StatusBits(MOVING_REVERSE).moving());
        assert!(!StatusBits(HOMED).moving());
    }
}
