//! The hot-loop benchmarks shared by `mbs bench` and the criterion benches
//! (`benches/step.rs`): settled beds of the paper's grains (d = 0.5 mm,
//! α_m = 20, α_cn = 1.3, constants from constants_dt = 2.0e-5 s, integrated
//! at step_dt = constants_dt/8),
//! [`ROWS`] rows deep over a fixed row, periodic in x, and five cases: a
//! step without flow, a step with the flow at τ* = 0.2, the neighbour
//! rebuild alone of the settled and of the flowing bed, and the contact
//! law alone.
//!
//! Beds wider than one tile of [`TILE_COLUMNS`] columns are that settled
//! tile repeated side by side and settled again, so a 65 536-grain bed costs
//! little more to prepare than a 1 023-grain one. Prepared beds can be kept
//! as kernel checkpoints in a directory and reused.

use crate::error::HostError;
use crate::io::input::{read_own_bounded, Bound};
use crate::io::output::{create_dir, write_atomic};
use crate::io::text::number;
use crate::sim::sims::{with_sim, HostSim, SimJob};
use crate::sim::threads::Stepping;
use mbs_kernel::contact::{ContactLaw, Spring};
use mbs_kernel::{BedSpec, Error, Fnv1a, GrainSpec, Real, Scenario, Sim};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Rows of mobile grains of the benchmark bed.
pub const ROWS: u32 = 10;

/// Columns of one tile: 93 × 11 = 1 023 grains.
pub const TILE_COLUMNS: u32 = 93;

/// Most steps of settling (0.5 s at step_dt = constants_dt/8).
pub const SETTLE_MAX_STEPS: u64 = 200_000;

/// Settled: every mobile grain slower than this (m/s).
pub const REST_SPEED: f64 = 1e-3;

/// Steps of flow before a flow case is timed (0.02 s at constants_dt/8): saltation
/// has started, so the neighbour lists are rebuilt as often as in a run.
pub const FLOW_WARM_UP: u64 = 8_000;

/// Shields number of the flow case.
pub const TAU_STAR: f64 = 0.2;

/// Steps a step case runs from its prepared state before it is rewound to
/// it (untimed). Under flow the bed keeps evolving (more grains saltate), so
/// without the rewind a timing would measure a later bed the more
/// repetitions it takes: criterion's 2.5 s are ~50 000 steps of a small bed
/// but ~700 of the largest. With it every timing, criterion's and
/// `mbs bench`'s, measures the same first 400 steps whatever the bed's size.
pub const WINDOW_STEPS: u64 = 400;

/// What one benchmark times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Case {
    /// One step of the settled bed without flow.
    Still,
    /// One step with the flow at τ* = 0.2 (drag, turbulence, log law).
    Flow,
    /// The neighbour-list rebuild alone.
    Rebuild,
    /// The neighbour-list rebuild alone, of the bed of the flow case (a
    /// larger skin, more candidates: what a flowing bed's rebuilds cost).
    RebuildFlow,
    /// The contact law (6)–(9) alone, over the bed's contacts.
    Contacts,
}

impl Case {
    /// Every case, in table order.
    pub const ALL: [Case; 5] = [
        Case::Still,
        Case::Flow,
        Case::Rebuild,
        Case::RebuildFlow,
        Case::Contacts,
    ];

    /// The case steps the bed (and is rewound every [`WINDOW_STEPS`]).
    pub fn steps(self) -> bool {
        matches!(self, Case::Still | Case::Flow)
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Case::Still => "still",
            Case::Flow => "flow",
            Case::Rebuild => "rebuild",
            Case::RebuildFlow => "rebuild-flow",
            Case::Contacts => "contacts",
        }
    }
}

/// A benchmark bed: about `grains` grains (fixed row included) with the
/// paper's constants scaled by `beta`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BenchBed {
    /// Grains wanted; the bed has whole columns of 11 grains.
    pub grains: usize,
    /// β of the contact constants (the paper's is 15.8).
    pub beta: f64,
}

