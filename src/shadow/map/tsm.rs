//! Trapezoidal shadow maps (Martin and Tan 2004; RTR 7.4.1): the camera frustum seen from a
//! directional light is enclosed in a trapezoid whose top lies at the near plane and whose
//! base lies at the far plane, and the trapezoid is mapped onto the square map by a
//! perspective transform, so texels are spent near the eye.
//!
//! The warp is [`crate::shadow::light::warp`]'s: the trapezoid's centre line is the view
//! direction projected onto the plane perpendicular to the light through the near plane's
//! centre, its apex `eta` before the top chosen by the paper's 80 % rule: the focus point
//! (`focus` of the view range past the near plane) lands on the line `xi = -0.6`, so the
//! region up to it takes 80 % of the map,
//! `eta = (lambda delta' + lambda delta' xi) / (lambda - 2 delta' - lambda xi)` (Martin and Tan
//! 2004, section 4; `lambda` the trapezoid's height, `delta'` the focus point's distance from
//! the top). Everything else is the plain shadow map's ([`super::plain`]).
//!
//! The paper computes the depth it stores in the light's unwarped space, against the
//! polygon-offset trouble of the warped depth; here the map stores the warped depth, which
//! is exact within a texel (the divide is the same along a light ray), and the pipeline's
//! slope-scaled offset follows the warped slopes.
//!
//! Known failures: dueling frusta (the light facing the camera: the trapezoid degenerates and
//! gains nothing over the orthographic map); a focus point beyond the 80 % line of the
//! trapezoid (a short view range seen from the side) leaves no warp (the map falls back to
//! the orthographic one and says so in `notes`); shadows crawl as the camera moves.
//! Directional lights only.

use super::warped::directional;
use crate::shadow::technique::{Entry, Family};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "tsm",
    family: Family::Map,
    summary: "trapezoidal shadow maps (Martin and Tan 2004): the view's trapezoid from the light mapped onto the map, the focus on the 80 % line; gains nothing when the light faces the camera",
    sweep: &[&[], &[("focus", "0.2")], &[("focus", "0.8")], &[("filter", "pcf2")]],
    extended: &[&[("size", "1024")], &[("focus", "0.05")], &[("filter", "poisson"), ("kernel", "7")]],
    applies: Some(directional),
    ..Entry::BASE
};

super::warped::warped_technique!(
    "TSM",
    "tsm",
    Tsm,
    tsm_fields,
    Tsm,
    tsm,
    "one warped view",
    "the focus at half the view range"
);
