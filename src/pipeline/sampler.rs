//! Texture sampling: nearest, bilinear, 2x2 comparison (hardware PCF, as `sampler2DShadow`),
//! gather, and explicit or derivative-selected mip levels.
//!
//! Coordinates: `uv` in [0, 1]^2 with the origin at the top-left; texel centres at
//! `(i + 0.5) / size`, so the texel-space position of `uv` is `uv * size - 0.5`.

use super::lanes::{floor4, index4};
use super::state::CompareFunc;
use super::surface::{MipChain, Surface, Texel};
use crate::math;
use glam::{BVec4A, Vec2, Vec3, Vec4};

/// What happens outside [0, 1].
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub enum Address {
    /// Clamp to the edge texel. (Default.)
    #[default]
    Clamp,
    /// Wrap around.
    Repeat,
}

/// Texel types that can be filtered (weighted sums).
pub trait Filterable: Texel {
    /// `a * wa + b * wb`.
    fn mix(a: Self, wa: f32, b: Self, wb: f32) -> Self;
}

impl Filterable for f32 {
    #[inline(always)]
    fn mix(a: f32, wa: f32, b: f32, wb: f32) -> f32 {
        a * wa + b * wb
    }
}

macro_rules! filterable_vec {
    ($($t:ty),*) => {$(
        impl Filterable for $t {
            #[inline(always)]
            fn mix(a: Self, wa: f32, b: Self, wb: f32) -> Self { a * wa + b * wb }
        }
    )*};
}
filterable_vec!(Vec2, Vec3, Vec4);

#[inline(always)]
fn wrap(i: i64, n: u32, addr: Address) -> i64 {
    match addr {
        Address::Clamp => i.clamp(0, n as i64 - 1),
        Address::Repeat => i.rem_euclid(n as i64),
    }
}

/// The 2x2 footprint of `uv`: integer corner and bilinear fractions.
#[inline(always)]
pub fn footprint(size: (u32, u32), uv: Vec2) -> (i64, i64, f32, f32) {
    let tx = uv.x * size.0 as f32 - 0.5;
    let ty = uv.y * size.1 as f32 - 0.5;
    let (fx, fy) = (tx.floor(), ty.floor());
    // Kept within ±2^60 so that neighbour offsets (`x + 1`, `x - r + i`) cannot overflow.
    const LIM: f32 = (1u64 << 60) as f32;
    (fx.clamp(-LIM, LIM) as i64, fy.clamp(-LIM, LIM) as i64, tx - fx, ty - fy)
}

/// The 2x2 footprint of a bilinear lookup at `uv` in a `size` map, clamped to the edge: its
/// texels `[top-left, top-right, bottom-left, bottom-right]` as (column, row), and the
/// fraction between them ([`footprint`]'s).
#[inline(always)]
pub fn footprint2x2(size: (u32, u32), uv: Vec2) -> ([(u32, u32); 4], Vec2) {
    let (x, y, fx, fy) = footprint(size, uv);
    let cx = |v: i64| v.clamp(0, size.0 as i64 - 1) as u32;
    let cy = |v: i64| v.clamp(0, size.1 as i64 - 1) as u32;
    let (x0, x1, y0, y1) = (cx(x), cx(x + 1), cy(y), cy(y + 1));
    ([(x0, y0), (x1, y0), (x0, y1), (x1, y1)], Vec2::new(fx, fy))
}

/// The bilinear mix of a 2x2 footprint's values `[top-left, top-right, bottom-left,
/// bottom-right]` at fraction `f`, in the hardware PCF's order of operations (the rows first,
/// each `a + (b - a) fx`): every filter of a footprint mixes this way, so that they agree bit
/// for bit.
#[inline(always)]
pub fn bilerp<T>(v: [T; 4], f: Vec2) -> T
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T> + std::ops::Mul<f32, Output = T>,
{
    let [a, b, c, d] = v;
    let top = a + (b - a) * f.x;
    let bottom = c + (d - c) * f.x;
    top + (bottom - top) * f.y
}

/// The weights [`bilerp`] gives the four texels of a footprint at fraction `f` (for
/// explanations: the mix itself is computed by [`bilerp`]).
pub fn bilerp_weights(f: Vec2) -> [f32; 4] {
    [
        (1.0 - f.x) * (1.0 - f.y),
        f.x * (1.0 - f.y),
        (1.0 - f.x) * f.y,
        f.x * f.y,
    ]
}

