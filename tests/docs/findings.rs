//! Every table of docs/findings/ is checked or says where it comes from.

use crate::tables::*;

/// Every table of docs/findings/ is either checked here or says where its
/// numbers come from, on a line starting `Source` in one of the two
/// paragraphs above it; configuration tables (`| key |`) are inputs.
#[test]
pub(crate) fn every_findings_table_says_where_it_comes_from() {
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
