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
//! `n`: where the two axes' worst texel-to-pixel ratios are equal (Lloyd et al.'s error
//! measure): the across axis's ratio grows to `n / z_n` at the near plane, the logarithmic
//! axis's is about `ln(1 + depth / n) / (2 tan(theta))` everywhere
//! ([`crate::shadow::light::warp::LogRows::balanced_n`]), divided by `sin(gamma)` as
//! LiSPSM's `n_opt` is (the warp fades as the light turns towards the view), times the
//! option `n_scale`. The rasterizer's 1/256-pixel grid bounds the log range: `n` is raised
//! until the farthest rows are 1/64 pixel apart in the rasterized space (`f / n` at most
//! about 380), and `notes` says so when it is.
//!
//! Known failures: dueling frusta (the light facing the camera: `sin(gamma)` small, `n`
//! large, the map tends to the uniform one, as every single-map warp does; Lloyd et al.
//! split the frustum into faces there); the depth stored is the perspective warp's, so the
//! constant bias varies across the map; the map changes with the camera, so edges crawl as
//! it moves; the light along the view has no warp axis (the orthographic fall-back, said in
//! `notes`). Only the first and second depth layers (`layer=first|second`): the peeled and
//! id layers draw with the standard rasterizer. Directional lights only.

use super::plain::MapPass;
use super::warped::{build, declaration as warped_declaration, directional};
use crate::shadow::light::warp::{Warp, WarpKind};
use crate::shadow::pass::PassTechnique;
use crate::shadow::{Declaration, Family, TechniqueInfo};
use crate::Error;

super::warped::warped_options!(
    "LogPSM",
    WarpKind::Logpsm,
    "The shadow map's options (map pass, bias, layer, filter), the warp in `shadow.map.warp`. Default: one 2048² map, the balanced `n` (`n_scale=1`); the rest as `shadow-map`'s defaults."
);

/// The option declaration: the shadow map's (but `fit` and `snap`: the warp fits the view)
/// and `n_scale`.
pub fn declaration() -> Declaration<Options> {
    warped_declaration("logpsm", Warp::logpsm_fields())
}

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "logpsm",
        family: Family::Map,
        summary: "logarithmic perspective shadow maps (Lloyd et al. 2008): LiSPSM's warp with logarithmic rows, drawn by logarithmic rasterization at a sample table; gains nothing when the light faces the camera",
        options: declaration().infos(),
        sweep: &[
            &[],
            &[("n_scale", "4")],
            &[("size", "1024")],
            &[("filter", "pcf2")],
        ],
        extended: &[
            &[("n_scale", "0.25")],
            &[("n_scale", "20")],
            &[("filter", "poisson"), ("kernel", "7")],
            &[("size", "4096")],
        ],
        create: |pairs| Ok(Box::new(logpsm(declaration().parse(pairs)?)?)),
        applies: Some(directional),
        models: &[],
    }
}

/// LogPSM (see the module docs): the plain map's pass over one warped view with logarithmic
/// rows, built by [`logpsm`].
pub type Logpsm = PassTechnique<MapPass>;

/// LogPSM with `opts`; an option out of its range is an error.
pub fn logpsm(opts: Options) -> Result<Logpsm, Error> {
    build(declaration(), opts)
}