/// Nearest-texel lookup.
#[inline]
pub fn sample_nearest<T: Texel>(s: &Surface<T>, uv: Vec2, addr: Address) -> T {
    let x = (uv.x * s.width() as f32).floor() as i64;
    let y = (uv.y * s.height() as f32).floor() as i64;
    s.at(wrap(x, s.width(), addr) as u32, wrap(y, s.height(), addr) as u32)
}

/// The four texels of the bilinear footprint: `[top-left, top-right, bottom-left, bottom-right]`.
#[inline]
pub fn gather<T: Texel>(s: &Surface<T>, uv: Vec2, addr: Address) -> [T; 4] {
    let (x, y, _, _) = footprint((s.width(), s.height()), uv);
    let (x0, x1) = (wrap(x, s.width(), addr) as u32, wrap(x + 1, s.width(), addr) as u32);
    let (y0, y1) = (wrap(y, s.height(), addr) as u32, wrap(y + 1, s.height(), addr) as u32);
    [s.at(x0, y0), s.at(x1, y0), s.at(x0, y1), s.at(x1, y1)]
}

/// Bilinear lookup.
#[inline]
pub fn sample_bilinear<T: Filterable>(s: &Surface<T>, uv: Vec2, addr: Address) -> T {
    let (_, _, fx, fy) = footprint((s.width(), s.height()), uv);
    let [a, b, c, d] = gather(s, uv, addr);
    let top = T::mix(a, 1.0 - fx, b, fx);
    let bottom = T::mix(c, 1.0 - fx, d, fx);
    T::mix(top, 1.0 - fy, bottom, fy)
}

/// The edge rule of every map lookup, the samplers' borders and the shadow techniques'
/// `locate` alike: `uv` lies on a map when it is in `[0, 1)²`, where its texel
/// `floor(uv * size)` exists (a coordinate of exactly 1 is off the map, as a texel index of
/// `size` would be). NaN lies on no map.
#[inline(always)]
pub fn on_map(uv: Vec2) -> bool {
    uv.x >= 0.0 && uv.x < 1.0 && uv.y >= 0.0 && uv.y < 1.0
}

/// [`on_map`] of four coordinates `(u[l], v[l])`, one per lane.
#[inline(always)]
pub fn on_map4(u: Vec4, v: Vec4) -> BVec4A {
    u.cmpge(Vec4::ZERO) & u.cmplt(Vec4::ONE) & v.cmpge(Vec4::ZERO) & v.cmplt(Vec4::ONE)
}

/// A depth-comparison sampler (GL `sampler2DShadow` with linear filtering).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CompareSampler {
    /// `reference FUNC texel` is "lit". Default: `LessEqual`.
    pub func: CompareFunc,
    /// Result for `uv` off the map ([`on_map`]: outside `[0, 1)²`; `None`: clamp to edge).
    /// Default: `Some(1.0)` (lit).
    pub border: Option<f32>,
}

impl Default for CompareSampler {
    fn default() -> Self {
        CompareSampler {
            func: CompareFunc::LessEqual,
            border: Some(1.0),
        }
    }
}

impl CompareSampler {
    /// One comparison against the nearest texel (0 or 1).
    #[inline]
    pub fn nearest(&self, s: &Surface<f32>, uv: Vec2, reference: f32) -> f32 {
        if let Some(b) = self.border_for(uv) {
            return b;
        }
        let t = sample_nearest(s, uv, Address::Clamp);
        if self.func.test(reference, t) {
            1.0
        } else {
            0.0
        }
    }

    #[inline(always)]
    fn border_for(&self, uv: Vec2) -> Option<f32> {
        match self.border {
            Some(b) if !on_map(uv) => Some(b),
            _ => None,
        }
    }

    /// Hardware PCF: the four texels of the bilinear footprint are compared with `reference`
    /// and the 0/1 results weighted bilinearly.
    #[inline(always)]
    pub fn pcf2x2(&self, s: &Surface<f32>, uv: Vec2, reference: f32) -> f32 {
        if let Some(b) = self.border_for(uv) {
            return b;
        }
        self.pcf2x2_parts(s, uv, reference).value
    }

