//! Overrides: `--set SECTION.KEY=VALUE`, each parsed on its own
//! ([`Override::parse`]: one key, a TOML value or a bare word), applied to
//! a configuration's TOML table ([`apply_overrides`]), and the errors a set
//! value causes named by the `--set` that gave it ([`Override::blame`]).

use super::errors::parse_message;
use super::DEPRECATED_KEYS;
use crate::error::ConfigError;
use crate::io::text::shown;

/// Keys of a section that say the same thing in other words: a `--set` of
/// one replaces the others (the embedded default's, the file's).
const ALTERNATIVES: [(&str, &[&str]); 2] = [
    ("grains", &["diameter_mm", "classes"]),
    ("flow", &["tau_star", "u_star_m_s", "slope"]),
];

/// The sections of a configuration file ([`super::ConfigFile`]).
const SECTIONS: [&str; 9] = [
    "grains", "bed", "contact", "time", "flow", "fluid", "channel", "target", "run",
];

/// Keys whose value is a list: a single value given with `--set` is a list
/// of one (`--set flow.tau_star=0.1`).
const LISTS: [&str; 4] = [
    "flow.tau_star",
    "flow.u_star_m_s",
    "flow.slope",
    "run.seeds",
];

/// One `--set SECTION.KEY=VALUE`, parsed.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// As given on the command line.
    pub given: String,
    /// The dotted key's parts: sections, then the key.
    pub path: Vec<String>,
    /// The value.
    pub value: toml::Value,
}

impl Override {
    /// Parses `SECTION.KEY=VALUE`: the key's parts are bare TOML keys, the
    /// VALUE is a TOML value (`0.3`, `[0.1, 0.2]`, `"f32"`, `{ … }`) or a
    /// bare word taken as a string (`f32`, `out/dir`). A line break, a value
    /// that looks like a number or a list but is not valid TOML (`1e400`,
    /// `[0.1,`) and anything that would set a second key are refused.
    ///
    /// ```
    /// use mbs::config::Override;
    ///
    /// let o = Override::parse("flow.tau_star=[0.2, 0.3]")?;
    /// assert_eq!(o.key(), "flow.tau_star");
    /// assert_eq!(Override::parse("run.precision=f32")?.value.as_str(), Some("f32"));
    /// // A single value of a list key is a list of one.
    /// assert!(Override::parse("flow.tau_star=0.1")?.value.is_array());
    /// for bad in ["tau_star=0.2", "flow.eps0=1e400", "flow.tau_star=[0.1,", "bed.columns=6\nrows=99"] {
    ///     assert!(Override::parse(bad).is_err(), "{bad}");
    /// }
    /// # Ok::<(), mbs::ConfigError>(())
    /// ```
    pub fn parse(set: &str) -> Result<Override, ConfigError> {
        let bad = |why: String| {
            ConfigError::Parse(format!(
                "--set {}: {why}",
                shown(set.escape_debug().to_string())
            ))
        };
        if set.chars().any(char::is_control) {
            return Err(bad(
                "holds a line break or another control character: give one \
                 SECTION.KEY=VALUE to each --set"
                    .into(),
            ));
        }
        let usage = || bad("must be SECTION.KEY=VALUE, e.g. flow.tau_star=[0.1, 0.2]".into());
        let (key, text) = set.split_once('=').ok_or_else(usage)?;
        let path: Vec<String> = key
            .trim()
            .split('.')
            .map(|k| k.trim().to_string())
            .collect();
        let bare = |k: &String| {
            !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        };
        if path.len() < 2 || !path.iter().all(bare) {
            return Err(usage());
        }
        let text = text.trim();
        let value = match toml::from_str::<toml::Table>(&format!("v = {text}")) {
            Ok(table) if table.len() == 1 => table.get("v").cloned().ok_or_else(usage)?,
            Ok(_) => return Err(usage()),
            Err(e) if looks_typed(text) => {
                return Err(bad(format!(
                    "{} is not a TOML value (a number, a list [..], a table {{..}} or a quoted \
                     string): {}",
                    shown(text.to_string()),
                    e.message().trim_end()
                )))
            }
            Err(_) => toml::Value::String(text.to_string()),
        };
        let mut o = Override {
            given: set.to_string(),
            path,
            value,
        };
        if LISTS.contains(&o.key().as_str()) && !o.value.is_array() {
            o.value = toml::Value::Array(vec![o.value]);
        }
        Ok(o)
    }

