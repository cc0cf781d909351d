//! Volumetric shadows (RTR 7.8): transmittance through semi-transparent casters along each
//! light ray. [`avsm`]: adaptive volumetric shadow maps, a fixed number of nodes per texel
//! compressed as the fragments stream in through the pipeline's raster-ordered storage.

pub mod avsm;
