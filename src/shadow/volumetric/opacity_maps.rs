//! Opacity shadow maps (Kim and Neumann 2001) and deep opacity maps (Yuksel and Keyser 2008;
//! RTR 7.8): the transparent casters' optical depth accumulated in `K` slices along the light's
//! depth, transmittance `exp(-sigma)` interpolated between the slices' boundaries.
//!
//! - Each transparent fragment of transmittance `t` adds its optical depth `-ln t` (per
//!   channel) to the slice its depth falls in, by additive blending into one target per slice
//!   (`K` draws through the pipeline, each keeping only its slice's fragments); a prefix sum
//!   over the slices gives `sigma` at every boundary, and a receiver at depth `z` between two
//!   boundaries takes the linear interpolation (Kim and Neumann's reconstruction).
//! - `slices=uniform` (opacity shadow maps): boundaries at fixed, uniform depths across the
//!   light-space depth range of the transparent casters.
//! - `slices=deep` (deep opacity maps): each texel's first boundary is the depth of its nearest
//!   transparent surface (a first-depth pass), and the slices follow the casters' shape from
//!   there, each of the same thickness (the range divided by `K`); the last one reaches to the
//!   far plane.
//! - Opaque casters are a depth map beside them (behind it: shadow).
//!
//! Known failures (RTR): banding and self-shadowing. Inside a slice the reconstruction
//! interpolates linearly, as if the slice's optical depth were spread evenly across it, so a
//! thin layer's step is smeared over its slice: receivers between layers see a ramp (which
//! shrinks as `K` grows), and a transparent surface shadows itself by the part of its own
//! slice in front of it, whatever `K` (on average half its own optical depth). Measured on
//! `smoke`, `layers` and `stained_glass`: deep opacity maps, whose first boundary lies on the
//! first layer, reach a lower error with 4 slices than uniform slices with 16.

pub use super::PassOptions;
use super::{LightPass, PointLookup, Texel, Volumetric};
use crate::choice_enum;
use crate::frame::Frame;
use crate::math;
use crate::pipeline::*;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::light::{light_views, Casters, DepthPass, LightView, Payload, ViewMaps};
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Field, Stage};
use crate::Error;
use glam::{Vec3, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "opacity-maps",
    summary: "opacity shadow maps (Kim and Neumann 2001) and deep opacity maps (Yuksel and Keyser 2008): optical depth in K slices, interpolated; banding between slices",
    sweep: &[
        &[("layout", "uniform"), ("slices", "4")],
        &[("layout", "uniform"), ("slices", "16")],
        &[],
    ],
    extended: &[&[("slices", "16")]],
    ..super::BASE
};

/// Most slices.
pub const MAX_SLICES: u32 = 64;

/// Options of opacity shadow maps.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Slices, 1 to 64. Default: 4.
    pub slices: u32,
    /// Uniform slices (opacity shadow maps) or slices from the first depth (deep opacity
    /// maps). Default: deep, with 4 slices: more accurate and faster than 16 uniform slices
    /// on the transparent fixtures (transmittance RMSE 0.058 against 0.114) and across 150
    /// generated scenes with translucent casters (0.0787 against 0.0871, `penumbra
    /// defaults`). `layout=uniform slices=16` is Kim and Neumann's.
    pub layout: Slices,
    /// The light pass: map side, polygon offset. Default: 512 texels, the shadow map's
    /// offset (4 units, slope 1.1).
    pub pass: PassOptions,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            pass: PassOptions::sized(512),
            slices: 4,
            layout: Slices::Deep,
        }
    }
}

