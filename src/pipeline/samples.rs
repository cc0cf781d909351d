//! Rasterization at non-uniform sample positions: the sample of column `i` and row `j` of the
//! target lies at window position `(xs[i], ys[j])` (fixed point, [`super::fixed::Fx8`]), two
//! monotone tables the draw supplies, instead of the pixel centre `(i + 1/2, j + 1/2)`. A
//! logarithmic shadow map (Lloyd et al. 2008) is a draw whose rows follow a logarithm: GPUs
//! cannot rasterize it, this can.
//!
//! Exactness: the edge functions are set up as for every draw ([`super::setup`]), and each is
//! evaluated at the warped sample positions in exact integer arithmetic,
//! `E(X, Y) = c + a (X - 1/2) + b (Y - 1/2)` (no tessellation, no approximation), with the same
//! top-left rule, so a sample on an edge shared by two triangles belongs to exactly one of
//! them, whatever the tables (watertight). Along a row `E` is monotone in the column (the
//! table increases), so each edge bounds the covered columns by one binary search.
//! Conservative modes test the sample's *cell* (from the midpoints between neighbouring
//! samples): overestimate covers a sample whose cell meets every edge's half-plane,
//! underestimate one whose cell lies inside all three, evaluated at the cell's extreme corner
//! per edge (exact as well).
//!
//! Depth is the triangle's window-depth plane at the sample position, plus the polygon offset,
//! clamped to [0, 1] and quantized to the format. The offset's slope term is the depth's
//! change across the sample's own cell, `factor * max(|dz/dx| w_i, |dz/dy| h_j)` with `w_i`,
//! `h_j` the cell's width and height in pixels: where samples are a pixel apart it is the
//! standard `factor * max(|dz/dx|, |dz/dy|)`, and where rows are spread wider (a logarithmic
//! map's rows near the eye) the bias grows with them, so a slope-scaled bias keeps covering
//! one sample's depth change.
//! Each 64 x 64 tile of samples takes its triangles in submission order on one worker, so the
//! result does not depend on the thread count.
//!
//! Depth-only: a draw at samples writes a depth surface (and counts); colour, stencil and
//! fragment lists are not offered in this mode.

use super::bin::{TileGrid, TILE};
use super::clip::{ClipVertex, Clipper};
use super::fixed::{HALF, ONE};
use super::setup::{self, Rejected, SetupParams, SetupTri};
use super::state::{RasterMode, RenderState};
use super::surface::Surface;
use super::{DrawStats, Pipeline, PipelineError};
use glam::Vec4;
use rayon::prelude::*;

/// The sample positions of a target: one monotone table per axis.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleGrid {
    /// Column `i`'s sample x (fixed point, 8 sub-pixel bits), strictly increasing.
    xs: Vec<i64>,
    /// Row `j`'s sample y (window y down), strictly increasing.
    ys: Vec<i64>,
    /// Each column's cell: from the midpoint with the previous sample to the next's.
    x_cells: (Vec<i64>, Vec<i64>),
    /// Each row's cell.
    y_cells: (Vec<i64>, Vec<i64>),
}

/// Snaps a table of window coordinates to fixed point; `what` names it in errors. Every entry
/// lies in `[0, t.len()]` (the viewport of a target as wide as the table).
fn snap(t: &[f64], what: &str) -> Result<Vec<i64>, PipelineError> {
    if t.is_empty() || t.len() > super::surface::MAX_DIMENSION as usize {
        return Err(PipelineError::BadArgument(format!(
            "sample table {what}: {} entries (1 to {} allowed)",
            t.len(),
            super::surface::MAX_DIMENSION
        )));
    }
    let mut out = Vec::with_capacity(t.len());
    for (i, v) in t.iter().enumerate() {
        if !(v.is_finite() && (0.0..=t.len() as f64).contains(v)) {
            return Err(PipelineError::BadArgument(format!(
                "sample table {what}[{i}] = {v}: not a window coordinate in [0, {}] (the viewport of {} samples)",
                t.len(),
                t.len()
            )));
        }
        let s = (v * ONE as f64).round() as i64;
        if let Some(&prev) = out.last() {
            if s <= prev {
                return Err(PipelineError::BadArgument(format!(
                    "sample table {what}[{i}] = {v}: not above the entry before it (the table must increase by at least 1/{ONE} pixel)"
                )));
            }
        }
        out.push(s);
    }
    Ok(out)
}

