//! Seeded random streams. Every random number in the kernel comes from a
//! `Xoshiro256PlusPlus` seeded from (run seed, stream tag, keys) through
//! SplitMix64 mixing, so a draw depends only on its key — never on how many
//! draws came before it elsewhere, on grain order, or on threads.

use rand_core::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Stream tag of the initial bed builder (docs/model.md §7).
pub const BED_STREAM: u64 = 0xBED0_0000_0000_0001;
/// Stream tag of the turbulent fluctuations (docs/model.md (15)).
pub const TURBULENCE_STREAM: u64 = 0x7B_0000_0000_0002;

/// SplitMix64 finaliser: a bijective 64-bit mixer.
#[inline]
pub const fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A seeded generator with uniform and Gaussian draws in `f64`.
pub struct Stream {
    rng: Xoshiro256PlusPlus,
}

impl Stream {
    /// The stream for `(seed, tag, a, b)`.
    pub fn new(seed: u64, tag: u64, a: u64, b: u64) -> Self {
        let key = mix64(mix64(mix64(seed ^ tag) ^ a) ^ b);
        Stream {
            rng: Xoshiro256PlusPlus::seed_from_u64(key),
        }
    }

    /// Uniform in (0, 1]: 53 random bits, never 0 (safe for `ln`).
    pub fn uniform_open0(&mut self) -> f64 {
        ((self.rng.next_u64() >> 11) + 1) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.rng.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// Two independent standard normal deviates (Box–Muller, libm only).
    pub fn gaussian_pair(&mut self) -> (f64, f64) {
        let r = libm::sqrt(-2.0 * libm::log(self.uniform_open0()));
        let theta = 2.0 * core::f64::consts::PI * self.uniform();
        (r * libm::cos(theta), r * libm::sin(theta))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_depend_only_on_the_key() {
        let a = Stream::new(7, TURBULENCE_STREAM, 3, 11).gaussian_pair();
        let b = Stream::new(7, TURBULENCE_STREAM, 3, 11).gaussian_pair();
        let c = Stream::new(7, TURBULENCE_STREAM, 3, 12).gaussian_pair();
        let d = Stream::new(8, TURBULENCE_STREAM, 3, 11).gaussian_pair();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
    }

    #[test]
    fn gaussian_moments() {
        let mut s = Stream::new(1, BED_STREAM, 0, 0);
        let n = 100_000;
        let (mut m1, mut m2) = (0.0, 0.0);
        for _ in 0..n / 2 {
            let (a, b) = s.gaussian_pair();
            m1 += a + b;
            m2 += a * a + b * b;
        }
        let mean = m1 / n as f64;
        let var = m2 / n as f64 - mean * mean;
        // 5σ bounds: σ(mean) = 1/√n, σ(var) ≈ √(2/n).
        assert!(mean.abs() < 5.0 / (n as f64).sqrt(), "mean {mean}");
        assert!(
            (var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt(),
            "var {var}"
        );
    }
}
