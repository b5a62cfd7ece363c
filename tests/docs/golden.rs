//! The README and the findings against the committed main job's table.

use crate::calibration::Calibration;
use crate::tables::*;

/// The committed main job's table.
pub(crate) const TRANSPORT: &str = "tests/golden/transport.csv";

/// The main job's table as the findings measured it (before MSER
/// truncation and batch-means errors, issue 41): their other columns were
/// run with the estimator of that time.
pub(crate) const FINDINGS_TRANSPORT: &str = "docs/findings/data/transport-2026-11-25.csv";

/// q*/MPM over the rows of `source` with τ* ≥ 0.1, as the docs quote it:
/// "LO–HI of Meyer-Peter & Müller".
pub(crate) fn mpm_ratio_phrase(source: &str) -> String {
    let rows = csv(source);
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
pub(crate) fn readme_transport_table_is_the_golden_table() {
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
pub(crate) fn quoted_fractions_of_mpm_are_the_golden_tables() {
    let mut c = Check::default();
    for (doc, source) in [
        ("README.md", TRANSPORT),
        ("docs/findings/bed-width.md", FINDINGS_TRANSPORT),
        (
            "docs/findings/explicit-damping-limit.md",
            FINDINGS_TRANSPORT,
        ),
    ] {
        let phrase = mpm_ratio_phrase(source);
        c.that(
            &format!("{doc} does not say \"{phrase}\" ({source}, τ* ≥ 0.1)"),
            read(doc).replace('\n', " ").contains(&phrase),
        );
    }
    c.done();
}

/// A doc table of q* ± stderr per τ* whose column `column` is the table
/// of the findings' time ([`FINDINGS_TRANSPORT`]).
pub(crate) fn check_golden_column(c: &mut Check, doc: &str, name: &str, column: &str) {
    let t = table(doc, name);
    let rows = csv(FINDINGS_TRANSPORT);
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
pub(crate) fn findings_quote_the_golden_table() {
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
    let rows = csv(FINDINGS_TRANSPORT);
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
    // Written with the calibration of 2026-11-25.
    let cal = Calibration::read_from(crate::calibration::CALIBRATION_2026_11_25);
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