/// The cells of a snapped table: `[lo, hi]` around each sample, meeting at midpoints (the
/// end cells as wide on the outside as on the inside, within the viewport `[0, end]`).
fn cells(t: &[i64], end: i64) -> (Vec<i64>, Vec<i64>) {
    let n = t.len();
    let mid = |a: i64, b: i64| a + (b - a) / 2;
    let lo: Vec<i64> = (0..n)
        .map(|i| match i {
            0 if n > 1 => (t[0] - (mid(t[0], t[1]) - t[0])).max(0),
            0 => (t[0] - HALF).max(0),
            _ => mid(t[i - 1], t[i]),
        })
        .collect();
    let hi: Vec<i64> = (0..n)
        .map(|i| match i {
            _ if i + 1 < n => mid(t[i], t[i + 1]),
            _ if n > 1 => (t[i] + (t[i] - mid(t[i - 1], t[i]))).min(end),
            _ => (t[i] + HALF).min(end),
        })
        .collect();
    (lo, hi)
}

impl SampleGrid {
    /// A grid with column samples at window x `xs[i]` and row samples at window y `ys[j]`
    /// (pixels, y down; the viewport maps NDC [-1, 1] to [0, width] and [0, height]). Each
    /// table must be finite and strictly increasing after snapping to 1/256 pixel; the
    /// target is `xs.len()` x `ys.len()`.
    pub fn new(xs: &[f64], ys: &[f64]) -> Result<SampleGrid, PipelineError> {
        let (xs, ys) = (snap(xs, "x")?, snap(ys, "y")?);
        Ok(SampleGrid {
            x_cells: cells(&xs, xs.len() as i64 * ONE),
            y_cells: cells(&ys, ys.len() as i64 * ONE),
            xs,
            ys,
        })
    }

    /// Pixel centres: the standard rasterizer's samples (for comparisons).
    pub fn uniform(width: u32, height: u32) -> Result<SampleGrid, PipelineError> {
        let centres = |n: u32| (0..n).map(|i| i as f64 + 0.5).collect::<Vec<_>>();
        SampleGrid::new(&centres(width), &centres(height))
    }

    /// Only the rows warped: columns at pixel centres, rows at `ys` (LogPSM's one warped
    /// axis).
    pub fn rows(width: u32, ys: &[f64]) -> Result<SampleGrid, PipelineError> {
        let xs: Vec<f64> = (0..width).map(|i| i as f64 + 0.5).collect();
        SampleGrid::new(&xs, ys)
    }

    /// Columns (the target's width).
    pub fn width(&self) -> u32 {
        self.xs.len() as u32
    }

    /// Rows (the target's height).
    pub fn height(&self) -> u32 {
        self.ys.len() as u32
    }

    /// Column `i`'s sample x in window pixels (as snapped).
    pub fn x(&self, i: usize) -> f64 {
        self.xs[i] as f64 / ONE as f64
    }

    /// Row `j`'s sample y in window pixels (as snapped).
    pub fn y(&self, j: usize) -> f64 {
        self.ys[j] as f64 / ONE as f64
    }

    /// Column `i`'s cell width in pixels (from the midpoint with the previous sample to the
    /// next's): what the polygon offset's slope term is scaled by.
    pub fn cell_width(&self, i: usize) -> f64 {
        (self.x_cells.1[i] - self.x_cells.0[i]) as f64 / ONE as f64
    }

    /// Row `j`'s cell height in pixels.
    pub fn cell_height(&self, j: usize) -> f64 {
        (self.y_cells.1[j] - self.y_cells.0[j]) as f64 / ONE as f64
    }
}

/// One edge for sample tests: `E(X, Y) = c + a (X - HALF) + b (Y - HALF)` in fixed point,
/// without any bias, and whether it is a top or left edge.
#[derive(Copy, Clone, Debug)]
struct RawEdge {
    a: i64,
    b: i64,
    c: i64,
    top_left: bool,
}

/// A triangle of a draw at samples: its edges, its depth plane and its sample box.
#[derive(Copy, Clone, Debug)]
struct SampleTri {
    edges: [RawEdge; 3],
    tri: SetupTri,
    /// Inclusive sample box `[i0, j0, i1, j1]`.
    bbox: [i32; 4],
}

