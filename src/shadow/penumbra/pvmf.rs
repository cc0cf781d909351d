//! Penumbra volume mask filtering (Cournia 2005, chapter 5): five steps.
//!
//! 1. **Depth map** from the light's centre (the shadow map's light pass). The text renders
//!    back faces only, second-depth shadow mapping (5.5, `layer=second`), and names midpoint
//!    shadow maps as future work (`layer=midpoint`, the default here: second depth leaks
//!    light through open surfaces, which most scenes have); `layer=first` is the plain map.
//! 2. **Penumbra volume mask** (5.1). Every light-space silhouette edge `e0 e1`
//!    ([`super::silhouettes`], the shadow volumes' adjacency) gives its own volume, with no
//!    neighbour: the end points are moved toward the light by the same distance,
//!    `ê_i = e_i - min(|e0 - l|, |e1 - l|) (e_i - l) / |e_i - l| s_e` (`spread` = s_e in
//!    (0, 1]); then `e = (ê1 - ê0) / |...|`, `v = (ê0 - l) / |...|`, `n = v x e`, and the
//!    four extrusion vectors `v0∓ = (ê0 - l + e ∓ n) / |...|`, `v1∓ = (ê1 - l - e ∓ n) / |...|`
//!    give an outer quad `ê0, ê0 + w v0-, ê1 + w v1-, ê1` and an inner one
//!    `ê1, ê1 + w v1+, ê0 + w v0+, ê0`, `w` at infinity (homogeneous `w = 0`, kept by the
//!    pipeline's depth clamp). The text's `e` and `n` are unit vectors in its scene's units,
//!    which makes the volumes' width depend on the scene's scale; here they are scaled by the
//!    light's radius `r`, so that the quads leave the moved points at the penumbra's own angle
//!    `r / |ê - l|` (wider than the true `r / |e - l|` by `1 / (1 - s_e)` at the nearer end)
//!    whatever the units. The quads are rendered from the light in one pass into the mask:
//!    depth, and the edge's distance from the light `d_e = min(|e0 - l|, |e1 - l|)` in a float
//!    channel.
//! 3. **Visibility estimate** (5.2). A pixel behind the mask's depth (inside a volume) or
//!    shadowed by the depth map is filtered; every other pixel is lit with no filtering (the
//!    method's speed). The filter width in the map is
//!    `w_pcf = s_p (d_r - d_o) r / (2 d_o d_r tan(α / 2))` (`scale` = s_p): `d_r` the
//!    receiver's distance from the light, `d_o` the mean of the `d_e` found in the
//!    `(2 region + 1)²` mask texels around the pixel's projection, and `2 d_r tan(α / 2)` the
//!    map's width at the receiver, here the world size of `size` texels there. The formula's
//!    penumbra is `(d_r - d_o) r / d_o`, half the width a light of diameter `2r` casts
//!    (RTR eq. 7.6), so `s_p = 2` (the default) is the physical width. The filter is an
//!    `n_pcf x n_pcf` grid of cells `w_pcf / n_pcf` square, one 2x2 comparison per cell at a
//!    position jittered inside it (hashed from the pixel and the cell; `jitter=false`: the
//!    cell centres, which bands, fig. 5.3). Filtered pixels with no volume texel around are
//!    deep in an umbra: their width is 0 (one comparison).
//!    Before its taps, a filter's footprint is classified on the map's hierarchy
//!    (`hierarchy`, the shadow map's [`crate::shadow::sample::planes::PlaneChain`]): fully lit or
//!    fully shadowed, its result is exactly 1 or 0 with no tap (not in the text; the same image).
//! 4. **Noise reduction** (5.3). The filtered pixels are blurred,
//!    `v = 1/b_s Σ_{i,j = -n_blur/2}^{n_blur/2} S(u + i, v + j) B(u, v, u + i, v + j)` with
//!    `B = 1` where the two pixels' ids are equal and `b_s` the number of such samples,
//!    separably as the text's implementation does (a horizontal pass, then a vertical one, each
//!    `n_blur + 1` samples). The ids are the G-buffer's objects, or (`ids=group`) runs of
//!    `group` consecutive triangles of an object, the per-triangle-group ids the text suggests
//!    for complex objects. The text's `n_blur` is 12 (`blur=12`); the default here is 0, no
//!    blur, which lets shadows bleed nowhere but leaves the noise: across generated scenes the
//!    blur's widening costs more than the noise does ([`Options::blur`]).
//! 5. **Compositing**: the visibility buffer modulates the light's centre as a point light
//!    (the frame's shading).
//!
//! A radius of 0 (`light=0`, or a point, spot or directional light) makes no mask: every
//! pixel is one 2x2 comparison, exactly `shadow-map [filter=pcf2]` with the same map options.
//! Known failure (4.3, point 4, shared with PVM): one silhouette from the light's centre is
//! wrong for a light much larger than a nearby occluder.

