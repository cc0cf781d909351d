//! Shadow volumes (RTR 7.3; Cournia 3.2): silhouettes from edge adjacency ([`silhouette`],
//! shared with the penumbra-volume techniques) extruded away from the light and counted in
//! the stencil ([`stencil`], the pass; [`shadow_volume`], the technique).

pub mod shadow_volume;
pub mod silhouette;
pub mod stencil;