impl BenchBed {
    /// Columns: whole tiles from 1.5 tiles on, else the nearest count.
    pub fn columns(&self) -> u32 {
        let per_column = ROWS as usize + 1;
        let tile = TILE_COLUMNS as usize * per_column;
        let columns = if self.grains >= tile + tile / 2 {
            (self.grains + tile / 2) / tile * TILE_COLUMNS as usize
        } else {
            (self.grains + per_column / 2) / per_column
        };
        columns.clamp(4, u32::MAX as usize) as u32
    }

    /// Grains of the bed (whole columns).
    pub fn grain_count(&self) -> usize {
        self.columns() as usize * (ROWS as usize + 1)
    }

    /// The paper's scenario with this β and `columns` columns.
    pub fn scenario(&self, columns: u32) -> Scenario {
        let mut sc = Scenario::paper();
        sc.rule.beta = self.beta;
        sc.bed = BedSpec::uniform(0.5e-3, columns, ROWS);
        sc
    }

    /// File of the prepared bed in `dir`, named by precision, columns, β,
    /// phase and a hash of the whole scenario, so a changed scenario never
    /// reuses an old bed.
    fn file<R: Real>(&self, dir: &Path, columns: u32, flow: bool) -> PathBuf {
        let phase = if flow { "flow" } else { "still" };
        let scenario = format!("{:?}", self.scenario(columns));
        dir.join(format!(
            "{}_{columns}c_beta{}_{phase}_{:016x}_v{}.ckpt",
            R::NAME,
            number(self.beta),
            Fnv1a::of(scenario.as_bytes()),
            mbs_kernel::CHECKPOINT_VERSION
        ))
    }
}

/// Puts a prepared bed into `sim`: settled (`flow` false) or after
/// [`FLOW_WARM_UP`] steps of flow at τ* = 0.2. With `beds`, prepared beds
/// are read from and written to that directory.
pub fn prepare<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    bed: &BenchBed,
    flow: bool,
    beds: Option<&Path>,
) -> Result<(), HostError> {
    prepare_columns(sim, bed, bed.columns(), flow, beds)
}

fn prepare_columns<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    bed: &BenchBed,
    columns: u32,
    flow: bool,
    beds: Option<&Path>,
) -> Result<(), HostError> {
    let bound = Bound {
        bytes: Sim::<R, N, K>::MAX_CHECKPOINT_LEN as u64,
        reason: "the largest checkpoint of this simulation",
    };
    let sc = bed.scenario(columns);
    // A prepared bed is used only if it is this bed (a file is a cache:
    // one that is not is prepared again and replaced).
    if let Some(dir) = beds
        && let Ok(bytes) = read_own_bounded(&bed.file::<R>(dir, columns, flow), bound)
        && sim.restore(&bytes).is_ok()
        && is_bed(sim, &sc, flow)
    {
        return Ok(());
    }
    if flow {
        prepare_columns(sim, bed, columns, false, beds)?;
        sim.set_flow(Some(&sc.flow(TAU_STAR))).map_err(bed_error)?;
        sim.run(FLOW_WARM_UP).map_err(bed_error)?;
    } else if columns > TILE_COLUMNS && columns.is_multiple_of(TILE_COLUMNS) {
        prepare_columns(sim, bed, TILE_COLUMNS, false, beds)?;
        tile(sim, columns / TILE_COLUMNS).map_err(bed_error)?;
        sim.settle(SETTLE_MAX_STEPS, REST_SPEED)
            .map_err(bed_error)?;
    } else {
        sc.build(sim).map_err(bed_error)?;
        sim.settle(SETTLE_MAX_STEPS, REST_SPEED)
            .map_err(bed_error)?;
    }
    if let Some(dir) = beds {
        create_dir(dir)?;
        let mut bytes = Vec::new();
        sim.checkpoint(|b| bytes.extend_from_slice(b));
        write_atomic(&bed.file::<R>(dir, columns, flow), &bytes)?;
    }
    Ok(())
}

