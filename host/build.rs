//! Build metadata for `mbs digest --trace`: the target triple
//! (`MBS_TARGET`) and the git commit (`MBS_GIT_COMMIT`: from the
//! environment, else `git rev-parse HEAD` when git and a repository are
//! there, else unset).

use std::process::Command;

fn main() {
    let target = std::env::var("TARGET").unwrap_or_default();
    println!("cargo:rustc-env=MBS_TARGET={target}");
    println!("cargo:rerun-if-env-changed=MBS_GIT_COMMIT");
    let commit = std::env::var("MBS_GIT_COMMIT").ok().or_else(|| {
        let out = Command::new("git")
            .args(["rev-parse", "HEAD"])
            .output()
            .ok()?;
        let text = String::from_utf8(out.stdout).ok()?;
        (out.status.success() && !text.trim().is_empty()).then(|| text.trim().to_string())
    });
    if let Some(commit) = commit {
        println!("cargo:rustc-env=MBS_GIT_COMMIT={commit}");
    }
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=../kernel/src");
}