    /// The dotted key, e.g. `flow.tau_star`.
    pub fn key(&self) -> String {
        self.path.join(".")
    }

    /// Whether an error about `key` (`flow.tau_star[1]`,
    /// `grains.classes[0].diameter_mm`, `flow.kappa`) is about this value.
    pub fn blame(&self, key: &str) -> bool {
        let own = self.key();
        key.strip_prefix(own.as_str())
            .is_some_and(|rest| rest.is_empty() || rest.starts_with(['[', '.', ' ']))
    }

    /// Whether this value made the section `section`, one a configuration
    /// does not have (`x` of `--set x.y=1`).
    fn made(&self, section: &str) -> bool {
        !SECTIONS.contains(&section) && self.path.first().is_some_and(|first| first == section)
    }
}

/// Whether a value that is not valid TOML was meant as a number, a list, a
/// table or a quoted string (rather than a bare word such as `f32`).
fn looks_typed(text: &str) -> bool {
    let mut chars = text.chars();
    match chars.next() {
        Some('[' | '{' | '"' | '\'' | '+' | '-' | '0'..='9') => true,
        Some('.') => chars.next().is_some_and(|c| c.is_ascii_digit()),
        _ => false,
    }
}

/// Applies `--set SECTION.KEY=VALUE` overrides ([`Override::parse`]) to a
/// configuration's TOML text: each replaces or adds its key (and replaces
/// the section's alternatives to it, e.g. `grains.classes` the default's
/// `grains.diameter_mm`). The result is parsed and validated like any
/// file, so an override is checked exactly as the same line in the file
/// would be, and echoed wherever the configuration is.
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
        let o = Override::parse(set)?;
        let Some((last, sections)) = o.path.split_last() else {
            continue;
        };
        let mut at = &mut table;
        for section in sections {
            at = at
                .entry(section.clone())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .ok_or_else(|| ConfigError::Invalid {
                    key: "--set".into(),
                    value: shown(o.given.clone()),
                    allowed: format!("a key of a section: {section} is a key, not a section"),
                })?;
        }
        let renamed = DEPRECATED_KEYS
            .iter()
            .map(|(section, old, new)| (*section, vec![*old, *new]));
        let alternatives = ALTERNATIVES.iter().map(|(s, keys)| (*s, keys.to_vec()));
        for (section, keys) in alternatives.chain(renamed) {
            if sections == [section] && keys.contains(&last.as_str()) {
                for k in keys {
                    at.remove(k);
                }
            }
        }
        at.insert(last.clone(), o.value);
    }
    toml::to_string(&table).map_err(|e| ConfigError::Parse(e.to_string()))
}

/// A parse error of the text with overrides applied, `e` at the key that
/// `text` holds at its span: named by the `--set` that gave that key
/// (`--set flow.kappa=abc: invalid type: …`), else toml's message.
pub(super) fn set_parse_error(text: &str, e: &toml::de::Error, sets: &[String]) -> ConfigError {
    let key = e.span().and_then(|span| key_at(text, span.start));
    let blamed = key.and_then(|key| {
        sets.iter()
            .filter_map(|s| Override::parse(s).ok())
            .find(|o| o.blame(&key) || o.made(&key))
    });
    match blamed {
        Some(o) => ConfigError::Parse(shown(format!(
            "--set {}: {}",
            o.given,
            e.message().trim_end()
        ))),
        None => ConfigError::Parse(parse_message(text, e)),
    }
}

/// The dotted key of the line of `text` at byte `at`: its section and the
/// name before its `=`.
fn key_at(text: &str, at: usize) -> Option<String> {
    let before = text.get(..at)?;
    let line_start = before.rfind('\n').map_or(0, |n| n + 1);
    let line = text.get(line_start..)?.lines().next()?;
    // A section's header (`[x]`, `[grains.classes]`, `[[flow.tau_star]]`,
    // as toml writes a table value): its dotted name.
    if let Some(header) = line.trim().strip_prefix('[') {
        let name = header.trim_start_matches('[').split(']').next()?;
        return Some(name.trim().to_string());
    }
    let name = line.split('=').next()?.trim();
    let section = before
        .lines()
        .rev()
        .find_map(|l| l.trim().strip_prefix('[')?.split(']').next())
        .unwrap_or("");
    Some(format!("{section}.{name}"))
}

