//! Short text for people and file names: excerpts of long lines for
//! messages, numbers in a form that stays short.

/// Characters of a line that a message quotes from its input (toml's
/// excerpt of the configuration).
pub const QUOTE: usize = 400;

/// Characters of the longest line of a message on standard error.
pub const MESSAGE: usize = 1000;

/// Writes `text` and a newline to standard error, long lines as excerpts
/// ([`excerpt`] of [`MESSAGE`] characters: a message quoting a 1 MB line
/// stays short); a closed or broken standard error is ignored (a message
/// cannot change the outcome or the exit status).
pub fn print_err(text: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "{}", excerpt(text, MESSAGE));
}

/// `text` with each line longer than `max` characters cut to its first
/// ones and the count of those left out: a message quoting a 1 MB line
/// stays short.
pub fn excerpt(text: &str, max: usize) -> String {
    let mut out = String::with_capacity(text.len().min(4 * max));
    for (k, line) in text.split('\n').enumerate() {
        if k > 0 {
            out.push('\n');
        }
        match line.char_indices().nth(max) {
            None => out.push_str(line),
            Some((cut, _)) => {
                out.push_str(&line[..cut]);
                let left = line[cut..].chars().count();
                out.push_str(&format!("… ({left} more characters)"));
            }
        }
    }
    out
}

/// Characters of the longest number written in its `Display` form.
const NUMBER: usize = 24;

/// `x` as Rust writes it (`0.03`, shortest round trip) if that takes at
/// most 24 characters, else in exponent form (`1e-300`): also distinct for
/// distinct values and short enough for a file name. Every value a
/// configuration normally holds keeps its `Display` form.
pub fn number(x: f64) -> String {
    let plain = x.to_string();
    if plain.len() <= NUMBER {
        plain
    } else {
        format!("{x:e}")
    }
}

/// `value` (a message's quoted value, or a message) with every number of
/// more than 24 characters in exponent form ([`number`]), also within
/// lists and sentences: `0.000…0001` (330 characters) becomes `1e-320`.
pub fn shown(value: String) -> String {
    let numeric = |c: char| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-');
    if !value.contains(|c: char| c.is_ascii_digit()) || value.len() <= NUMBER {
        return value;
    }
    let mut out = String::with_capacity(value.len());
    let mut rest = value.as_str();
    while let Some(start) = rest.find(numeric) {
        out.push_str(&rest[..start]);
        let run = &rest[start..];
        let end = run.find(|c: char| !numeric(c)).unwrap_or(run.len());
        let token = &run[..end];
        match token.parse::<f64>() {
            Ok(x) if token.len() > NUMBER => out.push_str(&number(x)),
            _ => out.push_str(token),
        }
        rest = &run[end..];
    }
    out.push_str(rest);
    out
}

/// `word` as one word of a shell command to show (POSIX `sh`): as it is
/// if it holds only characters no shell treats specially, else in single
/// quotes (a quote inside as `'\''`); control characters (a newline, a
/// terminal escape) and invisible ones (a direction override) are shown
/// escaped (`\n`, `\u{1b}`, `\u{202e}`), never written to the terminal: a word read from a file (a trace's labels) cannot inject
/// a command or an escape sequence into what mbs prints.
///
/// ```
/// use mbs::io::text::shell_word;
///
/// assert_eq!(shell_word("configs/paper.toml"), "configs/paper.toml");
/// assert_eq!(shell_word("run.output=\"it's\""), r#"'run.output="it'\''s"'"#);
/// assert_eq!(shell_word("x; rm -rf ~\n\u{1b}[31m"), r"'x; rm -rf ~\n\u{1b}[31m'");
/// assert_eq!(shell_word("a\u{202e}b"), r"'a\u{202e}b'");
/// ```
pub fn shell_word(word: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-./=:,+@%".contains(c);
    if !word.is_empty() && word.chars().all(plain) {
        return word.to_string();
    }
    let mut out = String::from("'");
    for c in word.chars() {
        match c {
            '\'' => out.push_str("'\\''"),
            c if c.is_control() || invisible(c) => out.extend(c.escape_default()),
            c => out.push(c),
        }
    }
    out.push('\'');
    out
}

/// Characters that change how text is shown without being shown: zero
/// widths, direction marks and overrides, the byte-order mark.
fn invisible(c: char) -> bool {
    matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' | '\u{feff}')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lines_are_quoted_as_excerpts() {
        assert_eq!(excerpt("a\nb", 1), "a\nb");
        let long = format!("x{}\nshort", "é".repeat(1_000_000));
        let e = excerpt(&long, 160);
        assert!(e.len() < 400, "{}", e.len());
        assert!(e.ends_with("… (999841 more characters)\nshort"), "{e}");
    }

    #[test]
    fn numbers_stay_short_and_normal_ones_unchanged() {
        for (x, text) in [
            (0.03, "0.03"),
            (0.1, "0.1"),
            (1e-6, "0.000001"),
            (0.30000000000000004, "0.30000000000000004"),
            (2.0, "2"),
            (1e-300, "1e-300"),
            (1e308, "1e308"),
            (1.2345678901234568e-10, "1.2345678901234568e-10"),
        ] {
            assert_eq!(number(x), text);
            assert_eq!(number(x).parse::<f64>(), Ok(x));
        }
        assert_eq!(shown(1e308.to_string()), "1e308");
        assert_eq!(shown("[1, 2]".into()), "[1, 2]");
        let long = format!("0.{}1", "0".repeat(319));
        assert_eq!(shown(format!("[{long}, 0.5]")), "[1e-320, 0.5]");
        assert_eq!(
            shown(format!(
                "invalid type: floating point `{long}`, expected u32"
            )),
            "invalid type: floating point `1e-320`, expected u32"
        );
        assert_eq!(
            shown("run 3 of 1e-3 s, step 12345678901234567890123456".into()),
            "run 3 of 1e-3 s, step 1.2345678901234568e25"
        );
    }
}
