//! The shadow map's hierarchy (RTR 7.6's hierarchical min/max shadow map, extended to sloped
//! receivers): per block of texels the least and greatest depth, and a plane with the least
//! and greatest residual of the block's depths from it.
//!
//! The min/max map classifies a kernel as fully lit when the highest reference depth of its
//! taps is at or before the least depth of its footprint. On a receiver that is sloped in the
//! light's view (a ground under a low sun) with the receiver-plane bias (Isidoro 2006) the
//! footprint holds the receiver itself, whose depths span the slope across the footprint, so
//! the least depth lies before the highest reference and no kernel on it is classified: the
//! hierarchy costs its lookups and saves no tap. So each block also keeps its depths as a
//! plane `P(p) = c + g . (p - m)` (`m` the block's centre, `p` a texel centre in texels) and
//! the bounds `lo <= depth - P <= hi` over its texels. A kernel whose taps compare against
//! the receiver's plane `r(p) = z + g_r . (p - q)` is then fully lit when, over every block
//! its footprint touches, `lo + min (P - r) >= 0` (less what a tap reads beyond its
//! position), and fully shadowed when `hi + max (P - r) < 0`. `P - r` is linear, so its
//! extremes over a box are at the box's corners. Where a block's depths are one plane (a
//! ground seen by a directional light is one, since depths interpolate linearly in an
//! orthographic view), `lo` and `hi` are rounding, and a kernel on the ground is classified as
//! soon as no caster lies in its footprint. A block keeps a flat plane (`g = 0`) where that
//! bounds its depths more tightly.
//!
//! A classification looks at the first level whose blocks cut the kernel's footprint into at
//! most 2 x 2 and tests the four blocks on four lanes: lit where each block passes the plain
//! min/max test (exact for a flat reference, a few ulps of margin for a sloped one, as RTR's
//! hierarchy) or the plane's bound (a margin of 256 float epsilons of the magnitudes
//! involved, far above the rounding of the chain and of [`Reference::at`]); shadowed where
//! each block passes the plain test or the plane's (`hi + max (P - r) < 0`). A flat
//! reference takes the plain test alone. A classified
//! kernel's taps all pass (all fail) exactly, so the filter's result, exactly 1 or 0 (see
//! [`super::kernel`]), is the one the taps give.
//!
//! The chain is a reduction in the pipeline's thread pool: the finest level takes blocks of
//! 8x8 texels from the map (a least-squares plane, then the residuals exactly), every next
//! level 2x2 blocks of the one below (a plane through the children's centre values, and the
//! children's bounds carried over: `P_child - P` is linear over the child's box).

use super::kernel::{Class, Reference};
use crate::pipeline::{Pipeline, Surface};
use glam::{Vec2, Vec4};
use rayon::prelude::*;

/// Texels per side of the finest level's blocks.
pub const FINEST: u32 = 8;

/// One block of a level: its plane and the bounds of its depths' residual from it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Block {
    /// The plane's value at the block's centre.
    pub c: f32,
    /// The plane's change per texel in x and y.
    pub g: Vec2,
    /// Least and greatest `depth - plane` over the block's texel centres (minus and plus
    /// infinity where a depth is not finite).
    pub lo: f32,
    /// See `lo`.
    pub hi: f32,
    /// The least and greatest depth of the block's texels, exactly (minus and plus infinity
    /// where a depth is not finite).
    pub min: f32,
    /// See `min`.
    pub max: f32,
}

impl Block {
    /// A block that bounds nothing (a depth that is not finite): classifies every kernel that
    /// touches it as mixed.
    const UNKNOWN: Block = Block {
        c: 0.0,
        g: Vec2::ZERO,
        lo: f32::NEG_INFINITY,
        hi: f32::INFINITY,
        min: f32::NEG_INFINITY,
        max: f32::INFINITY,
    };

