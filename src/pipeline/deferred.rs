//! Stage 6 with hidden surface removal before shading: tile-based deferred shading, as
//! PowerVR, Apple and Mali (forward pixel kill) hardware do it.
//!
//! For a tile (and one batch of the draw), pass 1 runs coverage and the depth test of every
//! triangle in submission order, as a depth-only pass does (the fused small-triangle path and
//! four-pixel spans), and records in a tile-sized visibility buffer which triangle last wrote
//! each pixel; while a passing triangle's data is in cache, its shading planes are re-based at
//! the tile. Pass 2 sorts the tile's pixels by the triangle they show (a counting sort, one
//! branch-free step per pixel) and runs the program ([`FragmentProgram::shade4`]) once per
//! pixel that stays visible, on each triangle's pixels four at a time in raster order (its
//! last group's idle lanes repeat its first pixel). Programs that
//! [`FragmentProgram::PREFETCHES`] get [`FragmentProgram::prefetch4`] a few groups before
//! every other group of a triangle is shaded. (An earlier pass 2 walked the buffer in aligned
//! fours and packed partial groups per triangle; its data-dependent branches, about three
//! mispredicted per group on 50-pixel triangles, cost more than the shading.)
//!
//! The result equals shading immediately ([`Shading::Immediate`]) bit for bit when the final
//! colour of a pixel is the colour of the last fragment that passed its depth test: blending
//! `Replace`, a program that cannot discard and has no side effects, no stencil and no
//! fragment lists. Depth follows the same formula on both paths, and a lane's inputs (depth,
//! barycentrics, varyings) depend only on its pixel and triangle, never on which lanes share a
//! call. Only the program-invocation counters differ: hidden fragments are counted in
//! [`DrawStats::fragments_hidden`] instead of [`DrawStats::fragments_shaded`].
//!
//! [`Shading::Immediate`]: super::state::Shading::Immediate

use super::bin::{TileTris, TILE, TILE_SHIFT};
use super::lanes::Fragment4;
use super::program::{ColorFormat, FragmentProgram, RawTargets, TileWork};
use super::raster::{raster_tile, small_depth_fused, TileMask};
use super::spans::{depth_span, depth_span_x4};
use super::state::{BlendMode, CompareFunc, DepthFormat, RenderState, Shading};
use super::stats::DrawStats;
use super::vertex::Varyings;
use super::wide::{fragment4_at, shade_fragment4, Stores, WideState, WideTri};
use glam::Vec4;

/// No triangle covers the pixel (yet).
const EMPTY: u32 = u32::MAX;

/// How many groups of four ahead of shading [`FragmentProgram::prefetch4`] is called.
const AHEAD: usize = 8;

/// Visible pixels of a triangle in a tile from which its groups are stored as runs
/// ([`Stores::Runs`]).
const RUNS_FROM: u32 = 64;

/// Pixels of the visibility buffer: one tile, [`TILE`] pixels per row.
const PIXELS: usize = (TILE * TILE) as usize;

/// True when `state` and the targets let the draw be shaded deferred with the same result
/// (see [`Shading::Deferred`]); `wide` says the four-pixel path already applies (a colour
/// target, no stencil, no lists, no discard). The path is the same on every target (pass 1
/// takes the four-pixel SSE4.1 depth spans where the build has them, the scalar spans with
/// the same result elsewhere), so the counters are too.
#[inline]
pub(crate) fn applies<C>(state: &RenderState, targets: &RawTargets<C>, wide: bool) -> bool {
    wide && state.shading == Shading::Deferred
        && state.blend == BlendMode::Replace
        && targets.depth.is_some()
        && state.depth.format == DepthFormat::F32
        && matches!(state.depth.func, CompareFunc::Less | CompareFunc::LessEqual)
}

