//! Stage 5, raster: coverage of one triangle inside one tile by hierarchical block tests.
//!
//! Tile (64 x 64, from binning) -> 16 x 16 blocks -> 4 x 4 blocks -> pixels. At each block
//! level every edge is evaluated at the block's two extreme sample corners: if the largest
//! value is negative the block is trivially rejected; if the smallest is non-negative for all
//! three edges the block is trivially accepted and all its pixels are set with no further
//! edge test. The same integer edge functions decide every mode (the fill-rule bias or the
//! conservative half-pixel shift is already folded into them by setup), so all modes share
//! this traversal.
//!
//! The output is a coverage mask of the tile, one `u64` per row (bit `x` = pixel `x` of the
//! tile), which the fragment stage walks in row order.

use super::bin::TILE;
use super::setup::{Edge, SetupTri};

/// Coverage of one triangle in one tile: bit `lx` of `rows[ly]` is pixel (lx, ly) of the tile.
#[derive(Clone, Debug)]
pub struct TileMask {
    /// One word per tile row.
    pub rows: [u64; TILE as usize],
    /// First row that may be non-zero (tile-local).
    pub y0: i32,
    /// Last row that may be non-zero (tile-local, inclusive).
    pub y1: i32,
}

impl Default for TileMask {
    fn default() -> Self {
        TileMask {
            rows: [0; TILE as usize],
            y0: 0,
            y1: -1,
        }
    }
}

impl TileMask {
    /// The covered rows as `(ly, lo, hi)`: tile-local row and its first and last covered
    /// pixel (a triangle's coverage of a row is one interval).
    #[inline(always)]
    pub fn spans(&self) -> impl Iterator<Item = (i32, u32, u32)> + '_ {
        (self.y0.max(0)..=self.y1).filter_map(move |ly| {
            let bits = self.rows[ly as usize];
            (bits != 0).then(|| (ly, bits.trailing_zeros(), 63 - bits.leading_zeros()))
        })
    }

    /// Number of covered pixels.
    pub fn count(&self) -> u64 {
        if self.y1 < self.y0 {
            return 0;
        }
        self.rows[self.y0 as usize..=self.y1 as usize]
            .iter()
            .map(|r| r.count_ones() as u64)
            .sum()
    }
}

/// Classification of a block against the three edges.
#[derive(Copy, Clone, PartialEq, Eq, Debug)]
enum Class {
    Out,
    In,
    Partial,
}

#[inline(always)]
fn classify(edges: &[Edge; 3], x0: i64, y0: i64, x1: i64, y1: i64) -> Class {
    let mut all_in = true;
    for e in edges {
        let (xmax, xmin) = if e.dx > 0 { (x1, x0) } else { (x0, x1) };
        let (ymax, ymin) = if e.dy > 0 { (y1, y0) } else { (y0, y1) };
        if e.at(xmax, ymax) < 0 {
            return Class::Out;
        }
        if e.at(xmin, ymin) < 0 {
            all_in = false;
        }
    }
    if all_in {
        Class::In
    } else {
        Class::Partial
    }
}

/// The small-triangle row test: which of up to 16 pixels of a row pass all three edges, from
/// the edge values `b` at the row's first pixel and their per-pixel steps. SSE2 on x86-64 (4
/// lanes at a time, sign bits gathered with `movemask`), scalar elsewhere; same result.
struct RowLanes {
    dx: [i32; 3],
    #[cfg(target_arch = "x86_64")]
    ramp: [std::arch::x86_64::__m128i; 3],
    #[cfg(target_arch = "x86_64")]
    step: [std::arch::x86_64::__m128i; 3],
}

impl RowLanes {
    #[inline(always)]
    fn new(dx: [i32; 3]) -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of every x86-64 CPU.
            unsafe {
                let ramp = dx.map(|d| _mm_setr_epi32(0, d, 2 * d, 3 * d));
                let step = dx.map(|d| _mm_set1_epi32(4 * d));
                RowLanes { dx, ramp, step }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        RowLanes { dx }
    }

