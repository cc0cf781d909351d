//! Stage 6, fragment operations, run per tile: depth (plane + polygon offset + clamp +
//! format quantization), early depth/stencil test where legal, the fragment program,
//! late depth/stencil test otherwise, two-sided stencil ops, depth write, blending with colour
//! write masks, and appending to per-pixel fragment lists.
//!
//! Order per fragment (GL/D3D): stencil test -> depth test -> stencil op (fail / depth-fail /
//! pass) -> depth write -> colour blend and write / list append. The "early" path runs the
//! tests before the program when the program cannot discard (so killed fragments are never
//! shaded); the result is identical to the late path.

use super::bin::{Chunk, TileTris};
use super::lists::{ListNode, NONE};
use super::raster::{raster_tile, small_depth_fused, TileMask};
use super::state::{BlendMode, CompareFunc, DepthFormat, RenderState};
use super::vertex::Varyings;
use super::wide::{shade_row4, Color4, Fragment4, WideState, WideTri};
use super::DrawStats;
use glam::{Vec2, Vec4};

/// A colour target's texel format: converts to and from the `Vec4` that programs output and
/// blending works in.
pub trait ColorFormat: Copy + Send + Sync + 'static {
    /// Texel to RGBA.
    fn to_vec4(self) -> Vec4;
    /// RGBA to texel (unused channels dropped).
    fn from_vec4(v: Vec4) -> Self;
    /// Four colours to texels, lane by lane; must equal [`ColorFormat::from_vec4`] of each lane.
    #[inline(always)]
    fn from_color4(c: &Color4) -> [Self; 4] {
        std::array::from_fn(|i| Self::from_vec4(c.lane(i)))
    }
}

/// 8-bit unsigned normalized RGBA.
pub type Rgba8 = [u8; 4];

impl ColorFormat for [u8; 4] {
    #[inline(always)]
    fn to_vec4(self) -> Vec4 {
        Vec4::new(self[0] as f32, self[1] as f32, self[2] as f32, self[3] as f32) * (1.0 / 255.0)
    }
    /// Round to nearest (ties to even) of `clamp(v, 0, 1) * 255`; NaN becomes 0.
    #[inline(always)]
    fn from_vec4(v: Vec4) -> Self {
        // Adding 2^23 leaves the rounded integer in the low mantissa bits: no saturating
        // float-to-int conversion (which costs more than the rest of the store).
        // `max` first maps NaN to 0 (`clamp` would keep the NaN).
        #[allow(clippy::manual_clamp)]
        let c = |x: f32| ((x.max(0.0).min(1.0) * 255.0 + 8_388_608.0).to_bits() & 0xff) as u8;
        [c(v.x), c(v.y), c(v.z), c(v.w)]
    }
    /// [`ColorFormat::from_vec4`] on four lanes at once: the same clamp, scale and rounding.
    #[inline(always)]
    fn from_color4(c: &Color4) -> [Self; 4] {
        // `max(x, 0)` first maps NaN to 0, as in `from_vec4` (maxps returns its second operand).
        let q = |v: Vec4| v.max(Vec4::ZERO).min(Vec4::ONE) * 255.0 + Vec4::splat(8_388_608.0);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of x86-64; the result is four packed little-endian RGBA8.
            unsafe {
                let byte = |v: Vec4| _mm_and_si128(_mm_castps_si128(q(v).into()), _mm_set1_epi32(0xff));
                let rg = _mm_or_si128(byte(c.r), _mm_slli_epi32(byte(c.g), 8));
                let ba = _mm_or_si128(_mm_slli_epi32(byte(c.b), 16), _mm_slli_epi32(byte(c.a), 24));
                std::mem::transmute::<__m128i, [[u8; 4]; 4]>(_mm_or_si128(rg, ba))
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let (r, g, b, a) = (
                q(c.r).to_array(),
                q(c.g).to_array(),
                q(c.b).to_array(),
                q(c.a).to_array(),
            );
            let byte = |x: f32| (x.to_bits() & 0xff) as u8;
            std::array::from_fn(|i| [byte(r[i]), byte(g[i]), byte(b[i]), byte(a[i])])
        }
    }
}

impl ColorFormat for Vec4 {
    #[inline(always)]
    fn to_vec4(self) -> Vec4 {
        self
    }
    #[inline(always)]
    fn from_vec4(v: Vec4) -> Self {
        v
    }
}

impl ColorFormat for Vec2 {
    #[inline(always)]
    fn to_vec4(self) -> Vec4 {
        Vec4::new(self.x, self.y, 0.0, 1.0)
    }
    #[inline(always)]
    fn from_vec4(v: Vec4) -> Self {
        Vec2::new(v.x, v.y)
    }
}

