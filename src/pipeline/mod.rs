//! The software GPU: a tiled, deterministic triangle pipeline.
//!
//! Stages, in order (one file each):
//! 1. [`vertex`]: user vertex programs, object -> clip space, varyings out.
//! 2. [`clip`]: homogeneous clipping against near (and far unless depth clamp is on); x/y by a
//!    guard band, so triangles crossing `w = 0` are cut where they must be.
//! 3. [`setup`]: snap to [`fixed::Fx8`] (8 sub-pixel bits), cull by winding, integer edge
//!    functions with the top-left rule, plane equations, polygon offset.
//! 4. [`bin`]: triangles into 64 x 64 tiles, in submission order.
//! 5. [`raster`]: per tile, hierarchical block tests (16 x 16 -> 4 x 4 -> pixel) with trivial
//!    accept/reject; standard, conservative overestimate and underestimate modes.
//! 6. [`fragment`]: early/late depth and stencil tests, two-sided stencil ops, the fragment
//!    program, depth write, blending with colour masks, per-pixel fragment [`lists`]; shaded
//!    draws without stencil, lists or discard run four pixels at a time ([`wide`]:
//!    [`FragmentProgram::shade4`] on structure-of-arrays lanes, bit-identical to the
//!    one-pixel path), hidden surfaces removed before shading ([`deferred`]). Under them,
//!    bottom up: [`lanes`] (what a program sees, one pixel or four), [`program`] (the program
//!    trait, colour formats, blending, the targets as tile workers see them) and [`spans`]
//!    (the depth-only and stencil-counting row spans).
//!
//! Beside them: raster-ordered per-pixel storage ([`ordered`], [`Pipeline::draw_ordered`]):
//! a program reads and writes its pixel's slice of user data, one pixel's fragments in
//! primitive order, with no locks (tile ownership gives the order).
//!
//! Around them: [`surface`] (targets, cube maps, arrays, mip chains), [`sampler`] (nearest,
//! bilinear, 2x2 comparison PCF, gather, explicit mip level) and [`compute`] (min/max reduce,
//! histogram, summed-area table, separable blur).
//!
//! Invariants (each one a test in `tests/raster.rs`):
//! - watertight: triangles sharing edges cover each pixel centre exactly once;
//! - conservative overestimate is a superset of standard coverage and equals the exact
//!   "closed pixel square touches closed triangle" test; underestimate is the exact "square
//!   inside triangle" test;
//! - fragment-list node count equals the fragments that passed, lists in submission order;
//! - two-sided stencil incr/decr over closed meshes counts surfaces crossed;
//! - a raster-ordered draw equals applying its fragments one by one in submission order;
//! - every output (targets, lists, counters) is bit-identical for any thread count: a tile is
//!   owned by one worker per draw and walks its triangles in submission order, and all partial
//!   results are combined in tile order.

pub mod bin;
pub mod clip;
pub mod compute;
pub mod deferred;
pub mod error;
pub mod fixed;
pub mod fragment;
pub mod lanes;
pub mod lists;
pub mod ordered;
pub mod program;
pub mod raster;
pub mod sampler;
pub mod samples;
pub mod setup;
pub mod spans;
pub mod state;
pub mod stats;
pub mod surface;
pub mod vertex;
pub mod wide;

pub(crate) use error::size_text;
pub use error::{OverBudget, PipelineError};
pub use lanes::Fragment;
pub use lanes::{Color4, Fragment4, Vec3x4};
pub use lists::{FragmentLists, ListNode};
pub use ordered::{OrderedProgram, PixelStore};
pub use program::{ColorFormat, DepthOnly, DiscardingShader, FragmentProgram, Rgba8, Shader};
pub use state::*;
pub use stats::DrawStats;
pub use surface::{
    check_bytes, check_room, live_surface_bytes, memory_limit, set_memory_limit, CubeFace, CubeMap, MipChain,
    Reservation, Surface, SurfaceArray, DEFAULT_MEMORY_LIMIT, MAX_DIMENSION,
};
pub use vertex::{ClipPassthrough, TransformHomogeneous, TransformPositions, Varyings, VertexProgram};

use bin::{process_chunk, TileGrid, CHUNK};
use clip::{ClipVertex, Clipper};
use fragment::shade_tile;
use program::{RawSurface, RawTargets, TileLists, TileWork};
use rayon::prelude::*;
use setup::SetupParams;
use std::fmt;

