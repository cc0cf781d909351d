//! "Compute" passes: plain Rust over surfaces, parallel over rows and deterministic (every
//! output element is computed by one fixed sequence of operations; partial results of
//! reductions are combined in row order).

use super::sampler::Filterable;
use super::surface::{MipChain, Surface};
use super::{Pipeline, PipelineError};
use crate::math;
use glam::{DVec4, Vec4};
use rayon::prelude::*;

/// Minimum and maximum of the finite texels accepted by `keep` (e.g. depth < 1 for "covered"),
/// or `None` if there is none. Used by SDSM and frustum fitting. Rows in parallel, each on
/// eight lanes (minima and maxima are exact, so neither the lanes nor the rows' order change
/// the result).
pub fn min_max(p: &Pipeline, s: &Surface<f32>, keep: impl Fn(f32) -> bool + Sync) -> Option<(f32, f32)> {
    let row_min_max = |row: &[f32]| {
        let (mut lo, mut hi) = ([f32::INFINITY; 8], [f32::NEG_INFINITY; 8]);
        let mut chunks = row.chunks_exact(8);
        let take = |l: usize, v: f32, lo: &mut [f32; 8], hi: &mut [f32; 8]| {
            let ok = v.is_finite() && keep(v);
            lo[l] = if ok && v < lo[l] { v } else { lo[l] };
            hi[l] = if ok && v > hi[l] { v } else { hi[l] };
        };
        for c in &mut chunks {
            for (l, &v) in c.iter().enumerate() {
                take(l, v, &mut lo, &mut hi);
            }
        }
        for &v in chunks.remainder() {
            take(0, v, &mut lo, &mut hi);
        }
        (
            lo.into_iter().fold(f32::INFINITY, f32::min),
            hi.into_iter().fold(f32::NEG_INFINITY, f32::max),
        )
    };
    let w = (s.width() as usize).max(1);
    let (lo, hi) = p.install(|| {
        s.data().par_chunks(w).map(row_min_max).reduce(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        )
    });
    // `+ 0.0`: a zero is +0 whatever the order the lanes met -0 and +0 in.
    (lo <= hi).then_some((lo + 0.0, hi + 0.0))
}

/// The least of `start` and the texels of `s` (NaN texels ignored, as [`f32::min`] does), with
/// zero returned as +0: rows in parallel, each row on eight lanes.
pub fn least(p: &Pipeline, s: &Surface<f32>, start: f32) -> f32 {
    // `v < m` is false for a NaN `v`, so each lane ignores NaNs; the minimum of numbers is
    // exact, so neither the lanes nor the rows' order change it (but for the sign of a zero,
    // which `+ 0.0` makes +0).
    let less = |m: f32, v: f32| if v < m { v } else { m };
    let row_least = |row: &[f32]| {
        let mut lanes = [start; 8];
        let mut chunks = row.chunks_exact(8);
        for c in &mut chunks {
            for (m, &v) in lanes.iter_mut().zip(c) {
                *m = less(*m, v);
            }
        }
        let tail = chunks.remainder().iter().fold(start, |m, &v| less(m, v));
        lanes.into_iter().fold(tail, less)
    };
    let w = (s.width() as usize).max(1);
    let m = p.install(|| s.data().par_chunks(w).map(row_least).reduce(|| start, less));
    m + 0.0
}