choice_enum! {
    /// Where the slices lie.
    pub enum Slices {
        /// Opacity shadow maps: uniform depths across the casters' range.
        Uniform = "uniform",
        /// Deep opacity maps: from each texel's nearest transparent surface.
        Deep = "deep",
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    super::declaration(
        "opacity-maps",
        |o: &mut Options| &mut o.pass,
        vec![
            Field::range("slices", "opacity slices", 1, MAX_SLICES, |o: &mut Options| {
                &mut o.slices
            }),
            Field::new(
                "layout",
                "uniform (opacity shadow maps) or deep (deep opacity maps: slices from the first depth)",
                |o: &mut Options| &mut o.layout,
            ),
        ],
    )
}

/// One light view's maps.
struct Maps {
    opaque: Surface<f32>,
    /// Slice thickness in this view's light depth.
    step: f32,
    /// Per texel, the first slice boundary (deep) or the range's start (uniform).
    start: Surface<f32>,
    /// Optical depth per slice (RGB in xyz).
    slices: Vec<Surface<Vec4>>,
}

/// The light pass of opacity maps: the opaque depth, the first depth and the slices per light view.
pub struct OpacityPass {
    opts: Options,
    maps: ViewMaps<Maps>,
    fragments: u64,
}

/// Opacity shadow maps and deep opacity maps (see the module docs).
pub type OpacityMaps = PassTechnique<Volumetric<OpacityPass>>;

impl OpacityMaps {
    /// Opacity maps with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<OpacityMaps, Error> {
        declaration().check(&opts)?;
        Ok(Volumetric::technique(
            "opacity-maps",
            OpacityPass {
                opts,
                maps: ViewMaps::default(),
                fragments: 0,
            },
        ))
    }
}

impl PointLookup for OpacityPass {
    /// The transmittance at world point `p` (the per-pixel pass, and `inspect` with a
    /// recording trace), every step reported to `t`.
    fn transmittance(&self, frame: &Frame, p: Vec3, t: &mut impl Trace) -> Vec3 {
        let Some((m, at)) = Texel::of(&self.maps, frame, p, self.opts.pass.size, t) else {
            return Vec3::ONE;
        };
        let (tx, ty) = (at.x, at.y);
        let z = at.depth.clamp(0.0, 1.0);
        let od = m.opaque.at(tx, ty);
        t.step(|| {
            at.step("the texel the maps are read at, and the point's depth", z)
                .num("opaque depth", od)
                .flag("behind an opaque caster", z > od)
        });
        if z > od {
            return Vec3::ZERO;
        }
        let start = m.start.at(tx, ty);
        let k = m.slices.len();
        // Sigma at boundary j: the sum of slices before j.
        let sigma = |j: usize| -> Vec3 { m.slices[..j.min(k)].iter().map(|sl| sl.at(tx, ty).truncate()).sum() };
        let x = (z - start) / m.step;
        let (j, lo, hi, v) = if x <= 0.0 {
            (0, Vec3::ZERO, Vec3::ZERO, Vec3::ONE)
        } else {
            let j = (x.floor() as usize).min(k);
            let (lo, hi) = (sigma(j), sigma(j + 1));
            let frac = if j >= k { 0.0 } else { x - j as f32 };
            let s = lo + (hi - lo) * frac;
            (j, lo, hi, Vec3::new(math::exp(-s.x), math::exp(-s.y), math::exp(-s.z)))
        };
        t.step(|| {
            Step::new(
                "slices",
                "the slice the depth falls in; sigma (optical depth) at its two boundaries, interpolated linearly",
            )
            .text("layout", self.opts.layout.as_str())
            .num("first boundary", start)
            .num("slice thickness", m.step)
            .int("slice", j)
            .vec3("sigma before", lo)
            .vec3("sigma after", hi)
        });
        t.step(|| Step::new("transmittance", "exp(-sigma) per channel").vec3("T", v));
        v
    }
}

/// The light pass's payload: per view, the opaque casters' depth, the slices' start and the
/// optical depth of each slice.
struct Sliced<'a> {
    pass: DepthPass,
    layout: Slices,
    slices: usize,
    opaque: &'a Casters,
    glass: &'a Casters,
    /// Per transparent triangle: its optical depth per channel.
    tau: &'a [Vec4],
    /// Fragments accumulated into the slices, every view.
    fragments: u64,
}

