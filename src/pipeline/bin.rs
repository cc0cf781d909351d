//! Stage 4, bin: set-up triangles into screen tiles, in submission order.
//!
//! Triangles are processed in fixed-size chunks (independent of the thread count). Each chunk
//! assembles, clips and sets up its triangles and sorts them into a per-tile index list (a
//! counting sort, so the order inside each tile list is submission order). A tile later walks
//! the chunks in order, which is the whole draw in submission order.

use super::clip::{ClipVertex, Clipper};
use super::setup::{setup_triangle, setup_window_parts, Rejected, SetupParams, SetupTri, TriAttrs, WinVertex};
use super::stats::DrawStats;
use super::vertex::Varyings;

/// Tile side in pixels.
pub const TILE: i32 = 64;
/// log2 of [`TILE`].
pub const TILE_SHIFT: i32 = 6;
/// Triangles per binning chunk (fixed, so results never depend on the thread count). A tile
/// walks every chunk of its batch, and moving to the next chunk after a few of its triangles
/// is a branch no predictor guesses: 4096 instead of 1024 took a fifth of the mispredicted
/// branches of 100k random triangles away and cut set-up and binning by about 10 %.
pub const CHUNK: usize = 4096;

/// The tile grid of a target.
#[derive(Copy, Clone, Debug)]
pub struct TileGrid {
    /// Tiles across.
    pub nx: i32,
    /// Tiles down.
    pub ny: i32,
    /// Target width in pixels.
    pub width: i32,
    /// Target height in pixels.
    pub height: i32,
}

impl TileGrid {
    /// The grid covering a `width` x `height` target.
    pub fn new(width: u32, height: u32) -> Self {
        let (w, h) = (width as i32, height as i32);
        TileGrid {
            nx: (w + TILE - 1) / TILE,
            ny: (h + TILE - 1) / TILE,
            width: w,
            height: h,
        }
    }

    /// Number of tiles.
    pub fn count(&self) -> usize {
        (self.nx * self.ny) as usize
    }

    /// Inclusive pixel rectangle `[x0, y0, x1, y1]` of tile `t`.
    pub fn rect(&self, t: usize) -> [i32; 4] {
        let tx = t as i32 % self.nx;
        let ty = t as i32 / self.nx;
        let x0 = tx * TILE;
        let y0 = ty * TILE;
        [
            x0,
            y0,
            (x0 + TILE - 1).min(self.width - 1),
            (y0 + TILE - 1).min(self.height - 1),
        ]
    }
}

/// What the vertex stage precomputes per vertex for setup: 40 bytes (an `Option` and a
/// `bool` made it 48), written once per vertex and read three times per triangle.
#[derive(Copy, Clone, Debug)]
pub struct PreVertex {
    /// Clip outcode (bits of the planes the position is outside of), plus
    /// [`PreVertex::NON_FINITE`] and [`PreVertex::NO_WINDOW`].
    pub code: u32,
    /// Window position; meaningful only when `code == 0`.
    pub win: WinVertex,
}

impl PreVertex {
    /// Flag: the position is not finite or beyond [`super::clip::MAX_CLIP_COORD`] (no plane
    /// bits are set then).
    pub const NON_FINITE: u32 = 1 << 31;
    /// Flag: inside every plane, but the window position was rejected (set-up runs again on
    /// the clip vertices and reports why).
    pub const NO_WINDOW: u32 = 1 << 30;
    /// The clip-plane bits of `code`.
    pub const PLANES: u32 = !(Self::NON_FINITE | Self::NO_WINDOW);

    /// Set-up data of a clip position: `outcode` gives its plane bits, `window` its window
    /// position (asked only inside every plane).
    #[inline(always)]
    pub fn new(
        pos: glam::Vec4,
        outcode: impl Fn(glam::Vec4) -> u32,
        window: impl Fn(glam::Vec4) -> Result<WinVertex, Rejected>,
    ) -> Self {
        let none = WinVertex {
            x: 0,
            y: 0,
            z: 0.0,
            iw: 0.0,
        };
        if !(pos.is_finite() && pos.abs().max_element() <= super::clip::MAX_CLIP_COORD) {
            return PreVertex {
                code: Self::NON_FINITE,
                win: none,
            };
        }
        let code = outcode(pos);
        if code != 0 {
            return PreVertex { code, win: none };
        }
        match window(pos) {
            Ok(win) => PreVertex { code: 0, win },
            Err(_) => PreVertex {
                code: Self::NO_WINDOW,
                win: none,
            },
        }
    }
}