impl ColorFormat for f32 {
    #[inline(always)]
    fn to_vec4(self) -> Vec4 {
        Vec4::new(self, 0.0, 0.0, 1.0)
    }
    #[inline(always)]
    fn from_vec4(v: Vec4) -> Self {
        v.x
    }
}

/// What the fragment program sees.
#[derive(Copy, Clone, Debug)]
pub struct Fragment<V> {
    /// Pixel column.
    pub x: u32,
    /// Pixel row (0 at the top).
    pub y: u32,
    /// Depth after polygon offset and clamp.
    pub z: f32,
    /// Perspective-correct varyings.
    pub var: V,
    /// The triangle faces the viewer.
    pub front: bool,
    /// Index of the source triangle in the draw.
    pub prim: u32,
}

/// A fragment program: returns the colour, or `None` to discard.
///
/// A program must be a pure function of its fragment: with [`Shading::Deferred`] (the
/// default) the pipeline runs it only for the fragments that stay visible, in an order of its
/// choosing, so a side effect would see fewer and reordered calls (set
/// [`Shading::Immediate`] to run it for every fragment that passes the depth test).
///
/// [`Shading::Deferred`]: super::state::Shading::Deferred
/// [`Shading::Immediate`]: super::state::Shading::Immediate
pub trait FragmentProgram<V>: Sync {
    /// Set to true when [`FragmentProgram::shade`] may return `None`; depth and stencil are
    /// then tested after the program (no early-z).
    const MAY_DISCARD: bool = false;
    /// Set to true when [`FragmentProgram::prefetch4`] is overridden: the deferred path then
    /// holds each group back for a few groups after the hint (which costs a copy per group),
    /// and otherwise shades it at once.
    const PREFETCHES: bool = false;
    /// True only for the pipeline's own raster-ordered adapter ([`super::ordered`]): the
    /// program then has side effects on per-pixel storage, so it runs once per fragment that
    /// passes the tests, after them, on the per-fragment path (never deferred, never four
    /// lanes at once), in primitive order per pixel.
    #[doc(hidden)]
    const ORDERED: bool = false;
    /// Shades one fragment.
    fn shade(&self, f: &Fragment<V>) -> Option<Vec4>;
    /// Shades four fragments of one row at once (used when the program cannot discard and the
    /// draw has no stencil or fragment lists). The default calls [`FragmentProgram::shade`] on
    /// each live lane. An override computes in structure-of-arrays form and must return, lane
    /// by lane, exactly what `shade` returns (same operations in the same order), so output
    /// never depends on which path ran.
    #[inline(always)]
    fn shade4(&self, f: &Fragment4<V>) -> Color4
    where
        V: Varyings,
    {
        let mut c = [Vec4::ZERO; 4];
        for (i, ci) in c.iter_mut().enumerate() {
            if f.mask & (1 << i) != 0 {
                *ci = self.shade(&f.lane(i)).unwrap_or(Vec4::ZERO);
            }
        }
        Color4::from_lanes(c)
    }
    /// A hint, called by the deferred path ([`Shading::Deferred`]) for a group of four
    /// fragments a few groups before [`FragmentProgram::shade4`] runs on the same group: the
    /// program may start the memory loads it will need (texel prefetches, as
    /// [`CompareSampler::prefetch2x2_4`]), so that cache misses of large textures overlap
    /// instead of stalling one group after another. It must not change any result. Called
    /// only when [`FragmentProgram::PREFETCHES`] is true, and for every other group of a
    /// triangle (a group's pixels neighbour the next group's, whose texels mostly share its
    /// cache lines); the default does nothing.
    ///
    /// [`Shading::Deferred`]: super::state::Shading::Deferred
    /// [`CompareSampler::prefetch2x2_4`]: super::sampler::CompareSampler::prefetch2x2_4
    #[inline(always)]
    fn prefetch4(&self, f: &Fragment4<V>)
    where
        V: Varyings,
    {
        let _ = f;
    }
}

/// No program: depth/stencil-only passes.
#[derive(Copy, Clone, Debug, Default)]
pub struct DepthOnly;

impl<V> FragmentProgram<V> for DepthOnly {
    #[inline(always)]
    fn shade(&self, _: &Fragment<V>) -> Option<Vec4> {
        Some(Vec4::ZERO)
    }
}

/// A closure that never discards, as a fragment program.
#[derive(Copy, Clone, Debug)]
pub struct Shader<F>(pub F);

