//! What the warped maps ([`super::lispsm`], [`super::tsm`]) share: their options are the
//! plain shadow map's with a [`Warp`] in the map pass, declared as `shadow-map`'s fields but
//! `fit` and `snap` (a warp fits the camera's view) plus the warp's own, and they are the
//! plain map's pass over the one warped view ([`crate::shadow::light::warp`]).

use super::plain::{self, HoldsMapPass, MapPass};
use crate::scene::{Light, LightKind, Scene};
use crate::shadow::light::warp::Warp;
use crate::shadow::options::within;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Field};
use crate::Error;

/// The warp inside `o`'s map pass.
fn warp_of<O: HoldsMapPass>(o: &mut O) -> &mut Warp {
    o.shadow().map.views.warp_mut()
}

/// A warped technique's declaration: `shadow-map`'s fields but `fit` and `snap`, and the
/// warp's `fields`.
pub fn declaration<O: HoldsMapPass>(technique: &'static str, fields: Vec<Field<Warp>>) -> Declaration<O> {
    let mut all = plain::fields_within::<O>(&["fit", "snap"]);
    all.extend(within(fields, warp_of::<O>));
    Declaration::new(technique, all)
}

/// Whether `light` is directional (the only kind warps and cascades take).
pub fn directional(_scene: &Scene, light: &Light) -> bool {
    light.kind == LightKind::Directional
}

/// The warped technique `d.technique` with `opts`: an option out of its range is an error,
/// and so are options without a warp.
pub fn build<O: HoldsMapPass>(d: Declaration<O>, mut opts: O) -> Result<PassTechnique<MapPass>, Error> {
    if opts.shadow().map.views.warp().is_none() {
        return Err(d.error("warp", "none", "must be set"));
    }
    plain::build(&d, opts)
}