use super::{
    light_and_silhouettes, light_field, render_views, silhouette_notes, volume_step, Extrusion, Quads, Silhouettes,
    VolumeMap,
};
use crate::frame::{Frame, NO_OBJECT};
use crate::hash::SplitMix;
use crate::pipeline::{Pipeline, Rgba8};
use crate::shadow::inspect::{self, NoTrace, Step, Trace};
use crate::shadow::light::{Layer, MapOptions};
use crate::shadow::pixels::{per_pixel, per_pixel_map};
use crate::shadow::sample::kernel::{bilinear_compare, Class};
use crate::shadow::sample::lookup::{lookup_fields, At, Bias, MapLookup, Prepared, Setup, Wide};
use crate::shadow::technique::{Declaration, Entry, Field, ShadowTechnique, Stage, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;
use glam::{Vec2, Vec3};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "pvmf",
    summary: "penumbra volume mask filtering (Cournia 2005 ch. 5): PCF as wide as the penumbra inside a volume mask, object-aware blur",
    sweep: &[&[], &[("size", "2048")], &[("blur", "12")]],
    extended: &[
        &[("pcf", "3")],
        &[("jitter", "false")],
        &[("layer", "second")],
        &[("layer", "first")],
        &[("pcf", "12"), ("size", "1024")],
        &[("spread", "1")],
        &[("ids", "group"), ("blur", "12")],
        &[("blur", "4")],
    ],
    ..super::BASE
};

/// Options of penumbra volume mask filtering.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The depth map's pass; the mask has the same size. Default: its defaults with
    /// `size=512`.
    pub map: MapOptions,
    /// Normal-offset and receiver-plane bias. Default: none.
    pub bias: Bias,
    /// What pass 1's map stores. Default: midpoint. The text's second depth (`layer=second`)
    /// leaks light through open surfaces (planes, sheets, terrain patches): on generated
    /// scenes under hard lights it was up to 9.8 % wrong where the plain map is 0.9 %, and
    /// on the area fixtures midpoint is as close to the reference (`tests/random.rs`).
    pub layer: Layer,
    /// The bias cone across the filter, and the hierarchy: it classifies each filter's
    /// footprint first and skips the taps of one fully lit or fully shadowed (the same image,
    /// fewer taps). Default: no cone, the hierarchy on.
    pub wide: Wide,
    /// The light's radius as a multiple of half the scene's area light width (0: the hard
    /// shadow map). Default: 1.
    pub light: f32,
    /// `s_e` in (0, 1]: how far the edge points move toward the light (the volumes'
    /// overestimation). The text gives no value. Default: 0.5. Measured over contact, overlap,
    /// forest, pergola and big_light, 0.05 to 0.25 change the penumbra RMSE by at most 0.004
    /// and filter fewer pixels (forest: 35 against 99 ms), but the tighter mask cuts
    /// penumbrae off where the filter still sees an edge: on forest 0.1 jumps 10 times as
    /// much (0.0088 against 0.0008) and bleeds more.
    pub spread: f32,
    /// `s_p`: the filter width's scale (2: the physical penumbra). Default: 2.
    pub scale: f32,
    /// Mask texels each side of the pixel's projection averaged for `d_o`. Default: 1.
    pub region: u32,
    /// `n_pcf`: filter cells per axis. Default: 7 (the text's).
    pub pcf: u32,
    /// Jitter each filter tap inside its cell. Default: true.
    pub jitter: bool,
    /// `n_blur`: blur samples per axis (0: no blur). Default: 0. The text's 12 (`blur=12`)
    /// hides the jittered filter's noise but widens narrow penumbrae by up to 12 screen
    /// pixels: across generated area-light scenes (`penumbra defaults`) it doubled PVMF's
    /// penumbra RMSE (mean 0.257 against 0.125 unblurred at 320x180, the hard map 0.271),
    /// and on the area fixtures it was 0.109 against 0.083.
    pub blur: u32,
    /// The blur's ids. Default: object.
    pub ids: Ids,
    /// Triangles per id with `ids=group`. Default: 64.
    pub group: u32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            map: MapOptions {
                size: 512,
                ..Default::default()
            },
            bias: Bias::default(),
            layer: Layer::Midpoint,
            wide: Wide {
                cone: 0.0,
                hierarchy: true,
            },
            light: 1.0,
            spread: 0.5,
            scale: 2.0,
            region: 1,
            pcf: 7,
            jitter: true,
            blur: 0,
            ids: Ids::Object,
            group: 64,
        }
    }
}

