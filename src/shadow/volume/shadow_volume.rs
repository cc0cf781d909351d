//! Stencil shadow volumes (Crow 1977; Heidmann z-pass; Carmack's reverse z-fail; RTR 7.3,
//! CS300, Cournia 3.2): silhouette edges from edge adjacency are extruded away from the light
//! to infinity (homogeneous w = 0), capped in front by the light-facing triangles and at
//! infinity by the same triangles projected away (geometry: [`super::silhouette`]); the camera
//! depth is the G-buffer's; the pipeline's two-sided stencil counts volume entries and exits
//! in one pass with wrapping increments. Count 0: lit.
//!
//! - z-pass (Heidmann): the stencil starts at the number of volumes containing the eye (a
//!   segment test from the eye to the light against the caps), then front faces increment and
//!   back faces decrement where the depth test passes. It is wrong where the near plane cuts a
//!   volume: pixels whose ray enters or leaves a volume between the eye and the near plane.
//! - z-fail (Carmack's reverse): counts where the depth test fails, back faces increment and
//!   front faces decrement; the caps close the volumes; the pipeline's depth clamp keeps the
//!   far plane from cutting them (`zfail`), or, as Everitt and Kilgard 2002, a projection with
//!   the far plane at infinity (`zfail-infinite`, with its own depth pre-pass).
//! - auto: z-pass when no caster can shadow the camera's near-plane rectangle (a conservative
//!   bounding-box test), z-fail otherwise.
//!
//! Known failures, each an option: `zpass` where the near plane cuts a volume, `zpass-naive`
//! (no eye count) whenever the eye is inside a volume, `zfail-noclamp` where the far plane cuts
//! a volume. The method's cost, the stencil fill, depends on the view (RTR 7.3): `counters`
//! reports it per frame, and camera paths chart it.

pub use super::stencil::zpass_is_safe;
pub use super::stencil::Mode;
use super::stencil::StencilVolumes;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "shadow-volume",
    family: Family::Volume,
    summary:
        "stencil shadow volumes, silhouettes by adjacency (RTR 7.3): exact; z-pass fails with the eye inside a volume",
    sweep: &[
        &[],
        &[("mode", "zfail")],
        &[("mode", "zfail-infinite")],
        &[("mode", "zpass")],
    ],
    ..Entry::BASE
};

/// Options of stencil shadow volumes.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// How the stencil counts volumes. Default: auto.
    pub mode: Mode,
}

impl Default for Options {
    fn default() -> Self {
        Options { mode: Mode::Auto }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new(
        "shadow-volume",
        vec![Field::new(
            "mode",
            "auto (z-pass unless a caster may put the near plane in shadow), zfail (capped, depth clamp), zfail-infinite (capped, infinite far plane projection and its own depth pre-pass), zpass (Heidmann, stencil starts at the eye's count), zpass-naive (starts at 0), or zfail-noclamp",
            |o: &mut Options| &mut o.mode,
        )],
    )
}

/// Stencil shadow volumes (see the module docs): the shared pass as a technique.
pub type ShadowVolume = PassTechnique<StencilVolumes>;

impl ShadowVolume {
    /// Shadow volumes with `opts`.
    pub fn new(opts: Options) -> Result<ShadowVolume, Error> {
        declaration().check(&opts)?;
        Ok(PassTechnique::with("shadow-volume", StencilVolumes::new(opts.mode)))
    }

    /// Whether the last run counted z-pass (auto mode chooses).
    pub fn chose_zpass(&self) -> bool {
        self.pass.chose_zpass()
    }
}
