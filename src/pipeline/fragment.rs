//! Stage 6, fragment operations, run per tile (the driver: the program and targets are
//! [`super::program`]'s, the span fast paths [`super::spans`]'s): depth (plane + polygon offset + clamp +
//! format quantization), early depth/stencil test where legal, the fragment program,
//! late depth/stencil test otherwise, two-sided stencil ops, depth write, blending with colour
//! write masks, and appending to per-pixel fragment lists.
//!
//! Order per fragment (GL/D3D): stencil test -> depth test -> stencil op (fail / depth-fail /
//! pass) -> depth write -> colour blend and write / list append. The "early" path runs the
//! tests before the program when the program cannot discard (so killed fragments are never
//! shaded); the result is identical to the late path.

use super::bin::TileTris;
use super::lanes::Fragment;
use super::lists::{ListNode, NONE};
use super::program::{blend_masked, ColorFormat, FragmentProgram, RawTargets, TileLists, TileWork};
use super::raster::{raster_tile, small_depth_fused, TileMask};
use super::setup::{SetupTri, TilePlane};
use super::spans::{depth_span, depth_span_x4, prefetch_rows, stencil_span};
use super::state::{CompareFunc, DepthFormat, RenderState};
use super::stats::DrawStats;
use super::vertex::Varyings;
use super::wide::{shade_row4, WideState, WideTri};
use glam::Vec4;

/// Runs stages 5 and 6 for one tile over its triangles (in submission order).
///
/// Fragment depth is `((c + dz/dy * ly) + offset) + dz/dx * lx` at tile-local pixel (lx, ly),
/// then clamped to [0, 1] and quantized to the depth format; every path uses this one formula.
#[inline(never)]
pub(crate) fn shade_tile<V: Varyings, P: FragmentProgram<V>, C: ColorFormat>(
    work: &TileWork<V, P, C>,
    stats: &mut DrawStats,
    lists: &mut TileLists,
) {
    let (chunks, tile, rect) = (work.chunks, work.tile, work.rect);
    let (state, targets, program) = (work.state, work.targets, work.program);
    let needs_shading = targets.color.is_some() || targets.lists || P::MAY_DISCARD || P::ORDERED;
    let depth_test = targets.depth.is_some() && state.depth.func != CompareFunc::Always;
    let depth_write = targets.depth.is_some() && state.depth.write;
    let stencil_on = targets.stencil.is_some() && state.stencil.enabled;
    let st = state.stencil;
    let fmt = state.depth.format;
    let fast_depth = !needs_shading && !stencil_on && targets.depth.is_some() && fmt == DepthFormat::F32;
    // Stencil counting (shadow volumes): per face, the (pass, depth-fail) wrapping deltas when
    // the fast path applies.
    let count_deltas = |f: super::state::StencilFace| -> Option<(u8, u8)> {
        let ok = !needs_shading
            && stencil_on
            && !depth_write
            && fmt == DepthFormat::F32
            && st.write_mask == 0xff
            && f.func == CompareFunc::Always;
        ok.then(|| Some((f.pass.wrapping_delta()?, f.depth_fail.wrapping_delta()?)))
            .flatten()
    };
    let fast_stencil = [count_deltas(st.back), count_deltas(st.front)];
    let (ox, oy) = (rect[0], rect[1]);
    let tw = (rect[2] - rect[0] + 1) as usize;
    if targets.lists && lists.head.is_empty() {
        let n = tw * (rect[3] - rect[1] + 1) as usize;
        lists.head = vec![NONE; n];
        lists.tail = vec![NONE; n];
    }
    let t = Tile {
        state,
        targets,
        program,
        origin: (ox, oy),
        tw,
        needs_shading,
        depth_test,
        depth_write,
        stencil_on,
        _varyings: std::marker::PhantomData,
    };
    let mut cover = TileMask::default();
    if let Some(d) = targets.depth.as_ref() {
        prefetch_rows(d, rect);
    }
    if let Some(c) = targets.color.as_ref() {
        prefetch_rows(c, rect);
    }

    let wide_state = WideState::new(state);
    let wide =
        needs_shading && !P::MAY_DISCARD && !P::ORDERED && !stencil_on && !targets.lists && targets.color.is_some();
    if super::deferred::applies(state, targets, wide) {
        super::deferred::shade_tile_deferred(work, stats);
        return;
    }
    let fused_small = fast_depth && matches!(state.depth.func, CompareFunc::Less | CompareFunc::LessEqual);
    // The tile's triangles in submission order: chunk by chunk, each chunk's tile list.
    for (tri, attrs) in TileTris::new(chunks, tile) {
        // Stages 5 and 6 fused for small triangles of depth-only passes.
        if fused_small {
            let depth = targets.depth.as_ref().unwrap();
            // SAFETY: the tile origin is inside the target.
            let origin = unsafe { depth.ptr.add(oy as usize * depth.stride + ox as usize) };
            let zp = tri.z.at_origin(ox as i64, oy as i64);
            let zoff = tri.z_offset;
            let le = state.depth.func == CompareFunc::LessEqual;
            let zrow = |ly: i32| (zp.c + zp.dy * ly as f32) + zoff;
            if let Some((emitted, passed)) =
                small_depth_fused(tri, rect, origin, depth.stride, zrow, zp.dx, depth_write, le, None)
            {
                stats.fragments_rasterized += emitted;
                stats.fragments_passed += passed;
                stats.early_z_killed += emitted - passed;
                continue;
            }
        }
        // Stage 5: coverage mask of this triangle in this tile.
        let emitted = raster_tile(tri, rect, &mut cover);
        stats.fragments_rasterized += emitted;
        if emitted == 0 {
            continue;
        }
        let zp = tri.z.at_origin(ox as i64, oy as i64);
        let zoff = tri.z_offset;

        // Fast path: depth-only spans.
        if fast_depth {
            let passed = t.depth_spans(&cover, zp, zoff);
            stats.fragments_passed += passed;
            stats.early_z_killed += emitted - passed;
            continue;
        }

        // Fast path: stencil counting spans.
        if let Some(deltas) = fast_stencil[tri.front as usize] {
            let passed = t.stencil_spans(&cover, zp, zoff, deltas);
            stats.fragments_passed += passed;
            stats.early_z_killed += emitted - passed;
            continue;
        }

        let (persp, var) = match attrs {
            Some(a) if needs_shading => (
                [
                    a.persp[0].at_origin(ox as i64, oy as i64),
                    a.persp[1].at_origin(ox as i64, oy as i64),
                    a.persp[2].at_origin(ox as i64, oy as i64),
                ],
                a.var,
            ),
            // Empty varyings: any value of V is the value.
            _ => ([zp; 3], [V::default(); 3]),
        };
        // Four pixels at a time when nothing per pixel is serial (see `wide`).
        // (A shaded draw keeps attributes unless it has no varyings, so `var` is right.)
        if wide {
            let t = WideTri {
                tri,
                persp,
                var: &var,
                zp,
            };
            for (ly, lo, hi) in cover.spans() {
                shade_row4(
                    &t,
                    (ox, oy),
                    (ly, lo, hi),
                    tw as u32,
                    &wide_state,
                    targets,
                    program,
                    stats,
                );
            }
            continue;
        }
        // Stage 6: fragment operations, span by span.
        t.fragments(tri, &cover, (zp, zoff), (&persp, &var), stats, lists);
    }
}