/// The min and max mip chains of a depth map (hierarchical min/max shadow maps, RTR 7.6):
/// each texel of level i+1 the minimum (maximum) of the up to 2x2 texels below it, an odd last
/// row or column folded into the previous texel. Rows in parallel; equal to
/// [`MipChain::build`] with [`super::surface::min_f32`] and [`super::surface::max_f32`]
/// without its level 0 (`base` itself is both chains' finest level; not copied).
pub fn min_max_chains(p: &Pipeline, base: &Surface<f32>) -> (MipChain<f32>, MipChain<f32>) {
    let mut mins: Vec<Surface<f32>> = Vec::new();
    let mut maxs: Vec<Surface<f32>> = Vec::new();
    loop {
        let (lo, hi) = (mins.last().unwrap_or(base), maxs.last().unwrap_or(base));
        let (w, h) = (lo.width(), lo.height());
        if w == 1 && h == 1 {
            break;
        }
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let rows: Vec<(Vec<f32>, Vec<f32>)> = p.install(|| {
            (0..nh)
                .into_par_iter()
                .map(|y| {
                    let y0 = 2 * y;
                    let y1 = if y == nh - 1 { h } else { (2 * y + 2).min(h) };
                    // Even sizes: each output texel is exactly the 2x2 below it (two rows read
                    // pairwise); otherwise the general fold with the last row and column.
                    if w % 2 == 0 && h % 2 == 0 {
                        let (wu, yu) = (w as usize, y0 as usize);
                        let (ld, hd) = (lo.data(), hi.data());
                        let (r0, r1) = (yu * wu..(yu + 1) * wu, (yu + 1) * wu..(yu + 2) * wu);
                        let (l0, l1, h0, h1) = (&ld[r0.clone()], &ld[r1.clone()], &hd[r0], &hd[r1]);
                        let a: Vec<f32> = l0
                            .chunks_exact(2)
                            .zip(l1.chunks_exact(2))
                            .map(|(p, q)| p[0].min(p[1]).min(q[0]).min(q[1]))
                            .collect();
                        let b: Vec<f32> = h0
                            .chunks_exact(2)
                            .zip(h1.chunks_exact(2))
                            .map(|(p, q)| p[0].max(p[1]).max(q[0]).max(q[1]))
                            .collect();
                        return (a, b);
                    }
                    (0..nw)
                        .map(|x| {
                            let x0 = 2 * x;
                            let x1 = if x == nw - 1 { w } else { (2 * x + 2).min(w) };
                            let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
                            for yy in y0..y1.max(y0 + 1) {
                                for xx in x0..x1.max(x0 + 1) {
                                    a = a.min(lo.at(xx.min(w - 1), yy.min(h - 1)));
                                    b = b.max(hi.at(xx.min(w - 1), yy.min(h - 1)));
                                }
                            }
                            (a, b)
                        })
                        .unzip()
                })
                .collect()
        });
        let (mut a, mut b) = (
            Vec::with_capacity((nw * nh) as usize),
            Vec::with_capacity((nw * nh) as usize),
        );
        for (ra, rb) in rows {
            a.extend(ra);
            b.extend(rb);
        }
        mins.push(Surface::from_vec_derived(nw, nh, a).expect("a level of a valid surface"));
        maxs.push(Surface::from_vec_derived(nw, nh, b).expect("a level of a valid surface"));
    }
    (MipChain::from_levels(mins), MipChain::from_levels(maxs))
}

/// Histogram of the finite texels in `[lo, hi)` over `bins` equal bins (values outside are not
/// counted): [`histogram_of`] of the texels themselves. Errors on zero bins or an empty range.
pub fn histogram(p: &Pipeline, s: &Surface<f32>, bins: usize, lo: f32, hi: f32) -> Result<Vec<u64>, PipelineError> {
    histogram_of(p, s, bins, lo, hi, |v| v)
}

/// A histogram of `map` of the texels of `s`, four at a time (a depth linearised on the
/// fly, say: `map` takes and gives four lanes, so its divide is one SIMD divide): the finite
/// mapped values in `[lo, hi)` over `bins` equal bins, the bin
/// `floor((v - lo) * (bins / (hi - lo)))` in `f32` (clamped to the last). Bands of rows in
/// parallel, each counting into four interleaved sub-histograms (so that runs of equal bins
/// do not wait on one counter), summed in band order. Errors on zero bins or an empty or
/// non-finite range.
pub fn histogram_of(
    p: &Pipeline,
    s: &Surface<f32>,
    bins: usize,
    lo: f32,
    hi: f32,
    map: impl Fn(Vec4) -> Vec4 + Sync,
) -> Result<Vec<u64>, PipelineError> {
    if bins == 0 || bins > 1 << 24 || hi <= lo || !lo.is_finite() || !hi.is_finite() {
        return Err(PipelineError::BadArgument(format!(
            "histogram of {bins} bins over [{lo}, {hi}) is invalid"
        )));
    }
    let w = s.width() as usize;
    let (lo4, hi4) = (Vec4::splat(lo), Vec4::splat(hi));
    let scale = Vec4::splat(bins as f32 / (hi - lo));
    let last = Vec4::splat((bins - 1) as f32);
    // Four sub-histograms, each with a slot at `bins` for values not counted.
    let stride = bins + 1;
    let count = move |h: &mut [u32], v: Vec4| {
        // Lanes outside [lo, hi) (NaN too) go to the discard slot.
        let ok = v.cmpge(lo4) & v.cmplt(hi4);
        let t = Vec4::select(ok, ((v - lo4) * scale).min(last), Vec4::splat(bins as f32));
        // Every lane is now in [0, bins]: a truncating integer conversion of four lanes.
        let i = t.as_ivec4();
        h[i.x as usize] += 1;
        h[stride + i.y as usize] += 1;
        h[2 * stride + i.z as usize] += 1;
        h[3 * stride + i.w as usize] += 1;
    };
    let parts: Vec<Vec<u32>> = p.install(|| {
        s.data()
            .par_chunks((w * 16).max(1))
            .map(|rows| {
                let mut h = vec![0u32; stride * 4];
                let mut chunks = rows.chunks_exact(4);
                for c in &mut chunks {
                    count(&mut h, map(Vec4::from_slice(c)));
                }
                // The last texels in the first lanes; the unused lanes are NaN, not counted.
                let r = chunks.remainder();
                if !r.is_empty() {
                    let mut t = [f32::NAN; 4];
                    t[..r.len()].copy_from_slice(r);
                    let v = map(Vec4::from_array(t));
                    let keep = Vec4::select(
                        glam::BVec4A::from_array([true, r.len() > 1, r.len() > 2, false]),
                        v,
                        Vec4::NAN,
                    );
                    count(&mut h, keep);
                }
                (0..bins)
                    .map(|i| h[i] + h[stride + i] + h[2 * stride + i] + h[3 * stride + i])
                    .collect()
            })
            .collect()
    });
    let mut out = vec![0u64; bins];
    for h in parts {
        for (o, v) in out.iter_mut().zip(h) {
            *o += v as u64;
        }
    }
    Ok(out)
}

