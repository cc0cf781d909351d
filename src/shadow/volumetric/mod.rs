//! Volumetric shadows (RTR 7.8): transmittance through semi-transparent casters along each
//! light ray. [`transparency_map`]: the nearest transparent caster's colour beside the opaque
//! depth map (one layer). [`opacity_maps`]: optical depth in K slices, uniform (opacity
//! shadow maps) or from the first depth (deep opacity maps). [`deep_shadow_map`]: every fragment of a texel, sorted and compressed
//! within a tolerance. [`avsm`]: adaptive volumetric shadow maps, a fixed number of nodes
//! per texel compressed as the fragments stream in through the pipeline's raster-ordered
//! storage.

pub mod avsm;
pub mod deep_shadow_map;
pub mod opacity_maps;
pub mod transparency_map;

use crate::frame::Frame;
use crate::pipeline::{DepthFormat, Pipeline, PolygonOffset};
use crate::reference::SamplePoint;
use crate::scene::Scene;
use crate::shadow::inspect::{NoTrace, Step, Steps, Trace};
use crate::shadow::light::{merged_casters, Casters, DepthPass, ViewMaps};
use crate::shadow::options::within;
use crate::shadow::pass::{Pass, PassTechnique};
use crate::shadow::technique::{Declaration, Effect, Entry, Family, Field, Stage};
use crate::shadow::timing::Passes;
use crate::visibility::{Visibility, LUMINANCE};
use crate::Error;
use glam::{Vec2, Vec3};

/// What every volumetric technique's registry entry shares: the family, and transmittance
/// among the effects it models.
pub const BASE: Entry = Entry {
    family: Family::Volumetric,
    models: &[Effect::Transmittance],
    ..Entry::BASE
};

/// What a volumetric technique is made of besides the family's lookup: its light pass (the
/// per-view maps it renders) and the transmittance those maps give at a point
/// ([`PointLookup`]). [`Volumetric`] makes a technique of it.
pub trait LightPass: PointLookup + Send {
    /// The light pass's name in `timings`. Default: "light pass".
    const PASS: &'static str = "light pass";
    /// Renders the light-space maps of `frame` (the technique's "light pass").
    fn render(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error>;
    /// Whether a run has left maps to read (`inspect` reports nothing before).
    fn ran(&self) -> bool;
    /// The last run's maps for `dump`.
    fn stages(&self) -> Result<Vec<Stage>, Error>;
    /// Work counters of the last run (light-space bytes, fragments...).
    fn counters(&self) -> Vec<(&'static str, f64)>;
}

/// A volumetric technique: light pass `L`, then the lookup pass at every pixel's point, both
/// timed; `inspect` runs the same per-point function with a recording trace.
pub struct Volumetric<L> {
    /// The light pass and its maps.
    pub light: L,
    /// Whether the last scene had a coloured material (the result is then per channel).
    coloured: bool,
}

impl<L: LightPass> Volumetric<L> {
    /// The technique `name` made of `light`.
    pub fn technique(name: &'static str, light: L) -> PassTechnique<Volumetric<L>> {
        PassTechnique::with(name, Volumetric { light, coloured: false })
    }
}

impl<L: LightPass> Pass for Volumetric<L> {
    type Output = Visibility;

    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Visibility, Error> {
        self.coloured = coloured(frame.scene);
        self.light.render(p, frame)?;
        passes.end(L::PASS);
        let out = lookup_pass(p, frame, self.coloured, &self.light);
        passes.end("lookup pass");
        Ok(out)
    }

    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32> {
        explain_point(frame, x, y, self.coloured, self.light.ran(), &self.light, t)
    }

    fn stages(&self, _: &Pipeline, _: &Frame) -> Result<Vec<Stage>, Error> {
        self.light.stages()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        self.light.counters()
    }
}

/// Where a world point falls in a technique's square maps: the view, the texel and the
/// point's depth in that view.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Texel {
    /// The light view (cube face) it falls in.
    pub view: usize,
    /// Texel column.
    pub x: u32,
    /// Texel row.
    pub y: u32,
    /// Depth in the view, as the view's projection gives it (not clamped).
    pub depth: f32,
}

impl Texel {
    /// The texel of world point `p` in `maps` (each `size` texels square), with the map of
    /// its view; `None`, reported to `t` as lit, where `p` is outside every map (the light
    /// side's one edge rule).
    pub fn of<'m, M>(
        maps: &'m ViewMaps<M>,
        frame: &Frame,
        p: Vec3,
        size: u32,
        t: &mut impl Trace,
    ) -> Option<(&'m M, Texel)> {
        let Some(at) = maps.locate(&frame.light, p).filter(|at| at.inside()) else {
            t.step(|| Step::new("outside", "the point is outside the light's maps: lit"));
            return None;
        };
        let (x, y) = at.texel(size, size);
        let texel = Texel {
            view: at.view,
            x,
            y,
            depth: at.depth,
        };
        Some((&maps.get(at.view).0, texel))
    }

    /// The `inspect` step that says where the point was read (`what`: what is read there),
    /// with depth `z`.
    pub fn step(&self, what: &str, z: f32) -> Step {
        Step::new("light-space position", what)
            .int("view", self.view)
            .vec2("texel", Vec2::new(self.x as f32, self.y as f32))
            .num("depth", z)
    }
}

/// Per triangle of `casters`: its material's transmittance per channel (RGB), in triangle
/// order.
pub fn transmittances(scene: &Scene, casters: &Casters) -> Vec<Vec3> {
    casters
        .object
        .iter()
        .map(|&ob| scene.materials[scene.objects[ob as usize].material].transmittance_rgb())
        .collect()
}

