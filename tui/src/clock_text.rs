//! Durations as the front ends print them: `H:MM:SS`, one format for the screens and the
//! command line.

use std::time::Duration;

/// `d` as hours, minutes and seconds (`0:03:05`, `12:00:00`).
pub(crate) fn clock(d: Duration) -> String {
    let s = d.as_secs();
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hours_minutes_seconds() {
        assert_eq!(clock(Duration::from_secs(185)), "0:03:05");
        assert_eq!(clock(Duration::from_millis(43_200_999)), "12:00:00");
    }
}