/// Whether `sim` holds the bench bed of `sc` (settled; under its flow if
/// `flow`): its configuration (the width within rounding: a tiled bed's is
/// the tile's times the copies), its grains (every lattice site filled),
/// its flow.
fn is_bed<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &Sim<R, N, K, C>,
    sc: &Scenario,
    flow: bool,
) -> bool {
    let got = sim.config();
    let width = sc.bed.width();
    let expected_flow = flow.then(|| sc.flow(TAU_STAR));
    crate::sim::sims::of_scenario(got, sc)
        && (got.width - width).abs() <= 1e-9 * width
        && sim.len() == sc.bed.grains()
        && sim.flow() == expected_flow.as_ref()
}

fn bed_error(error: Error) -> HostError {
    HostError::kernel("bench bed")(error)
}

/// Replaces the bed in `sim` by `copies` copies of it side by side (grain
/// positions and velocities; contacts restart from their overlaps).
fn tile<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    copies: u32,
) -> Result<(), Error> {
    let grains: Vec<GrainSpec> = (0..sim.len()).filter_map(|i| sim.grain(i)).collect();
    let mut config = *sim.config();
    let width = config.width;
    config.width *= f64::from(copies);
    sim.reset(&config)?;
    for copy in 0..copies {
        for g in &grains {
            sim.add_grain(&GrainSpec {
                x: g.x + f64::from(copy) * width,
                ..*g
            })?;
        }
    }
    Ok(())
}

/// Runs `work` once: the timed region, never inlined, so that
/// `benches/instructions.sh` can count its instructions with callgrind.
#[inline(never)]
pub fn timed<T>(work: impl FnOnce() -> T) -> T {
    work()
}

/// Pseudo-velocities (m/s) of the contact-law case: small, of both signs,
/// like those of a settled bed.
fn contact_speeds(k: usize) -> (f64, f64) {
    let a = (k * 7 % 11) as f64 - 5.0;
    let b = (k * 5 % 13) as f64 - 6.0;
    (2e-5 * a, 2e-5 * b)
}

/// The contact-law case: every contact of a bed with its history, overlap
/// (from the normal spring) and pseudo-velocities.
pub struct ContactLawCase<R: Real> {
    law: ContactLaw<R>,
    contacts: Vec<(Spring<R>, R, R, R)>,
}

impl<R: Real> ContactLawCase<R> {
    /// The contacts of `sim`.
    pub fn new<const N: usize, const K: usize, const C: usize>(sim: &Sim<R, N, K, C>) -> Self {
        let law = sim.contact_law();
        let contacts = sim
            .contacts()
            .enumerate()
            .map(|(k, (_, _, spring))| {
                let (v_n, v_s) = contact_speeds(k);
                let overlap = spring.e_n / law.k_n;
                (spring, overlap, R::from_f64(v_n), R::from_f64(v_s))
            })
            .collect();
        ContactLawCase { law, contacts }
    }

    /// Applies the law once to every contact.
    pub fn pass(&mut self) {
        for (spring, overlap, v_n, v_s) in &mut self.contacts {
            std::hint::black_box(self.law.apply(spring, *overlap, *v_n, *v_s));
        }
    }
}

/// A prepared bed and repetitions of a case on it: what both `mbs bench`
/// and the criterion benches time ([`Prepared::time`]).
pub struct Prepared<'s, R: Real, const N: usize, const K: usize, const C: usize> {
    sim: &'s mut Sim<R, N, K, C>,
    case: Case,
    law: ContactLawCase<R>,
    /// Checkpoint of the state the step cases start from (empty otherwise).
    start: Vec<u8>,
    /// Steps since that state.
    taken: u64,
    /// Neighbour-list rebuilds during the timed steps.
    rebuilds: u64,
    /// Time each step on its own to find [`Prepared::rebuild_time`].
    split: bool,
    /// Time of the timed steps that rebuilt the neighbour lists (with
    /// `split`).
    rebuild_time: Duration,
    /// How steps run ([`Prepared::threads`]).
    stepping: Stepping<R, N, K>,
}

