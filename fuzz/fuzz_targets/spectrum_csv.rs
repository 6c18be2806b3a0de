//! Any bytes into the spectrum CSV reader: never a panic, and every spectrum it accepts is finite.
#![no_main]

use libfuzzer_sys::fuzz_target;
use metamer_core::spectrum::parse_spectrum_csv_bytes;

fuzz_target!(|data: &[u8]| {
    if let Ok(s) = parse_spectrum_csv_bytes(data) {
        assert!(s.is_finite());
    }
});
