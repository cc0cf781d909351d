//! Shadow maps (Williams 1978; RTR 7.4): a depth map from the light through the pipeline and
//! a depth comparison per camera pixel, with the bias terms ([`bias`]) that the rest of the
//! family (filtering, resolution) shares.

pub mod bias;
pub mod chs;
pub mod kernel;
pub mod multi_sample;
pub mod pcss;
pub mod planes;
pub mod shadow_map;
