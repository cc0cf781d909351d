//! Penumbra volume maps (Cournia 2005, chapter 4): three passes.
//!
//! 1. **Depth map** from the light's centre (the shadow map's light pass, with its options).
//! 2. **Penumbra volume map** (4.1). The light-space silhouettes ([`super::silhouettes`], the
//!    shadow volumes' adjacency) are walked as loops: at a silhouette vertex `v1` with
//!    neighbours `v0` and `v2` (edges `e0 = v0 -> v1`, `e1 = v1 -> v2`), the hard shadow
//!    plane normal of `e1` is `n1 = (v2 - v1) x (v1 - l) / |...|`, the displaced light
//!    positions `d1- = l - n1 r` (outer) and `d1+ = l + n1 r` (inner), and the outer plane
//!    through `v1, v2, d1-` has normal `n1- = (v2 - v1) x (v1 - d1-) / |...|` (4.1.2); the same
//!    for `e0` gives `n0-`, and the outer extrusion vector is the planes' intersection,
//!    `v1^- = n1- x n0-`, negated when it points towards the light (the text's rule, `v1` in
//!    the negative half-space of the plane through `v0, v2, l`, fixes the same sign); where
//!    `n0 = n1` (coincident planes) or a loop is open, `v1^- = (v1 - d1-) / |v1 - d1-|`;
//!    nearly coincident planes (a UV sphere's silhouette zig-zags in depth) meet along a line
//!    close to the edges, not the light's ray, and are taken as coincident too
//!    ([`WELL_CONDITIONED`]: our addition, the text does not treat them). The
//!    inner vector `v1^+` likewise. Each edge gives an outer quad `v1, v1 + w v1^-,
//!    v2 + w v2^-, v2` and an inner one, `w` at infinity (homogeneous `w = 0`, kept by the
//!    pipeline's depth clamp). The quads are rendered from the light in one pass (4.1.3):
//!    the depth target is the penumbra volume depth map (PVDM) and the colour target holds,
//!    per texel, the index of the silhouette edge whose volume is nearest: the two penumbra
//!    volume edge maps (PVEM) as one texel, their end points `h0, h1` read from the edge
//!    table at full precision (`dump` expands them into the two maps).
//! 3. **Visibility** (4.2, listing 4.2). A pixel behind the PVDM's depth is in a volume: the
//!    cutting plane through `h0, h1` and the pixel, `n = (h1 - h0) x (p - h0) / |...|`,
//!    `d = -n . h0`, cuts a disk of the light's radius centred at the light and perpendicular
//!    to it at `s = n . l + d`; the area beyond, eq. 4.1, gives `k = 2 a / (pi r^2)` (eq. 4.2)
//!    and the visibility `3 k^2 - 2 k^3` (Parker et al.'s Bernstein smoothing, with `smooth=true`;
//!    the default keeps `k`, see [`Options::smooth`]). Outside every volume the depth map decides umbra or lit (one hardware 2x2
//!    comparison).
//!
//! The light is a sphere of radius `r`: half the scene's area light width
//! ([`crate::shadow::light::soft::light_width`]) times `light`. Point and spot lights have
//! none, and a directional light has no centre to extrude from, so those get the hard map; a
//! radius of 0 is exactly `shadow-map [filter=pcf2]` with the same map options.
//!
//! Known failures (4.3): **penumbra volume overlap**: where volumes overlap in light space the
//! nearest one overwrites the others' edge, so pixels are shaded from the wrong occluder
//! (fig. 4.7); **visibility discontinuities** between neighbouring edges' volumes (fig. 4.8);
//! and the **single silhouette** from the light's centre, wrong for a light much larger than a
//! nearby occluder.