crate::choice_enum! {
    /// What the blur's `B(u, v, s, t)` compares (Cournia 5.3).
    pub enum Ids {
        /// The G-buffer's object index.
        Object = "object",
        /// The object and its triangle index divided by `group`.
        Group = "group",
        /// One id for every surface: the uniform blur the text warns against (shadows bleed
        /// onto lit objects), for comparison.
        None = "none",
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = lookup_fields(
        |o: &mut Options| &mut o.map,
        |o: &mut Options| &mut o.bias,
        |o: &mut Options| &mut o.wide,
    );
    fields.extend([
        Field::new(
            "layer",
            "pass 1: first, second (back faces, the text's) or midpoint depth (the default)",
            |o: &mut Options| &mut o.layer,
        ),
        light_field(|o: &mut Options| &mut o.light),
        Field::above(
            "spread",
            "s_e in (0, 1]: edge points moved toward the light (the mask's overestimation)",
            0.0,
            1.0,
            |o: &mut Options| &mut o.spread,
        ),
        Field::range(
            "scale",
            "s_p: filter width scale (2: the physical penumbra)",
            0.0,
            100.0,
            |o: &mut Options| &mut o.scale,
        ),
        Field::range(
            "region",
            "mask texels each side averaged for the edge distance d_o",
            0,
            8,
            |o: &mut Options| &mut o.region,
        ),
        Field::range("pcf", "n_pcf: filter cells per axis", 1, 32, |o: &mut Options| {
            &mut o.pcf
        }),
        Field::new("jitter", "jitter each filter tap inside its cell", |o: &mut Options| {
            &mut o.jitter
        }),
        Field::range(
            "blur",
            "n_blur: blur samples per axis (0: no blur)",
            0,
            64,
            |o: &mut Options| &mut o.blur,
        ),
        Field::new(
            "ids",
            "the blur's ids: object, group (runs of `group` triangles) or none (uniform blur)",
            |o: &mut Options| &mut o.ids,
        ),
        Field::range(
            "group",
            "triangles per id with ids=group",
            1,
            1 << 24,
            |o: &mut Options| &mut o.group,
        ),
    ]);
    Declaration::new("pvmf", fields)
}

/// The moved end points and the four extrusion vectors of one edge (Cournia 5.1).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MaskVolume {
    /// `ê0`, `ê1`: the end points moved toward the light.
    pub ends: [Vec3; 2],
    /// `v0-`, `v1-` (outer) and `v0+`, `v1+` (inner): the two quads' extrusion vectors.
    pub vectors: Extrusion,
    /// `d_e`: the edge's distance from the light.
    pub distance: f32,
}

