//! Loading: the one place in `config/` that reads files. [`load`] reads the
//! configuration file (or takes text, the embedded default or a parsed
//! file), applies the `--set` overrides, parses it and reads the files it
//! names, then hands all of it to validation (`validate.rs`), which reads
//! nothing.

use super::defaults::DEFAULT_TOML;
use super::errors::parse_message;
use super::file::ConfigFile;
use super::limits::CONFIG_BOUND;
use super::overrides::{apply_overrides, line_of, set_parse_error, Override};
use super::validate::{validate, Named};
use super::Config;
use super::DEPRECATED_KEYS;
use crate::error::ConfigError;
use crate::io::input::read_text_bounded;
use crate::io::text::shown;
use crate::science::measured::MeasuredProfile;
use std::path::Path;

/// Where a configuration comes from.
pub(super) enum Source<'a> {
    /// The embedded default ([`DEFAULT_TOML`]).
    Default,
    /// TOML text.
    Text(&'a str),
    /// A file of TOML text, read (at most [`CONFIG_BOUND`]); its parse
    /// errors are prefixed with its path.
    File(&'a Path),
    /// A parsed file: with overrides, written back to text first.
    Parsed(Box<ConfigFile>),
}

/// The configuration of `source` with the `--set` overrides `sets`
/// ([`apply_overrides`]): every file read of a configuration happens here
/// (the configuration file, the measured profile of
/// `run.measured_profiles`), before validation; what a read gives,
/// an error included, is validated where the value is checked, so the
/// errors come in the order of the checks.
pub(super) fn load(source: Source<'_>, sets: &[String]) -> Result<Config, ConfigError> {
    match source {
        Source::Default => load(Source::Text(DEFAULT_TOML), sets),
        Source::Text(text) => load_text(text, sets, None),
        Source::File(p) => {
            let text = read_text_bounded(p, CONFIG_BOUND).map_err(|source| ConfigError::Read {
                path: p.to_path_buf(),
                source,
            })?;
            load_text(&text, sets, Some(p))
        }
        Source::Parsed(file) if !sets.is_empty() => {
            let text = toml::to_string(&file).map_err(|e| ConfigError::Parse(e.to_string()))?;
            load(Source::Text(&text), sets)
        }
        Source::Parsed(file) => {
            // Heights unshifted (z/d − 0 is z/d exactly): validation shifts
            // them once it has checked `run.measured_shift_d`.
            let measured = (file.run.measured_profiles.as_deref())
                .map(|path| MeasuredProfile::read(path, 0.0));
            validate(*file, Named { measured })
        }
    }
}

/// The configuration `text` (read from `path`, if from a file) with the
/// overrides `sets`. The text is parsed alone first, so that its errors
/// point at its own lines; an error a `--set` causes names that `--set`
/// ([`set_parse_error`]); a value out of range is named with where it was
/// given ([`given_at`]).
fn load_text(text: &str, sets: &[String], path: Option<&Path>) -> Result<Config, ConfigError> {
    let in_file = |m: String| match path {
        Some(p) => ConfigError::Parse(format!("{}: {m}", p.display())),
        None => ConfigError::Parse(m),
    };
    let own: ConfigFile = toml::from_str(text).map_err(|e| in_file(parse_message(text, &e)))?;
    let (file, merged) = if sets.is_empty() {
        (own, None)
    } else {
        let merged = apply_overrides(text, sets)?;
        let file = toml::from_str(&merged).map_err(|e| set_parse_error(&merged, &e, sets))?;
        (file, Some(merged))
    };
    let mut config =
        load(Source::Parsed(Box::new(file)), &[]).map_err(|e| given_at(e, text, sets, path))?;
    config.renamed_keys = renamed_keys(merged.as_deref().unwrap_or(text));
    Ok(config)
}

/// `e` with where its key's value was given: the last `--set` of that key,
/// else the line of the file `path` (when the text came from a file).
fn given_at(e: ConfigError, text: &str, sets: &[String], path: Option<&Path>) -> ConfigError {
    let key = match &e {
        ConfigError::Invalid { key, .. } => key.as_str(),
        ConfigError::Kernel { key, .. } => key,
        _ => return e,
    };
    let by_set = sets
        .iter()
        .rev()
        .filter_map(|s| Override::parse(s).ok())
        .find(|o| o.blame(key))
        .map(|o| format!("--set {}", shown(o.given)));
    let at = by_set.or_else(|| {
        let p = path?;
        line_of(text, key).map(|n| format!("{} line {n}", p.display()))
    });
    match at {
        Some(at) => ConfigError::Given {
            error: Box::new(e),
            at,
        },
        None => e,
    }
}

/// A warning for each renamed key ([`DEPRECATED_KEYS`]) that `text` (a
/// configuration that parsed) still uses.
fn renamed_keys(text: &str) -> Vec<String> {
    let Ok(table) = toml::from_str::<toml::Table>(text) else {
        return Vec::new();
    };
    DEPRECATED_KEYS
        .iter()
        .filter(|(section, old, _)| {
            (table.get(*section))
                .and_then(toml::Value::as_table)
                .is_some_and(|t| t.contains_key(*old))
        })
        .map(|(section, old, new)| {
            format!(
                "{section}.{old} is now {section}.{new}; the old key is read until the next \
                 release: write {section}.{new}"
            )
        })
        .collect()
}
