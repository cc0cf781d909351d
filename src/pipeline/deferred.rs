//! Stage 6 with hidden surface removal before shading: tile-based deferred shading, as
//! PowerVR, Apple and Mali (forward pixel kill) hardware do it.
//!
//! For a tile (and one batch of the draw), pass 1 runs coverage and the depth test of every
//! triangle in submission order, as a depth-only pass does (the fused small-triangle path and
//! four-pixel spans), and records in a tile-sized visibility buffer which triangle last wrote
//! each pixel. Pass 2 walks the buffer in aligned groups of four pixels of a row and runs the
//! program once per pixel that stays visible, four lanes at a time
//! ([`FragmentProgram::shade4`]) for the lanes that show the same triangle.
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

use super::bin::{Chunk, TILE};
use super::fragment::{depth_span_x4, ColorFormat, FragmentProgram, RawTargets};
use super::raster::{raster_tile, small_depth_fused, TileMask};
use super::setup::{SetupTri, TriAttrs};
use super::state::{BlendMode, CompareFunc, DepthFormat, RenderState, Shading};
use super::vertex::Varyings;
use super::wide::{clamp01, fragment4, shade_fragment4, Fragment4, WideState, WideTri};
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
/// target, no stencil, no lists, no discard).
#[inline]
pub(crate) fn applies<C>(state: &RenderState, targets: &RawTargets<C>, wide: bool) -> bool {
    cfg!(target_arch = "x86_64")
        && wide
        && state.shading == Shading::Deferred
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
    let mut list: Vec<(&SetupTri, Option<&TriAttrs<V>>)> = Vec::new();
    let mut passed_all = 0u64;

    // Pass 1: coverage, depth test and write, visibility buffer.
    // The tile's triangles in submission order: chunk by chunk, each chunk's tile list.
    for c in chunks {
        for &ti in &c.binned[c.offsets[tile] as usize..c.offsets[tile + 1] as usize] {
            let tri = &c.tris[ti as usize];
            let attrs = c.attrs.get(tri.attr as usize);
            let k = list.len() as u32;
            list.push((tri, attrs));
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
                                if (hi | 3) < tw {
                                    passed += depth_span_x4(row, lo, hi, zrow(ly), zp.dx, write, le, Some((idrow, k)));
                                    continue;
                                }
                                // The tile's last, partial chunk of a row: one pixel at a time, with
                                // the same formula.
                                for x in lo..=hi {
                                    let z = (zrow(ly) + zp.dx * x as f32).clamp(0.0, 1.0);
                                    // SAFETY: x <= hi < tile width.
                                    unsafe {
                                        let d = row.add(x as usize);
                                        if if le { z <= *d } else { z < *d } {
                                            if write {
                                                *d = z;
                                            }
                                            *idrow.add(x as usize) = k;
                                            passed += 1;
                                        }
                                    }
                                }
                            }
                        }
                        (emitted, passed)
                    }
                };
            stats.fragments_rasterized += emitted;
            stats.fragments_passed += passed;
            stats.early_z_killed += emitted - passed;
            passed_all += passed;
        }
    }
    if passed_all == 0 {
        return;
    }

    // Pass 2: one program run per visible pixel, grouped by triangle within aligned fours.
    let st = WideState::new(state);
    let no_vars = [V::default(); 3];
    let mut prepared: Vec<Option<WideTri<V>>> = Vec::new();
    prepared.resize_with(list.len(), || None);
    let shaded_before = stats.fragments_shaded;
    let ramp = Vec4::new(0.0, 1.0, 2.0, 3.0);
    // Groups are shaded `AHEAD` groups after they are formed, and `prefetch4` is called as
    // each is formed, so the program's memory loads have time to arrive.
    let mut ring: [Option<Fragment4<V>>; AHEAD] = [None; AHEAD];
    let mut n = 0usize;
    for ly in 0..th {
        let lyf = ly as f32;
        let y = oy + ly;
        let row = &ids[ly as usize * TILE as usize..][..TILE as usize];
        for (g, v) in row.chunks_exact(4).enumerate().take(tw.div_ceil(4) as usize) {
            // Columns past the tile's width were never written: they stay empty.
            let mut live = (0..4).fold(0u8, |m, i| m | ((v[i] != EMPTY) as u8) << i);
            while live != 0 {
                let k = v[live.trailing_zeros() as usize];
                let lanes = (0..4).fold(0u8, |m, i| m | ((v[i] == k) as u8) << i) & live;
                live &= !lanes;
                let t = prepared[k as usize].get_or_insert_with(|| {
                    let (tri, attrs) = list[k as usize];
                    let zp = tri.z.at_origin(ox as i64, oy as i64);
                    let (persp, var) = match attrs {
                        Some(a) => (a.persp.map(|p| p.at_origin(ox as i64, oy as i64)), &a.var),
                        // Empty varyings: any value of V is the value.
                        None => ([zp; 3], &no_vars),
                    };
                    WideTri { tri, persp, var, zp }
                });
                let c = 4 * g as i32;
                let lx = Vec4::splat(c as f32) + ramp;
                let zrow = (t.zp.c + t.zp.dy * lyf) + t.tri.z_offset;
                let z = clamp01(Vec4::splat(zrow) + Vec4::splat(t.zp.dx) * lx);
                let frag = fragment4(t, (ox + c, y), lx, lyf, z, lanes);
                program.prefetch4(&frag);
                if let Some(due) = ring[n % AHEAD].replace(frag) {
                    shade_fragment4(&due, &st, targets, program, stats);
                }
                n += 1;
            }
        }
    }
    for i in n..n + AHEAD {
        if let Some(due) = ring[i % AHEAD].take() {
            shade_fragment4(&due, &st, targets, program, stats);
        }
    }
    stats.fragments_hidden += passed_all - (stats.fragments_shaded - shaded_before);
}