/// The line (1-based) of `text`, a configuration file, that gives the
/// dotted `key` (`flow.kappa`, also `flow.tau_star[1]`): a `name = …` line in
/// its `[section]`. `None` where the key is not written that way.
pub(super) fn line_of(text: &str, key: &str) -> Option<usize> {
    let (section, name) = key.split_once('.')?;
    let name: String = name
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect();
    let mut current = "";
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(header) = line.strip_prefix('[') {
            current = header.split(']').next().unwrap_or("").trim();
        } else if current == section
            && line
                .split('=')
                .next()
                .is_some_and(|k| line.contains('=') && k.trim() == name)
        {
            return Some(n + 1);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_name_themselves_and_lines_are_found() {
        let o = Override::parse(" flow.kappa = 0.3 ").unwrap();
        assert_eq!(
            (o.key(), o.value.as_float()),
            ("flow.kappa".into(), Some(0.3))
        );
        assert!(o.blame("flow.kappa") && !o.blame("flow.kappa_x") && !o.blame("flow"));
        // A section the value made, not one every configuration has.
        assert!(!o.made("flow") && Override::parse("x.y=1").unwrap().made("x"));
        // toml writes a table value as a section's header.
        let header = "a = 1\n[[flow.tau_star]]\nb = 2\n";
        assert_eq!(key_at(header, 7).as_deref(), Some("flow.tau_star"));
        // SECTIONS are the file's: an unknown one lists exactly them.
        let e = toml::from_str::<super::super::ConfigFile>("[zzz]\n")
            .unwrap_err()
            .to_string();
        assert!(
            SECTIONS.iter().all(|s| e.contains(&format!("`{s}`"))),
            "{e}"
        );
        assert_eq!(e.matches('`').count(), 2 * (SECTIONS.len() + 1), "{e}");
        let t = Override::parse("flow.tau_star=[0.1, 0.2]").unwrap();
        assert!(t.blame("flow.tau_star[1]") && t.blame("flow.tau_star"));
        let text = "# c\n[flow]\ntau_star = [0.1]\nkappa=0.4\n[run]\nseeds = [1]\n";
        assert_eq!(line_of(text, "flow.kappa"), Some(4));
        assert_eq!(line_of(text, "flow.tau_star[0]"), Some(3));
        assert_eq!(line_of(text, "run.seeds"), Some(6));
        assert_eq!(line_of(text, "run.kappa"), None);
        assert_eq!(
            key_at(text, text.find("0.4").unwrap()).as_deref(),
            Some("flow.kappa")
        );
        // Bare words are strings; typed-looking garbage is an error naming the set.
        assert_eq!(
            Override::parse("run.output=out/a b")
                .unwrap()
                .value
                .as_str(),
            Some("out/a b")
        );
        let e = Override::parse("flow.tau_star=[0.1,")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--set flow.tau_star=[0.1,: [0.1, is not a TOML value"),
            "{e}"
        );
        let e = Override::parse("bed.columns=6\nrows=99")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bed.columns=6\\nrows=99") && e.contains("line break"),
            "{e}"
        );
        // Alternatives replace each other; a set value of the wrong type names its --set.
        let text = apply_overrides(
            "[grains]\ndiameter_mm = 0.5\n",
            &["grains.classes=[{diameter_mm = 0.5, fraction = 1.0}]".into()],
        )
        .unwrap();
        let table: toml::Table = toml::from_str(&text).unwrap();
        let grains = table["grains"].as_table().unwrap();
        assert!(
            !grains.contains_key("diameter_mm") && grains.contains_key("classes"),
            "{text}"
        );
        let e = crate::Config::load_with(None, &["flow.hold_steps=1e-320".into()]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--set flow.hold_steps=1e-320: invalid type: floating point `1e-320`, expected u32"
        );
    }
}