    /// The block with plane `c`, `g`, residual bounds `lo ..= hi` and depths `min ..= max`;
    /// flat (`g = 0`, the plain min/max) where that bounds the depths more tightly;
    /// [`Block::UNKNOWN`] where a value is not finite.
    fn new(c: f32, g: Vec2, (lo, hi): (f32, f32), (min, max): (f32, f32)) -> Block {
        if !(c.is_finite() && g.is_finite() && lo.is_finite() && hi.is_finite() && min.is_finite() && max.is_finite()) {
            return Block::UNKNOWN;
        }
        if max - min < hi - lo {
            let c = 0.5 * (min + max);
            return Block {
                c,
                g: Vec2::ZERO,
                lo: min - c,
                hi: max - c,
                min,
                max,
            };
        }
        Block { c, g, lo, hi, min, max }
    }
}

/// One level: blocks of `block` x `block` texels (the last row and column may be narrower).
pub struct Level {
    /// Texels per block side.
    pub block: u32,
    /// Blocks per row and per column.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// Row-major blocks.
    pub blocks: Vec<Block>,
    /// The classification's tables ([`Tables`]).
    tables: Tables,
}

/// A level's blocks as the classification reads them: per block the plane's lowest and
/// highest offsets `c + lo` and `c + hi`, its slopes, the magnitude `|c| + |lo| + |hi|` (for
/// the rounding margin) and the least and greatest depth, one array each, rows `width + 1`
/// long with one more row, the extra entries bounding nothing, so that two neighbouring
/// blocks of two neighbouring rows are always four in-bounds reads.
struct Tables {
    stride: usize,
    low: Vec<f32>,
    high: Vec<f32>,
    gx: Vec<f32>,
    gy: Vec<f32>,
    mag: Vec<f32>,
    min: Vec<f32>,
    max: Vec<f32>,
}

impl Tables {
    fn new(blocks: &[Block], width: u32, height: u32) -> Tables {
        let stride = width as usize + 1;
        let n = stride * (height as usize + 1);
        let mut t = Tables {
            stride,
            low: vec![f32::NEG_INFINITY; n],
            high: vec![f32::INFINITY; n],
            gx: vec![0.0; n],
            gy: vec![0.0; n],
            mag: vec![0.0; n],
            min: vec![f32::NEG_INFINITY; n],
            max: vec![f32::INFINITY; n],
        };
        let rows = t
            .low
            .par_chunks_mut(stride)
            .zip(t.high.par_chunks_mut(stride))
            .zip(t.gx.par_chunks_mut(stride))
            .zip(t.gy.par_chunks_mut(stride))
            .zip(t.mag.par_chunks_mut(stride))
            .zip(t.min.par_chunks_mut(stride))
            .zip(t.max.par_chunks_mut(stride));
        rows.zip(blocks.par_chunks(width as usize))
            .for_each(|(((((((low, high), gx), gy), mag), min), max), row)| {
                for (i, k) in row.iter().enumerate() {
                    min[i] = k.min;
                    max[i] = k.max;
                    if k.lo.is_finite() && k.hi.is_finite() {
                        low[i] = k.c + k.lo;
                        high[i] = k.c + k.hi;
                        gx[i] = k.g.x;
                        gy[i] = k.g.y;
                        mag[i] = k.c.abs() + k.lo.abs() + k.hi.abs();
                    }
                }
            });
        t
    }

    /// Field `f` of blocks `j`, `j + 1`, `j + stride` and `j + stride + 1`.
    #[inline(always)]
    fn quad(&self, f: &[f32], j: usize) -> Vec4 {
        let (r0, r1) = (&f[j..j + 2], &f[j + self.stride..j + self.stride + 2]);
        Vec4::new(r0[0], r0[1], r1[0], r1[1])
    }
}

impl Level {
    /// The level of `blocks` (row-major, `width` x `height`), each `block` texels wide, with
    /// its classification tables (made in `p`'s thread pool).
    fn new(p: &Pipeline, block: u32, (width, height): (u32, u32), blocks: Vec<Block>) -> Level {
        Level {
            block,
            width,
            height,
            tables: p.install(|| Tables::new(&blocks, width, height)),
            blocks,
        }
    }

