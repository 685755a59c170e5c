//! The one loader of TOML configuration files (rig, plans, sensors, register maps, profiles):
//! errors name the file, the line, the section and key, and what was wrong.

use serde::de::DeserializeOwned;
use std::path::Path;

/// A configuration file that could not be read or understood.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{origin}: {message}")]
pub struct ConfigError {
    /// File path or other origin ("built-in layered sensor").
    pub origin: String,
    pub message: String,
}

/// Parses TOML text into `T`; `origin` names the text in the error, whose message is one line:
/// "line N, key section.key: message".
pub fn parse_toml<T: DeserializeOwned>(text: &str, origin: &str) -> Result<T, ConfigError> {
    toml::from_str(text).map_err(|e| ConfigError {
        origin: origin.to_string(),
        message: describe_toml_error(text, &e),
    })
}

/// Reads and parses a TOML file; errors name the file.
pub fn load_toml<T: DeserializeOwned>(path: &Path) -> Result<(T, String), ConfigError> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
        origin: origin.clone(),
        message: format!("cannot read: {e}"),
    })?;
    let value = parse_toml(&text, &origin)?;
    Ok((value, text))
}

/// A one-line message for a TOML error: line, section and key, then what was wrong.
pub(crate) fn describe_toml_error(text: &str, e: &toml::de::Error) -> String {
    let Some(span) = e.span() else {
        return match e.message().trim() {
            "" => "not valid TOML".to_string(),
            m => m.to_string(),
        };
    };
    let before = text.get(..span.start).unwrap_or(text);
    let line_no = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let message = match e.message().trim_end().replace('\n', " ") {
        m if m.is_empty() => "not valid TOML here".to_string(),
        m => m,
    };
    // An error on a table header is about that section, not the one before it.
    let line = text[line_start..].lines().next().unwrap_or("").trim();
    if line.starts_with('[') {
        let name = line.trim_matches(|c| c == '[' || c == ']').trim();
        // A misspelt section is an unknown field of the level above: say it is a section.
        let last = name.rsplit('.').next().unwrap_or(name).trim();
        if let Some(rest) = message.strip_prefix(&format!("unknown field `{last}`")) {
            return format!("line {line_no}: unknown section [{name}]{rest}");
        }
        return format!("line {line_no}, section [{name}]: {message}");
    }
    // The key is the last `name =` before the error on its line.
    let key = before[line_start..]
        .rsplit_once('=')
        .map(|(k, _)| k)
        .and_then(|k| {
            k.rsplit(|c: char| c == '{' || c == ',' || c.is_whitespace())
                .find(|t| !t.is_empty())
        })
        .map(|k| k.trim().to_string());
    let section = before
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with('[') && l.ends_with(']'))
        .map(|l| l.trim_matches(|c| c == '[' || c == ']').to_string());
    let mut at = format!("line {line_no}");
    match (section, key) {
        (Some(s), Some(k)) => at.push_str(&format!(", key {s}.{k}")),
        (None, Some(k)) => at.push_str(&format!(", key {k}")),
        (Some(s), None) => at.push_str(&format!(", section [{s}]")),
        (None, None) => {}
    }
    format!("{at}: {message}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Axis {
        velocity: f64,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct File {
        x: Axis,
    }

    #[test]
    fn errors_name_line_section_and_key() {
        let err = parse_toml::<File>("[x]\nvelocity = \"fast\"\n", "t.toml")
            .expect_err("string")
            .message;
        assert!(err.starts_with("line 2, key x.velocity:"), "{err}");
        let err = parse_toml::<File>("[x]\nvelocity = 1.0\nspeed = 2\n", "t.toml")
            .expect_err("unknown")
            .message;
        assert!(err.contains("line 3") && err.contains("speed"), "{err}");
        let dir = std::env::temp_dir().join(format!("fringe-config-{}", std::process::id()));
        let err = parse_toml::<File>("[x]\nvelocity = 1.0\n[xx]\nvelocity = 2.0\n", "t.toml")
            .expect_err("section")
            .message;
        assert_eq!(err, "line 3: unknown section [xx], expected `x`");
        let err = parse_toml::<File>("[x]\nvelocity = 1.0\u{0}\n", "t.toml")
            .expect_err("nul")
            .message;
        assert!(
            err.starts_with("line 2") && err.len() > "line 2, key x.velocity: ".len(),
            "{err}"
        );
        let err = load_toml::<File>(&dir.join("missing.toml")).expect_err("missing");
        assert!(
            err.to_string().contains("missing.toml: cannot read"),
            "{err}"
        );
    }
}