impl Payload for Sliced<'_> {
    type Map = Maps;

    fn what(&self) -> &'static str {
        "the opacity maps"
    }

    fn draw(&mut self, p: &Pipeline, _: usize, view: &LightView, _: Option<Maps>) -> Result<Maps, Error> {
        let (pass, k, tau) = (self.pass, self.slices, self.tau);
        let size = pass.size;
        let opaque = pass.render(p, self.opaque, view, CullMode::None, None, None)?;
        // The depth range of the transparent casters in this view.
        let (mut lo, mut hi) = (1.0f32, 0.0f32);
        for q in &self.glass.positions {
            if let Some((_, z)) = view.lookup(*q) {
                lo = lo.min(z.clamp(0.0, 1.0));
                hi = hi.max(z.clamp(0.0, 1.0));
            }
        }
        if lo > hi {
            (lo, hi) = (0.0, 1.0);
        }
        let step = ((hi - lo) / k as f32).max(1e-7);
        let start = match self.layout {
            Slices::Uniform => Surface::new(size, size, lo)?,
            // Deep opacity maps: each texel's slices start at its first transparent depth.
            Slices::Deep => pass.render(p, self.glass, view, CullMode::None, None, None)?,
        };
        let mut slices = Vec::with_capacity(k);
        for j in 0..k {
            let mut acc = Surface::new(size, size, Vec4::ZERO)?;
            let st = &start;
            // Only fragments in slice j (the last slice takes everything behind).
            let fs = DiscardingShader(move |f: &Fragment<()>| {
                let x = (f.z - st.at(f.x, f.y)) / step;
                let slice = if x < 0.0 { 0 } else { (x as usize).min(k - 1) };
                (slice == j).then(|| tau[f.prim as usize])
            });
            let stats = p.draw(
                &mut Targets::color(&mut acc),
                &RenderState {
                    shading: Shading::Immediate,
                    ..RenderState::accumulate()
                },
                &self.glass.positions,
                &self.glass.indices,
                &TransformPositions(view.matrix),
                &fs,
            )?;
            self.fragments += stats.fragments_passed;
            slices.push(acc);
        }
        Ok(Maps {
            opaque,
            step,
            start,
            slices,
        })
    }
}

impl LightPass for OpacityPass {
    fn render(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error> {
        let o = self.opts.clone();
        let scene = frame.scene;
        let (opaque, glass) = super::opaque_and_transparent(frame)?;
        // Optical depth per triangle (a fully opaque channel would be infinite: capped).
        let od = |x: f32| (-math::ln(x.max(1e-6))).min(30.0);
        let tau: Vec<Vec4> = super::transmittances(scene, &glass)
            .iter()
            .map(|t| Vec4::new(od(t.x), od(t.y), od(t.z), 0.0))
            .collect();
        let mut payload = Sliced {
            pass: o.pass.depth(),
            layout: o.layout,
            slices: o.slices as usize,
            opaque: &opaque,
            glass: &glass,
            tau: &tau,
            fragments: 0,
        };
        self.maps
            .render(p, light_views(frame, o.pass.size), o.pass.size, &mut payload)?;
        self.fragments = payload.fragments;
        Ok(())
    }

    fn ran(&self) -> bool {
        !self.maps.is_empty()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let texels: usize = self.maps.maps().iter().map(|(m, _)| m.opaque.data().len()).sum();
        // Per texel: the opaque depth, the first boundary and K RGB optical depths (as a GPU
        // would store them, 4 bytes a channel).
        let per = 8 + 12 * self.opts.slices as usize;
        vec![
            ("fragments accumulated", self.fragments as f64),
            ("light-space bytes", (texels * per) as f64),
        ]
    }

    fn stages(&self) -> Result<Vec<Stage>, Error> {
        let mut v = Vec::new();
        for (i, (m, _)) in self.maps.maps().iter().enumerate() {
            v.push(Stage::unit(format!("opaque_depth{i}"), m.opaque.clone()));
            v.push(Stage::unit(format!("first_boundary{i}"), m.start.clone()));
            for (j, sl) in m.slices.iter().enumerate() {
                v.push(Stage::Scalar {
                    name: format!("slice{i}_{j:02}_optical_depth"),
                    data: sl.map(|c| c.truncate().dot(crate::visibility::LUMINANCE)),
                    lo: 0.0,
                    hi: 2.0,
                });
            }
        }
        Ok(v)
    }
}
