//! Deep shadow maps (Lokovic and Veach 2000; RTR 7.8): each light texel stores its whole
//! transmittance function along the light ray, built from every caster fragment and
//! compressed to a piecewise-linear function within an error tolerance.
//!
//! - **Light pass**: every caster is drawn from the light into the pipeline's per-pixel
//!   fragment lists (deterministic: each texel's list is in submission order), each fragment
//!   carrying its material's transmittance per channel.
//! - **Per texel**: the fragments sorted by depth (ties in submission order) make a step
//!   function: `T` drops by the fragment's factor at its depth. It is written as vertices
//!   (two at every step, before and after it) and compressed by Lokovic and Veach's greedy
//!   algorithm: from the current vertex, the line is extended as far as a slope exists that
//!   stays within `tolerance` of every vertex passed (the intersection of the slope intervals
//!   the vertices allow); where the interval becomes empty, a vertex is emitted on the line
//!   and the next segment starts there. Every channel must fit.
//! - **Lookup**: binary search of the receiver's depth among the texel's vertices, linear
//!   interpolation; the receiver's own surface is kept out by the shadow map's polygon offset
//!   in the light pass.
//! - **Filtering between texels** (`filter=bilinear`, the default): Lokovic and Veach filter
//!   the functions, not the depths: the transmittances of the four texels around the lookup
//!   point, each evaluated at the receiver's depth, weighted bilinearly (their box filter over
//!   the lookup's footprint, at the footprint of one texel). With opaque casters only this is
//!   the 2x2 hardware PCF of the shadow map (`filter=pcf2`), bit for bit; `filter=nearest`
//!   takes the nearest texel's function and is then the hard shadow map.
//!
//! Memory grows with the fragments (the lists' pool, capacity as an option: a scene that needs
//! more is an error that says how many), then shrinks to the compressed vertices, counted.
//! Known failure: resolution; one function per texel, so thin occluders alias as in a shadow
//! map (softened, not removed, by the bilinear filter).

pub use super::PassOptions;
use super::{LightPass, PointLookup, Volumetric};
use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::sampler::{bilerp, footprint2x2};
use crate::pipeline::*;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::light::{light_views, merged_casters, Casters, LightView, Payload, ViewMaps};
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Field, Stage};
use crate::{Error, Resource};
use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "deep-shadow-map",
    summary: "deep shadow maps (Lokovic and Veach 2000; RTR 7.8): every fragment per texel in lists, sorted, compressed piecewise-linear within a tolerance; memory grows with the fragments",
    sweep: &[&[]],
    extended: &[&[("filter", "nearest")]],
    ..super::BASE
};

/// Options of the deep shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Compression tolerance of the transmittance functions, in (0, 1). Default: 0.01.
    pub tolerance: f32,
    /// Fragments the lists may hold per view. Default: 16777216.
    pub capacity: u32,
    /// Filtering between texels. Default: bilinear.
    pub filter: Filter,
    /// The light pass: map side, polygon offset. Default: 512 texels, the shadow map's
    /// offset (4 units, slope 1.1).
    pub pass: PassOptions,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            pass: PassOptions::sized(512),
            tolerance: 0.01,
            capacity: 1 << 24,
            filter: Filter::Bilinear,
        }
    }
}

choice_enum! {
    /// How the lookup combines texels.
    pub enum Filter {
        /// The nearest texel's function.
        Nearest = "nearest",
        /// The four nearest texels' functions evaluated at the receiver's depth, weighted
        /// bilinearly.
        Bilinear = "bilinear",
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    super::declaration(
        "deep-shadow-map",
        |o: &mut Options| &mut o.pass,
        vec![
            Field::range(
                "tolerance",
                "compression tolerance of each texel's transmittance function, in (0, 1)",
                1e-6,
                0.999_999,
                |o: &mut Options| &mut o.tolerance,
            ),
            Field::range(
                "capacity",
                "fragments the lists may hold per light view (a scene that needs more is an error)",
                1,
                1 << 28,
                |o: &mut Options| &mut o.capacity,
            ),
            Field::new(
                "filter",
                "nearest (one texel's function) or bilinear (four texels' transmittances weighted bilinearly)",
                |o: &mut Options| &mut o.filter,
            ),
        ],
    )
}

/// A vertex of a texel's function.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Vertex {
    /// Light-space depth.
    pub depth: f32,
    /// Transmittance per channel.
    pub t: Vec3,
}

