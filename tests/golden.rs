//! Golden digests: the paper's scenario (settling bed, then the bed under
//! flow at τ* = 0.2), with clear water and with the coupled flow, must
//! reproduce the committed digests bit for bit, in f32 and f64, on every
//! machine. Re-record on purpose, in a commit that says why:
//!
//!     MBS_BLESS=1 cargo test --test golden

use mbs_kernel::{Real, Scenario, Sim};
use std::path::PathBuf;

/// Steps of each phase of the golden run.
const SETTLE_STEPS: u64 = 2000;
const FLOW_STEPS: u64 = 2000;

fn path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/digests.txt")
}

/// The settled and flow digests of `scenario` in a simulation of `C` cells.
fn run<R: Real, const C: usize>(scenario: &Scenario) -> (u64, u64) {
    let mut sim = Box::new(Sim::<R, 64, 8, C>::new());
    scenario
        .digests(
            &mut *sim,
            Scenario::PAPER_TAU_STAR,
            SETTLE_STEPS,
            FLOW_STEPS,
        )
        .expect("golden scenario runs")
}

/// The golden file's lines of `scenario`, f32 then f64.
fn lines_of<const C: usize>(scenario: &Scenario) -> Vec<String> {
    let (a, b) = (run::<f32, C>(scenario), run::<f64, C>(scenario));
    vec![
        format!("settling f32 {:#018x}", a.0),
        format!("flow f32 {:#018x}", a.1),
        format!("settling f64 {:#018x}", b.0),
        format!("flow f64 {:#018x}", b.1),
    ]
}

fn lines() -> Vec<String> {
    lines_of::<0>(&Scenario::paper())
}

#[test]
fn golden_digests_match() {
    let header = format!(
        "Digests of Scenario::paper() after {SETTLE_STEPS} settling steps and {FLOW_STEPS} flow steps."
    );
    match_or_bless(&path(), &header, &lines());
}

/// Compares `now` with the digest lines of the golden file at `path`, or,
/// with `MBS_BLESS` set, writes them there under `header`.
fn match_or_bless(path: &std::path::Path, header: &str, now: &[String]) {
    if std::env::var_os("MBS_BLESS").is_some() {
        // Re-recording compares nothing: never in CI.
        assert!(std::env::var_os("CI").is_none(), "MBS_BLESS is set in CI");
        let text = format!(
            "# {header}\n# Re-record: MBS_BLESS=1 cargo test --release --test golden\n{}\n",
            now.join("\n")
        );
        std::fs::write(path, text).expect("write golden file");
        return;
    }
    let text = std::fs::read_to_string(path).expect("the golden file exists");
    let recorded: Vec<&str> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .collect();
    assert_eq!(
        recorded,
        now,
        "{}: digests changed; if on purpose, re-record (see the file's header)",
        path.display()
    );
}

/// The coupled golden run: [`Scenario::paper_coupled`] (the paper's bed,
/// the coupled flow in a column of 100 cells), the same phases as the
/// paper's run, in a simulation of exactly the column's capacity (the
/// host's, of 2048 cells, gives the same bits: `mbs digest`, host test
/// `digest_matches_the_golden_file`).
fn coupled_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/coupled.txt")
}

fn coupled_lines() -> Vec<String> {
    lines_of::<{ Scenario::PAPER_COUPLED_CELLS }>(&Scenario::paper_coupled())
}

#[test]
fn coupled_golden_digests_match() {
    let header = format!(
        "Digests of Scenario::paper_coupled() after {SETTLE_STEPS} settling steps and {FLOW_STEPS} flow steps."
    );
    let now = coupled_lines();
    // Settling runs without flow: the paper's settled bed, bit for bit.
    let paper = lines();
    assert_eq!((&now[0], &now[2]), (&paper[0], &paper[2]));
    assert_ne!((&now[1], &now[3]), (&paper[1], &paper[3]));
    match_or_bless(&coupled_path(), &header, &now);
}

#[test]
fn digests_distinguish_phases_and_precisions() {
    let now = lines();
    for (i, a) in now.iter().enumerate() {
        for b in &now[i + 1..] {
            assert_ne!(a.split(' ').nth(2), b.split(' ').nth(2));
        }
    }
}

/// The living-bed golden run: the paper's bed settled for
/// `LIVING_SETTLE_STEPS` (no flow), then `LIVING_FLOW_STEPS` under the flow
/// at τ* = `LIVING_TAU_STAR`, where grains saltate: every path of the step
/// runs many times (counted by `Sim::events`).
const LIVING_TAU_STAR: f64 = 0.5;
const LIVING_SETTLE_STEPS: u64 = 80_000;
const LIVING_FLOW_STEPS: u64 = 400_000;

