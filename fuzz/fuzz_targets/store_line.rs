//! A line of the cell store (`cells.jsonl`): any bytes are a stored cell
//! whose checksum matches, or are ignored as torn or damaged; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = mbs::work::store::parse_line(data);
});
