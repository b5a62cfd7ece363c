//! A line of the cell store (`cells.jsonl`): any bytes are a stored cell
//! whose checksum matches, or are ignored as torn or damaged; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Some((key, value)) = mbs::store::parse_line(data) {
        assert!(key.len() + value.to_string().len() <= data.len());
    }
});