/// Summed-area table (Crow 1984; RTR 7.7 for VSM): `sat(x, y)` = sum of all texels with
/// coordinates `<= (x, y)`, accumulated in `f64` so large maps keep their precision. Each
/// entry is its row's prefix sum (left to right) plus the entry above (top to bottom), for
/// any thread count: rows in parallel, then strips of columns in parallel.
pub fn summed_area_table(p: &Pipeline, s: &Surface<Vec4>) -> Surface<DVec4> {
    let (w, h) = (s.width() as usize, s.height() as usize);
    let mut out = vec![DVec4::ZERO; w * h];
    p.install(|| {
        // Row prefix sums (parallel over rows).
        out.par_chunks_mut(w).zip(s.data().par_chunks(w)).for_each(|(o, i)| {
            let mut acc = DVec4::ZERO;
            for (o, v) in o.iter_mut().zip(i) {
                acc += v.as_dvec4();
                *o = acc;
            }
        });
    });
    column_prefix_sums(p, &mut out, w);
    Surface::from_vec_derived(s.width(), s.height(), out).expect("same size as input")
}

/// Columns of a strip of [`column_prefix_sums`].
const PREFIX_STRIP: usize = 128;

/// Adds to each entry of the row-major `data` (rows `w` long) the entry above it, top to
/// bottom: the column pass of a summed-area table. Strips of columns run in parallel, each
/// walking its rows in order, so every entry takes the same additions for any thread count.
fn column_prefix_sums<T: Copy + Send + std::ops::AddAssign>(p: &Pipeline, data: &mut [T], w: usize) {
    if w == 0 {
        return;
    }
    // Per strip, its piece of every row.
    let strips = w.div_ceil(PREFIX_STRIP);
    let mut pieces: Vec<Vec<&mut [T]>> = (0..strips).map(|_| Vec::with_capacity(data.len() / w)).collect();
    for row in data.chunks_mut(w) {
        for (k, piece) in row.chunks_mut(PREFIX_STRIP).enumerate() {
            pieces[k].push(piece);
        }
    }
    p.install(|| {
        pieces.par_iter_mut().for_each(|rows| {
            for y in 1..rows.len() {
                let (above, below) = rows.split_at_mut(y);
                for (c, a) in below[0].iter_mut().zip(above[y - 1].iter()) {
                    *c += *a;
                }
            }
        })
    });
}

/// Sum over the inclusive texel rectangle `[x0, x1] x [y0, y1]` (clamped to the surface) from a
/// summed-area table.
pub fn sat_box(sat: &Surface<DVec4>, x0: i64, y0: i64, x1: i64, y1: i64) -> DVec4 {
    let (w, h) = (sat.width() as i64, sat.height() as i64);
    let (x0, x1) = (x0.clamp(0, w - 1), x1.clamp(0, w - 1));
    let (y0, y1) = (y0.clamp(0, h - 1), y1.clamp(0, h - 1));
    let g = |x: i64, y: i64| {
        if x < 0 || y < 0 {
            DVec4::ZERO
        } else {
            sat.at(x as u32, y as u32)
        }
    };
    g(x1, y1) - g(x0 - 1, y1) - g(x1, y0 - 1) + g(x0 - 1, y0 - 1)
}

/// Normalized Gaussian weights for a kernel of `radius` taps each side (`sigma = radius / 2`);
/// radius 0 is the identity.
pub fn gaussian_weights(radius: usize) -> Vec<f32> {
    if radius == 0 {
        return vec![1.0];
    }
    let sigma = radius as f64 / 2.0;
    let w: Vec<f64> = (-(radius as i64)..=radius as i64)
        .map(|i| math::exp_f64(-(i * i) as f64 / (2.0 * sigma * sigma)))
        .collect();
    let sum: f64 = w.iter().sum();
    w.iter().map(|v| (v / sum) as f32).collect()
}

/// Separable blur with an odd-length kernel (`weights.len() = 2r + 1`), edges clamped:
/// horizontal pass then vertical pass. Each output is `sum_k w_k v_k` accumulated in kernel
/// order (`acc * 1 + v_k * w_k` from zero), the same operations for any thread count; the
/// rows are read through an edge-padded copy and the columns a whole row at a time, so no
/// tap clamps its index. [`separable_blur_rows`] with the surface's rows as the source.
pub fn separable_blur<T: Filterable + Default>(
    p: &Pipeline,
    s: &Surface<T>,
    weights: &[f32],
) -> Result<Surface<T>, PipelineError> {
    let mut out = Surface::new(s.width(), s.height(), T::default())?;
    separable_blur_rows(p, &mut out, weights, |y, row| row.copy_from_slice(s.row(y)))?;
    Ok(out)
}