    /// [`CompareSampler::pcf2x2`] on the map (the border not applied), with its parts: the
    /// one code of the comparison, whose unused parts compile away in `pcf2x2`, so that an
    /// explanation reads the texels and outcomes the value was mixed from.
    #[inline(always)]
    pub fn pcf2x2_parts(&self, s: &Surface<f32>, uv: Vec2, reference: f32) -> Pcf2x2 {
        // The footprint of `footprint2x2` and the mix of `bilerp`, written out: this is the
        // innermost loop of every PCF kernel (the array form measured 15 % slower in PCSS).
        let (w, h) = (s.width(), s.height());
        let (x, y, fx, fy) = footprint((w, h), uv);
        let x0 = x.clamp(0, w as i64 - 1) as usize;
        let x1 = (x + 1).clamp(0, w as i64 - 1) as usize;
        let y0 = y.clamp(0, h as i64 - 1) as usize;
        let y1 = (y + 1).clamp(0, h as i64 - 1) as usize;
        let d = s.data();
        let ws = w as usize;
        let c = |t: f32| {
            if self.func.test(reference, t) {
                1.0f32
            } else {
                0.0
            }
        };
        let a = c(d[y0 * ws + x0]);
        let b = c(d[y0 * ws + x1]);
        let cc = c(d[y1 * ws + x0]);
        let dd = c(d[y1 * ws + x1]);
        let top = a + (b - a) * fx;
        let bottom = cc + (dd - cc) * fx;
        Pcf2x2 {
            texels: [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| (x as u32, y as u32)),
            lit: [a, b, cc, dd],
            fraction: Vec2::new(fx, fy),
            value: top + (bottom - top) * fy,
        }
    }
}

/// One hardware 2x2 comparison and what it was mixed from ([`CompareSampler::pcf2x2_parts`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Pcf2x2 {
    /// The footprint's texels: top-left, top-right, bottom-left, bottom-right (clamped to
    /// the map).
    pub texels: [(u32, u32); 4],
    /// Each texel's comparison: 1 lit, 0 not.
    pub lit: [f32; 4],
    /// The bilinear fraction.
    pub fraction: Vec2,
    /// The mix: the comparison's value.
    pub value: f32,
}

impl CompareSampler {
    /// The sum of `n x n` hardware 2x2 comparisons on a grid of whole-texel offsets
    /// (`-(n/2)..=n/2` texels in x and y), divided by `n^2`: a box-filtered PCF kernel of
    /// `n + 1` texels with bilinear edges (RTR 7.5). All taps share one bilinear fraction, so
    /// the sum collapses to `(n + 1)^2` comparisons with separable weights `1 - f, 1, ..., 1, f`
    /// instead of `4 n^2`. `n` must be odd; `n = 1` is [`CompareSampler::pcf2x2`].
    #[inline]
    pub fn pcf_grid(&self, s: &Surface<f32>, uv: Vec2, reference: f32, n: u32) -> f32 {
        if let Some(b) = self.border_for(uv) {
            return b;
        }
        let (w, h) = (s.width() as i64, s.height() as i64);
        let (x, y, fx, fy) = footprint((s.width(), s.height()), uv);
        let r = (n / 2) as i64;
        let d = s.data();
        let mut sum = 0.0f32;
        for j in 0..=n as i64 {
            let wy = grid_weight(j, n as i64, fy);
            let yy = (y - r + j).clamp(0, h - 1) as usize;
            let row = &d[yy * w as usize..(yy + 1) * w as usize];
            let mut rs = 0.0f32;
            for i in 0..=n as i64 {
                let wx = grid_weight(i, n as i64, fx);
                let xx = (x - r + i).clamp(0, w - 1) as usize;
                if self.func.test(reference, row[xx]) {
                    rs += wx;
                }
            }
            sum += wy * rs;
        }
        sum / (n * n) as f32
    }
}

/// Four lanes at once: [`CompareSampler::pcf2x2`] and [`CompareSampler::pcf_grid`] on
/// `Vec4`s of coordinates, each lane equal to the one-lane call bit for bit (same operations
/// in the same order; texels are fetched lane by lane).
impl CompareSampler {
    /// Lanes inside `[0, 1]^2` (NaN is outside), or all lanes when there is no border.
    #[inline(always)]
    fn inside4(&self, u: Vec4, v: Vec4) -> BVec4A {
        match self.border {
            Some(_) => on_map4(u, v),
            None => BVec4A::TRUE,
        }
    }