/// First index whose value is at least `v` in an increasing table (`t.len()` if none).
fn first_at_least(t: &[i64], v: i64) -> usize {
    t.partition_point(|x| *x < v)
}

/// Ceiling of `n / d` for `d > 0`.
fn ceil_div(n: i64, d: i64) -> i64 {
    -((-n).div_euclid(d))
}

impl SampleGrid {
    /// The triangle's edges without the set-up's conservative shift and its sample box (the
    /// samples whose cells meet its window box `[x0, y0, x1, y1]`, fixed point), or `None`
    /// when no sample can be covered.
    fn prepare(&self, t: SetupTri, [x0, y0, x1, y1]: [i64; 4]) -> Option<SampleTri> {
        // Set-up ran in overestimate mode (its box then holds every window point the triangle
        // touches): undo the shift of `(|a| + |b|) / 2` pixel it folded into `c`.
        let edges = t.edges.map(|e| {
            let (a, b) = (e.dx / ONE, e.dy / ONE);
            RawEdge {
                a,
                b,
                c: e.c - (a.abs() + b.abs()) * HALF,
                top_left: (a > 0) | ((a == 0) & (b > 0)),
            }
        });
        let span = |lo: &Vec<i64>, hi: &Vec<i64>, a: i64, b: i64| {
            // Samples whose cell meets [a, b] (a superset of those inside it).
            let first = hi.partition_point(|h| *h < a);
            let last = lo.partition_point(|l| *l <= b);
            (first < last).then(|| (first as i32, last as i32 - 1))
        };
        let (i0, i1) = span(&self.x_cells.0, &self.x_cells.1, x0, x1)?;
        let (j0, j1) = span(&self.y_cells.0, &self.y_cells.1, y0, y1)?;
        Some(SampleTri {
            edges,
            tri: t,
            bbox: [i0, j0, i1, j1],
        })
    }

    /// The covered columns `[l, r]` of row `j` within `[i0, i1]` for triangle `s` in `mode`.
    fn row_span(&self, s: &SampleTri, mode: RasterMode, j: usize, i0: usize, i1: usize) -> Option<(usize, usize)> {
        let (mut l, mut r) = (i0, i1 + 1);
        for e in &s.edges {
            // The row's part of E and the column positions it is tested at: the sample, or
            // the cell corner that makes E largest (overestimate) or least (underestimate).
            let (y, xs, bias) = match mode {
                RasterMode::Standard => (self.ys[j], &self.xs, (!e.top_left) as i64),
                RasterMode::Overestimate => (
                    if e.b > 0 { self.y_cells.1[j] } else { self.y_cells.0[j] },
                    if e.a > 0 { &self.x_cells.1 } else { &self.x_cells.0 },
                    0,
                ),
                RasterMode::Underestimate => (
                    if e.b > 0 { self.y_cells.0[j] } else { self.y_cells.1[j] },
                    if e.a > 0 { &self.x_cells.0 } else { &self.x_cells.1 },
                    0,
                ),
            };
            // Inside: c - bias + b (y - HALF) + a (x - HALF) >= 0.
            let k = e.c - bias + e.b * (y - HALF);
            if e.a > 0 {
                // x >= HALF + ceil(-k / a).
                let t = HALF + ceil_div(-k, e.a);
                l = l.max(i0 + first_at_least(&xs[i0..=i1], t));
            } else if e.a < 0 {
                // x <= HALF + floor(k / -a).
                let t = HALF + k.div_euclid(-e.a);
                r = r.min(i0 + first_at_least(&xs[i0..=i1], t + 1));
            } else if k < 0 {
                return None;
            }
        }
        (l < r).then(|| (l, r - 1))
    }
}

