//! The cell-checkpoint decoder: any bytes decode or are refused, never a
//! panic and never an allocation beyond the input's size.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mbs::work::cell::CellCheckpoint;

fuzz_target!(|data: &[u8]| {
    if let Ok(ck) = CellCheckpoint::decode(data, 0x5eed) {
        assert!(ck.sim.len() <= data.len());
        assert_eq!(
            ck.encode(),
            data,
            "what decodes re-encodes to the same bytes"
        );
    }
});
