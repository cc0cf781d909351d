//! The irregular z-buffer (Johnson et al. 2005; Aila and Laine 2004; Sintorn et al. 2008;
//! Wyman et al. 2015; RTR 7.9): exact hard shadows at the camera's own sample points.
//!
//! A shadow map samples visibility on the light's regular grid and the camera then looks the
//! grid up at other points, which is where acne, aliasing and bias come from. The irregular
//! z-buffer turns this around: the camera's sample points are inserted into a light-space
//! grid as they are (irregularly), and the occluders are rasterized into the same grid, each
//! covered texel testing its own samples against the occluding triangle exactly.
//!
//! Pass by pass:
//! 1. **Samples**: one per pixel (the G-buffer's point) or `k` per pixel (4, 16, 32) at
//!    stratified sub-pixel positions, each the pixel's sub-sample camera ray intersected with
//!    the pixel's tangent plane (position and normal), as Wyman et al. place them. Samples
//!    whose normal faces away from the light are unlit and never inserted.
//! 2. **Grid**: the light's view ([`crate::shadow::light::light_views`]: orthographic for a
//!    directional light, six cube faces for point, area and spot lights, since samples may lie
//!    outside a spot's cone) cropped to the light-space bounds of its samples ("tight bounds
//!    are formed from this set", RTR 7.9), `size` x `size` texels; a cube face without samples
//!    is skipped. A sample's texel comes from its uv in the uncropped view (found once, with
//!    the bounds) through the crop's scale and offset.
//! 3. **Lists**: each sample goes into the list of the texel it projects to. The lists are a
//!    deterministic counting sort by texel (count, prefix sum, fill in sample order) into one
//!    pool (the pipeline's indexed [`PixelStore`]), so list order is the samples' order and
//!    never depends on the thread count. The sort runs in parallel in two stable steps (by
//!    texel row over chunks of samples cut by a rule of their count alone, then by column
//!    within each row, which also lays out the row's part of the store,
//!    [`PixelStore::rebuild_rows`]), which give the serial sort's lists exactly. Each
//!    sample's record (ray origin and own triangle) travels with it through both steps, so
//!    neither gathers from the samples. (Drawing the points into the pipeline's fragment
//!    lists would give the same order, at the cost of a node per sample and a pass to copy
//!    the nodes into the store the occluder pass needs.)
//! 4. **Occluder pass**: every caster triangle is drawn through the pipeline into the grid
//!    with *conservative* rasterization (every texel the triangle touches gets a fragment), and
//!    the fragment program, through the pipeline's raster-ordered storage
//!    ([`Pipeline::draw_ordered`]), walks the texel's samples and tests each against the
//!    triangle exactly: the segment from the sample to the light (for a directional light, the
//!    ray against its direction) intersects the triangle strictly in front of the sample
//!    (Möller–Trumbore, `t > 0`). Standard rasterization is an option, to show why it is not
//!    enough: a triangle thinner than a texel misses the texel centres and its shadow breaks.
//!    Two things keep the pass's work down without changing a result:
//!    - a **depth cull** (the light-space depth test of Wyman et al.'s frustum-traced
//!      shadows): each texel keeps the largest depth along the light's axis of its samples
//!      still lit, and a fragment of a triangle whose nearest vertex lies beyond it (by a
//!      margin far above rounding) cannot shadow any of them and returns at once; a texel
//!      whose samples are all shadowed culls every later fragment;
//!    - the texel's samples are tested **four at a time** without a branch per sample, each
//!      lane with the one-sample operations, and a list sample is 16 bytes (its ray origin,
//!      and one word that holds its own triangle while it is lit and its shadower after).
//!
//! No depth bias anywhere. A sample is never tested against the triangle it lies on (the
//! G-buffer's primitive id) where that triangle faces the light. Closed meshes (checked with
//! the shadow volumes' edge adjacency, [`crate::shadow::volume::silhouette::Adjacency`], after
//! it drops zero-area triangles, which cover nothing: a UV sphere's pole triangles) cast
//! only through their triangles that face away from the light: a ray blocked by a closed
//! object crosses one of them (Sintorn et al.: "no bias for closed objects"). Open meshes and
//! two-sided sheets cast through every triangle. Where a sample's own triangle faces away from
//! the light while its interpolated normal faces it (the terminator of a tessellated sphere,
//! the far side of a heightfield's ridge), the sample's ray leaves through the back of its own
//! surface and the triangle is tested like any other. The ray starts where the reference's
//! does: the point moved a few ULPs along its normal (Wächter and Binder 2019), a property of
//! float numbers that does not depend on the scene, the light or the grid. Coplanar contact (a
//! box resting on the ground) needs nothing: the ground under the box is shadowed by the box's
//! top, and the box's bottom faces away from the light.
//!
//! Known failure: long lists. Where receivers are seen at a grazing angle from the light, or
//! the camera's samples crowd into few light texels (`long_view`, `grazing`), lists grow and
//! so does the occluder pass; `counters` reports list lengths, `dump` their image.

use crate::choice_enum;
use crate::frame::{Frame, NO_OBJECT};
use crate::pipeline::wide::Vec3x4;
use crate::pipeline::*;
use crate::reference::{offset_origin, SamplePoint};
use crate::scene::{Light, LightKind};
use crate::shadow::inspect::{self, NoTrace, Step, Steps, Trace};
use crate::shadow::light::{self, light_views, merged_casters, LightView};
use crate::shadow::pass::Pass;
use crate::shadow::timing::Passes;
use crate::shadow::volume::silhouette::Adjacency;
use crate::shadow::Stage;
use glam::{BVec4A, Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;

choice_enum! {
    /// Samples per pixel.
    pub enum SamplesPerPixel {
        /// The G-buffer's point.
        One = "1",
        /// 2 x 2 strata.
        Four = "4",
        /// 4 x 4 strata.
        Sixteen = "16",
        /// 8 x 4 strata.
        ThirtyTwo = "32",
    }
}

impl SamplesPerPixel {
    /// The count.
    pub fn count(self) -> usize {
        match self {
            SamplesPerPixel::One => 1,
            SamplesPerPixel::Four => 4,
            SamplesPerPixel::Sixteen => 16,
            SamplesPerPixel::ThirtyTwo => 32,
        }
    }

    /// Strata columns and rows.
    fn grid(self) -> (usize, usize) {
        match self {
            SamplesPerPixel::One => (1, 1),
            SamplesPerPixel::Four => (2, 2),
            SamplesPerPixel::Sixteen => (4, 4),
            SamplesPerPixel::ThirtyTwo => (8, 4),
        }
    }
}

choice_enum! {
    /// How occluders are rasterized into the grid.
    pub enum OccluderRaster {
        /// Conservative overestimate: every texel the triangle touches (exact).
        Conservative = "conservative",
        /// Texel centres only (to show what breaks: thin occluders' shadows).
        Standard = "standard",
    }
}

/// Options of the irregular z-buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Light-space grid side in texels (per cube face for point lights). Default: 512: any
    /// size is exact; in the sweep over the fixtures (480x270 and the 960x540 spheres) and on
    /// the 1920x1080 benchmark, 512 was the fastest or within noise of it (256 makes lists
    /// long at 1080p, 1024 and more spend their time on empty texels).
    pub size: u32,
    /// Samples per pixel. Default: 1.
    pub samples: SamplesPerPixel,
    /// Occluder rasterization. Default: conservative.
    pub raster: OccluderRaster,
    /// Most samples the lists may hold (a frame with more is an error). Default: 16777216
    /// (16 M, 384 MiB of lists).
    pub capacity: u32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            size: 512,
            samples: SamplesPerPixel::One,
            raster: OccluderRaster::Conservative,
            capacity: 1 << 24,
        }
    }
}

