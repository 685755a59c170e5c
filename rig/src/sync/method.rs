//! The synchronisation methods a run can use to place frames in the force stream.

use std::fmt;
use std::str::FromStr;

/// How each frame's exposure window is found in the force stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SyncMethod {
    /// The camera's exposure-active signal sampled beside the force gauges: windows in the force
    /// stream's own sample index.
    Strobe,
    /// The camera triggered by a counter of the DAQ on the force stream's sample clock: frame n's
    /// exposure starts a known delay after scan n x (scan rate / frame rate).
    Trigger,
    /// Device clocks (camera ticks, F/T sample counter) mapped to host time by one-way
    /// lower-hull fits with drift, plus timestamp-latch exchanges where the camera offers them.
    ClockFit,
    /// Host arrival times (the reference pipeline's method), kept as a baseline only.
    Host,
}

impl SyncMethod {
    pub const ALL: [SyncMethod; 4] = [
        SyncMethod::Strobe,
        SyncMethod::Trigger,
        SyncMethod::ClockFit,
        SyncMethod::Host,
    ];

    /// The name used in rig.toml, run documents and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SyncMethod::Strobe => "strobe",
            SyncMethod::Trigger => "trigger",
            SyncMethod::ClockFit => "clock-fit",
            SyncMethod::Host => "host",
        }
    }
}

impl fmt::Display for SyncMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for SyncMethod {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        SyncMethod::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!("unknown sync method {s:?}: use strobe, trigger, clock-fit or host")
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_list_the_choices() {
        for m in SyncMethod::ALL {
            assert_eq!(m.name().parse::<SyncMethod>(), Ok(m));
        }
        let e = "clockfit".parse::<SyncMethod>().unwrap_err();
        assert!(e.contains("strobe, trigger, clock-fit or host"), "{e}");
    }
}
