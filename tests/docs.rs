//! Docs that cannot drift: every result table of the README and docs/ that
//! has a committed source is checked here against it, number by number, to
//! the digits printed.
//!
//! A checked table is announced in its document by a comment on a line of
//! its own above it, `<!-- checked: NAME -->`, where NAME is the name this
//! file looks it up by; docs/calibration/report.md, which `mbs calibrate`
//! writes, is read by its tables' headers instead. Changing a source (a new `tests/golden/transport.csv`,
//! a new calibration under `docs/calibration/`, new golden digests) fails
//! these tests until the tables and the prose numbers quoted here are
//! updated with it. Tables of docs/findings/ whose runs left no committed
//! output carry a line `Source: ...` instead (the command, the date and
//! the machine), which `every_findings_table_says_where_it_comes_from`
//! requires.
//!
//!     cargo test --release --test docs

use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(path: &str) -> String {
    let p = root().join(path);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// A markdown table: its rows of cells, the header first, the `|---|` line left out.
type Table = Vec<Vec<String>>;

fn cells(line: &str) -> Vec<String> {
    let line = line.trim();
    let inner = line.strip_prefix('|').unwrap_or(line);
    let inner = inner.strip_suffix('|').unwrap_or(inner);
    inner.split('|').map(|c| c.trim().to_string()).collect()
}

fn is_rule(line: &str) -> bool {
    let t = line.trim();
    t.starts_with('|') && t.chars().all(|c| matches!(c, '|' | '-' | ':' | ' '))
}

/// Every table of `text`: (the line number of its header, 1-based; its rows).
fn tables(text: &str) -> Vec<(usize, Table)> {
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
fn table(path: &str, name: &str) -> Table {
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
fn table_headed(path: &str, header: &[&str]) -> Table {
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
fn csv(path: &str) -> Vec<HashMap<String, String>> {
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

fn num(s: &str) -> f64 {
    s.parse()
        .unwrap_or_else(|e| panic!("`{s}` is not a number: {e}"))
}

fn field(row: &HashMap<String, String>, key: &str) -> f64 {
    num(row.get(key).unwrap_or_else(|| panic!("no column {key}")))
}

/// The printed form of `value` with as many digits as `printed` has:
/// fixed decimals (`0.0050`, `0`) or a mantissa's decimals (`7.68e-6`).
fn as_printed(printed: &str, value: f64) -> String {
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
struct Check(Vec<String>);

impl Check {
    /// `printed` (one cell, or a part of one) must be `value` to its digits.
    fn num(&mut self, what: &str, printed: &str, value: f64) {
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
    fn num_of_rounded(&mut self, what: &str, printed: &str, value: f64, digits: i32) {
        let printed = printed.trim();
        let n = printed.split_once('.').map_or(0, |(_, f)| f.len()) as i32;
        let slack = 0.5 * 10f64.powi(-n) + 0.5 * 10f64.powi(-digits) + 1e-12;
        if n > digits || (num(printed) - value).abs() > slack {
            self.0.push(format!(
                "{what}: printed {printed}, the source gives {value} (to {digits} decimals)"
            ));
        }
    }

    fn text(&mut self, what: &str, printed: &str, want: &str) {
        if printed.trim() != want {
            self.0.push(format!(
                "{what}: printed `{}`, the source gives `{want}`",
                printed.trim()
            ));
        }
    }

    fn that(&mut self, what: &str, ok: bool) {
        if !ok {
            self.0.push(what.to_string());
        }
    }

    fn done(self) {
        assert!(self.0.is_empty(), "\n{}\n", self.0.join("\n"));
    }
}

/// `a ± b` as its two parts.
fn pm(cell: &str) -> (&str, &str) {
    cell.split_once('±')
        .map(|(a, b)| (a.trim(), b.trim()))
        .unwrap_or_else(|| panic!("`{cell}` is not `a ± b`"))
}

/// The column of `header` whose name starts with `name`.
fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h.starts_with(name))
        .unwrap_or_else(|| panic!("no column `{name}` in {header:?}"))
}

/// The row of `rows` whose `key` equals `value` (as numbers).
fn row_where<'a>(
    rows: &'a [HashMap<String, String>],
    key: &str,
    value: f64,
) -> Option<&'a HashMap<String, String>> {
    rows.iter().find(|r| field(r, key) == value)
}

/// The committed main job's table.
const TRANSPORT: &str = "tests/golden/transport.csv";

/// q*/MPM over the golden rows with τ* ≥ 0.1, as the docs quote it:
/// "LO–HI of Meyer-Peter & Müller".
fn mpm_ratio_phrase() -> String {
    let rows = csv(TRANSPORT);
    let ratios: Vec<f64> = rows
        .iter()
        .filter(|r| field(r, "tau_star") >= 0.1)
        .map(|r| field(r, "q_star") / field(r, "mpm"))
        .collect();
    let lo = ratios.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = ratios.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    format!("{lo:.2}–{hi:.2} of Meyer-Peter & Müller")
}

#[test]
fn readme_transport_table_is_the_golden_table() {
    let t = table("README.md", "readme-transport");
    let rows = csv(TRANSPORT);
    let h = &t[0];
    let (tau, q, se, mpm, wp) = (
        col(h, "τ*"),
        col(h, "q*"),
        col(h, "standard error"),
        col(h, "Meyer-Peter"),
        col(h, "Wong"),
    );
    // "standard error (4 seeds)"
    let seeds: f64 = num(h[se]
        .split('(')
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap());
    let mut c = Check::default();
    c.that(
        &format!("README: {} rows, {TRANSPORT} {}", t.len() - 1, rows.len()),
        t.len() - 1 == rows.len(),
    );
    for r in &t[1..] {
        let Some(g) = row_where(&rows, "tau_star", num(&r[tau])) else {
            c.that(
                &format!("README: τ* = {} is not in {TRANSPORT}", r[tau]),
                false,
            );
            continue;
        };
        let w = format!("README τ* = {}", r[tau]);
        c.num(&format!("{w} q*"), &r[q], field(g, "q_star"));
        c.num(
            &format!("{w} standard error"),
            &r[se],
            field(g, "q_star_stderr"),
        );
        c.num(
            &format!("{w} seeds"),
            &format!("{seeds}"),
            field(g, "seeds"),
        );
        c.num(&format!("{w} MPM"), &r[mpm], field(g, "mpm"));
        c.num(&format!("{w} W&P"), &r[wp], field(g, "wong_parker"));
    }
    c.done();
}

#[test]
fn quoted_fractions_of_mpm_are_the_golden_tables() {
    let phrase = mpm_ratio_phrase();
    let mut c = Check::default();
    for doc in [
        "README.md",
        "docs/findings/bed-width.md",
        "docs/findings/explicit-damping-limit.md",
    ] {
        c.that(
            &format!("{doc} does not say \"{phrase}\" ({TRANSPORT}, τ* ≥ 0.1)"),
            read(doc).replace('\n', " ").contains(&phrase),
        );
    }
    c.done();
}

/// A doc table of q* ± stderr per τ* whose column `column` is the golden table.
fn check_golden_column(c: &mut Check, doc: &str, name: &str, column: &str) {
    let t = table(doc, name);
    let rows = csv(TRANSPORT);
    let (tau, q) = (col(&t[0], "τ*"), col(&t[0], column));
    c.that(&format!("{doc} {name}: rows"), t.len() - 1 == rows.len());
    for r in &t[1..] {
        let Some(g) = row_where(&rows, "tau_star", num(&r[tau])) else {
            c.that(
                &format!("{doc} {name}: τ* = {} is not golden", r[tau]),
                false,
            );
            continue;
        };
        let (v, e) = pm(&r[q]);
        let w = format!("{doc} {name} τ* = {}", r[tau]);
        c.num(&format!("{w} q*"), v, field(g, "q_star"));
        c.num(&format!("{w} ±"), e, field(g, "q_star_stderr"));
    }
}

#[test]
fn findings_quote_the_golden_table() {
    let mut c = Check::default();
    check_golden_column(
        &mut c,
        "docs/findings/explicit-damping-limit.md",
        "substeps-8-16",
        "q*, 8 substeps",
    );
    let doc = "docs/findings/coupled-flow.md";
    check_golden_column(&mut c, doc, "coupled-transport", "clear water");
    // Its reference columns too.
    let t = table(doc, "coupled-transport");
    let rows = csv(TRANSPORT);
    let (tau, mpm, wp) = (
        col(&t[0], "τ*"),
        col(&t[0], "Meyer-Peter"),
        col(&t[0], "Wong"),
    );
    for r in &t[1..] {
        if let Some(g) = row_where(&rows, "tau_star", num(&r[tau])) {
            c.num(
                &format!("{doc} τ* = {} MPM", r[tau]),
                &r[mpm],
                field(g, "mpm"),
            );
            c.num(
                &format!("{doc} τ* = {} W&P", r[tau]),
                &r[wp],
                field(g, "wong_parker"),
            );
        }
    }
    // The MPM row of the coupled calibration's table: stage 3's reference.
    let t = table(doc, "coupled-calibration-transport");
    let stage3 = csv("docs/calibration/stage3_transport.csv");
    let mpm_row = t
        .iter()
        .find(|r| r[0].starts_with("Meyer-Peter"))
        .expect("a Meyer-Peter & Müller row");
    for (i, tau) in t[0].iter().enumerate().skip(1) {
        match row_where(&stage3, "tau_star", num(tau)) {
            Some(g) => c.num(
                &format!("{doc} MPM at τ* = {tau}"),
                &mpm_row[i],
                field(g, "reference"),
            ),
            None => c.that(&format!("{doc}: τ* = {tau} not in stage 3"), false),
        }
    }
    // The clear-water column of the calibration comparison: the committed calibration.
    let t = table(doc, "coupled-calibration");
    let clear = col(&t[0], "clear water, `\"dashpot\"`");
    let cal = Calibration::read();
    for r in &t[1..] {
        let cell = &r[clear];
        let w = format!("{doc} clear water {}", r[0]);
        if r[0].starts_with("α_m") {
            let (m, n) = cell.split_once(',').unwrap();
            c.num(&format!("{w} α_m"), m, cal.alpha_m);
            c.num(&format!("{w} α_cn"), n, cal.alpha_cn);
        } else if r[0] == "β" {
            cal.check_beta(&mut c, &w, cell);
        } else if r[0].starts_with("worst factor") {
            c.num(&w, cell, cal.worst_factor());
        } else if r[0] == "misfit" {
            c.num(&w, cell, cal.beta_misfit());
        } else {
            c.that(&format!("{w}: unknown row"), false);
        }
    }
    c.done();
}

/// The committed calibration: docs/calibration/*.csv, plan.json and the
/// numbers report.md quotes from its stage files.
struct Calibration {
    stage1: Vec<HashMap<String, String>>,
    stage2: Vec<HashMap<String, String>>,
    stage3: Vec<HashMap<String, String>>,
    transport: Vec<HashMap<String, String>>,
    stage4: Vec<HashMap<String, String>>,
    stage5: Vec<HashMap<String, String>>,
    alpha_m: f64,
    alpha_cn: f64,
    /// β's uncertainty as report.md prints it ("spans **[a, b]**"): stage3.json is not committed.
    beta_range: (String, String),
}

/// The fastest stable value of a packing stage.
fn fastest(rows: &[HashMap<String, String>]) -> f64 {
    let best = rows
        .iter()
        .filter(|r| r["stable"] == "true")
        .min_by(|a, b| field(a, "settling_time").total_cmp(&field(b, "settling_time")))
        .unwrap();
    field(best, "value")
}

fn settling_time(rows: &[HashMap<String, String>], value: f64) -> f64 {
    field(row_where(rows, "value", value).unwrap(), "settling_time")
}

impl Calibration {
    fn read() -> Self {
        let stage1 = csv("docs/calibration/stage1.csv");
        let stage2 = csv("docs/calibration/stage2.csv");
        let report = read("docs/calibration/report.md");
        let spans = report
            .split_once("spans **[")
            .and_then(|(_, r)| r.split_once("]**"))
            .expect("report.md: β spans **[a, b]**")
            .0;
        let (a, b) = spans.split_once(',').unwrap();
        Calibration {
            alpha_m: fastest(&stage1),
            alpha_cn: fastest(&stage2),
            stage1,
            stage2,
            stage3: csv("docs/calibration/stage3.csv"),
            transport: csv("docs/calibration/stage3_transport.csv"),
            stage4: csv("docs/calibration/stage4.csv"),
            stage5: csv("docs/calibration/stage5.csv"),
            beta_range: (a.trim().to_string(), b.trim().to_string()),
        }
    }

    /// The calibrated β: the precise (`fine`) curve of least misfit.
    fn best_precise(&self) -> &HashMap<String, String> {
        self.stage3
            .iter()
            .filter(|r| r["fidelity"] == "fine") // "precise" in the report
            .min_by(|a, b| field(a, "misfit").total_cmp(&field(b, "misfit")))
            .unwrap()
    }

    fn beta(&self) -> f64 {
        field(self.best_precise(), "beta")
    }

    fn beta_misfit(&self) -> f64 {
        field(self.best_precise(), "misfit")
    }

    /// The factor between q* and the reference at each τ* of stage 3, after the fit.
    fn factors(&self) -> Vec<(f64, f64)> {
        self.transport
            .iter()
            .map(|r| {
                let ratio = field(r, "q_star_after") / field(r, "reference");
                (field(r, "tau_star"), ratio.max(1.0 / ratio))
            })
            .collect()
    }

    fn worst_factor(&self) -> f64 {
        self.factors().iter().map(|f| f.1).fold(0.0, f64::max)
    }

    /// constants_dt of stage 4 at (d, nvd).
    fn constants_dt(&self, d: f64, layers: f64) -> f64 {
        let r = self
            .stage4
            .iter()
            .find(|r| field(r, "diameter_mm") == d && field(r, "layers") == layers)
            .unwrap();
        field(r, "constants_dt")
    }

    /// `3.63 (3.46–3.86)`: β and its uncertainty (the latter as report.md prints it).
    fn check_beta(&self, c: &mut Check, what: &str, cell: &str) {
        let (b, range) = cell.split_once('(').unwrap_or((cell, ""));
        c.num(what, b, self.beta());
        if let Some((lo, hi)) = range.trim_end_matches(')').split_once('–') {
            let digits = |v: &str| v.split_once('.').map_or(0, |(_, f)| f.len()) as i32;
            let (a, b) = (&self.beta_range.0, &self.beta_range.1);
            c.num_of_rounded(&format!("{what} low"), lo, num(a), digits(a));
            c.num_of_rounded(&format!("{what} high"), hi, num(b), digits(b));
        }
    }
}

const REPORT: &str = "docs/calibration/report.md";

/// A packing stage's table of report.md against its CSV.
fn check_packing(c: &mut Check, name: &str, header: &[&str], rows: &[HashMap<String, String>]) {
    let t = table_headed(REPORT, header);
    c.that(&format!("{name}: rows"), t.len() - 1 == rows.len());
    for (r, g) in t[1..].iter().zip(rows) {
        let w = format!("{name} {}", r[0]);
        c.num(&format!("{w} value"), &r[0], field(g, "value"));
        c.num(
            &format!("{w} settling time"),
            &r[1],
            field(g, "settling_time"),
        );
        c.num(&format!("{w} speed"), &r[2], field(g, "final_speed"));
        let stable = if g["stable"] == "true" { "yes" } else { "no" };
        c.text(&format!("{w} stable"), &r[3], stable);
        c.text(&format!("{w} note"), &r[4], &g["note"]);
    }
}

/// A plan.json list of numbers: `"key": [ ... ]`.
fn plan_list(key: &str) -> Vec<f64> {
    let plan = read("docs/calibration/plan.json");
    let after = plan
        .split_once(&format!("\"{key}\": ["))
        .unwrap_or_else(|| panic!("plan.json: no list {key}"))
        .1;
    let list = after.split_once(']').unwrap().0;
    list.split(',').map(|v| num(v.trim())).collect()
}

#[test]
fn calibration_report_tables_are_the_stage_files() {
    let cal = Calibration::read();
    let mut c = Check::default();

    // The plan: the values each stage ran.
    let values = |rows: &[HashMap<String, String>], key: &str| -> Vec<f64> {
        rows.iter().map(|r| field(r, key)).collect()
    };
    c.that(
        "plan.json alpha_m = stage1.csv",
        plan_list("alpha_m") == values(&cal.stage1, "value"),
    );
    c.that(
        "plan.json alpha_cn = stage2.csv",
        plan_list("alpha_cn") == values(&cal.stage2, "value"),
    );
    let coarse: Vec<f64> = cal
        .stage3
        .iter()
        .filter(|r| r["fidelity"] == "coarse")
        .map(|r| field(r, "beta"))
        .collect();
    c.that(
        "plan.json beta_grid = stage3.csv's coarse β",
        plan_list("beta_grid") == coarse,
    );
    c.that(
        "plan.json tau_stars = stage3_transport.csv",
        plan_list("tau_stars") == values(&cal.transport, "tau_star"),
    );
    let seeds = plan_list("pack_seeds")
        .iter()
        .map(|s| format!("{s}"))
        .collect::<Vec<_>>()
        .join(", ");
    c.that(
        &format!("report.md: packing seeds [{seeds}] (plan.json)"),
        read(REPORT).contains(&format!("seeds [{seeds}]")),
    );

    check_packing(
        &mut c,
        "stage 1",
        &["α_m", "settling time (s)"],
        &cal.stage1,
    );
    check_packing(
        &mut c,
        "stage 2",
        &["α_cn", "settling time (s)"],
        &cal.stage2,
    );

    let t = table_headed(REPORT, &["β", "fidelity", "misfit"]);
    c.that(
        "report-stage3-misfit: rows",
        t.len() - 1 == cal.stage3.len(),
    );
    for (r, g) in t[1..].iter().zip(&cal.stage3) {
        c.num(&format!("stage 3 β {}", r[0]), &r[0], field(g, "beta"));
        let fidelity = if g["fidelity"] == "fine" {
            "precise"
        } else {
            &g["fidelity"]
        };
        c.text(&format!("stage 3 β {} fidelity", r[0]), &r[1], fidelity);
        c.num(
            &format!("stage 3 β {} misfit", r[0]),
            &r[2],
            field(g, "misfit"),
        );
    }

    let t = table_headed(REPORT, &["τ*", "q* at β = 1 (coarse)"]);
    let h = &t[0];
    let after = col(h, "q* at β = 3");
    c.num(
        "stage 3 transport: β of the header",
        h[after].trim_start_matches("q* at β = "),
        cal.beta(),
    );
    c.that(
        "report-stage3-transport: rows",
        t.len() - 1 == cal.transport.len(),
    );
    for (r, g) in t[1..].iter().zip(&cal.transport) {
        let w = format!("stage 3 τ* = {}", r[0]);
        c.num(&w, &r[0], field(g, "tau_star"));
        c.num(
            &format!("{w} q* before"),
            &r[col(h, "q* at β = 1")],
            field(g, "q_star_before"),
        );
        c.num(
            &format!("{w} q* after"),
            &r[after],
            field(g, "q_star_after"),
        );
        c.num(&format!("{w} ±"), &r[col(h, "±")], field(g, "stderr_after"));
        c.num(
            &format!("{w} reference"),
            &r[col(h, "Meyer-Peter")],
            field(g, "reference"),
        );
    }
    let factors = cal
        .factors()
        .iter()
        .map(|(tau, f)| format!("{tau}: {f:.2}"))
        .collect::<Vec<_>>()
        .join(", ");
    let report = read(REPORT);
    c.that(
        &format!("report.md: \"Factor per τ*: {factors}.\""),
        report.contains(&format!("Factor per τ*: {factors}.")),
    );
    c.that(
        &format!("report.md: worst factor **{:.2}**", cal.worst_factor()),
        report.contains(&format!("[0.06, 0.5]: **{:.2}**", cal.worst_factor())),
    );

    let t = table_headed(REPORT, &["d (mm)", "nvd"]);
    let h = &t[0];
    c.that("report-stage4: rows", t.len() - 1 == cal.stage4.len());
    for (r, g) in t[1..].iter().zip(&cal.stage4) {
        let w = format!("stage 4 d = {} nvd = {}", r[0], r[1]);
        c.num(&w, &r[0], field(g, "diameter_mm"));
        c.num(&w, &r[1], field(g, "layers"));
        c.num(
            &format!("{w} constants_dt"),
            &r[col(h, "constants_dt (s)")],
            field(g, "constants_dt"),
        );
        c.num(
            &format!("{w} / base"),
            &r[col(h, "constants_dt / base")],
            field(g, "constants_dt_over_base"),
        );
        c.num(
            &format!("{w} misfit"),
            &r[col(h, "misfit")],
            field(g, "misfit"),
        );
        c.num(
            &format!("{w} worst factor"),
            &r[col(h, "worst factor")],
            field(g, "worst_factor"),
        );
    }

    let t = table_headed(REPORT, &["τ*", "d (mm)", "τ*_k"]);
    c.that("report-stage5: rows", t.len() - 1 == cal.stage5.len());
    for (r, g) in t[1..].iter().zip(&cal.stage5) {
        let w = format!("stage 5 τ* = {} d = {}", r[0], r[1]);
        let (q, reference, wc) = (
            field(g, "q_star_fraction"),
            field(g, "reference"),
            field(g, "wilcock_crowe"),
        );
        c.num(&w, &r[0], field(g, "tau_star"));
        c.num(&w, &r[1], field(g, "diameter_mm"));
        c.num(&format!("{w} τ*_k"), &r[2], field(g, "tau_star_class"));
        c.num(&format!("{w} q*_k/f_k"), &r[3], q);
        c.num(&format!("{w} reference"), &r[4], reference);
        c.num(&format!("{w} ratio"), &r[5], q / reference);
        c.num(&format!("{w} W&C"), &r[6], wc);
        c.num(&format!("{w} W&C ratio"), &r[7], q / wc);
    }

    // The first table: the calibrated values, and the settling times its reasons quote.
    let t = table_headed(REPORT, &["parameter", "mbs", "paper", "why they differ"]);
    for r in &t[1..] {
        let w = format!("report.md calibrated {}", r[0]);
        match r[0].as_str() {
            "α_m" => {
                c.num(&w, &r[1], cal.alpha_m);
                let (paper, fast) = (num(&r[2]), settling_time(&cal.stage1, cal.alpha_m));
                let why = format!(
                    "here {} settles in {:.4} s and {} in {fast:.4} s",
                    r[2],
                    settling_time(&cal.stage1, paper),
                    r[1]
                );
                c.that(&format!("{w}: \"{why}\""), r[3].contains(&why));
            }
            "α_cn" => {
                c.num(&w, &r[1], cal.alpha_cn);
                let (paper, fast) = (num(&r[2]), settling_time(&cal.stage2, cal.alpha_cn));
                let why = format!(
                    "here {} settles in {:.4} s and {} in {fast:.4} s",
                    r[2],
                    settling_time(&cal.stage2, paper),
                    r[1]
                );
                c.that(&format!("{w}: \"{why}\""), r[3].contains(&why));
            }
            "β" => c.num(&w, &r[1], cal.beta()),
            _ if r[0].starts_with("constants_dt at d = 0.1 mm") => {
                c.num(&w, r[1].trim_end_matches(" s"), cal.constants_dt(0.1, 10.0))
            }
            _ => c.that(&format!("{w}: unknown row"), false),
        }
    }
    c.done();
}

#[test]
fn calibration_results_are_the_committed_calibration() {
    let cal = Calibration::read();
    let doc = "docs/calibration.md";
    let mut c = Check::default();

    let t = table(doc, "calibration-results");
    for r in &t[1..] {
        let w = format!("{doc} results {}", r[0]);
        if r[0].starts_with("α_m") {
            c.num(&w, &r[1], cal.alpha_m);
            // "(fastest settling: 0.063 s; 20 takes 0.093 s)"
            let label = r[0].split_once(": ").unwrap().1;
            let (fast, other) = label.split_once(" s; ").unwrap();
            c.num(
                &format!("{w} fastest"),
                fast,
                settling_time(&cal.stage1, cal.alpha_m),
            );
            let (value, time) = other.split_once(" takes ").unwrap();
            c.num(
                &format!("{w} {value}"),
                time.trim_end_matches(" s)"),
                settling_time(&cal.stage1, num(value)),
            );
        } else if r[0].starts_with("α_cn") {
            c.num(&w, &r[1], cal.alpha_cn);
            // "(0.063 s; 1.3 takes 0.085 s)"
            let label = r[0].split_once('(').unwrap().1;
            let (fast, other) = label.split_once(" s; ").unwrap();
            c.num(
                &format!("{w} fastest"),
                fast,
                settling_time(&cal.stage2, cal.alpha_cn),
            );
            let (value, time) = other.split_once(" takes ").unwrap();
            c.num(
                &format!("{w} {value}"),
                time.trim_end_matches(" s)"),
                settling_time(&cal.stage2, num(value)),
            );
        } else if r[0].starts_with("β") {
            cal.check_beta(&mut c, &w, &r[1]);
        } else if r[0].starts_with("Δt at d = 0.1 mm") {
            c.num(&w, r[1].trim_end_matches(" s"), cal.constants_dt(0.1, 10.0));
        } else {
            c.that(&format!("{w}: unknown row"), false);
        }
    }

    // Stage 3, transposed: a column per τ*.
    let t = table(doc, "calibration-stage3");
    let report_seeds = table_headed(REPORT, &["τ*", "q* at β = 1 (coarse)"]);
    let seeds_col = col(&report_seeds[0], "seeds");
    for (i, tau) in t[0].iter().enumerate().skip(1) {
        let Some(g) = row_where(&cal.transport, "tau_star", num(tau)) else {
            c.that(&format!("{doc} stage 3: τ* = {tau} not in the CSV"), false);
            continue;
        };
        for r in &t[1..] {
            let w = format!("{doc} stage 3 τ* = {tau} {}", r[0]);
            match r[0].as_str() {
                "q*" => c.num(&w, &r[i], field(g, "q_star_after")),
                "±" => c.num(&w, &r[i], field(g, "stderr_after")),
                "q*/MPM" => c.num(&w, &r[i], field(g, "q_star_after") / field(g, "reference")),
                "seeds" => {
                    let printed = report_seeds[1..]
                        .iter()
                        .find(|s| num(&s[0]) == num(tau))
                        .map(|s| s[seeds_col].clone())
                        .unwrap_or_default();
                    c.text(&w, &r[i], &printed)
                }
                _ => c.that(&format!("{w}: unknown row"), false),
            }
        }
    }

    // Stage 5: a row per τ*, the coarse class then the fine one.
    let t = table(doc, "calibration-stage5");
    let sizes: Vec<f64> = {
        let mut d: Vec<f64> = cal.stage5.iter().map(|r| field(r, "diameter_mm")).collect();
        d.sort_by(|a, b| b.total_cmp(a));
        d.dedup();
        d
    };
    c.that(&format!("{doc} stage 5: two classes"), sizes.len() == 2);
    for r in &t[1..] {
        let tau = num(&r[0]);
        for (k, d) in sizes.iter().enumerate() {
            let Some(g) = cal
                .stage5
                .iter()
                .find(|g| field(g, "tau_star") == tau && field(g, "diameter_mm") == *d)
            else {
                c.that(
                    &format!("{doc} stage 5: τ* = {tau} d = {d} not in the CSV"),
                    false,
                );
                continue;
            };
            let w = format!("{doc} stage 5 τ* = {tau} d = {d}");
            let q = field(g, "q_star_fraction");
            c.num(&w, &r[1 + 3 * k], q);
            c.num(
                &format!("{w} /MPM"),
                &r[2 + 3 * k],
                q / field(g, "reference"),
            );
            c.num(
                &format!("{w} /W&C"),
                &r[3 + 3 * k],
                q / field(g, "wilcock_crowe"),
            );
        }
    }
    c.that(
        &format!("{doc} stage 5: rows"),
        (t.len() - 1) * 2 == cal.stage5.len(),
    );
    c.done();
}

/// The numbers of a cell, in order: `7.68, 10.9 (∝ d^0.49)` → 7.68, 10.9.
fn numbers(cell: &str) -> Vec<&str> {
    let cell = cell.split('(').next().unwrap();
    cell.split([',', ' ', '/'])
        .map(|v| v.trim().trim_matches('*'))
        .filter(|v| !v.is_empty())
        .collect()
}

/// `printed` must list `values`, one number each, to its digits.
fn check_list(c: &mut Check, what: &str, printed: &str, values: &[f64]) {
    let printed = numbers(printed);
    c.that(
        &format!(
            "{what}: {} numbers, the source {}",
            printed.len(),
            values.len()
        ),
        printed.len() == values.len(),
    );
    for (i, (p, v)) in printed.iter().zip(values).enumerate() {
        c.num(&format!("{what} [{i}]"), p, *v);
    }
}

#[test]
fn glue_quotes_the_committed_calibration() {
    let doc = "docs/findings/glue.md";
    let cal = Calibration::read();
    let t = table(doc, "glue-full");
    let dashpot = col(&t[0], "`\"dashpot\"`");
    let mut c = Check::default();
    let stage4 = |layers: Option<f64>, key: &str| -> Vec<f64> {
        cal.stage4
            .iter()
            .filter(|r| match layers {
                Some(n) => field(r, "layers") == n,
                None => field(r, "diameter_mm") == 0.5 && field(r, "layers") != 10.0,
            })
            .map(|r| field(r, key))
            .collect()
    };
    let micro = |v: Vec<f64>| v.iter().map(|x| x * 1e6).collect::<Vec<_>>();
    let worst5 = |key: &str| {
        cal.stage5
            .iter()
            .map(|r| {
                let ratio = field(r, "q_star_fraction") / field(r, key);
                ratio.max(1.0 / ratio)
            })
            .fold(0.0, f64::max)
    };
    for r in &t[1..] {
        let (row, cell) = (r[0].as_str(), r[dashpot].as_str());
        let w = format!("{doc} dashpot: {row}");
        match row {
            "wall time, transport cells" => {} // a wall time: not in the stage files
            "α_m, α_cn (stages 1–2)" => {
                check_list(&mut c, &w, cell, &[cal.alpha_m, cal.alpha_cn])
            }
            "β (stage 3), its uncertainty" => cal.check_beta(&mut c, &w, cell),
            "stage 3: worst factor to MPM, misfit" => {
                check_list(&mut c, &w, cell, &[cal.worst_factor(), cal.beta_misfit()])
            }
            _ if row.starts_with("stage 3: q*/MPM") => {
                let ratios: Vec<f64> = cal
                    .transport
                    .iter()
                    .map(|g| field(g, "q_star_after") / field(g, "reference"))
                    .collect();
                check_list(&mut c, &w, cell, &ratios)
            }
            _ if row.starts_with("stage 4, d =") => {
                check_list(&mut c, &w, cell, &micro(stage4(Some(10.0), "constants_dt")))
            }
            "stage 4, worst factor per d" => {
                check_list(&mut c, &w, cell, &stage4(Some(10.0), "worst_factor"))
            }
            _ if row.starts_with("stage 4, nvd =") => {
                check_list(&mut c, &w, cell, &micro(stage4(None, "constants_dt")))
            }
            "stage 4, worst factor per nvd" => {
                check_list(&mut c, &w, cell, &stage4(None, "worst_factor"))
            }
            _ if row.starts_with("stage 5") => check_list(
                &mut c,
                &w,
                cell,
                &[worst5("reference"), worst5("wilcock_crowe")],
            ),
            _ => c.that(&format!("{w}: unknown row"), false),
        }
    }
    c.done();
}

/// The golden digests of a file of tests/golden/: (precision, phase) → digest.
fn digests(path: &str) -> HashMap<(String, String), String> {
    read(path)
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            ((f[1].to_string(), f[0].to_string()), f[2].to_string())
        })
        .collect()
}

/// A table of `| precision | settled | flow |` against a golden file.
fn check_digest_table(c: &mut Check, doc: &str, name: &str, golden: &str) {
    let t = table(doc, name);
    let g = digests(golden);
    c.that(&format!("{doc} {name}: two precisions"), t.len() == 3);
    for r in &t[1..] {
        let p = r[0].clone();
        for (i, phase) in [(1, "settling"), (2, "flow")] {
            let want = format!("`{}`", g[&(p.clone(), phase.to_string())]);
            c.text(&format!("{doc} {name} {p} {phase}"), &r[i], &want);
        }
    }
}

/// The boards' tables: the digests of every paper and coupled row.
fn check_board_rows(c: &mut Check, name: &str) {
    let doc = "docs/board.md";
    let t = table(doc, name);
    let h = &t[0];
    let (bin, prec, dig) = (col(h, "binary"), col(h, "precision"), col(h, "digests"));
    let (paper, coupled) = (
        digests("tests/golden/digests.txt"),
        digests("tests/golden/coupled.txt"),
    );
    for r in &t[1..] {
        let golden = if r[bin].starts_with("firmware") {
            &paper
        } else if r[bin].starts_with("coupled") {
            &coupled
        } else {
            continue; // the largest beds: compared with `mbs digest` by .ci/firmware, not committed
        };
        let p = &r[prec];
        let want = format!(
            "`{}`, `{}`",
            golden[&(p.clone(), "settling".into())],
            golden[&(p.clone(), "flow".into())]
        );
        c.text(&format!("{doc} {name} {} {p}", r[bin]), &r[dig], &want);
    }
}

#[test]
fn digest_tables_are_the_golden_files() {
    let mut c = Check::default();
    let (paper, coupled) = ("tests/golden/digests.txt", "tests/golden/coupled.txt");
    check_digest_table(&mut c, "docs/board.md", "board-coupled-digests", coupled);
    check_digest_table(&mut c, "docs/board.md", "board-paper-digests", paper);
    check_digest_table(
        &mut c,
        "docs/determinism.md",
        "determinism-coupled-digests",
        coupled,
    );
    for name in ["board-m4f", "board-m0", "board-riscv"] {
        check_board_rows(&mut c, name);
    }
    // The living bed's digests are in tests/golden/living.txt; the table of
    // its events states the test's asserted minima.
    c.done();
}

/// Every table of docs/findings/ is either checked here or says where its
/// numbers come from, on a line starting `Source` in one of the two
/// paragraphs above it; configuration tables (`| key |`) are inputs.
#[test]
fn every_findings_table_says_where_it_comes_from() {
    let mut c = Check::default();
    let dir = root().join("docs/findings");
    let mut docs: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    for path in docs {
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let name = path
            .strip_prefix(root())
            .unwrap_or(Path::new("?"))
            .display()
            .to_string();
        for (at, t) in tables(&text) {
            if t[0].first().is_some_and(|h| h == "key") {
                continue;
            }
            // The two paragraphs above the table.
            let mut above = Vec::new();
            let mut paragraphs = 0;
            for l in lines[..at - 1].iter().rev().map(|l| l.trim()) {
                if l.is_empty() {
                    if above.last().is_some_and(|a: &&str| !a.is_empty()) {
                        paragraphs += 1;
                    }
                    if paragraphs == 2 {
                        break;
                    }
                }
                above.push(l);
            }
            let ok = above.iter().any(|l| {
                l.starts_with("<!-- checked: ")
                    || l.starts_with("Source")
                    || l.starts_with("*Source")
            });
            c.that(
                &format!("{name}:{at}: a table with neither `<!-- checked: NAME -->` nor a `Source` line above it"),
                ok,
            );
        }
    }
    c.done();
}