/// A [`ListSample`]'s state from this value up: shadowed (by the triangle in the low bits).
const SHADOWED: u32 = 1 << 31;
/// A lit [`ListSample`]'s state when it has no triangle of its own to skip.
const NO_TRIANGLE: u32 = SHADOWED - 1;
/// A sample's pass-1 byte: its base view, and [`META_SKIP_OWN`] when it skips its own
/// triangle; [`META_NONE`]: it faces away from the light (or falls in no view).
const META_NONE: u8 = 0x7f;
const META_SKIP_OWN: u8 = 0x80;
/// The counting sort's chunks: at most this many, of at least [`MIN_CHUNK`] samples (a rule
/// of the sample count alone, so the sort's work is cut the same way for any thread count).
const MAX_CHUNKS: usize = 64;
const MIN_CHUNK: usize = 16384;

/// One sample in a texel's list: 16 bytes, so that the occluder pass, which walks the lists
/// of a tile's texels again and again, keeps more of them in cache.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ListSample {
    /// World position (where its ray to the light starts).
    pub position: Vec3,
    /// Below [`SHADOWED`]: lit so far, and the scene-wide id of the triangle it lies on and
    /// is never tested against ([`NO_TRIANGLE`]: none). From [`SHADOWED`] up: shadowed, by
    /// the triangle whose id is in the low 31 bits.
    state: u32,
}

impl ListSample {
    const EMPTY: ListSample = ListSample {
        position: Vec3::ZERO,
        state: NO_TRIANGLE,
    };

    /// The scene-wide id of the first triangle found to shadow the sample (`None`: lit).
    pub fn shadowed_by(&self) -> Option<u32> {
        (self.state >= SHADOWED).then_some(self.state & !SHADOWED)
    }
}

/// Per texel of a view, what its fragments of the occluder pass keep: the largest depth
/// along the view's axis ([`axis_depth`]) of its samples still lit (`-inf`: none; an
/// occluder whose nearest vertex lies clearly beyond it cannot shadow any of them), and the
/// triangle-sample tests run on its list.
#[derive(Copy, Clone, Debug)]
struct Texel {
    far: f32,
    /// (64 bits: a texel's list can hold millions of samples, each tested by many triangles.)
    tests: u64,
}

/// A camera sample: the pixel it belongs to, its surface point and triangle.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CameraSample {
    /// Row-major pixel index.
    pub pixel: u32,
    /// The point on the pixel's tangent plane, and the pixel's normal.
    pub point: SamplePoint,
    /// Scene-wide id of the triangle visible at the pixel.
    pub triangle: u32,
}

/// The camera samples of `frame`, `k` per covered pixel (pixel-major, strata row by row):
/// with one sample, the G-buffer's point; with more, stratified sub-pixel camera rays
/// intersected with the pixel's tangent plane (falling back to the G-buffer's point where the
/// plane is seen edge-on or the hit lands more than two pixels' footprint away).
pub fn camera_samples(frame: &Frame, k: SamplesPerPixel) -> Vec<CameraSample> {
    camera_samples_grid(frame, k.grid())
}

/// [`camera_samples`] on any `(columns, rows)` grid of sub-pixel strata (for supersampled
/// references: `(8, 8)` is 64 rays per pixel).
pub fn camera_samples_grid(frame: &Frame, grid: (usize, usize)) -> Vec<CameraSample> {
    let filler = SampleFiller {
        grid,
        ..SampleFiller::new(frame, SamplesPerPixel::One)
    };
    let w = frame.width() as usize;
    let mut out = Vec::new();
    for (y, row) in frame.points().chunks(w).enumerate() {
        let n = row.iter().filter(|p| p.is_some()).count() * grid.0 * grid.1;
        let start = out.len();
        out.resize(start + n, CameraSample::default());
        filler.row(y, &mut out[start..]);
    }
    out
}

/// Makes the samples of one row at a time (see [`camera_samples`]).
struct SampleFiller<'a> {
    frame: &'a Frame<'a>,
    bases: Vec<u32>,
    grid: (usize, usize),
    inv: Mat4,
    eye: Vec3,
}

impl<'a> SampleFiller<'a> {
    fn new(frame: &'a Frame<'a>, k: SamplesPerPixel) -> Self {
        SampleFiller {
            frame,
            bases: frame.scene.triangle_bases(),
            grid: k.grid(),
            inv: frame.camera.view_projection().inverse(),
            eye: frame.camera.position,
        }
    }

    /// The scene-wide id of the triangle visible at pixel `i`, or `u32::MAX`.
    #[inline]
    fn triangle(&self, i: usize) -> u32 {
        self.frame.triangle_at(i, &self.bases).unwrap_or(u32::MAX)
    }

    /// The samples of row `y` into `out` (exactly as many as the row's covered pixels times k).
    fn row(&self, y: usize, out: &mut [CameraSample]) {
        let f = self.frame;
        let (w, h) = (f.width() as usize, f.height() as usize);
        let (cols, rows) = self.grid;
        let pts = &f.points()[y * w..(y + 1) * w];
        let mut o = 0;
        for (x, p) in pts.iter().enumerate() {
            let Some(s) = *p else { continue };
            let i = y * w + x;
            let triangle = self.triangle(i);
            if cols * rows == 1 {
                out[o] = CameraSample {
                    pixel: i as u32,
                    point: s,
                    triangle,
                };
                o += 1;
                continue;
            }
            let ray = |px: f32, py: f32| {
                let ndc = Vec2::new(px / w as f32 * 2.0 - 1.0, 1.0 - py / h as f32 * 2.0);
                (self.inv.project_point3(ndc.extend(1.0)) - self.eye).normalize()
            };
            // The pixel's footprint at the point, for the fall-back test.
            let dist = (s.position - self.eye).length();
            let foot = (ray(x as f32 + 0.5, y as f32 + 0.5) - ray(x as f32 + 1.5, y as f32 + 0.5)).length() * dist;
            for r in 0..rows {
                for c in 0..cols {
                    let d = ray(
                        x as f32 + (c as f32 + 0.5) / cols as f32,
                        y as f32 + (r as f32 + 0.5) / rows as f32,
                    );
                    let denom = s.normal.dot(d);
                    let mut p = s.position;
                    if denom.abs() > 1e-6 {
                        let t = s.normal.dot(s.position - self.eye) / denom;
                        let q = self.eye + d * t;
                        if t > 0.0 && (q - s.position).length() <= 2.0 * foot.max(1e-12) {
                            p = q;
                        }
                    }
                    out[o] = CameraSample {
                        pixel: i as u32,
                        point: SamplePoint {
                            position: p,
                            normal: s.normal,
                        },
                        triangle,
                    };
                    o += 1;
                }
            }
        }
        debug_assert_eq!(o, out.len());
    }
}

impl Default for CameraSample {
    fn default() -> Self {
        CameraSample {
            pixel: u32::MAX,
            point: SamplePoint {
                position: Vec3::ZERO,
                normal: Vec3::ZERO,
            },
            triangle: u32::MAX,
        }
    }
}

/// Per scene triangle (scene-wide ids): its geometric normal (unnormalised) and whether it
/// faces the light (at its centroid).
fn triangle_facing(frame: &Frame) -> Vec<(Vec3, bool)> {
    let light = frame.light;
    let per: Vec<Vec<(Vec3, bool)>> = frame
        .scene
        .objects
        .par_iter()
        .map(|o| {
            let m = &o.mesh;
            m.indices
                .chunks_exact(3)
                .map(|t| {
                    let [a, b, c] =
                        [t[0], t[1], t[2]].map(|i| m.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO));
                    let n = (b - a).cross(c - a);
                    (n, n.dot(to_light(&light, (a + b + c) / 3.0)) > 0.0)
                })
                .collect()
        })
        .collect();
    per.concat()
}

/// From `p` towards the light: the light's position minus `p`, or against a directional
/// light's direction.
fn to_light(light: &Light, p: Vec3) -> Vec3 {
    match light.kind {
        LightKind::Directional => -light.direction,
        _ => light.position - p,
    }
}

/// Whether a sample's surface faces the light (the others are unlit and never inserted).
fn faces_light(light: &Light, s: &SamplePoint) -> bool {
    s.normal.dot(light.to_light(s.position)) > 0.0
}