    /// The texel corner (as an exact float) and bilinear fractions of four lanes (see
    /// [`footprint`]).
    #[inline(always)]
    fn footprint4(s: &Surface<f32>, u: Vec4, v: Vec4) -> (Vec4, Vec4, Vec4, Vec4) {
        let tx = u * s.width() as f32 - Vec4::splat(0.5);
        let ty = v * s.height() as f32 - Vec4::splat(0.5);
        let (fx, fy) = (floor4(tx), floor4(ty));
        // A NaN corner is texel 0, as `NaN as i64` makes it in `footprint` (so its neighbour
        // offsets land where the one-lane path's do).
        let zero_nan = |f: Vec4| Vec4::select(f.is_nan_mask(), Vec4::ZERO, f);
        (zero_nan(fx), zero_nan(fy), tx - fx, ty - fy)
    }

    /// Asks the memory system for the texels [`CompareSampler::pcf2x2_4`] reads at `(u, v)`
    /// (one cache line per lane and row of the 2 x 2 footprint), without waiting for them.
    /// Changes no result: a program calls it from [`FragmentProgram::prefetch4`] so that a
    /// large map's cache misses overlap instead of stalling one lookup after another.
    ///
    /// [`FragmentProgram::prefetch4`]: super::FragmentProgram::prefetch4
    #[inline(always)]
    pub fn prefetch2x2_4(s: &Surface<f32>, u: Vec4, v: Vec4) {
        let (w, h) = (s.width() as i64, s.height() as i64);
        let (x, y, _, _) = Self::footprint4(s, u, v);
        let x0 = index4(x, w - 1);
        let (y0, y1) = (index4(y, h - 1), index4(y + Vec4::ONE, h - 1));
        let d = s.data();
        let ws = w as usize;
        #[cfg(target_arch = "x86_64")]
        for k in 0..4 {
            for ys in [y0, y1] {
                debug_assert!(ys[k] * ws + x0[k] < d.len());
                // SAFETY: the index is clamped into the map; prefetching never faults.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                        d.as_ptr().add(ys[k] * ws + x0[k]) as *const i8,
                    )
                };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (d, ws, x0, y0, y1);
    }

    /// [`CompareSampler::pcf2x2`] per lane.
    #[inline(always)]
    pub fn pcf2x2_4(&self, s: &Surface<f32>, u: Vec4, v: Vec4, reference: Vec4) -> Vec4 {
        let c = |t: Vec4| Vec4::select(self.func.test4(reference, t), Vec4::ONE, Vec4::ZERO);
        // The comparisons of the four texels, filtered bilinearly.
        let filter = |((t0, t1), (b0, b1)): ((Vec4, Vec4), (Vec4, Vec4)), fx: Vec4, fy: Vec4| {
            let (a, b, cc, dd) = (c(t0), c(t1), c(b0), c(b1));
            let top = a + (b - a) * fx;
            let bottom = cc + (dd - cc) * fx;
            top + (bottom - top) * fy
        };
        #[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
        {
            use std::arch::x86_64::*;
            let (w, h) = (s.width() as i64, s.height() as i64);
            let d = s.data();
            // Every lane's whole footprint inside the map (the common case): no NaN (it fails
            // the comparisons), no clamp, and inside [0, 1]^2, so no border either
            // (`floor(u w - 0.5) >= 0` gives `u > 0`, `<= w - 2` gives `u w < w`, so `u < 1`).
            // The same fractions and texels as below, each row's two texels one 8-byte load.
            let tx = u * w as f32 - Vec4::splat(0.5);
            let ty = v * h as f32 - Vec4::splat(0.5);
            let (x, y) = (floor4(tx), floor4(ty));
            let interior = x.cmpge(Vec4::ZERO)
                & x.cmple(Vec4::splat((w - 2) as f32))
                & y.cmpge(Vec4::ZERO)
                & y.cmple(Vec4::splat((h - 2) as f32));
            if w >= 2 && h >= 2 && interior.all() {
                let (fx, fy) = (tx - x, ty - y);
                let lanes = lane_indices(x, y, w as u32);
                // SAFETY: SSE4.1 is enabled for this build; x <= w - 2 and y <= h - 2, so texels
                // i, i + 1, i + w and i + w + 1 of every lane's index i are in the map.
                let texels = unsafe {
                    let pair = |i: usize| {
                        debug_assert!(i + 1 < d.len());
                        _mm_castpd_ps(_mm_load_sd(d.as_ptr().add(i) as *const f64))
                    };
                    let row = |off: usize| -> (Vec4, Vec4) {
                        let p01 = _mm_movelh_ps(pair(lanes[0] + off), pair(lanes[1] + off));
                        let p23 = _mm_movelh_ps(pair(lanes[2] + off), pair(lanes[3] + off));
                        (
                            Vec4::from(_mm_shuffle_ps::<0b10_00_10_00>(p01, p23)),
                            Vec4::from(_mm_shuffle_ps::<0b11_01_11_01>(p01, p23)),
                        )
                    };
                    (row(0), row(w as usize))
                };
                return filter(texels, fx, fy);
            }
        }
        let inside = self.inside4(u, v);
        let (x, y, fx, fy) = Self::footprint4(s, u, v);
        // Footprints that reach past an edge, NaN or outside the map: clamped lane by lane.
        self.bordered(inside, filter(Self::texels2x2_4(s, x, y), fx, fy))
    }