/// What every fragment of one tile's draw shares: the state, the targets and the program, the
/// tile's origin and width, and which tests and writes are on. Its paths are inlined into
/// [`shade_tile`].
struct Tile<'a, V, P, C> {
    state: &'a RenderState,
    targets: &'a RawTargets<C>,
    program: &'a P,
    origin: (i32, i32),
    tw: usize,
    needs_shading: bool,
    depth_test: bool,
    depth_write: bool,
    stencil_on: bool,
    _varyings: std::marker::PhantomData<V>,
}

impl<V: Varyings, P: FragmentProgram<V>, C: ColorFormat> Tile<'_, V, P, C> {
    /// Depth-only spans (no stencil, no program, float depth) of a triangle's `cover`, depth
    /// plane `zp` and offset `zoff`: four pixels at a time where the span allows. Returns the
    /// fragments that passed.
    #[inline(always)]
    fn depth_spans(&self, cover: &TileMask, zp: TilePlane, zoff: f32) -> u64 {
        let (state, targets, (ox, oy), tw, depth_write) =
            (self.state, self.targets, self.origin, self.tw, self.depth_write);
        let depth = targets.depth.as_ref().unwrap();
        let mut passed = 0;
        for (ly, lo, hi) in cover.spans() {
            let zrow = (zp.c + zp.dy * ly as f32) + zoff;
            // SAFETY: the row start is inside this worker's tile.
            let row = unsafe { depth.ptr.add((oy + ly) as usize * depth.stride + ox as usize) };
            let w = depth_write;
            if (hi | 3) < tw as u32 && matches!(state.depth.func, CompareFunc::Less | CompareFunc::LessEqual) {
                let le = state.depth.func == CompareFunc::LessEqual;
                passed += depth_span_x4(row, lo, hi, zrow, zp.dx, w, le, None);
                continue;
            }
            passed += match state.depth.func {
                CompareFunc::Less => depth_span(row, lo, hi, zrow, zp.dx, w, |a, b| a < b, None),
                CompareFunc::LessEqual => depth_span(row, lo, hi, zrow, zp.dx, w, |a, b| a <= b, None),
                CompareFunc::Greater => depth_span(row, lo, hi, zrow, zp.dx, w, |a, b| a > b, None),
                CompareFunc::GreaterEqual => depth_span(row, lo, hi, zrow, zp.dx, w, |a, b| a >= b, None),
                f => depth_span(row, lo, hi, zrow, zp.dx, w, |a, b| f.test(a, b), None),
            };
        }
        passed
    }

    /// Stencil-counting spans (shadow volumes) of a triangle's `cover`: the wrapping `deltas`
    /// for depth pass and fail added, nothing else written. Returns the fragments that passed
    /// the depth test.
    #[inline(always)]
    fn stencil_spans(&self, cover: &TileMask, zp: TilePlane, zoff: f32, deltas: (u8, u8)) -> u64 {
        let (state, targets, (ox, oy), depth_test) = (self.state, self.targets, self.origin, self.depth_test);
        let stencil = targets.stencil.as_ref().unwrap();
        let mut passed = 0;
        for (ly, lo, hi) in cover.spans() {
            let zrow = (zp.c + zp.dy * ly as f32) + zoff;
            // SAFETY: the row starts are inside this worker's tile.
            let srow = unsafe { stencil.ptr.add((oy + ly) as usize * stencil.stride + ox as usize) };
            passed += match targets.depth.as_ref().filter(|_| depth_test) {
                Some(depth) => {
                    // SAFETY: the depth row's start is inside this worker's tile, as the stencil row's is.
                    let drow = unsafe { depth.ptr.add((oy + ly) as usize * depth.stride + ox as usize) };
                    match state.depth.func {
                        CompareFunc::Less => stencil_span(srow, drow, lo, hi, zrow, zp.dx, deltas, |a, b| a < b),
                        CompareFunc::LessEqual => stencil_span(srow, drow, lo, hi, zrow, zp.dx, deltas, |a, b| a <= b),
                        f => stencil_span(srow, drow, lo, hi, zrow, zp.dx, deltas, |a, b| f.test(a, b)),
                    }
                }
                None => {
                    // No depth test: every fragment passes.
                    for x in lo..=hi {
                        // SAFETY: lo <= x <= hi lie in the tile row that `srow` starts.
                        let p = unsafe { srow.add(x as usize) };
                        // SAFETY: `p` is this worker's texel (above); nothing else aliases it during the draw.
                        unsafe { *p = (*p).wrapping_add(deltas.0) };
                    }
                    (hi - lo + 1) as u64
                }
            };
        }
        passed
    }

    /// Every fragment of `tri`'s `cover`, one at a time (a triangle's row coverage is
    /// contiguous): stencil and depth tests, the program before them where it may discard and
    /// after them otherwise, stencil ops, depth write, blending and the fragment lists.
    #[inline(always)]
    fn fragments(
        &self,
        tri: &SetupTri,
        cover: &TileMask,
        (zp, zoff): (TilePlane, f32),
        (persp, var): (&[TilePlane; 3], &[V; 3]),
        stats: &mut DrawStats,
        lists: &mut TileLists,
    ) {
        let (state, targets, program, (ox, oy), tw) = (self.state, self.targets, self.program, self.origin, self.tw);
        let (needs_shading, depth_test, depth_write, stencil_on) =
            (self.needs_shading, self.depth_test, self.depth_write, self.stencil_on);
        let st = state.stencil;
        let fmt = state.depth.format;
        let mask = state.color_mask.0;
        let full_mask = mask == [true; 4];
        let face = if tri.front { st.front } else { st.back };
        // Stage 6: fragment operations, span by span (a triangle's row coverage is contiguous).
        for (lyi, lo, hi) in cover.spans() {
            let (lo, hi) = (lo as i32, hi as i32);
            let y = oy + lyi;
            let ly = lyi as f32;
            let zrow = (zp.c + zp.dy * ly) + zoff;
            for lxi in lo..=hi {
                let x = ox + lxi;
                let lx = lxi as f32;
                let z = fmt.quantize((zrow + zp.dx * lx).clamp(0.0, 1.0));
                // Applies a stencil op under the write mask.
                let write_stencil = |op: super::state::StencilOp, sval: u8| {
                    let nv = op.apply(sval, st.reference);
                    // SAFETY: (x, y) is inside this worker's tile.
                    unsafe {
                        targets
                            .stencil
                            .as_ref()
                            .unwrap()
                            .set(x, y, (sval & !st.write_mask) | (nv & st.write_mask))
                    };
                };
                let shade = |stats: &mut DrawStats| -> Option<Vec4> {
                    stats.fragments_shaded += 1;
                    let var = if V::EMPTY {
                        var[0]
                    } else {
                        let w = 1.0 / persp[0].at(lx, ly);
                        let b1 = persp[1].at(lx, ly) * w;
                        let b2 = persp[2].at(lx, ly) * w;
                        V::combine(&var[0], &var[1], &var[2], [1.0 - b1 - b2, b1, b2])
                    };
                    program.shade(&Fragment {
                        x: x as u32,
                        y: y as u32,
                        z,
                        var,
                        front: tri.front,
                        prim: tri.prim,
                    })
                };
                // Late path: the program runs first and may discard.
                let mut color = None;
                if P::MAY_DISCARD {
                    color = shade(stats);
                    if color.is_none() {
                        stats.fragments_discarded += 1;
                        continue;
                    }
                }
                // Stencil test.
                let mut sval = 0u8;
                if stencil_on {
                    // SAFETY: (x, y) is inside this worker's tile.
                    sval = unsafe { targets.stencil.as_ref().unwrap().get(x, y) };
                    let pass = face.func.test(st.reference & st.read_mask, sval & st.read_mask);
                    if !pass {
                        stats.stencil_failed += 1;
                        write_stencil(face.fail, sval);
                        continue;
                    }
                }
                // Depth test.
                if depth_test {
                    // SAFETY: (x, y) is a pixel of this worker's tile, inside the target.
                    let d = unsafe { targets.depth.as_ref().unwrap().get(x, y) };
                    if !state.depth.func.test(z, d) {
                        if stencil_on {
                            write_stencil(face.depth_fail, sval);
                        }
                        if P::MAY_DISCARD {
                            stats.depth_failed += 1;
                        } else {
                            stats.early_z_killed += 1;
                        }
                        continue;
                    }
                }
                if stencil_on {
                    write_stencil(face.pass, sval);
                }
                if depth_write {
                    // SAFETY: (x, y) is a pixel of this worker's tile, inside the target.
                    unsafe { targets.depth.as_ref().unwrap().set(x, y, z) };
                }
                stats.fragments_passed += 1;
                if !needs_shading {
                    continue;
                }
                // Early path: the program runs after the tests.
                if !P::MAY_DISCARD {
                    color = shade(stats);
                }
                let Some(src) = color else {
                    stats.fragments_discarded += 1;
                    continue;
                };
                if let Some(ct) = targets.color.as_ref() {
                    let out = if state.blend == super::state::BlendMode::Replace && full_mask {
                        src
                    } else {
                        // SAFETY: (x, y) is a pixel of this worker's tile, inside the colour target.
                        blend_masked(state.blend, mask, src, unsafe { ct.get(x, y) }.to_vec4())
                    };
                    // SAFETY: (x, y) is a pixel of this worker's tile, inside the colour target.
                    unsafe { ct.set(x, y, C::from_vec4(out)) };
                }
                if targets.lists {
                    if lists.nodes.len() >= targets.list_capacity {
                        lists.overflow += 1;
                        continue;
                    }
                    let idx = lists.nodes.len() as u32;
                    lists.nodes.push(ListNode {
                        depth: z,
                        value: src,
                        prim: tri.prim,
                        draw: 0,
                        next: NONE,
                    });
                    let li = (y - oy) as usize * tw + (x - ox) as usize;
                    if lists.head[li] == NONE {
                        lists.head[li] = idx;
                    } else {
                        lists.nodes[lists.tail[li] as usize].next = idx;
                    }
                    lists.tail[li] = idx;
                    stats.list_nodes += 1;
                }
            }
        }
    }
}