/// One edge's mask volume for light centre `l`, radius `r` and spread `s_e` (Cournia 5.1;
/// `e` and `n` scaled by `r`, see the module docs).
pub fn mask_volume(e0: Vec3, e1: Vec3, l: Vec3, r: f32, s_e: f32) -> MaskVolume {
    let (l0, l1) = ((e0 - l).length(), (e1 - l).length());
    let d_e = l0.min(l1);
    let moved = |p: Vec3, len: f32| p - (p - l) / len.max(f32::MIN_POSITIVE) * (d_e * s_e);
    let (h0, h1) = (moved(e0, l0), moved(e1, l1));
    // When s_e = 1 moves both points onto the light, the edge's own direction stands in.
    let e = (h1 - h0)
        .try_normalize()
        .unwrap_or_else(|| (e1 - e0).normalize_or_zero());
    // The moved point lies on the ray from the light through e0, so v is that ray's direction;
    // taking it from e0 keeps it defined when s_e = 1 puts the moved point on the light.
    let v = (e0 - l).normalize_or_zero();
    let n = v.cross(e);
    let (e, n) = (e * r, n * r);
    let dir = |p: Vec3, side: Vec3| (p - l + side).normalize_or_zero();
    MaskVolume {
        ends: [h0, h1],
        vectors: Extrusion {
            outer: [dir(h0, e - n), dir(h1, -e - n)],
            inner: [dir(h0, e + n), dir(h1, -e + n)],
        },
        distance: d_e,
    }
}

/// Every edge's outer and inner quads, each writing its edge's `d_e`.
pub fn mask_quads(s: &Silhouettes, l: Vec3, r: f32, s_e: f32) -> (Vec<MaskVolume>, Quads) {
    let mut q = Quads::default();
    let vols: Vec<MaskVolume> = s.edges.iter().map(|e| mask_volume(e.a, e.b, l, r, s_e)).collect();
    for m in &vols {
        // End points at w = 1, extrusion vectors at w = 0 (points at infinity).
        let [h0, h1] = m.ends.map(|h| h.extend(1.0));
        let (o, i) = (
            m.vectors.outer.map(|v| v.extend(0.0)),
            m.vectors.inner.map(|v| v.extend(0.0)),
        );
        q.push([h0, o[0], o[1], h1], m.distance);
        q.push([h1, i[1], i[0], h0], m.distance);
    }
    (vols, q)
}

/// The `n x n` grid cell `(i, j)`'s tap, in texels from the centre of a `w`-texel filter:
/// jittered inside the cell by `(ju, jv)` in [0, 1)², or at its centre with `(0.5, 0.5)`.
#[inline]
pub fn grid_tap(i: u32, j: u32, n: u32, w: f32, ju: f32, jv: f32) -> Vec2 {
    let cell = w / n as f32;
    Vec2::new(-0.5 * w + (i as f32 + ju) * cell, -0.5 * w + (j as f32 + jv) * cell)
}

/// What the visibility estimate found at one pixel.
#[derive(Copy, Clone, Debug, PartialEq)]
enum Found {
    /// Not filtered: no geometry (NaN), decided before any lookup, or lit outside the mask.
    Plain(f32),
    /// Filtered: the mean edge distance (NaN: none around), the width in texels, the taps and
    /// the visibility.
    Filtered { d_o: f32, w: f32, taps: u32, v: f32 },
}

impl Found {
    fn value(self) -> f32 {
        match self {
            Found::Plain(v) | Found::Filtered { v, .. } => v,
        }
    }
}

