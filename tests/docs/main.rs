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

mod calibration;
mod digests;
mod findings;
mod golden;
mod tables;
