//! The `mbs` command's integration tests, in one test binary (one link
//! instead of nine; see docs/architecture.md, "Tests"). Each module is one
//! topic; `common` holds the shared small configurations and helpers.

mod common;

mod attack;
mod beds;
mod calibrate;
mod cli;
mod coupled;
mod figures;
mod frames;
mod hostile;
mod links;
mod log;
mod paper_case;
mod resume;
mod round2;
mod round3;
mod threads;
mod trace;
