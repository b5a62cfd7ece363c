//! Overrides: `--set SECTION.KEY=VALUE` applied to a configuration's TOML
//! text before it is parsed.

use super::errors::parse_message;
use super::DEPRECATED_KEYS;
use crate::error::ConfigError;
use crate::io::text::shown;

/// Applies `--set SECTION.KEY=VALUE` overrides to a configuration's TOML
/// text: each VALUE is TOML (`0.3`, `[0.1, 0.2]`, `"f32"`, `{ … }`) or else
/// taken as a string, and replaces or adds the key. The result is parsed
/// and validated like any file, so an override is checked exactly as the
/// same line in the file would be, and echoed wherever the configuration is.
///
/// ```
/// use mbs::config::apply_overrides;
///
/// let text = apply_overrides("[flow]\ntau_star = [0.1]\n", &["flow.tau_star=[0.2, 0.3]".into(), "run.precision=f32".into()])?;
/// let c = mbs::Config::from_toml(&text)?;
/// assert_eq!(c.tau_stars, [0.2, 0.3]);
/// assert!(apply_overrides("", &["tau_star=0.2".into()]).is_err());
/// # Ok::<(), mbs::ConfigError>(())
/// ```
pub fn apply_overrides(text: &str, sets: &[String]) -> Result<String, ConfigError> {
    if sets.is_empty() {
        return Ok(text.to_string());
    }
    let mut table: toml::Table =
        toml::from_str(text).map_err(|e| ConfigError::Parse(parse_message(text, &e)))?;
    for set in sets {
        let bad = |allowed: String| ConfigError::Invalid {
            key: "--set".into(),
            value: shown(set.clone()),
            allowed,
        };
        let usage = || bad("SECTION.KEY=VALUE, e.g. flow.tau_star=[0.1, 0.2]".into());
        let (path, value) = set.split_once('=').ok_or_else(usage)?;
        let keys: Vec<&str> = path.trim().split('.').map(str::trim).collect();
        let Some((last, sections)) = keys.split_last().filter(|(_, s)| !s.is_empty()) else {
            return Err(usage());
        };
        if keys.iter().any(|k| k.is_empty()) {
            return Err(usage());
        }
        let value = value.trim();
        let value = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.to_string()));
        let mut at = &mut table;
        for section in sections {
            at = at
                .entry(section.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .ok_or_else(|| bad(format!("{section} is a key, not a section")))?;
        }
        // A renamed key set under either name replaces the other.
        for (section, old, new) in DEPRECATED_KEYS {
            if sections == [*section] && (*last == *old || *last == *new) {
                at.remove(*old);
                at.remove(*new);
            }
        }
        at.insert(last.to_string(), value);
    }
    toml::to_string(&table).map_err(|e| ConfigError::Parse(e.to_string()))
}
