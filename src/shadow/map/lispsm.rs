//! Light space perspective shadow maps (Wimmer, Scherzer and Purgathofer 2004; RTR 7.4.1,
//! fig. 7.15): one map of a directional light, warped by a perspective frustum in light space
//! whose view direction is the camera's projected onto the plane perpendicular to the light,
//! so texels are spent near the eye instead of evenly over the view.
//!
//! The warp is [`crate::shadow::light::warp`]'s: the frustum's centre of projection lies under
//! the eye at `n_opt = (z_n + sqrt(z_n z_f)) / sin(gamma)` before the view's body (Wimmer et
//! al. 2004, section 5; `z_n`, `z_f` the view range clipped to the scene, `gamma` the angle
//! between view and light directions), scaled by the option `n_scale`. Everything else is
//! the plain shadow map's ([`super::plain`]: the pass, bias, filters and lookup).
//!
//! Known failures: dueling frusta (the light facing the camera: `sin(gamma)` small, `n_opt`
//! large, so the warp fades to the orthographic map and gains nothing); the far part of a
//! long view gets fewer texels than a uniform map would give it; the warp changes with the
//! camera, so the shadows' edges crawl as it moves; a light along the view direction has no
//! warp axis (the map falls back to the orthographic map of the view and says so in
//! `notes`). Directional lights only (a scene with another light is an error that says so).

use super::warped::directional;
use crate::shadow::technique::{Entry, Family};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "lispsm",
    family: Family::Map,
    summary: "light space perspective shadow maps (Wimmer et al. 2004): one map warped towards the eye by n_opt; gains nothing when the light faces the camera",
    sweep: &[
        &[],
        &[("n_scale", "0.5")],
        &[("n_scale", "4")],
        &[("size", "1024")],
        &[("filter", "pcf2")],
    ],
    extended: &[
        &[("n_scale", "0.25")],
        &[("n_scale", "100")],
        &[("filter", "poisson"), ("kernel", "7")],
        &[("size", "4096")],
    ],
    applies: Some(directional),
    ..Entry::BASE
};

super::warped::warped_technique!(
    "LiSPSM",
    "lispsm",
    Lispsm,
    lispsm_fields,
    Lispsm,
    lispsm,
    "one warped view",
    "the paper's `n_opt` (`n_scale=1`)"
);