    /// Bit `i` set when pixel `i` (< `width` <= 16) passes all edges.
    #[inline(always)]
    fn row(&self, b: [i32; 3], width: u32) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            let _ = self.dx;
            // SAFETY: SSE2 is part of every x86-64 CPU.
            unsafe {
                let mut e0 = _mm_add_epi32(_mm_set1_epi32(b[0]), self.ramp[0]);
                let mut e1 = _mm_add_epi32(_mm_set1_epi32(b[1]), self.ramp[1]);
                let mut e2 = _mm_add_epi32(_mm_set1_epi32(b[2]), self.ramp[2]);
                let mut bits = 0u32;
                let mut k = 0;
                while k < width {
                    let or = _mm_or_si128(_mm_or_si128(e0, e1), e2);
                    let neg = _mm_movemask_ps(_mm_castsi128_ps(or)) as u32;
                    bits |= (!neg & 0xf) << k;
                    e0 = _mm_add_epi32(e0, self.step[0]);
                    e1 = _mm_add_epi32(e1, self.step[1]);
                    e2 = _mm_add_epi32(e2, self.step[2]);
                    k += 4;
                }
                bits & (span_bits(0, width as i32 - 1) as u32)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut bits = 0u32;
            for i in 0..width as i32 {
                let v = (b[0] + self.dx[0] * i) | (b[1] + self.dx[1] * i) | (b[2] + self.dx[2] * i);
                bits |= ((v >= 0) as u32) << i;
            }
            bits
        }
    }
}