/// A triangle as the occluder test needs it (Möller–Trumbore), with its plane for an early
/// out.
#[derive(Copy, Clone, Debug)]
struct Occluder {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    /// `e1 x e2` and its squared length.
    n: Vec3,
    n2: f32,
    /// `n . (light - v0)` (directional: `n . direction to the light`): the light's side.
    light_side: f32,
    id: u32,
    /// Directional lights: the Möller–Trumbore terms that depend on the direction alone
    /// ([`segment_terms`] of the direction to the light), made once per triangle instead of
    /// per sample.
    pv: Vec3,
    inv: f32,
}

impl Occluder {
    fn new(a: Vec3, b: Vec3, c: Vec3, light: &Light, id: u32) -> Occluder {
        let (e1, e2) = (b - a, c - a);
        let n = e1.cross(e2);
        let light_side = match light.kind {
            LightKind::Directional => n.dot(-light.direction),
            _ => n.dot(light.position - a),
        };
        let (pv, inv) = match light.kind {
            LightKind::Directional => segment_terms(e1, e2, -light.direction),
            _ => (Vec3::ZERO, f32::NAN),
        };
        Occluder {
            v0: a,
            e1,
            e2,
            n,
            n2: n.length_squared(),
            light_side,
            id,
            pv,
            inv,
        }
    }

    /// True when `p` lies clearly on the light's side of the triangle's plane (by more than
    /// 1e-4 of its distance to the triangle's first vertex, so rounding cannot decide): then
    /// the segment to the light cannot cross the triangle, and the exact test is skipped.
    #[cfg(test)]
    fn same_side_as_light(&self, p: Vec3) -> bool {
        let tv = p - self.v0;
        let a = self.n.dot(tv);
        a * self.light_side > 0.0 && a * a > 1e-8 * self.n2 * tv.length_squared()
    }

    /// Whether the segment from `p` to the light (`to_light` = light position - p, `t` in
    /// (0, 1); directional: the direction to the light, `t` > 0) hits the triangle.
    #[cfg(test)]
    fn blocks(&self, p: Vec3, to_light: Vec3, directional: bool) -> bool {
        // A directional light's terms depend on its direction alone: made once per triangle.
        let (pv, inv) = if directional {
            (self.pv, self.inv)
        } else {
            segment_terms(self.e1, self.e2, to_light)
        };
        if inv.is_nan() {
            return false;
        }
        let tv = p - self.v0;
        let u = tv.dot(pv) * inv;
        if !(0.0..=1.0).contains(&u) {
            return false;
        }
        let qv = tv.cross(self.e1);
        let v = to_light.dot(qv) * inv;
        if v < 0.0 || u + v > 1.0 {
            return false;
        }
        let t = self.e2.dot(qv) * inv;
        t > 0.0 && (directional || t < 1.0)
    }
}

/// The Möller–Trumbore terms (Möller and Trumbore 1997) of a triangle with edges `e1`,
/// `e2` and a segment along `to_light`: `pv = to_light x e2` and `1 / (e1 . pv)`, the latter
/// NaN where the segment is parallel to the triangle or the determinant is not finite (no
/// crossing).
#[inline(always)]
fn segment_terms(e1: Vec3, e2: Vec3, to_light: Vec3) -> (Vec3, f32) {
    let pv = to_light.cross(e2);
    let det = e1.dot(pv);
    (
        pv,
        if det == 0.0 || !det.is_finite() {
            f32::NAN
        } else {
            1.0 / det
        },
    )
}

/// The occluder pass's test of one texel's samples against occluder `o` (the light at `lp`,
/// or along `dir` for a directional one): a lit sample not on `o` is shadowed when its
/// segment to the light crosses `o` (the plane test first, then Möller–Trumbore). Returns
/// the largest [`axis_at`] (`axis`) of the samples still lit after it (`-inf` for none) and
/// the tests it ran.
///
/// Four samples at a time, without a branch per sample (which samples are shadowed already,
/// lie on `o` or pass the plane test is data the branch predictor cannot learn); each lane
/// computes exactly the one-sample operations of `Occluder::same_side_as_light` and
/// `Occluder::blocks`, in their order, so the results are theirs (a test checks it).
#[inline(always)]
fn test_list(o: &Occluder, list: &mut [ListSample], directional: bool, lp: Vec3, dir: Vec3, axis: Vec4) -> (f32, u32) {
    let mut far = Vec4::NEG_INFINITY;
    let mut tests = 0;
    let shadow = SHADOWED | o.id;
    let side = 1e-8 * o.n2;
    for chunk in list.chunks_mut(4) {
        // Lanes past the list's end count as shadowed: they take no part.
        let mut st = [SHADOWED; 4];
        let (mut x, mut y, mut z) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
        for (l, s) in chunk.iter().enumerate() {
            (x[l], y[l], z[l], st[l]) = (s.position.x, s.position.y, s.position.z, s.state);
        }
        let lit = BVec4A::new(st[0] < SHADOWED, st[1] < SHADOWED, st[2] < SHADOWED, st[3] < SHADOWED);
        if !lit.any() {
            continue;
        }
        let testing = lit & BVec4A::new(st[0] != o.id, st[1] != o.id, st[2] != o.id, st[3] != o.id);
        tests += testing.bitmask().count_ones();
        let p = Vec3x4 {
            x: Vec4::from_array(x),
            y: Vec4::from_array(y),
            z: Vec4::from_array(z),
        };
        // `same_side_as_light`, lane by lane.
        let tv = p - Vec3x4::splat(o.v0);
        let a = tv.dot(o.n);
        let same = (a * o.light_side).cmpgt(Vec4::ZERO) & (a * a).cmpgt(side * tv.dot4(tv));
        let candidates = testing & !same;
        let mut hit = BVec4A::FALSE;
        if candidates.any() {
            // `blocks`, lane by lane.
            let (to, pv, inv) = if directional {
                (Vec3x4::splat(dir), Vec3x4::splat(o.pv), Vec4::splat(o.inv))
            } else {
                // `segment_terms`, lane by lane.
                let to = Vec3x4::splat(lp) - p;
                let pv = to.cross(o.e2);
                let det = pv.dot(o.e1);
                let bad = det.cmpeq(Vec4::ZERO) | !det.is_finite_mask();
                (to, pv, Vec4::select(bad, Vec4::NAN, Vec4::ONE / det))
            };
            let u = tv.dot4(pv) * inv;
            let inside_u = u.cmpge(Vec4::ZERO) & u.cmple(Vec4::ONE);
            let qv = tv.cross(o.e1);
            let v = to.dot4(qv) * inv;
            let inside_v = !v.cmplt(Vec4::ZERO) & !(u + v).cmpgt(Vec4::ONE);
            let t = qv.dot(o.e2) * inv;
            let ahead = t.cmpgt(Vec4::ZERO) & if directional { BVec4A::TRUE } else { t.cmplt(Vec4::ONE) };
            hit = candidates & !inv.is_nan_mask() & inside_u & inside_v & ahead;
            let bits = hit.bitmask();
            if bits != 0 {
                for (l, s) in chunk.iter_mut().enumerate() {
                    if bits & (1 << l) != 0 {
                        s.state = shadow;
                    }
                }
            }
        }
        let d = p.dot(axis.truncate()) + axis.w;
        far = Vec4::select(lit & !hit, far.max(d), far);
    }
    (far.max_element(), tests)
}

/// A point's depth along a view's axis, `axis` from [`axis_depth`]:
/// `(axis.x p.x + axis.y p.y) + axis.z p.z + axis.w`.
#[inline(always)]
fn axis_at(axis: Vec4, p: Vec3) -> f32 {
    p.dot(axis.truncate()) + axis.w
}

/// The row of `view`'s matrix whose dot product with `(p, 1)` is p's depth along the view's
/// axis, growing away from the light: clip `w` (the distance along the axis) for a
/// perspective view, clip `z` for an orthographic one. Linear in p, so a triangle's nearest
/// point along the axis is one of its vertices.
fn axis_depth(view: &LightView) -> Vec4 {
    view.matrix.row(if view.perspective { 3 } else { 2 })
}

