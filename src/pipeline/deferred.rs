//! Stage 6 with hidden surface removal before shading: tile-based deferred shading, as
//! PowerVR, Apple and Mali (forward pixel kill) hardware do it.
//!
//! For a tile (and one batch of the draw), pass 1 runs coverage and the depth test of every
//! triangle in submission order, as a depth-only pass does (the fused small-triangle path and
//! four-pixel spans), and records in a tile-sized visibility buffer which triangle last wrote
//! each pixel; while a passing triangle's data is in cache, its shading planes are re-based at
//! the tile. Pass 2 walks the buffer in aligned groups of four pixels of a row and runs the
//! program ([`FragmentProgram::shade4`]) once per pixel that stays visible: a group that shows
//! one triangle is shaded as a run, a triangle's other pixels wait in its slot until four of
//! them fill a group (or the tile ends). Programs that [`FragmentProgram::PREFETCHES`] get
//! [`FragmentProgram::prefetch4`] a few groups before each group is shaded.
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

use super::bin::{Chunk, TileTris, TILE};
use super::fragment::{depth_span, depth_span_x4, ColorFormat, FragmentProgram, RawTargets};
use super::raster::{raster_tile, small_depth_fused, TileMask};
use super::state::{BlendMode, CompareFunc, DepthFormat, RenderState, Shading};
use super::vertex::Varyings;
use super::wide::{fragment4, shade_fragment4, Fragment4, WideState, WideTri};
use super::DrawStats;
use glam::Vec4;

/// No triangle covers the pixel (yet).
const EMPTY: u32 = u32::MAX;

/// How many groups of four ahead of shading [`FragmentProgram::prefetch4`] is called.
const AHEAD: usize = 8;

/// Pixels of the visibility buffer: one tile, [`TILE`] pixels per row.
const PIXELS: usize = (TILE * TILE) as usize;

/// True when `state` and the targets let the draw be shaded deferred with the same result
/// (see [`Shading::Deferred`]); `wide` says the four-pixel path already applies (a colour
/// target, no stencil, no lists, no discard). The path exists on x86-64 only (its pass 1 is
/// the SSE4.1 depth path); elsewhere every draw shades immediately.
#[inline]
pub(crate) fn applies<C>(state: &RenderState, targets: &RawTargets<C>, wide: bool) -> bool {
    wide && state.shading == Shading::Deferred
        && state.blend == BlendMode::Replace
        && targets.depth.is_some()
        && state.depth.format == DepthFormat::F32
        && matches!(state.depth.func, CompareFunc::Less | CompareFunc::LessEqual)
}

/// Stages 5 and 6 of one tile, deferred (the caller checked [`applies`]).
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(crate) fn shade_tile_deferred<V: Varyings, P: FragmentProgram<V>, C: ColorFormat>(
    chunks: &[Chunk<V>],
    tile: usize,
    rect: [i32; 4],
    state: &RenderState,
    targets: &RawTargets<C>,
    program: &P,
    stats: &mut DrawStats,
) {
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
    for (tri, attrs) in TileTris::new(chunks, tile) {
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
            pending: Pending::default(),
        });
    }
    if passed_all == 0 {
        return;
    }

    // Pass 2: one program run per visible pixel. An aligned four of a row that shows one
    // triangle is shaded as a run; other pixels wait in their triangle's slot until four of
    // them fill a group (or the tile ends), so lanes are rarely idle.
    let shaded_before = stats.fragments_shaded;
    let ramp = Vec4::new(0.0, 1.0, 2.0, 3.0);
    let mut queue = Queue {
        ring: [None; AHEAD],
        n: 0,
        st: WideState::new(state),
        targets,
        program,
    };
    for ly in 0..th {
        let lyf = ly as f32;
        let y = (oy + ly) as u32;
        let row = &ids[ly as usize * TILE as usize..][..TILE as usize];
        for (g, v) in row.chunks_exact(4).enumerate().take(tw.div_ceil(4) as usize) {
            // Columns past the tile's width were never written: they stay empty.
            let v4 = load_ids4(v);
            let mut live = !eq_mask4(v4, EMPTY) & 0xf;
            while live != 0 {
                let k = v[live.trailing_zeros() as usize];
                let lanes = eq_mask4(v4, k) & live;
                live &= !lanes;
                let Slot { tri: t, pending } = &mut slots[k as usize];
                let c = 4 * g as u32;
                if lanes == 0xf {
                    let (lx, ly) = (Vec4::splat(c as f32) + ramp, Vec4::splat(lyf));
                    let xs = std::array::from_fn(|i| ox as u32 + c + i as u32);
                    queue.push(fragment4(t, (xs, [y; 4]), (lx, ly), t.depth4(lx, ly), 0xf), stats);
                    continue;
                }
                let mut bits = lanes;
                while bits != 0 {
                    let i = bits.trailing_zeros();
                    bits &= bits - 1;
                    pending.x[pending.n as usize] = (c + i) as u8;
                    pending.y[pending.n as usize] = ly as u8;
                    pending.n += 1;
                    if pending.n == 4 {
                        queue.push(pending.fragment4(t, (ox, oy)), stats);
                        pending.n = 0;
                    }
                }
            }
        }
    }
    for Slot { tri, pending } in &slots {
        if pending.n > 0 {
            queue.push(pending.fragment4(tri, (ox, oy)), stats);
        }
    }
    queue.finish(stats);
    stats.fragments_hidden += passed_all - (stats.fragments_shaded - shaded_before);
}

