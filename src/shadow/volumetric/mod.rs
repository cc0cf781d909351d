//! Volumetric shadows (RTR 7.8): transmittance through semi-transparent casters along each
//! light ray. [`transparency_map`]: the nearest transparent caster's colour beside the opaque
//! depth map (one layer). [`opacity_maps`]: optical depth in K slices, uniform (opacity
//! shadow maps) or from the first depth (deep opacity maps). [`deep_shadow_map`]: every fragment of a texel, sorted and compressed
//! within a tolerance. [`avsm`]: adaptive volumetric shadow maps, a fixed number of nodes
//! per texel compressed as the fragments stream in through the pipeline's raster-ordered
//! storage.

pub mod avsm;
pub mod deep_shadow_map;
pub mod opacity_maps;
pub mod transparency_map;