/// The step function of `frags` (depth, transmittance; in submission order), as vertices:
/// two at every step (before and after).
pub fn step_vertices(frags: &mut [(f32, Vec3)]) -> Vec<Vertex> {
    frags.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out = Vec::with_capacity(2 * frags.len() + 1);
    let mut t = Vec3::ONE;
    out.push(Vertex { depth: 0.0, t });
    for &(d, f) in frags.iter() {
        out.push(Vertex { depth: d, t });
        t *= f;
        out.push(Vertex { depth: d, t });
    }
    out
}

/// Lokovic and Veach's greedy compression: the fewest segments (greedily) that stay within
/// `eps` of every vertex, in every channel.
pub fn compress(v: &[Vertex], eps: f32) -> Vec<Vertex> {
    let Some(&first) = v.first() else { return Vec::new() };
    let mut out = vec![first];
    let mut origin = first;
    let mut lo = Vec3::splat(f32::NEG_INFINITY);
    let mut hi = Vec3::splat(f32::INFINITY);
    let mut last = first;
    let mut i = 1;
    while i < v.len() {
        let p = v[i];
        let dz = p.depth - origin.depth;
        if dz <= 0.0 {
            // A vertical step at the origin: it can only be kept as a vertex of its own.
            if (p.t - origin.t).abs().max_element() > eps {
                out.push(p);
                origin = p;
                lo = Vec3::splat(f32::NEG_INFINITY);
                hi = Vec3::splat(f32::INFINITY);
            }
            last = p;
            i += 1;
            continue;
        }
        let nlo = lo.max((p.t - eps - origin.t) / dz);
        let nhi = hi.min((p.t + eps - origin.t) / dz);
        if nlo.cmple(nhi).all() {
            lo = nlo;
            hi = nhi;
            last = p;
            i += 1;
            continue;
        }
        // The slopes left no room: end the segment at the last vertex that fitted, on the
        // middle of the allowed slopes, and start again from there.
        let ldz = last.depth - origin.depth;
        let slope = if lo.x.is_finite() { (lo + hi) * 0.5 } else { Vec3::ZERO };
        let end = if ldz > 0.0 {
            Vertex {
                depth: last.depth,
                t: origin.t + slope * ldz,
            }
        } else {
            last
        };
        out.push(end);
        origin = end;
        lo = Vec3::splat(f32::NEG_INFINITY);
        hi = Vec3::splat(f32::INFINITY);
        if ldz <= 0.0 {
            // No progress possible from `last` itself: take `p` as a vertex.
            out.push(p);
            origin = p;
            last = p;
            i += 1;
        }
    }
    // Close with the last vertex on the final segment.
    let ldz = last.depth - origin.depth;
    if ldz > 0.0 {
        let slope = if lo.x.is_finite() { (lo + hi) * 0.5 } else { Vec3::ZERO };
        out.push(Vertex {
            depth: last.depth,
            t: (origin.t + slope * ldz).clamp(Vec3::ZERO, Vec3::ONE),
        });
    }
    out
}

/// The function's value at depth `z`: linear between the bracketing vertices, the last
/// vertex's value behind all.
pub fn evaluate(v: &[Vertex], z: f32) -> Vec3 {
    let k = v.partition_point(|p| p.depth < z);
    if k == 0 {
        return v.first().map_or(Vec3::ONE, |p| p.t);
    }
    if k >= v.len() {
        return v[v.len() - 1].t;
    }
    let (a, b) = (v[k - 1], v[k]);
    let dz = b.depth - a.depth;
    if dz <= 0.0 {
        return a.t;
    }
    a.t + (b.t - a.t) * ((z - a.depth) / dz)
}

/// One light view's compressed functions: vertices per texel in one pool.
struct Map {
    size: u32,
    offsets: Vec<u32>,
    vertices: Vec<Vertex>,
    fragments: u64,
}

