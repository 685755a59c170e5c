//! Key bindings as data: which keys, where they act, what they do and what the help says of
//! them. Dispatch ([`find`]) and the `?` help ([`help_rows`]) read the same tables.

use ratatui::crossterm::event::{KeyCode, KeyModifiers};

/// A key as a table names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Key {
    pub code: KeyCode,
    /// Only with Ctrl held.
    pub ctrl: bool,
}

/// A character key.
pub const fn char(c: char) -> Key {
    Key {
        code: KeyCode::Char(c),
        ctrl: false,
    }
}

/// A named key (Enter, Esc, arrows...).
pub const fn code(code: KeyCode) -> Key {
    Key { code, ctrl: false }
}

/// A character key with Ctrl.
pub const fn ctrl(c: char) -> Key {
    Key {
        code: KeyCode::Char(c),
        ctrl: true,
    }
}

/// Where a screen's binding acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// While its screen is shown (the help names the screen after the keys).
    Shown,
    /// On every screen.
    Everywhere,
}

/// Keys, where they act, the action they stand for and their line in the help.
#[derive(Debug, Clone, Copy)]
pub struct Binding<A> {
    pub keys: &'static [Key],
    pub scope: Scope,
    pub action: A,
    /// The keys as the help writes them; empty: not listed (the overlay that takes them says).
    pub label: &'static str,
    /// What they do, as the help says it.
    pub help: &'static str,
}

/// The action `table` binds to the key pressed, when `shown` or everywhere. A binding whose
/// Ctrl matches the key's wins; keys named without Ctrl also answer with any modifier held
/// (Shift makes the capitals).
pub fn find<A: Copy>(
    table: &[Binding<A>],
    code: KeyCode,
    mods: KeyModifiers,
    shown: bool,
) -> Option<A> {
    let ctrl = mods.contains(KeyModifiers::CONTROL);
    let active = |b: &&Binding<A>| shown || b.scope == Scope::Everywhere;
    let exact = table
        .iter()
        .filter(active)
        .find(|b| b.keys.iter().any(|k| k.code == code && k.ctrl == ctrl));
    exact
        .or_else(|| {
            table
                .iter()
                .filter(active)
                .find(|b| b.keys.iter().any(|k| k.code == code && !k.ctrl))
        })
        .map(|b| b.action)
}

/// One line of the help.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HelpRow {
    pub keys: String,
    pub what: String,
}

/// The listed bindings of `table` as help lines; `screen`, when given, names where the bindings
/// scoped to their screen act.
pub fn help_rows<A>(table: &[Binding<A>], screen: Option<&str>) -> Vec<HelpRow> {
    table
        .iter()
        .filter(|b| !b.label.is_empty())
        .map(|b| HelpRow {
            keys: match (b.scope, screen) {
                (Scope::Shown, Some(s)) => format!("{} ({s})", b.label),
                _ => b.label.to_string(),
            },
            what: b.help.to_string(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, Copy, PartialEq)]
    enum A {
        Continue,
        Quit,
        Jog,
    }

    const TABLE: &[Binding<A>] = &[
        Binding {
            keys: &[char('c')],
            scope: Scope::Everywhere,
            action: A::Continue,
            label: "c",
            help: "continue",
        },
        Binding {
            keys: &[code(KeyCode::Left), char('-')],
            scope: Scope::Shown,
            action: A::Jog,
            label: "←",
            help: "jog",
        },
        Binding {
            keys: &[ctrl('c')],
            scope: Scope::Everywhere,
            action: A::Quit,
            label: "Ctrl-C",
            help: "quit",
        },
    ];

    #[test]
    fn ctrl_keys_win_and_plain_keys_answer_with_any_modifier() {
        let none = KeyModifiers::NONE;
        assert_eq!(
            find(TABLE, KeyCode::Char('c'), KeyModifiers::CONTROL, true),
            Some(A::Quit)
        );
        assert_eq!(
            find(TABLE, KeyCode::Char('c'), none, true),
            Some(A::Continue)
        );
        assert_eq!(
            find(TABLE, KeyCode::Char('-'), KeyModifiers::ALT, true),
            Some(A::Jog)
        );
        assert_eq!(find(TABLE, KeyCode::Left, none, false), None);
        assert_eq!(find(TABLE, KeyCode::Char('x'), none, true), None);
    }

    #[test]
    fn help_names_the_screen_of_scoped_bindings() {
        let rows = help_rows(TABLE, Some("Bench"));
        let keys: Vec<&str> = rows.iter().map(|r| r.keys.as_str()).collect();
        assert_eq!(keys, ["c", "← (Bench)", "Ctrl-C"]);
    }
}
