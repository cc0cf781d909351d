//! The irregular z-buffer (Johnson et al. 2005; Aila and Laine 2004; RTR 7.9), the technique:
//! its options, their declaration and the registry entry. The samples, their lists, the
//! conservative occluder pass and the resolve are [`super::irregular`]'s, which the hybrid
//! shares; its module docs give the method and its known failure (long lists).

use super::irregular::IrregularZBuffer;
pub use super::irregular::{
    camera_samples, camera_samples_grid, CameraSample, OccluderRaster, Options, SamplesPerPixel,
};
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "izb",
    family: Family::Exact,
    summary: "irregular z-buffer (RTR 7.9): camera samples in light-space lists, occluders conservatively rasterized and tested exactly; long lists at grazing views",
    sweep: &[
        &[],
        &[("size", "256")],
        &[("raster", "standard")],
        &[("samples", "4")],
    ],
    ..Entry::BASE
};

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new(
        "izb",
        vec![
            Field::size(
                "light-space grid side in texels (per cube face for point lights)",
                |o: &mut Options| &mut o.size,
            ),
            Field::new(
                "samples",
                "samples per pixel: 1 (the G-buffer's point), 4, 16 or 32 (anti-aliased hard shadows)",
                |o: &mut Options| &mut o.samples,
            ),
            Field::new(
                "raster",
                "occluder rasterization: conservative (exact) or standard (thin occluders' shadows break)",
                |o: &mut Options| &mut o.raster,
            ),
            Field::range(
                "capacity",
                "most samples the lists may hold (a frame with more is an error)",
                1,
                1 << 28,
                |o: &mut Options| &mut o.capacity,
            ),
        ],
    )
}

/// The irregular z-buffer (see the module docs): the shared pass as a technique.
pub type Izb = PassTechnique<IrregularZBuffer>;

impl Izb {
    /// An irregular z-buffer with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Izb, Error> {
        declaration().check(&opts)?;
        Ok(PassTechnique::with("izb", IrregularZBuffer::new(opts)))
    }

    /// The options.
    pub fn options(&self) -> &Options {
        self.pass.options()
    }

    /// Visibility of every camera sample of the last run (0 for samples facing away), in the
    /// order of [`camera_samples`].
    pub fn sample_visibility(&self) -> Vec<f32> {
        self.pass.sample_visibility()
    }
}
