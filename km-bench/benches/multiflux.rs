//! Criterion benchmarks of the multiflux method (filled in with the method).
fn main() {}
