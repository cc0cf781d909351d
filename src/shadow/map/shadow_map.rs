//! Shadow maps (Williams 1978; RTR 7.4; Cournia 3.1): depth from the light through the
//! pipeline, then a depth comparison per camera pixel. Directional lights get an orthographic
//! map, spot lights a perspective map of their cone, point and area lights (their centre) a
//! cube map of six 90-degree faces, looked up per pixel by the face its direction selects.
//!
//! Options combine: depth format (16/24/32 bit); constant and slope-scaled bias (the
//! pipeline's polygon offset); normal-offset bias (Holbert 2011: the lookup point moves along
//! the normal by `k * texel size * sin(angle to the light)`); receiver-plane depth bias
//! (Isidoro 2006: the receiver's depth slope in shadow-map texels, from its screen-space
//! derivatives); which layer is stored (`first`; `second`, back faces only, Wang and Molnar
//! 1994; `midpoint`, the average of the two nearest layers, Woo 1992, by depth peeling; `id`,
//! object ids instead of depth, Cournia 3.1.2); fitting of a directional light's frustum to
//! the casters that can shadow visible receivers, with other casters culled (RTR fig. 7.11);
//! and texel snapping so camera motion does not move the sampling grid; and the lookup's
//! filter: one comparison, 2x2 hardware PCF, or a wide PCF kernel of [`crate::shadow::sample::kernel`] (grid,
//! tent, Poisson, rotated Poisson, spiral; width in texels or world units; receiver-plane
//! depth and bias cone across the kernel; a hierarchy of the map, [`crate::shadow::sample::planes`], to skip
//! the taps of kernels fully lit or shadowed), or the depths filtered before one comparison,
//! the wrong order.
//!
//! Known failures: acne without bias, Peter Panning with too much, aliasing where the map is
//! magnified, shimmering of fitted maps without snapping, light leaks of second-depth maps on
//! open (two-sided) geometry, self-shadowing lost by id maps, acne of wide kernels without bias
//! across the kernel, uniform penumbrae of fixed-width PCF.

use super::plain::{beyond_ranges, MapPass};
pub use super::plain::{declaration, Filter, FitTo, Layer, Options};
use crate::pipeline::Surface;
use crate::shadow::light::LightView;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Entry, Family};
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "shadow-map",
    family: Family::Map,
    summary: "depth map from the light, one comparison per pixel (RTR 7.4): acne, Peter Panning, aliasing, shimmering",
    sweep: &[
        &[("size", "256")],
        &[("size", "512")],
        &[("size", "2048")],
        &[("units", "0"), ("slope", "0")],
        &[("units", "100000")],
        &[("units", "0"), ("slope", "0"), ("normal", "1.5")],
        &[("units", "0"), ("slope", "0"), ("receiver", "true")],
        &[("layer", "second"), ("units", "0"), ("slope", "0")],
        &[("layer", "midpoint"), ("units", "0"), ("slope", "0")],
        &[("layer", "id")],
        &[("fit", "receivers"), ("snap", "true")],
        &[("filter", "pcf2")],
        &[("filter", "depth-bilinear")],
        &[("filter", "grid")],
        &[("filter", "tent")],
        &[("filter", "poisson")],
        &[("filter", "rotated")],
        &[("filter", "spiral")],
    ],
    extended: &[
        &[("size", "1024")],
        &[("size", "4096")],
        &[("format", "u16")],
        &[("filter", "grid"), ("kernel", "9"), ("cone", "2")],
        &[("format", "u24")],
        &[("fit", "receivers")],
        &[("filter", "grid"), ("hierarchy", "true")],
        &[("filter", "grid"), ("kernel", "9")],
        &[
            ("filter", "grid"),
            ("kernel", "9"),
            ("receiver", "true"),
            ("units", "0"),
            ("slope", "0"),
        ],
        &[("filter", "poisson"), ("taps", "64")],
        &[("filter", "poisson"), ("world", "0.1")],
    ],
    ..Entry::BASE
};

/// The shadow-map technique (see the module docs): the plain map's pass.
pub type ShadowMap = PassTechnique<MapPass>;