/// Small triangles of a depth-only pass, coverage and depth test fused (SSE4.1): for each row
/// of the triangle's box in this tile, four pixels at a time, the three edge values give the
/// coverage lanes (the same integer test as [`RowLanes`]), the plane gives the depth (the
/// same float operations as the fragment stage's spans), and covered lanes that pass `Less`
/// (or `LessEqual`) are written. Returns `None` (nothing done) unless the triangle is small,
/// its box lies within 16 x 16 pixels of this tile, and its four-pixel chunks end inside the
/// tile row; else `(covered, passed)`.
///
/// `depth` points at the tile's origin pixel, `stride` is the target's row length, `zrow_at`
/// gives the depth plane's value at the start of tile row `ly` (offset included) and `dzdx`
/// its step. With `ids = Some((p, k))`, `p` points at a [`TILE`]-wide `u32` buffer of the tile
/// and `k` is written to every pixel that passes (the deferred path's visibility buffer).
/// Without SSE4.1 in the build's target it never applies: the caller's general path
/// (coverage, then depth spans) gives the same pixels, depths, ids and counts.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn small_depth_fused(
    tri: &SetupTri,
    rect: [i32; 4],
    depth: *mut f32,
    stride: usize,
    zrow_at: impl Fn(i32) -> f32,
    dzdx: f32,
    write: bool,
    less_equal: bool,
    ids: Option<(*mut u32, u32)>,
) -> Option<(u64, u64)> {
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse4.1")))]
    {
        let _ = (tri, rect, depth, stride, zrow_at, dzdx, write, less_equal, ids);
        None
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
    {
        use std::arch::x86_64::*;
        let x0 = tri.bbox[0].max(rect[0]);
        let y0 = tri.bbox[1].max(rect[1]);
        let x1 = tri.bbox[2].min(rect[2]);
        let y1 = tri.bbox[3].min(rect[3]);
        if !tri.small || x1 - x0 >= 16 || y1 - y0 >= 16 || x0 > x1 || y0 > y1 {
            return None;
        }
        let width = x1 - x0 + 1;
        let chunks = (width + 3) / 4;
        if x0 + 4 * chunks - 1 > rect[2] {
            return None;
        }
        let (ox, oy) = (rect[0], rect[1]);
        let e = &tri.edges;
        let lx0 = x0 - ox;
        // SAFETY: SSE4.1 is in the build's target (x86-64-v2); every lane read or written lies in
        // this worker's tile (checked above); lanes outside the triangle are written back as read.
        unsafe {
            let ramp = [0, 1, 2].map(|k| {
                let d = e[k].dx as i32;
                _mm_setr_epi32(0, d, 2 * d, 3 * d)
            });
            let step = [0, 1, 2].map(|k| _mm_set1_epi32(4 * e[k].dx as i32));
            let xs0 = _mm_add_epi32(_mm_set1_epi32(lx0), _mm_setr_epi32(0, 1, 2, 3));
            let four = _mm_set1_epi32(4);
            let (zero, one) = (_mm_setzero_ps(), _mm_set1_ps(1.0));
            let dz = _mm_set1_ps(dzdx);
            let lane_limit = _mm_set1_epi32(x1 - ox + 1);
            let (mut covered, mut passed) = (0u32, 0u32);
            // Edge values at the box's first pixel, stepped down the rows (exact: small triangles'
            // edge values stay far inside i32 over their box).
            let mut rows =
                [0, 1, 2].map(|k| _mm_add_epi32(_mm_set1_epi32(e[k].at(x0 as i64, y0 as i64) as i32), ramp[k]));
            let down = [0, 1, 2].map(|k| _mm_set1_epi32(e[k].dy as i32));
            for y in y0..=y1 {
                let [mut e0, mut e1, mut e2] = rows;
                rows = [0, 1, 2].map(|k| _mm_add_epi32(rows[k], down[k]));
                let zr = _mm_set1_ps(zrow_at(y - oy));
                let mut xs = xs0;
                let row = depth.add((y - oy) as usize * stride + lx0 as usize);
                for c in 0..chunks as usize {
                    let or = _mm_or_si128(_mm_or_si128(e0, e1), e2);
                    // Inside all edges (sign bit clear) and inside the box's columns.
                    let inside =
                        _mm_and_si128(_mm_cmpgt_epi32(or, _mm_set1_epi32(-1)), _mm_cmplt_epi32(xs, lane_limit));
                    let inside = _mm_castsi128_ps(inside);
                    // Branch-free: an empty chunk writes back what it read (lanes in this tile).
                    covered += (_mm_movemask_ps(inside) as u32).count_ones();
                    let z = _mm_add_ps(zr, _mm_mul_ps(dz, _mm_cvtepi32_ps(xs)));
                    let z = _mm_min_ps(one, _mm_max_ps(zero, z));
                    let p = row.add(4 * c);
                    let d = _mm_loadu_ps(p);
                    let t = if less_equal {
                        _mm_cmple_ps(z, d)
                    } else {
                        _mm_cmplt_ps(z, d)
                    };
                    let t = _mm_and_ps(t, inside);
                    passed += (_mm_movemask_ps(t) as u32).count_ones();
                    if write {
                        _mm_storeu_ps(p, _mm_blendv_ps(d, z, t));
                    }
                    if let Some((ip, k)) = ids {
                        store_ids4(ip.add((y - oy) as usize * TILE as usize + lx0 as usize + 4 * c), k, t);
                    }
                    e0 = _mm_add_epi32(e0, step[0]);
                    e1 = _mm_add_epi32(e1, step[1]);
                    e2 = _mm_add_epi32(e2, step[2]);
                    xs = _mm_add_epi32(xs, four);
                }
            }
            Some((covered as u64, passed as u64))
        }
    }
}

/// Writes id `k` to the lanes of `p[0..4]` (a visibility buffer) that `mask` (all-ones or
/// all-zeros lanes) selects; the other lanes keep their ids.
///
/// # Safety
/// `p .. p + 4` is readable and writable; SSE4.1 is in the build's target.
#[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
#[inline(always)]
pub(crate) unsafe fn store_ids4(p: *mut u32, k: u32, mask: std::arch::x86_64::__m128) {
    use std::arch::x86_64::*;
    let p = p as *mut __m128i;
    let old = _mm_castsi128_ps(_mm_loadu_si128(p));
    let new = _mm_blendv_ps(old, _mm_castsi128_ps(_mm_set1_epi32(k as i32)), mask);
    _mm_storeu_si128(p, _mm_castps_si128(new));
}

/// Bits `a..=b` set.
#[inline(always)]
fn span_bits(a: i32, b: i32) -> u64 {
    let n = (b - a + 1) as u32;
    let m = if n >= 64 { u64::MAX } else { (1u64 << n) - 1 };
    m << a
}

/// The covered interval `[l, r]` of row `y` within `[x0, x1]`: pixels where all three edge
/// functions are non-negative, by exact integer division (ceil for rising, floor for falling
/// edges).
#[inline(always)]
fn row_span(e: &[Edge; 3], x0: i32, x1: i32, y: i32) -> Option<(i32, i32)> {
    let (mut l, mut r) = (x0 as i64, x1 as i64);
    for ed in e {
        let v = ed.at(x0 as i64, y as i64);
        if ed.dx > 0 {
            if v < 0 {
                l = l.max(x0 as i64 + (-v + ed.dx - 1) / ed.dx);
            }
        } else if v < 0 {
            // Falling or flat and already negative: nothing further right passes.
            return None;
        } else if ed.dx < 0 {
            r = r.min(x0 as i64 + v / -ed.dx);
        }
    }
    (l <= r).then_some((l as i32, r as i32))
}

/// Computes the coverage of `tri` inside the tile whose inclusive pixel rectangle is `rect`
/// (origin `rect[0], rect[1]`) into `mask`. Returns the number of covered pixels.
pub fn raster_tile(tri: &SetupTri, rect: [i32; 4], mask: &mut TileMask) -> u64 {
    let x0 = tri.bbox[0].max(rect[0]);
    let y0 = tri.bbox[1].max(rect[1]);
    let x1 = tri.bbox[2].min(rect[2]);
    let y1 = tri.bbox[3].min(rect[3]);
    let (ox, oy) = (rect[0], rect[1]);
    mask.y0 = 0;
    mask.y1 = -1;
    if x0 > x1 || y0 > y1 {
        return 0;
    }
    mask.y0 = y0 - oy;
    mask.y1 = y1 - oy;
    for r in &mut mask.rows[(y0 - oy) as usize..=(y1 - oy) as usize] {
        *r = 0;
    }
    let e = &tri.edges;
    let mut n = 0u64;
    // Small triangles: a hierarchy level costs more than it saves; test every pixel of the
    // (at most 16 x 16) box. The triangle spans under 32 pixels, so every edge value within its
    // bounding box is below 2^28 in magnitude and the test runs on 16 lanes of `i32`.
    if tri.small && x1 - x0 < 16 && y1 - y0 < 16 {
        let dx = [e[0].dx as i32, e[1].dx as i32, e[2].dx as i32];
        let lanes = RowLanes::new(dx);
        let width = (x1 - x0 + 1) as u32;
        for y in y0..=y1 {
            let b = [
                e[0].at(x0 as i64, y as i64) as i32,
                e[1].at(x0 as i64, y as i64) as i32,
                e[2].at(x0 as i64, y as i64) as i32,
            ];
            let bits = lanes.row(b, width);
            n += bits.count_ones() as u64;
            mask.rows[(y - oy) as usize] = (bits as u64) << (x0 - ox);
        }
        return n;
    }
    // Large triangles: the whole tile at once if it is inside all edges, else row by row.
    // A triangle covers an interval of each row; every edge's condition `E >= 0` is monotone
    // along the row, so the interval's ends come from one exact integer division per edge
    // (the same pixels a per-pixel test would pick, at a fraction of the cost).
    match classify(e, x0 as i64, y0 as i64, x1 as i64, y1 as i64) {
        Class::Out => return 0,
        Class::In => {
            let bits = span_bits(x0 - ox, x1 - ox);
            for r in &mut mask.rows[(y0 - oy) as usize..=(y1 - oy) as usize] {
                *r = bits;
            }
            return ((x1 - x0 + 1) * (y1 - y0 + 1)) as u64;
        }
        Class::Partial => {}
    }
    let mut first = None;
    let mut last = 0;
    for y in y0..=y1 {
        if let Some((l, r)) = row_span(e, x0, x1, y) {
            mask.rows[(y - oy) as usize] = span_bits(l - ox, r - ox);
            n += (r - l + 1) as u64;
            first.get_or_insert(y);
            last = y;
        }
    }
    // Tighten the row range to the covered rows (the fragment stage walks it).
    match first {
        Some(f) => {
            mask.y0 = f - oy;
            mask.y1 = last - oy;
        }
        None => {
            mask.y0 = 0;
            mask.y1 = -1;
        }
    }
    n
}