impl<'s, R: Real, const N: usize, const K: usize, const C: usize> Prepared<'s, R, N, K, C> {
    /// Prepares `bed` in `sim` for `case` ([`prepare`]) and rebuilds the
    /// neighbour lists, which a restored bed would otherwise do, untimed,
    /// on its first step. The flow cases also take that first step untimed:
    /// it recomputes the bed level and redraws the fluctuations, which the
    /// flow does once per 800 steps, so a short timed run (callgrind's 20
    /// steps) would otherwise count them 40 times too often.
    pub fn new(
        sim: &'s mut Sim<R, N, K, C>,
        bed: &BenchBed,
        case: Case,
        beds: Option<&Path>,
    ) -> Result<Self, HostError> {
        let flow = matches!(case, Case::Flow | Case::RebuildFlow);
        prepare(sim, bed, flow, beds)?;
        if flow {
            sim.step().map_err(bed_error)?;
        }
        let mut start = Vec::new();
        if case.steps() {
            sim.checkpoint(|b| start.extend_from_slice(b));
        }
        sim.rebuild_neighbours().map_err(bed_error)?;
        let law = ContactLawCase::new(sim);
        Ok(Prepared {
            sim,
            case,
            law,
            start,
            taken: 0,
            rebuilds: 0,
            split: false,
            rebuild_time: Duration::ZERO,
            stepping: Stepping::new(1),
        })
    }

    /// From now on, steps run the phased step on `threads` threads (a
    /// team kept for the bed, [`Stepping`]); 1: the step on one core. The
    /// bits are the same either way.
    pub fn threads(&mut self, threads: usize) {
        self.stepping = Stepping::new(threads);
    }

    /// The simulation.
    pub fn sim(&self) -> &Sim<R, N, K, C> {
        self.sim
    }

    /// Neighbour-list rebuilds during the timed steps so far.
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// From now on, times every step on its own and keeps the time of the
    /// steps that rebuilt the neighbour lists ([`Prepared::rebuild_time`]);
    /// costs two clock reads per step (~0.04 µs).
    pub fn split_rebuilds(&mut self) {
        self.split = true;
    }

    /// Time of the timed steps that rebuilt the neighbour lists (with
    /// [`Prepared::split_rebuilds`]; zero otherwise).
    pub fn rebuild_time(&self) -> Duration {
        self.rebuild_time
    }

    /// Times `times` repetitions (steps, rebuilds or passes over the
    /// contacts). Step cases run in stretches of at most [`WINDOW_STEPS`]
    /// from the prepared state, rewound to it between stretches, untimed.
    pub fn time(&mut self, times: u64) -> Result<Duration, Error> {
        let steps = self.case.steps();
        let mut total = Duration::ZERO;
        let mut left = times;
        while left > 0 {
            let chunk = if steps {
                if self.taken >= WINDOW_STEPS {
                    self.rewind()?;
                }
                left.min(WINDOW_STEPS - self.taken)
            } else {
                left
            };
            let rebuilds = self.sim.neighbour_rebuilds();
            let clock = Instant::now();
            if self.split && steps {
                timed(|| self.steps_split(chunk))?;
            } else {
                timed(|| self.repeat(chunk))?;
            }
            total += clock.elapsed();
            if steps {
                self.rebuilds += self.sim.neighbour_rebuilds() - rebuilds;
                self.taken += chunk;
            }
            left -= chunk;
        }
        Ok(total)
    }

    /// Back to the prepared state, neighbour lists built.
    fn rewind(&mut self) -> Result<(), Error> {
        self.sim.restore(&self.start)?;
        self.sim.rebuild_neighbours()?;
        self.taken = 0;
        Ok(())
    }

    /// `times` steps, each timed on its own ([`Prepared::split_rebuilds`]).
    fn steps_split(&mut self, times: u64) -> Result<(), Error> {
        for _ in 0..times {
            let rebuilds = self.sim.neighbour_rebuilds();
            let clock = Instant::now();
            self.stepping.run(self.sim, 1)?;
            if self.sim.neighbour_rebuilds() != rebuilds {
                self.rebuild_time += clock.elapsed();
            }
        }
        Ok(())
    }

