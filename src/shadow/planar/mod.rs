//! Planar and projective shadows (RTR 7.1-7.2): casters flattened onto planar receivers
//! ([`projected`]), and the occluders' mask projected from the light like a slide
//! ([`cookie`]).

pub mod cookie;
pub mod projected;
