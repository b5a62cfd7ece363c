//! A team of threads kept for one bed's phased step. The thread that runs
//! a phase leads: it publishes the phase's ranges with one store, runs the
//! first range and waits for the others. Its helpers wait between phases
//! spinning for 200 µs (then asleep), so the ranges start together.
//!
//! rayon's `join` hands the second half of a phase to a worker that has
//! gone to sleep since the last phase and must be woken (a system call on
//! each side): a 16 k-grain step on two cores ran 5.1 ns per grain-step
//! that way and 4.5 with a team (docs/performance.md, "A team per bed").
//! What a range computes, and so the bits, does not depend on which thread
//! runs it.

use std::cell::UnsafeCell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use mbs_kernel::{cut_ranges, Phase};

/// How long a helper spins for the next phase before it sleeps: longer
/// than the serial work between two phases of a step (microseconds) and
/// of a 16 k-grain rebuild (its sort, pair index and history: ~0.15 ms);
/// a larger bed's rebuild outlasts it, and the helpers are then woken
/// (tens of microseconds, once per rebuild). Far shorter than a pause for
/// output.
const SPIN: Duration = Duration::from_micros(200);

/// One phase as the helpers see it: helper `k` runs range `k + 1`.
type Job = *const (dyn Fn(usize) + Sync + 'static);

/// A range of a phase before it runs, and its outcome after.
type Slot<P> = Mutex<(Option<P>, Option<thread::Result<<P as Phase>::Output>>)>;

/// What the leader shares with its helpers.
struct Shared {
    /// Bumped once per phase (and to stop): a helper runs the current job
    /// when it sees a value it has not seen.
    generation: AtomicUsize,
    /// The current job. The leader writes it only while no helper runs
    /// one (`pending` is 0); a helper reads it after it has seen the bump
    /// of `generation` that follows the write.
    job: UnsafeCell<Option<Job>>,
    /// Helpers that have not finished the current job.
    pending: AtomicUsize,
    /// Set before the last bump: the helpers return.
    stop: AtomicBool,
    /// Per helper: asleep, or about to be, and to be unparked.
    asleep: Vec<AtomicBool>,
    /// Whether helpers spin at all (not when the team has more threads than
    /// the machine has cores: a spinning helper would hold a core that
    /// another member needs).
    spin: bool,
}

// SAFETY: `job` is the one field that is neither `Send` nor `Sync`. The
// leader writes it when every helper has finished the previous job
// (`pending` read as 0 with Acquire after each helper's Release decrement)
// and before the SeqCst bump of `generation` (one leader at a time: the
// `busy` flag, Acquire and Release, orders two leaders' writes); a helper
// reads it only after it has seen that bump (Acquire), and dereferences it
// only until its decrement of `pending`, before which the leader does not
// return from or unwind out of `Team::run`, where the pointee (`Sync`)
// lives.
unsafe impl Sync for Shared {}
// SAFETY: as for `Sync`.
unsafe impl Send for Shared {}

/// A leader (whichever thread calls [`Team::run`]) and its helper
/// threads, which end when the team is dropped.
///
/// ```
/// use mbs::sim::team::Team;
/// use mbs_kernel::Phase;
///
/// /// The sum of a range of numbers.
/// struct Sum(std::ops::Range<u64>);
///
/// impl Phase for Sum {
///     type Output = u64;
///     fn grains(&self) -> usize {
///         self.0.clone().count()
///     }
///     fn split_at(self, mid: usize) -> (Self, Self) {
///         let cut = (self.0.start + mid as u64).min(self.0.end);
///         (Sum(self.0.start..cut), Sum(cut..self.0.end))
///     }
///     fn run(self) -> u64 {
///         self.0.sum()
///     }
///     fn merge(first: u64, second: u64) -> u64 {
///         first + second
///     }
/// }
///
/// let team = Team::new(3);
/// assert_eq!(team.run(Sum(0..1000), 3), 499_500);
/// ```
pub struct Team {
    shared: Arc<Shared>,
    helpers: Vec<JoinHandle<()>>,
    /// Set while a leader runs a phase: a second caller (another thread,
    /// or a phase that runs a phase) runs its phase whole instead.
    busy: AtomicBool,
}

impl Team {
    /// A team of `threads` threads: the leader and `threads − 1` helpers
    /// (fewer if the system refuses to start one; the ranges, and the bits,
    /// stay the same).
    pub fn new(threads: usize) -> Team {
        let wanted = threads.max(1) - 1;
        let cores = thread::available_parallelism().map_or(1, usize::from);
        let shared = Arc::new(Shared {
            generation: AtomicUsize::new(0),
            job: UnsafeCell::new(None),
            pending: AtomicUsize::new(0),
            stop: AtomicBool::new(false),
            asleep: (0..wanted).map(|_| AtomicBool::new(false)).collect(),
            spin: wanted < cores,
        });
        let helpers = (0..wanted)
            .map_while(|k| {
                let shared = Arc::clone(&shared);
                thread::Builder::new()
                    .name(format!("mbs-team-{}", k + 1))
                    .spawn(move || help(&shared, k))
                    .ok()
            })
            .collect();
        Team {
            shared,
            helpers,
            busy: AtomicBool::new(false),
        }
    }

    /// Threads of the team, the leader included.
    pub fn threads(&self) -> usize {
        self.helpers.len() + 1
    }

    /// Runs `phase` cut into `parts` ranges of about equal size (at most
    /// one per thread), the calling thread running the first; the ranges'
    /// outputs merged in order. A panic in a range is raised here once
    /// every range has stopped.
    pub fn run<P: Phase>(&self, phase: P, parts: usize) -> P::Output {
        let parts = parts.min(self.threads());
        if parts <= 1 || self.busy.swap(true, Ordering::Acquire) {
            return phase.run();
        }
        // Released however this call ends (a range's `split_at` may panic).
        let busy = Release(&self.busy);
        let slots = cut(phase, parts);
        let job = |k: usize| {
            let Some(slot) = slots.get(k) else { return };
            let range = slot.lock().map_or(None, |mut s| s.0.take());
            if let Some(range) = range {
                let outcome = panic::catch_unwind(AssertUnwindSafe(|| range.run()));
                if let Ok(mut s) = slot.lock() {
                    s.1 = Some(outcome);
                }
            }
        };
        self.publish(&job);
        // From here the helpers may use `job` and `slots`: this call waits
        // for them before it returns or unwinds (dropped before them).
        let helpers = Helpers(self);
        job(0);
        drop(helpers);
        drop(busy);
        let mut outputs = slots.into_iter().map(|slot| {
            let (_, outcome) = slot.into_inner().unwrap_or_else(|e| e.into_inner());
            outcome.unwrap_or_else(|| Err(lost("a range of a phase did not run")))
        });
        let first = outputs
            .next()
            .unwrap_or_else(|| Err(lost("a phase without ranges")));
        let merged = outputs.fold(first, |a, b| Ok(P::merge(a?, b?)));
        merged.unwrap_or_else(|cause| panic::resume_unwind(cause))
    }

    /// Hands `job` to the helpers and wakes those asleep.
    fn publish(&self, job: &(dyn Fn(usize) + Sync)) {
        // SAFETY: the lifetime is erased for the helpers' sake; `run` waits
        // for every helper to finish with the pointer before `job` goes
        // (see `Shared`). No helper runs a job now: `pending` is 0.
        unsafe {
            let job = std::mem::transmute::<*const (dyn Fn(usize) + Sync + '_), Job>(job);
            *self.shared.job.get() = Some(job);
        }
        let helpers = self.helpers.len();
        self.shared.pending.store(helpers, Ordering::Relaxed);
        self.shared.generation.fetch_add(1, Ordering::SeqCst);
        for (asleep, helper) in self.shared.asleep.iter().zip(&self.helpers) {
            if asleep.load(Ordering::SeqCst) {
                helper.thread().unpark();
            }
        }
    }

    /// Waits until every helper has finished the current job.
    fn wait(&self) {
        let mut spins = 0u32;
        while self.shared.pending.load(Ordering::Acquire) != 0 {
            if self.shared.spin && spins < 1 << 16 {
                spins += 1;
                std::hint::spin_loop();
            } else {
                thread::yield_now();
            }
        }
    }
}

/// Clears a team's `busy` flag when dropped.
struct Release<'a>(&'a AtomicBool);

impl Drop for Release<'_> {
    fn drop(&mut self) {
        self.0.store(false, Ordering::Release);
    }
}

