//! Numbers from the literature and from statistics: bed-load relations, hiding in mixtures, measured profiles, means, their transients and their intervals.

pub mod interval;
pub mod measured;
pub mod mixture;
pub mod references;
pub mod stats;
pub mod truncation;