/// Where set-up finds a triangle's vertices: the vertex stage's output arrays, or the vertex
/// program run on the spot (for draws that share no vertices, see `Pipeline::draw`).
pub trait VertexSource<V>: Sync {
    /// The source runs the vertex program for each request (rather than reading stored
    /// results): set-up then asks for positions and varyings together ([`VertexSource::both3`]).
    const COMPUTES: bool = false;
    /// Clip outcodes, validity and window positions of three vertices.
    fn pre3(&self, ia: [usize; 3]) -> [PreVertex; 3];
    /// Clip-space positions and varyings of three vertices.
    fn clip3(&self, ia: [usize; 3]) -> [ClipVertex<V>; 3];
    /// The varyings of vertex `i`.
    fn var(&self, i: usize) -> V;
    /// Both of the above (a source that computes vertices computes each once).
    #[inline(always)]
    fn both3(&self, ia: [usize; 3]) -> ([PreVertex; 3], [ClipVertex<V>; 3]) {
        (self.pre3(ia), self.clip3(ia))
    }
}

/// The vertex stage's output, one entry per input vertex.
pub struct VertexArrays<'a, V> {
    /// Clip vertices.
    pub verts: &'a [ClipVertex<V>],
    /// Their pre-computed set-up data.
    pub pre: &'a [PreVertex],
}

impl<V: Varyings> VertexSource<V> for VertexArrays<'_, V> {
    #[inline(always)]
    fn pre3(&self, ia: [usize; 3]) -> [PreVertex; 3] {
        [self.pre[ia[0]], self.pre[ia[1]], self.pre[ia[2]]]
    }
    #[inline(always)]
    fn clip3(&self, ia: [usize; 3]) -> [ClipVertex<V>; 3] {
        [self.verts[ia[0]], self.verts[ia[1]], self.verts[ia[2]]]
    }
    #[inline(always)]
    fn var(&self, i: usize) -> V {
        self.verts[i].var
    }
}

/// Vertices computed when set-up asks for them: `run` maps an input vertex to its clip
/// vertex, `pre` a clip vertex to its set-up data (both pure, so running them again gives the
/// same values the vertex stage would have stored).
pub struct VertexOnDemand<'a, In, R, P> {
    /// The draw's input vertices.
    pub input: &'a [In],
    /// The vertex program.
    pub run: R,
    /// Outcode, validity and viewport transform of a clip position.
    pub pre: P,
}

impl<V: Varyings, In: Sync, R, P> VertexSource<V> for VertexOnDemand<'_, In, R, P>
where
    R: Fn(&In) -> ClipVertex<V> + Sync,
    P: Fn(glam::Vec4) -> PreVertex + Sync,
{
    const COMPUTES: bool = true;
    #[inline(always)]
    fn pre3(&self, ia: [usize; 3]) -> [PreVertex; 3] {
        let f = |i: usize| (self.pre)((self.run)(&self.input[i]).pos);
        [f(ia[0]), f(ia[1]), f(ia[2])]
    }
    #[inline(always)]
    fn clip3(&self, ia: [usize; 3]) -> [ClipVertex<V>; 3] {
        let f = |i: usize| (self.run)(&self.input[i]);
        [f(ia[0]), f(ia[1]), f(ia[2])]
    }
    #[inline(always)]
    fn var(&self, i: usize) -> V {
        (self.run)(&self.input[i]).var
    }
    #[inline(always)]
    fn both3(&self, ia: [usize; 3]) -> ([PreVertex; 3], [ClipVertex<V>; 3]) {
        let c = self.clip3(ia);
        ([(self.pre)(c[0].pos), (self.pre)(c[1].pos), (self.pre)(c[2].pos)], c)
    }
}

/// Average triangles per touched tile from which a chunk bins indices instead of copies.
const COHERENT: usize = 8;

/// The binned output of one chunk of triangles.
pub struct Chunk<V> {
    /// Shading attributes of the chunk's triangles, in submission order (indexed by
    /// [`SetupTri::attr`]; empty when the varyings are empty).
    pub attrs: Vec<TriAttrs<V>>,
    /// Entries `offsets[t]..offsets[t + 1]` of `binned` are the triangles touching tile `t`.
    pub offsets: Vec<u32>,
    /// Set-up triangles: in submission order for coherent chunks (many triangles per tile,
    /// as meshes drawn in order give), so each is stored once and a tile reads nearby
    /// triangles; for scattered chunks (a few triangles per tile) copies grouped by tile, so
    /// each tile reads its triangles sequentially instead of missing the cache on every one.
    pub tris: Vec<SetupTri>,
    /// Indices into `tris`, grouped by tile, each group in submission order; empty for
    /// scattered chunks, whose copies are already in that order (entry `j` is `tris[j]`).
    pub binned: Vec<u32>,
    /// Counters of stages 2 to 4.
    pub stats: DrawStats,
}