    /// `times` repetitions.
    fn repeat(&mut self, times: u64) -> Result<(), Error> {
        match self.case {
            Case::Still | Case::Flow => self.stepping.run(self.sim, times),
            Case::Rebuild | Case::RebuildFlow => self.stepping.rebuild(self.sim, times),
            Case::Contacts => {
                (0..times).for_each(|_| self.law.pass());
                Ok(())
            }
        }
    }
}

/// What `mbs bench` measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BenchResult {
    /// Grains (fixed included).
    pub grains: usize,
    /// Repetitions timed (steps, rebuilds or passes over the contacts).
    pub repetitions: u64,
    /// Wall time per grain and repetition (ns), over all repetitions.
    pub ns_per_grain_step: f64,
    /// The same in each of [`ROUNDS`] rounds of the repetitions: (min,
    /// median, max).
    pub ns_spread: (f64, f64, f64),
    /// Rounds timed (fewer than [`ROUNDS`] for fewer repetitions).
    pub rounds: u64,
    /// Contacts per grain when timing started.
    pub contacts_per_grain: f64,
    /// Neighbour-list rebuilds during the timed steps (0 for the rebuild
    /// and contact-law cases, which do not step).
    pub rebuilds: u64,
    /// Share of the time spent in the steps that rebuilt them.
    pub rebuild_share: f64,
}

/// The repetitions of `mbs bench` are timed in this many rounds, for the
/// spread (min, median, max) of the time per grain-step.
pub const ROUNDS: u64 = 5;

/// `mbs bench`: prepare a bed, then time `repetitions` of `case`.
pub struct Bench<'a> {
    /// The bed.
    pub bed: BenchBed,
    /// What is timed.
    pub case: Case,
    /// Repetitions timed.
    pub repetitions: u64,
    /// Directory of prepared beds, if any.
    pub beds: Option<&'a Path>,
    /// Threads of one step (1: the step on one core; more: the phased
    /// step, [`Prepared::threads`]).
    pub threads: usize,
}

impl SimJob for Bench<'_> {
    type Output = Result<BenchResult, HostError>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        let mut bed = Prepared::new(sim, &self.bed, self.case, self.beds)?;
        bed.split_rebuilds();
        bed.threads(self.threads);
        let n = bed.sim().len() as f64;
        let contacts = bed.sim().observe().contacts as f64;
        let reps = self.repetitions;
        let rounds = reps.clamp(1, ROUNDS);
        let ns = |time: Duration, reps: u64| time.as_secs_f64() * 1e9 / (n * reps.max(1) as f64);
        let mut elapsed = Duration::ZERO;
        let mut per_round = Vec::new();
        for k in 0..rounds {
            // Round k times repetitions [k reps / rounds, (k + 1) reps / rounds).
            let part = (k + 1) * reps / rounds - k * reps / rounds;
            let time = bed.time(part).map_err(HostError::kernel("bench"))?;
            elapsed += time;
            per_round.push(ns(time, part));
        }
        per_round.sort_by(f64::total_cmp);
        let spread = (
            per_round[0],
            per_round[per_round.len() / 2],
            per_round[per_round.len() - 1],
        );
        Ok(BenchResult {
            grains: bed.sim().len(),
            repetitions: reps,
            ns_per_grain_step: ns(elapsed, reps),
            ns_spread: spread,
            rounds,
            contacts_per_grain: contacts / n,
            rebuilds: bed.rebuilds(),
            rebuild_share: bed.rebuild_time().as_secs_f64() / elapsed.as_secs_f64().max(1e-300),
        })
    }
}