    /// The 2 x 2 footprint's texels at corner `(x, y)` of four lanes, clamped to the edge,
    /// lane by lane: `((x0 y0, x1 y0), (x0 y1, x1 y1))`.
    #[inline(always)]
    fn texels2x2_4(s: &Surface<f32>, x: Vec4, y: Vec4) -> ((Vec4, Vec4), (Vec4, Vec4)) {
        let (w, h) = (s.width() as i64, s.height() as i64);
        let (x0, x1) = (index4(x, w - 1), index4(x + Vec4::ONE, w - 1));
        let (y0, y1) = (index4(y, h - 1), index4(y + Vec4::ONE, h - 1));
        let (d, ws) = (s.data(), w as usize);
        let fetch =
            |ys: [usize; 4], xs: [usize; 4]| Vec4::from_array(std::array::from_fn(|i| texel(d, ys[i] * ws + xs[i])));
        ((fetch(y0, x0), fetch(y0, x1)), (fetch(y1, x0), fetch(y1, x1)))
    }

    /// `r` where `inside`, the border value elsewhere.
    #[inline(always)]
    fn bordered(&self, inside: BVec4A, r: Vec4) -> Vec4 {
        Vec4::select(inside, r, Vec4::splat(self.border.unwrap_or(0.0)))
    }

    /// [`CompareSampler::pcf_grid`] per lane.
    #[inline(always)]
    pub fn pcf_grid_4(&self, s: &Surface<f32>, u: Vec4, v: Vec4, reference: Vec4, n: u32) -> Vec4 {
        let inside = self.inside4(u, v);
        let (w, h) = (s.width() as i64, s.height() as i64);
        let (x, y, fx, fy) = Self::footprint4(s, u, v);
        let r = (n / 2) as f32;
        let d = s.data();
        let ws = w as usize;
        // Column indices of every tap, computed once (for kernels up to 15 x 15 on the stack).
        const MAX_TAPS: usize = 16;
        let col = |i: i64| index4(x - Vec4::splat(r) + Vec4::splat(i as f32), w - 1);
        let mut cols = [[0usize; 4]; MAX_TAPS];
        let cached = (n as usize) < MAX_TAPS;
        if cached {
            for (i, c) in cols.iter_mut().enumerate().take(n as usize + 1) {
                *c = col(i as i64);
            }
        }
        let mut sum = Vec4::ZERO;
        for j in 0..=n as i64 {
            let wy = grid_weight4(j, n as i64, fy);
            let rows = index4(y - Vec4::splat(r) + Vec4::splat(j as f32), h - 1).map(|yy| yy * ws);
            let mut rs = Vec4::ZERO;
            for i in 0..=n as i64 {
                let wx = grid_weight4(i, n as i64, fx);
                let xx = if cached { cols[i as usize] } else { col(i) };
                let t = Vec4::from_array(std::array::from_fn(|k| texel(d, rows[k] + xx[k])));
                // `rs += wx` where the test passes; + 0.0 elsewhere leaves `rs` (never -0.0).
                rs += Vec4::select(self.func.test4(reference, t), wx, Vec4::ZERO);
            }
            sum += wy * rs;
        }
        self.bordered(inside, sum / (n * n) as f32)
    }
}

/// The texels at whole-number coordinates `(x, y)` of four lanes, clamped into the surface
/// (NaN lanes read texel 0 of their axis, as [`index4`] makes them): one vector index
/// computation (`y * width + x`) instead of four scalar ones, then four loads.
#[inline(always)]
pub fn texels4(s: &Surface<f32>, x: Vec4, y: Vec4) -> Vec4 {
    texels_at4(s, Indices4::new(s, x, y))
}

