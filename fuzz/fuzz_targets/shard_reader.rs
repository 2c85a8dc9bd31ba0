//! The shard reader and merge on arbitrary bytes: a shard file is merged or
//! refused, never a panic or an allocation from an unchecked count.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(part) = km_montecarlo::parse_partial(text) {
        // Checked as it is, and resealed (so the content checks behind the
        // checksum are reached too).
        let _ = km_montecarlo::merge(std::slice::from_ref(&part));
        let _ = km_montecarlo::merge(&[part.seal()]);
    }
});
