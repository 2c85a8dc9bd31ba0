//! The `.rxt` reader and the fit on arbitrary bytes: every input is rows or
//! a refusal, never a panic; the first rows of an accepted file are fitted
//! (each a result or a refusal naming the row), and every fitted value is
//! finite and inside its physical range.
#![no_main]

use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(rows) = km_inverse::rxt::parse_rxt(text) {
        common::fit_first_rows(&rows);
    }
});
