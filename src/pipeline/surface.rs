//! Render targets and textures: [`Surface`] (a 2D buffer of any texel type), [`CubeMap`],
//! [`SurfaceArray`] (cascades, layers) and [`MipChain`].
//!
//! Storage is row-major, row 0 at the top (window origin top-left, y down).

use super::error::{OverBudget, PipelineError};
use glam::{Vec3, Vec4};
use std::sync::atomic::{AtomicU64, Ordering};

pub use super::error::MAX_DIMENSION;

/// A texel type: anything plain that can live in a surface.
pub trait Texel: Copy + Send + Sync + 'static {}
impl<T: Copy + Send + Sync + 'static> Texel for T {}

/// A 2D buffer of texels, row-major, origin top-left.
///
/// Every surface counts against one process-wide memory budget ([`set_memory_limit`]): a
/// surface that would take the live surfaces past it is refused before it is allocated, with
/// an error that says how large it is and how to raise the limit.
#[derive(Debug, PartialEq)]
pub struct Surface<T> {
    width: u32,
    height: u32,
    data: Vec<T>,
}

/// Default memory budget of all live surfaces together (4 GiB).
pub const DEFAULT_MEMORY_LIMIT: u64 = 4 << 30;

static LIVE_BYTES: AtomicU64 = AtomicU64::new(0);
static MEMORY_LIMIT: AtomicU64 = AtomicU64::new(DEFAULT_MEMORY_LIMIT);

/// Sets the memory budget of all live surfaces together, in bytes (the CLI's `--max-memory`).
pub fn set_memory_limit(bytes: u64) {
    MEMORY_LIMIT.store(bytes, Ordering::Relaxed);
}

/// The memory budget in force.
pub fn memory_limit() -> u64 {
    MEMORY_LIMIT.load(Ordering::Relaxed)
}

/// Bytes held by live surfaces now.
pub fn live_surface_bytes() -> u64 {
    LIVE_BYTES.load(Ordering::Relaxed)
}

/// Whether `count` surfaces of `width` x `height` fit in the budget now (nothing reserved):
/// the check for a set of surfaces before the first is allocated.
///
/// Techniques call it with everything a pass will allocate (maps × faces × layers) before
/// the pass, so that a request past the budget is refused at once rather than after the
/// first surfaces were filled.
pub fn check_room(width: u32, height: u32, texel: usize, count: u64) -> Result<(), PipelineError> {
    check_bytes(
        width,
        height,
        (width as u64 * height as u64 * texel as u64).saturating_mul(count),
    )
}

/// Whether `bytes` of a `width` x `height` structure that is not a surface (per-pixel
/// stores, lists) fit beside the live surfaces in the budget now. Checked before such a
/// structure is allocated.
pub fn check_bytes(width: u32, height: u32, bytes: u64) -> Result<(), PipelineError> {
    fits(width, height, bytes, live_surface_bytes()).map(|_| ())
}

/// `bytes` more beside `live` within the budget: the new total, or the error that says why
/// not.
fn fits(width: u32, height: u32, bytes: u64, live: u64) -> Result<u64, PipelineError> {
    let limit = memory_limit();
    match live.checked_add(bytes) {
        Some(total) if total <= limit => Ok(total),
        _ => Err(PipelineError::OverBudget(OverBudget {
            width,
            height,
            bytes,
            live,
            limit,
        })),
    }
}

/// Reserves a surface's bytes in the budget, or says why not.
fn reserve(width: u32, height: u32, texel: usize) -> Result<(), PipelineError> {
    reserve_bytes(width, height, width as u64 * height as u64 * texel as u64)
}

/// Bytes of a structure that is not a surface (lists, per-texel records, a store's pool)
/// counted in the budget for as long as the reservation lives: reserved before the
/// structure is allocated, returned when the reservation is dropped or shrunk.
#[derive(Debug, Default)]
pub struct Reservation {
    bytes: u64,
}

