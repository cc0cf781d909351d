//! What the warped maps ([`super::lispsm`], [`super::logpsm`], [`super::psm`],
//! [`super::tsm`]) share: their options are the
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

/// A warped technique's items: its `Options` (the plain map's, with the map pass warped by
/// `WarpKind::$kind`; `$defaults` says the warp's defaults), its `declaration()` (the plain
/// map's fields but `fit` and `snap`, and `Warp::$fields()`), the technique's type `$ty` (the
/// plain map's pass over `$view`) and its constructor `$ctor`.
macro_rules! warped_technique {
    ($title:literal, $name:literal, $kind:ident, $fields:ident, $ty:ident, $ctor:ident, $view:literal, $defaults:literal) => {
        $crate::shadow::map::plain::map_pass_options!(
            $title,
            $crate::shadow::light::MapOptions::warped($crate::shadow::light::warp::WarpKind::$kind),
            concat!(
                "The shadow map's options (map pass, bias, layer, filter), the warp in `shadow.map.views` (`Views::Warp`). Default: one 2048² map, ",
                $defaults,
                "; the rest as `shadow-map`'s defaults."
            )
        );

        #[doc = concat!("The option declaration: the shadow map's (but `fit` and `snap`: the warp fits the view) and `Warp::", stringify!($fields), "`.")]
        pub fn declaration() -> $crate::shadow::technique::Declaration<Options> {
            $crate::shadow::map::warped::declaration($name, $crate::shadow::light::warp::Warp::$fields())
        }

        #[doc = concat!($title, " (see the module docs): the plain map's pass over ", $view, ", built by [`", stringify!($ctor), "`].")]
        pub type $ty = $crate::shadow::pass::PassTechnique<$crate::shadow::map::plain::MapPass>;

        #[doc = concat!($title, " with `opts`; an option out of its range is an error.")]
        pub fn $ctor(opts: Options) -> Result<$ty, $crate::Error> {
            $crate::shadow::map::warped::build(declaration(), opts)
        }
    };
}
pub(crate) use warped_technique;
