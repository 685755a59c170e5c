//! When a unit's next health check is due. The policy (no other existed): a commissioned unit is
//! checked every [`CHECK_EVERY_DAYS`] days, counted from its last check, or from its passing
//! certificate when it has not been checked since; a check that was not ok asks for what its
//! verdict says (calibrate, commission again, repair) and a check again now; a unit without a
//! passing certificate has nothing to be checked against (commission it first).

use crate::health::figures::Verdict;
use fringe_rig::store::{utc_date, utc_days};

/// Days between checks of a unit that was ok.
pub const CHECK_EVERY_DAYS: i64 = 7;

/// When a unit's next check is due.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NextCheck {
    /// No passing certificate: nothing to check against.
    NotCommissioned,
    /// The last check was not ok: act on its verdict, then check again.
    Now(Verdict),
    /// On `date` (YYYY-MM-DD, UTC); `overdue` when that is before today.
    On { date: String, overdue: bool },
}

impl NextCheck {
    /// In words: `2026-12-13`, `2026-12-01 (overdue)`, `now (the last check: recalibrate)`.
    pub fn describe(&self) -> String {
        match self {
            NextCheck::NotCommissioned => "none: commission the unit first".into(),
            NextCheck::Now(v) => format!("now, after acting on the last check ({})", v.name()),
            NextCheck::On { date, overdue } => {
                if *overdue {
                    format!("{date} (overdue)")
                } else {
                    date.clone()
                }
            }
        }
    }
}

/// The next check of a unit whose newest passing certificate was issued at `certified` (RFC 3339,
/// `None`: none) and whose last check was at `last` with its verdict, on `today` (RFC 3339).
pub fn next_check(
    certified: Option<&str>,
    last: Option<(&str, Verdict)>,
    today: &str,
) -> NextCheck {
    let Some(certified) = certified else {
        return NextCheck::NotCommissioned;
    };
    // A check before the newest certificate is of the unit as it was before.
    let since = match last {
        Some((at, verdict)) if at >= certified => {
            if verdict != Verdict::Ok {
                return NextCheck::Now(verdict);
            }
            at
        }
        _ => certified,
    };
    let Some(day) = utc_days(since) else {
        return NextCheck::Now(Verdict::Ok);
    };
    let due = day + CHECK_EVERY_DAYS;
    NextCheck::On {
        date: utc_date(due),
        overdue: utc_days(today).is_some_and(|t| t > due),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_check_is_due_a_week_after_the_last_one_or_the_certificate() {
        let today = "2026-12-06T12:00:00Z";
        assert_eq!(next_check(None, None, today), NextCheck::NotCommissioned);
        let certified = Some("2026-12-01T09:00:00Z");
        assert_eq!(
            next_check(certified, None, today),
            NextCheck::On {
                date: "2026-12-08".into(),
                overdue: false
            }
        );
        assert_eq!(
            next_check(
                certified,
                Some(("2026-12-05T09:00:00Z", Verdict::Ok)),
                today
            ),
            NextCheck::On {
                date: "2026-12-12".into(),
                overdue: false
            }
        );
        // A check before the newest certificate does not count.
        assert_eq!(
            next_check(
                certified,
                Some(("2026-11-01T09:00:00Z", Verdict::Recalibrate)),
                today
            ),
            NextCheck::On {
                date: "2026-12-08".into(),
                overdue: false
            }
        );
        assert_eq!(
            next_check(
                certified,
                Some(("2026-12-02T09:00:00Z", Verdict::Recalibrate)),
                today
            ),
            NextCheck::Now(Verdict::Recalibrate)
        );
        assert_eq!(
            next_check(certified, None, "2026-12-20T00:00:00Z"),
            NextCheck::On {
                date: "2026-12-08".into(),
                overdue: true
            }
        );
    }
}