impl Reservation {
    /// Reserves `bytes` of a `width` x `height` structure, or says why they do not fit beside
    /// everything alive.
    pub fn new(width: u32, height: u32, bytes: u64) -> Result<Self, PipelineError> {
        reserve_bytes(width, height, bytes)?;
        Ok(Reservation { bytes })
    }

    /// Makes the reservation `bytes` (a structure that grows or shrinks): more is checked
    /// against the budget, less is returned. On an error nothing changes.
    pub fn resize(&mut self, width: u32, height: u32, bytes: u64) -> Result<(), PipelineError> {
        if bytes > self.bytes {
            reserve_bytes(width, height, bytes - self.bytes)?;
        } else {
            LIVE_BYTES.fetch_sub(self.bytes - bytes, Ordering::Relaxed);
        }
        self.bytes = bytes;
        Ok(())
    }

    /// The bytes reserved.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }
}

impl Drop for Reservation {
    fn drop(&mut self) {
        LIVE_BYTES.fetch_sub(self.bytes, Ordering::Relaxed);
    }
}

impl Clone for Reservation {
    /// A copy of the structure counts too (it cannot be refused: `Clone` cannot fail).
    fn clone(&self) -> Self {
        LIVE_BYTES.fetch_add(self.bytes, Ordering::Relaxed);
        Reservation { bytes: self.bytes }
    }
}

impl PartialEq for Reservation {
    /// Reservations are bookkeeping: they never make two structures differ.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Reserves `bytes` in the budget, or says why not.
fn reserve_bytes(width: u32, height: u32, bytes: u64) -> Result<(), PipelineError> {
    let mut live = LIVE_BYTES.load(Ordering::Relaxed);
    loop {
        let total = fits(width, height, bytes, live)?;
        match LIVE_BYTES.compare_exchange_weak(live, total, Ordering::Relaxed, Ordering::Relaxed) {
            Ok(_) => return Ok(()),
            Err(now) => live = now,
        }
    }
}

/// A surface made from a smaller one (a mapped copy, a mip level): counted in the budget, not
/// refused (its source already passed).
fn counted<T>(width: u32, height: u32, data: Vec<T>) -> Surface<T> {
    LIVE_BYTES.fetch_add((data.len() * std::mem::size_of::<T>()) as u64, Ordering::Relaxed);
    Surface { width, height, data }
}

impl<T> Drop for Surface<T> {
    fn drop(&mut self) {
        LIVE_BYTES.fetch_sub((self.data.len() * std::mem::size_of::<T>()) as u64, Ordering::Relaxed);
    }
}

impl<T: Clone> Clone for Surface<T> {
    /// A copy counts in the budget too (it cannot be refused: `Clone` cannot fail).
    fn clone(&self) -> Self {
        counted(self.width, self.height, self.data.clone())
    }
}

/// Checks a surface size against the pipeline's limits.
pub fn check_size(width: u32, height: u32) -> Result<(), PipelineError> {
    if width == 0 || height == 0 || width > MAX_DIMENSION || height > MAX_DIMENSION {
        return Err(PipelineError::BadSize { width, height });
    }
    Ok(())
}

impl<T: Texel> Surface<T> {
    /// A `width` x `height` surface filled with `value`.
    ///
    /// Errors when a side is zero or above [`MAX_DIMENSION`].
    pub fn new(width: u32, height: u32, value: T) -> Result<Self, PipelineError> {
        check_size(width, height)?;
        reserve(width, height, std::mem::size_of::<T>())?;
        Ok(Surface {
            width,
            height,
            data: vec![value; width as usize * height as usize],
        })
    }

    /// Wraps existing row-major data; errors if the length does not match the size.
    pub fn from_vec(width: u32, height: u32, data: Vec<T>) -> Result<Self, PipelineError> {
        check_size(width, height)?;
        if data.len() != width as usize * height as usize {
            return Err(PipelineError::BadSize { width, height });
        }
        reserve(width, height, std::mem::size_of::<T>())?;
        Ok(Surface { width, height, data })
    }