/// Rows of output a band of [`separable_blur_rows`] computes from one horizontal pass over
/// its rows and `2r` neighbours (the band's horizontal results stay in cache for the
/// vertical pass instead of going through memory).
const BLUR_BAND: usize = 32;

/// [`separable_blur`] into `out`, whose source row `y` is written by `source(y, row)` (so a
/// source computed per texel, such as the moments of a depth map, is never stored whole).
/// The image is cut into bands of rows, each band blurred horizontally over its rows and the
/// `r` rows each side it needs, then vertically; every output texel takes the same operations
/// in the same order whatever the band or thread, so the result is that of the two whole
/// passes bit for bit. `source` may be called for a row more than once (by neighbouring
/// bands) and must give the same row each time.
pub fn separable_blur_rows<T: Filterable + Default>(
    p: &Pipeline,
    out: &mut Surface<T>,
    weights: &[f32],
    source: impl Fn(u32, &mut [T]) + Sync,
) -> Result<(), PipelineError> {
    if weights.len().is_multiple_of(2) {
        return Err(PipelineError::BadArgument(format!(
            "blur kernel length {} must be odd",
            weights.len()
        )));
    }
    let r = weights.len() / 2;
    let (w, h) = (out.width() as usize, out.height() as usize);
    let zero = T::mix(T::default(), 0.0, T::default(), 0.0);
    p.install(|| {
        out.data_mut()
            .par_chunks_mut(w * BLUR_BAND)
            .enumerate()
            .for_each(|(b, band)| {
                let y0 = b * BLUR_BAND;
                let rows = band.len() / w;
                // The horizontal pass over the rows this band's outputs read (clamped).
                let lo = y0.saturating_sub(r);
                let hi = (y0 + rows - 1 + r).min(h - 1);
                let mut tmp = vec![T::default(); (hi - lo + 1) * w];
                // A row with r copies of each edge texel on its side.
                let mut pad = vec![T::default(); w + 2 * r];
                for (yy, row) in (lo..=hi).zip(tmp.chunks_mut(w)) {
                    source(yy as u32, &mut pad[r..r + w]);
                    let (first, last) = (pad[r], pad[r + w - 1]);
                    pad[..r].fill(first);
                    pad[r + w..].fill(last);
                    for (x, o) in row.iter_mut().enumerate() {
                        let mut acc = zero;
                        for (k, &wk) in weights.iter().enumerate() {
                            acc = T::mix(acc, 1.0, pad[x + k], wk);
                        }
                        *o = acc;
                    }
                }
                for (i, row) in band.chunks_mut(w).enumerate() {
                    let y = y0 + i;
                    row.fill(zero);
                    for (k, &wk) in weights.iter().enumerate() {
                        let yy = (y as i64 + k as i64 - r as i64).clamp(0, h as i64 - 1) as usize - lo;
                        for (o, &v) in row.iter_mut().zip(&tmp[yy * w..(yy + 1) * w]) {
                            *o = T::mix(*o, 1.0, v, wk);
                        }
                    }
                }
            });
    });
    Ok(())
}

/// Normalized box weights for a kernel of `radius` taps each side (all `1 / (2r + 1)`).
pub fn box_weights(radius: usize) -> Vec<f32> {
    vec![1.0 / (2 * radius + 1) as f32; 2 * radius + 1]
}

/// Summed-area table accumulated in `f32`, with no care for precision (running sums of
/// rows, then of columns, each in one `f32`): what a naive GPU implementation stores, kept to
/// show what [`summed_area_table`]'s `f64` sums avoid (Lauritzen 2007: at 4096² the sums of
/// depths near 1 reach 1.6e7, where an `f32` step is 1 and the box differences of a few
/// texels lose every digit). The values are returned widened to `f64`, bit for bit those of
/// the `f32` sums, so one box lookup ([`sat_box`]) serves both.
pub fn summed_area_table_f32(p: &Pipeline, s: &Surface<Vec4>) -> Surface<DVec4> {
    let (w, h) = (s.width() as usize, s.height() as usize);
    let mut out = vec![Vec4::ZERO; w * h];
    p.install(|| {
        out.par_chunks_mut(w).zip(s.data().par_chunks(w)).for_each(|(o, i)| {
            let mut acc = Vec4::ZERO;
            for (o, v) in o.iter_mut().zip(i) {
                acc += *v;
                *o = acc;
            }
        });
    });
    column_prefix_sums(p, &mut out, w);
    let wide = out.into_iter().map(|v| v.as_dvec4()).collect();
    Surface::from_vec_derived(s.width(), s.height(), wide).expect("same size as input")
}

/// `ln(wa e^a + wb e^b)` without overflow (either weight may be zero; `-inf` is the log of
/// zero): the one operation of log-space filtering.
#[inline(always)]
pub fn log_mix(a: f32, wa: f32, b: f32, wb: f32) -> f32 {
    let m = a.max(b);
    if m == f32::NEG_INFINITY {
        return m;
    }
    let sa = if wa > 0.0 { wa * math::exp(a - m) } else { 0.0 };
    let sb = if wb > 0.0 { wb * math::exp(b - m) } else { 0.0 };
    m + math::ln(sa + sb)
}

