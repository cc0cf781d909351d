//! Coloured transparency maps (RTR 7.8, its first paragraph; the usual extension of shadow
//! maps to coloured glass): beside the opaque casters' depth map, a second map of the
//! transparent casters stores the closest transparent depth and that surface's transmittance
//! colour. A receiver that passes the opaque map's test and fails the transparent depth test
//! takes the stored colour; one that fails the opaque test is in shadow; others are lit.
//!
//! Known failures, both measured on `stained_glass`:
//! - only the closest transparent layer counts: where panes overlap, the light behind both
//!   takes the nearer pane's colour instead of the product of both;
//! - transparent objects cannot be shadowed by transparent objects correctly: a pane behind
//!   another takes the front pane's colour, and a pane's own depth is the map's, so it is lit
//!   by its own colour map (the polygon offset keeps it from shadowing itself) — the panes
//!   themselves are where the error is.
//!
//! Both maps come from the shared light pass ([`crate::shadow::light`]); the colour map is a
//! colour target drawn with a depth test, so its colour is the nearest transparent surface's.

pub use super::PassOptions;
use super::{LightPass, PointLookup, Texel, Volumetric};
use crate::frame::Frame;
use crate::pipeline::*;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::light::{light_views, Casters, DepthPass, LightView, Payload, ViewMaps};
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Stage};
use crate::Error;
use glam::{Vec3, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "transparency-map",
    summary: "coloured transparency map (RTR 7.8): opaque depth map plus the nearest transparent surface's depth and colour; one layer only, transparent receivers wrong",
    sweep: &[&[], &[("size", "512")]],
    ..super::BASE
};

/// Options of the coloured transparency map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The light pass: map side, polygon offset. Default: 1024 texels, the shadow map's
    /// offset (4 units, slope 1.1).
    pub pass: PassOptions,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            pass: PassOptions::sized(1024),
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    super::declaration("transparency-map", |o: &mut Options| &mut o.pass, Vec::new())
}

/// One light view's maps: opaque depth, transparent depth, transparent colour.
struct Maps {
    opaque: Surface<f32>,
    depth: Surface<f32>,
    colour: Surface<Vec4>,
}

/// The light pass of the coloured transparency map: both maps per light view.
pub struct TransparencyPass {
    opts: Options,
    maps: ViewMaps<Maps>,
}

/// The coloured transparency map (see the module docs).
pub type TransparencyMap = PassTechnique<Volumetric<TransparencyPass>>;

impl TransparencyMap {
    /// A transparency map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<TransparencyMap, Error> {
        declaration().check(&opts)?;
        Ok(Volumetric::technique(
            "transparency-map",
            TransparencyPass {
                opts,
                maps: ViewMaps::default(),
            },
        ))
    }
}

impl PointLookup for TransparencyPass {
    /// The transmittance at world point `p` (the per-pixel pass, and `inspect` with a
    /// recording trace): both maps read at the point's texel, every step reported to `t`.
    fn transmittance(&self, frame: &Frame, p: Vec3, t: &mut impl Trace) -> Vec3 {
        let Some((m, at)) = Texel::of(&self.maps, frame, p, self.opts.pass.size, t) else {
            return Vec3::ONE;
        };
        let (tx, ty) = (at.x, at.y);
        let z = at.depth.clamp(0.0, 1.0);
        let (od, td, c) = (m.opaque.at(tx, ty), m.depth.at(tx, ty), m.colour.at(tx, ty).truncate());
        t.step(|| at.step("the texel both maps are read at, and the point's depth", z));
        t.step(|| {
            Step::new(
                "opaque map",
                "the nearest opaque caster's depth (with polygon offset): shadowed if the point is behind it",
            )
            .num("stored depth", od)
            .flag("behind it", z > od)
        });
        if z > od {
            return Vec3::ZERO;
        }
        t.step(|| {
            Step::new(
                "transparent map",
                "the nearest transparent caster's depth and colour: behind it, the point takes the colour (one layer only)",
            )
            .num("stored depth", td)
            .vec3("stored colour", c)
            .flag("behind it", z > td)
        });
        if z > td {
            c
        } else {
            Vec3::ONE
        }
    }
}

/// The light pass's payload: per view, the opaque casters' depth and the nearest
/// transparent surface's depth and colour.
struct Layers<'a> {
    pass: DepthPass,
    opaque: &'a Casters,
    glass: &'a Casters,
    /// Per transparent triangle: its colour.
    colours: &'a [Vec4],
}

impl Payload for Layers<'_> {
    type Map = Maps;

    fn what(&self) -> &'static str {
        "the transparency maps"
    }

    fn draw(&mut self, p: &Pipeline, _: usize, view: &LightView, _: Option<Maps>) -> Result<Maps, Error> {
        let size = self.pass.size;
        let opaque = self.pass.render(p, self.opaque, view, CullMode::None, None, None)?;
        // The nearest transparent surface: its depth and, by the depth test, its colour.
        let mut depth = Surface::new(size, size, 1.0f32)?;
        let mut colour = Surface::new(size, size, Vec4::ONE)?;
        let colours = self.colours;
        let fs = Shader(|f: &Fragment<()>| colours[f.prim as usize]);
        p.draw(
            &mut Targets::color(&mut colour).with_depth(&mut depth),
            &RenderState {
                offset: self.pass.offset,
                shading: Shading::Immediate,
                ..Default::default()
            },
            &self.glass.positions,
            &self.glass.indices,
            &TransformPositions(view.matrix),
            &fs,
        )?;
        Ok(Maps { opaque, depth, colour })
    }
}

impl LightPass for TransparencyPass {
    fn render(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error> {
        let o = self.opts.clone();
        let scene = frame.scene;
        let (opaque, glass) = super::opaque_and_transparent(frame)?;
        let colours: Vec<Vec4> = super::transmittances(scene, &glass)
            .iter()
            .map(|t| t.extend(1.0))
            .collect();
        let mut payload = Layers {
            pass: o.pass.depth(),
            opaque: &opaque,
            glass: &glass,
            colours: &colours,
        };
        self.maps
            .render(p, light_views(frame, o.pass.size), o.pass.size, &mut payload)
    }

    fn ran(&self) -> bool {
        !self.maps.is_empty()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let texels: usize = self.maps.maps().iter().map(|(m, _)| m.opaque.data().len()).sum();
        // Per texel: opaque depth, transparent depth, RGB colour (as a GPU would store it:
        // 4 + 4 + 4 bytes; ours keeps RGBA f32).
        vec![("light-space bytes", (texels * 12) as f64)]
    }

    fn stages(&self) -> Result<Vec<Stage>, Error> {
        let mut v = Vec::new();
        for (i, (m, _)) in self.maps.maps().iter().enumerate() {
            v.push(Stage::unit(format!("opaque_depth{i}"), m.opaque.clone()));
            v.push(Stage::unit(format!("transparent_depth{i}"), m.depth.clone()));
            v.push(Stage::Color {
                name: format!("transparent_colour{i}"),
                data: m
                    .colour
                    .map(|c| <Rgba8 as ColorFormat>::from_vec4(c.truncate().extend(1.0))),
            });
        }
        Ok(v)
    }
}