/// Stages 5 and 6 of one tile, deferred (the caller checked [`applies`]).
#[inline(never)]
pub(crate) fn shade_tile_deferred<V: Varyings, P: FragmentProgram<V>, C: ColorFormat>(
    work: &TileWork<V, P, C>,
    stats: &mut DrawStats,
) {
    let (rect, state, targets) = (work.rect, work.state, work.targets);
    let Some(depth) = targets.depth.as_ref() else {
        return;
    };
    let (ox, oy) = (rect[0], rect[1]);
    let tw = (rect[2] - rect[0] + 1) as u32;
    let th = rect[3] - rect[1] + 1;
    let write = state.depth.write;
    let le = state.depth.func == CompareFunc::LessEqual;
    // SAFETY: the tile origin is inside the target.
    let origin = unsafe { depth.ptr.add(oy as usize * depth.stride + ox as usize) };
    let mut ids = [EMPTY; PIXELS];
    let idp = ids.as_mut_ptr();
    let mut cover = TileMask::default();
    let no_vars = [V::default(); 3];
    // One slot per triangle of the tile (index = its visibility-buffer id).
    let mut slots: Vec<Slot<V>> = Vec::new();
    let mut passed_all = 0u64;

    // Pass 1: coverage, depth test and write, visibility buffer.
    // The tile's triangles in submission order: chunk by chunk, each chunk's tile list.
    for (tri, attrs) in TileTris::new(work.chunks, work.tile) {
        let k = slots.len() as u32;
        let zp = tri.z.at_origin(ox as i64, oy as i64);
        let zoff = tri.z_offset;
        let zrow = |ly: i32| (zp.c + zp.dy * ly as f32) + zoff;
        let (emitted, passed) =
            match small_depth_fused(tri, rect, origin, depth.stride, zrow, zp.dx, write, le, Some((idp, k))) {
                Some(r) => r,
                None => {
                    let emitted = raster_tile(tri, rect, &mut cover);
                    let mut passed = 0;
                    if emitted > 0 {
                        for (ly, lo, hi) in cover.spans() {
                            // SAFETY: row `ly` of the tile, in the target and in the buffer.
                            let row = unsafe { origin.add(ly as usize * depth.stride) };
                            // SAFETY: the id buffer holds TILE rows of TILE pixels, and ly < TILE.
                            let idrow = unsafe { idp.add(ly as usize * TILE as usize) };
                            let ids = Some((idrow, k));
                            passed += if (hi | 3) < tw {
                                depth_span_x4(row, lo, hi, zrow(ly), zp.dx, write, le, ids)
                            } else if le {
                                // The tile's last, partial chunk of a row: one pixel at a time.
                                depth_span(row, lo, hi, zrow(ly), zp.dx, write, |a, b| a <= b, ids)
                            } else {
                                depth_span(row, lo, hi, zrow(ly), zp.dx, write, |a, b| a < b, ids)
                            };
                        }
                    }
                    (emitted, passed)
                }
            };
        stats.fragments_rasterized += emitted;
        stats.fragments_passed += passed;
        stats.early_z_killed += emitted - passed;
        passed_all += passed;
        // A triangle that may show a pixel gets its shading planes now, while its data
        // is at hand (pass 2 would wait for them); the others are never read.
        let (persp, var) = match attrs {
            Some(a) if passed > 0 => (a.persp.map(|p| p.at_origin(ox as i64, oy as i64)), &a.var),
            // Empty varyings: any value of V is the value.
            _ => ([zp; 3], &no_vars),
        };
        slots.push(Slot {
            tri: WideTri { tri, persp, var, zp },
            start: (passed_all - passed) as u32,
        });
    }
    if passed_all == 0 {
        return;
    }

    // Pass 2: one program run per visible pixel, each triangle's visible pixels in groups of
    // four. First the tile's pixels are sorted by triangle (a counting sort whose counts are
    // pass 1's `passed`, an upper bound of what stays visible; empty pixels go to a last,
    // discarded bucket), so that the shading loop has no branch per pixel.
    let shaded_before = stats.fragments_shaded;
    let mut cursor: Vec<u32> = slots.iter().map(|s| s.start).collect();
    cursor.push(passed_all as u32);
    // Four spare entries: a triangle's last group reads whole fours. Entries that no pixel
    // writes keep whatever they held (they are only read into idle lanes, which ignore them).
    let mut order = ORDER.take();
    order.resize(order.len().max(passed_all as usize + (tw * th as u32) as usize + 4), 0);
    sort_by_triangle(&ids, (tw as usize, th as usize), &mut cursor, &mut order);
    let mut queue = Queue {
        ring: [None; AHEAD],
        n: 0,
        st: WideState::new(state),
        targets,
        program: work.program,
    };
    for (slot, &end) in slots.iter().zip(&cursor) {
        let t = &slot.tri;
        // Many visible pixels: most groups are runs of a row, and one store each pays.
        let stores = if end - slot.start >= RUNS_FROM {
            Stores::Runs
        } else {
            Stores::Scatter
        };
        for g in (slot.start..end).step_by(4) {
            let live = (end - g).min(4);
            let (lx, ly, xs, ys) = group_pixels(&order[g as usize..][..4], live, (ox, oy));
            let frag = fragment4_at(t, (xs, ys), (lx, ly), t.depth4(lx, ly), ((1u32 << live) - 1) as u8);
            // Every other group of a triangle is prefetched: the next one's pixels are its
            // neighbours, whose texels are mostly on the same cache lines.
            queue.push(frag, stores, (g - slot.start) & 4 == 0, stats);
        }
    }
    queue.finish(stats);
    ORDER.set(order);
    stats.fragments_hidden += passed_all - (stats.fragments_shaded - shaded_before);
}

