//! penumbra: a pure-CPU, deterministic software rasterizer with the GPU features real-time
//! shadow algorithms need, and (on it) the shadow algorithms themselves.
//!
//! - [`pipeline`]: the software GPU (tiled raster, depth, stencil, conservative raster,
//!   fragment lists, samplers, compute helpers).
//! - [`mod@bench`]: the benchmark workloads (the "spheres" frame and random triangles).
//! - [`hash`]: stable hashing of outputs for golden tests.
//!
//! ```
//! # fn main() -> Result<(), penumbra::pipeline::PipelineError> {
//! use glam::{Mat4, Vec3};
//! use penumbra::pipeline::*;
//!
//! let p = Pipeline::new(0)?; // 0 = one worker per core
//! let mut depth = Surface::new(512, 512, 1.0f32)?; // a shadow map
//! let tri = [Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0)];
//! let light = Mat4::orthographic_rh(-2.0, 2.0, -2.0, 2.0, 0.1, 10.0)
//!     * Mat4::look_at_rh(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, Vec3::Z);
//! let state = RenderState { offset: PolygonOffset { factor: 1.1, units: 4.0 }, ..Default::default() };
//! let stats = p.draw(&mut Targets::depth_only(&mut depth), &state, &tri, &[0, 1, 2], &TransformPositions(light), &DepthOnly)?;
//! assert!(stats.fragments_rasterized > 0);
//! # Ok(())
//! # }
//! ```
#![warn(missing_docs)]

pub mod alloc;
pub mod bench;
pub mod frame;
pub mod hash;
pub mod image_io;
pub mod metrics;
pub mod pipeline;
pub mod reference;
pub mod report;
pub mod run;
pub mod scene;
pub mod shadow;
pub mod visibility;
