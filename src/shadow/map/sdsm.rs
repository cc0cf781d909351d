//! Sample distribution shadow maps (Lauritzen, Salvi and Lefohn 2011; RTR 7.4.1): cascaded
//! shadow maps whose range and splits come from the depths the camera sees, found by a
//! parallel reduction of the depth buffer each frame, instead of from its near and far planes.
//!
//! The light side is [`crate::shadow::light::sdsm`] (the reduction and the histogram) and
//! [`crate::shadow::light::cascades`] (splits, fitting, selection, blending); everything else
//! is the plain map's ([`super::plain`]). `partition=minmax` splits the tight range (the
//! paper's log partitioning on tight bounds: a near wall or a distant scene gets every texel);
//! `partition=histogram` (the default) also fits each cascade to the part of its slice where
//! the histogram has samples, so gaps in the depth distribution cost no texels. `latency=1`
//! uses the previous frame's reduction, as engines that read it back late do.
//!
//! Known failures: with `latency=1`, a sudden view change (a cut, or turning from a near wall
//! to the horizon) leaves the new frame's far points beyond every cascade for one frame:
//! their shadows are lost; the range follows the view, so cascades move with every camera
//! move (shimmering, the cost of tight fitting); the reduction and histogram are a pass over
//! the depth buffer each frame. Directional lights only.

use super::cascaded::{build, cascaded_declaration, Csm};
use super::warped::directional;
use crate::shadow::light::cascades::{Cascades, Split};
use crate::shadow::light::sdsm::Partition;
use crate::shadow::light::MapOptions;
use crate::shadow::technique::{Declaration, Entry, Family};
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "sdsm",
    family: Family::Map,
    summary: "sample distribution shadow maps (Lauritzen et al. 2011): cascades over the depths the camera sees, by a reduction and a histogram; a frame late after a sudden view change with latency=1",
    sweep: &[
        &[],
        &[("partition", "minmax")],
        &[("split", "practical")],
        &[("latency", "1")],
        &[("filter", "pcf2")],
    ],
    extended: &[
        &[("cascades", "2"), ("size", "1448")],
        &[("partition", "view")],
        &[("snap", "true")],
        &[("blend", "dither")],
    ],
    applies: Some(directional),
    ..Entry::BASE
};

super::plain::map_pass_options!(
    "SDSM",
    MapOptions::cascaded(
        1024,
        Cascades {
            split: Split::Log,
            partition: Partition::Histogram,
            ..Cascades::default()
        },
    ),
    "CSM's options ([`super::cascaded::Options`]) with the depth reduction's (`partition`, `latency` in the cascades). Default: `csm`'s, but logarithmic splits of the reduced range (the paper's), each cascade fitted to where the histogram has samples, this frame's depths (`latency=0`)."
);

/// The option declaration: `csm`'s and SDSM's `partition` and `latency`.
pub fn declaration() -> Declaration<Options> {
    cascaded_declaration("sdsm", Cascades::sdsm_fields())
}

/// SDSM (see the module docs): the cascaded map's pass with the depths' partition, built by
/// [`sdsm`].
pub type Sdsm = Csm;

/// SDSM with `opts`; an option out of its range is an error, and so are options without
/// cascades.
pub fn sdsm(opts: Options) -> Result<Sdsm, Error> {
    build(declaration(), opts)
}
