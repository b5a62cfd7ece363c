//! Criterion benchmarks of the step live in `step.rs` (`cargo bench --manifest-path
//! benches/Cargo.toml`); this empty library only gives the package a target.