impl<V, F: Fn(&Fragment<V>) -> Vec4 + Sync> FragmentProgram<V> for Shader<F> {
    #[inline(always)]
    fn shade(&self, f: &Fragment<V>) -> Option<Vec4> {
        Some((self.0)(f))
    }
}

/// A closure that may discard (returns `None`), as a fragment program (no early-z).
#[derive(Copy, Clone, Debug)]
pub struct DiscardingShader<F>(pub F);

impl<V, F: Fn(&Fragment<V>) -> Option<Vec4> + Sync> FragmentProgram<V> for DiscardingShader<F> {
    const MAY_DISCARD: bool = true;
    #[inline(always)]
    fn shade(&self, f: &Fragment<V>) -> Option<Vec4> {
        (self.0)(f)
    }
}

/// Blends `src` over `dst` and keeps `dst` in channels the colour mask excludes.
#[inline(always)]
pub(crate) fn blend_masked(mode: BlendMode, mask: [bool; 4], src: Vec4, dst: Vec4) -> Vec4 {
    let b = blend(mode, src, dst);
    Vec4::new(
        if mask[0] { b.x } else { dst.x },
        if mask[1] { b.y } else { dst.y },
        if mask[2] { b.z } else { dst.z },
        if mask[3] { b.w } else { dst.w },
    )
}

/// Blends source `s` over destination `d`.
#[inline(always)]
pub fn blend(mode: BlendMode, s: Vec4, d: Vec4) -> Vec4 {
    match mode {
        BlendMode::Replace => s,
        BlendMode::Add => s + d,
        BlendMode::Alpha => {
            let a = s.w;
            let rgb = s.truncate() * a + d.truncate() * (1.0 - a);
            rgb.extend(a + d.w * (1.0 - a))
        }
        BlendMode::Multiply => s * d,
        BlendMode::Min => s.min(d),
        BlendMode::Max => s.max(d),
    }
}

/// A surface shared by tile workers. Each worker touches only its own tile's pixels, so no two
/// threads ever access the same texel.
#[derive(Copy, Clone)]
pub(crate) struct RawSurface<T> {
    pub ptr: *mut T,
    pub stride: usize,
}

// SAFETY: tiles are disjoint pixel rectangles and each tile is processed by exactly one worker
// per draw (see `Pipeline::draw`), so accesses through a `RawSurface` never overlap.
unsafe impl<T: Send> Send for RawSurface<T> {}
unsafe impl<T: Send> Sync for RawSurface<T> {}

impl<T: Copy> RawSurface<T> {
    /// Sets every texel of the inclusive rectangle `[x0, y0, x1, y1]` to `v`.
    ///
    /// # Safety
    /// The rectangle lies inside the surface and no other thread accesses it meanwhile.
    pub unsafe fn fill_rect(&self, rect: [i32; 4], v: T) {
        let n = (rect[2] - rect[0] + 1) as usize;
        for y in rect[1]..=rect[3] {
            // SAFETY: per the contract, the row segment is inside the surface and ours.
            let row =
                unsafe { std::slice::from_raw_parts_mut(self.ptr.add(y as usize * self.stride + rect[0] as usize), n) };
            row.fill(v);
        }
    }

    #[inline(always)]
    pub(crate) unsafe fn get(&self, x: i32, y: i32) -> T {
        *self.ptr.add(y as usize * self.stride + x as usize)
    }
    #[inline(always)]
    pub(crate) unsafe fn set(&self, x: i32, y: i32, v: T) {
        *self.ptr.add(y as usize * self.stride + x as usize) = v;
    }
}

/// The targets of one draw, as seen by tile workers.
pub(crate) struct RawTargets<C> {
    pub color: Option<RawSurface<C>>,
    pub depth: Option<RawSurface<f32>>,
    pub stencil: Option<RawSurface<u8>>,
    pub lists: bool,
    pub list_capacity: usize,
}

/// One tile's local fragment-list pool (merged after the draw).
#[derive(Default)]
pub(crate) struct TileLists {
    pub nodes: Vec<ListNode>,
    pub head: Vec<u32>,
    pub tail: Vec<u32>,
    pub overflow: u64,
}

