//! The radiance inside a stack at depths and directions: the answer's type
//! (km-core's, so that a solve's [`km_core::DepthOutput`] carries it), made
//! by the multi-flux route ([`crate::field`]) and the Monte Carlo one
//! ([`crate::mc_field::mc_inside`]) alike (docs/field.md §2a, §4a).

pub use km_core::solution::InsideField;