    /// Block `(x, y)`.
    #[inline(always)]
    pub fn at(&self, x: u32, y: u32) -> &Block {
        &self.blocks[(y * self.width + x) as usize]
    }
}

/// The plane-residual hierarchy of one depth map (see the module docs).
pub struct PlaneChain {
    /// The map's size.
    pub size: (u32, u32),
    /// Levels, finest ([`FINEST`] texels per block) first, to one block.
    pub levels: Vec<Level>,
}

/// The texel-centre span `[a, b]` of a block along one axis: blocks of `block` texels, index
/// `i`, a map `n` texels wide.
#[inline(always)]
fn span(i: u32, block: u32, n: u32) -> (f32, f32) {
    let a = i * block;
    let b = ((i + 1) * block).min(n);
    (a as f32 + 0.5, b as f32 - 0.5)
}

impl PlaneChain {
    /// The chain of `map`, built in `p`'s thread pool.
    pub fn new(p: &Pipeline, map: &Surface<f32>) -> PlaneChain {
        let (w, h) = (map.width(), map.height());
        let mut levels = vec![finest(p, map)];
        while levels.last().is_some_and(|l| l.width > 1 || l.height > 1) {
            let next = coarser(p, levels.last().expect("a level"), (w, h));
            levels.push(next);
        }
        PlaneChain { size: (w, h), levels }
    }