/// Runs [`Bench`] on the smallest compiled capacity that holds the bed.
pub fn bench(
    precision: crate::config::Precision,
    bench: Bench<'_>,
) -> Result<BenchResult, HostError> {
    with_sim(precision, bench.bed.grain_count(), bench)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boxed_sim;

    #[test]
    fn columns_are_whole_tiles_for_large_beds() {
        let columns = |grains| BenchBed { grains, beta: 1.0 }.columns();
        assert_eq!(columns(64), 6);
        assert_eq!(columns(1_024), TILE_COLUMNS);
        assert_eq!(columns(16_384), 16 * TILE_COLUMNS);
        assert_eq!(columns(65_536), 64 * TILE_COLUMNS);
        assert_eq!(columns(10), 4);
    }

    #[test]
    fn tiles_repeat_the_bed_side_by_side() {
        let mut sim = boxed_sim::<f64, 256, 8>();
        let bed = BenchBed {
            grains: 55,
            beta: 15.8,
        };
        bed.scenario(5).build(&mut *sim).unwrap();
        let one: Vec<GrainSpec> = (0..sim.len()).filter_map(|i| sim.grain(i)).collect();
        let width = sim.config().width;
        tile(&mut *sim, 3).unwrap();
        assert_eq!(sim.len(), 3 * one.len());
        assert_eq!(sim.config().width, 3.0 * width);
        for copy in 0..3 {
            for (k, g) in one.iter().enumerate() {
                let t = sim.grain(copy * one.len() + k).unwrap();
                let x = g.x + copy as f64 * width;
                assert_eq!(t, GrainSpec { x, ..*g });
            }
        }
    }

    #[test]
    fn prepared_beds_are_reused_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let bed = BenchBed {
            grains: 55,
            beta: 15.8,
        };
        let mut fresh = boxed_sim::<f32, 256, 8>();
        prepare(&mut *fresh, &bed, true, Some(dir.path())).unwrap();
        let files = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(files, 2, "the settled bed and the flowing bed");
        let mut reused = boxed_sim::<f32, 256, 8>();
        prepare(&mut *reused, &bed, true, Some(dir.path())).unwrap();
        assert_eq!(fresh.digest(), reused.digest());
        assert!(reused.flow().is_some());
        fresh.run(100).unwrap();
        reused.run(100).unwrap();
        assert_eq!(fresh.digest(), reused.digest());
    }

    /// Step cases are timed over the same first WINDOW_STEPS steps from the
    /// prepared bed, however many repetitions are asked for.
    #[test]
    fn step_cases_rewind_to_the_prepared_bed_every_window_split_or_not() {
        let dir = tempfile::tempdir().unwrap();
        let bed = BenchBed {
            grains: 55,
            beta: 1.0,
        };
        let mut sim = boxed_sim::<f64, 256, 8>();
        let mut prepared = Prepared::new(&mut *sim, &bed, Case::Flow, Some(dir.path())).unwrap();
        let first = prepared.sim().step_count();
        prepared.time(WINDOW_STEPS).unwrap();
        let (end, rebuilds) = (prepared.sim().digest(), prepared.rebuilds());
        assert_eq!(prepared.sim().step_count(), first + WINDOW_STEPS);
        assert!(rebuilds > 0, "the flowing bed rebuilds its lists");
        prepared.time(WINDOW_STEPS / 2).unwrap();
        assert_eq!(prepared.sim().step_count(), first + WINDOW_STEPS / 2);
        prepared.time(WINDOW_STEPS / 2).unwrap();
        assert_eq!(prepared.sim().digest(), end, "the same stretch again");
        assert_eq!(prepared.rebuilds(), 2 * rebuilds);
        // Steps timed one by one (`mbs bench`): the same stretch, and the
        // steps that rebuilt took part of its time.
        assert_eq!(prepared.rebuild_time(), Duration::ZERO);
        prepared.split_rebuilds();
        let total = prepared.time(WINDOW_STEPS).unwrap();
        assert_eq!(prepared.sim().digest(), end);
        assert_eq!(prepared.rebuilds(), 3 * rebuilds);
        let in_rebuilds = prepared.rebuild_time();
        assert!(in_rebuilds > Duration::ZERO && in_rebuilds < total);
    }
}