/// Four ids of a visibility-buffer row (`v[0..4]`), as one vector.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn load_ids4(v: &[u32]) -> std::arch::x86_64::__m128i {
    assert!(v.len() >= 4);
    // SAFETY: four readable u32s (checked); SSE2 is part of x86-64.
    unsafe { std::arch::x86_64::_mm_loadu_si128(v.as_ptr() as *const std::arch::x86_64::__m128i) }
}

/// Bit `i` set where lane `i` of `v` equals `k`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn eq_mask4(v: std::arch::x86_64::__m128i, k: u32) -> u8 {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of x86-64.
    unsafe { _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(v, _mm_set1_epi32(k as i32)))) as u8 }
}

/// Up to three visible pixels of one triangle in a tile, waiting for a fourth.
#[derive(Copy, Clone, Default)]
struct Pending {
    /// Pixels held.
    n: u8,
    /// Tile-local columns.
    x: [u8; 4],
    /// Tile-local rows.
    y: [u8; 4],
}

impl Pending {
    /// The held pixels (lanes `0..n`) of `t` as a group; the tile's origin is `(ox, oy)`.
    #[inline(always)]
    fn fragment4<'a, V: Varyings>(&self, t: &WideTri<'a, V>, (ox, oy): (i32, i32)) -> Fragment4<'a, V> {
        // Idle lanes repeat lane 0 (their values are replaced by lane 0's anyway).
        let lane = |i: usize| if i < self.n as usize { i } else { 0 };
        let lx = Vec4::from_array(std::array::from_fn(|i| self.x[lane(i)] as f32));
        let ly = Vec4::from_array(std::array::from_fn(|i| self.y[lane(i)] as f32));
        let z = t.depth4(lx, ly);
        let xs = std::array::from_fn(|i| (ox + self.x[lane(i)] as i32) as u32);
        let ys = std::array::from_fn(|i| (oy + self.y[lane(i)] as i32) as u32);
        fragment4(t, (xs, ys), (lx, ly), z, ((1u32 << self.n) - 1) as u8)
    }
}

/// A triangle of the tile: its planes re-based at the tile and its pending pixels.
struct Slot<'a, V> {
    tri: WideTri<'a, V>,
    pending: Pending,
}

/// Groups on their way to the program: for a program that [`FragmentProgram::PREFETCHES`],
/// each is shaded [`AHEAD`] groups after it is queued, and [`FragmentProgram::prefetch4`] runs
/// when it is queued, so the program's memory loads have time to arrive; other programs shade
/// it at once.
struct Queue<'a, 'p, V, P, C> {
    ring: [Option<Fragment4<'a, V>>; AHEAD],
    n: usize,
    st: WideState,
    targets: &'p RawTargets<C>,
    program: &'p P,
}

impl<'a, V: Varyings, P: FragmentProgram<V>, C: ColorFormat> Queue<'a, '_, V, P, C> {
    #[inline(always)]
    fn push(&mut self, frag: Fragment4<'a, V>, stats: &mut DrawStats) {
        if !P::PREFETCHES {
            shade_fragment4(&frag, &self.st, self.targets, self.program, stats);
            return;
        }
        self.program.prefetch4(&frag);
        if let Some(due) = self.ring[self.n % AHEAD].replace(frag) {
            shade_fragment4(&due, &self.st, self.targets, self.program, stats);
        }
        self.n += 1;
    }

    /// Shades what is still queued.
    #[inline(always)]
    fn finish(&mut self, stats: &mut DrawStats) {
        for i in self.n..self.n + AHEAD {
            if let Some(due) = self.ring[i % AHEAD].take() {
                shade_fragment4(&due, &self.st, self.targets, self.program, stats);
            }
        }
    }
}
