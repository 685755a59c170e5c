//! The screens, in tab order: the one list a new screen is added to (its file goes beside
//! these, its name in [`super::state::Tab`]).

mod bench;
mod calibrate;
mod commission;
mod health;
mod runs;
mod scan;
mod validate;

use super::screen::ScreenDef;
use super::state::Tab;

pub const ALL: &[ScreenDef] = &[
    scan::SCREEN,
    validate::SCREEN,
    runs::SCREEN,
    bench::SCREEN,
    calibrate::SCREEN,
    commission::SCREEN,
    health::SCREEN,
];

/// Where `tab` is in [`ALL`].
pub fn index(tab: Tab) -> usize {
    ALL.iter().position(|s| s.tab == tab).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_tab_has_one_screen() {
        for tab in [
            Tab::Scan,
            Tab::Validate,
            Tab::Runs,
            Tab::Bench,
            Tab::Calibrate,
            Tab::Commission,
            Tab::Health,
        ] {
            assert_eq!(ALL.iter().filter(|s| s.tab == tab).count(), 1, "{tab:?}");
        }
    }
}