    /// Classifies a kernel at `uv` whose taps lie within `radius` texels of it along each axis
    /// and each read the texel centres within `reach` texels of its position along each axis
    /// (0.5 for a nearest-texel read, 1 for a bilinear one), comparing against `r`: lit when
    /// every tap passes (its depths at or beyond its reference), shadowed when every tap fails.
    ///
    /// It looks at the first level whose blocks cut the footprint into at most 2 x 2 and tests
    /// those blocks on four lanes (see the module docs): for lit, a block's least depth or its
    /// plane's bound `P - r` over the whole footprint (a box around `uv`), with a margin of 256
    /// float epsilons of the magnitudes involved; for shadowed, its greatest depth or the
    /// plane's bound. A footprint that leaves the map is mixed (its taps meet the border).
    pub fn classify(&self, uv: Vec2, radius: f32, reach: f32, r: &Reference) -> Class {
        let (w, h) = self.size;
        let (fw, fh) = (w as f32, h as f32);
        let (qx, qy) = (uv.x * fw, uv.y * fh);
        // A tap's texel comes from its own float uv: allow its rounding (ulps of the map).
        let reach = reach + 2.0 * f32::EPSILON * fw.max(fh);
        let e = radius + reach;
        let (lx, ly, hx, hy) = (qx - e, qy - e, qx + e, qy + e);
        if !(lx >= 0.0 && ly >= 0.0 && hx <= fw && hy <= fh && e.is_finite()) {
            return Class::Mixed;
        }
        // Texels whose centres lie in the footprint: ceil(lo - 0.5) ..= floor(hi - 0.5).
        let (x0, y0) = ((lx - 0.5).ceil() as u32, (ly - 0.5).ceil() as u32);
        let (x1, y1) = (
            ((hx - 0.5).floor() as u32).min(w - 1),
            ((hy - 0.5).floor() as u32).min(h - 1),
        );
        let mut i = 0;
        let mut s = FINEST.trailing_zeros();
        while i + 1 < self.levels.len() && ((x1 >> s) - (x0 >> s) > 1 || (y1 >> s) - (y0 >> s) > 1) {
            i += 1;
            s += 1;
        }
        let t = &self.levels[i].tables;
        let (bx, by) = (x0 >> s, y0 >> s);
        // The blocks' centres (the last row and column may be narrower).
        let centre = |i: u32, n: u32| 0.5 * ((i << s) + ((i + 1) << s).min(n)) as f32;
        let (mx0, my0) = (centre(bx, w), centre(by, h));
        let (mx1, my1) = (centre(bx + 1, w), centre(by + 1, h));
        // Lanes: (bx, by), (bx + 1, by), (bx, by + 1), (bx + 1, by + 1); the second column and
        // row only where the footprint reaches them.
        let (two_x, two_y) = ((x1 >> s) > bx, (y1 >> s) > by);
        let idle = glam::BVec4A::new(false, !two_x, !two_y, !(two_x && two_y));
        let j = by as usize * t.stride + bx as usize;
        if r.is_flat() {
            // Every tap compares against `z` exactly: the plain min/max test, without margin.
            // (A block's plane could only bound the footprint's part of a sloped block more
            // tightly, which a flat reference on a receiver seldom needs.)
            let z = Vec4::splat(r.z);
            return if (z.cmple(t.quad(&t.min, j)) | idle).all() {
                Class::Lit
            } else if (z.cmpgt(t.quad(&t.max, j)) | idle).all() {
                Class::Shadowed
            } else {
                Class::Mixed
            };
        }
        let (gx, gy) = (t.quad(&t.gx, j), t.quad(&t.gy, j));
        let tx = gx * (Vec4::splat(qx) - Vec4::new(mx0, mx1, mx0, mx1));
        let ty = gy * (Vec4::splat(qy) - Vec4::new(my0, my0, my1, my1));
        let ev = Vec4::splat(e);
        let spread = ((gx - Vec4::splat(r.gradient.x)).abs() + (gy - Vec4::splat(r.gradient.y)).abs()) * ev;
        // A tap's reference differs from the one at a texel centre it reads by at most `read`;
        // the bias cone moves it by `cone` per texel of distance from the centre (toward the
        // light where negative): at most `up` up or `down` down.
        let slope = r.gradient.x.abs() + r.gradient.y.abs();
        let read = slope * reach;
        let moved = r.cone.abs() * radius * std::f32::consts::SQRT_2;
        let (up, down) = if r.cone > 0.0 { (moved, 0.0) } else { (0.0, moved) };
        let base = 1.0 + r.z.abs() + slope * e + read + moved;
        let eps =
            Vec4::splat(256.0 * f32::EPSILON) * (Vec4::splat(base) + t.quad(&t.mag, j) + tx.abs() + ty.abs() + spread);
        let lit = ((t.quad(&t.low, j) + tx) + ty) - Vec4::splat(r.z + read + up) - spread;
        // The plain min/max test: every tap's reference against the blocks' least and greatest
        // depth (exact for a flat reference, a few ulps of margin otherwise).
        let (r_lo, r_hi) = if r.is_flat() {
            (r.z, r.z)
        } else {
            let margin = 4.0 * f32::EPSILON * (r.z.abs() + 1.0);
            let across = slope * radius;
            (r.z - across - down - margin, r.z + across + up + margin)
        };
        let lit = lit.cmpge(eps) | Vec4::splat(r_hi).cmple(t.quad(&t.min, j));
        let shadowed = (((t.quad(&t.high, j) + tx) + ty) - Vec4::splat(r.z - read - down) + spread).cmplt(-eps)
            | Vec4::splat(r_lo).cmpgt(t.quad(&t.max, j));
        if (lit | idle).all() {
            Class::Lit
        } else if (shadowed | idle).all() {
            Class::Shadowed
        } else {
            Class::Mixed
        }
    }
}

