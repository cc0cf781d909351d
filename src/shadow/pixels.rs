//! The per-pixel pass most techniques end with: a function of the pixel, run row by row on the
//! pipeline's workers (deterministic: each pixel's value depends on that pixel alone).

use crate::frame::Frame;
use crate::pipeline::Pipeline;
use rayon::prelude::*;

/// `f(x, y)` for every pixel of `frame`, row-major, rows in parallel on `p`'s workers.
pub fn per_pixel(p: &Pipeline, frame: &Frame, f: impl Fn(usize, usize) -> f32 + Sync) -> Vec<f32> {
    let w = frame.width() as usize;
    let mut out = vec![f32::NAN; w * frame.height() as usize];
    p.install(|| {
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                *o = f(x, y);
            }
        })
    });
    out
}

/// [`per_pixel`] for functions that also count their work: `f(x, y)` returns the value and a
/// count, and the counts' total comes back beside the values (summed per row, then over rows
/// in order: the same total for any thread count).
pub fn per_pixel_counted(
    p: &Pipeline,
    frame: &Frame,
    f: impl Fn(usize, usize) -> (f32, u64) + Sync,
) -> (Vec<f32>, u64) {
    let w = frame.width() as usize;
    let mut out = vec![f32::NAN; w * frame.height() as usize];
    let total = p.install(|| {
        out.par_chunks_mut(w)
            .enumerate()
            .map(|(y, row)| {
                let mut n = 0u64;
                for (x, o) in row.iter_mut().enumerate() {
                    let (v, c) = f(x, y);
                    *o = v;
                    n += c;
                }
                n
            })
            .sum::<u64>()
    });
    (out, total)
}

/// `f(x, y)` of any plain value for every pixel of `frame`, row-major, rows in parallel on
/// `p`'s workers (for passes that keep more than one value per pixel).
pub fn per_pixel_map<T: Copy + Default + Send>(
    p: &Pipeline,
    frame: &Frame,
    f: impl Fn(usize, usize) -> T + Sync,
) -> Vec<T> {
    let w = frame.width() as usize;
    let mut out = vec![T::default(); w * frame.height() as usize];
    p.install(|| {
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                *o = f(x, y);
            }
        })
    });
    out
}

/// [`per_pixel_counted`] a row at a time: `f(y, row)` writes every value of row `y` and
/// returns its count. Each pixel's value must still depend on that pixel alone (a row may
/// group its pixels' work in any way), so the image is the one-pixel pass's for any thread
/// count.
pub fn per_row_counted<T: Copy + Send>(
    p: &Pipeline,
    frame: &Frame,
    init: T,
    f: impl Fn(usize, &mut [T]) -> u64 + Sync,
) -> (Vec<T>, u64) {
    let w = frame.width() as usize;
    let mut out = vec![init; w * frame.height() as usize];
    let total = p.install(|| out.par_chunks_mut(w).enumerate().map(|(y, row)| f(y, row)).sum::<u64>());
    (out, total)
}

/// [`per_pixel_counted`] four pixels at a time, for lookups that run on four lanes:
/// `f(x, y, n)` gives the values of pixels `x .. x + n` of row `y` (`n` is 4, or fewer at a
/// row's end; lanes past `n` are ignored) and their count. Each pixel's value must still
/// depend on that pixel alone, so the image is the one-pixel pass's for any thread count.
pub fn per_pixel4_counted<T: Copy + Send>(
    p: &Pipeline,
    frame: &Frame,
    init: T,
    f: impl Fn(usize, usize, usize) -> ([T; 4], u64) + Sync,
) -> (Vec<T>, u64) {
    let w = frame.width() as usize;
    let mut out = vec![init; w * frame.height() as usize];
    let total = p.install(|| {
        out.par_chunks_mut(w)
            .enumerate()
            .map(|(y, row)| {
                let mut n = 0u64;
                for (q, o) in row.chunks_mut(4).enumerate() {
                    let (v, c) = f(4 * q, y, o.len());
                    o.copy_from_slice(&v[..o.len()]);
                    n += c;
                }
                n
            })
            .sum::<u64>()
    });
    (out, total)
}