/// Penumbra volume mask filtering (see the module docs).
pub struct Pvmf {
    opts: Options,
    lookup: MapLookup,
    sil: Silhouettes,
    vols: Vec<MaskVolume>,
    masks: Vec<VolumeMap>,
    radius: f32,
    /// The visibility estimate before the blur, its horizontal pass, and which pixels were
    /// filtered (the blur mask), of the last run.
    raw: Vec<f32>,
    horizontal: Vec<f32>,
    filtered: Vec<bool>,
    ids: Vec<u64>,
    taps: u64,
    covered: u64,
    times: Vec<(&'static str, f64)>,
}

impl Pvmf {
    /// Penumbra volume mask filtering with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Pvmf, Error> {
        declaration().check(&opts)?;
        if opts.layer == Layer::Id {
            return Err(declaration().error("layer", "id", "stores no depth to filter (first, second or midpoint)"));
        }
        // Wide kernels: the lookup prepares the receiver plane and cone of the taps.
        let lookup = MapLookup::new(Setup {
            map: opts.map.clone(),
            layer: opts.layer,
            bias: opts.bias,
            wide: Some(opts.wide),
            min_max: false,
        });
        Ok(Pvmf {
            opts,
            lookup,
            sil: Silhouettes::default(),
            vols: Vec::new(),
            masks: Vec::new(),
            radius: 0.0,
            raw: Vec::new(),
            horizontal: Vec::new(),
            filtered: Vec::new(),
            ids: Vec::new(),
            taps: 0,
            covered: 0,
            times: Vec::new(),
        })
    }

    /// The light's radius of the last run (0: hard shadows).
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The mean `d_e` of the mask texels around `uv` (NaN: none), and how many were found.
    fn edge_distance(&self, mask: &VolumeMap, uv: Vec2) -> (f32, u32) {
        let size = mask.texel.width() as i64;
        let (cx, cy) = ((uv.x * size as f32).floor() as i64, (uv.y * size as f32).floor() as i64);
        let k = self.opts.region as i64;
        let (mut sum, mut n) = (0.0f32, 0u32);
        for ty in (cy - k).max(0)..=(cy + k).min(size - 1) {
            for tx in (cx - k).max(0)..=(cx + k).min(size - 1) {
                let d = mask.texel.at(tx as u32, ty as u32);
                if d >= 0.0 {
                    sum += d;
                    n += 1;
                }
            }
        }
        (if n > 0 { sum / n as f32 } else { f32::NAN }, n)
    }

    /// Steps 3's filter at a prepared lookup: `n_pcf²` jittered 2x2 comparisons over `w`
    /// texels, unless the map's hierarchy decides the footprint; returns the visibility and the
    /// taps taken.
    fn filter(&self, at: &At, w: f32, x: usize, y: usize, t: &mut impl Trace) -> (f32, u32) {
        // Every tap lies within w / 2 texels of the centre.
        match self.lookup.classify(at, 0.5 * w, t) {
            Class::Lit => return (1.0, 1),
            Class::Shadowed => return (0.0, 1),
            Class::Mixed => {}
        }
        let map = &self.lookup.maps()[at.face].0;
        let inv = 1.0 / map.width() as f32;
        let n = self.opts.pcf;
        let mut rng = SplitMix(((y as u64) << 32 | x as u64) ^ 0x5056_4d46);
        let mut sum = 0.0f32;
        for j in 0..n {
            for i in 0..n {
                let (ju, jv) = if self.opts.jitter {
                    (rng.next_f32(), rng.next_f32())
                } else {
                    (0.5, 0.5)
                };
                let d = grid_tap(i, j, n, w, ju, jv);
                sum += bilinear_compare(map, at.uv + d * inv, at.r.at(d));
            }
        }
        (sum / (n * n) as f32, n * n)
    }