impl Pipeline {
    /// Draws triangles (clip-space `positions`, indexed) into `depth` at the sample positions
    /// of `grid` (see the module docs), with `state`'s culling, raster mode, polygon offset,
    /// depth test, write and format. `clear` fills the target first. The target must be the
    /// grid's size. Returns the draw's counters.
    pub fn draw_depth_at(
        &self,
        depth: &mut Surface<f32>,
        clear: Option<f32>,
        state: &RenderState,
        positions: &[Vec4],
        indices: &[u32],
        grid: &SampleGrid,
    ) -> Result<DrawStats, PipelineError> {
        let (width, height) = (depth.width(), depth.height());
        if (width, height) != (grid.width(), grid.height()) {
            return Err(PipelineError::SizeMismatch {
                what: "depth target against the sample grid",
                expected: (grid.width(), grid.height()),
                got: (width, height),
            });
        }
        let (tris, mut stats) = self.setup_at(state, positions, indices, grid)?;
        let tiles = TileGrid::new(width, height);
        let bins = bin(&tris, &tiles, &mut stats);
        let mode = state.raster;
        let func = state.depth.func;
        let write = state.depth.write;
        let fmt = state.depth.format;
        let stride = width as usize;
        // Window positions of the samples relative to pixel (0, 0)'s centre, as the depth
        // plane takes them.
        let xf: Vec<f64> = (0..width as usize).map(|i| grid.x(i) - 0.5).collect();
        let yf: Vec<f64> = (0..height as usize).map(|j| grid.y(j) - 0.5).collect();
        // The offset's slope term per sample cell (see the module docs).
        let factor = state.offset.factor;
        let cw: Vec<f64> = (0..width as usize).map(|i| grid.cell_width(i)).collect();
        let ch: Vec<f64> = (0..height as usize).map(|j| grid.cell_height(j)).collect();
        let data = depth.data_mut();
        let ptr = RawPtr(data.as_mut_ptr());
        let results: Vec<DrawStats> = self.pool.install(|| {
            (0..tiles.count())
                .into_par_iter()
                .map(|t| {
                    let ptr = &ptr;
                    let rect = tiles.rect(t);
                    let mut s = DrawStats::default();
                    if let Some(v) = clear {
                        for y in rect[1]..=rect[3] {
                            for x in rect[0]..=rect[2] {
                                // SAFETY: the tile's samples are this worker's alone.
                                unsafe { *ptr.0.add(y as usize * stride + x as usize) = v };
                            }
                        }
                    }
                    for &k in &bins[t] {
                        let st = &tris[k as usize];
                        let (i0, i1) = (st.bbox[0].max(rect[0]) as usize, st.bbox[2].min(rect[2]) as usize);
                        let (j0, j1) = (st.bbox[1].max(rect[1]) as usize, st.bbox[3].min(rect[3]) as usize);
                        let z = st.tri.z;
                        // The units term (the set-up's offset, computed without the factor).
                        let zoff = st.tri.z_offset;
                        let (sx, sy) = (z.dx.abs(), z.dy.abs());
                        for (j, y) in yf.iter().enumerate().take(j1 + 1).skip(j0) {
                            let Some((l, r)) = grid.row_span(st, mode, j, i0, i1) else {
                                continue;
                            };
                            s.fragments_rasterized += (r - l + 1) as u64;
                            let zrow = z.c + z.dy * y;
                            let rise = sy * ch[j];
                            for (i, x) in xf.iter().enumerate().take(r + 1).skip(l) {
                                let off = if factor != 0.0 {
                                    zoff + factor * (sx * cw[i]).max(rise) as f32
                                } else {
                                    zoff
                                };
                                let v = fmt.quantize((((zrow + z.dx * x) as f32) + off).clamp(0.0, 1.0));
                                // SAFETY: (i, j) lies in this worker's tile.
                                let p = unsafe { ptr.0.add(j * stride + i) };
                                // SAFETY: `p` is (i, j) of this worker's tile (above).
                                let old = unsafe { *p };
                                if func.test(v, old) {
                                    s.fragments_passed += 1;
                                    if write {
                                        // SAFETY: `p` is (i, j) of this worker's tile, written by this worker alone.
                                        unsafe { *p = v };
                                    }
                                } else {
                                    s.early_z_killed += 1;
                                }
                            }
                        }
                    }
                    s
                })
                .collect()
        });
        for r in results {
            stats += r;
        }
        Ok(stats)
    }

