//! Helpers shared by the command-line tests.

use assert_cmd::Command;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A bed small and short enough for a test: 5 × 4 grains; 20 000 settling
/// steps per seed, per cell 8 000 spin-up + 20 000 window steps (fixed
/// 0.05 s windows of ten blocks).
pub const SMALL: &str = r#"
[bed]
columns = 5
rows = 4
[time]
settle = 0.05
spin_up = 0.02
window = 0.05
window_min = 0.05
block = 0.005
[flow]
tau_star = [0.1, 0.3]
[run]
seeds = [1, 2]
capacity = 256
"#;

/// `mbs --quiet`.
pub fn mbs() -> Command {
    let mut c = Command::cargo_bin("mbs").unwrap();
    c.arg("--quiet");
    c
}

/// `mbs --quiet run CONFIG --out OUT`.
pub fn run_into(config: &Path, out: &Path) -> Command {
    let mut c = mbs();
    c.arg("run").arg(config).arg("--out").arg(out);
    c
}

/// `mbs --quiet --threads THREADS run CONFIG --out OUT`.
pub fn run_on_threads(config: &Path, out: &Path, threads: &str) -> Command {
    let mut c = mbs();
    c.args(["--threads", threads, "run"])
        .arg(config)
        .arg("--out")
        .arg(out);
    c
}

/// `mbs --quiet run --resume DIR`.
pub fn resume_in(dir: &Path) -> Command {
    let mut c = mbs();
    c.arg("run").arg("--resume").arg(dir);
    c
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Deterministic "random" fractions in [0, 1) from a fixed LCG (so a
/// failure reproduces).
pub fn random_fractions(seed: u64) -> impl Iterator<Item = f64> {
    std::iter::successors(Some(seed), |s| {
        Some(
            s.wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407),
        )
    })
    .skip(1)
    .map(|s| (s >> 11) as f64 / (1u64 << 53) as f64)
}

/// The value of `f` and the wall time it took.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let start = std::time::Instant::now();
    (f(), start.elapsed())
}

/// Spawns `command`, SIGKILLs it after `delay` unless it has finished, and
/// waits for it. Returns whether it was killed.
pub fn kill_after(command: &mut std::process::Command, delay: Duration) -> bool {
    let mut child = command.spawn().unwrap();
    std::thread::sleep(delay);
    let killed = child.try_wait().unwrap().is_none();
    if killed {
        child.kill().unwrap();
    }
    child.wait().unwrap();
    killed
}
