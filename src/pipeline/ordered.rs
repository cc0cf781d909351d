//! Raster-ordered per-pixel storage (what D3D calls rasterizer-ordered views, GL
//! `fragment_shader_interlock`): per-pixel user data that a fragment program reads and
//! writes, the fragments of one pixel applied in primitive (submission) order.
//!
//! A GPU needs an interlock for this; here it follows from how the pipeline already works: a
//! tile is owned by one worker for the whole draw and walks its triangles in submission order,
//! so a pixel's storage is touched by one thread at a time, fragment after fragment in
//! primitive order, without locks. The result never depends on the thread count.
//!
//! Storage is a [`PixelStore`]: each pixel owns a slice of `T`, either of a fixed size
//! ([`PixelStore::fixed`]: AVSM's nodes per texel) or of its own size, indexed into one pool
//! ([`PixelStore::indexed`]: the irregular z-buffer's samples per texel). A draw with it is
//! `Pipeline::draw_ordered`; the program is an [`OrderedProgram`].

use super::error::PipelineError;
use super::lanes::Fragment;
use super::program::FragmentProgram;
use glam::Vec4;

/// Per-pixel slices of user data in one pool.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelStore<T> {
    width: u32,
    height: u32,
    /// `offsets[i]..offsets[i + 1]` is pixel `i`'s range of `data` (row-major pixels).
    offsets: Vec<u32>,
    data: Vec<T>,
    /// The pool's and offsets' bytes, counted in the memory budget.
    reserved: super::surface::Reservation,
}

/// An empty store of no pixels, to be built by [`PixelStore::rebuild_indexed`] or
/// [`PixelStore::rebuild_rows`].
impl<T> Default for PixelStore<T> {
    fn default() -> Self {
        PixelStore {
            width: 0,
            height: 0,
            offsets: vec![0],
            data: Vec::new(),
            reserved: Default::default(),
        }
    }
}

impl<T: Copy + Send + Sync> PixelStore<T> {
    /// `slots` values of `init` per pixel.
    pub fn fixed(width: u32, height: u32, slots: usize, init: T) -> Result<Self, PipelineError> {
        let pixels = check_size(width, height)?;
        let total = pixels
            .checked_mul(slots)
            .filter(|&n| n <= u32::MAX as usize)
            .ok_or_else(|| {
                PipelineError::BadArgument(format!(
                    "pixel store of {width}x{height} pixels x {slots} slots is too large (at most {} values)",
                    u32::MAX
                ))
            })?;
        // Reserved in the memory budget before it is allocated.
        let reserved = super::surface::Reservation::new(
            width,
            height,
            (total * std::mem::size_of::<T>() + 4 * (pixels + 1)) as u64,
        )?;
        Ok(PixelStore {
            width,
            height,
            offsets: (0..=pixels).map(|i| (i * slots) as u32).collect(),
            data: vec![init; total],
            reserved,
        })
    }

    /// `counts[i]` values of `init` for pixel `i` (row-major), one pool for all.
    pub fn indexed(width: u32, height: u32, counts: &[u32], init: T) -> Result<Self, PipelineError> {
        let mut s = PixelStore {
            width,
            height,
            offsets: Vec::new(),
            data: Vec::new(),
            reserved: Default::default(),
        };
        s.rebuild_indexed(width, height, counts, init)?;
        Ok(s)
    }

    /// Makes this store what [`PixelStore::indexed`] would make, reusing its allocations (a
    /// technique that rebuilds its lists every frame keeps its memory warm).
    pub fn rebuild_indexed(&mut self, width: u32, height: u32, counts: &[u32], init: T) -> Result<(), PipelineError> {
        let pixels = check_size(width, height)?;
        if counts.len() != pixels {
            return Err(PipelineError::BadArgument(format!(
                "pixel store: {} counts for {width}x{height} = {pixels} pixels",
                counts.len()
            )));
        }
        let total = self.reserve_growth(width, height, counts)?;
        self.offsets.clear();
        self.offsets.reserve(pixels + 1);
        self.offsets.push(0);
        let mut at = 0u32;
        for &c in counts {
            at += c;
            self.offsets.push(at);
        }
        self.width = width;
        self.height = height;
        self.data.clear();
        self.data.resize(total as usize, init);
        Ok(())
    }

    /// Rebuilds the store row by row in parallel, for a caller that knows each row's number of
    /// values (`row_totals`) but not yet each pixel's: `fill(y, starts, values)` runs once per
    /// row (on the current rayon pool) and sets `starts[x]`, where pixel x's values begin
    /// relative to the row's first value (non-decreasing, at most the row's total; each
    /// pixel's values end where the next one's begin), and every one of `values`. Values
    /// `fill` leaves unset keep what an earlier build left there (this one writes nothing
    /// first: a counting sort fills every value anyway). Starts that are not non-decreasing
    /// or pass the row's total are an error, after which the store must be rebuilt before
    /// it is used.
    pub fn rebuild_rows<F>(
        &mut self,
        width: u32,
        height: u32,
        row_totals: &[u32],
        init: T,
        fill: F,
    ) -> Result<(), PipelineError>
    where
        F: Fn(usize, &mut [u32], &mut [T]) + Sync,
    {
        use rayon::prelude::*;
        let pixels = check_size(width, height)?;
        if row_totals.len() != height as usize {
            return Err(PipelineError::BadArgument(format!(
                "pixel store: {} row totals for {height} rows",
                row_totals.len()
            )));
        }
        let total = self.reserve_growth(width, height, row_totals)?;
        self.width = width;
        self.height = height;
        self.offsets.resize(pixels + 1, 0);
        self.offsets[pixels] = total as u32;
        self.data.resize(total as usize, init);
        let w = width as usize;
        let mut parts: Vec<(usize, u32, &mut [u32], &mut [T])> = Vec::with_capacity(height as usize);
        let (mut offs, mut data) = (&mut self.offsets[..pixels], self.data.as_mut_slice());
        let mut base = 0u32;
        for (y, &n) in row_totals.iter().enumerate() {
            let (o, orest) = offs.split_at_mut(w);
            let (d, drest) = data.split_at_mut(n as usize);
            parts.push((y, base, o, d));
            (offs, data) = (orest, drest);
            base += n;
        }
        let bad = parts
            .into_par_iter()
            .filter_map(|(y, base, starts, values)| {
                fill(y, starts, values);
                let mut last = 0;
                for s in starts.iter_mut() {
                    if *s < last || *s as usize > values.len() {
                        return Some(y);
                    }
                    last = *s;
                    *s += base;
                }
                None
            })
            .min();
        match bad {
            Some(y) => Err(PipelineError::BadArgument(format!(
                "pixel store: row {y}'s starts decrease or pass its {} values",
                row_totals[y]
            ))),
            None => Ok(()),
        }
    }