/// How many of a tile's triangles ahead [`Chunk::prefetch`] is asked for.
pub(crate) const PREFETCH_TRIS: usize = 6;

impl<V> Chunk<V> {
    /// The entries of tile `tile`'s list (indices into [`Chunk::binned`], or into
    /// [`Chunk::tris`] for scattered chunks).
    #[inline(always)]
    pub(crate) fn tile_entries(&self, tile: usize) -> std::ops::Range<usize> {
        self.offsets[tile] as usize..self.offsets[tile + 1] as usize
    }

    /// The set-up triangle of entry `j` of the tile lists (see [`Chunk::binned`]).
    #[inline(always)]
    fn entry(&self, j: usize) -> usize {
        if self.binned.is_empty() {
            j
        } else {
            self.binned[j] as usize
        }
    }

    /// Asks the memory system for set-up triangle `i` and its shading attributes (if the
    /// chunk keeps them), without waiting: a tile walks its triangles by index, and a batch's
    /// set-up data is far larger than the caches.
    #[inline(always)]
    pub(crate) fn prefetch(&self, i: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let lines = |p: *const i8, bytes: usize| {
                for off in (0..bytes).step_by(64) {
                    // SAFETY: prefetching never faults; the address is inside the element.
                    unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
                }
                // The element's last byte (it may start mid-line).
                // SAFETY: a prefetch never faults.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(bytes - 1)) };
            };
            if let Some(t) = self.tris.get(i) {
                lines(t as *const SetupTri as *const i8, std::mem::size_of::<SetupTri>());
            }
            // A triangle's attributes sit at its own index (`SetupTri::attr == i` in both
            // binning layouts), so they are found without reading the triangle.
            if let Some(a) = self.attrs.get(i) {
                lines(a as *const TriAttrs<V> as *const i8, std::mem::size_of::<TriAttrs<V>>());
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = i;
    }
}

/// A position in one tile's walk: chunk `c` and its tile list `binned[j..end]`.
#[derive(Copy, Clone)]
struct Cursor {
    c: usize,
    j: usize,
    end: usize,
}

impl Cursor {
    /// The first entry at or after this position (moving on to later chunks when the current
    /// one's list is used up), or `None` past the last chunk.
    #[inline(always)]
    fn settle<V>(&mut self, chunks: &[Chunk<V>], tile: usize) -> Option<()> {
        while self.j >= self.end {
            self.c += 1;
            let r = chunks.get(self.c)?.tile_entries(tile);
            (self.j, self.end) = (r.start, r.end);
        }
        Some(())
    }
}

/// The triangles of one tile with their shading attributes, in submission order (chunk by
/// chunk, each chunk's tile list). A second cursor runs [`PREFETCH_TRIS`] entries ahead of
/// the walk, across chunk boundaries, and prefetches the triangle it passes: scattered
/// chunks hold only a few triangles per tile, so a look-ahead confined to one chunk would
/// miss the cache at every chunk's first triangles.
pub(crate) struct TileTris<'a, V> {
    chunks: &'a [Chunk<V>],
    tile: usize,
    /// The next entry of the walk.
    at: Cursor,
    /// The next entry to prefetch (`None` once past the last chunk).
    ahead: Option<Cursor>,
}

impl<'a, V> TileTris<'a, V> {
    /// The walk over tile `tile` of `chunks`.
    #[inline(always)]
    pub(crate) fn new(chunks: &'a [Chunk<V>], tile: usize) -> Self {
        let first = chunks.first().map_or(0..0, |c| c.tile_entries(tile));
        let at = Cursor {
            c: 0,
            j: first.start,
            end: first.end,
        };
        let mut walk = TileTris {
            chunks,
            tile,
            at,
            ahead: Some(at),
        };
        for _ in 0..PREFETCH_TRIS {
            walk.prefetch_next();
        }
        walk
    }

    /// Prefetches the look-ahead cursor's entry and moves it on by one.
    #[inline(always)]
    fn prefetch_next(&mut self) {
        if let Some(a) = self.ahead.as_mut() {
            if a.settle(self.chunks, self.tile).is_some() {
                let c = &self.chunks[a.c];
                c.prefetch(c.entry(a.j));
                a.j += 1;
            } else {
                self.ahead = None;
            }
        }
    }
}