/// Whether some material of `scene` transmits a colour (different per channel): the
/// volumetric techniques then return one transmittance per channel.
pub fn coloured(scene: &Scene) -> bool {
    scene.materials.iter().any(|m| {
        let t = m.transmittance_rgb();
        t.x != t.y || t.y != t.z
    })
}

/// The frame's opaque casters and its transparent ones, each merged in scene order (for the
/// techniques that draw them into separate maps).
pub fn opaque_and_transparent(frame: &Frame) -> Result<(Casters, Casters), Error> {
    let scene = frame.scene;
    let transparent: Vec<bool> = scene
        .objects
        .iter()
        .map(|ob| scene.materials[ob.material].is_transparent())
        .collect();
    let opaque = merged_casters(frame, &transparent.iter().map(|t| !t).collect::<Vec<_>>())?;
    Ok((opaque, merged_casters(frame, &transparent)?))
}

/// The lookup pass every volumetric technique ends with: `f` at each covered pixel's point,
/// in parallel on `p`'s workers (NaN where no geometry); per channel if `coloured`, else the
/// first channel (all three are equal then).
pub fn resolve(p: &Pipeline, frame: &Frame, coloured: bool, f: impl Fn(&SamplePoint) -> Vec3 + Sync) -> Visibility {
    use rayon::prelude::*;
    let rgb: Vec<Vec3> = p.install(|| {
        frame
            .points()
            .par_iter()
            .map(|s| s.as_ref().map_or(Vec3::NAN, &f))
            .collect()
    });
    if coloured {
        Visibility::Rgb(rgb)
    } else {
        Visibility::Scalar(rgb.iter().map(|c| c.x).collect())
    }
}

/// A volumetric technique's per-pixel contract: the transmittance at a world point, every
/// step reported to a trace. The lookup pass runs it with [`NoTrace`] ([`lookup_pass`]),
/// `inspect` with a recording trace ([`explain_point`]), so the two cannot disagree.
pub trait PointLookup: Sync {
    /// Transmittance at world point `p` (1: lit), per channel.
    fn transmittance(&self, frame: &Frame, p: Vec3, t: &mut impl Trace) -> Vec3;
}

/// The lookup pass of a volumetric technique: `l`'s transmittance at each covered pixel's
/// point ([`resolve`]).
pub fn lookup_pass(p: &Pipeline, frame: &Frame, coloured: bool, l: &impl PointLookup) -> Visibility {
    resolve(p, frame, coloured, |s| l.transmittance(frame, s.position, &mut NoTrace))
}

/// `inspect` of a volumetric technique at pixel `(x, y)`: `l`'s steps at the pixel's point and
/// its [`value`]; nothing where no geometry is, or before the first run (`ran` false).
pub fn explain_point(
    frame: &Frame,
    x: u32,
    y: u32,
    coloured: bool,
    ran: bool,
    l: &impl PointLookup,
    t: &mut Steps,
) -> Option<f32> {
    match frame.point(x, y) {
        Some(s) if ran => Some(value(coloured, l.transmittance(frame, s.position, t))),
        _ => None,
    }
}

/// A transmittance as the one value `inspect` reports: its luminance, or its first channel
/// for grey scenes.
pub fn value(coloured: bool, t: Vec3) -> f32 {
    if coloured {
        t.dot(LUMINANCE)
    } else {
        t.x
    }
}

/// The light pass of every volumetric technique: the maps' side and the polygon offset that
/// keeps the casters' own fragments behind their surfaces (the shadow map's defaults).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PassOptions {
    /// Map side in texels (per cube face for point lights). Default: 512.
    pub size: u32,
    /// Constant polygon offset of the light pass, in depth steps. Default: 4 (the shadow
    /// map's).
    pub units: f32,
    /// Slope-scaled polygon offset of the light pass. Default: 1.1 (the shadow map's).
    pub slope: f32,
}

impl Default for PassOptions {
    fn default() -> Self {
        PassOptions::sized(512)
    }
}

impl PassOptions {
    /// The default pass with maps of `size` texels.
    pub const fn sized(size: u32) -> PassOptions {
        PassOptions {
            size,
            units: 4.0,
            slope: 1.1,
        }
    }

    /// The pass's polygon offset.
    pub fn offset(&self) -> PolygonOffset {
        PolygonOffset {
            units: self.units,
            factor: self.slope,
        }
    }

    /// The depth pass of the opaque casters (f32 depth with the pass's offset).
    pub fn depth(&self) -> DepthPass {
        DepthPass {
            size: self.size,
            format: DepthFormat::F32,
            offset: self.offset(),
        }
    }

    /// The declaration of the pass's fields (`size`, `units`, `slope`), with the shadow
    /// map's ranges; a technique's options declare them with [`within`].
    pub fn fields() -> Vec<Field<PassOptions>> {
        vec![
            Field::size(
                "map side in texels (per cube face for point lights)",
                |o: &mut PassOptions| &mut o.size,
            ),
            Field::range(
                "units",
                "constant polygon offset of the light pass",
                -1e6,
                1e6,
                |o: &mut PassOptions| &mut o.units,
            ),
            Field::range(
                "slope",
                "slope-scaled polygon offset of the light pass",
                -1e3,
                1e3,
                |o: &mut PassOptions| &mut o.slope,
            ),
        ]
    }
}

/// A volumetric technique's declaration: its light pass's fields ([`PassOptions::fields`],
/// reached through `pass`), then its own `fields`.
pub fn declaration<O: Clone + Default + 'static>(
    technique: &'static str,
    pass: fn(&mut O) -> &mut PassOptions,
    fields: Vec<Field<O>>,
) -> Declaration<O> {
    let mut all = within(PassOptions::fields(), pass);
    all.extend(fields);
    Declaration { technique, fields: all }
}
