//! Criterion benchmarks of the step live in `step.rs` (`cargo bench --bench
//! step`); this empty library only gives the package a target.
