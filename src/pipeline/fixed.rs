//! Fixed-point window coordinates: 8 sub-pixel bits, as D3D/GL hardware and llvmpipe snap.
//!
//! Every edge function is computed from these integers, so coverage is exact and watertight:
//! two triangles that share an edge evaluate the same integers with opposite signs.

/// Number of sub-pixel bits of the snapped window coordinates.
pub const SUBPIXEL_BITS: u32 = 8;
/// One pixel in fixed-point units.
pub const ONE: i64 = 1 << SUBPIXEL_BITS;
/// Half a pixel in fixed-point units (pixel centres sit at `x * ONE + HALF`).
pub const HALF: i64 = ONE / 2;

/// A window coordinate in 24.8 fixed point (`Fx8(256)` is one pixel).
///
/// Stored as `i64` so products of two coordinates never overflow anywhere in the guard band.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Fx8(pub i64);

impl Fx8 {
    /// Snaps a float window coordinate to the nearest 1/256 pixel (ties away from zero,
    /// computed in `f64` so every value inside the guard band rounds exactly once).
    #[inline]
    pub fn from_f32(v: f32) -> Fx8 {
        Fx8((v as f64 * ONE as f64).round() as i64)
    }

    /// The fixed-point coordinate of the centre of pixel `p`.
    #[inline]
    pub fn pixel_center(p: i32) -> Fx8 {
        Fx8(p as i64 * ONE + HALF)
    }

    /// Back to pixels, as `f64` (exact).
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.0 as f64 / ONE as f64
    }

    /// Largest pixel index `p` with `p * ONE <= self` (floor division).
    #[inline]
    pub fn floor_pixel(self) -> i64 {
        self.0.div_euclid(ONE)
    }

    /// Smallest pixel index `p` with `p * ONE >= self` (ceiling division).
    #[inline]
    pub fn ceil_pixel(self) -> i64 {
        -(-self.0).div_euclid(ONE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapping_rounds_to_nearest_subpixel() {
        assert_eq!(Fx8::from_f32(1.0), Fx8(256));
        assert_eq!(Fx8::from_f32(0.5 / 256.0), Fx8(1));
        assert_eq!(Fx8::from_f32(-0.5 / 256.0), Fx8(-1));
        assert_eq!(Fx8::from_f32(0.4 / 256.0), Fx8(0));
        assert_eq!(Fx8::pixel_center(3), Fx8(3 * 256 + 128));
    }

    #[test]
    fn floor_and_ceil_handle_negatives() {
        assert_eq!(Fx8(-1).floor_pixel(), -1);
        assert_eq!(Fx8(-1).ceil_pixel(), 0);
        assert_eq!(Fx8(-256).floor_pixel(), -1);
        assert_eq!(Fx8(-256).ceil_pixel(), -1);
        assert_eq!(Fx8(257).floor_pixel(), 1);
        assert_eq!(Fx8(257).ceil_pixel(), 2);
    }
}