/// Asks the memory system for every cache line of a tile's rows at once. Rows of a target lie
/// a whole row apart (usually in different pages), which defeats hardware prefetchers; issuing
/// all misses together overlaps their latency instead of paying it line by line.
#[inline(always)]
fn prefetch_rows<T>(s: &RawSurface<T>, rect: [i32; 4]) {
    #[cfg(target_arch = "x86_64")]
    {
        let bytes = (rect[2] - rect[0] + 1) as usize * std::mem::size_of::<T>();
        for y in rect[1]..=rect[3] {
            // SAFETY: addresses inside the target; prefetch never faults.
            let row = unsafe { s.ptr.add(y as usize * s.stride + rect[0] as usize) } as *const i8;
            let mut off = 0;
            while off < bytes {
                unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(row.wrapping_add(off)) };
                off += 64;
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (s, rect);
}

/// [`depth_span`] for `Less` / `LessEqual`, four pixels at a time (SSE4.1). Chunks are aligned
/// to four pixels of the tile row and the caller guarantees the last chunk ends inside the
/// tile (`(hi | 3) < tile width`), so every lane read lies in this worker's tile; lanes outside
/// `lo..=hi` are written back unchanged. The arithmetic is the scalar path's, in the same
/// order (mul then add, no FMA; clamp with the operand order that keeps -0.0 and NaN as the
/// scalar `clamp` does), so results are bit-identical. With `ids = Some((p, k))`, `p` points
/// at the row's tile-local pixel 0 of a `u32` buffer and `k` is written where a lane passes.
/// Without SSE4.1 in the build's target, it is the scalar span (the same depths, ids, count).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn depth_span_x4(
    row: *mut f32,
    lo: u32,
    hi: u32,
    zrow: f32,
    dzdx: f32,
    write: bool,
    less_equal: bool,
    ids: Option<(*mut u32, u32)>,
) -> u64 {
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse4.1")))]
    {
        if less_equal {
            depth_span(row, lo, hi, zrow, dzdx, write, |a, b| a <= b, ids)
        } else {
            depth_span(row, lo, hi, zrow, dzdx, write, |a, b| a < b, ids)
        }
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
    // SAFETY: SSE4.1 is in the build's target (x86-64-v2); pointers stay within the tile row.
    unsafe {
        use std::arch::x86_64::*;
        let (zr, dz) = (_mm_set1_ps(zrow), _mm_set1_ps(dzdx));
        let (zero, one) = (_mm_setzero_ps(), _mm_set1_ps(1.0));
        let ramp = _mm_setr_epi32(0, 1, 2, 3);
        let (lo_v, hi_v) = (_mm_set1_epi32(lo as i32 - 1), _mm_set1_epi32(hi as i32 + 1));
        let mut passed = 0u32;
        // One chunk: lanes outside `lo..=hi` masked off when `edge`.
        let chunk = |c: u32, xf: __m128, edge: bool| -> u32 {
            let z = _mm_add_ps(zr, _mm_mul_ps(dz, xf));
            let z = _mm_min_ps(one, _mm_max_ps(zero, z));
            let p = row.add(c as usize);
            let d = _mm_loadu_ps(p);
            let mut t = if less_equal {
                _mm_cmple_ps(z, d)
            } else {
                _mm_cmplt_ps(z, d)
            };
            if edge {
                let xi = _mm_add_epi32(_mm_set1_epi32(c as i32), ramp);
                t = _mm_and_ps(
                    t,
                    _mm_castsi128_ps(_mm_and_si128(_mm_cmpgt_epi32(xi, lo_v), _mm_cmplt_epi32(xi, hi_v))),
                );
            }
            if write {
                _mm_storeu_ps(p, _mm_blendv_ps(d, z, t));
            }
            if let Some((ip, k)) = ids {
                super::raster::store_ids4(ip.add(c as usize), k, t);
            }
            (_mm_movemask_ps(t) as u32).count_ones()
        };
        let (first, last) = (lo & !3, hi & !3);
        // Lane x as a float: exact small integers, stepped by an exact 4.0.
        let mut xf = _mm_cvtepi32_ps(_mm_add_epi32(_mm_set1_epi32(first as i32), ramp));
        let four = _mm_set1_ps(4.0);
        passed += chunk(first, xf, true);
        let mut c = first + 4;
        while c < last {
            xf = _mm_add_ps(xf, four);
            passed += chunk(c, xf, false);
            c += 4;
        }
        if last > first {
            xf = _mm_add_ps(xf, four);
            passed += chunk(last, xf, true);
        }
        passed as u64
    }
}

/// Depth-only span: the common shadow-map case (no stencil, no program, float depth).
/// Returns the number of fragments that passed. With `ids = Some((p, k))` (the deferred
/// path's visibility buffer, as in [`depth_span_x4`]), `k` is written where a pixel passes.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn depth_span(
    row: *mut f32,
    lo: u32,
    hi: u32,
    zrow: f32,
    dzdx: f32,
    write: bool,
    test: impl Fn(f32, f32) -> bool,
    ids: Option<(*mut u32, u32)>,
) -> u64 {
    // SAFETY: `row` points at this worker's tile row and lo <= hi < TILE.
    let span = unsafe { std::slice::from_raw_parts_mut(row.add(lo as usize), (hi - lo + 1) as usize) };
    let mut passed = 0u32;
    // Branch-free: depth tests of a shadow-map pass are data-dependent coin flips.
    for (i, d) in span.iter_mut().enumerate() {
        let z = (zrow + dzdx * (lo + i as u32) as f32).clamp(0.0, 1.0);
        let t = test(z, *d);
        passed += t as u32;
        *d = if t & write { z } else { *d };
        if let (Some((ip, k)), true) = (ids, t) {
            // SAFETY: the buffer's row has a slot for every pixel of the tile row.
            unsafe { *ip.add(lo as usize + i) = k };
        }
    }
    passed as u64
}

/// Stencil-counting span (shadow volumes): the stencil test always passes, the depth test
/// picks which wrapping delta to add, nothing else is written. Returns fragments that passed
/// the depth test.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn stencil_span(
    srow: *mut u8,
    drow: *const f32,
    lo: u32,
    hi: u32,
    zrow: f32,
    dzdx: f32,
    deltas: (u8, u8),
    test: impl Fn(f32, f32) -> bool,
) -> u64 {
    let n = (hi - lo + 1) as usize;
    // SAFETY: both rows point at this worker's tile row and lo <= hi < TILE.
    let (s, d) = unsafe {
        (
            std::slice::from_raw_parts_mut(srow.add(lo as usize), n),
            std::slice::from_raw_parts(drow.add(lo as usize), n),
        )
    };
    let (pass, fail) = deltas;
    let mut passed = 0u32;
    for (i, (sv, dv)) in s.iter_mut().zip(d).enumerate() {
        let z = (zrow + dzdx * (lo + i as u32) as f32).clamp(0.0, 1.0);
        let t = test(z, *dv);
        passed += t as u32;
        *sv = sv.wrapping_add(if t { pass } else { fail });
    }
    passed as u64
}