    /// The values `counts` add up to (at most `u32::MAX`), reserved with a `width` x `height`
    /// store's offsets in the memory budget before the pool grows to them (what it holds now
    /// is reused, and stays reserved).
    fn reserve_growth(&mut self, width: u32, height: u32, counts: &[u32]) -> Result<u64, PipelineError> {
        let total: u64 = counts.iter().map(|&c| c as u64).sum();
        if total > u32::MAX as u64 {
            return Err(PipelineError::BadArgument(format!(
                "pixel store: more than {} values in all",
                u32::MAX
            )));
        }
        let pixels = width as u64 * height as u64;
        let need = total * std::mem::size_of::<T>() as u64 + 4 * (pixels + 1);
        let bytes = need.max(self.reserved.bytes());
        self.reserved.resize(width, height, bytes)?;
        Ok(total)
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The values of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> &[T] {
        let i = (y * self.width + x) as usize;
        &self.data[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// The values of pixel (x, y), to change.
    pub fn pixel_mut(&mut self, x: u32, y: u32) -> &mut [T] {
        let i = (y * self.width + x) as usize;
        &mut self.data[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Pixel `i`'s range of [`PixelStore::data`] (row-major pixel index).
    pub fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }

    /// Where each pixel's values start in [`PixelStore::data`] (one more entry than pixels:
    /// the last is the total).
    pub fn offsets(&self) -> &[u32] {
        &self.offsets
    }

    /// Every value, pixel after pixel.
    pub fn data(&self) -> &[T] {
        &self.data
    }

    /// Every value, to change (between draws).
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Bytes of storage (values and offsets).
    pub fn bytes(&self) -> usize {
        self.data.len() * std::mem::size_of::<T>() + self.offsets.len() * 4
    }
}

fn check_size(width: u32, height: u32) -> Result<usize, PipelineError> {
    if width == 0 || height == 0 || width > super::error::MAX_DIMENSION || height > super::error::MAX_DIMENSION {
        return Err(PipelineError::BadSize { width, height });
    }
    Ok(width as usize * height as usize)
}

/// A fragment program with raster-ordered access to its pixel's storage.
pub trait OrderedProgram<V, T>: Sync {
    /// Called for every fragment that passes the depth and stencil tests, with exclusive
    /// access to its pixel's values; the fragments of one pixel come in primitive order.
    fn apply(&self, f: &Fragment<V>, pixel: &mut [T]);
}

impl<V, T, F: Fn(&Fragment<V>, &mut [T]) + Sync> OrderedProgram<V, T> for F {
    #[inline(always)]
    fn apply(&self, f: &Fragment<V>, pixel: &mut [T]) {
        self(f, pixel)
    }
}

/// The pipeline's side of an ordered draw: a fragment program that applies the user's
/// program to the fragment's pixel of the store.
pub(crate) struct Ordered<'a, P, T> {
    pub program: &'a P,
    pub data: *mut T,
    pub offsets: &'a [u32],
    pub width: usize,
}

// SAFETY: a pixel's range of the store is written only while its tile is processed, and a
// tile is processed by exactly one worker per draw (see `Pipeline::draw`); `ORDERED`
// programs run only on the per-fragment path (never deferred, never four lanes at once), so
// no two threads ever hold the same pixel's slice, and one thread holds it once at a time.
unsafe impl<P: Sync, T: Send> Sync for Ordered<'_, P, T> {}

impl<V, P: OrderedProgram<V, T>, T: Send> FragmentProgram<V> for Ordered<'_, P, T> {
    const ORDERED: bool = true;

    #[inline(always)]
    fn shade(&self, f: &Fragment<V>) -> Option<Vec4> {
        let i = f.y as usize * self.width + f.x as usize;
        let (a, b) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
        // SAFETY: see the `Sync` impl: this worker owns the pixel during the call.
        let px = unsafe { std::slice::from_raw_parts_mut(self.data.add(a), b - a) };
        self.program.apply(f, px);
        Some(Vec4::ZERO)
    }
}

impl<'a, P, T> Ordered<'a, P, T> {
    /// Wraps `program` over `store`.
    pub fn new(program: &'a P, store: &'a mut PixelStore<T>) -> Self {
        Ordered {
            program,
            data: store.data.as_mut_ptr(),
            offsets: &store.offsets,
            width: store.width as usize,
        }
    }
}