fn living_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/living.txt")
}

/// The committed settled living bed of precision `name` (`f32`, `f64`):
/// the kernel checkpoint every target's trace starts from
/// (firmware/golden, docs/board.md).
fn settled_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join(format!("tests/golden/living-settled-{name}.ckpt"))
}

/// (settled digest, flow digest, events of the flow phase). Also checks
/// the settled bed's checkpoint against the committed one (or, with
/// `MBS_BLESS`, writes it).
fn living<R: Real>() -> (u64, u64, mbs_kernel::Events) {
    let mut sim = Box::new(Sim::<R, 64, 8>::new());
    let sc = Scenario::paper();
    sc.build(&mut *sim).expect("bed");
    sim.count_events(true);
    sim.run(LIVING_SETTLE_STEPS).expect("settles");
    let settled = sim.digest();
    let mut bytes = Vec::new();
    sim.checkpoint(|b| bytes.extend_from_slice(b));
    let path = settled_path(R::NAME);
    if std::env::var_os("MBS_BLESS").is_some() {
        assert!(std::env::var_os("CI").is_none(), "MBS_BLESS is set in CI");
        std::fs::write(&path, &bytes).expect("write the settled bed");
    }
    assert!(
        std::fs::read(&path).expect("the settled bed is committed") == bytes,
        "{}: the settled living bed changed; if on purpose, re-record (tests/golden/living.txt's header)",
        path.display()
    );
    let before = sim.events();
    sim.set_flow(Some(&sc.flow(LIVING_TAU_STAR))).expect("flow");
    sim.run(LIVING_FLOW_STEPS).expect("flows");
    let after = sim.events();
    let flow = mbs_kernel::Events {
        contacts_made: after.contacts_made - before.contacts_made,
        contacts_broken: after.contacts_broken - before.contacts_broken,
        contacts_sliding: after.contacts_sliding - before.contacts_sliding,
        seam_crossings: after.seam_crossings - before.seam_crossings,
        neighbour_rebuilds: after.neighbour_rebuilds - before.neighbour_rebuilds,
        turbulence_redraws: after.turbulence_redraws - before.turbulence_redraws,
        bed_level_updates: after.bed_level_updates - before.bed_level_updates,
        batched_steps: after.batched_steps - before.batched_steps,
        phased_steps: after.phased_steps - before.phased_steps,
    };
    (settled, sim.digest(), flow)
}

/// The living bed reproduces its committed digests (re-record as the
/// paper's: `MBS_BLESS=1 cargo test --release --test golden`), and its
/// flow phase makes, breaks and slides contacts, carries grains across
/// the seam, rebuilds the lists, redraws the turbulence and updates the
/// bed level many times, in both precisions (docs/determinism.md gives
/// the counts).
#[test]
fn living_bed_exercises_every_path_and_matches() {
    let (a, b) = (living::<f32>(), living::<f64>());
    for (precision, (_, _, e)) in [("f32", &a), ("f64", &b)] {
        println!("living bed {precision}, flow phase: {e:?}");
        assert!(e.contacts_made >= 300, "{precision} {e:?}");
        assert!(e.contacts_broken >= 300, "{precision} {e:?}");
        assert!(e.contacts_sliding >= 1_000_000, "{precision} {e:?}");
        assert!(e.seam_crossings >= 40, "{precision} {e:?}");
        assert!(e.neighbour_rebuilds >= 1000, "{precision} {e:?}");
        assert_eq!(e.turbulence_redraws, 500, "{precision}");
        assert_eq!(e.bed_level_updates, 500, "{precision}");
        // Both step paths are exercised: the batched step where it has
        // lanes (and the scalar one after each rebuild that leaves pairs
        // outside the index), the scalar one alone elsewhere.
        if cfg!(all(target_arch = "x86_64", target_feature = "avx2")) {
            assert!(e.batched_steps > 0, "{precision} {e:?}");
        } else {
            assert_eq!(e.batched_steps, 0, "{precision} {e:?}");
        }
    }
    let now = vec![
        format!("settled f32 {:#018x}", a.0),
        format!("flow f32 {:#018x}", a.1),
        format!("settled f64 {:#018x}", b.0),
        format!("flow f64 {:#018x}", b.1),
    ];
    let header = format!(
        "Digests of the living bed: Scenario::paper() settled {LIVING_SETTLE_STEPS} steps, then {LIVING_FLOW_STEPS} steps at tau* = {LIVING_TAU_STAR} (tests/golden.rs)."
    );
    match_or_bless(&living_path(), &header, &now);
}
