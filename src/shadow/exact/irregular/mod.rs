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
//!    the triangle visible at the pixel (the pixel's own point where the ray passes beside
//!    it). Wyman et al. place them on the pixel's tangent plane; with interpolated normals
//!    that plane leaves the surface, and on a heightfield its sub-samples lay under the
//!    neighbouring facets, which shadowed them. Samples whose normal faces away from the
//!    light are unlit and never inserted.
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
use crate::pipeline::compute::Scatter;
use crate::pipeline::lanes::Vec3x4;
use crate::pipeline::*;
use crate::reference::{offset_origin, SamplePoint};
use crate::scene::{Light, LightKind};
use crate::shadow::inspect::{NoTrace, Step, Steps, Trace};
use crate::shadow::light::{self, light_views, merged_casters, LightView, ViewMaps};
use crate::shadow::pass::Pass;
use crate::shadow::technique::Stage;
use crate::shadow::timing::Passes;
use crate::shadow::volume::silhouette::Adjacency;
use crate::{Error, Resource};
use glam::{BVec4A, Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;

mod insert;
mod occluder;
mod samples;
#[cfg(all(test, feature = "files"))]
mod tests;

use insert::{Entry, Grid, Rec};
use occluder::{axis_at, axis_depth, test_list, ListLight, Occluder};
use samples::to_light;
pub use samples::{camera_samples, camera_samples_grid, CameraSample};

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

choice_enum! {
    /// How occluders are rasterized into the grid.
    pub enum OccluderRaster {
        /// Conservative overestimate: every texel the triangle touches (exact).
        Conservative = "conservative",
        /// Texel centres only (to show what breaks: thin occluders' shadows).
        Standard = "standard",
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

/// One light view of the grid: its cropped matrix, the store of lists, and which sample
/// each stored record is.
struct View {
    /// The uncropped view, and the crop in its uv: a sample's texel is
    /// `grid.texel(base.lookup(p).uv)` (see [`Grid`]). The tests check the lists against it,
    /// independently of the insertion.
    #[cfg_attr(not(all(test, feature = "files")), allow(dead_code))]
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
    /// `texels` and `order` in the memory budget.
    reserved: Reservation,
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
    views: ViewMaps<View>,
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
    /// The per-sample buffers (at most 88 bytes a sample) in the memory budget.
    reserved: Reservation,
}

impl IrregularZBuffer {
    /// An irregular z-buffer with `opts` (the technique checks their ranges).
    pub fn new(opts: Options) -> IrregularZBuffer {
        IrregularZBuffer {
            opts,
            total: 0,
            inserted: 0,
            views: ViewMaps::default(),
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
            reserved: Reservation::default(),
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
    fn slot(&self, i: usize) -> Option<(usize, usize)> {
        self.views
            .iter()
            .enumerate()
            .find_map(|(v, (view, _))| view.order.iter().position(|&o| o as usize == i).map(|at| (v, at)))
    }

    /// Pass 4: occluders through the pipeline, conservatively, testing each texel's samples.
    fn occlude(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error> {
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
        for (v, view) in self.views.maps_mut() {
            let axis = axis_depth(view);
            let at = ListLight {
                directional,
                position: lp,
                direction: dir,
                axis,
            };
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
                let (far, tests) = test_list(&occluders[f.prim as usize], list, at);
                let t = Texel {
                    far,
                    tests: t.tests + tests as u64,
                };
                // SAFETY: as above.
                unsafe { texels.write(i, t) };
            };
            let mask = v.mask.as_mut().expect("every view has its mask");
            let st = p.draw_ordered(
                &mut Targets::none().with_depth(mask),
                &state,
                &casters.positions,
                &indices,
                &TransformPositions(view.matrix),
                &program,
                &mut v.store,
            )?;
            v.fragments = st.fragments_shaded;
            v.rasterized = st.fragments_rasterized;
        }
        Ok(())
    }

    /// Per texel list lengths of view `v`.
    fn lengths(&self, v: usize) -> Surface<f32> {
        let s = &self.views.get(v).0.store;
        let data = (0..(s.width() * s.height()) as usize)
            .map(|i| s.range(i).len() as f32)
            .collect();
        Surface::from_vec_derived(s.width(), s.height(), data).expect("grid size")
    }

    fn list_stats(&self) -> (usize, usize, u64) {
        let (mut nonempty, mut max, mut tests) = (0usize, 0usize, 0u64);
        for (v, _) in self.views.iter() {
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
    type Output = Vec<f32>;

    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Vec<f32>, Error> {
        // The samples and their lists (at most 88 bytes a sample: its position, record, key
        // and sort entry, the store's node and its index, its result), checked against the
        // memory budget before any is made.
        let (w, h) = (frame.width(), frame.height());
        let samples = w as u64 * h as u64 * self.opts.samples.count() as u64;
        let need = (samples * 88).max(self.reserved.bytes());
        self.reserved.resize(w, h, need).map_err(|e| {
            Error::from(e).within(&format!(
                "the irregular z-buffer ({samples} camera samples, option samples={})",
                self.opts.samples.count()
            ))
        })?;
        passes.skip();
        p.install(|| self.insert(p, frame))?;
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
                for (v, _) in views.iter() {
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

    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32> {
        let i = (y * frame.width() + x) as usize;
        t.0.push(
            Step::new(
                "grid",
                "the light views cropped to their samples, and the lists (counting sort by texel)",
            )
            .int("views", self.views.len())
            .int("size", self.opts.size)
            .int("samples in the frame", self.total)
            .int("occluder triangles", self.occluders),
        );
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
                let view = &self.views.get(v).0;
                let ls = view.store.data()[at];
                // The uv the insertion found for the sample (kept from the run), and its texel.
                let base_uv = self.uv[start + j];
                let uv = (base_uv - view.grid.lo) * view.grid.scale / view.grid.size as f32;
                let (tx, ty) = view.grid.texel(base_uv);
                let t = ty * view.store.width() as usize + tx;
                debug_assert!(
                    view.store.range(t).contains(&at),
                    "the sample's record lies in its texel's list"
                );
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
            t.0.push(st);
        }
        if frame.point(x, y).is_none() || self.lit.is_empty() {
            return Some(f32::NAN);
        }
        // The image's marks of the pixel's samples: the row's first sample, then k per
        // covered pixel before this one.
        let y0 = y as usize * frame.width() as usize;
        let before = frame.gbuffer.object.data()[y0..y0 + x as usize]
            .iter()
            .filter(|&&o| o != NO_OBJECT)
            .count();
        let first = self.row_start[y as usize] as usize + before * k;
        let v = resolve(&self.lit[first..first + k], t);
        debug_assert_eq!(v, lit_sum / k as f32);
        Some(v)
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let (nonempty, max, tests) = self.list_stats();
        let inserted = self.inserted;
        let bytes: usize = self.views.iter().map(|(v, _)| v.store.bytes()).sum();
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
                self.views.iter().map(|(v, _)| v.fragments).sum::<u64>() as f64,
            ),
            ("triangle-sample tests", tests as f64),
            ("list bytes", bytes as f64),
        ]
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
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
            let s = &self.views.get(i).0.store;
            let tests = self.views.get(i).0.texels.iter().map(|t| t.tests as f32).collect();
            let tests = Surface::from_vec(s.width(), s.height(), tests)?;
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
                data: light::fitted_overview(p, frame, &self.views.get(0).1)?,
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
            data: Surface::from_vec(frame.width(), frame.height(), shadowed)?,
            lo: 0.0,
            hi: self.opts.samples.count() as f32,
        });
        Ok(v)
    }
}
