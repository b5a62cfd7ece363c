//! The kernel's checkpoint loader on raw bytes (first byte even) or on a
//! valid checkpoint of the paper's bed edited by the input (first byte odd:
//! then pairs of (position, byte) overwrite it): restore succeeds and the
//! simulation steps, or it fails and nothing changed.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mbs_kernel::{Scenario, Sim};
use std::sync::OnceLock;

type Small = Sim<f64, 64, 8>;

fn valid() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| {
        let mut sim = Box::new(Small::new());
        let sc = Scenario::paper();
        sc.build(&mut *sim).expect("paper bed");
        sim.run(200).expect("runs");
        sim.set_flow(Some(&sc.flow(Scenario::PAPER_TAU_STAR)))
            .expect("flow");
        sim.run(200).expect("runs");
        let mut out = Vec::new();
        sim.checkpoint(|b| out.extend_from_slice(b));
        out
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let bytes = if mode % 2 == 0 {
        rest.to_vec()
    } else {
        let mut b = valid().to_vec();
        for pair in rest.chunks_exact(3) {
            let at = usize::from(u16::from_le_bytes([pair[0], pair[1]])) % b.len();
            b[at] = pair[2];
        }
        if mode & 2 != 0 && !rest.is_empty() {
            let cut = usize::from(rest[0]) * b.len() / 256;
            b.truncate(cut);
        }
        b
    };
    let mut sim = Box::new(Small::new());
    let before = sim.digest();
    match sim.restore(&bytes) {
        Ok(()) => {
            let _ = sim.run(3);
        }
        Err(_) => assert_eq!(
            sim.digest(),
            before,
            "a refused checkpoint changed the simulation"
        ),
    }
});