/// Chunks set up and binned before their tiles are rasterized (bounds memory per draw: about
/// 40 MB of set-up triangles at most). Hidden surface removal before shading works within a
/// batch, so a draw of up to 131k triangles is one batch: with batches of 65k triangles the
/// 100k-triangle spheres frame took two, shaded 1.37 M instead of 1.22 M fragments and its
/// camera pass took 14 % longer (random triangles: 11 %).
const CHUNKS_PER_BATCH: usize = 32;

/// Whole triangles of indices below `vertices`, or the error that says which index is not.
pub(crate) fn check_indices(indices: &[u32], vertices: usize) -> Result<(), PipelineError> {
    if !indices.len().is_multiple_of(3) {
        return Err(PipelineError::BadIndexCount(indices.len()));
    }
    if let Some(p) = indices.iter().position(|&i| i as usize >= vertices) {
        return Err(PipelineError::IndexOutOfRange {
            triangle: p / 3,
            index: indices[p],
            vertices,
        });
    }
    Ok(())
}

/// The render targets of one draw. All present targets must have the same size.
pub struct Targets<'a, C = Rgba8> {
    /// Colour target.
    pub color: Option<&'a mut Surface<C>>,
    /// Depth target (values in [0, 1]).
    pub depth: Option<&'a mut Surface<f32>>,
    /// Stencil target.
    pub stencil: Option<&'a mut Surface<u8>>,
    /// Per-pixel fragment lists.
    pub lists: Option<&'a mut FragmentLists>,
    /// Clear the depth target to this value as part of the draw (a render pass's "load op
    /// clear"): each tile is cleared by its worker just before it rasterizes, while the tile
    /// is in cache, instead of in a separate pass over the whole target. Default: none.
    pub depth_clear: Option<f32>,
    /// Clear the colour target to this value as part of the draw, as
    /// [`Targets::depth_clear`] does for depth. Default: none.
    pub color_clear: Option<C>,
}

impl<'a> Targets<'a, Rgba8> {
    /// Only a depth target.
    pub fn depth_only(depth: &'a mut Surface<f32>) -> Self {
        Targets {
            color: None,
            depth: Some(depth),
            stencil: None,
            lists: None,
            depth_clear: None,
            color_clear: None,
        }
    }

    /// No colour target (add depth, stencil, lists with the builder methods).
    pub fn none() -> Self {
        Targets {
            color: None,
            depth: None,
            stencil: None,
            lists: None,
            depth_clear: None,
            color_clear: None,
        }
    }
}

impl<'a, C: ColorFormat> Targets<'a, C> {
    /// A colour target (add the others with the builder methods).
    pub fn color(color: &'a mut Surface<C>) -> Self {
        Targets {
            color: Some(color),
            depth: None,
            stencil: None,
            lists: None,
            depth_clear: None,
            color_clear: None,
        }
    }

    /// Adds a depth target.
    pub fn with_depth(mut self, depth: &'a mut Surface<f32>) -> Self {
        self.depth = Some(depth);
        self
    }

    /// Clears the depth target to `value` as part of this draw (see [`Targets::depth_clear`]);
    /// the result equals [`Pipeline::clear`] followed by the draw.
    pub fn clearing_depth(mut self, value: f32) -> Self {
        self.depth_clear = Some(value);
        self
    }

    /// Clears the colour target to `value` as part of this draw (see [`Targets::color_clear`]);
    /// the result equals [`Pipeline::clear`] followed by the draw.
    pub fn clearing_color(mut self, value: C) -> Self {
        self.color_clear = Some(value);
        self
    }

    /// Adds a stencil target.
    pub fn with_stencil(mut self, stencil: &'a mut Surface<u8>) -> Self {
        self.stencil = Some(stencil);
        self
    }

    /// Adds fragment lists.
    pub fn with_lists(mut self, lists: &'a mut FragmentLists) -> Self {
        self.lists = Some(lists);
        self
    }

    /// The targets as tile workers see them (rows `width` texels apart), and how much room the
    /// fragment-list pool has left.
    fn raw(&mut self, width: u32) -> RawTargets<C> {
        RawTargets {
            color: self.color.as_mut().map(|s| RawSurface {
                ptr: s.data_mut().as_mut_ptr(),
                stride: width as usize,
            }),
            depth: self.depth.as_mut().map(|s| RawSurface {
                ptr: s.data_mut().as_mut_ptr(),
                stride: width as usize,
            }),
            stencil: self.stencil.as_mut().map(|s| RawSurface {
                ptr: s.data_mut().as_mut_ptr(),
                stride: width as usize,
            }),
            lists: self.lists.is_some(),
            list_capacity: self.lists.as_ref().map_or(0, |l| l.capacity().saturating_sub(l.len())),
        }
    }

