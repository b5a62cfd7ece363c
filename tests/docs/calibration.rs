//! The calibration's report and the docs that quote it against
//! docs/calibration/.

use crate::tables::*;

/// The committed calibration: docs/calibration/*.csv, plan.json and the
/// numbers report.md quotes from its stage files.
pub(crate) struct Calibration {
    stage1: Vec<HashMap<String, String>>,
    stage2: Vec<HashMap<String, String>>,
    stage3: Vec<HashMap<String, String>>,
    pub(crate) transport: Vec<HashMap<String, String>>,
    stage4: Vec<HashMap<String, String>>,
    stage5: Vec<HashMap<String, String>>,
    pub(crate) alpha_m: f64,
    pub(crate) alpha_cn: f64,
    /// β's uncertainty as report.md prints it ("spans **[a, b]**"): stage3.json is not committed.
    pub(crate) beta_range: (String, String),
}

/// The fastest stable value of a packing stage.
pub(crate) fn fastest(rows: &[HashMap<String, String>]) -> f64 {
    let best = rows
        .iter()
        .filter(|r| r["stable"] == "true")
        .min_by(|a, b| field(a, "settling_time").total_cmp(&field(b, "settling_time")))
        .unwrap();
    field(best, "value")
}

pub(crate) fn settling_time(rows: &[HashMap<String, String>], value: f64) -> f64 {
    field(row_where(rows, "value", value).unwrap(), "settling_time")
}

/// The calibration of 2026-11-25 (before the MSER truncation and the
/// batch-means intervals of issue 41), which the findings written with it
/// quote: its stage files and report, kept under docs/findings/data/.
pub(crate) const CALIBRATION_2026_11_25: &str = "docs/findings/data/calibration-2026-11-25";

impl Calibration {
    /// The committed calibration, docs/calibration/.
    pub(crate) fn read() -> Self {
        Self::read_from("docs/calibration")
    }

    /// The calibration whose stage files and report.md are in `dir`.
    pub(crate) fn read_from(dir: &str) -> Self {
        let file = |name: &str| format!("{dir}/{name}");
        let stage1 = csv(&file("stage1.csv"));
        let stage2 = csv(&file("stage2.csv"));
        let report = read(&file("report.md"));
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
            stage3: csv(&file("stage3.csv")),
            transport: csv(&file("stage3_transport.csv")),
            stage4: csv(&file("stage4.csv")),
            stage5: csv(&file("stage5.csv")),
            beta_range: (a.trim().to_string(), b.trim().to_string()),
        }
    }

    /// The calibrated β: the precise (`fine`) curve of least misfit.
    pub(crate) fn best_precise(&self) -> &HashMap<String, String> {
        self.stage3
            .iter()
            .filter(|r| r["fidelity"] == "fine") // "precise" in the report
            .min_by(|a, b| field(a, "misfit").total_cmp(&field(b, "misfit")))
            .unwrap()
    }

    pub(crate) fn beta(&self) -> f64 {
        field(self.best_precise(), "beta")
    }

    pub(crate) fn beta_misfit(&self) -> f64 {
        field(self.best_precise(), "misfit")
    }

    /// The factor between q* and the reference at each τ* of stage 3, after the fit.
    pub(crate) fn factors(&self) -> Vec<(f64, f64)> {
        self.transport
            .iter()
            .map(|r| {
                let ratio = field(r, "q_star_after") / field(r, "reference");
                (field(r, "tau_star"), ratio.max(1.0 / ratio))
            })
            .collect()
    }

    pub(crate) fn worst_factor(&self) -> f64 {
        self.factors().iter().map(|f| f.1).fold(0.0, f64::max)
    }

    /// constants_dt of stage 4 at (d, nvd).
    pub(crate) fn constants_dt(&self, d: f64, layers: f64) -> f64 {
        let r = self
            .stage4
            .iter()
            .find(|r| field(r, "diameter_mm") == d && field(r, "layers") == layers)
            .unwrap();
        field(r, "constants_dt")
    }

    /// `3.63 (3.46–3.86)`: β and its uncertainty (the latter as report.md prints it).
    pub(crate) fn check_beta(&self, c: &mut Check, what: &str, cell: &str) {
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

pub(crate) const REPORT: &str = "docs/calibration/report.md";

/// A packing stage's table of report.md against its CSV.
pub(crate) fn check_packing(
    c: &mut Check,
    name: &str,
    header: &[&str],
    rows: &[HashMap<String, String>],
) {
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
pub(crate) fn plan_list(key: &str) -> Vec<f64> {
    let plan = read("docs/calibration/plan.json");
    let after = plan
        .split_once(&format!("\"{key}\": ["))
        .unwrap_or_else(|| panic!("plan.json: no list {key}"))
        .1;
    let list = after.split_once(']').unwrap().0;
    list.split(',').map(|v| num(v.trim())).collect()
}

#[test]
pub(crate) fn calibration_report_tables_are_the_stage_files() {
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
pub(crate) fn calibration_results_are_the_committed_calibration() {
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
pub(crate) fn numbers(cell: &str) -> Vec<&str> {
    let cell = cell.split('(').next().unwrap();
    cell.split([',', ' ', '/'])
        .map(|v| v.trim().trim_matches('*'))
        .filter(|v| !v.is_empty())
        .collect()
}

/// `printed` must list `values`, one number each, to its digits.
pub(crate) fn check_list(c: &mut Check, what: &str, printed: &str, values: &[f64]) {
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
pub(crate) fn glue_quotes_the_committed_calibration() {
    let doc = "docs/findings/glue.md";
    // Written with the calibration of 2026-11-25.
    let cal = Calibration::read_from(CALIBRATION_2026_11_25);
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
