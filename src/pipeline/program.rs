//! The fragment program and what it writes to: colour formats ([`ColorFormat`]), the
//! fragment a program sees, the program trait and its stock programs, blending, and the
//! targets of a draw as tile workers see them. The lowest layer of stage 6 (fragment
//! operations): the spans, the four-pixel path, the deferred path and the per-tile driver
//! (`spans.rs`, `wide.rs`, `deferred.rs`, `fragment.rs`) build on it.

use super::bin::Chunk;
use super::lanes::{Color4, Fragment, Fragment4};
use super::lists::ListNode;
use super::state::{BlendMode, RenderState};
use super::vertex::Varyings;
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
// SAFETY: as for `Send`: workers touch disjoint tiles.
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

/// One tile's share of a draw, as stages 5 and 6 see it: the binned triangles, the tile's
/// index and pixel rectangle (inclusive), the state, targets and program of the draw.
pub(crate) struct TileWork<'a, V: Varyings, P, C> {
    /// The binned chunks of the draw.
    pub chunks: &'a [Chunk<V>],
    /// The tile's index in the grid.
    pub tile: usize,
    /// The tile's pixels: x0, y0, x1, y1, inclusive.
    pub rect: [i32; 4],
    /// The draw's state.
    pub state: &'a RenderState,
    /// The draw's targets.
    pub targets: &'a RawTargets<C>,
    /// The draw's fragment program.
    pub program: &'a P,
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
