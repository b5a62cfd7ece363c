//! Helpers shared by the kernel's integration tests. Each test binary
//! declares it `pub mod common`: its items are this suite's shared API, used
//! by some binaries and not others.

use mbs_kernel::{ContactConstants, GrainSpec, Material, Real, Sim, SimConfig, Tension};

/// Grain diameter used throughout (m).
pub const D: f64 = 0.5e-3;

/// A small simulation on the heap.
pub type Small<R> = Sim<R, 256, 8>;

/// Neighbour slots of a simulation that runs the **batched step** where
/// it has lanes (x86-64 with AVX2): a power of two.
pub const BATCHED: usize = 8;

/// Neighbour slots of a simulation that always runs the **scalar step**:
/// not a power of two, so the batched step's lanes do not fit.
pub const SCALAR: usize = 6;

/// A boxed, reset simulation of 256 grains with `K` neighbour slots per
/// grain: [`BATCHED`] or [`SCALAR`] picks the step path. When dropped it
/// adds the steps it took by the batched step to this thread's count
/// ([`batched_steps`]).
pub fn sim<R: Real, const K: usize>(config: &SimConfig) -> Tracked<R, K> {
    let mut s = Box::new(Sim::<R, 256, K>::new());
    s.reset(config).expect("valid config");
    Tracked(s)
}

/// A simulation of [`sim`] that reports its batched steps when dropped.
pub struct Tracked<R: Real, const K: usize>(Box<Sim<R, 256, K>>);

impl<R: Real, const K: usize> std::ops::Deref for Tracked<R, K> {
    type Target = Sim<R, 256, K>;
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl<R: Real, const K: usize> std::ops::DerefMut for Tracked<R, K> {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

impl<R: Real, const K: usize> Drop for Tracked<R, K> {
    fn drop(&mut self) {
        BATCHED_STEPS.with(|n| n.set(n.get() + self.0.events().batched_steps));
    }
}

std::thread_local! {
    static BATCHED_STEPS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// Runs `body` and returns the batched steps of the simulations of [`sim`]
/// it dropped (each test runs on its own thread).
pub fn batched_steps(body: impl FnOnce()) -> u64 {
    BATCHED_STEPS.with(|n| n.set(0));
    body();
    BATCHED_STEPS.with(|n| n.get())
}

/// The step path a test of [`both_paths`] claims is the one that ran: a
/// `*_batched` test took batched steps where the batched step has lanes
/// (x86-64 with AVX2) and none elsewhere; a `*_scalar` test took none.
pub fn assert_path(batched_steps: u64, batched: bool) {
    if batched && cfg!(all(target_arch = "x86_64", target_feature = "avx2")) {
        assert!(batched_steps > 0, "a *_batched test ran no batched step");
    } else {
        assert_eq!(
            batched_steps, 0,
            "the batched step ran where it has no lanes or was not asked for"
        );
    }
}

/// A boxed, reset simulation.
pub fn small<R: Real>(config: &SimConfig) -> Box<Small<R>> {
    let mut s = Box::new(Small::<R>::new());
    s.reset(config).expect("valid config");
    s
}

/// Translational inertia of a grain of diameter `D` with added mass.
pub fn mass() -> f64 {
    Material::default().translational_mass(D)
}

/// A configuration with explicit normal constants; k_s and η_s follow (12)–(13).
pub fn config(dt: f64, k_n: f64, eta_n: f64, mu: f64) -> SimConfig {
    let material = Material {
        mu,
        ..Material::default()
    };
    SimConfig {
        step_dt: dt,
        material,
        contact: ContactConstants::from_normal(k_n, eta_n, material.nu),
        tension: Tension::Dashpot,
        gravity: [0.0, 0.0],
        width: 40.0 * D,
        y_min: -20.0 * D,
        y_max: 200.0 * D,
        surface: 200.0 * D,
        skin: 0.1 * D,
        seed: 1,
        slope_angle: 0.0,
    }
}

/// A mobile grain of diameter `D`.
pub fn mobile(x: f64, y: f64, u: f64, v: f64) -> GrainSpec {
    GrainSpec {
        x,
        y,
        u,
        v,
        diameter: D,
        ..GrainSpec::default()
    }
}

/// A fixed grain of diameter `D`.
pub fn fixed(x: f64, y: f64) -> GrainSpec {
    GrainSpec {
        x,
        y,
        diameter: D,
        fixed: true,
        ..GrainSpec::default()
    }
}

/// Runs a test body `$body::<R, K>(tol)` for f32 and f64 (`tol` as in
/// [`both_precisions`]) through both step paths ([`BATCHED`], [`SCALAR`]),
/// and checks that the path the test is named after is the one that ran
/// ([`assert_path`]).
#[macro_export]
macro_rules! both_paths {
    ($name:ident, $body:ident) => {
        mod $name {
            #[test]
            fn f64_batched() {
                let n = $crate::common::batched_steps(|| {
                    super::$body::<f64, { $crate::common::BATCHED }>(1e-9)
                });
                $crate::common::assert_path(n, true);
            }
            #[test]
            fn f64_scalar() {
                let n = $crate::common::batched_steps(|| {
                    super::$body::<f64, { $crate::common::SCALAR }>(1e-9)
                });
                $crate::common::assert_path(n, false);
            }
            #[test]
            fn f32_batched() {
                let n = $crate::common::batched_steps(|| {
                    super::$body::<f32, { $crate::common::BATCHED }>(1e-4)
                });
                $crate::common::assert_path(n, true);
            }
            #[test]
            fn f32_scalar() {
                let n = $crate::common::batched_steps(|| {
                    super::$body::<f32, { $crate::common::SCALAR }>(1e-4)
                });
                $crate::common::assert_path(n, false);
            }
        }
    };
}

/// Runs a test body for f32 and f64.
#[macro_export]
macro_rules! both_precisions {
    ($name:ident, $body:ident) => {
        mod $name {
            #[test]
            fn f64() {
                super::$body::<f64>(1e-9);
            }
            #[test]
            fn f32() {
                super::$body::<f32>(1e-4);
            }
        }
    };
}

/// The checkpoint of `sim` as bytes.
pub fn bytes<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &Sim<R, N, K, C>,
) -> Vec<u8> {
    let mut out = Vec::new();
    sim.checkpoint(|b| out.extend_from_slice(b));
    out
}

/// `whole`, stopped where it is, restored into `resumed` (other
/// capacities): the same digest and checkpoint bytes, and after `more`
/// steps of each the same digest again; `at` names the stop in messages.
pub fn assert_resumes<R: Real, const N: usize, const K: usize, const C: usize>(
    whole: &mut Sim<R, N, K, C>,
    resumed: &mut Sim<R, 128, 10, 900>,
    more: u64,
    at: u64,
) {
    let saved = bytes(whole);
    resumed.restore(&saved).unwrap();
    assert_eq!(resumed.digest(), whole.digest(), "restored at {at}");
    assert_eq!(bytes(resumed), saved, "checkpoint of the restored state");
    whole.run(more).unwrap();
    resumed.run(more).unwrap();
    assert_eq!(resumed.digest(), whole.digest(), "continued from {at}");
}