    /// [`Surface::from_vec`] for a surface derived from ones that already passed the memory
    /// budget (a reduction level, a filtered copy, an image of a frame): counted in the
    /// budget but never refused, so that code deriving it need not fail. Errors only when the
    /// size is invalid or does not match the data.
    pub fn from_vec_derived(width: u32, height: u32, data: Vec<T>) -> Result<Self, PipelineError> {
        check_size(width, height)?;
        if data.len() != width as usize * height as usize {
            return Err(PipelineError::BadSize { width, height });
        }
        Ok(counted(width, height, data))
    }

    /// Width in texels.
    #[inline]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    #[inline]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The texel at (x, y). Panics when out of range, like slice indexing; use [`Surface::get`]
    /// for a checked read.
    #[inline]
    pub fn at(&self, x: u32, y: u32) -> T {
        self.data[y as usize * self.width as usize + x as usize]
    }

    /// The texel at (x, y), or `None` outside the surface.
    #[inline]
    pub fn get(&self, x: i64, y: i64) -> Option<T> {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            None
        } else {
            Some(self.data[y as usize * self.width as usize + x as usize])
        }
    }

    /// The texel at (x, y) with coordinates clamped to the edge.
    #[inline]
    pub fn at_clamped(&self, x: i64, y: i64) -> T {
        let x = x.clamp(0, self.width as i64 - 1) as usize;
        let y = y.clamp(0, self.height as i64 - 1) as usize;
        self.data[y * self.width as usize + x]
    }

    /// Writes the texel at (x, y). Panics when out of range.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, v: T) {
        let w = self.width as usize;
        self.data[y as usize * w + x as usize] = v;
    }

    /// Sets every texel to `value`.
    pub fn fill(&mut self, value: T) {
        self.data.fill(value);
    }

    /// All texels, row-major.
    #[inline]
    pub fn data(&self) -> &[T] {
        &self.data
    }

    /// All texels, row-major, mutable.
    #[inline]
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// One row.
    #[inline]
    pub fn row(&self, y: u32) -> &[T] {
        let w = self.width as usize;
        &self.data[y as usize * w..(y as usize + 1) * w]
    }

    /// A new surface of the same size with `f` applied to every texel.
    pub fn map<U: Texel>(&self, f: impl Fn(T) -> U) -> Surface<U> {
        counted(self.width, self.height, self.data.iter().map(|&t| f(t)).collect())
    }
}

/// Cube-map faces in the D3D/GL order: +X, -X, +Y, -Y, +Z, -Z.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum CubeFace {
    /// +X
    PosX = 0,
    /// -X
    NegX = 1,
    /// +Y
    PosY = 2,
    /// -Y
    NegY = 3,
    /// +Z
    PosZ = 4,
    /// -Z
    NegZ = 5,
}

impl CubeFace {
    /// All six faces in order.
    pub const ALL: [CubeFace; 6] = [
        CubeFace::PosX,
        CubeFace::NegX,
        CubeFace::PosY,
        CubeFace::NegY,
        CubeFace::PosZ,
        CubeFace::NegZ,
    ];

    /// The face's forward axis, and the world directions of its +u (right) and +v (down) texture axes,
    /// per the GL/D3D cube-map table (`ma`, `sc`, `tc` selection).
    pub fn basis(self) -> (Vec3, Vec3, Vec3) {
        match self {
            CubeFace::PosX => (Vec3::X, -Vec3::Z, -Vec3::Y),
            CubeFace::NegX => (-Vec3::X, Vec3::Z, -Vec3::Y),
            CubeFace::PosY => (Vec3::Y, Vec3::X, Vec3::Z),
            CubeFace::NegY => (-Vec3::Y, Vec3::X, -Vec3::Z),
            CubeFace::PosZ => (Vec3::Z, Vec3::X, -Vec3::Y),
            CubeFace::NegZ => (-Vec3::Z, -Vec3::X, -Vec3::Y),
        }
    }

