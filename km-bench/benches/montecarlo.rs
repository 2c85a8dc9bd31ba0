//! Criterion benchmarks of the montecarlo method (filled in with the method).
fn main() {}