    /// How many triangles of a draw cover each sample of `grid` (row-major, `width x height`
    /// counts), with `state`'s culling and raster mode: the coverage a draw at samples
    /// would have, without depth. For tests and for explaining a draw.
    pub fn coverage_at(
        &self,
        state: &RenderState,
        positions: &[Vec4],
        indices: &[u32],
        grid: &SampleGrid,
    ) -> Result<Vec<u32>, PipelineError> {
        let (tris, mut stats) = self.setup_at(state, positions, indices, grid)?;
        let tiles = TileGrid::new(grid.width(), grid.height());
        let bins = bin(&tris, &tiles, &mut stats);
        let w = grid.width() as usize;
        let per_tile: Vec<Vec<(usize, usize, usize)>> = self.pool.install(|| {
            (0..tiles.count())
                .into_par_iter()
                .map(|t| {
                    let rect = tiles.rect(t);
                    let mut spans = Vec::new();
                    for &k in &bins[t] {
                        let st = &tris[k as usize];
                        let (i0, i1) = (st.bbox[0].max(rect[0]) as usize, st.bbox[2].min(rect[2]) as usize);
                        for j in st.bbox[1].max(rect[1]) as usize..=st.bbox[3].min(rect[3]) as usize {
                            if let Some((l, r)) = grid.row_span(st, state.raster, j, i0, i1) {
                                spans.push((j, l, r));
                            }
                        }
                    }
                    spans
                })
                .collect()
        });
        let mut counts = vec![0u32; w * grid.height() as usize];
        for (j, l, r) in per_tile.into_iter().flatten() {
            for c in &mut counts[j * w + l..=j * w + r] {
                *c += 1;
            }
        }
        Ok(counts)
    }

    /// Clip and set up every triangle for a draw at `grid`'s samples, in submission order.
    fn setup_at(
        &self,
        state: &RenderState,
        positions: &[Vec4],
        indices: &[u32],
        grid: &SampleGrid,
    ) -> Result<(Vec<SampleTri>, DrawStats), PipelineError> {
        super::check_indices(indices, positions.len())?;
        let (width, height) = (grid.width(), grid.height());
        let mut params = SetupParams::new(state, width, height);
        params.raster = RasterMode::Overestimate;
        // The offset's slope term is added per sample cell by the draw.
        params.offset.factor = 0.0;
        let clipper = Clipper::new(width, height, !state.depth.clamp);
        let per: Vec<(Vec<SampleTri>, DrawStats)> = self.pool.install(|| {
            indices
                .par_chunks(3 * 1024)
                .enumerate()
                .map(|(c, chunk)| {
                    let mut out = Vec::new();
                    let mut s = DrawStats::default();
                    let (mut poly, mut tmp) = (Vec::new(), Vec::new());
                    for (k, t) in chunk.chunks_exact(3).enumerate() {
                        let prim = (c * 1024 + k) as u32;
                        s.triangles_in += 1;
                        let v = [0, 1, 2].map(|q| ClipVertex {
                            pos: positions[t[q] as usize],
                            var: (),
                        });
                        if v.iter()
                            .any(|p| !p.pos.is_finite() || p.pos.abs().max_element() > super::clip::MAX_CLIP_COORD)
                        {
                            s.dropped_nonfinite += 1;
                            continue;
                        }
                        let mask = v.iter().fold(0, |m, p| m | clipper.outcode(p.pos));
                        if mask == 0 {
                            poly.clear();
                            poly.extend_from_slice(&v);
                        } else {
                            s.clipped += 1;
                            clipper.clip_polygon(v, mask, &mut poly, &mut tmp);
                            s.clip_triangles_out += poly.len().saturating_sub(2) as u64;
                        }
                        for q in 1..poly.len().saturating_sub(1) {
                            let tri = [poly[0], poly[q], poly[q + 1]];
                            let win = match tri.map(|v| setup::window_vertex(&params, v.pos)) {
                                [Ok(a), Ok(b), Ok(c)] => Ok([a, b, c]),
                                _ => Err(Rejected::NonFinite),
                            };
                            // The triangle's exact window box (the set-up's is in pixels).
                            let boxed = win.map_or([0; 4], |[a, b, c]| {
                                [
                                    a.x.min(b.x).min(c.x),
                                    a.y.min(b.y).min(c.y),
                                    a.x.max(b.x).max(c.x),
                                    a.y.max(b.y).max(c.y),
                                ]
                            });
                            match win.and_then(|w| setup::setup_window_parts::<()>(&params, w, prim)) {
                                Ok((st, _, _)) => match grid.prepare(st, boxed) {
                                    Some(p) => {
                                        s.triangles_setup += 1;
                                        out.push(p);
                                    }
                                    None => s.culled_outside += 1,
                                },
                                Err(Rejected::Culled) => s.culled_backface += 1,
                                Err(Rejected::Degenerate) => s.culled_degenerate += 1,
                                Err(Rejected::Outside) => s.culled_outside += 1,
                                Err(Rejected::NonFinite) => s.dropped_nonfinite += 1,
                            }
                        }
                    }
                    (out, s)
                })
                .collect()
        });
        let mut stats = DrawStats::default();
        let mut tris = Vec::new();
        for (t, s) in per {
            tris.extend(t);
            stats += s;
        }
        Ok((tris, stats))
    }
}

