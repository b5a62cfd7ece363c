//! The digest's vocabulary: [`Fnv1a`], the 64-bit hash over canonical bits
//! (−0.0 as +0.0, one NaN pattern), little-endian, and [`FieldGroup`], the
//! groups of the state's fields. The digest of a simulation itself
//! ([`crate::Sim::digest`], [`crate::Sim::group_digest`]) is an `impl Sim`
//! in `sim/digest.rs`; these types stay here, below the simulation, because
//! they need none: the host hashes its own files with [`Fnv1a`], and
//! [`crate::GrainField`] names its [`FieldGroup`].

use crate::real::Real;

/// FNV-1a, 64-bit.
///
/// ```
/// use mbs_kernel::Fnv1a;
///
/// // The offset basis, and the published test vector of "a".
/// assert_eq!(Fnv1a::of(b""), 0xcbf2_9ce4_8422_2325);
/// assert_eq!(Fnv1a::of(b"a"), 0xaf63_dc4c_8601_ec8c);
/// // Floats by their canonical bits: −0.0 as +0.0.
/// let (mut a, mut b) = (Fnv1a::default(), Fnv1a::default());
/// a.real(-0.0f64);
/// b.real(0.0f64);
/// assert_eq!(a.finish(), b.finish());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    /// The digest of `bytes` alone.
    pub fn of(bytes: &[u8]) -> u64 {
        let mut h = Fnv1a::default();
        h.bytes(bytes);
        h.finish()
    }

    /// Hashes bytes.
    pub fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Hashes 8 little-endian bytes.
    pub fn word(&mut self, w: u64) {
        self.bytes(&w.to_le_bytes());
    }

    /// Hashes a float by its canonical bits.
    pub fn real<R: Real>(&mut self, x: R) {
        self.word(R::canonical_bits(x));
    }

    /// The digest.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// A group of the state's fields, digested on its own by
/// [`crate::Sim::group_digest`] so that a mismatch says which group differs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FieldGroup {
    /// Every grain's x, y.
    Positions,
    /// Every grain's u, v.
    Velocities,
    /// Every grain's ω.
    Spins,
    /// The contacts (i, j) in (i, j) order with their spring history e_n, e_s.
    Springs,
    /// The flow state: step count, the held fluctuation draws of every
    /// grain, seed, flow epoch, flow on, mean bed level, and the coupled
    /// flow's state.
    Flow,
}

impl FieldGroup {
    /// Every group, in trace order.
    pub const ALL: [FieldGroup; 5] = [
        FieldGroup::Positions,
        FieldGroup::Velocities,
        FieldGroup::Spins,
        FieldGroup::Springs,
        FieldGroup::Flow,
    ];

    /// The group's name in traces: `positions`, `velocities`, `spins`,
    /// `springs`, `flow`.
    pub fn name(self) -> &'static str {
        match self {
            FieldGroup::Positions => "positions",
            FieldGroup::Velocities => "velocities",
            FieldGroup::Spins => "spins",
            FieldGroup::Springs => "springs",
            FieldGroup::Flow => "flow",
        }
    }
}
