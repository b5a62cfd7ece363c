//! The digest tables of the docs against tests/golden/.

use crate::tables::*;

/// The golden digests of a file of tests/golden/: (precision, phase) → digest.
pub(crate) fn digests(path: &str) -> HashMap<(String, String), String> {
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
pub(crate) fn check_digest_table(c: &mut Check, doc: &str, name: &str, golden: &str) {
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
pub(crate) fn check_board_rows(c: &mut Check, name: &str) {
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
pub(crate) fn digest_tables_are_the_golden_files() {
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
