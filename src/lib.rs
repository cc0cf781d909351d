//! penumbra: a pure-CPU, deterministic software rasterizer with the GPU features real-time
//! shadow algorithms need, and (on it) the shadow algorithms themselves, each measured against
//! a ray-traced ground truth.
//!
//! # Data flow
//!
//! ```text
//! scene file (TOML, OBJ, glTF) --scene--> Scene { objects, materials, camera, lights, path }
//!     |
//!     +--frame--> camera pass through the pipeline: G-buffer (depth, position, normal, object)
//!     |               |                                     |
//!     |               v                                     v
//!     |     shadow technique (penumbra::create):   reference ray tracer (reference):
//!     |     light-space passes through the         exact hard or area-light visibility
//!     |     pipeline -> Visibility                 -> Visibility
//!     |               |                                     |
//!     |               +-------------> metrics <-------------+   (RMSE, wrong %, penumbra RMSE)
//!     v               v
//!   frame::shade -> image      run (timing, camera paths) -> report (CSV, charts, HTML)
//! ```
//!
//! - [`pipeline`]: the software GPU (tiled raster, depth, stencil, conservative raster,
//!   fragment lists, samplers, compute helpers). It knows nothing of scenes or shadows.
//! - [`scene`]: scene data and its files ([`scene::file`] for TOML, [`scene::gltf`] for glTF).
//! - [`frame`]: the camera's G-buffer pass and shading.
//! - [`shadow`]: every technique, by family, behind one trait ([`shadow::ShadowTechnique`]);
//!   [`shadow::registry`] lists them with their options.
//! - [`mod@reference`]: the ray tracer, independent of the pipeline; [`metrics`]: errors against it.
//! - [`run`]: timing and camera paths; [`report`]: the files a sweep writes.
//! - [`mod@bench`]: the benchmark workloads (the "spheres" frame and random triangles).
//! - [`hash`]: stable hashing of outputs for golden tests.
//!
//! # A scene, a technique and its error
//!
//! ```
//! # fn main() -> Result<(), penumbra::Error> {
//! use penumbra::pipeline::Pipeline;
//! use penumbra::reference::{Reference, ReferenceOptions};
//! use penumbra::{frame, metrics, scene, shadow};
//!
//! let text = "# a box on a plane\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\nresolution = [64, 48]\n\
//!             [[light]]\ntype = \"directional\"\ndirection = [0.3, -1, 0.2]\n\
//!             [[object]]\nmesh = \"plane\"\nsize = 4\n\
//!             [[object]]\nmesh = \"box\"\ntranslate = [0, 0.5, 0]\n";
//! let s = scene::file::parse(text, std::path::Path::new("box.toml"))?;
//! let p = Pipeline::new(2)?;
//! let f = frame::frame(&p, &s, 0, 0)?; // the camera's G-buffer for light 0, frame 0
//! let mut t = shadow::registry::create("shadow-volume", &[])?; // or "pcss", "izb", with ("key", "value") options
//! let v = t.visibility(&p, &f)?;
//! let r = Reference::new(&s).visibility(f.points(), f.width() as usize, &f.light, &ReferenceOptions::default());
//! let e = metrics::compare(&v, &r, &f.metric_mask());
//! assert!(e.wrong_pct < 0.5, "shadow volumes are exact: {e:?}");
//! let _picture = frame::shade(&f, &v); // an RGBA8 surface, for image_io::write_png
//! # Ok(())
//! # }
//! ```
//!
//! # The pipeline alone
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
//!
//! Runnable programs are in `examples/`: `render_scene`, `draw_triangles`, `technique_stages`.
#![warn(missing_docs)]

#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod alloc;
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod bench;
#[cfg(feature = "cli")]
pub mod choose;
pub mod error;
pub mod frame;
pub mod hash;
#[cfg(feature = "images")]
pub mod image_io;
pub mod math;
pub mod metrics;
pub mod output;
pub mod pipeline;
pub mod progress;
pub mod reference;
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod report;
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod run;
pub mod scene;
pub mod shadow;
pub mod visibility;

pub use error::{Error, Resource};
pub use frame::Frame;
pub use pipeline::{Pipeline, PipelineError};
pub use reference::{Reference, ReferenceOptions};
pub use scene::Scene;
pub use shadow::registry::{create, registry};
pub use shadow::ShadowTechnique;
pub use visibility::Visibility;

pub use shadow::registry::techniques;