/// The texel indices that [`texels4`] reads at `(x, y)` (clamped into surface `s`), made
/// ahead of their loads: a loop that makes a batch of them first and loads them after keeps
/// many loads in flight at once.
#[derive(Copy, Clone, Debug, Default)]
pub struct Indices4([u32; 4]);

impl Indices4 {
    /// [`texels4`]'s indices at whole-number coordinates `(x, y)` of surface `s`.
    #[inline(always)]
    pub fn new(s: &Surface<f32>, x: Vec4, y: Vec4) -> Indices4 {
        let (w, h) = (s.width(), s.height());
        #[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
        {
            use std::arch::x86_64::*;
            // Clamped in float as `index4` does (`maxps` maps NaN to 0).
            let cx = Vec4::splat((w - 1) as f32).min(x.max(Vec4::ZERO));
            let cy = Vec4::splat((h - 1) as f32).min(y.max(Vec4::ZERO));
            // SAFETY: four lanes of u32 are one __m128i.
            Indices4(unsafe { std::mem::transmute::<__m128i, [u32; 4]>(lane_index_vector(cx, cy, w)) })
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "sse4.1")))]
        {
            let (xs, ys) = (index4(x, w as i64 - 1), index4(y, h as i64 - 1));
            Indices4(std::array::from_fn(|k| (ys[k] * w as usize + xs[k]) as u32))
        }
    }

    /// The indices `y * width + x` of surface `s` for the lanes of `keep`, whose `(x, y)`
    /// must lie in the surface (then truncation is the floor), and 0 for the others: for a
    /// loop whose lanes outside the surface read a texel they then ignore.
    #[inline(always)]
    pub fn kept(s: &Surface<f32>, x: Vec4, y: Vec4, keep: BVec4A) -> Indices4 {
        let w = s.width();
        #[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE4.1 is enabled for this build; four lanes of u32 are one __m128i.
            // Kept lanes' indices are below w * h (see `lane_index_vector`), the others are
            // masked to 0.
            unsafe {
                let i = _mm_and_si128(lane_index_vector(x, y, w), _mm_castps_si128(keep.into()));
                Indices4(std::mem::transmute::<__m128i, [u32; 4]>(i))
            }
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "sse4.1")))]
        {
            Indices4(std::array::from_fn(|k| {
                if keep.test(k) {
                    y[k] as u32 * w + x[k] as u32
                } else {
                    0
                }
            }))
        }
    }
}

/// The texels of surface `s` at indices `i` made for it.
#[inline(always)]
pub fn texels_at4(s: &Surface<f32>, i: Indices4) -> Vec4 {
    let d = s.data();
    // The indices lie in the surface (clamped when made); checked here as well, since an
    // `Indices4` made for a larger surface could be passed.
    let at = |k: usize| d[i.0[k] as usize];
    Vec4::new(at(0), at(1), at(2), at(3))
}

/// [`lane_indices`] as one vector of four u32 lanes.
#[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
#[inline(always)]
fn lane_index_vector(x: Vec4, y: Vec4, w: u32) -> std::arch::x86_64::__m128i {
    use std::arch::x86_64::*;
    // SAFETY: SSE4.1 is enabled for this build.
    unsafe {
        _mm_add_epi32(
            _mm_mullo_epi32(_mm_cvttps_epi32(y.into()), _mm_set1_epi32(w as i32)),
            _mm_cvttps_epi32(x.into()),
        )
    }
}

/// The texel indices `y * w + x` of four lanes of whole, in-surface coordinates, computed on
/// all lanes at once (w * h < 2^31: both sides at most MAX_DIMENSION = 2^14, so the indices
/// fit an i32 and are zero-extended).
#[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
#[inline(always)]
fn lane_indices(x: Vec4, y: Vec4, w: u32) -> [usize; 4] {
    use std::arch::x86_64::*;
    let i = lane_index_vector(x, y, w);
    // SAFETY: SSE4.1 is enabled for this build.
    unsafe {
        [
            _mm_cvtsi128_si32(i) as u32 as usize,
            _mm_extract_epi32::<1>(i) as u32 as usize,
            _mm_extract_epi32::<2>(i) as u32 as usize,
            _mm_extract_epi32::<3>(i) as u32 as usize,
        ]
    }
}