/// `ln(sum_i w_i e^(v_i))` of one kernel's values `v` and weights `w` (largest value taken
/// out first, so nothing overflows; Salvi 2008's log-space filtering of ESM).
#[inline(always)]
pub fn log_sum(v: &[f32], w: &[f32]) -> f32 {
    let m = v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    if m == f32::NEG_INFINITY {
        return m;
    }
    let s: f32 = v.iter().zip(w).map(|(&v, &w)| w * math::exp(v - m)).sum();
    m + math::ln(s)
}

/// Separable blur in log space (Salvi 2008): each output is `ln(sum w_k e^(v_k))` of its
/// kernel's texels, rows then columns, edges clamped. Values are logarithms (`c z` of an
/// exponential shadow map), so the exponentials are never formed and cannot overflow.
pub fn log_space_blur(p: &Pipeline, s: &Surface<f32>, weights: &[f32]) -> Result<Surface<f32>, PipelineError> {
    if weights.len().is_multiple_of(2) {
        return Err(PipelineError::BadArgument(format!(
            "blur kernel length {} must be odd",
            weights.len()
        )));
    }
    let r = (weights.len() / 2) as i64;
    let (w, h) = (s.width() as usize, s.height() as usize);
    let mut tmp = vec![0.0f32; w * h];
    let mut out = vec![0.0f32; w * h];
    p.install(|| {
        tmp.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            let src = s.row(y as u32);
            let mut v = vec![0.0f32; weights.len()];
            for (x, o) in row.iter_mut().enumerate() {
                for (k, t) in v.iter_mut().enumerate() {
                    *t = src[(x as i64 + k as i64 - r).clamp(0, w as i64 - 1) as usize];
                }
                *o = log_sum(&v, weights);
            }
        });
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            let mut v = vec![0.0f32; weights.len()];
            for (x, o) in row.iter_mut().enumerate() {
                for (k, t) in v.iter_mut().enumerate() {
                    let yy = (y as i64 + k as i64 - r).clamp(0, h as i64 - 1) as usize;
                    *t = tmp[yy * w + x];
                }
                *o = log_sum(&v, weights);
            }
        });
    });
    Surface::from_vec(s.width(), s.height(), out)
}

/// Writes to distinct elements of a slice from many threads: the scatter of a parallel
/// counting sort, where a prefix sum has given every element exactly one writer.
///
/// Safety argument: a `Scatter` borrows its slice mutably for its whole life, so nothing
/// else reads or writes the slice meanwhile. Its methods are `unsafe` with one contract:
/// while the `Scatter` lives, no two calls touch the same element unless both are reads. With
/// that, threads sharing the `Scatter` touch disjoint elements, exactly as if each held a
/// `&mut` to its own elements, so the writes are race-free. Every index is checked against the
/// slice's length (an out-of-range index panics instead of writing outside the slice), and
/// `T: Copy` means no element is dropped by an overwrite.
pub struct Scatter<'a, T> {
    ptr: *mut T,
    len: usize,
    _slice: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: writes go to distinct elements (the contract of `write` and `read`), so sharing the
// pointer between threads is like handing each thread its own elements; `T: Send` because
// values written by one thread may be read by the thread that owns the slice afterwards.
unsafe impl<T: Send> Sync for Scatter<'_, T> {}

impl<'a, T: Copy> Scatter<'a, T> {
    /// A scatter into `s` (borrowed mutably while the scatter lives).
    pub fn new(s: &'a mut [T]) -> Self {
        Scatter {
            ptr: s.as_mut_ptr(),
            len: s.len(),
            _slice: std::marker::PhantomData,
        }
    }

    /// Writes element `i` (checked against the length).
    ///
    /// # Safety
    /// No other call may touch element `i` while this `Scatter` lives, except reads that
    /// happen after this write on the same thread.
    #[inline(always)]
    pub unsafe fn write(&self, i: usize, v: T) {
        assert!(i < self.len, "scatter index {i} beyond {}", self.len);
        // SAFETY: in bounds (checked), and the caller guarantees no concurrent access to `i`.
        unsafe { self.ptr.add(i).write(v) }
    }