use super::{
    bernstein, disk_visibility, light_and_silhouettes, light_field, render_views, silhouette_notes, volume_step,
    Extrusion, Quads, Silhouettes, VolumeMap,
};
use crate::frame::Frame;
use crate::pipeline::{Pipeline, Rgba8};
use crate::shadow::inspect::{self, NoTrace, Step, Trace};
use crate::shadow::light::{Layer, MapOptions};
use crate::shadow::options::within;
use crate::shadow::overview::{backdrop, draw_world_segment};
use crate::shadow::pixels::{per_pixel, per_pixel_counted};
use crate::shadow::sample::kernel::bilinear_compare;
use crate::shadow::sample::lookup::{Bias, MapLookup, Prepared, Setup};
use crate::shadow::technique::{Declaration, Entry, Field, ShadowTechnique, Stage, Visibility};
use crate::shadow::timing::Passes;
use crate::{Error, Resource};
use glam::{Vec2, Vec3};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "pvm",
    summary: "penumbra volume maps (Cournia 2005 ch. 4): the nearest volume's silhouette edge and a cut disk; fails where volumes overlap",
    sweep: &[&[], &[("smooth", "true")]],
    extended: &[&[("size", "512")], &[("size", "4096")], &[("light", "2")]],
    ..super::BASE
};

/// Options of penumbra volume maps.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The depth map's pass; the volume map has the same size. Default: its defaults (2048
    /// texels, f32, 4 units, slope 1.1).
    pub map: MapOptions,
    /// Normal-offset and receiver-plane bias of the depth map's 2x2 comparison. Default: none.
    pub bias: Bias,
    /// The light's radius as a multiple of half the scene's area light width (0: the hard
    /// shadow map). Default: 1.
    pub light: f32,
    /// Bernstein smoothing `3 k^2 - 2 k^3` of the disk visibility (Parker et al.), as the text
    /// does. Default: false: the smoothed ramp is steeper than the cut disk's, and without it
    /// the penumbra RMSE was lower across 150 generated area-light scenes (mean 0.1245
    /// against 0.1486, `penumbra defaults`) and on the area fixtures (0.106 against 0.114).
    pub smooth: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            map: MapOptions::default(),
            bias: Bias::default(),
            light: 1.0,
            smooth: false,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(MapOptions::fields(), |o: &mut Options| &mut o.map);
    fields.extend(within(Bias::fields(), |o: &mut Options| &mut o.bias));
    fields.extend([
        light_field(|o: &mut Options| &mut o.light),
        Field::new(
            "smooth",
            "Bernstein smoothing 3k^2 - 2k^3 of the disk visibility (Parker et al.)",
            |o: &mut Options| &mut o.smooth,
        ),
    ]);
    Declaration::new("pvm", fields)
}

/// How far off the light's ray through a vertex its extrusion vector may turn, in light radii
/// per unit distance (a square corner turns `sqrt(2)`); beyond, the planes are taken as
/// coincident.
pub const WELL_CONDITIONED: f32 = 4.0;

/// The plane of edge `a -> b` through the displaced light `l + side n r` (`side` -1: outer,
/// +1: inner; `n` the hard shadow plane's normal), and that displaced light (Cournia 4.1.2).
fn displaced_plane(a: Vec3, b: Vec3, l: Vec3, r: f32, side: f32) -> (Vec3, Vec3, Vec3) {
    let n = (b - a).cross(a - l).normalize_or_zero();
    let d = l + n * (side * r);
    ((b - a).cross(a - d).normalize_or_zero(), d, n)
}