/// Waits for a team's helpers to finish the current job when dropped.
struct Helpers<'a>(&'a Team);

impl Drop for Helpers<'_> {
    fn drop(&mut self) {
        self.0.wait();
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.shared.generation.fetch_add(1, Ordering::SeqCst);
        for helper in self.helpers.drain(..) {
            helper.thread().unpark();
            // A helper catches its ranges' panics: it returns normally.
            let _ = helper.join();
        }
    }
}

impl std::fmt::Debug for Team {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Team")
            .field("threads", &self.threads())
            .finish()
    }
}

/// A panic's payload for a range that gave nothing.
fn lost(what: &'static str) -> Box<dyn std::any::Any + Send> {
    Box::new(what)
}

/// `phase` cut into `parts` ranges ([`cut_ranges`]), in order.
fn cut<P: Phase>(phase: P, parts: usize) -> Vec<Slot<P>> {
    let mut slots = Vec::with_capacity(parts);
    let last = cut_ranges(phase, parts, |range| {
        slots.push(Mutex::new((Some(range), None)))
    });
    slots.push(Mutex::new((Some(last), None)));
    slots
}

/// Helper `k`: waits for a job (spinning for [`SPIN`], then asleep), runs
/// its range, reports; until told to stop.
fn help(shared: &Shared, k: usize) {
    let mut seen = 0;
    loop {
        let start = Instant::now();
        let mut spins = 0u32;
        loop {
            let now = shared.generation.load(Ordering::Acquire);
            if now != seen {
                seen = now;
                break;
            }
            spins = spins.wrapping_add(1);
            if shared.spin && (!spins.is_multiple_of(64) || start.elapsed() < SPIN) {
                std::hint::spin_loop();
                continue;
            }
            shared.asleep[k].store(true, Ordering::SeqCst);
            if shared.generation.load(Ordering::SeqCst) == seen {
                thread::park();
            }
            shared.asleep[k].store(false, Ordering::SeqCst);
        }
        if shared.stop.load(Ordering::SeqCst) {
            return;
        }
        // SAFETY: written before the bump just seen (see `Shared`).
        if let Some(job) = unsafe { *shared.job.get() } {
            // SAFETY: alive until `pending` is 0 (see `Shared`); the job
            // catches its range's panic.
            unsafe { (*job)(k + 1) };
        }
        shared.pending.fetch_sub(1, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The numbers of a range, in order (a phase whose output shows the
    /// order of the merge).
    struct Numbers(std::ops::Range<usize>);

    impl Phase for Numbers {
        type Output = Vec<usize>;
        fn grains(&self) -> usize {
            self.0.len()
        }
        fn split_at(self, mid: usize) -> (Self, Self) {
            let cut = (self.0.start + mid).min(self.0.end);
            (Numbers(self.0.start..cut), Numbers(cut..self.0.end))
        }
        fn run(self) -> Vec<usize> {
            if self.0.contains(&666) {
                panic!("the number of the beast");
            }
            self.0.collect()
        }
        fn merge(mut first: Vec<usize>, second: Vec<usize>) -> Vec<usize> {
            first.extend(second);
            first
        }
    }

    #[test]
    fn ranges_merge_in_order_for_every_cut() {
        let team = Team::new(5);
        for parts in 0..8 {
            for _ in 0..50 {
                assert_eq!(
                    team.run(Numbers(3..103), parts),
                    (3..103).collect::<Vec<_>>()
                );
            }
        }
        // More ranges than grains: empty ranges merge as nothing.
        assert_eq!(team.run(Numbers(0..2), 5), vec![0, 1]);
    }

    #[test]
    fn a_panic_in_any_range_reaches_the_caller_and_the_team_goes_on() {
        let team = Team::new(4);
        for range in [600..700, 0..700, 0..1000] {
            let got = panic::catch_unwind(AssertUnwindSafe(|| team.run(Numbers(range), 4)));
            assert!(got.is_err());
        }
        assert_eq!(team.run(Numbers(0..10), 4), (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn a_panic_while_cutting_leaves_the_team_whole() {
        /// Numbers whose cut panics once.
        struct BadCut(Numbers, bool);
        impl Phase for BadCut {
            type Output = Vec<usize>;
            fn grains(&self) -> usize {
                self.0.grains()
            }
            fn split_at(self, mid: usize) -> (Self, Self) {
                assert!(!self.1, "a cut that fails");
                let (a, b) = self.0.split_at(mid);
                (BadCut(a, false), BadCut(b, false))
            }
            fn run(self) -> Vec<usize> {
                // Which thread ran the range, to see that helpers still do.
                vec![thread::current().name().map_or(0, |n| n.len())]
            }
            fn merge(first: Vec<usize>, second: Vec<usize>) -> Vec<usize> {
                Numbers::merge(first, second)
            }
        }
        let team = Team::new(2);
        let bad = panic::catch_unwind(AssertUnwindSafe(|| {
            team.run(BadCut(Numbers(0..9), true), 2)
        }));
        assert!(bad.is_err());
        // The helper ("mbs-team-1", 10 characters) runs the second range.
        let names = team.run(BadCut(Numbers(0..9), false), 2);
        assert_eq!(names[1], "mbs-team-1".len(), "{names:?}");
    }

    #[test]
    fn a_phase_run_within_a_phase_runs_whole() {
        /// A phase whose ranges each run a phase on the same team.
        struct Nested<'a>(&'a Team, std::ops::Range<usize>);
        impl Phase for Nested<'_> {
            type Output = Vec<usize>;
            fn grains(&self) -> usize {
                self.1.len()
            }
            fn split_at(self, mid: usize) -> (Self, Self) {
                let cut = (self.1.start + mid).min(self.1.end);
                (
                    Nested(self.0, self.1.start..cut),
                    Nested(self.0, cut..self.1.end),
                )
            }
            fn run(self) -> Vec<usize> {
                self.0.run(Numbers(self.1), 3)
            }
            fn merge(first: Vec<usize>, second: Vec<usize>) -> Vec<usize> {
                Numbers::merge(first, second)
            }
        }
        let team = Team::new(3);
        assert_eq!(
            team.run(Nested(&team, 0..99), 3),
            (0..99).collect::<Vec<_>>()
        );
    }

    #[test]
    fn helpers_asleep_are_woken() {
        // Two threads: the helper spins where the machine has two cores.
        let team = Team::new(2);
        for _ in 0..5 {
            thread::sleep(SPIN * 3);
            assert_eq!(team.run(Numbers(0..30), 2), (0..30).collect::<Vec<_>>());
        }
    }
}
