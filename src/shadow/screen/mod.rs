//! Shadows from data other than a shadow map alone (RTR 7.10): the camera's depth buffer
//! marched towards the light ([`march`]), alone ([`screen_space`]) or as the contact term of a
//! shadow map ([`contact`]); and the terrain's occlusion height ([`terrain`]), a heightfield of
//! the height above which the sun is visible.

pub mod contact;
pub mod march;
pub mod screen_space;
pub mod terrain;
