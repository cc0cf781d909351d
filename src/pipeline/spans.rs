//! Stage 6 on one row span of a tile: the depth-only span (scalar and four pixels at a time)
//! and the stencil-counting span, the fast paths of shadow-map and shadow-volume passes.

use super::program::RawSurface;

/// Asks the memory system for every cache line of a tile's rows at once. Rows of a target lie
/// a whole row apart (usually in different pages), which defeats hardware prefetchers; issuing
/// all misses together overlaps their latency instead of paying it line by line.
#[inline(always)]
pub(crate) fn prefetch_rows<T>(s: &RawSurface<T>, rect: [i32; 4]) {
    #[cfg(target_arch = "x86_64")]
    {
        let bytes = (rect[2] - rect[0] + 1) as usize * std::mem::size_of::<T>();
        for y in rect[1]..=rect[3] {
            // SAFETY: addresses inside the target; prefetch never faults.
            let row = unsafe { s.ptr.add(y as usize * s.stride + rect[0] as usize) } as *const i8;
            let mut off = 0;
            while off < bytes {
                // SAFETY: a prefetch never faults, whatever the address.
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
pub(crate) fn stencil_span(
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