/// The finest level: blocks of [`FINEST`] texels, a least-squares plane through each and the
/// residuals of its texels (a flat block where that is tighter). Rows of blocks in parallel.
fn finest(p: &Pipeline, map: &Surface<f32>) -> Level {
    let (w, h) = (map.width(), map.height());
    let b = FINEST;
    let (nw, nh) = (w.div_ceil(b), h.div_ceil(b));
    let d = map.data();
    let mut blocks = vec![Block::UNKNOWN; (nw * nh) as usize];
    p.install(|| {
        blocks.par_chunks_mut(nw as usize).enumerate().for_each(|(by, row)| {
            let by = by as u32;
            let (y0, y1) = (by * b, ((by + 1) * b).min(h));
            for (bx, out) in row.iter_mut().enumerate() {
                let bx = bx as u32;
                let (x0, x1) = (bx * b, ((bx + 1) * b).min(w));
                *out = if x1 - x0 == 8 && y1 - y0 == 8 {
                    full8(std::array::from_fn(|j| {
                        let i = ((y0 + j as u32) * w + x0) as usize;
                        (Vec4::from_slice(&d[i..i + 4]), Vec4::from_slice(&d[i + 4..i + 8]))
                    }))
                } else {
                    partial(d, w, (x0, x1), (y0, y1))
                };
            }
        })
    });
    Level::new(p, b, (nw, nh), blocks)
}