/// A sample's record from pass 1: where its ray starts and the triangle it never tests
/// ([`NO_TRIANGLE`]: none).
#[derive(Copy, Clone, Debug, Default)]
struct Rec {
    origin: Vec3,
    triangle: u32,
}

/// A sample on its way through the counting sort: its record, its index and its texel's
/// column (the whole record travels, so the last step reads it in order instead of
/// gathering it from the samples).
#[derive(Copy, Clone, Debug, Default)]
struct Entry {
    rec: Rec,
    sample: u32,
    column: u32,
}

/// Writes to distinct elements of a slice from many threads: the parallel counting sort's
/// scatter, where a prefix sum has given every element exactly one writer.
struct Scatter<'a, T> {
    ptr: *mut T,
    len: usize,
    _slice: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: writes go to distinct elements (the caller's contract on `write`), so sharing the
// pointer between threads is like handing each thread its own elements.
unsafe impl<T: Send> Sync for Scatter<'_, T> {}

impl<'a, T: Copy> Scatter<'a, T> {
    fn new(s: &'a mut [T]) -> Self {
        Scatter {
            ptr: s.as_mut_ptr(),
            len: s.len(),
            _slice: std::marker::PhantomData,
        }
    }

    /// Writes element `i` (checked against the length).
    ///
    /// # Safety
    /// No other write to element `i` may happen while this `Scatter` lives.
    #[inline(always)]
    unsafe fn write(&self, i: usize, v: T) {
        assert!(i < self.len, "scatter index {i} beyond {}", self.len);
        // SAFETY: in bounds (checked), and the caller guarantees no concurrent write to `i`.
        unsafe { self.ptr.add(i).write(v) }
    }

    /// Reads element `i` (checked against the length).
    ///
    /// # Safety
    /// No other thread may write element `i` while this read happens.
    #[inline(always)]
    unsafe fn read(&self, i: usize) -> T {
        assert!(i < self.len, "scatter index {i} beyond {}", self.len);
        // SAFETY: in bounds (checked), and the caller guarantees no concurrent write to `i`.
        unsafe { self.ptr.add(i).read() }
    }
}

/// One light view of the grid: its cropped matrix, the store of lists, and which sample
/// each stored record is.
struct View {
    view: LightView,
    /// The uncropped view, and the crop in its uv: a sample's texel is
    /// `grid.texel(base.lookup(p).uv)` (see [`Grid`]).
    base: LightView,
    grid: Grid,
    store: PixelStore<ListSample>,
    /// Per record of the store (same order): the sample's index.
    order: Vec<u32>,
    /// The occluder pass's depth target, used as a mask: 1 where the texel has samples, -1
    /// where it has none, so the early depth test (`LessEqual`, no writes) drops fragments on
    /// empty texels before the program runs.
    mask: Option<Surface<f32>>,
    /// Per texel (row-major): the occluder pass's [`Texel`].
    texels: Vec<Texel>,
    /// Occluder fragments of the pass (that reached a non-empty texel).
    fragments: u64,
    /// Occluder fragments rasterized in all.
    rasterized: u64,
}

/// The irregular z-buffer: the samples, their lists and the last run's results (see the
/// module docs).
pub struct IrregularZBuffer {
    opts: Options,
    /// Samples of the last run, and of them in the lists.
    total: usize,
    inserted: usize,
    views: Vec<View>,
    occluders: usize,
    /// Per scene object: closed (manifold, no degenerate triangles), from edge adjacency,
    /// with the fingerprint of the mesh it was found for (recomputed when it changes).
    closed: Vec<(u64, bool)>,
    /// Samples whose own triangle faces away from the light (tested against it).
    own_tested: usize,
    /// Per sample (pixel-major): lit (1) or not (0), from the last run.
    lit: Vec<u8>,
    /// Kept buffers: where each row's samples start; per sample its uv in its base view,
    /// record, view byte and key (view and texel); the sort's entries.
    row_start: Vec<u32>,
    uv: Vec<Vec2>,
    rec: Vec<Rec>,
    meta: Vec<u8>,
    keys: Vec<u32>,
    by_row: Vec<Entry>,
}

impl IrregularZBuffer {
    /// An irregular z-buffer with `opts` (the technique checks their ranges).
    pub fn new(opts: Options) -> IrregularZBuffer {
        IrregularZBuffer {
            opts,
            total: 0,
            inserted: 0,
            views: Vec::new(),
            occluders: 0,
            closed: Vec::new(),
            own_tested: 0,
            lit: Vec::new(),
            row_start: Vec::new(),
            uv: Vec::new(),
            rec: Vec::new(),
            meta: Vec::new(),
            keys: Vec::new(),
            by_row: Vec::new(),
        }
    }

    /// The options.
    pub fn options(&self) -> &Options {
        &self.opts
    }

    /// Visibility of every camera sample of the last run (0 for samples facing away), in the
    /// order of [`camera_samples`].
    pub fn sample_visibility(&self) -> Vec<f32> {
        self.lit.iter().map(|&l| l as f32).collect()
    }

    /// Passes 1-3: samples, grids cropped to them, lists by counting sort. Every buffer is
    /// kept from run to run (fresh pages cost more than the work on them).
    ///
    /// The counting sort runs in parallel and gives the serial one's result (list order =
    /// sample order) for any thread count: samples are cut into chunks by a rule of their
    /// count alone, each chunk counts its samples per (view, texel row), a prefix sum over
    /// (row, chunk) places every chunk's run of each row, and each texel row then sorts its
    /// samples by column, stably, into its part of the store.
    fn insert(&mut self, frame: &Frame) -> Result<(), String> {
        let size = self.opts.size;
        let k = self.opts.samples.count();
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let objects = frame.gbuffer.object.data();
        // A list sample keeps a triangle id in 31 bits (see `ListSample`).
        let triangles = frame.scene.triangles();
        if triangles >= NO_TRIANGLE as usize {
            return Err(format!(
                "technique 'izb': the scene has {triangles} triangles; the lists hold triangle ids below {NO_TRIANGLE}"
            ));
        }
        // Samples per row, and the capacity check before anything is allocated.
        let row_counts: Vec<u32> = objects
            .par_chunks(w)
            .map(|r| (r.iter().filter(|&&o| o != NO_OBJECT).count() * k) as u32)
            .collect();
        self.row_start.clear();
        self.row_start.push(0);
        let mut total = 0usize;
        for c in &row_counts {
            total += *c as usize;
            self.row_start.push(total as u32);
        }
        if total > self.opts.capacity as usize {
            return Err(format!(
                "technique 'izb': {total} samples ({}x{} pixels, {k} per covered pixel) exceed the lists' capacity of {} (raise capacity=, at most {})",
                frame.width(),
                frame.height(),
                self.opts.capacity,
                1u32 << 28
            ));
        }
        self.total = total;
        let light = frame.light;
        // A spot light's samples may lie outside its cone (the reference gives spot lights no
        // cone): like point lights, it gets six cube faces, each cropped to its samples.
        let base = match light.kind {
            LightKind::Spot { .. } => light::cube_views(frame, size),
            _ => light_views(frame, size),
        };
        let nb = base.len();
        // Pass 1, row by row in parallel: the samples; for each, the base view it falls in
        // (none: it faces away from the light), its uv there, and its record (ray origin, and
        // the triangle it skips). A sample skips its own triangle only where that triangle
        // faces the light (its geometric normal turned to the side of the shading normal,
        // for two-sided sheets). Where it faces away (the terminator of a tessellated sphere,
        // the far side of a heightfield's ridge), the sample's ray leaves through the back of
        // its own surface and the triangle is tested like any other. Each row also takes its
        // samples' uv bounds per view (min and max: exact in any order).
        let facing = triangle_facing(frame);
        let filler = SampleFiller::new(frame, self.opts.samples);
        // (Every element is written below: the kept buffers are only resized.)
        self.uv.resize(total, Vec2::ZERO);
        self.rec.resize(total, Rec::default());
        self.meta.resize(total, META_NONE);
        let mut rows: Vec<(&mut [Vec2], &mut [Rec], &mut [u8])> = Vec::with_capacity(h);
        let (mut ru, mut rr, mut rm) = (
            self.uv.as_mut_slice(),
            self.rec.as_mut_slice(),
            self.meta.as_mut_slice(),
        );
        for c in &row_counts {
            let c = *c as usize;
            let (au, bu) = std::mem::take(&mut ru).split_at_mut(c);
            let (ar, br) = std::mem::take(&mut rr).split_at_mut(c);
            let (am, bm) = std::mem::take(&mut rm).split_at_mut(c);
            rows.push((au, ar, am));
            (ru, rr, rm) = (bu, br, bm);
        }
        let empty = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        let points = frame.points();
        let row_bounds: Vec<Vec<(Vec2, Vec2)>> = rows
            .into_par_iter()
            .enumerate()
            .map_init(Vec::new, |buf: &mut Vec<CameraSample>, (y, (uvs, rec, meta))| {
                let mut b = vec![empty; nb];
                let count = uvs.len();
                // The bounds of the view the last sample fell in, kept in registers (a row's
                // samples mostly fall in one view; min and max are exact in any order).
                let mut cur = (usize::MAX, empty);
                {
                    let mut one = |j: usize, s: &SamplePoint, triangle: u32| {
                        let f = light::view_of(nb, &light, s.position);
                        let seen = if faces_light(&light, s) {
                            base[f].lookup(s.position)
                        } else {
                            None
                        };
                        let Some((uv, _)) = seen else {
                            meta[j] = META_NONE;
                            rec[j] = Rec {
                                origin: Vec3::ZERO,
                                triangle: NO_TRIANGLE,
                            };
                            return;
                        };
                        if f != cur.0 {
                            if cur.0 != usize::MAX {
                                b[cur.0] = cur.1;
                            }
                            cur = (f, b[f]);
                        }
                        cur.1 = (cur.1 .0.min(uv), cur.1 .1.max(uv));
                        uvs[j] = uv;
                        let skip_own = facing.get(triangle as usize).is_some_and(|&(n, lit)| {
                            let flip = n.dot(s.normal) < 0.0;
                            lit != flip
                        });
                        meta[j] = f as u8 | if skip_own { META_SKIP_OWN } else { 0 };
                        rec[j] = Rec {
                            // The ray starts where the reference's does: the point moved a few
                            // ULPs along its normal (Wächter and Binder 2019), a property of
                            // float numbers, not a bias that depends on the scene or the light.
                            origin: offset_origin(s.position, s.normal),
                            triangle: if skip_own { triangle } else { NO_TRIANGLE },
                        };
                    };
                    if k == 1 {
                        let mut j = 0;
                        for x in 0..w {
                            let i = y * w + x;
                            if let Some(s) = &points[i] {
                                one(j, s, filler.triangle(i));
                                j += 1;
                            }
                        }
                    } else {
                        buf.clear();
                        buf.resize(count, CameraSample::default());
                        filler.row(y, buf);
                        for (j, c) in buf.iter().enumerate() {
                            one(j, &c.point, c.triangle);
                        }
                    }
                }
                if cur.0 != usize::MAX {
                    b[cur.0] = cur.1;
                }
                b
            })
            .collect();
        // Pass 2: tight bounds per view, then the cropped views.
        let mut bounds = vec![empty; nb];
        for rb in &row_bounds {
            for (e, r) in bounds.iter_mut().zip(rb) {
                *e = (e.0.min(r.0), e.1.max(r.1));
            }
        }
        let mut view_of = vec![u8::MAX; nb];
        // Per view: the cropped view, its base view, and the crop in the base view's uv.
        let mut views: Vec<(LightView, LightView, Grid)> = Vec::new();
        for (f, (lo, hi)) in bounds.iter().enumerate() {
            if lo.x > hi.x {
                continue; // no samples in this view
            }
            view_of[f] = views.len() as u8;
            let (view, grid) = crop(&base[f], *lo, *hi, size);
            views.push((view, base[f], grid));
        }
        // Pass 3a, by chunks in parallel: each sample's key (view and texel in its cropped
        // view, or none), and each chunk's count per texel row of every view.
        let n = (size * size) as usize;
        let s = size as usize;
        let buckets = views.len() * s;
        let chunk = total.div_ceil(MAX_CHUNKS).max(MIN_CHUNK);
        self.keys.resize(total, u32::MAX);
        let per_chunk: Vec<(Vec<u32>, usize)> = self
            .keys
            .par_chunks_mut(chunk)
            .zip(self.uv.par_chunks(chunk))
            .zip(self.meta.par_chunks(chunk))
            .map(|((keys, uvs), meta)| {
                let mut hist = vec![0u32; buckets];
                let mut own_tested = 0;
                for ((key, uv), &m) in keys.iter_mut().zip(uvs).zip(meta) {
                    *key = u32::MAX;
                    if m == META_NONE {
                        continue;
                    }
                    let v = view_of[(m & !META_SKIP_OWN) as usize] as usize;
                    let (tx, ty) = views[v].2.texel(*uv);
                    *key = (v * n + ty * s + tx) as u32;
                    hist[v * s + ty] += 1;
                    own_tested += (m & META_SKIP_OWN == 0) as usize;
                }
                (hist, own_tested)
            })
            .collect();
        self.own_tested = per_chunk.iter().map(|c| c.1).sum();
        // Pass 3b: where each chunk's run of each texel row starts (rows in order, chunks in
        // order within a row: the serial sort's order).
        let mut row_at = Vec::with_capacity(buckets + 1);
        let mut starts = vec![vec![0u32; buckets]; per_chunk.len()];
        let mut at = 0u32;
        for b in 0..buckets {
            row_at.push(at);
            for (c, (hist, _)) in per_chunk.iter().enumerate() {
                starts[c][b] = at;
                at += hist[b];
            }
        }
        row_at.push(at);
        let inserted = at as usize;
        // Pass 3c, by chunks in parallel: each sample's entry (record, index and column)
        // behind the ones before it in its row's run (every position has one writer).
        self.by_row.resize(inserted, Entry::default());
        {
            let out = Scatter::new(&mut self.by_row[..inserted]);
            self.keys
                .par_chunks(chunk)
                .zip(self.rec.par_chunks(chunk))
                .zip(starts.par_iter_mut())
                .enumerate()
                .for_each(|(c, ((keys, rec), cursor))| {
                    for (j, (&key, r)) in keys.iter().zip(rec).enumerate() {
                        if key == u32::MAX {
                            continue;
                        }
                        let b = key as usize / s;
                        let e = Entry {
                            rec: *r,
                            sample: (c * chunk + j) as u32,
                            column: key % size,
                        };
                        // SAFETY: the prefix sum gives each (row, chunk) run its own positions,
                        // and this chunk alone advances its cursors through them.
                        unsafe { out.write(cursor[b] as usize, e) };
                        cursor[b] += 1;
                    }
                });
        }
        // Pass 3d, by texel rows in parallel: each row counts its records per texel, and
        // puts them behind the ones before them in their texel's list (a stable sort by
        // column) into the row's part of the store; the occluder pass's masks.
        let mut old: Vec<View> = self.views.drain(..).collect();
        let by_row = &self.by_row;
        let mut made = Vec::with_capacity(views.len());
        for (v, (view, base, grid)) in views.into_iter().enumerate() {
            let (mut store, mut order, mask, mut texels) = match old.pop() {
                Some(o) => (o.store, o.order, o.mask, o.texels),
                None => (PixelStore::default(), Vec::new(), None, Vec::new()),
            };
            let axis = axis_depth(&view);
            texels.resize(n, Texel { far: 0.0, tests: 0 });
            let texel_rows = Scatter::new(&mut texels);
            let runs = &row_at[v * s..=(v + 1) * s];
            let row_totals: Vec<u32> = runs.windows(2).map(|r| r[1] - r[0]).collect();
            order.resize((runs[s] - runs[0]) as usize, 0);
            let ord = Scatter::new(&mut order);
            store
                .rebuild_rows(size, size, &row_totals, ListSample::EMPTY, |ty, starts, part| {
                    let run = &by_row[runs[ty] as usize..runs[ty + 1] as usize];
                    let first = (runs[ty] - runs[0]) as usize;
                    starts.fill(0);
                    for e in run {
                        starts[e.column as usize] += 1;
                    }
                    let mut acc = 0;
                    for st in starts.iter_mut() {
                        let c = *st;
                        *st = acc;
                        acc += c;
                    }
                    let mut cursor = starts.to_vec();
                    let mut row_far = vec![f32::NEG_INFINITY; s];
                    for e in run {
                        let f = &mut row_far[e.column as usize];
                        *f = f.max(axis_at(axis, e.rec.origin));
                        let at = &mut cursor[e.column as usize];
                        part[*at as usize] = ListSample {
                            position: e.rec.origin,
                            state: e.rec.triangle,
                        };
                        // SAFETY: every record of the view is in one row's run once.
                        unsafe { ord.write(first + *at as usize, e.sample) };
                        *at += 1;
                    }
                    for (x, far) in row_far.into_iter().enumerate() {
                        // SAFETY: row `ty` alone writes texels `ty * s .. (ty + 1) * s`.
                        unsafe { texel_rows.write(ty * s + x, Texel { far, tests: 0 }) };
                    }
                })
                .map_err(|e| e.to_string())?;
            let mut mask = match mask {
                Some(m) if m.width() == size => m,
                _ => Surface::new(size, size, 0.0f32).map_err(|e| e.to_string())?,
            };
            let offsets = store.offsets();
            mask.data_mut()
                .par_iter_mut()
                .zip(offsets.par_windows(2))
                .for_each(|(m, o)| *m = if o[1] > o[0] { 1.0 } else { -1.0 });
            made.push(View {
                view,
                base,
                grid,
                store,
                order,
                mask: Some(mask),
                texels,
                fragments: 0,
                rasterized: 0,
            });
        }
        self.inserted = inserted;
        self.views = made;
        Ok(())
    }

    /// Where sample `i` sits: its view and index into that view's store (None: in no list).
    /// A search (for `inspect`, one pixel at a time).
    fn slot(&self, i: usize) -> Option<(usize, usize)> {
        self.views
            .iter()
            .enumerate()
            .find_map(|(v, view)| view.order.iter().position(|&o| o as usize == i).map(|at| (v, at)))
    }

    /// Pass 4: occluders through the pipeline, conservatively, testing each texel's samples.
    fn occlude(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), String> {
        let light = frame.light;
        let directional = light.kind == LightKind::Directional;
        let casters = merged_casters(frame, &vec![true; frame.scene.objects.len()])?;
        // Closed meshes (edge adjacency, as the shadow volumes check them) cast only through
        // their triangles that face away from the light.
        // The finding is kept per object with the mesh's fingerprint, and made again only
        // for a mesh that changed (a camera path's frames share their meshes).
        let kept = std::mem::take(&mut self.closed);
        self.closed = p.install(|| {
            frame
                .scene
                .objects
                .par_iter()
                .enumerate()
                .map(|(i, o)| {
                    let fp = crate::hash::mesh_fingerprint(&o.mesh.positions, &o.mesh.indices);
                    match kept.get(i) {
                        Some(&(f, c)) if f == fp => (fp, c),
                        _ => (fp, Adjacency::new(&o.mesh).report.is_closed_manifold()),
                    }
                })
                .collect()
        });
        let closed: Vec<bool> = self.closed.iter().map(|c| c.1).collect();
        let mut occluders = Vec::new();
        let mut indices = Vec::new();
        for (t, tri) in casters.indices.chunks_exact(3).enumerate() {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| casters.positions[i as usize]);
            let n = (b - a).cross(c - a);
            if closed[casters.object[t] as usize] && n.dot(to_light(&light, (a + b + c) / 3.0)) > 0.0 {
                continue; // a closed mesh's light-facing triangle: never needed
            }
            occluders.push(Occluder::new(a, b, c, &light, casters.triangle[t]));
            indices.extend_from_slice(tri);
        }
        self.occluders = occluders.len();
        let state = RenderState {
            depth: DepthState {
                // Against the mask: passes on texels with samples (1), fails on empty ones (-1).
                func: CompareFunc::LessEqual,
                write: false,
                clamp: true,
                ..Default::default()
            },
            raster: match self.opts.raster {
                OccluderRaster::Conservative => RasterMode::Overestimate,
                OccluderRaster::Standard => RasterMode::Standard,
            },
            ..Default::default()
        };
        let lp = light.position;
        let dir = -light.direction;
        // The depth cull's margin, far above the rounding of an axis depth anywhere in the
        // scene (1e-5 of the largest term such a depth can have).
        let extent = frame
            .scene
            .bounds()
            .map_or(Vec3::ONE, |(lo, hi)| lo.abs().max(hi.abs()));
        let mut near = Vec::new();
        for v in &mut self.views {
            let axis = axis_depth(&v.view);
            let margin = 1e-5 * (axis.truncate().abs().dot(extent) + axis.w.abs());
            // Per occluder: its nearest vertex's axis depth, less the margin.
            near.clear();
            near.extend(indices.chunks_exact(3).map(|t| {
                let d = t.iter().map(|&i| axis_at(axis, casters.positions[i as usize]));
                d.fold(f32::INFINITY, f32::min) - margin
            }));
            let size = v.grid.size as usize;
            let texels = Scatter::new(&mut v.texels);
            let near = &near;
            let program = |f: &Fragment<()>, list: &mut [ListSample]| {
                let i = f.y as usize * size + f.x as usize;
                // SAFETY: texel i's `Texel`, like its list, is touched only by the fragments
                // of texel i, which the pipeline's raster-ordered storage gives to one worker
                // at a time (the worker that holds its tile).
                let t = unsafe { texels.read(i) };
                // Depth cull: every still-lit sample of the texel lies nearer to the light than
                // the whole triangle, so no segment from one to the light can cross it (a
                // texel whose samples are all shadowed is culled too: its `far` is -inf).
                if t.far < near[f.prim as usize] {
                    return;
                }
                let (far, tests) = test_list(&occluders[f.prim as usize], list, directional, lp, dir, axis);
                let t = Texel {
                    far,
                    tests: t.tests + tests as u64,
                };
                // SAFETY: as above.
                unsafe { texels.write(i, t) };
            };
            let mask = v.mask.as_mut().expect("every view has its mask");
            let st = p
                .draw_ordered(
                    &mut Targets::none().with_depth(mask),
                    &state,
                    &casters.positions,
                    &indices,
                    &TransformPositions(v.view.matrix),
                    &program,
                    &mut v.store,
                )
                .map_err(|e| e.to_string())?;
            v.fragments = st.fragments_shaded;
            v.rasterized = st.fragments_rasterized;
        }
        Ok(())
    }

    /// Per texel list lengths of view `v`.
    fn lengths(&self, v: usize) -> Surface<f32> {
        let s = &self.views[v].store;
        let data = (0..(s.width() * s.height()) as usize)
            .map(|i| s.range(i).len() as f32)
            .collect();
        Surface::from_vec_derived(s.width(), s.height(), data).expect("grid size")
    }

    fn list_stats(&self) -> (usize, usize, u64) {
        let (mut nonempty, mut max, mut tests) = (0usize, 0usize, 0u64);
        for v in &self.views {
            let s = &v.store;
            for i in 0..(s.width() * s.height()) as usize {
                let n = s.range(i).len();
                nonempty += (n > 0) as usize;
                max = max.max(n);
            }
            tests += v.texels.iter().map(|t| t.tests).sum::<u64>();
        }
        (nonempty, max, tests)
    }
}