/// Runs stages 5 and 6 for one tile over its triangles (in submission order).
///
/// Fragment depth is `((c + dz/dy * ly) + offset) + dz/dx * lx` at tile-local pixel (lx, ly),
/// then clamped to [0, 1] and quantized to the depth format; every path uses this one formula.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(crate) fn shade_tile<V: Varyings, P: FragmentProgram<V>, C: ColorFormat>(
    chunks: &[Chunk<V>],
    tile: usize,
    rect: [i32; 4],
    state: &RenderState,
    targets: &RawTargets<C>,
    program: &P,
    stats: &mut DrawStats,
    lists: &mut TileLists,
) {
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
    let mask = state.color_mask.0;
    let full_mask = mask == [true; 4];
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
        super::deferred::shade_tile_deferred(chunks, tile, rect, state, targets, program, stats);
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
            stats.fragments_passed += passed;
            stats.early_z_killed += emitted - passed;
            continue;
        }

        // Fast path: stencil counting spans.
        if let Some(deltas) = fast_stencil[tri.front as usize] {
            let stencil = targets.stencil.as_ref().unwrap();
            let mut passed = 0;
            for (ly, lo, hi) in cover.spans() {
                let zrow = (zp.c + zp.dy * ly as f32) + zoff;
                // SAFETY: the row starts are inside this worker's tile.
                let srow = unsafe { stencil.ptr.add((oy + ly) as usize * stencil.stride + ox as usize) };
                passed += match targets.depth.as_ref().filter(|_| depth_test) {
                    Some(depth) => {
                        let drow = unsafe { depth.ptr.add((oy + ly) as usize * depth.stride + ox as usize) };
                        match state.depth.func {
                            CompareFunc::Less => stencil_span(srow, drow, lo, hi, zrow, zp.dx, deltas, |a, b| a < b),
                            CompareFunc::LessEqual => {
                                stencil_span(srow, drow, lo, hi, zrow, zp.dx, deltas, |a, b| a <= b)
                            }
                            f => stencil_span(srow, drow, lo, hi, zrow, zp.dx, deltas, |a, b| f.test(a, b)),
                        }
                    }
                    None => {
                        // No depth test: every fragment passes.
                        for x in lo..=hi {
                            let p = unsafe { srow.add(x as usize) };
                            unsafe { *p = (*p).wrapping_add(deltas.0) };
                        }
                        (hi - lo + 1) as u64
                    }
                };
            }
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
                        blend_masked(state.blend, mask, src, unsafe { ct.get(x, y) }.to_vec4())
                    };
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