impl<'a, V> Iterator for TileTris<'a, V> {
    type Item = (&'a SetupTri, Option<&'a TriAttrs<V>>);
    #[inline(always)]
    fn next(&mut self) -> Option<Self::Item> {
        self.at.settle(self.chunks, self.tile)?;
        self.prefetch_next();
        let c = &self.chunks[self.at.c];
        let tri = &c.tris[c.entry(self.at.j)];
        self.at.j += 1;
        Some((tri, c.attrs.get(tri.attr as usize)))
    }
}

/// True if no pixel centre of `rect` can pass all edges (conservative: may keep a tile that
/// ends up empty, never drops a covered one).
#[inline]
pub fn rect_rejected(tri: &SetupTri, rect: [i32; 4]) -> bool {
    let (x0, y0, x1, y1) = (rect[0] as i64, rect[1] as i64, rect[2] as i64, rect[3] as i64);
    tri.edges.iter().any(|e| {
        let x = if e.dx > 0 { x1 } else { x0 };
        let y = if e.dy > 0 { y1 } else { y0 };
        e.at(x, y) < 0
    })
}

/// Stages 2-4 for triangles `first..first + count` of an indexed list: assemble, drop
/// non-finite ones, clip, set up, bin.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub fn process_chunk<V: Varyings, S: VertexSource<V>>(
    src: &S,
    indices: &[u32],
    first: usize,
    count: usize,
    params: &SetupParams,
    clipper: &Clipper,
    grid: &TileGrid,
    needs_attrs: bool,
) -> Chunk<V> {
    // Shading attributes are kept only when a fragment program will read them.
    let keep_attrs = needs_attrs && !V::EMPTY;
    let mut stats = DrawStats::default();
    let mut tris: Vec<SetupTri> = Vec::with_capacity(count);
    let mut attrs: Vec<TriAttrs<V>> = Vec::with_capacity(if keep_attrs { count } else { 0 });
    let mut poly = Vec::with_capacity(12);
    let mut tmp = Vec::with_capacity(12);
    type Out<'a, V> = (&'a mut Vec<SetupTri>, &'a mut Vec<TriAttrs<V>>);
    let push = |r: Result<(SetupTri, TriAttrs<V>), Rejected>, stats: &mut DrawStats, out: Out<'_, V>| match r {
        Ok((mut t, a)) => {
            t.attr = out.0.len() as u32;
            out.0.push(t);
            if keep_attrs {
                out.1.push(a);
            }
        }
        Err(Rejected::Degenerate) => stats.culled_degenerate += 1,
        Err(Rejected::Culled) => stats.culled_backface += 1,
        Err(Rejected::Outside) => stats.culled_outside += 1,
        Err(Rejected::NonFinite) => stats.dropped_nonfinite += 1,
    };
    for t in first..first + count {
        stats.triangles_in += 1;
        let ia = [
            indices[3 * t] as usize,
            indices[3 * t + 1] as usize,
            indices[3 * t + 2] as usize,
        ];
        // A source that computes vertices runs the program once per vertex for both (with
        // varyings, set-up reads the clip vertices anyway). Stored vertices are read when a
        // triangle needs them, in place (a triangle's three are 150 to 200 bytes: moving them
        // about cost a `memcpy` each time).
        let (p, mut fetched) = if V::EMPTY || !S::COMPUTES {
            (src.pre3(ia), None)
        } else {
            let (p, c) = src.both3(ia);
            (p, Some(c))
        };
        let any = p[0].code | p[1].code | p[2].code;
        if any & PreVertex::NON_FINITE != 0 {
            stats.dropped_nonfinite += 1;
            continue;
        }
        if p[0].code & p[1].code & p[2].code & PreVertex::PLANES != 0 {
            stats.culled_outside += 1;
            continue;
        }
        let mask = any & PreVertex::PLANES;
        if mask == 0 && any != 0 {
            // Inside every plane, but a window position was rejected: set-up says why.
            let c = *fetched.get_or_insert_with(|| src.clip3(ia));
            push(setup_triangle(params, c, t as u32), &mut stats, (&mut tris, &mut attrs));
            continue;
        }
        if mask == 0 {
            match setup_window_parts::<V>(params, [p[0].win, p[1].win, p[2].win], t as u32) {
                Ok((mut tri, persp, order)) => {
                    tri.attr = tris.len() as u32;
                    tris.push(tri);
                    if keep_attrs {
                        // From the computed vertices, or each straight from the stored ones.
                        let var = |k: usize| fetched.as_ref().map_or_else(|| src.var(ia[k]), |c| c[k].var);
                        if attrs.len() == attrs.capacity() {
                            attrs.reserve(1);
                        }
                        // SAFETY: capacity for one more is ensured above; the slot is written
                        // whole (field by field) before the length covers it.
                        unsafe {
                            attrs.as_mut_ptr().add(attrs.len()).write(TriAttrs {
                                persp,
                                var: [var(order[0]), var(order[1]), var(order[2])],
                            });
                            attrs.set_len(attrs.len() + 1);
                        }
                    }
                }
                Err(e) => push(Err(e), &mut stats, (&mut tris, &mut attrs)),
            }
            continue;
        }
        let tri = *fetched.get_or_insert_with(|| src.clip3(ia));
        stats.clipped += 1;
        clipper.clip_polygon(tri, mask, &mut poly, &mut tmp);
        if poly.is_empty() {
            stats.culled_outside += 1;
            continue;
        }
        for k in 1..poly.len() - 1 {
            stats.clip_triangles_out += 1;
            push(
                setup_triangle(params, [poly[0], poly[k], poly[k + 1]], t as u32),
                &mut stats,
                (&mut tris, &mut attrs),
            );
        }
    }

    // Bin: count per tile, prefix sum, fill (a stable counting sort).
    let setup_count = tris.len();
    let (offsets, tris, binned, attrs) = bin_triangles(tris, attrs, grid, keep_attrs);
    let n = offsets[grid.count()] as usize;
    stats.bin_entries += n as u64;
    stats.triangles_setup += setup_count as u64;
    Chunk {
        attrs,
        offsets,
        tris,
        binned,
        stats,
    }
}

