//! Exact hard shadows (RTR 7.9): the irregular z-buffer ([`izb`]), visibility computed at the
//! camera's own sample points from light-space lists and conservatively rasterized occluders.

pub mod izb;