    /// The common size of the targets, or an error if they disagree or there are none.
    pub fn size(&self) -> Result<(u32, u32), PipelineError> {
        let mut sizes: Vec<(&'static str, (u32, u32))> = Vec::new();
        if let Some(c) = &self.color {
            sizes.push(("color", (c.width(), c.height())));
        }
        if let Some(d) = &self.depth {
            sizes.push(("depth", (d.width(), d.height())));
        }
        if let Some(s) = &self.stencil {
            sizes.push(("stencil", (s.width(), s.height())));
        }
        if let Some(l) = &self.lists {
            sizes.push(("fragment-list", (l.width(), l.height())));
        }
        let Some(&(_, first)) = sizes.first() else {
            return Err(PipelineError::BadArgument("a draw needs at least one target".into()));
        };
        for &(what, s) in &sizes[1..] {
            if s != first {
                return Err(PipelineError::SizeMismatch {
                    what,
                    expected: first,
                    got: s,
                });
            }
        }
        Ok(first)
    }
}

/// Wall-clock time spent per stage, summed over draws since the last
/// [`Pipeline::take_times`] (not part of the deterministic output).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Stage 1, vertex programs, seconds (0 for draws that run them during set-up).
    pub vertex: f64,
    /// Stages 2-4, clip + setup + bin, seconds.
    pub setup_bin: f64,
    /// Stages 5-6, raster + fragment operations, seconds.
    pub raster_fragment: f64,
    /// Fragment-list merging, seconds.
    pub list_merge: f64,
    /// Draw calls timed.
    pub draws: u64,
}

impl std::ops::AddAssign for StageTimes {
    fn add_assign(&mut self, o: StageTimes) {
        self.vertex += o.vertex;
        self.setup_bin += o.setup_bin;
        self.raster_fragment += o.raster_fragment;
        self.list_merge += o.list_merge;
        self.draws += o.draws;
    }
}

/// The pipeline: a worker pool and the draw call. Output never depends on the thread count.
pub struct Pipeline {
    pool: rayon::ThreadPool,
    threads: usize,
    times: std::sync::Mutex<StageTimes>,
}

impl fmt::Debug for Pipeline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Pipeline").field("threads", &self.threads).finish()
    }
}

impl Pipeline {
    /// A pipeline with `threads` workers (0: one per available core).
    pub fn new(threads: usize) -> Result<Self, PipelineError> {
        let n = if threads == 0 {
            std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
        } else {
            threads
        };
        if n > 1024 {
            return Err(PipelineError::BadArgument(format!(
                "thread count {n} is absurd (at most 1024)"
            )));
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| PipelineError::BadArgument(format!("cannot start {n} worker threads: {e}")))?;
        Ok(Pipeline {
            pool,
            threads: n,
            times: Default::default(),
        })
    }