/// The chunk's set-up triangles `tris` (and their shading `attrs` where `keep_attrs`) binned
/// into `grid`'s tiles by a stable counting sort: the per-tile offsets, and the tile lists
/// either as indices into `tris` (coherent chunks) or as copies in tile order (scattered
/// ones, `binned` empty).
#[inline(always)]
#[allow(clippy::type_complexity)]
fn bin_triangles<V: Varyings>(
    tris: Vec<SetupTri>,
    attrs: Vec<TriAttrs<V>>,
    grid: &TileGrid,
    keep_attrs: bool,
) -> (Vec<u32>, Vec<SetupTri>, Vec<u32>, Vec<TriAttrs<V>>) {
    let ntiles = grid.count();
    let mut offsets = vec![0u32; ntiles + 1];
    let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(tris.len() * 2);
    for (i, tri) in tris.iter().enumerate() {
        let tx0 = tri.bbox[0] >> TILE_SHIFT;
        let ty0 = tri.bbox[1] >> TILE_SHIFT;
        let tx1 = tri.bbox[2] >> TILE_SHIFT;
        let ty1 = tri.bbox[3] >> TILE_SHIFT;
        let single = tx0 == tx1 && ty0 == ty1;
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                let t = (ty * grid.nx + tx) as usize;
                if !single && rect_rejected(tri, grid.rect(t)) {
                    continue;
                }
                pairs.push((t as u32, i as u32));
                offsets[t + 1] += 1;
            }
        }
    }
    for t in 0..ntiles {
        offsets[t + 1] += offsets[t];
    }
    let n = pairs.len();
    let touched = offsets.windows(2).filter(|w| w[1] > w[0]).count();
    // The tile lists as indices (a counting sort of the pairs: 4-byte writes, in cache).
    let mut cursor = offsets.clone();
    let mut idx: Vec<u32> = vec![0; n];
    for (t, i) in pairs {
        idx[cursor[t as usize] as usize] = i;
        cursor[t as usize] += 1;
    }
    let (tris, binned, attrs) = if n >= COHERENT * touched {
        (tris, idx, attrs)
    } else {
        // Copies in tile order, their shading attributes too (each copy points at its own),
        // gathered in that order: the copies are written front to back (the chunk's set-up
        // output they read is still in cache; scattering the writes instead missed on each).
        let copies: Vec<SetupTri> = idx
            .iter()
            .enumerate()
            .map(|(k, &i)| SetupTri {
                attr: if keep_attrs { k as u32 } else { tris[i as usize].attr },
                ..tris[i as usize]
            })
            .collect();
        let attr_copies: Vec<TriAttrs<V>> = if keep_attrs {
            idx.iter().map(|&i| attrs[tris[i as usize].attr as usize]).collect()
        } else {
            Vec::new()
        };
        (copies, Vec::new(), attr_copies)
    };
    (offsets, tris, binned, attrs)
}
