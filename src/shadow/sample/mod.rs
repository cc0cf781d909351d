//! The sampling floor: from a camera pixel to a light's maps and back to a visibility, for
//! every family that reads a depth map (shadow maps, penumbra volumes, the hybrid, the
//! contact march).
//!
//! - [`lookup`]: a camera pixel to its map and texel through [`crate::shadow::light::locate`],
//!   the reference depth with every bias, and the per-pixel lookup each technique calls with
//!   its own options;
//! - [`bias`]: normal offset and receiver-plane depth bias;
//! - [`kernel`]: the comparisons and the PCF kernels (2x2 bilinear, grids, Poisson);
//! - [`planes`]: the min/max hierarchy (mip chains of the map's depth range).
//!
//! Each computes its value and its explanation for `inspect` in one loop over its taps,
//! generic over [`crate::shadow::inspect::Trace`]. Nothing here is a technique: `map/` and
//! the other families hold those.

pub mod bias;
pub mod kernel;
pub mod lookup;
pub mod planes;
#[cfg(all(test, feature = "files"))]
pub(crate) mod testing;
