//! Library side of the `km` command: the accuracy-target drivers shared by
//! the binary and its tests.
#![deny(missing_docs)]

pub mod tolerance;
