//! Logarithmic perspective shadow maps (Lloyd, Govindaraju, Quammen, Molnar and Manocha
//! 2008; the Cesium slides' "perspective projection + logarithmic transformation"): LiSPSM's
//! light space, whose perspective makes the map's `u` follow the view's angle across it,
//! followed by a logarithm of the other axis, so each row covers the same ratio of
//! distances along the view and a texel's extent grows with the distance as the camera's
//! pixels do (the error is about constant over the view range instead of concentrated at
//! one end).
//!
//! The map: `u` is the perspective warp's (`x / z` from the centre of projection `P`), `v =
//! 1 - ln(w / n) / ln(f / n)` with `w` the distance from `P` along the warp axis over the
//! body's `n .. f` ([`crate::shadow::light::warp::LogRows`]), depth the warp's (the same
//! along each light ray, so a texel's comparison is exact). A GPU cannot rasterize that `v`;
//! this pipeline draws the map in the perspective warp's space, where triangles stay
//! triangles, at a table of sample rows placed where that space puts each row's distance
//! ([`crate::pipeline::samples`]: edge functions evaluated exactly at the warped samples,
//! watertight, with the same top-left rule). The polygon offset's slope term there is taken
//! per sample cell, so the slope-scaled bias follows the rows' spacing.
//!
//! `n`: LiSPSM's `n_opt` without its `sqrt(z_n z_f)` term, `z_n / sin(gamma)` (the
//! logarithm spreads the rows along the view in its place), `z_n` the nearest depth seen (the
//! depth reduction PSM and SDSM use); where the body lies wholly ahead of the eye and nearer
//! than that, the centre of projection sits at the eye, as Lloyd et al. place it (the across
//! axis's texels then follow the view's angle, the along axis's the distance). Times the
//! option `n_scale`. The rasterizer's 1/256-pixel grid bounds the log range: `n` is raised
//! until the farthest rows are 1/64 pixel apart in the rasterized space (`f / n` at most
//! about 380), and `notes` says so when it is.
//!
//! Known failures: the sun low behind the eye (the body reaches behind the eye, so the centre
//! of projection cannot sit at it, and the rows near the eye are `ln(f / n)` times coarser
//! than LiSPSM's: its 99th percentile footprint is worse; Lloyd et al. split the frustum into
//! faces there); dueling frusta (the light facing the camera: `sin(gamma)` small, `n`
//! large, the map tends to the uniform one, as every single-map warp does); the depth stored is the perspective warp's, so the
//! constant bias varies across the map; the map changes with the camera, so edges crawl as
//! it moves; the light along the view has no warp axis (the orthographic fall-back, said in
//! `notes`). Only the first and second depth layers (`layer=first|second`): the peeled and
//! id layers draw with the standard rasterizer. Directional lights only.

use super::warped::directional;
use crate::shadow::technique::{Entry, Family};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "logpsm",
    family: Family::Map,
    summary: "logarithmic perspective shadow maps (Lloyd et al. 2008): LiSPSM's warp with logarithmic rows, drawn by logarithmic rasterization at a sample table; gains nothing when the light faces the camera",
    sweep: &[&[], &[("n_scale", "4")], &[("filter", "pcf2")]],
    extended: &[
        &[("size", "1024")],
        &[("n_scale", "0.25")],
        &[("n_scale", "20")],
        &[("filter", "poisson"), ("kernel", "7")],
        &[("size", "4096")],
    ],
    applies: Some(directional),
    ..Entry::BASE
};

super::warped::warped_technique!(
    "LogPSM",
    "logpsm",
    Logpsm,
    logpsm_fields,
    Logpsm,
    logpsm,
    "one warped view with logarithmic rows",
    "`n_scale=1`"
);