impl ShadowMap {
    /// A shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<ShadowMap, Error> {
        declaration().check(&opts)?;
        if let Some((key, value, message)) = beyond_ranges(&opts) {
            return Err(declaration().error(key, &value, message));
        }
        Ok(PassTechnique::with("shadow-map", MapPass::new(opts)))
    }

    /// Casters culled by fitting in the last run.
    pub fn culled(&self) -> usize {
        self.pass().culled()
    }

    /// Texels of the last run's maps, all views.
    pub fn texels(&self) -> usize {
        self.pass().texels()
    }

    /// The maps of the last run, one per light view (six for point lights).
    pub fn maps(&self) -> &[(Surface<f32>, LightView)] {
        self.pass().maps()
    }
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;
    use crate::pipeline::Pipeline;
    use crate::shadow::inspect::NoTrace;
    use crate::shadow::light::MapOptions;
    use crate::shadow::technique::ShadowTechnique;

    #[test]
    fn fitting_culls_casters_that_cannot_shadow_visible_receivers() {
        // A box far to the side of the view casts nowhere the camera looks: culled.
        let text = "[camera]\nposition = [0, 3, 6]\ntarget = [0, 0, 0]\nresolution = [64, 48]\n\n[[light]]\ntype = \"directional\"\ndirection = [0.2, -1, 0.1]\n\n[[object]]\nmesh = \"plane\"\nsize = 8\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [0, 0.5, 0]\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [60, 0.5, 0]\n";
        let scene = crate::scene::file::parse(text, std::path::Path::new("t.toml")).unwrap();
        let p = Pipeline::new(2).unwrap();
        let f = crate::frame::frame(&p, &scene, 0, 0).unwrap();
        let mut sm = ShadowMap::new(Options {
            map: MapOptions {
                size: 256,
                fit: FitTo::Receivers,
                ..Default::default()
            },
            ..Default::default()
        })
        .unwrap();
        sm.visibility(&p, &f).unwrap();
        assert_eq!(sm.culled(), 1);
    }

    /// `inspect`'s lookup is the image at every pixel of every fixture
    /// ([`crate::shadow::sample::testing::assert_lookups_on_fixtures`]).
    #[test]
    #[cfg(feature = "files")]
    fn the_image_is_the_traced_lookup_on_every_fixture() {
        crate::shadow::sample::testing::assert_lookups_on_fixtures(
            &ENTRY,
            declaration,
            ShadowMap::new,
            |t, f, x, y| t.pass().lookup(f, x, y, &mut NoTrace).0,
        );
    }

    #[test]
    fn four_pixel_lookups_equal_one_pixel_ones() {
        use crate::shadow::sample::testing::assert_lookups;
        // The hierarchy's sets take the row pass (mixed pixels queued into full lane groups).
        let sets: [&[(&str, &str)]; 11] = [
            &[("filter", "grid"), ("kernel", "5")],
            &[("filter", "tent"), ("kernel", "5"), ("cone", "0.5"), ("size", "256")],
            &[("filter", "tent"), ("kernel", "3"), ("size", "128")],
            &[("filter", "grid"), ("kernel", "17")],
            &[("filter", "grid"), ("kernel", "3"), ("receiver", "true")],
            &[("filter", "poisson"), ("kernel", "6"), ("cone", "1")],
            &[("filter", "rotated"), ("world", "0.05")],
            &[("filter", "spiral"), ("taps", "9"), ("hierarchy", "true")],
            &[("filter", "grid"), ("receiver", "true"), ("hierarchy", "true")],
            &[
                ("filter", "rotated"),
                ("kernel", "4"),
                ("receiver", "true"),
                ("hierarchy", "true"),
            ],
            &[("filter", "pcf2")],
        ];
        assert_lookups(
            &sets,
            |pairs| ShadowMap::new(declaration().parse(pairs).unwrap()).unwrap(),
            |t, f, x, y| t.pass().lookup(f, x, y, &mut NoTrace),
            |_, _, _, _, _| {},
            |t| t.pass().taps,
        );
    }

    #[test]
    fn the_library_constructor_checks_ranges() {
        let e = ShadowMap::new(Options {
            map: MapOptions {
                size: 0,
                ..Default::default()
            },
            ..Default::default()
        })
        .err()
        .unwrap();
        assert_eq!(
            e.to_string(),
            "technique 'shadow-map': option size=0 is outside [16, 16384]"
        );
    }
}
