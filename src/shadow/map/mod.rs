//! Shadow maps (Williams 1978; RTR 7.4): a depth map from the light through the pipeline and
//! a depth comparison per camera pixel.
//!
//! The family's shared modules, which every map-based technique calls with its own options:
//! [`lookup`] (from a camera pixel to the maps, the reference depth with every bias, and the
//! comparisons and kernels), [`bias`] (normal offset, receiver plane), [`kernel`] (the PCF
//! kernels), [`planes`] (the min/max hierarchy) and [`plain`] (the plain map's pass, which
//! `shadow-map` and `contact-map` both run). The light's maps themselves are
//! [`crate::shadow::light`]'s. No technique here holds another.

pub mod bias;
pub mod cascaded;
pub mod chs;
pub mod kernel;
pub mod lispsm;
pub mod logpsm;
pub mod lookup;
pub mod multi_sample;
pub mod pcss;
pub mod plain;
pub mod planes;
pub mod psm;
pub mod sdsm;
pub mod shadow_map;
pub mod soft;
pub mod tsm;
pub mod warped;