    /// Reads element `i` (checked against the length).
    ///
    /// # Safety
    /// No other thread may write element `i` while this `Scatter` lives.
    #[inline(always)]
    pub unsafe fn read(&self, i: usize) -> T {
        assert!(i < self.len, "scatter index {i} beyond {}", self.len);
        // SAFETY: in bounds (checked), and the caller guarantees no concurrent write to `i`.
        unsafe { self.ptr.add(i).read() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_max_and_histogram_of_equal_their_plain_loops() {
        // Odd widths (lane remainders), NaN, infinities, -0 and values the filter rejects.
        let mut x = 12345u32;
        let mut next = || {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (x >> 8) as f32 / (1u32 << 24) as f32
        };
        for (w, h) in [(13u32, 7u32), (64, 3), (1, 9), (3, 1)] {
            let mut data: Vec<f32> = (0..w * h).map(|_| next() * 1.2).collect();
            data[0] = f32::NAN;
            if data.len() > 3 {
                data[1] = f32::INFINITY;
                data[2] = -0.0;
            }
            let s = Surface::from_vec(w, h, data.clone()).unwrap();
            let kept: Vec<f32> = data.iter().copied().filter(|v| v.is_finite() && *v < 1.0).collect();
            let want = kept.iter().fold(None, |a: Option<(f32, f32)>, &v| {
                Some(a.map_or((v, v), |(l, h)| (l.min(v), h.max(v))))
            });
            for threads in [1, 2, 4] {
                let p = Pipeline::new(threads).unwrap();
                let got = min_max(&p, &s, |v| v < 1.0);
                assert_eq!(
                    got.map(|(a, b)| (a + 0.0, b + 0.0)),
                    want.map(|(a, b)| (a + 0.0, b + 0.0))
                );
                let hist = histogram_of(&p, &s, 10, 0.1, 0.9, |v| v).unwrap();
                let mut plain = vec![0u64; 10];
                for &v in &data {
                    if (0.1..0.9).contains(&v) {
                        plain[(((v - 0.1) * (10.0 / 0.8f32)).min(9.0)) as usize] += 1;
                    }
                }
                assert_eq!(hist, plain, "{w}x{h}, {threads} threads");
            }
        }
        let p = Pipeline::new(2).unwrap();
        let empty = Surface::from_vec(2, 1, vec![f32::NAN, 2.0]).unwrap();
        assert_eq!(min_max(&p, &empty, |v| v < 1.0), None);
        assert!(histogram_of(&p, &empty, 0, 0.0, 1.0, |v| v).is_err());
    }

    #[test]
    fn sat_box_equals_direct_sum() {
        let p = Pipeline::new(2).unwrap();
        let data: Vec<Vec4> = (0..35).map(|i| Vec4::splat(i as f32)).collect();
        let s = Surface::from_vec(7, 5, data).unwrap();
        let sat = summed_area_table(&p, &s);
        let direct: f32 = (1..=3).flat_map(|y| (2..=5).map(move |x| (y * 7 + x) as f32)).sum();
        assert_eq!(sat_box(&sat, 2, 1, 5, 3).x, direct as f64);
    }

    /// Both summed-area tables are the serial sums (each row left to right, then each
    /// column top to bottom), bit for bit, for any thread count and widths that are not
    /// multiples of the column strips.
    #[test]
    fn summed_area_tables_are_the_serial_sums_for_any_thread_count() {
        let mut rng = crate::hash::SplitMix(41);
        for (w, h) in [(1, 1), (300, 7), (129, 130), (7, 300)] {
            let data: Vec<Vec4> = (0..w * h)
                .map(|_| Vec4::new(rng.next_f32(), rng.next_f32(), 0.5, rng.next_f32() * 100.0))
                .collect();
            let s = Surface::from_vec(w, h, data.clone()).unwrap();
            let (w, h) = (w as usize, h as usize);
            let (mut wide, mut narrow) = (vec![DVec4::ZERO; w * h], vec![Vec4::ZERO; w * h]);
            for y in 0..h {
                let (mut a, mut b) = (DVec4::ZERO, Vec4::ZERO);
                for x in 0..w {
                    a += data[y * w + x].as_dvec4();
                    b += data[y * w + x];
                    wide[y * w + x] = a + if y > 0 { wide[(y - 1) * w + x] } else { DVec4::ZERO };
                    narrow[y * w + x] = b + if y > 0 { narrow[(y - 1) * w + x] } else { Vec4::ZERO };
                }
            }
            let narrow: Vec<DVec4> = narrow.iter().map(|v| v.as_dvec4()).collect();
            for t in [1, 2, 4] {
                let p = Pipeline::new(t).unwrap();
                assert!(summed_area_table(&p, &s).data() == wide, "f64 {w}x{h}, {t} threads");
                assert!(
                    summed_area_table_f32(&p, &s).data() == narrow,
                    "f32 {w}x{h}, {t} threads"
                );
            }
        }
    }

    #[test]
    fn min_max_chains_equal_the_sequential_chains_for_any_thread_count() {
        use crate::pipeline::surface::{max_f32, min_f32};
        let mut rng = crate::hash::SplitMix(9);
        for (w, h) in [(37, 20), (64, 64), (1, 9)] {
            let data: Vec<f32> = (0..w * h).map(|_| rng.next_f32()).collect();
            let s = Surface::from_vec(w, h, data).unwrap();
            let (lo, hi) = (MipChain::build(s.clone(), min_f32), MipChain::build(s.clone(), max_f32));
            for t in [1, 2, 4] {
                let (a, b) = min_max_chains(&Pipeline::new(t).unwrap(), &s);
                assert!(
                    a.levels() == &lo.levels()[1..] && b.levels() == &hi.levels()[1..],
                    "{w}x{h}, {t} threads"
                );
            }
        }
    }

    /// The parallel least texel is the serial `f32::min` fold's for any thread count, with
    /// NaNs anywhere (in a lane, in a row's tail), a start below every texel and widths that
    /// are not multiples of eight.
    #[test]
    fn least_equals_the_serial_fold_for_any_thread_count() {
        let mut rng = crate::hash::SplitMix(3);
        for (w, h) in [(37, 20), (64, 64), (1, 9), (8, 1), (2048, 3)] {
            let mut data: Vec<f32> = (0..w * h).map(|_| 0.2 + rng.next_f32()).collect();
            for i in (0..data.len()).step_by(7) {
                data[i] = f32::NAN;
            }
            let s = Surface::from_vec(w, h, data.clone()).unwrap();
            for start in [1.0, 0.1] {
                let serial = data.iter().copied().fold(start, f32::min);
                for t in [1, 2, 4] {
                    let got = least(&Pipeline::new(t).unwrap(), &s, start);
                    assert_eq!(got.to_bits(), serial.to_bits(), "{w}x{h}, start {start}, {t} threads");
                }
            }
        }
        // Zero comes back as +0 whatever its sign.
        let z = Surface::from_vec(2, 1, vec![-0.0f32, 0.0]).unwrap();
        assert_eq!(least(&Pipeline::new(2).unwrap(), &z, 1.0).to_bits(), 0.0f32.to_bits());
    }

    #[test]
    fn min_max_histogram_blur() {
        let p = Pipeline::new(2).unwrap();
        let s = Surface::from_vec(3, 2, vec![0.5f32, 0.1, 1.0, f32::NAN, 0.7, 0.3]).unwrap();
        assert_eq!(min_max(&p, &s, |v| v < 1.0), Some((0.1, 0.7)));
        assert_eq!(histogram(&p, &s, 2, 0.0, 1.0).unwrap(), vec![2, 2]);
        assert!(histogram(&p, &s, 0, 0.0, 1.0).is_err());
        let c = Surface::new(9, 9, 2.0f32).unwrap();
        let b = separable_blur(&p, &c, &gaussian_weights(3)).unwrap();
        assert!(b.data().iter().all(|v| (v - 2.0).abs() < 1e-5));
    }

    /// The banded blur is the two whole passes of its specification (clamped taps summed in
    /// kernel order), bit for bit, for any thread count, band boundary and kernel wider than
    /// the image; a source computed per row gives the same as the stored rows.
    #[test]
    fn the_banded_blur_is_the_two_whole_passes_bit_for_bit() {
        use glam::Vec2;
        let plain = |s: &Surface<Vec2>, wk: &[f32]| {
            let (w, h, r) = (s.width() as i64, s.height() as i64, wk.len() as i64 / 2);
            let at = |x: i64, y: i64| s.at(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32);
            let horizontal: Vec<Vec2> = (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .map(|(x, y)| (0..2 * r + 1).fold(Vec2::ZERO, |a, k| a + at(x + k - r, y) * wk[k as usize]))
                .collect();
            let hz = |x: i64, y: i64| horizontal[(y.clamp(0, h - 1) * w + x) as usize];
            (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .map(|(x, y)| (0..2 * r + 1).fold(Vec2::ZERO, |a, k| a + hz(x, y + k - r) * wk[k as usize]))
                .collect::<Vec<Vec2>>()
        };
        let mut rng = crate::hash::SplitMix(17);
        for (w, h, radius) in [(37, 70, 2), (64, 64, 4), (5, 3, 4), (1, 33, 1), (130, 97, 9)] {
            let depth: Vec<f32> = (0..w * h).map(|_| rng.next_f32()).collect();
            let moments: Vec<Vec2> = depth.iter().map(|&z| Vec2::new(z, z * z)).collect();
            let s = Surface::from_vec(w, h, moments).unwrap();
            for wk in [box_weights(radius), gaussian_weights(radius)] {
                let want = plain(&s, &wk);
                for t in [1, 2, 4] {
                    let p = Pipeline::new(t).unwrap();
                    let got = separable_blur(&p, &s, &wk).unwrap();
                    let mut rows = Surface::new(w, h, Vec2::ZERO).unwrap();
                    separable_blur_rows(&p, &mut rows, &wk, |y, row| {
                        for (o, &z) in row.iter_mut().zip(&depth[(y * w) as usize..]) {
                            *o = Vec2::new(z, z * z);
                        }
                    })
                    .unwrap();
                    for (i, v) in want.iter().enumerate() {
                        let (a, b) = (got.data()[i], rows.data()[i]);
                        assert!(
                            a.to_array().map(f32::to_bits) == v.to_array().map(f32::to_bits) && a == b,
                            "{w}x{h} r={radius}, {t} threads, texel {i}: {a} / {b} against {v}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn log_space_blur_is_the_log_of_the_blurred_exponentials() {
        // Small exponents, where the plain blur of e^v is exact enough to compare with.
        let mut rng = crate::hash::SplitMix(5);
        let data: Vec<f32> = (0..13 * 7).map(|_| 3.0 * rng.next_f32()).collect();
        let s = Surface::from_vec(13, 7, data).unwrap();
        let wts = gaussian_weights(2);
        let ex = s.map(math::exp);
        let want = separable_blur(&Pipeline::new(1).unwrap(), &ex, &wts).unwrap();
        for t in [1, 2, 4] {
            let got = log_space_blur(&Pipeline::new(t).unwrap(), &s, &wts).unwrap();
            for (g, w) in got.data().iter().zip(want.data()) {
                assert!((math::exp(*g) - w).abs() < 1e-4 * w, "{} vs {w}", math::exp(*g));
            }
        }
        // Values whose exponentials overflow f32 (e^200) filter without overflow.
        let big = Surface::new(5, 5, 200.0f32).unwrap();
        let b = log_space_blur(&Pipeline::new(2).unwrap(), &big, &box_weights(1)).unwrap();
        assert!(b.data().iter().all(|v| (v - 200.0).abs() < 1e-4), "{:?}", b.data());
        assert_eq!(log_mix(f32::NEG_INFINITY, 0.0, 2.0, 0.5), 2.0 + math::ln(0.5));
    }

    #[test]
    fn the_f32_summed_area_table_loses_what_the_f64_one_keeps() {
        // 4096 x 4096 depths near 1: a 3x3 box far from the origin.
        let p = Pipeline::new(2).unwrap();
        let n = 4096u32;
        let data: Vec<Vec4> = (0..n * n)
            .map(|i| Vec4::splat(0.9 + 0.05 * ((i % 7) as f32 / 7.0)))
            .collect();
        let s = Surface::from_vec(n, n, data).unwrap();
        let (x, y) = (4000i64, 4000i64);
        let direct: f64 = (y - 1..=y + 1)
            .flat_map(|yy| (x - 1..=x + 1).map(move |xx| (yy, xx)))
            .map(|(yy, xx)| s.at(xx as u32, yy as u32).x as f64)
            .sum();
        let wide = sat_box(&summed_area_table(&p, &s), x - 1, y - 1, x + 1, y + 1).x;
        let narrow = sat_box(&summed_area_table_f32(&p, &s), x - 1, y - 1, x + 1, y + 1).x;
        assert!((wide - direct).abs() < 1e-6 * direct, "f64: {wide} vs {direct}");
        assert!((narrow - direct).abs() > 0.5, "f32: {narrow} vs {direct}");
    }

    #[test]
    fn scatter_places_a_parallel_counting_sort_like_the_serial_one() {
        // Keys of 1000 items into 7 buckets, items cut into chunks: each chunk counts its
        // items per bucket, a prefix sum over (bucket, chunk) gives every chunk its own run in
        // each bucket, and the chunks scatter in parallel. The result is the stable serial
        // sort, for any thread count.
        let keys: Vec<usize> = (0..1000u64).map(|i| ((i * 2654435761) % 7) as usize).collect();
        let mut serial: Vec<u32> = (0..1000u32).collect();
        serial.sort_by_key(|&i| keys[i as usize]);
        let chunk = 64;
        let counts: Vec<[u32; 7]> = keys
            .chunks(chunk)
            .map(|c| {
                let mut h = [0u32; 7];
                c.iter().for_each(|&k| h[k] += 1);
                h
            })
            .collect();
        let mut starts = vec![[0u32; 7]; counts.len()];
        let mut at = 0;
        for b in 0..7 {
            for (c, h) in counts.iter().enumerate() {
                starts[c][b] = at;
                at += h[b];
            }
        }
        for threads in [1, 2, 4] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut out = vec![u32::MAX; keys.len()];
            let mut cursors = starts.clone();
            {
                let s = Scatter::new(&mut out);
                pool.install(|| {
                    keys.par_chunks(chunk)
                        .zip(cursors.par_iter_mut())
                        .enumerate()
                        .for_each(|(c, (ks, cur))| {
                            for (j, &k) in ks.iter().enumerate() {
                                // SAFETY: the prefix sum gives each (bucket, chunk) run its own
                                // positions, and this chunk alone advances its cursors.
                                unsafe { s.write(cur[k] as usize, (c * chunk + j) as u32) };
                                cur[k] += 1;
                            }
                        })
                });
                // Every element written once: reading back on this thread is allowed.
                // SAFETY: no other thread touches the slice now.
                assert_eq!(unsafe { s.read(0) }, serial[0]);
            }
            assert_eq!(out, serial, "{threads} threads");
        }
    }

    #[test]
    #[should_panic(expected = "scatter index 3 beyond 3")]
    fn scatter_refuses_an_index_outside_its_slice() {
        let mut v = [0u8; 3];
        let s = Scatter::new(&mut v);
        // SAFETY: one thread, one write (the index is out of range: it must panic, not write).
        unsafe { s.write(3, 1) };
    }
}
