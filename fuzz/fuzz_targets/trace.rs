//! The trace reader of `mbs digest --check`: any text is a trace of this
//! format whose checksum matches, or is refused with a message; never a
//! panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(trace) = mbs::tools::trace::parse(text) {
            assert!(!trace.records.is_empty() && trace.every > 0);
        }
    }
});
