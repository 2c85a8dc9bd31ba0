//! Criterion benchmarks of the two_flux method (filled in with the method).
fn main() {}
