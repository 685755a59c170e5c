//! The Units screen's side of the units: every unit known, read from the rig's profiles (and the
//! simulated bench's units) by `fringe_app::units::list`, and when to read them again.

use super::state::UnitsView;
use fringe_app::units;
use fringe_app::RigConfig;
use std::time::SystemTime;

/// The units as the profiles are now, the rig's unit selected.
pub fn view(config: &RigConfig) -> UnitsView {
    let l = units::list(config, &fringe_rig::store::now_utc());
    let selected = l
        .on_rig
        .as_ref()
        .and_then(|r| l.units.iter().position(|u| &u.id == r))
        .unwrap_or(0);
    UnitsView {
        profiles: l.profiles.display().to_string(),
        on_rig: l.on_rig,
        units: l.units,
        notes: l.notes,
        selected,
    }
}

/// When the profiles directory last changed (a unit commissioned, checked or calibrated adds or
/// renames a file there).
pub fn changed(config: &RigConfig) -> Option<SystemTime> {
    let dir = config.profile_dir();
    let mut newest = std::fs::metadata(&dir).and_then(|m| m.modified()).ok();
    for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
        let m = e.metadata().and_then(|m| m.modified()).ok();
        newest = newest.max(m);
    }
    newest
}
