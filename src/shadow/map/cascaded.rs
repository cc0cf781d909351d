//! Cascaded shadow maps and parallel-split shadow maps (RTR 7.4.1, eq. 7.5 and fig. 7.20;
//! Zhang et al. 2006; Dimitrov 2007; the Cesium slides): the camera's view range is split
//! into 1 to 8 slices, each gets its own orthographic map of a directional light fitted to
//! it, so that near the eye, where a single map fitted to the whole view is magnified, a
//! cascade spends its texels on a few metres.
//!
//! Everything but the cascades is the plain shadow map's ([`super::plain`]: the same map
//! pass, bias, filters and per-pixel lookup); the cascades are the light side's
//! ([`crate::shadow::light::cascades`]): splits uniform, logarithmic (RTR eq. 7.5,
//! `z_i = n (f / n)^(i / c)`) or practical (`lambda * log + (1 - lambda) * uniform`; PSSM's
//! 0.5 by default, the Cesium slides use 0.9), each cascade fitted to its slice (stable: its
//! bounding sphere on whole texels, `snap`; or tight: the slice's box) with the casters that
//! cannot reach it culled, selected per point by view depth or by map bounds behind the one
//! `locate`, and blended across a band at each split (linear, or an ordered dither at one
//! lookup per pixel).
//!
//! Known failures: seams at the splits where the texel size jumps (wide filters make them
//! visible; the blend band hides them); shimmering of tight fitting as the camera moves
//! (stable fitting keeps the grid); texels wasted by stable fitting (the sphere is larger than
//! the slice); the last cascade as coarse as a single map over a long view. Directional
//! lights only: cascades split a map along the view, and a spot or point light's map is
//! already perspective (a scene with another light is an error that says so).

use super::plain::{self, HoldsMapPass, MapPass};
use super::warped::directional;
use crate::shadow::light::cascades::Cascades;
use crate::shadow::light::MapOptions;
use crate::shadow::options::within;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "csm",
    family: Family::Map,
    summary: "cascaded / parallel-split shadow maps (RTR 7.4.1, Zhang et al. 2006): a map per slice of the view range; seams at the splits, texels wasted by stable fitting",
    sweep: &[
        &[],
        &[("cascades", "2"), ("size", "1448")],
        &[("split", "log")],
        &[("split", "uniform")],
        &[("snap", "true")],
        &[("blend", "dither")],
        &[("filter", "pcf2")],
    ],
    extended: &[
        &[("cascades", "8"), ("size", "724")],
        &[("cascades", "1"), ("size", "2048")],
        &[("lambda", "0.9")],
        &[("select", "bounds")],
        &[("band", "0")],
        &[("band", "0"), ("filter", "poisson"), ("kernel", "7")],
        &[("filter", "poisson"), ("kernel", "7")],
        &[("size", "2048")],
    ],
    applies: Some(directional),
    ..Entry::BASE
};

super::plain::map_pass_options!(
    "the cascaded shadow map",
    MapOptions::cascaded(1024, Cascades::default()),
    "The shadow map's options (map pass, bias, layer, filter), the cascades in `shadow.map.views` (`Views::Cascades`). Default: 4 cascades of 1024² texels (the texels of one 2048² map), practical splits with Zhang et al.'s lambda 0.5, selection by view depth, a linear blend over the last tenth of each cascade, tight fitting (`snap=false`, the paper's: on 12 of the 13 directional fixtures the stable sphere's wasted texels gave more wrong pixels; `snap=true` is the fix for shimmering), one comparison per pixel; the rest as `shadow-map`'s defaults."
);

/// The cascades inside `o`'s map pass.
fn cascades_of<O: HoldsMapPass>(o: &mut O) -> &mut Cascades {
    o.shadow().map.views.cascades_mut()
}

/// A cascaded technique's declaration: `shadow-map`'s fields but `fit` (cascades fit to their
/// slices), the cascades' ([`Cascades::fields`]) and `extra` ones.
pub fn cascaded_declaration<O: HoldsMapPass>(technique: &'static str, extra: Vec<Field<Cascades>>) -> Declaration<O> {
    let mut fields = plain::fields_within::<O>(&["fit"]);
    fields.extend(within(Cascades::fields().into_iter().chain(extra), cascades_of::<O>));
    Declaration { technique, fields }
}

/// The cascaded technique `d.technique` with `opts`: an option out of its range is an error,
/// and so are options without cascades.
pub fn build<O: HoldsMapPass>(d: Declaration<O>, mut opts: O) -> Result<PassTechnique<MapPass>, Error> {
    if opts.shadow().map.views.cascades().is_none() {
        return Err(d.error("cascades", "none", "must be set (1 to 8)"));
    }
    plain::build(&d, opts)
}

/// The option declaration: the shadow map's (but `fit`: cascades fit to their slices) and the
/// cascades'.
pub fn declaration() -> Declaration<Options> {
    cascaded_declaration("csm", Vec::new())
}

/// The cascaded shadow map (see the module docs): the plain map's pass over cascades, the
/// same type as [`super::shadow_map::ShadowMap`] (its `maps` are the cascades' maps, nearest
/// first), built by [`csm`].
pub type Csm = PassTechnique<MapPass>;

/// A cascaded shadow map with `opts`; an option out of its range is an error, and so are
/// options without cascades.
pub fn csm(opts: Options) -> Result<Csm, Error> {
    build(declaration(), opts)
}
