//! Physical quantities as types, so a unit mix-up does not compile.
//!
//! Every quantity is a thin `f64` newtype. Conversions to device units (microsteps, counts,
//! register values) live beside the codec that needs them, never here.

use std::fmt;
use std::ops::{Add, Div, Mul, Neg, Sub};

macro_rules! quantity {
    ($(#[$doc:meta])* $name:ident, $unit:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default, serde::Serialize, serde::Deserialize)]
        #[serde(transparent)]
        pub struct $name(pub f64);

        impl $name {
            /// Unit symbol used when printing.
            pub const UNIT: &'static str = $unit;
            /// The raw number in this unit.
            pub fn value(self) -> f64 {
                self.0
            }
            /// Absolute value.
            pub fn abs(self) -> Self {
                Self(self.0.abs())
            }
        }
        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                if let Some(p) = f.precision() {
                    write!(f, "{:.*} {}", p, self.0, $unit)
                } else {
                    write!(f, "{} {}", self.0, $unit)
                }
            }
        }
        impl Add for $name {
            type Output = Self;
            fn add(self, o: Self) -> Self {
                Self(self.0 + o.0)
            }
        }
        impl Sub for $name {
            type Output = Self;
            fn sub(self, o: Self) -> Self {
                Self(self.0 - o.0)
            }
        }
        impl Neg for $name {
            type Output = Self;
            fn neg(self) -> Self {
                Self(-self.0)
            }
        }
        impl Mul<f64> for $name {
            type Output = Self;
            fn mul(self, k: f64) -> Self {
                Self(self.0 * k)
            }
        }
        impl Div<f64> for $name {
            type Output = Self;
            fn div(self, k: f64) -> Self {
                Self(self.0 / k)
            }
        }
    };
}

quantity!(
    /// A length in millimetres (stage positions, contact points).
    Millimetres,
    "mm"
);
quantity!(
    /// A speed in millimetres per second.
    MillimetresPerSecond,
    "mm/s"
);
quantity!(
    /// An acceleration in millimetres per second squared.
    MillimetresPerSecondSquared,
    "mm/s^2"
);
quantity!(
    /// A force in newtons.
    Newtons,
    "N"
);
quantity!(
    /// A torque in newton metres.
    NewtonMetres,
    "N m"
);
quantity!(
    /// A time span in microseconds (camera exposure).
    Microseconds,
    "us"
);
quantity!(
    /// A frequency in hertz (frame rate, sample rate).
    Hertz,
    "Hz"
);
quantity!(
    /// A voltage in volts (strain gauges, strobe channel).
    Volts,
    "V"
);
quantity!(
    /// Gain in decibels.
    Decibels,
    "dB"
);

/// Six-axis force and torque, in the sensor frame, in N and N m.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Wrench {
    pub fx: Newtons,
    pub fy: Newtons,
    pub fz: Newtons,
    pub tx: NewtonMetres,
    pub ty: NewtonMetres,
    pub tz: NewtonMetres,
}

impl Wrench {
    /// Builds a wrench from `[Fx, Fy, Fz]` in N and `[Tx, Ty, Tz]` in N m.
    pub fn from_arrays(force: [f64; 3], torque: [f64; 3]) -> Self {
        Wrench {
            fx: Newtons(force[0]),
            fy: Newtons(force[1]),
            fz: Newtons(force[2]),
            tx: NewtonMetres(torque[0]),
            ty: NewtonMetres(torque[1]),
            tz: NewtonMetres(torque[2]),
        }
    }

    /// `[Fx, Fy, Fz, Tx, Ty, Tz]` as plain numbers (N, N m).
    pub fn to_array(&self) -> [f64; 6] {
        [
            self.fx.0, self.fy.0, self.fz.0, self.tx.0, self.ty.0, self.tz.0,
        ]
    }

    /// Inverse of [`Wrench::to_array`].
    pub fn from_array(v: [f64; 6]) -> Self {
        Wrench::from_arrays([v[0], v[1], v[2]], [v[3], v[4], v[5]])
    }

    /// Magnitude of the force vector.
    pub fn force_magnitude(&self) -> Newtons {
        Newtons((self.fx.0 * self.fx.0 + self.fy.0 * self.fy.0 + self.fz.0 * self.fz.0).sqrt())
    }
}

impl Sub for Wrench {
    type Output = Wrench;
    fn sub(self, o: Wrench) -> Wrench {
        let (a, b) = (self.to_array(), o.to_array());
        Wrench::from_array(std::array::from_fn(|i| a[i] - b[i]))
    }
}

impl Add for Wrench {
    type Output = Wrench;
    fn add(self, o: Wrench) -> Wrench {
        let (a, b) = (self.to_array(), o.to_array());
        Wrench::from_array(std::array::from_fn(|i| a[i] + b[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_keeps_precision_and_unit() {
        assert_eq!(format!("{:.3}", Millimetres(1.23456)), "1.235 mm");
        assert_eq!(format!("{}", Newtons(2.5)), "2.5 N");
    }

    #[test]
    fn wrench_round_trips_through_arrays() {
        let w = Wrench::from_array([1.0, -2.0, 3.0, 0.1, 0.2, -0.3]);
        assert_eq!(w.to_array(), [1.0, -2.0, 3.0, 0.1, 0.2, -0.3]);
        assert_eq!((w - w).to_array(), [0.0; 6]);
        assert!((Wrench::from_arrays([3.0, 4.0, 0.0], [0.0; 3]).force_magnitude().0 - 5.0).abs() < 1e-12);
    }
}