    /// Worker count.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Per-stage times accumulated since the last call, and resets them.
    pub fn take_times(&self) -> StageTimes {
        std::mem::take(&mut *self.times.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// Fills a surface with `value` on the pipeline's workers (a render-target clear).
    pub fn clear<T: surface::Texel>(&self, s: &mut Surface<T>, value: T) {
        let w = s.width() as usize;
        self.pool
            .install(|| s.data_mut().par_chunks_mut(w * 16).for_each(|c| c.fill(value)));
    }

    /// Runs `f` on the pipeline's workers (for compute passes that use rayon).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.pool.install(f)
    }

    /// Draws an indexed triangle list: `indices` holds 3 vertex indices per triangle.
    ///
    /// Errors (and draws nothing) on a bad index buffer or mismatched targets; a full
    /// fragment-list pool is reported after the draw (other targets are written, the lists
    /// are left as they were).
    pub fn draw<VP, P, C>(
        &self,
        targets: &mut Targets<'_, C>,
        state: &RenderState,
        vertices: &[VP::In],
        indices: &[u32],
        vp: &VP,
        fp: &P,
    ) -> Result<DrawStats, PipelineError>
    where
        VP: VertexProgram,
        P: FragmentProgram<VP::Out>,
        C: ColorFormat,
    {
        let (width, height) = targets.size()?;
        check_indices(indices, vertices.len())?;
        let grid = TileGrid::new(width, height);
        let params = SetupParams::new(state, width, height);
        let clipper = Clipper::new(width, height, !state.depth.clamp);
        let raw = targets.raw(width);
        let ntri = indices.len() / 3;
        // Shading attributes are read only by fragment programs that run (see `shade_tile`).
        let needs_attrs = raw.color.is_some() || raw.lists || P::MAY_DISCARD || P::ORDERED;
        let depth_clear = targets.depth_clear.filter(|_| raw.depth.is_some());
        let color_clear = targets.color_clear.filter(|_| raw.color.is_some());
        if ntri == 0 {
            if let (Some(v), Some(d)) = (depth_clear, targets.depth.as_mut()) {
                self.clear(d, v);
            }
            if let (Some(v), Some(c)) = (color_clear, targets.color.as_mut()) {
                self.clear(c, v);
            }
        }
        let mut times = StageTimes {
            draws: 1,
            ..Default::default()
        };
        let (stats, tile_lists) = self.pool.install(|| {
            let t0 = std::time::Instant::now();
            // Stage 1: vertex programs (an indexed map: order-independent).
            // Per vertex, in the same pass: finite, clip outcode and, inside the clip volume,
            // the viewport transform (shared by the triangles around the vertex).
            let run = |v: &VP::In| {
                let (pos, var) = vp.run(v);
                ClipVertex { pos, var }
            };
            let pre = |pos: glam::Vec4| {
                bin::PreVertex::new(pos, |p| clipper.outcode(p), |p| setup::window_vertex(&params, p))
            };
            // A draw with at least one vertex per index shares (on average) no vertices: set-up
            // then runs the vertex program itself, once per index (no more often than the
            // stage would; again only for a triangle that needs clipping), and the stage's
            // arrays (tens of bytes per vertex, written then read back) are skipped.
            let on_demand = vertices.len() >= indices.len();
            let (verts, pres): (Vec<ClipVertex<VP::Out>>, Vec<bin::PreVertex>) = if on_demand {
                (Vec::new(), Vec::new())
            } else {
                vertices
                    .par_iter()
                    .with_min_len(1024)
                    .map(|v| {
                        let cv = run(v);
                        (cv, pre(cv.pos))
                    })
                    .unzip()
            };
            let arrays = bin::VertexArrays {
                verts: &verts,
                pre: &pres,
            };
            let lazy = bin::VertexOnDemand {
                input: vertices,
                run,
                pre,
            };
            if !on_demand {
                times.vertex += t0.elapsed().as_secs_f64();
            }
            let mut stats = DrawStats::default();
            let mut all_lists: Vec<(usize, TileLists)> = Vec::new();
            let nchunks = ntri.div_ceil(CHUNK);
            for batch in (0..nchunks).step_by(CHUNKS_PER_BATCH) {
                let batch_end = (batch + CHUNKS_PER_BATCH).min(nchunks);
                // Stages 2-4: clip, set up and bin each chunk.
                let t1 = std::time::Instant::now();
                let chunks: Vec<_> = (batch..batch_end)
                    .into_par_iter()
                    .map(|c| {
                        let (first, count) = (c * CHUNK, CHUNK.min(ntri - c * CHUNK));
                        if on_demand {
                            process_chunk(&lazy, indices, first, count, &params, &clipper, &grid, needs_attrs)
                        } else {
                            process_chunk(&arrays, indices, first, count, &params, &clipper, &grid, needs_attrs)
                        }
                    })
                    .collect();
                for c in &chunks {
                    stats += c.stats;
                }
                times.setup_bin += t1.elapsed().as_secs_f64();
                let t2 = std::time::Instant::now();
                // Stages 5-6: each tile walks the chunks in order (= submission order).
                // The first batch visits every tile when a target is cleared with the draw, so
                // untouched tiles are cleared too.
                let clears = (batch == 0).then_some((depth_clear, color_clear));
                let (tiles, results) = shade_tiles(&chunks, &grid, clears, state, &raw, fp);
                times.raster_fragment += t2.elapsed().as_secs_f64();
                for (&t, (s, l)) in tiles.iter().zip(results) {
                    stats += s;
                    if raw.lists && !l.nodes.is_empty() || l.overflow > 0 {
                        all_lists.push((t, l));
                    }
                }
            }
            (stats, all_lists)
        });
        let t3 = std::time::Instant::now();
        if let Some(lists) = targets.lists.as_mut() {
            merge_lists(lists, &tile_lists, &grid)?;
        }
        times.list_merge += t3.elapsed().as_secs_f64();
        *self.times.lock().unwrap_or_else(|e| e.into_inner()) += times;
        Ok(stats)
    }

    /// Draws with raster-ordered per-pixel storage: `program` is applied to every fragment
    /// that passes the depth and stencil tests of `targets` (which may hold depth and stencil,
    /// but no colour or lists), with exclusive access to its pixel's slice of `store`, one
    /// pixel's fragments in submission order (see [`ordered`]). The store must have the size
    /// of the draw. [`DrawStats::fragments_shaded`] counts the program's accesses.
    #[allow(clippy::too_many_arguments)]
    pub fn draw_ordered<VP, P, T>(
        &self,
        targets: &mut Targets<'_, Rgba8>,
        state: &RenderState,
        vertices: &[VP::In],
        indices: &[u32],
        vp: &VP,
        program: &P,
        store: &mut PixelStore<T>,
    ) -> Result<DrawStats, PipelineError>
    where
        VP: VertexProgram,
        P: OrderedProgram<VP::Out, T>,
        T: Copy + Send + Sync,
    {
        if targets.color.is_some() || targets.lists.is_some() {
            return Err(PipelineError::BadArgument(
                "a raster-ordered draw writes its store only: no colour target or fragment lists".into(),
            ));
        }
        let size = (store.width(), store.height());
        if targets.depth.is_none() && targets.stencil.is_none() {
            // No other target: a dummy size carrier is needed for the draw's size check.
            let mut dummy = Surface::new(size.0, size.1, 0u8)?;
            let mut t = Targets::none().with_stencil(&mut dummy);
            let st = RenderState {
                stencil: StencilState {
                    enabled: false,
                    ..state.stencil
                },
                ..*state
            };
            return self.draw(
                &mut t,
                &st,
                vertices,
                indices,
                vp,
                &ordered::Ordered::new(program, store),
            );
        }
        let got = targets.size()?;
        if got != size {
            return Err(PipelineError::SizeMismatch {
                what: "pixel store",
                expected: got,
                got: size,
            });
        }
        self.draw(
            targets,
            state,
            vertices,
            indices,
            vp,
            &ordered::Ordered::new(program, store),
        )
    }
}

/// Stages 5 and 6 of one batch of `chunks`: each tile that a chunk touches (every tile where
/// the draw `clears` a target, so untouched tiles are cleared too) walks the chunks in order
/// (= submission order) on the pipeline's workers. The tiles, and each one's counters and
/// fragment lists.
fn shade_tiles<V: Varyings, P: FragmentProgram<V>, C: ColorFormat>(
    chunks: &[bin::Chunk<V>],
    grid: &TileGrid,
    clears: Option<(Option<f32>, Option<C>)>,
    state: &RenderState,
    raw: &RawTargets<C>,
    fp: &P,
) -> (Vec<usize>, Vec<(DrawStats, TileLists)>) {
    let clearing = clears.is_some_and(|(d, c)| d.is_some() || c.is_some());
    let tiles: Vec<usize> = (0..grid.count())
        .filter(|&t| clearing || chunks.iter().any(|c| !c.tile_entries(t).is_empty()))
        .collect();
    let results: Vec<(DrawStats, TileLists)> = tiles
        .par_iter()
        .map(|&t| {
            let mut s = DrawStats::default();
            let mut l = TileLists::default();
            let rect = grid.rect(t);
            if let Some((dc, cc)) = clears {
                // SAFETY: the tile's rows are this worker's alone during the draw.
                if let (Some(v), Some(d)) = (dc, raw.depth.as_ref()) {
                    unsafe { d.fill_rect(rect, v) };
                }
                if let (Some(v), Some(c)) = (cc, raw.color.as_ref()) {
                    // SAFETY: as for the depth target: the tile's rows are this worker's alone.
                    unsafe { c.fill_rect(rect, v) };
                }
            }
            let work = TileWork {
                chunks,
                tile: t,
                rect,
                state,
                targets: raw,
                program: fp,
            };
            shade_tile(&work, &mut s, &mut l);
            (s, l)
        })
        .collect();
    (tiles, results)
}

/// Merges the tiles' fragment lists into `lists` in tile order (deterministic node indices),
/// or says that its pool is too small for them (and merges nothing).
fn merge_lists(
    lists: &mut FragmentLists,
    tile_lists: &[(usize, TileLists)],
    grid: &TileGrid,
) -> Result<(), PipelineError> {
    let needed: usize = tile_lists
        .iter()
        .map(|(_, l)| l.nodes.len() + l.overflow as usize)
        .sum();
    if lists.len() + needed > lists.capacity() {
        return Err(PipelineError::FragmentPoolFull {
            capacity: lists.capacity(),
            needed: lists.len() + needed,
        });
    }
    // Merge per-tile pools in tile order (deterministic node indices).
    for (t, l) in tile_lists {
        lists.merge_tile(grid.rect(*t), &l.nodes, &l.head, &l.tail);
    }
    lists.end_draw();
    Ok(())
}
