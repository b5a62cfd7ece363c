//! Puts the target's memory map on the linker search path as memory.x and
//! links with cortex-m-rt's link.x: the top-level memory.x for the
//! Cortex-M4F (mps2-an386), memory-thumbv6m.x for the Cortex-M0 (microbit);
//! `cfg(phased)` where the phased step's buffers fit (not the Cortex-M0).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    let target = env::var("TARGET").expect("TARGET");
    // The phased step's buffers (`golden::run_phased`) fit every board but
    // the Cortex-M0's 16 KiB, next to the simulation.
    println!("cargo::rustc-check-cfg=cfg(phased)");
    if !target.starts_with("thumbv6m") {
        println!("cargo:rustc-cfg=phased");
    }
    let memory = if target.starts_with("thumbv6m") {
        "memory-thumbv6m.x"
    } else {
        "../memory.x"
    };
    fs::copy(memory, out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rerun-if-changed={memory}");
}
