//! Shadow maps (Williams 1978; RTR 7.4): a depth map from the light through the pipeline and
//! a depth comparison per camera pixel.
//!
//! Every map technique calls the sampling floor ([`crate::shadow::sample`]: lookup, biases,
//! kernels, the min/max hierarchy) with its own options. Two passes here are shared with
//! other families: [`plain`] (the plain map's pass, which `shadow-map`, the warps and
//! `contact-map` run) and [`soft`] (PCSS's pass, which the hybrid runs). The light's maps
//! themselves are [`crate::shadow::light`]'s. No technique here holds another.

pub mod cascaded;
pub mod chs;
pub mod lispsm;
pub mod logpsm;
pub mod multi_sample;
pub mod pcss;
pub mod plain;
pub mod psm;
pub mod sdsm;
pub mod shadow_map;
pub mod soft;
pub mod tsm;
pub mod warped;
