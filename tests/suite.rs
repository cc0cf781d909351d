//! The integration tests, one module per file, in one binary: the library is linked (and
//! optimised across crates) once instead of once per file. `memory.rs` (a process-wide
//! budget), `determinism.rs` and the two golden-hash files (which `.ci/run` also runs on
//! aarch64 and baseline x86-64) are binaries of their own.

mod cascades;
mod common;
mod explore;
mod filtered;
mod fuzz;
mod hostile;
mod house;
mod random;
mod raster;
mod reference;
mod report;
mod samples;
mod screen;
mod shadows;
mod warps;