thread_local! {
    /// Pass 2's sorted pixel order, kept per worker from tile to tile.
    static ORDER: std::cell::Cell<Vec<u16>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Pass 2's counting sort: each pixel index (`row << TILE_SHIFT | column`) of the `tw` x `th`
/// tile whose visibility buffer is `ids` goes to `order[cursor[k]]` for the triangle `k` it
/// shows (empty pixels: the last cursor's bucket), and that cursor moves on. Its own function,
/// so that the loop keeps its arrays in registers.
#[inline(never)]
fn sort_by_triangle(ids: &[u32; PIXELS], (tw, th): (usize, usize), cursor: &mut [u32], order: &mut [u16]) {
    let trash = cursor.len() - 1;
    for (ly, row) in ids.chunks_exact(TILE as usize).take(th).enumerate() {
        for (lx, &k) in row[..tw].iter().enumerate() {
            let k = (k as usize).min(trash);
            let c = cursor[k];
            order[c as usize] = (ly << TILE_SHIFT | lx) as u16;
            cursor[k] = c + 1;
        }
    }
}

/// The pixels of a group of four tile pixel indices (`row << TILE_SHIFT | column`), the lanes
/// from `live` on repeating lane 0: tile-local columns and rows as floats, and target columns
/// and rows (the tile's origin is `(ox, oy)`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn group_pixels(p: &[u16], live: u32, (ox, oy): (i32, i32)) -> (Vec4, Vec4, [u32; 4], [u32; 4]) {
    use std::arch::x86_64::*;
    assert!(p.len() >= 4);
    // SAFETY: four readable u16s (checked); SSE2 is part of x86-64.
    unsafe {
        let v = _mm_unpacklo_epi16(_mm_loadl_epi64(p.as_ptr() as *const __m128i), _mm_setzero_si128());
        // Lanes at or past `live` take lane 0.
        let idle = _mm_cmpgt_epi32(_mm_setr_epi32(1, 2, 3, 4), _mm_set1_epi32(live as i32));
        let v = _mm_or_si128(_mm_andnot_si128(idle, v), _mm_and_si128(idle, _mm_shuffle_epi32(v, 0)));
        let lx = _mm_and_si128(v, _mm_set1_epi32(TILE - 1));
        let ly = _mm_srli_epi32(v, TILE_SHIFT);
        let xs = _mm_add_epi32(lx, _mm_set1_epi32(ox));
        let ys = _mm_add_epi32(ly, _mm_set1_epi32(oy));
        (
            Vec4::from(_mm_cvtepi32_ps(lx)),
            Vec4::from(_mm_cvtepi32_ps(ly)),
            std::mem::transmute::<__m128i, [u32; 4]>(xs),
            std::mem::transmute::<__m128i, [u32; 4]>(ys),
        )
    }
}

/// [`group_pixels`] without SSE2, lane by lane: the same values.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn group_pixels(p: &[u16], live: u32, (ox, oy): (i32, i32)) -> (Vec4, Vec4, [u32; 4], [u32; 4]) {
    let v: [u32; 4] = std::array::from_fn(|i| p[if (i as u32) < live { i } else { 0 }] as u32);
    let lx = v.map(|v| v & (TILE as u32 - 1));
    let ly = v.map(|v| v >> TILE_SHIFT);
    (
        Vec4::from_array(lx.map(|x| x as f32)),
        Vec4::from_array(ly.map(|y| y as f32)),
        std::array::from_fn(|i| (lx[i] as i32 + ox) as u32),
        std::array::from_fn(|i| (ly[i] as i32 + oy) as u32),
    )
}

/// A triangle of the tile: its planes re-based at the tile, and where its visible pixels
/// start in pass 2's sorted order.
struct Slot<'a, V> {
    tri: WideTri<'a, V>,
    start: u32,
}

/// Groups on their way to the program: for a program that [`FragmentProgram::PREFETCHES`],
/// each is shaded [`AHEAD`] groups after it is queued, and [`FragmentProgram::prefetch4`] runs
/// when it is queued (if asked to), so the program's memory loads have time to arrive; other
/// programs shade it at once.
struct Queue<'a, 'p, V, P, C> {
    ring: [Option<(Fragment4<'a, V>, Stores)>; AHEAD],
    n: usize,
    st: WideState,
    targets: &'p RawTargets<C>,
    program: &'p P,
}

impl<'a, V: Varyings, P: FragmentProgram<V>, C: ColorFormat> Queue<'a, '_, V, P, C> {
    #[inline(always)]
    fn push(&mut self, frag: Fragment4<'a, V>, stores: Stores, prefetch: bool, stats: &mut DrawStats) {
        if !P::PREFETCHES {
            shade_fragment4(&frag, stores, &self.st, self.targets, self.program, stats);
            return;
        }
        if prefetch {
            self.program.prefetch4(&frag);
        }
        if let Some((due, stores)) = self.ring[self.n % AHEAD].replace((frag, stores)) {
            shade_fragment4(&due, stores, &self.st, self.targets, self.program, stats);
        }
        self.n += 1;
    }

    /// Shades what is still queued.
    #[inline(always)]
    fn finish(&mut self, stats: &mut DrawStats) {
        for i in self.n..self.n + AHEAD {
            if let Some((due, stores)) = self.ring[i % AHEAD].take() {
                shade_fragment4(&due, stores, &self.st, self.targets, self.program, stats);
            }
        }
    }
}
