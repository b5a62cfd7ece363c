//! Prints the memory footprint of the kernel's simulation per grain.
//! Run: `cargo run --release -p mbs --example footprint`.
use mbs_kernel::Sim;

fn main() {
    const N: usize = 16_384;
    let f32_bytes = std::mem::size_of::<Sim<f32, N, 8>>();
    let f64_bytes = std::mem::size_of::<Sim<f64, N, 8>>();
    println!(
        "Sim<f32, {N}, 8>: {f32_bytes} B = {:.1} B/grain",
        f32_bytes as f64 / N as f64
    );
    println!(
        "Sim<f64, {N}, 8>: {f64_bytes} B = {:.1} B/grain",
        f64_bytes as f64 / N as f64
    );
    let f32_k6 = std::mem::size_of::<Sim<f32, N, 6>>();
    println!(
        "Sim<f32, {N}, 6>: {f32_k6} B = {:.1} B/grain",
        f32_k6 as f64 / N as f64
    );
}