/// Where one point reads the map.
struct Lookup {
    view: usize,
    depth: f32,
    /// Top-left, top-right, bottom-left, bottom-right (all four the same texel for nearest).
    texels: [(u32, u32); 4],
    /// The bilinear fraction, `None` for nearest.
    frac: Option<Vec2>,
}

/// The light pass of the deep shadow map: every texel's compressed function per light view.
pub struct DeepShadowPass {
    opts: Options,
    maps: ViewMaps<Map>,
    /// Most bytes held at once while building: the finished views' functions plus one view's
    /// lists (heads, tails, nodes) and its functions twice (per row, then pooled).
    peak: usize,
}

/// The deep shadow map (see the module docs).
pub type DeepShadowMap = PassTechnique<Volumetric<DeepShadowPass>>;

impl DeepShadowMap {
    /// A deep shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<DeepShadowMap, Error> {
        declaration().check(&opts)?;
        Ok(Volumetric::technique(
            "deep-shadow-map",
            DeepShadowPass {
                opts,
                maps: ViewMaps::default(),
                peak: 0,
            },
        ))
    }
}

impl DeepShadowPass {
    /// The lookup of point `p`: its view, depth, and the texels it reads with their weights
    /// (one texel for `nearest`; for `bilinear` the 2x2 footprint of the shadow map's
    /// hardware PCF, clamped to the map's edge, weights `(1 - fx)(1 - fy)`, `fx (1 - fy)`,
    /// `(1 - fx) fy`, `fx fy`). `None` outside every view.
    fn taps(&self, frame: &Frame, p: Vec3) -> Option<Lookup> {
        let at = self.maps.locate(&frame.light, p).filter(|at| at.inside())?;
        let (f, uv, m) = (at.view, at.uv, &self.maps.get(at.view).0);
        let s = m.size;
        let z = at.depth.clamp(0.0, 1.0);
        Some(match self.opts.filter {
            Filter::Nearest => Lookup {
                view: f,
                depth: z,
                texels: [at.texel(s, s); 4],
                frac: None,
            },
            Filter::Bilinear => {
                let (texels, frac) = footprint2x2((s, s), uv);
                Lookup {
                    view: f,
                    depth: z,
                    texels,
                    frac: Some(frac),
                }
            }
        })
    }

    /// The transmittance of texel `(tx, ty)` of view `f` at depth `z` (1 where the texel
    /// holds no fragment).
    fn at(&self, f: usize, (tx, ty): (u32, u32), z: f32) -> Vec3 {
        let v = self.function(f, tx, ty);
        if v.is_empty() {
            Vec3::ONE
        } else {
            evaluate(v, z)
        }
    }

    fn function(&self, f: usize, tx: u32, ty: u32) -> &[Vertex] {
        let m = &self.maps.get(f).0;
        let i = (ty * m.size + tx) as usize;
        &m.vertices[m.offsets[i] as usize..m.offsets[i + 1] as usize]
    }
}

impl PointLookup for DeepShadowPass {
    /// The transmittance at world point `p` (the per-pixel pass, and `inspect` with a
    /// recording trace): each texel's function at the point's depth, filtered; every step
    /// reported to `t`.
    fn transmittance(&self, frame: &Frame, p: Vec3, t: &mut impl Trace) -> Vec3 {
        let Some(l) = self.taps(frame, p) else {
            t.step(|| Step::new("outside", "the point is outside the light's maps: lit"));
            return Vec3::ONE;
        };
        // The value as the lookup pass computes it; the trace reads each texel again.
        let v = match l.frac {
            None => self.at(l.view, l.texels[0], l.depth),
            // The sampler's PCF mix, so that opaque casters give its result bit for bit.
            Some(fr) => bilerp(l.texels.map(|t| self.at(l.view, t, l.depth)), fr),
        };
        let n = if l.frac.is_some() { 4 } else { 1 };
        for (k, &(tx, ty)) in l.texels.iter().enumerate().take(n) {
            t.step(|| {
                let f = self.function(l.view, tx, ty);
                let mut st = Step::new(
                    "function",
                    "a texel's compressed transmittance function (depth, transmittance per channel)",
                )
                .int("view", l.view)
                .vec2("texel", Vec2::new(tx as f32, ty as f32))
                .int("vertices", f.len());
                // The vertices of the first texel (the others' are listed by their own pixels).
                if k == 0 {
                    for (i, p) in f.iter().enumerate().take(32) {
                        st = st
                            .num(&format!("vertex {i} depth"), p.depth)
                            .vec3(&format!("vertex {i} T"), p.t);
                    }
                }
                st.vec3("T at the depth", self.at(l.view, (tx, ty), l.depth))
            });
        }
        t.step(|| {
            let mut lookup = Step::new(
                "lookup",
                match l.frac {
                    None => "binary search of the depth in the nearest texel's function, linear interpolation between the two vertices",
                    Some(_) => "each texel's function at the depth (binary search, linear interpolation), the four weighted bilinearly",
                },
            )
            .num("depth", l.depth);
            if let Some(fr) = l.frac {
                lookup = lookup.vec2("bilinear fraction", fr);
            }
            lookup.vec3("transmittance", v)
        });
        v
    }
}