    /// Step 3 at one pixel; every step reported to `t`.
    fn lookup(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> Found {
        let at = match self.lookup.prepare(frame, x, y, t) {
            Prepared::Done(v, _) => return Found::Plain(v),
            Prepared::At(at) => at,
        };
        let (map, view) = &self.lookup.maps()[at.face];
        let hard = bilinear_compare(map, at.uv, at.r.z);
        let Some(mask) = self.masks.get(at.face) else {
            t.step(|| Step::new("hard", "no light radius: one 2x2 comparison, no mask").num("visibility", hard));
            return Found::Plain(hard);
        };
        let size = mask.depth.width();
        let on_map = at.uv.cmpge(Vec2::ZERO).all() && at.uv.cmplt(Vec2::ONE).all();
        let (md, de) = if on_map {
            let (tx, ty) = ((at.uv.x * size as f32) as u32, (at.uv.y * size as f32) as u32);
            (mask.depth.at(tx, ty), mask.texel.at(tx, ty))
        } else {
            (1.0, -1.0)
        };
        let inside = de >= 0.0 && md < at.r.z;
        t.step(|| {
            Step::new(
                "penumbra volume mask",
                "inside a volume when the mask's depth is in front of the point (5.2); or shadowed by the depth map",
            )
            .num("mask depth", md)
            .num("point depth", at.r.z)
            .flag("inside a volume", inside)
            .num("depth map 2x2 comparison", hard)
        });
        if !inside && hard >= 1.0 {
            t.step(|| Step::new("unmasked", "outside every volume and lit: no filtering").num("visibility", 1.0));
            return Found::Plain(1.0);
        }
        let (d_o, found) = self.edge_distance(mask, at.uv);
        let d_r = (at.pos - frame.light.position).length();
        // Eq. of 5.2: w_pcf = s_p (d_r - d_o) r / (2 d_o d_r tan(α/2)) of the map's width; in
        // texels, with the map's width at the receiver `size * texel_at`.
        let texel = view.texel_at(&frame.light, at.pos);
        let w = if found > 0 {
            (self.opts.scale * (d_r - d_o).max(0.0) * self.radius / (d_o * texel).max(1e-12)).min(size as f32)
        } else {
            0.0
        };
        let (v, taps) = if w > 0.0 {
            self.filter(&at, w, x, y, t)
        } else {
            (hard, 1)
        };
        t.step(|| {
            Step::new(
                "filter width",
                "d_o: the mean edge distance d_e of the mask texels around; w_pcf = s_p (d_r - d_o) r / (2 d_o d_r tan(a/2))",
            )
            .int("edge distances found", found)
            .num("d_o", d_o)
            .num("d_r", d_r)
            .num("light radius", self.radius)
            .num("w_pcf (texels)", w)
        });
        t.step(|| {
            Step::new(
                "jittered PCF",
                "n_pcf x n_pcf cells of w_pcf / n_pcf texels, one 2x2 comparison per cell (5.2)",
            )
            .int("taps", taps)
            .flag("jitter", self.opts.jitter)
            .num("visibility estimate", v)
        });
        Found::Filtered { d_o, w, taps, v }
    }

    /// The blur's id of pixel `i` (5.3): its object, or its object and triangle group.
    fn id(&self, frame: &Frame, i: usize) -> u64 {
        let o = frame.gbuffer.object.data()[i];
        match self.opts.ids {
            Ids::Object => o as u64,
            Ids::None if o == NO_OBJECT => u64::MAX,
            Ids::None => 0,
            Ids::Group if o == NO_OBJECT => u64::MAX,
            Ids::Group => ((o as u64) << 32) | (frame.gbuffer.prim.data()[i] / self.opts.group) as u64,
        }
    }

    /// One separable pass of the blur `B` (5.3) at pixel `(x, y)` of `src`: a filtered pixel
    /// becomes the mean of the finite samples within `n_blur / 2` along the axis that share
    /// its id; any other pixel keeps its value.
    fn blur_at(&self, frame: &Frame, src: &[f32], x: usize, y: usize, horizontal: bool) -> f32 {
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let i = y * w + x;
        if !self.filtered[i] {
            return src[i];
        }
        let half = (self.opts.blur / 2) as usize;
        let (id, (mut sum, mut n)) = (self.ids[i], (0.0f32, 0u32));
        let (c, len) = if horizontal { (x, w) } else { (y, h) };
        for k in c.saturating_sub(half)..=(c + half).min(len - 1) {
            let j = if horizontal { y * w + k } else { k * w + x };
            if self.ids[j] == id && src[j].is_finite() {
                sum += src[j];
                n += 1;
            }
        }
        if n > 0 {
            sum / n as f32
        } else {
            src[i]
        }
    }
}

impl ShadowTechnique for Pvmf {
    fn name(&self) -> &'static str {
        "pvmf"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        self.masks.clear();
        self.vols.clear();
        let mut quads = Quads::default();
        (self.radius, self.sil) = light_and_silhouettes(p, frame, &mut self.lookup, self.opts.light, &mut passes)?;
        if self.radius > 0.0 {
            (self.vols, quads) = mask_quads(&self.sil, frame.light.position, self.radius, self.opts.spread);
        }
        passes.end("volume construction");
        if self.radius > 0.0 {
            self.masks = render_views(p, &quads, &self.lookup, self.opts.map.size)?;
        }
        passes.end("volume rendering");
        let this = &*self;
        let pass = per_pixel_map(p, frame, |x, y| match this.lookup(frame, x, y, &mut NoTrace) {
            Found::Plain(v) => (v, 0u32),
            Found::Filtered { taps, v, .. } => (v, taps),
        });
        self.taps = pass.iter().map(|&(_, t)| t as u64).sum();
        let raw: Vec<f32> = pass.iter().map(|&(v, _)| v).collect();
        // The blur mask: the pixels step 3 filtered.
        self.filtered = pass.iter().map(|&(_, t)| t > 0).collect();
        let any = self.filtered.iter().any(|&f| f);
        let n = raw.len();
        self.covered = frame.points().iter().filter(|p| p.is_some()).count() as u64;
        passes.end("visibility");
        let out = if self.opts.blur > 0 && any {
            self.ids = (0..n).map(|i| self.id(frame, i)).collect();
            let this = &*self;
            let h = per_pixel(p, frame, |x, y| this.blur_at(frame, &raw, x, y, true));
            let v = per_pixel(p, frame, |x, y| this.blur_at(frame, &h, x, y, false));
            self.horizontal = h;
            v
        } else {
            self.ids.clear();
            self.horizontal.clear();
            raw.clone()
        };
        self.raw = raw;
        passes.end("blur");
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let header = || volume_step(&self.lookup, self.radius, &self.sil).num("s_e", self.opts.spread);
        inspect::closed(|t| {
            self.lookup.explain(t, header, |t| {
            let f = self.lookup(frame, x as usize, y as usize, t);
            let i = y as usize * frame.width() as usize + x as usize;
            if !matches!(f, Found::Filtered { .. }) || self.horizontal.is_empty() {
                return f.value();
            }
            let final_v = self.blur_at(frame, &self.horizontal, x as usize, y as usize, false);
            t.step(|| {
                Step::new(
                    "id-aware blur",
                    "B(u, v, s, t) = 1 where the ids agree; a horizontal then a vertical pass of n_blur + 1 samples (5.3)",
                )
                .text("ids", self.opts.ids.as_str())
                .int("id", self.ids[i] as usize)
                .num("before", self.raw[i])
                .num("after the horizontal pass", self.horizontal[i])
                .num("after the vertical pass", final_v)
            });
            final_v
        })
        })
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn notes(&self) -> Vec<String> {
        silhouette_notes(&self.sil, "its open edges extrude as silhouettes")
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let filtered = self.filtered.iter().filter(|&&f| f).count() as f64;
        vec![
            ("map texels", self.lookup.texels() as f64),
            ("silhouette edges", self.sil.edges.len() as f64),
            ("mask quads", 2.0 * self.vols.len() as f64),
            (
                "mask fragments",
                self.masks.iter().map(|v| v.fragments).sum::<u64>() as f64,
            ),
            ("filtered pixels", filtered),
            ("filtered fraction", filtered / (self.covered.max(1) as f64)),
            ("taps", self.taps as f64),
            (
                "blurred pixels",
                if self.horizontal.is_empty() { 0.0 } else { filtered },
            ),
        ]
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v = self.lookup.stages(p, frame)?;
        for (i, m) in self.masks.iter().enumerate() {
            let Some(depth) = m.depth_stage(format!("mask_depth{i}")) else {
                continue;
            };
            v.push(depth);
            let finite = m.texel.data().iter().copied().filter(|&d| d >= 0.0);
            let (lo, hi) = finite.fold((f32::MAX, 0.0f32), |(a, b), d| (a.min(d), b.max(d)));
            v.push(Stage::Scalar {
                name: format!("edge_distance{i}"),
                data: m.texel.map(|d| if d >= 0.0 { d } else { f32::NAN }),
                lo,
                hi,
            });
        }
        if self.masks.is_empty() {
            return Ok(v);
        }
        let width = per_pixel(p, frame, |x, y| match self.lookup(frame, x, y, &mut NoTrace) {
            Found::Filtered { w, .. } => w,
            Found::Plain(_) => f32::NAN,
        });
        let hi = width.iter().copied().filter(|w| w.is_finite()).fold(1.0f32, f32::max);
        v.push(Stage::pixels(frame, "filter_width", width, 0.0, hi)?);
        let mask = self.filtered.iter().map(|&f| if f { 1.0 } else { 0.0 }).collect();
        v.push(Stage::pixels(frame, "blur_mask", mask, 0.0, 1.0)?);
        v.push(Stage::pixels(
            frame,
            "visibility_unblurred",
            self.raw.clone(),
            0.0,
            1.0,
        )?);
        if !self.ids.is_empty() {
            let colour = |id: u64| -> Rgba8 {
                if id == u64::MAX || id == NO_OBJECT as u64 {
                    return [0, 0, 0, 255];
                }
                let h = SplitMix(id).next_u64();
                [h as u8 | 64, (h >> 8) as u8 | 64, (h >> 16) as u8 | 64, 255]
            };
            let data = crate::pipeline::Surface::from_vec(
                frame.width(),
                frame.height(),
                self.ids.iter().map(|&id| colour(id)).collect(),
            )?;
            v.push(Stage::Color {
                name: "blur_ids".into(),
                data,
            });
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mask_volumes_enclose_the_penumbra_wedge_and_grids_cover_their_cells() {
        // An edge along x at height 1 under a light at height 5 of radius 0.5: the penumbra's
        // half-angle at the edge is r / 4; the quads leave the moved points at r / |ê - l|.
        let (l, r) = (Vec3::new(0.0, 5.0, 0.0), 0.5);
        let (a, b) = (Vec3::new(-1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0));
        for s_e in [0.25f32, 0.5, 1.0] {
            let m = mask_volume(a, b, l, r, s_e);
            let d = (a - l).length();
            assert!((m.distance - d).abs() < 1e-5);
            assert!(((m.ends[0] - l).length() - d * (1.0 - s_e)).abs() < 1e-4, "{s_e}");
            // The outer and inner vectors lie on opposite sides of the hard shadow plane
            // (z = 0) at an angle from the ray at least the penumbra's.
            for k in 0..2 {
                let ray = ((if k == 0 { a } else { b }) - l).normalize();
                let (o, i) = (m.vectors.outer[k], m.vectors.inner[k]);
                assert!(o.z * i.z < 0.0, "{s_e} {k}: {o} {i}");
                for v in [o, i] {
                    let off = v.cross(ray).length();
                    assert!(off >= r / d - 1e-4, "{s_e} {k}: {off}");
                }
            }
        }
        // Grid taps: centred cells without jitter, inside their cells with it.
        let taps: Vec<Vec2> = (0..3).map(|i| grid_tap(i, 1, 3, 6.0, 0.5, 0.5)).collect();
        assert_eq!(
            taps,
            vec![Vec2::new(-2.0, 0.0), Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0)]
        );
        let t = grid_tap(2, 0, 3, 6.0, 0.99, 0.0);
        assert!(t.x > 1.0 && t.x < 3.0 && t.y == -3.0, "{t}");
    }
}
