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

/// Bits `a..=b` set.
#[inline(always)]
fn span_bits(a: i32, b: i32) -> u64 {
    let n = (b - a + 1) as u32;
    let m = if n >= 64 { u64::MAX } else { (1u64 << n) - 1 };
    m << a
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
    let mut by = y0 & !15;
    while by <= y1 {
        let (cy0, cy1) = (by.max(y0), (by + 15).min(y1));
        let mut bx = x0 & !15;
        while bx <= x1 {
            let (cx0, cx1) = (bx.max(x0), (bx + 15).min(x1));
            match classify(e, cx0 as i64, cy0 as i64, cx1 as i64, cy1 as i64) {
                Class::Out => {}
                Class::In => {
                    let bits = span_bits(cx0 - ox, cx1 - ox);
                    for y in cy0..=cy1 {
                        mask.rows[(y - oy) as usize] |= bits;
                    }
                    n += ((cx1 - cx0 + 1) * (cy1 - cy0 + 1)) as u64;
                }
                Class::Partial => {
                    let mut sy = cy0 & !3;
                    while sy <= cy1 {
                        let (sy0, sy1) = (sy.max(cy0), (sy + 3).min(cy1));
                        let mut sx = cx0 & !3;
                        while sx <= cx1 {
                            let (sx0, sx1) = (sx.max(cx0), (sx + 3).min(cx1));
                            match classify(e, sx0 as i64, sy0 as i64, sx1 as i64, sy1 as i64) {
                                Class::Out => {}
                                Class::In => {
                                    let bits = span_bits(sx0 - ox, sx1 - ox);
                                    for y in sy0..=sy1 {
                                        mask.rows[(y - oy) as usize] |= bits;
                                    }
                                    n += ((sx1 - sx0 + 1) * (sy1 - sy0 + 1)) as u64;
                                }
                                Class::Partial => {
                                    for y in sy0..=sy1 {
                                        let mut e0 = e[0].at(sx0 as i64, y as i64);
                                        let mut e1 = e[1].at(sx0 as i64, y as i64);
                                        let mut e2 = e[2].at(sx0 as i64, y as i64);
                                        let mut bits = 0u64;
                                        for x in sx0..=sx1 {
                                            if (e0 | e1 | e2) >= 0 {
                                                bits |= 1u64 << (x - ox);
                                                n += 1;
                                            }
                                            e0 += e[0].dx;
                                            e1 += e[1].dx;
                                            e2 += e[2].dx;
                                        }
                                        mask.rows[(y - oy) as usize] |= bits;
                                    }
                                }
                            }
                            sx += 4;
                        }
                        sy += 4;
                    }
                }
            }
            bx += 16;
        }
        by += 16;
    }
    n
}
