//! The screens, in tab order: the one list a new screen is added to. A screen is its file
//! beside these (`screens/<name>.rs`, declaring its `TAB` and its `SCREEN`) and its name in the
//! list below, which declares the module and gives its place: its tab order and its number key.

use super::screen::ScreenDef;
use super::state::Tab;

/// Declares each screen's module and lists their `SCREEN`s, in that order, as [`ALL`].
macro_rules! screens {
    ($($name:ident),+ $(,)?) => {
        $(pub mod $name;)+

        /// Every screen, in tab order.
        pub const ALL: &[ScreenDef] = &[$($name::SCREEN),+];
    };
}

screens! {
    scan,
    validate,
    runs,
    bench,
    calibrate,
    commission,
    health,
    units,
    stream,
}

/// Where `tab` is in [`ALL`].
pub fn index(tab: Tab) -> usize {
    ALL.iter().position(|s| s.tab == tab).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_screen_has_a_tab_and_a_title_of_its_own() {
        for (i, s) in ALL.iter().enumerate() {
            for other in &ALL[..i] {
                assert_ne!(s.tab, other.tab, "{} and {}", s.title, other.title);
                assert_ne!(s.title, other.title, "{:?} and {:?}", s.tab, other.tab);
            }
            assert_eq!(index(s.tab), i, "{}", s.title);
        }
    }
}
