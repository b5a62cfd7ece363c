//! Numbers from the literature and from statistics: bed-load relations, hiding in mixtures, measured profiles, means and their errors.

pub mod measured;
pub mod mixture;
pub mod references;
pub mod stats;