    /// The face a direction selects and its texture coordinate in [0, 1]^2 (origin top-left).
    /// Ties between major axes resolve in the order x, y, z. Returns `None` for a zero or
    /// non-finite direction.
    pub fn from_direction(d: Vec3) -> Option<(CubeFace, f32, f32)> {
        if !d.is_finite() || d == Vec3::ZERO {
            return None;
        }
        let a = d.abs();
        let face = if a.x >= a.y && a.x >= a.z {
            if d.x >= 0.0 {
                CubeFace::PosX
            } else {
                CubeFace::NegX
            }
        } else if a.y >= a.z {
            if d.y >= 0.0 {
                CubeFace::PosY
            } else {
                CubeFace::NegY
            }
        } else if d.z >= 0.0 {
            CubeFace::PosZ
        } else {
            CubeFace::NegZ
        };
        let (f, u, v) = face.basis();
        let ma = d.dot(f);
        let s = d.dot(u) / ma;
        let t = d.dot(v) / ma;
        Some((face, 0.5 * (s + 1.0), 0.5 * (t + 1.0)))
    }
}

/// Six square surfaces indexed by [`CubeFace`].
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap<T> {
    /// The faces, in [`CubeFace::ALL`] order.
    pub faces: [Surface<T>; 6],
}

impl<T: Texel> CubeMap<T> {
    /// A cube map with `size` x `size` faces filled with `value`.
    pub fn new(size: u32, value: T) -> Result<Self, PipelineError> {
        // All six faces are checked against the budget before the first is allocated.
        check_size(size, size)?;
        check_room(size, size, std::mem::size_of::<T>(), 6)?;
        let f = Surface::new(size, size, value)?;
        Ok(CubeMap {
            faces: [f.clone(), f.clone(), f.clone(), f.clone(), f.clone(), f],
        })
    }

    /// Face size in texels.
    pub fn size(&self) -> u32 {
        self.faces[0].width()
    }

    /// One face.
    pub fn face(&self, f: CubeFace) -> &Surface<T> {
        &self.faces[f as usize]
    }

    /// One face, mutable.
    pub fn face_mut(&mut self, f: CubeFace) -> &mut Surface<T> {
        &mut self.faces[f as usize]
    }
}

/// An array of same-sized surfaces (cascades, layers).
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceArray<T> {
    /// The layers.
    pub layers: Vec<Surface<T>>,
}

impl<T: Texel> SurfaceArray<T> {
    /// `count` layers of `width` x `height` filled with `value`.
    pub fn new(count: usize, width: u32, height: u32, value: T) -> Result<Self, PipelineError> {
        if count == 0 || count > 64 {
            return Err(PipelineError::BadArgument(format!(
                "surface array layer count {count} (must be 1..=64)"
            )));
        }
        check_size(width, height)?;
        check_room(width, height, std::mem::size_of::<T>(), count as u64)?;
        let s = Surface::new(width, height, value)?;
        Ok(SurfaceArray { layers: vec![s; count] })
    }

    /// Number of layers.
    pub fn len(&self) -> usize {
        self.layers.len()
    }

    /// True when there are no layers (never, for an array built by [`SurfaceArray::new`]).
    pub fn is_empty(&self) -> bool {
        self.layers.is_empty()
    }
}

/// A mip chain: level 0 is the full surface, each next level half the size (rounded down,
/// at least 1), down to 1 x 1.
#[derive(Clone, Debug, PartialEq)]
pub struct MipChain<T> {
    levels: Vec<Surface<T>>,
}