/// `base` cropped to its samples' uv bounds `lo`..`hi` (plus half a texel), so the grid's
/// texels cover only where samples are: a scale and offset of clip x and y.
fn crop(base: &LightView, lo: Vec2, hi: Vec2, size: u32) -> (LightView, Grid) {
    let pad = 0.5 / size as f32;
    let (lo, hi) = (lo - pad, hi + pad);
    // uv -> ndc: x = 2u - 1, y = 1 - 2v.
    let (x0, x1) = (2.0 * lo.x - 1.0, 2.0 * hi.x - 1.0);
    let (y0, y1) = (1.0 - 2.0 * hi.y, 1.0 - 2.0 * lo.y);
    let (sx, sy) = (2.0 / (x1 - x0).max(1e-9), 2.0 / (y1 - y0).max(1e-9));
    let c = Mat4::from_cols(
        Vec4::new(sx, 0.0, 0.0, 0.0),
        Vec4::new(0.0, sy, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(-(x0 + x1) * 0.5 * sx, -(y0 + y1) * 0.5 * sy, 0.0, 1.0),
    );
    let view = LightView {
        matrix: c * base.matrix,
        texel: base.texel * (hi - lo).max_element(),
        perspective: base.perspective,
    };
    let grid = Grid {
        lo,
        scale: Vec2::splat(size as f32) / (hi - lo).max(Vec2::splat(1e-9)),
        size,
    };
    (view, grid)
}

/// A cropped view's texels in its base view's uv: the crop's scale and offset.
#[derive(Copy, Clone, Debug)]
struct Grid {
    lo: Vec2,
    scale: Vec2,
    size: u32,
}

impl Grid {
    /// The texel (column, row) of base-view uv `uv`.
    #[inline(always)]
    fn texel(&self, uv: Vec2) -> (usize, usize) {
        let t = ((uv - self.lo) * self.scale).floor();
        let last = self.size as f32 - 1.0;
        (t.x.clamp(0.0, last) as usize, t.y.clamp(0.0, last) as usize)
    }
}

/// The per-pixel resolve (the image's, and `inspect`'s with a recording trace): the mean of
/// the lit marks of the pixel's samples, the count of lit samples over their number (with a
/// power-of-two count, exactly the sum of its terms).
#[inline(always)]
fn resolve(marks: &[u8], t: &mut impl Trace) -> f32 {
    let c: u32 = marks.iter().map(|&l| l as u32).sum();
    t.step(|| {
        Step::new("resolve", "the pixel's lit samples over its samples")
            .int("lit samples", c)
            .int("samples", marks.len())
    });
    c as f32 / marks.len() as f32
}

impl Pass for IrregularZBuffer {
    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Vec<f32>, String> {
        // The samples and their lists (at most 88 bytes a sample: its position, record, key
        // and sort entry, the store's node and its index, its result), checked against the
        // memory budget before any is made.
        let (w, h) = (frame.width(), frame.height());
        let samples = w as u64 * h as u64 * self.opts.samples.count() as u64;
        crate::pipeline::check_bytes(w, h, samples * 88).map_err(|e| {
            format!(
                "the irregular z-buffer ({samples} camera samples, option samples={}): {e}",
                self.opts.samples.count()
            )
        })?;
        passes.skip();
        p.install(|| self.insert(frame))?;
        passes.end("sample insertion");
        self.occlude(p, frame)?;
        passes.end("occluder pass");
        // Resolve: each list's lit samples marked in sample order (one byte each, every
        // sample in one list once); then each pixel's mean over its samples, row by row (a
        // row's samples are contiguous, pixel after pixel, k each). The mean is the count of
        // lit samples over k: with k a power of two, exactly the sum of k terms of 1/k.
        let k = self.opts.samples.count();
        let w = w as usize;
        let mut out = vec![f32::NAN; w * h as usize];
        self.lit.clear();
        self.lit.resize(self.total, 0);
        let (views, row_start) = (&self.views, &self.row_start);
        let objects = frame.gbuffer.object.data();
        let lit = &mut self.lit;
        p.install(|| {
            {
                let marks = Scatter::new(lit);
                for v in views {
                    v.store
                        .data()
                        .par_chunks(MIN_CHUNK)
                        .zip(v.order.par_chunks(MIN_CHUNK))
                        .for_each(|(recs, order)| {
                            for (r, &i) in recs.iter().zip(order) {
                                if r.state < SHADOWED {
                                    // SAFETY: every sample is in one list once.
                                    unsafe { marks.write(i as usize, 1) };
                                }
                            }
                        });
                }
            }
            let lit = &*lit;
            out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                let mut i = row_start[y] as usize;
                for (px, &o) in row.iter_mut().zip(&objects[y * w..(y + 1) * w]) {
                    if o == NO_OBJECT {
                        continue;
                    }
                    *px = resolve(&lit[i..i + k], &mut NoTrace);
                    i += k;
                }
            })
        });
        passes.end("resolve");
        Ok(out)
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let i = (y * frame.width() + x) as usize;
        let mut steps = vec![Step::new(
            "grid",
            "the light views cropped to their samples, and the lists (counting sort by texel)",
        )
        .int("views", self.views.len())
        .int("size", self.opts.size)
        .int("samples in the frame", self.total)
        .int("occluder triangles", self.occluders)];
        let samples = camera_samples(frame, self.opts.samples);
        let start = samples.partition_point(|s| (s.pixel as usize) < i);
        let mut lit_sum = 0.0;
        let k = self.opts.samples.count();
        let names = |id: u32| -> String {
            let bases = frame.scene.triangle_bases();
            let o = bases.partition_point(|&b| b <= id).saturating_sub(1);
            frame
                .scene
                .objects
                .get(o)
                .map_or("?".into(), |ob| format!("{} (triangle {})", ob.name, id - bases[o]))
        };
        for (j, s) in samples[start..]
            .iter()
            .take_while(|s| s.pixel as usize == i)
            .enumerate()
        {
            let slot = self.slot(start + j);
            let mut st = Step::new(
                format!("sample {j}"),
                "a camera sample: its point, the texel whose list holds it, and what the occluder pass found",
            )
            .vec3("position", s.point.position)
            .text("on", names(s.triangle));
            if let Some((v, at)) = slot {
                let view = &self.views[v];
                let ls = view.store.data()[at];
                // The sample's uv in the cropped grid (as its texel was found).
                let (uv, _) = view.base.lookup(s.point.position).unwrap_or_default();
                let uv = (uv - view.grid.lo) * view.grid.scale / view.grid.size as f32;
                let t = (0..(view.store.width() * view.store.height()) as usize)
                    .find(|&t| view.store.range(t).contains(&at))
                    .unwrap_or(0);
                st = st
                    .int("view", v)
                    .vec2("uv", uv)
                    .vec2(
                        "texel",
                        Vec2::new(
                            (t as u32 % view.store.width()) as f32,
                            (t as u32 / view.store.width()) as f32,
                        ),
                    )
                    .int("list length", view.store.range(t).len())
                    .int("triangle tests on the texel's list", view.texels[t].tests)
                    .flag("lit", ls.shadowed_by().is_none());
                if let Some(by) = ls.shadowed_by() {
                    st = st.text("shadowed by", names(by));
                } else {
                    lit_sum += 1.0;
                }
            } else {
                st = st
                    .flag("faces the light", false)
                    .text("result", "unlit (faces away from the light)");
            }
            steps.push(st);
        }
        if frame.point(x, y).is_none() || self.lit.is_empty() {
            steps.push(inspect::result(f32::NAN));
            return steps;
        }
        // The image's marks of the pixel's samples: the row's first sample, then k per
        // covered pixel before this one.
        let y0 = y as usize * frame.width() as usize;
        let before = frame.gbuffer.object.data()[y0..y0 + x as usize]
            .iter()
            .filter(|&&o| o != NO_OBJECT)
            .count();
        let first = self.row_start[y as usize] as usize + before * k;
        let mut t = Steps(steps);
        let v = resolve(&self.lit[first..first + k], &mut t);
        debug_assert_eq!(v, lit_sum / k as f32);
        t.0.push(inspect::result(v));
        t.0
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let (nonempty, max, tests) = self.list_stats();
        let inserted = self.inserted;
        let bytes: usize = self.views.iter().map(|v| v.store.bytes()).sum();
        vec![
            ("samples", self.total as f64),
            ("samples inserted", inserted as f64),
            ("samples tested against their own triangle", self.own_tested as f64),
            ("non-empty texels", nonempty as f64),
            ("max list length", max as f64),
            ("mean list length", inserted as f64 / nonempty.max(1) as f64),
            ("occluder triangles", self.occluders as f64),
            (
                "occluder fragments",
                self.views.iter().map(|v| v.fragments).sum::<u64>() as f64,
            ),
            ("triangle-sample tests", tests as f64),
            ("list bytes", bytes as f64),
        ]
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, String> {
        let mut v = Vec::new();
        for i in 0..self.views.len() {
            let len = self.lengths(i);
            let hi = len.data().iter().copied().fold(1.0f32, f32::max);
            v.push(Stage::Scalar {
                name: format!("list_length{i}"),
                data: len,
                lo: 0.0,
                hi,
            });
            // Triangle-sample tests per texel (the occluder pass's work where it went).
            let s = &self.views[i].store;
            let tests = self.views[i].texels.iter().map(|t| t.tests as f32).collect();
            let tests = Surface::from_vec(s.width(), s.height(), tests).map_err(|e| e.to_string())?;
            let hi = tests.data().iter().copied().fold(1.0f32, f32::max);
            v.push(Stage::Scalar {
                name: format!("tests_per_texel{i}"),
                data: tests,
                lo: 0.0,
                hi,
            });
        }
        if self.views.len() == 1 && frame.light.kind != LightKind::Point {
            v.push(Stage::Color {
                name: "grid_over_light_view".into(),
                data: light::fitted_overview(p, frame, &self.views[0].view)?,
            });
        }
        // Shadowed samples per pixel.
        let mut shadowed = frame
            .points()
            .iter()
            .map(|s| if s.is_some() { 0.0 } else { f32::NAN })
            .collect::<Vec<f32>>();
        for (s, lit) in camera_samples(frame, self.opts.samples)
            .iter()
            .zip(self.sample_visibility())
        {
            shadowed[s.pixel as usize] += 1.0 - lit;
        }
        v.push(Stage::Scalar {
            name: "shadowed_samples_per_pixel".into(),
            data: Surface::from_vec(frame.width(), frame.height(), shadowed).map_err(|e| e.to_string())?,
            lo: 0.0,
            hi: self.opts.samples.count() as f32,
        });
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::path::Path;

    /// [`test_list`] one sample at a time, with the one-sample tests.
    fn test_list_one(
        o: &Occluder,
        list: &mut [ListSample],
        directional: bool,
        lp: Vec3,
        dir: Vec3,
        axis: Vec4,
    ) -> (f32, u32) {
        let (mut far, mut tests) = (f32::NEG_INFINITY, 0);
        for s in list {
            if s.state >= SHADOWED {
                continue;
            }
            if s.state != o.id {
                tests += 1;
                if !o.same_side_as_light(s.position) {
                    let to = if directional { dir } else { lp - s.position };
                    if o.blocks(s.position, to, directional) {
                        s.state = SHADOWED | o.id;
                        continue;
                    }
                }
            }
            far = far.max(axis_at(axis, s.position));
        }
        (far, tests)
    }

    fn v3() -> impl Strategy<Value = Vec3> {
        (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        /// The four-lane occluder test gives the one-sample test's states, test count and
        /// largest lit depth, for directional and point lights, samples on, near, above and
        /// below the triangle (and on its edges), and degenerate triangles.
        #[test]
        fn four_lane_occluder_test_equals_the_one_sample_test(
            tri in (v3(), v3(), v3(), 0u8..4),
            light in (v3(), any::<bool>()),
            samples in prop::collection::vec((0.0f32..1.0, 0.0f32..1.0, -0.5f32..0.5, (0u8..6, 0u8..4), v3()), 0..14),
        ) {
            let (a, mut b, mut c, degenerate) = tri;
            match degenerate {
                0 => b = a,
                1 => c = a + (b - a) * 0.5,
                _ => {}
            }
            let (lp, directional) = (light.0 * 3.0, light.1);
            let l = Light {
                kind: if directional { LightKind::Directional } else { LightKind::Point },
                position: lp,
                direction: (Vec3::new(0.1, -1.0, 0.2) + light.0 * 0.3).normalize(),
                intensity: 1.0,
            };
            let o = Occluder::new(a, b, c, &l, 7);
            let axis = Vec4::new(0.3, -0.8, 0.1, 0.5);
            let dir = -l.direction;
            let mut list: Vec<ListSample> = samples
                .iter()
                .map(|&(u, v, h, (kind, st), free)| {
                    let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                    let on = a + (b - a) * u + (c - a) * v;
                    let position = match kind {
                        0 => free,
                        1 => on,
                        2 => a + (b - a) * u, // on an edge
                        3 => [a, b, c][(u * 3.0) as usize % 3], // on a vertex
                        4 => [a, b, c][(u * 3.0) as usize % 3] + dir * h, // above or below one
                        _ => on + (b - a).cross(c - a).normalize_or_zero() * h,
                    };
                    let state = match st {
                        0 => 7, // on the occluder itself
                        1 => SHADOWED | 3,
                        2 => 9,
                        _ => NO_TRIANGLE,
                    };
                    ListSample { position, state }
                })
                .collect();
            let mut one = list.clone();
            let got = test_list(&o, &mut list, directional, lp, dir, axis);
            let want = test_list_one(&o, &mut one, directional, lp, dir, axis);
            prop_assert_eq!(&list, &one);
            prop_assert_eq!(got.1, want.1);
            prop_assert!(got.0 == want.0, "far {} against {}", got.0, want.0);
        }
    }

    /// The parallel counting sort gives the serial one's lists: walking the samples in order,
    /// each lands at its texel's next free place, with its own record.
    #[test]
    fn parallel_list_sort_equals_the_serial_one() {
        let p = Pipeline::new(2).unwrap();
        for (scene, k) in [("point_casters", "1"), ("contact", "4")] {
            let s = crate::scene::file::load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
            let f = crate::frame::frame(&p, &s, 0, 0).unwrap();
            let mut t = IrregularZBuffer::new(Options {
                samples: crate::shadow::options::OptionValue::parse(k).unwrap(),
                ..Default::default()
            });
            t.run(&p, &f, &mut Passes::start()).unwrap();
            assert!(t.total > 2 * MIN_CHUNK, "{scene}: too few samples to test chunks");
            let size = t.opts.size;
            let samples = camera_samples(&f, t.opts.samples);
            assert_eq!(samples.len(), t.total);
            let mut slot = vec![None; samples.len()];
            for (v, view) in t.views.iter().enumerate() {
                for (at, &i) in view.order.iter().enumerate() {
                    assert!(slot[i as usize].is_none(), "{scene}: sample {i} stored twice");
                    slot[i as usize] = Some((v, at));
                }
            }
            let mut cursors: Vec<Vec<u32>> = t.views.iter().map(|v| v.store.offsets().to_vec()).collect();
            let mut inserted = 0;
            for (i, smp) in samples.iter().enumerate() {
                let Some((v, at)) = slot[i] else { continue };
                inserted += 1;
                let (uv, _) = t.views[v].base.lookup(smp.point.position).unwrap();
                let (tx, ty) = t.views[v].grid.texel(uv);
                let c = &mut cursors[v][ty * size as usize + tx];
                assert_eq!(at as u32, *c, "{scene}: sample {i} out of the serial order");
                *c += 1;
                let rec = t.views[v].store.data()[at];
                assert_eq!(rec.position, offset_origin(smp.point.position, smp.point.normal));
                assert_eq!(t.slot(i), Some((v, at)));
            }
            assert_eq!(inserted, t.inserted);
            assert!(t.views.len() > 1 || scene == "contact", "{scene}: expected cube faces");
        }
    }
}