/// The light pass's payload: per view, every texel's fragments in a list, then each
/// texel's compressed transmittance function.
struct Functions<'a> {
    size: u32,
    capacity: usize,
    tolerance: f32,
    casters: &'a Casters,
    /// Per triangle: its transmittance.
    transmit: &'a [Vec4],
    state: RenderState,
    /// Bytes of the views' functions built so far.
    built: usize,
    /// Most bytes held at once ([`DeepShadowPass::peak`]).
    peak: usize,
}

impl Payload for Functions<'_> {
    type Map = Map;

    fn what(&self) -> &'static str {
        "the deep shadow maps"
    }

    /// Per texel of a view while it is built: the lists' heads and tails and a function's
    /// header (40 bytes); per texel of every view kept: its offset (4).
    fn bytes(&self, size: u32, views: usize, _: usize) -> u64 {
        size as u64 * size as u64 * (40 + 4 * views as u64)
    }

    fn draw(&mut self, p: &Pipeline, _: usize, view: &LightView, _: Option<Map>) -> Result<Map, Error> {
        let (size, tolerance, transmit) = (self.size, self.tolerance, self.transmit);
        let mut lists = FragmentLists::new(size, size, self.capacity)?;
        let fs = Shader(|f: &Fragment<()>| transmit[f.prim as usize]);
        p.draw(
            &mut Targets::none().with_lists(&mut lists),
            &self.state,
            &self.casters.positions,
            &self.casters.indices,
            &TransformPositions(view.matrix),
            &fs,
        )
        .map_err(|e| match e {
            PipelineError::FragmentPoolFull { needed, capacity } => Error::budget(
                "the fragments of one light view (option capacity)",
                needed as u64,
                capacity as u64,
                Resource::Entries,
            ),
            e => Error::from(e),
        })?;
        // Per texel: sort, step function, compression (texels in parallel, gathered in
        // order).
        let n = size as usize;
        let per_row: Vec<Vec<Vec<Vertex>>> = p.install(|| {
            (0..n)
                .into_par_iter()
                .map(|y| {
                    (0..n)
                        .map(|x| {
                            let mut frags: Vec<(f32, Vec3)> = lists
                                .iter(x as u32, y as u32)
                                .map(|nd| (nd.depth, nd.value.truncate()))
                                .collect();
                            if frags.is_empty() {
                                return Vec::new();
                            }
                            compress(&step_vertices(&mut frags), tolerance)
                        })
                        .collect()
                })
                .collect()
        });
        let mut offsets = Vec::with_capacity(n * n + 1);
        let mut vertices = Vec::new();
        offsets.push(0u32);
        for row in per_row {
            for f in row {
                vertices.extend_from_slice(&f);
                offsets.push(vertices.len() as u32);
            }
        }
        let lists_bytes = n * n * 8 + lists.len() * std::mem::size_of::<ListNode>();
        let built = vertices.len() * std::mem::size_of::<Vertex>() + offsets.len() * 4;
        self.peak = self.peak.max(self.built + lists_bytes + 2 * built);
        self.built += built;
        Ok(Map {
            size,
            offsets,
            vertices,
            fragments: lists.len() as u64,
        })
    }
}