/// The extrusion vector at the vertex where edge `prev` ends and edge `next` starts (either
/// may be missing: an open loop), for `side` -1 (outer) or +1 (inner) (Cournia 4.1.2).
pub fn vertex_extrusion(prev: Option<(Vec3, Vec3)>, next: Option<(Vec3, Vec3)>, l: Vec3, r: f32, side: f32) -> Vec3 {
    let v1 = next.map_or_else(|| prev.map_or(l, |e| e.1), |e| e.0);
    let planes = [prev, next].map(|e| e.map(|(a, b)| displaced_plane(a, b, l, r, side)));
    if let [Some((m0, _, n0)), Some((m1, _, n1))] = planes {
        // Coincident planes (collinear edges) have no intersection line.
        if n0.dot(n1) < 1.0 - 1e-6 {
            let v = m1.cross(m0);
            let len = v.length();
            let ray = (v1 - l).normalize_or_zero();
            let v = v / len.max(f32::MIN_POSITIVE);
            let v = if v.dot(ray) < 0.0 { -v } else { v };
            // Nearly parallel planes (edges almost collinear seen from the light, turning in
            // depth) meet along a line close to the edges themselves, far off the light's
            // ray: an intersection more than `WELL_CONDITIONED` light radii off the ray (the
            // sine of its angle, against r / |v1 - l|) is taken as coincident.
            let off = v.cross(ray).length();
            if len > 1e-9 && off <= (WELL_CONDITIONED * r / (v1 - l).length().max(1e-9)).min(1.0) {
                return v;
            }
        }
    }
    let d = planes[1].or(planes[0]).map_or(l, |p| p.1);
    (v1 - d).normalize_or_zero()
}

/// Every silhouette edge's extrusion vectors, from its loop neighbours.
pub fn extrusions(s: &Silhouettes, l: Vec3, r: f32) -> Vec<Extrusion> {
    let ends = |i: Option<u32>| i.map(|i| (s.edges[i as usize].a, s.edges[i as usize].b));
    (0..s.edges.len())
        .map(|i| {
            let own = Some((s.edges[i].a, s.edges[i].b));
            let (prev, next) = (ends(s.prev[i]), ends(s.next[i]));
            let at = |side| {
                [
                    vertex_extrusion(prev, own, l, r, side),
                    vertex_extrusion(own, next, l, r, side),
                ]
            };
            Extrusion {
                outer: at(-1.0),
                inner: at(1.0),
            }
        })
        .collect()
}

/// The outer and inner quads of every edge; each quad's texel is `2 edge + kind` (kind 0:
/// outer, 1: inner), exact in `f32` below 2^23 edges.
pub fn volume_quads(s: &Silhouettes, ext: &[Extrusion]) -> Quads {
    let mut q = Quads::default();
    for (i, (e, x)) in s.edges.iter().zip(ext).enumerate() {
        for (kind, v) in [(0, x.outer), (1, x.inner)] {
            q.push(
                [e.a.extend(1.0), v[0].extend(0.0), v[1].extend(0.0), e.b.extend(1.0)],
                (2 * i + kind) as f32,
            );
        }
    }
    q
}

/// Penumbra volume maps (see the module docs).
pub struct Pvm {
    opts: Options,
    lookup: MapLookup,
    sil: Silhouettes,
    ext: Vec<Extrusion>,
    volumes: Vec<VolumeMap>,
    radius: f32,
    quads: usize,
    inside: u64,
    umbra: u64,
    times: Vec<(&'static str, f64)>,
}

/// What pass 3 found at one pixel.
#[derive(Copy, Clone, Debug, PartialEq)]
enum Found {
    /// Decided by the depth map outside every volume (2x2 comparison).
    Map(f32),
    /// Inside the volume of edge `edge`: the disk visibility `k` and the visibility.
    Volume { edge: usize, k: f32, v: f32 },
}

impl Pvm {
    /// Penumbra volume maps with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Pvm, Error> {
        declaration().check(&opts)?;
        // The depth map, compared with 2x2 PCF outside the volumes.
        let lookup = MapLookup::new(Setup {
            map: opts.map.clone(),
            layer: Layer::First,
            bias: opts.bias,
            wide: None,
            min_max: false,
        });
        Ok(Pvm {
            opts,
            lookup,
            sil: Silhouettes::default(),
            ext: Vec::new(),
            volumes: Vec::new(),
            radius: 0.0,
            quads: 0,
            inside: 0,
            umbra: 0,
            times: Vec::new(),
        })
    }

