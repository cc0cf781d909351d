//! Exact hard shadows (RTR 7.9): the irregular z-buffer ([`izb`]), visibility computed at the
//! camera's own sample points from light-space lists and conservatively rasterized occluders,
//! and its [`hybrid`] with PCSS (Story and Wyman 2016).

pub mod hybrid;
pub mod irregular;
pub mod izb;
