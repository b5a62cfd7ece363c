//! Targets without vector lanes (every target but x86-64 with AVX2): the
//! pair index of the batched step is empty and never ready, so the scalar
//! step runs. The methods of the real one (`step/index.rs`), doing nothing.

use crate::contact::Spring;
use crate::grains::Grains;
use crate::neighbours::Neighbours;
use crate::real::Real;
use core::marker::PhantomData;

/// The pair index of a target without lanes: nothing (zero bytes).
#[derive(Debug, Clone)]
pub(crate) struct PairIndex<R: Real, const N: usize, const K: usize>(PhantomData<R>);

impl<R: Real, const N: usize, const K: usize> PairIndex<R, N, K> {
    /// Empty.
    pub(crate) const fn new() -> Self {
        PairIndex(PhantomData)
    }

    /// Nothing to forget.
    pub(crate) fn clear(&mut self) {}

    /// Nothing to index: never ready.
    pub(crate) fn index(&mut self, _: &Grains<R, N>, _: &Neighbours<R, N, K>, _: R, _: R) {}

    /// The slots always hold the history.
    pub(crate) fn spring_at(&self, _: usize, _: usize) -> Option<Spring<R>> {
        None
    }

    /// The slots always hold the history.
    pub(crate) fn history_to_slots(&mut self, _: &mut [[Spring<R>; K]; N]) {}
}
