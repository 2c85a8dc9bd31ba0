//! The CSV reader of `km fit` and the fit on arbitrary bytes: every input is
//! rows or a refusal, never a panic; the first rows of an accepted file are
//! fitted, each a result or a refusal, every fitted value finite and in range.
#![no_main]

use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // The set-up `km fit FILE.csv --thickness 1 --n-sample 1.4` builds.
    let Ok(sample) = km_inverse::forward::Sample::new(1.0, 1.4, None) else {
        return;
    };
    let setup = km_inverse::slab::Setup::new(sample);
    if let Ok(rows) = km_inverse::rxt::parse_csv(text, &setup) {
        common::fit_first_rows(&rows);
    }
});