/// A block of the finest level at the map's last row or column (fewer than 8x8 texels):
/// [`full8`]'s plane and residuals, one texel at a time.
fn partial(d: &[f32], w: u32, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> Block {
    let mx = 0.5 * (x0 + x1) as f32;
    let my = 0.5 * (y0 + y1) as f32;
    let texels = || {
        (y0..y1).flat_map(move |y| {
            (x0..x1).map(move |x| (x as f32 + 0.5 - mx, y as f32 + 0.5 - my, d[(y * w + x) as usize]))
        })
    };
    let (mut sum, mut sx, mut sy, mut xx, mut yy) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
    for (dx, dy, v) in texels() {
        sum += v;
        sx += v * dx;
        sy += v * dy;
        xx += dx * dx;
        yy += dy * dy;
        min = min.min(v);
        max = max.max(v);
    }
    let n = ((x1 - x0) * (y1 - y0)) as f32;
    let g = Vec2::new(
        if xx > 0.0 { sx / xx } else { 0.0 },
        if yy > 0.0 { sy / yy } else { 0.0 },
    );
    let c = sum / n;
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (dx, dy, v) in texels() {
        let res = v - (c + g.x * dx + g.y * dy);
        lo = lo.min(res);
        hi = hi.max(res);
    }
    if !sum.is_finite() {
        return Block::UNKNOWN;
    }
    Block::new(c, g, (lo, hi), (min, max))
}

/// A full block of 8x8 texels (rows `r`, each as its left and right four) on four lanes:
/// [`partial`]'s least-squares plane (the texel centres' offsets from the block's centre are
/// -3.5 ..= 3.5 along each axis, their squares summing to 42 per row and column, 336 over the
/// block) and residuals.
#[inline(always)]
fn full8(r: [(Vec4, Vec4); 8]) -> Block {
    const L: Vec4 = Vec4::new(-3.5, -2.5, -1.5, -0.5);
    const R: Vec4 = Vec4::new(0.5, 1.5, 2.5, 3.5);
    let dy = |j: usize| j as f32 - 3.5;
    let (mut sum, mut sx, mut sy) = (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO);
    let (mut min, mut max) = (Vec4::splat(f32::INFINITY), Vec4::splat(f32::NEG_INFINITY));
    for (j, &(a, b)) in r.iter().enumerate() {
        let row = a + b;
        sum += row;
        sx += a * L + b * R;
        sy += row * dy(j);
        min = min.min(a.min(b));
        max = max.max(a.max(b));
    }
    let c = sum.element_sum() / 64.0;
    let g = Vec2::new(sx.element_sum() / 336.0, sy.element_sum() / 336.0);
    let (pl, pr) = (
        Vec4::splat(c) + Vec4::splat(g.x) * L,
        Vec4::splat(c) + Vec4::splat(g.x) * R,
    );
    let (mut lo, mut hi) = (Vec4::splat(f32::INFINITY), Vec4::splat(f32::NEG_INFINITY));
    for (j, &(a, b)) in r.iter().enumerate() {
        let up = Vec4::splat(g.y * dy(j));
        let (ra, rb) = (a - (pl + up), b - (pr + up));
        lo = lo.min(ra.min(rb));
        hi = hi.max(ra.max(rb));
    }
    if !sum.is_finite() {
        return Block::UNKNOWN;
    }
    Block::new(
        c,
        g,
        (lo.min_element(), hi.max_element()),
        (min.min_element(), max.max_element()),
    )
}

/// A block of [`coarser`] whose four children are whole blocks of `cb` texels (row-major:
/// left, right, then the next row): the same plane and bounds with the children on four
/// lanes (their centres lie `cb / 2` from the block's along each axis).
#[inline(always)]
fn full_kids(k: [Block; 4], cb: f32) -> Block {
    let c4 = Vec4::from_array(k.map(|k| k.c));
    let (gx4, gy4) = (Vec4::from_array(k.map(|k| k.g.x)), Vec4::from_array(k.map(|k| k.g.y)));
    let (lo4, hi4) = (Vec4::from_array(k.map(|k| k.lo)), Vec4::from_array(k.map(|k| k.hi)));
    if !(lo4.is_finite() && hi4.is_finite()) {
        return Block::UNKNOWN;
    }
    let gx = 0.5 * ((c4.y - c4.x) + (c4.w - c4.z)) / cb;
    let gy = 0.5 * ((c4.z - c4.x) + (c4.w - c4.y)) / cb;
    let c = c4.element_sum() / 4.0;
    let h2 = 0.5 * cb;
    let (dx, dy) = (Vec4::new(-h2, h2, -h2, h2), Vec4::new(-h2, -h2, h2, h2));
    // The children's texel centres lie within (cb - 1) / 2 of their centres.
    let kh = Vec4::splat(0.5 * (cb - 1.0));
    let off = c4 - (Vec4::splat(c) + Vec4::splat(gx) * dx + Vec4::splat(gy) * dy);
    let spread = ((gx4 - Vec4::splat(gx)).abs() + (gy4 - Vec4::splat(gy)).abs()) * kh;
    let min = k[0].min.min(k[1].min).min(k[2].min.min(k[3].min));
    let max = k[0].max.max(k[1].max).max(k[2].max.max(k[3].max));
    Block::new(
        c,
        Vec2::new(gx, gy),
        ((lo4 + off - spread).min_element(), (hi4 + off + spread).max_element()),
        (min, max),
    )
}

/// The level above `below`: blocks of 2x2 of its blocks, each a plane through the children's
/// centre values and the children's bounds carried over (a flat block where that is tighter).
/// Rows of blocks in parallel.
fn coarser(p: &Pipeline, below: &Level, (w, h): (u32, u32)) -> Level {
    let (cb, b) = (below.block, below.block * 2);
    let (nw, nh) = (below.width.div_ceil(2), below.height.div_ceil(2));
    // A block's centre and half-size (of its texel centres' span) along one axis.
    let axis = |i: u32, block: u32, n: u32| {
        let (a, z) = span(i, block, n);
        (0.5 * (a + z), 0.5 * (z - a))
    };
    let mut blocks = vec![Block::UNKNOWN; (nw * nh) as usize];
    p.install(|| {
        blocks.par_chunks_mut(nw as usize).enumerate().for_each(|(by, row)| {
            let by = by as u32;
            let ys = 2 * by..(2 * by + 2).min(below.height);
            let my = axis(by, b, h).0;
            for (bx, out) in row.iter_mut().enumerate() {
                let bx = bx as u32;
                let xs = 2 * bx..(2 * bx + 2).min(below.width);
                if (bx + 1) * b <= w && (by + 1) * b <= h {
                    let j = (2 * by * below.width + 2 * bx) as usize;
                    let (r0, r1) = (&below.blocks[j..j + 2], &below.blocks[j + below.width as usize..][..2]);
                    *out = full_kids([r0[0], r0[1], r1[0], r1[1]], cb as f32);
                    continue;
                }
                let m = Vec2::new(axis(bx, b, w).0, my);
                // The children that exist (the last row and column may have one), with their
                // centres and half-sizes.
                let mut kids = [(Block::UNKNOWN, Vec2::ZERO, Vec2::ZERO); 4];
                let mut n = 0;
                for y in ys.clone() {
                    for x in xs.clone() {
                        let ((kx, hx), (ky, hy)) = (axis(x, cb, w), axis(y, cb, h));
                        kids[n] = (*below.at(x, y), Vec2::new(kx, ky), Vec2::new(hx, hy));
                        n += 1;
                    }
                }
                let kids = &kids[..n];
                let (two_x, two_y) = (xs.len() == 2, ys.len() == 2);
                // Slopes from the children's centre values along rows and columns.
                let slope = |a: usize, z: usize, along: fn(Vec2) -> f32| {
                    (kids[z].0.c - kids[a].0.c) / (along(kids[z].1) - along(kids[a].1))
                };
                let (gx, gy) = match (two_x, two_y) {
                    (true, true) => (
                        0.5 * (slope(0, 1, |v| v.x) + slope(2, 3, |v| v.x)),
                        0.5 * (slope(0, 2, |v| v.y) + slope(1, 3, |v| v.y)),
                    ),
                    (true, false) => (slope(0, 1, |v| v.x), 0.0),
                    (false, true) => (0.0, slope(0, 1, |v| v.y)),
                    (false, false) => (0.0, 0.0),
                };
                let g = Vec2::new(gx, gy);
                let c = kids.iter().map(|k| k.0.c - g.dot(k.1 - m)).sum::<f32>() / n as f32;
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
                for &(k, km, kh) in kids {
                    // Over the child's box: P_child - P = offset +- spread.
                    let off = k.c - (c + g.dot(km - m));
                    let spread = ((k.g - g).abs() * kh).element_sum();
                    lo = lo.min(k.lo + off - spread);
                    hi = hi.max(k.hi + off + spread);
                    min = min.min(k.min);
                    max = max.max(k.max);
                }
                *out = Block::new(c, g, (lo, hi), (min, max));
            }
        })
    });
    Level::new(p, b, (nw, nh), blocks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash::SplitMix;

    /// Maps of several sizes (whole blocks or not): sloped planes (an orthographic ground),
    /// depths near 1 (a perspective one), steps (a caster's silhouette) and noise.
    fn maps() -> Vec<Surface<f32>> {
        let mut rng = SplitMix(41);
        let mut out = Vec::new();
        for (w, h) in [(64, 64), (37, 29), (100, 17), (8, 8), (5, 3)] {
            for kind in 0..4 {
                let (gx, gy) = (rng.next_f32() * 2e-3 - 1e-3, rng.next_f32() * 2e-3 - 1e-3);
                let data = (0..w * h)
                    .map(|i| {
                        let (x, y) = ((i % w) as f32, (i / w) as f32);
                        let plane = 0.5 + gx * x + gy * y;
                        match kind {
                            0 => plane,
                            1 => 0.9999 + 1e-7 * x - 2e-7 * y,
                            2 if (x - 20.0).powi(2) + (y - 12.0).powi(2) < 60.0 => 0.3,
                            2 => plane,
                            _ => rng.next_f32(),
                        }
                    })
                    .collect();
                out.push(Surface::from_vec(w, h, data).unwrap());
            }
        }
        out
    }

    #[test]
    fn every_block_bounds_its_texels() {
        let p = Pipeline::new(2).unwrap();
        for map in maps() {
            let chain = PlaneChain::new(&p, &map);
            let (w, h) = (map.width(), map.height());
            assert_eq!(chain.levels.last().map(|l| (l.width, l.height)), Some((1, 1)));
            for level in &chain.levels {
                for by in 0..level.height {
                    for bx in 0..level.width {
                        let k = level.at(bx, by);
                        let (xa, xb) = span(bx, level.block, w);
                        let (ya, yb) = span(by, level.block, h);
                        let m = (0.5 * (xa + xb) as f64, 0.5 * (ya + yb) as f64);
                        let tol = 64.0 * f32::EPSILON as f64 * (1.0 + k.c.abs() as f64);
                        for y in (ya - 0.5) as u32..=(yb - 0.5) as u32 {
                            for x in (xa - 0.5) as u32..=(xb - 0.5) as u32 {
                                let d = map.at(x, y);
                                assert!(k.min <= d && d <= k.max, "{w}x{h} block {bx},{by}: {d} outside min/max");
                                let plane = k.c as f64
                                    + k.g.x as f64 * (x as f64 + 0.5 - m.0)
                                    + k.g.y as f64 * (y as f64 + 0.5 - m.1);
                                let res = d as f64 - plane;
                                assert!(
                                    res >= k.lo as f64 - tol && res <= k.hi as f64 + tol,
                                    "{w}x{h} level {} block {bx},{by} texel {x},{y}: residual {res} outside {}..{}",
                                    level.block,
                                    k.lo,
                                    k.hi
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// Every tap of a classified kernel, read as the search (nearest texel) or the filters
    /// (the four texels of a bilinear tap) read it, passes (lit) or fails (shadowed) against
    /// its reference ([`Reference::at`]); and receivers on a plane of the map are classified.
    #[test]
    fn classified_kernels_agree_with_every_tap() {
        let p = Pipeline::new(2).unwrap();
        let mut rng = SplitMix(7);
        let mut classified = 0;
        for map in maps() {
            let chain = PlaneChain::new(&p, &map);
            let (w, h) = (map.width() as f32, map.height() as f32);
            for _ in 0..400 {
                let uv = Vec2::new(rng.next_f32(), rng.next_f32());
                let radius = rng.next_f32() * 6.0;
                let q = uv * Vec2::new(w, h);
                // The map's own depth and slope at the centre (a receiver on it), moved by a
                // bias toward or away from the light, or a random reference.
                let (tx, ty) = ((q.x as u32).min(map.width() - 1), (q.y as u32).min(map.height() - 1));
                let here = map.at(tx, ty);
                let gx = map.at((tx + 1).min(map.width() - 1), ty) - here;
                let gy = map.at(tx, (ty + 1).min(map.height() - 1)) - here;
                let bias = [1e-4, 1e-6, -1e-4, 0.0][(rng.next_u64() % 4) as usize];
                let r = match rng.next_u64() % 4 {
                    0 => Reference::flat(here - bias),
                    1 => Reference {
                        z: here - bias,
                        gradient: Vec2::new(gx, gy),
                        cone: 0.0,
                    },
                    2 => Reference {
                        z: here - bias,
                        gradient: Vec2::new(gx, gy),
                        cone: -rng.next_f32() * 1e-4,
                    },
                    _ => Reference::flat(rng.next_f32()),
                };
                for reach in [0.5, 1.0] {
                    let class = chain.classify(uv, radius, reach, &r);
                    if class == Class::Mixed {
                        continue;
                    }
                    classified += 1;
                    let n = 8;
                    for j in 0..=n {
                        for i in 0..=n {
                            let d = Vec2::new(i as f32, j as f32) / n as f32 * 2.0 * radius - Vec2::splat(radius);
                            let t = (uv + d / Vec2::new(w, h)) * Vec2::new(w, h);
                            let reads: Vec<f32> = if reach == 0.5 {
                                vec![map.at(t.x as u32, t.y as u32)]
                            } else {
                                let (x0, y0) = ((t.x - 0.5).floor(), (t.y - 0.5).floor());
                                [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                                    .iter()
                                    .map(|(a, b)| map.at((x0 + a) as u32, (y0 + b) as u32))
                                    .collect()
                            };
                            for depth in reads {
                                let passes = r.at(d) <= depth;
                                assert_eq!(
                                    passes,
                                    class == Class::Lit,
                                    "{class:?} tap {d} depth {depth} reference {}",
                                    r.at(d)
                                );
                            }
                        }
                    }
                }
            }
        }
        assert!(classified > 500, "only {classified} kernels classified");
    }
}