/// `d[i]` for an index [`index4`] has clamped into the surface.
#[inline(always)]
fn texel(d: &[f32], i: usize) -> f32 {
    debug_assert!(i < d.len());
    // SAFETY: callers build `i` as `y * width + x` with `y < height` and `x < width`.
    unsafe { *d.get_unchecked(i) }
}

/// [`grid_weight`] on four lanes.
#[inline(always)]
fn grid_weight4(k: i64, n: i64, f: Vec4) -> Vec4 {
    if k == 0 {
        Vec4::ONE - f
    } else if k == n {
        f
    } else {
        Vec4::ONE
    }
}

/// Weight of texel `k` (0..=n) of an `n`-tap unit-spaced sum of bilinear kernels with
/// fraction `f`: `1 - f` at the first, `f` at the last, 1 between.
#[inline(always)]
fn grid_weight(k: i64, n: i64, f: f32) -> f32 {
    if k == 0 {
        1.0 - f
    } else if k == n {
        f
    } else {
        1.0
    }
}

/// Bilinear lookup in mip level `level` (an error value for a level that does not exist).
pub fn sample_level<T: Filterable>(
    m: &MipChain<T>,
    uv: Vec2,
    level: usize,
    addr: Address,
) -> Result<T, super::PipelineError> {
    Ok(sample_bilinear(m.level(level)?, uv, addr))
}

