//! Perspective shadow maps (Stamminger and Drettakis 2002; RTR 7.4.1): the shadow map of a
//! directional light rendered in the camera's post-perspective space, where the view
//! frustum is the unit cube and the near part of the view is large, so the map spends its
//! texels where the camera sees detail.
//!
//! The fit is [`crate::shadow::light::warp`]'s (its module docs, "Perspective shadow maps"):
//! the light becomes the point `C (-d, 0)` of that space (section 3), a point light ahead of
//! the viewer, an inverted one (depths reversed) behind it, a directional one across the view
//! (section 4); the map is the perspective from it fitted to the view between the nearest
//! and farthest depths the camera sees (a depth reduction, as the paper's near-plane push),
//! and one matrix takes world points to it, so the pass, bias, filters and lookup are the
//! plain shadow map's ([`super::plain`]).
//!
//! Casters behind the eye lie behind the camera's eye plane, where the projection wraps
//! around: they are clipped and their shadows lost. `shift=true` (default) moves the virtual
//! camera back until they are in front of it (Kozlov, GPU Gems ch. 14); its price is a
//! weaker warp (the near plane moves away with it), measured in the docs.
//!
//! Known failures: the light ahead of the viewer near the view axis (its post-perspective
//! position comes too close to the body for one frustum: the map falls back to the
//! orthographic one and says so in `notes`; the paper uses a cube map there); with
//! `shift=false`, a caster behind the eye casts no shadow; a long view range with a near
//! receiver warps so strongly that the far half gets few texels; the map changes with the
//! camera, so edges crawl as it moves; the stored depth is post-perspective, so the bias
//! varies across the map. Directional lights only.

use super::warped::directional;
use crate::shadow::technique::{Entry, Family};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "psm",
    family: Family::Map,
    summary: "perspective shadow maps (Stamminger and Drettakis 2002): the map in the camera's post-perspective space; casters behind the eye need the virtual camera moved back (shift); falls back near the view axis",
    sweep: &[&[], &[("shift", "false")], &[("filter", "pcf2")]],
    extended: &[&[("size", "1024")], &[("filter", "poisson"), ("kernel", "7")]],
    applies: Some(directional),
    ..Entry::BASE
};

super::warped::warped_technique!(
    "PSM",
    "psm",
    Psm,
    psm_fields,
    Psm,
    psm,
    "one post-perspective view",
    "the virtual camera moved back past the casters behind the eye (`shift=true`)"
);