impl LightPass for DeepShadowPass {
    const PASS: &'static str = "light pass and compression";

    fn render(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error> {
        let o = self.opts.clone();
        let scene = frame.scene;
        let casters = merged_casters(frame, &vec![true; scene.objects.len()])?;
        let transmit: Vec<Vec4> = super::transmittances(scene, &casters)
            .iter()
            .map(|t| t.extend(1.0))
            .collect();
        let state = RenderState {
            offset: o.pass.offset(),
            depth: DepthState {
                func: CompareFunc::Always,
                write: false,
                ..Default::default()
            },
            shading: Shading::Immediate,
            ..Default::default()
        };
        let mut payload = Functions {
            size: o.pass.size,
            capacity: o.capacity as usize,
            tolerance: o.tolerance,
            casters: &casters,
            transmit: &transmit,
            state,
            built: 0,
            peak: 0,
        };
        self.maps
            .render(p, light_views(frame, o.pass.size), o.pass.size, &mut payload)?;
        self.peak = payload.peak;
        Ok(())
    }

    fn ran(&self) -> bool {
        !self.maps.is_empty()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let frags: u64 = self.maps.maps().iter().map(|(m, _)| m.fragments).sum();
        let verts: usize = self.maps.maps().iter().map(|(m, _)| m.vertices.len()).sum();
        let texels: usize = self.maps.maps().iter().map(|(m, _)| (m.size * m.size) as usize).sum();
        vec![
            ("fragments", frags as f64),
            ("vertices", verts as f64),
            // The lists' nodes before compression (what the pool held) and after.
            (
                "fragment-list bytes",
                (frags as usize * std::mem::size_of::<ListNode>()) as f64,
            ),
            (
                "light-space bytes",
                (verts * std::mem::size_of::<Vertex>() + texels * 4) as f64,
            ),
            // What one view's pool may hold at most (the `capacity` option), and the most
            // bytes held at once while building.
            (
                "pool capacity bytes",
                (self.opts.capacity as usize * std::mem::size_of::<ListNode>()) as f64,
            ),
            ("peak bytes", self.peak as f64),
        ]
    }

    fn stages(&self) -> Result<Vec<Stage>, Error> {
        let mut out = Vec::new();
        for (i, (m, _)) in self.maps.maps().iter().enumerate() {
            let n = (m.size * m.size) as usize;
            let count: Vec<f32> = (0..n).map(|t| (m.offsets[t + 1] - m.offsets[t]) as f32).collect();
            let hi = count.iter().copied().fold(1.0f32, f32::max);
            out.push(Stage::Scalar {
                name: format!("vertices_per_texel{i}"),
                data: Surface::from_vec(m.size, m.size, count)?,
                lo: 0.0,
                hi,
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compression_stays_within_the_tolerance_and_drops_vertices() {
        // Many faint layers: a staircase a line fits within a coarse tolerance.
        let mut frags: Vec<(f32, Vec3)> = (0..40).map(|k| (0.3 + 0.01 * k as f32, Vec3::splat(0.97))).collect();
        let v = step_vertices(&mut frags);
        for eps in [0.001, 0.01, 0.05] {
            let c = compress(&v, eps);
            for z in (0..=1000).map(|k| k as f32 / 1000.0) {
                let (a, b) = (evaluate(&v, z), evaluate(&c, z));
                assert!(
                    (a - b).abs().max_element() <= eps * 2.0 + 1e-5,
                    "eps {eps} at {z}: {a} vs {b}"
                );
            }
            if eps >= 0.01 {
                assert!(c.len() < v.len(), "eps {eps}: {} of {} vertices", c.len(), v.len());
            }
        }
        assert!(compress(&v, 0.05).len() < compress(&v, 0.001).len());
        // An opaque step stays a step.
        let mut one = vec![(0.5, Vec3::ZERO)];
        let c = compress(&step_vertices(&mut one), 0.01);
        assert_eq!(evaluate(&c, 0.4), Vec3::ONE);
        assert_eq!(evaluate(&c, 0.6), Vec3::ZERO);
    }
}