/// The mip level (fractional, clamped to the chain) for texture-coordinate derivatives
/// `duv_dx`, `duv_dy` per pixel, as GPUs select it: `log2(max(|d/dx|, |d/dy|) * size)`.
pub fn select_level<T: Texel>(m: &MipChain<T>, duv_dx: Vec2, duv_dy: Vec2) -> f32 {
    let base = &m.levels()[0];
    let size = Vec2::new(base.width() as f32, base.height() as f32);
    let rho = (duv_dx * size).length().max((duv_dy * size).length());
    if rho.is_nan() || rho <= 1.0 {
        return 0.0;
    }
    math::log2(rho).min((m.level_count() - 1) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal bits, or both NaN (a NaN's payload is not part of the contract).
    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    #[test]
    fn four_lane_texel_reads_clamp_as_one_lane_reads() {
        let s = Surface::from_vec(7, 5, (0..35).map(|i| i as f32).collect()).unwrap();
        let coords = [-3.0, -0.0, 0.0, 1.0, 4.0, 6.0, 9.0, 1e30, -1e30, f32::NAN];
        for &x in &coords {
            for &y in &coords {
                let four = texels4(&s, Vec4::new(x, 0.0, x, 2.0), Vec4::new(y, y, 1.0, y));
                for (k, (xx, yy)) in [(x, y), (0.0, y), (x, 1.0), (2.0, y)].into_iter().enumerate() {
                    // `as` maps NaN to 0 and saturates, as the clamp does.
                    let (cx, cy) = ((xx as i64).clamp(0, 6) as u32, (yy as i64).clamp(0, 4) as u32);
                    assert_eq!(four[k], s.at(cx, cy), "lane {k} at ({xx}, {yy})");
                }
            }
        }
    }

    #[test]
    fn huge_coordinates_clamp_without_overflow() {
        // Regression: `pcf_grid` added its offsets to a saturated `i64` (overflow panic in
        // debug builds, a wrapped index in release).
        let s = Surface::from_vec(4, 4, (0..16).map(|i| i as f32 / 16.0).collect()).unwrap();
        let cs = CompareSampler {
            func: CompareFunc::LessEqual,
            border: None,
        };
        for big in [1e30f32, -1e30, 3e18] {
            let uv = Vec2::new(0.4, big);
            let edge = Vec2::new(0.4, if big > 0.0 { 1.0 } else { 0.0 });
            assert_eq!(cs.pcf_grid(&s, uv, 0.5, 3), cs.pcf_grid(&s, edge, 0.5, 3), "{big}");
        }
    }

    #[test]
    fn four_lane_pcf_equals_one_lane_bit_for_bit() {
        let mut rng = crate::hash::SplitMix(11);
        let data = (0..37 * 23).map(|_| rng.next_f32()).collect();
        let s = Surface::from_vec(37, 23, data).unwrap();
        let special = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e30,
            -1e30,
            -0.0,
            0.0,
            1.0,
            0.5 / 37.0,
        ];
        let coord = |rng: &mut crate::hash::SplitMix| {
            if rng.next_u64().is_multiple_of(6) {
                special[(rng.next_u64() % special.len() as u64) as usize]
            } else {
                rng.next_f32() * 1.6 - 0.3
            }
        };
        let funcs = [
            CompareFunc::Never,
            CompareFunc::Less,
            CompareFunc::Equal,
            CompareFunc::LessEqual,
            CompareFunc::Greater,
            CompareFunc::NotEqual,
            CompareFunc::GreaterEqual,
            CompareFunc::Always,
        ];
        for round in 0..3000 {
            let cs = CompareSampler {
                func: funcs[round % 8],
                border: [Some(1.0), Some(0.25), None][round % 3],
            };
            let u = Vec4::from_array(std::array::from_fn(|_| coord(&mut rng)));
            let v = Vec4::from_array(std::array::from_fn(|_| coord(&mut rng)));
            let r = Vec4::from_array(std::array::from_fn(|i| {
                if i == 3 && round % 7 == 0 {
                    f32::NAN
                } else {
                    rng.next_f32()
                }
            }));
            // The prefetch hint takes the same awkward coordinates (clamped, never out of
            // the map) and changes nothing.
            CompareSampler::prefetch2x2_4(&s, u, v);
            let two = cs.pcf2x2_4(&s, u, v, r).to_array();
            for n in [1, 3, 5] {
                let grid = cs.pcf_grid_4(&s, u, v, r, n).to_array();
                for i in 0..4 {
                    let uv = Vec2::new(u.to_array()[i], v.to_array()[i]);
                    let rf = r.to_array()[i];
                    assert!(same(grid[i], cs.pcf_grid(&s, uv, rf, n)), "grid {n} {cs:?} {uv} {rf}");
                    assert!(same(two[i], cs.pcf2x2(&s, uv, rf)), "2x2 {cs:?} {uv} {rf}");
                }
            }
        }
    }

    #[test]
    fn bilinear_at_texel_centre_is_exact() {
        let s = Surface::from_vec(2, 1, vec![0.0f32, 1.0]).unwrap();
        assert_eq!(sample_bilinear(&s, Vec2::new(0.25, 0.5), Address::Clamp), 0.0);
        assert_eq!(sample_bilinear(&s, Vec2::new(0.75, 0.5), Address::Clamp), 1.0);
        assert_eq!(sample_bilinear(&s, Vec2::new(0.5, 0.5), Address::Clamp), 0.5);
    }

    #[test]
    fn pcf_weights_comparisons_bilinearly() {
        let s = Surface::from_vec(2, 2, vec![0.2f32, 0.8, 0.2, 0.8]).unwrap();
        let cs = CompareSampler::default();
        // Halfway between the columns: one column lit, one shadowed.
        assert!((cs.pcf2x2(&s, Vec2::new(0.5, 0.5), 0.5) - 0.5).abs() < 1e-6);
        assert_eq!(cs.pcf2x2(&s, Vec2::new(0.25, 0.25), 0.5), 0.0);
        assert_eq!(cs.pcf2x2(&s, Vec2::new(1.5, 0.5), 0.5), 1.0);
    }

    #[test]
    fn pcf_grid_equals_sum_of_2x2_taps() {
        let data: Vec<f32> = (0..64 * 64).map(|i| ((i * 7919) % 101) as f32 / 100.0).collect();
        let s = Surface::from_vec(64, 64, data).unwrap();
        let cs = CompareSampler::default();
        for k in 0..50 {
            let uv = Vec2::new(0.2 + 0.011 * k as f32, 0.7 - 0.009 * k as f32);
            let reference = 0.3 + 0.01 * k as f32;
            for n in [1u32, 3, 5] {
                let r = (n / 2) as i32;
                let mut taps = 0.0;
                for j in -r..=r {
                    for i in -r..=r {
                        taps += cs.pcf2x2(&s, uv + Vec2::new(i as f32, j as f32) / 64.0, reference);
                    }
                }
                let grid = cs.pcf_grid(&s, uv, reference, n);
                assert!(
                    (grid - taps / (n * n) as f32).abs() < 1e-4,
                    "n {n} uv {uv}: {grid} vs {}",
                    taps / (n * n) as f32
                );
            }
        }
    }

    #[test]
    fn repeat_wraps() {
        let s = Surface::from_vec(2, 1, vec![3u8, 7]).unwrap();
        assert_eq!(sample_nearest(&s, Vec2::new(1.25, 0.5), Address::Repeat), 3);
        assert_eq!(sample_nearest(&s, Vec2::new(1.25, 0.5), Address::Clamp), 7);
    }
}