    /// The light's radius of the last run (0: hard shadows).
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Pass 3 at one pixel; every step reported to `t`.
    fn lookup(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> Option<Found> {
        let at = match self.lookup.prepare(frame, x, y, t) {
            Prepared::Done(v, _) => return v.is_finite().then_some(Found::Map(v)),
            Prepared::At(at) => at,
        };
        let map = &self.lookup.maps()[at.face].0;
        if let Some(vm) = self.volumes.get(at.face) {
            let size = vm.depth.width() as f32;
            let inside_map = at.uv.cmpge(Vec2::ZERO).all() && at.uv.cmplt(Vec2::ONE).all();
            if inside_map {
                let (tx, ty) = ((at.uv.x * size) as u32, (at.uv.y * size) as u32);
                let vd = vm.depth.at(tx, ty);
                let rec = vm.texel.at(tx, ty);
                let inside = vd < at.r.z && rec >= 0.0;
                t.step(|| {
                    Step::new(
                        "penumbra volume depth map",
                        "the nearest volume's depth at the point's texel: in front of the point, the point is in a volume (listing 4.2)",
                    )
                    .num("volume depth", vd)
                    .num("point depth", at.r.z)
                    .flag("inside a volume", inside)
                });
                if inside {
                    let edge = rec as usize / 2;
                    let e = self.sil.edges[edge];
                    let l = frame.light.position;
                    let (k, s) = disk_visibility(e.a, e.b, at.pos, l, self.radius);
                    let v = if self.opts.smooth { bernstein(k) } else { k };
                    t.step(|| {
                        Step::new(
                            "cutting plane",
                            "the plane through the volume's edge h0 h1 and the point; a disk of the light's radius perpendicular to it at the light (4.2)",
                        )
                        .int("edge", edge)
                        .text("volume", if rec as usize % 2 == 1 { "inner" } else { "outer" })
                        .vec3("h0", e.a)
                        .vec3("h1", e.b)
                        .num("light radius", self.radius)
                        .num("light centre to plane, s", s)
                    });
                    t.step(|| {
                        Step::new(
                            "disk visibility",
                            "eq. 4.1 area a = acos(s/r) r^2/2 - s sqrt(r^2 - s^2)/2; eq. 4.2 k = 2a/(pi r^2); v = 3k^2 - 2k^3",
                        )
                        .num("k", k)
                        .flag("smoothed", self.opts.smooth)
                    });
                    return Some(Found::Volume { edge, k, v });
                }
            }
        }
        let v = bilinear_compare(map, at.uv, at.r.z);
        t.step(|| {
            Step::new(
                "depth map",
                "outside every volume: the depth map decides umbra or lit (one 2x2 comparison)",
            )
            .num("visibility", v)
        });
        Some(Found::Map(v))
    }

    fn value(f: Option<Found>) -> f32 {
        match f {
            None => f32::NAN,
            Some(Found::Map(v)) | Some(Found::Volume { v, .. }) => v,
        }
    }
}

impl ShadowTechnique for Pvm {
    fn name(&self) -> &'static str {
        "pvm"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        let l = frame.light.position;
        self.volumes.clear();
        self.ext.clear();
        self.quads = 0;
        (self.radius, self.sil) = light_and_silhouettes(p, frame, &mut self.lookup, self.opts.light, &mut passes)?;
        if self.sil.edges.len() >= 1 << 23 {
            return Err(Error::budget(
                "the edge map's silhouette edges",
                self.sil.edges.len() as u64,
                (1 << 23) - 1,
                Resource::Entries,
            ));
        }
        let mut quads = Quads::default();
        if self.radius > 0.0 {
            self.ext = extrusions(&self.sil, l, self.radius);
            quads = volume_quads(&self.sil, &self.ext);
            self.quads = quads.len();
        }
        passes.end("volume construction");
        if self.radius > 0.0 {
            self.volumes = render_views(p, &quads, &self.lookup, self.opts.map.size)?;
        }
        passes.end("volume rendering");
        let this = &*self;
        let (out, count) = per_pixel_counted(p, frame, |x, y| {
            let f = this.lookup(frame, x, y, &mut NoTrace);
            let c = match f {
                Some(Found::Volume { .. }) => 1,
                Some(Found::Map(0.0)) => 1 << 32,
                _ => 0,
            };
            (Self::value(f), c)
        });
        self.inside = count & 0xffff_ffff;
        self.umbra = count >> 32;
        passes.end("visibility");
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let header = || volume_step(&self.lookup, self.radius, &self.sil).int("volume quads", self.quads);
        inspect::closed(|t| {
            self.lookup.explain(t, header, |t| {
                Self::value(self.lookup(frame, x as usize, y as usize, t))
            })
        })
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn notes(&self) -> Vec<String> {
        silhouette_notes(
            &self.sil,
            "its silhouette loops may be open (coincident-plane extrusion there)",
        )
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("map texels", self.lookup.texels() as f64),
            ("silhouette edges", self.sil.edges.len() as f64),
            ("volume quads", self.quads as f64),
            (
                "volume fragments",
                self.volumes.iter().map(|v| v.fragments).sum::<u64>() as f64,
            ),
            ("pixels in a volume", self.inside as f64),
            ("umbra pixels", self.umbra as f64),
        ]
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v = self.lookup.stages(p, frame)?;
        if self.volumes.is_empty() {
            return Ok(v);
        }
        let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ONE));
        let span = (hi - lo).max(Vec3::splat(1e-6));
        let colour = |q: Vec3| -> Rgba8 {
            let c = ((q - lo) / span).clamp(Vec3::ZERO, Vec3::ONE) * 255.0;
            [c.x as u8, c.y as u8, c.z as u8, 255]
        };
        for (i, vm) in self.volumes.iter().enumerate() {
            let Some(depth) = vm.depth_stage(format!("volume_depth{i}")) else {
                continue;
            };
            v.push(depth);
            for (end, name) in [(0, "edge0"), (1, "edge1")] {
                let data = vm.texel.map(|t| {
                    if t < 0.0 {
                        [0, 0, 0, 255]
                    } else {
                        let e = self.sil.edges[t as usize / 2];
                        colour(if end == 0 { e.a } else { e.b })
                    }
                });
                v.push(Stage::Color {
                    name: format!("{name}_map{i}"),
                    data,
                });
            }
        }
        // Fig. 4.2: the silhouette (green) and each vertex's outer (yellow) and inner (orange)
        // extrusion vectors, a tenth of the scene's size long.
        let mut img = backdrop(frame);
        let len = 0.1 * (hi - lo).length();
        for (e, x) in self.sil.edges.iter().zip(&self.ext) {
            draw_world_segment(&mut img, frame, e.a, e.b, [60, 220, 60, 255]);
            for (k, end) in [e.a, e.b].into_iter().enumerate() {
                draw_world_segment(&mut img, frame, end, end + x.outer[k] * len, [240, 220, 40, 255]);
                draw_world_segment(&mut img, frame, end, end + x.inner[k] * len, [240, 130, 30, 255]);
            }
        }
        v.push(Stage::Color {
            name: "extrusion_vectors".into(),
            data: img,
        });
        let inside = per_pixel(p, frame, |x, y| match self.lookup(frame, x, y, &mut NoTrace) {
            None => f32::NAN,
            Some(Found::Volume { .. }) => 1.0,
            Some(Found::Map(_)) => 0.0,
        });
        v.push(Stage::pixels(frame, "inside_volume", inside, 0.0, 1.0)?);
        let k = per_pixel(p, frame, |x, y| match self.lookup(frame, x, y, &mut NoTrace) {
            Some(Found::Volume { k, .. }) => k,
            _ => f32::NAN,
        });
        v.push(Stage::pixels(frame, "disk_visibility_k", k, 0.0, 1.0)?);
        Ok(v)
    }
}
