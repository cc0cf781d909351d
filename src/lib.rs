//! penumbra: a pure-CPU, deterministic software rasterizer with the GPU features real-time
//! shadow algorithms need, and (on it) the shadow algorithms themselves.
//!
//! - [`pipeline`]: the software GPU (tiled raster, depth, stencil, conservative raster,
//!   fragment lists, samplers, compute helpers).
//! - [`bench`]: the benchmark workloads (the "spheres" frame and random triangles).
//! - [`hash`]: stable hashing of outputs for golden tests.
#![warn(missing_docs)]

pub mod alloc;
pub mod bench;
pub mod hash;
pub mod image_io;
pub mod pipeline;
