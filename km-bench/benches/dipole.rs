//! Criterion benchmarks of the dipole method (filled in with the method).
fn main() {}
