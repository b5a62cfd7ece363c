//! Reading markdown tables and CSV files, and comparing printed numbers
//! with their sources.

pub(crate) use std::collections::HashMap;
pub(crate) use std::path::{Path, PathBuf};

pub(crate) fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub(crate) fn read(path: &str) -> String {
    let p = root().join(path);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// A markdown table: its rows of cells, the header first, the `|---|` line left out.
pub(crate) type Table = Vec<Vec<String>>;

pub(crate) fn cells(line: &str) -> Vec<String> {
    let line = line.trim();
    let inner = line.strip_prefix('|').unwrap_or(line);
    let inner = inner.strip_suffix('|').unwrap_or(inner);
    inner.split('|').map(|c| c.trim().to_string()).collect()
}

pub(crate) fn is_rule(line: &str) -> bool {
    let t = line.trim();
    t.starts_with('|') && t.chars().all(|c| matches!(c, '|' | '-' | ':' | ' '))
}

/// Every table of `text`: (the line number of its header, 1-based; its rows).
pub(crate) fn tables(text: &str) -> Vec<(usize, Table)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim_start().starts_with('|') {
            let start = i;
            let mut rows = Vec::new();
            while i < lines.len() && lines[i].trim_start().starts_with('|') {
                if !is_rule(lines[i]) {
                    rows.push(cells(lines[i]));
                }
                i += 1;
            }
            out.push((start + 1, rows));
        } else {
            i += 1;
        }
    }
    out
}

/// The table announced by `<!-- checked: NAME -->` in the document at `path`.
pub(crate) fn table(path: &str, name: &str) -> Table {
    let text = read(path);
    let marker = format!("<!-- checked: {name} -->");
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.trim() == marker)
        .unwrap_or_else(|| panic!("{path}: no line `{marker}`"));
    let from: usize = lines[..=at].iter().map(|l| l.len() + 1).sum();
    let (_, t) = tables(&text[from.min(text.len())..])
        .into_iter()
        .next()
        .unwrap_or_else(|| panic!("{path}: no table after `{marker}`"));
    t
}

/// The table of the document at `path` whose header starts with the cells
/// `header` (for docs/calibration/report.md, which `mbs calibrate` writes
/// and which therefore carries no markers).
pub(crate) fn table_headed(path: &str, header: &[&str]) -> Table {
    let found: Vec<Table> = tables(&read(path))
        .into_iter()
        .map(|(_, t)| t)
        .filter(|t| t[0].len() >= header.len() && t[0].iter().zip(header).all(|(a, b)| a == b))
        .collect();
    assert_eq!(
        found.len(),
        1,
        "{path}: {} tables headed {header:?}",
        found.len()
    );
    found.into_iter().next().unwrap()
}

/// A CSV file of plain fields (no quotes): one map per line, by column name.
pub(crate) fn csv(path: &str) -> Vec<HashMap<String, String>> {
    let text = read(path);
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(str::to_string))
                .collect()
        })
        .collect()
}

pub(crate) fn num(s: &str) -> f64 {
    s.parse()
        .unwrap_or_else(|e| panic!("`{s}` is not a number: {e}"))
}

pub(crate) fn field(row: &HashMap<String, String>, key: &str) -> f64 {
    num(row.get(key).unwrap_or_else(|| panic!("no column {key}")))
}

/// The printed form of `value` with as many digits as `printed` has:
/// fixed decimals (`0.0050`, `0`) or a mantissa's decimals (`7.68e-6`).
pub(crate) fn as_printed(printed: &str, value: f64) -> String {
    if let Some((mantissa, _)) = printed.split_once('e') {
        let n = mantissa.split_once('.').map_or(0, |(_, f)| f.len());
        format!("{value:.n$e}")
    } else {
        let n = printed.split_once('.').map_or(0, |(_, f)| f.len());
        format!("{value:.n$}")
    }
}

/// The mismatches of a document against its source, reported all at once.
#[derive(Default)]
pub(crate) struct Check(Vec<String>);

impl Check {
    /// `printed` (one cell, or a part of one) must be `value` to its digits.
    pub(crate) fn num(&mut self, what: &str, printed: &str, value: f64) {
        let printed = printed.trim().trim_matches('*').replace('−', "-");
        let printed = printed.trim();
        let want = as_printed(printed, value);
        if printed != want {
            self.0.push(format!(
                "{what}: printed {printed}, the source gives {want} ({value})"
            ));
        }
    }

    /// `printed` must be consistent with `value`, itself known only to
    /// `digits` decimals (a number another document printed).
    pub(crate) fn num_of_rounded(&mut self, what: &str, printed: &str, value: f64, digits: i32) {
        let printed = printed.trim();
        let n = printed.split_once('.').map_or(0, |(_, f)| f.len()) as i32;
        let slack = 0.5 * 10f64.powi(-n) + 0.5 * 10f64.powi(-digits) + 1e-12;
        if n > digits || (num(printed) - value).abs() > slack {
            self.0.push(format!(
                "{what}: printed {printed}, the source gives {value} (to {digits} decimals)"
            ));
        }
    }

    pub(crate) fn text(&mut self, what: &str, printed: &str, want: &str) {
        if printed.trim() != want {
            self.0.push(format!(
                "{what}: printed `{}`, the source gives `{want}`",
                printed.trim()
            ));
        }
    }

    pub(crate) fn that(&mut self, what: &str, ok: bool) {
        if !ok {
            self.0.push(what.to_string());
        }
    }

    pub(crate) fn done(self) {
        assert!(self.0.is_empty(), "\n{}\n", self.0.join("\n"));
    }
}

/// `a ± b` as its two parts.
pub(crate) fn pm(cell: &str) -> (&str, &str) {
    cell.split_once('±')
        .map(|(a, b)| (a.trim(), b.trim()))
        .unwrap_or_else(|| panic!("`{cell}` is not `a ± b`"))
}

/// The column of `header` whose name starts with `name`.
pub(crate) fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h.starts_with(name))
        .unwrap_or_else(|| panic!("no column `{name}` in {header:?}"))
}

/// The row of `rows` whose `key` equals `value` (as numbers).
pub(crate) fn row_where<'a>(
    rows: &'a [HashMap<String, String>],
    key: &str,
    value: f64,
) -> Option<&'a HashMap<String, String>> {
    rows.iter().find(|r| field(r, key) == value)
}