/// The triangles of each tile, in submission order.
fn bin(tris: &[SampleTri], tiles: &TileGrid, stats: &mut DrawStats) -> Vec<Vec<u32>> {
    let mut bins = vec![Vec::new(); tiles.count()];
    for (k, t) in tris.iter().enumerate() {
        for ty in t.bbox[1] / TILE..=t.bbox[3] / TILE {
            for tx in t.bbox[0] / TILE..=t.bbox[2] / TILE {
                bins[(ty * tiles.nx + tx) as usize].push(k as u32);
                stats.bin_entries += 1;
            }
        }
    }
    bins
}

/// The depth target's samples, shared by the tile workers (each writes only its tile).
struct RawPtr(*mut f32);
// SAFETY: workers write disjoint tiles of the surface, which outlives the parallel loop.
unsafe impl Sync for RawPtr {}
// SAFETY: as for `Sync`: the pointer is only used for disjoint tiles of a live surface.
unsafe impl Send for RawPtr {}

#[cfg(test)]
mod tests {
    use super::super::state::CompareFunc;
    use super::*;

    #[test]
    fn tables_must_increase_and_be_finite() {
        assert!(SampleGrid::new(&[0.5, 1.5], &[0.5]).is_ok());
        for bad in [&[1.0, 1.0][..], &[1.5, 1.0], &[f64::NAN], &[], &[-0.5], &[1.5]] {
            assert!(SampleGrid::new(bad, &[0.5]).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn cells_meet_at_midpoints() {
        let t = [64, 256, 700];
        let (lo, hi) = cells(&t, 768);
        assert_eq!(lo, vec![0, 160, 478]);
        assert_eq!(hi, vec![160, 478, 768]);
    }

    #[test]
    fn the_uniform_grid_covers_what_the_standard_rasterizer_does() {
        // A few triangles; the pixel-centre grid must give the standard coverage.
        let p = Pipeline::new(2).unwrap();
        let pos = [
            Vec4::new(-0.9, -0.8, 0.5, 1.0),
            Vec4::new(0.7, -0.3, 0.5, 1.0),
            Vec4::new(0.1, 0.9, 0.5, 1.0),
            Vec4::new(0.95, 0.95, 0.2, 1.0),
        ];
        let idx = [0, 1, 2, 1, 3, 2];
        let (w, h) = (37u32, 23u32);
        let state = RenderState::default();
        let grid = SampleGrid::uniform(w, h).unwrap();
        let counts = p.coverage_at(&state, &pos, &idx, &grid).unwrap();
        let mut d = Surface::new(w, h, 1.0f32).unwrap();
        let mut std_d = Surface::new(w, h, 1.0f32).unwrap();
        let vp = super::super::ClipPassthrough;
        let mut st = state;
        st.depth.func = CompareFunc::Always;
        let stats = p
            .draw(
                &mut super::super::Targets::depth_only(&mut std_d),
                &st,
                &pos,
                &idx,
                &vp,
                &super::super::DepthOnly,
            )
            .unwrap();
        let at = p.draw_depth_at(&mut d, Some(1.0), &st, &pos, &idx, &grid).unwrap();
        assert_eq!(stats.fragments_rasterized, at.fragments_rasterized);
        assert_eq!(counts.iter().map(|c| *c as u64).sum::<u64>(), at.fragments_rasterized);
        // The same samples; depths to rounding (the standard path steps an f32 plane).
        for (a, b) in std_d.data().iter().zip(d.data()) {
            assert!((a - b).abs() < 1e-6, "{a} {b}");
            assert_eq!(*a == 1.0, *b == 1.0);
        }
    }
}
