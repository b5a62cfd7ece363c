//! Loading: the one place in `config/` that reads files. [`load`] reads the
//! configuration file (or takes text, the embedded default or a parsed
//! file), applies the `--set` overrides, parses it and reads the files it
//! names, then hands all of it to validation (`validate.rs`), which reads
//! nothing.

use super::defaults::DEFAULT_TOML;
use super::errors::parse_message;
use super::file::ConfigFile;
use super::limits::CONFIG_BOUND;
use super::overrides::apply_overrides;
use super::validate::{validate, Named};
use super::Config;
use super::DEPRECATED_KEYS;
use crate::error::ConfigError;
use crate::io::input::read_text_bounded;
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
        Source::Text(text) => {
            let text = apply_overrides(text, sets)?;
            let file: ConfigFile =
                toml::from_str(&text).map_err(|e| ConfigError::Parse(parse_message(&text, &e)))?;
            let mut config = load(Source::Parsed(Box::new(file)), &[])?;
            config.renamed_keys = renamed_keys(&text);
            Ok(config)
        }
        Source::File(p) => {
            let text = read_text_bounded(p, CONFIG_BOUND).map_err(|source| ConfigError::Read {
                path: p.to_path_buf(),
                source,
            })?;
            load(Source::Text(&text), sets).map_err(|e| match e {
                ConfigError::Parse(m) => ConfigError::Parse(format!("{}: {m}", p.display())),
                other => other,
            })
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