impl<T: Texel> MipChain<T> {
    /// Builds the chain from `base`, each texel of level i+1 reducing the (up to) 2x2 texels of
    /// level i below it with `reduce` (average for colour, min or max for hierarchical depth).
    /// For odd sizes the last row/column folds into the previous texel so no texel is lost.
    pub fn build(base: Surface<T>, reduce: impl Fn(&[T]) -> T) -> Self {
        let mut levels = vec![base];
        let mut buf: Vec<T> = Vec::with_capacity(9);
        loop {
            let prev = levels.last().unwrap();
            let (w, h) = (prev.width(), prev.height());
            if w == 1 && h == 1 {
                break;
            }
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let mut data = Vec::with_capacity(nw as usize * nh as usize);
            for y in 0..nh {
                let y0 = 2 * y;
                let y1 = if y == nh - 1 { h } else { (2 * y + 2).min(h) };
                for x in 0..nw {
                    let x0 = 2 * x;
                    let x1 = if x == nw - 1 { w } else { (2 * x + 2).min(w) };
                    buf.clear();
                    for yy in y0..y1.max(y0 + 1) {
                        for xx in x0..x1.max(x0 + 1) {
                            buf.push(prev.at(xx.min(w - 1), yy.min(h - 1)));
                        }
                    }
                    data.push(reduce(&buf));
                }
            }
            levels.push(counted(nw, nh, data));
        }
        MipChain { levels }
    }

    /// A chain from its levels, finest first (each half the previous, at least 1, down to
    /// 1 x 1), as [`MipChain::build`] makes them.
    pub(crate) fn from_levels(levels: Vec<Surface<T>>) -> Self {
        MipChain { levels }
    }

    /// Number of levels.
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Level `i`, or an error naming the valid range.
    pub fn level(&self, i: usize) -> Result<&Surface<T>, PipelineError> {
        self.levels.get(i).ok_or(PipelineError::BadMipLevel {
            level: i,
            levels: self.levels.len(),
        })
    }

    /// All levels.
    pub fn levels(&self) -> &[Surface<T>] {
        &self.levels
    }
}

/// Averages texels (box filter), for [`MipChain::build`].
pub fn average_f32(t: &[f32]) -> f32 {
    t.iter().sum::<f32>() / t.len() as f32
}

/// Averages RGBA texels (box filter), for [`MipChain::build`].
pub fn average_vec4(t: &[Vec4]) -> Vec4 {
    t.iter().copied().sum::<Vec4>() / t.len() as f32
}

/// Minimum, for hierarchical min maps.
pub fn min_f32(t: &[f32]) -> f32 {
    t.iter().copied().fold(f32::INFINITY, f32::min)
}

/// Maximum, for hierarchical max maps.
pub fn max_f32(t: &[f32]) -> f32 {
    t.iter().copied().fold(f32::NEG_INFINITY, f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_and_absurd_sizes_are_errors() {
        assert!(Surface::new(0, 4, 0f32).is_err());
        assert!(Surface::new(4, 0, 0f32).is_err());
        assert!(Surface::new(MAX_DIMENSION + 1, 4, 0f32).is_err());
        assert!(Surface::from_vec(2, 2, vec![0u8; 3]).is_err());
    }

    #[test]
    fn mip_chain_reaches_one_texel_and_keeps_min() {
        let mut s = Surface::new(5, 3, 1.0f32).unwrap();
        s.set(4, 2, -3.0);
        let m = MipChain::build(s, min_f32);
        assert_eq!(m.level_count(), 3);
        assert_eq!(m.level(1).unwrap().width(), 2);
        assert_eq!(m.level(2).unwrap().at(0, 0), -3.0);
        assert!(m.level(3).is_err());
    }

    #[test]
    fn cube_face_selection_matches_table() {
        let (f, u, v) = CubeFace::from_direction(Vec3::new(1.0, 0.0, 0.0)).unwrap();
        assert_eq!((f, u, v), (CubeFace::PosX, 0.5, 0.5));
        let (f, u, _) = CubeFace::from_direction(Vec3::new(1.0, 0.0, -0.5)).unwrap();
        assert_eq!(f, CubeFace::PosX);
        assert!(u > 0.5);
        assert!(CubeFace::from_direction(Vec3::ZERO).is_none());
        for f in CubeFace::ALL {
            let (fwd, _, _) = f.basis();
            assert_eq!(CubeFace::from_direction(fwd).unwrap().0, f);
        }
    }
}
