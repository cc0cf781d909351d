//! The one output every technique and the reference produce: light visibility per camera
//! pixel, row-major, either one value per pixel or one transmittance per colour channel.
//!
//! 1 = fully lit, 0 = fully shadowed, NaN where no geometry covers the pixel. Opaque
//! techniques return [`Visibility::Scalar`]; techniques that model coloured transparency
//! (and the reference, when a scene has coloured materials) return [`Visibility::Rgb`]. A
//! scalar value stands for the same value in every channel wherever the two are compared.

use crate::hash::{fnv1a, hash_f32, FNV_OFFSET};
use glam::Vec3;

/// Visibility of every pixel of a frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Visibility {
    /// One value per pixel (grey: the same in every channel).
    Scalar(Vec<f32>),
    /// One transmittance per channel (R, G, B) per pixel.
    Rgb(Vec<Vec3>),
}

/// Rec. 709 luminance weights: wrong % and penumbra masks of colour visibility use them.
pub const LUMINANCE: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

impl Visibility {
    /// Pixels.
    pub fn len(&self) -> usize {
        match self {
            Visibility::Scalar(v) => v.len(),
            Visibility::Rgb(v) => v.len(),
        }
    }

    /// True for a zero-pixel image.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// True when the image has a value per channel.
    pub fn is_rgb(&self) -> bool {
        matches!(self, Visibility::Rgb(_))
    }

    /// Pixel `i` per channel (a scalar in every channel).
    #[inline]
    pub fn rgb(&self, i: usize) -> Vec3 {
        match self {
            Visibility::Scalar(v) => Vec3::splat(v[i]),
            Visibility::Rgb(v) => v[i],
        }
    }

    /// Pixel `i` as one value: itself, or the luminance of its channels.
    #[inline]
    pub fn value(&self, i: usize) -> f32 {
        match self {
            Visibility::Scalar(v) => v[i],
            Visibility::Rgb(v) => v[i].dot(LUMINANCE),
        }
    }

    /// The scalar data, if the image is scalar.
    pub fn as_scalar(&self) -> Option<&[f32]> {
        match self {
            Visibility::Scalar(v) => Some(v),
            Visibility::Rgb(_) => None,
        }
    }

    /// One value per pixel ([`Visibility::value`]).
    pub fn to_scalar(&self) -> Vec<f32> {
        match self {
            Visibility::Scalar(v) => v.clone(),
            Visibility::Rgb(v) => v.iter().map(|c| c.dot(LUMINANCE)).collect(),
        }
    }

    /// Every channel of every pixel, flattened (1 or 3 values per pixel).
    pub fn to_flat(&self) -> Vec<f32> {
        match self {
            Visibility::Scalar(v) => v.clone(),
            Visibility::Rgb(v) => v.iter().flat_map(|c| c.to_array()).collect(),
        }
    }

    /// Rebuilds an image from [`Visibility::to_flat`] data of `pixels` pixels.
    pub fn from_flat(pixels: usize, data: Vec<f32>) -> Option<Visibility> {
        if data.len() == pixels {
            Some(Visibility::Scalar(data))
        } else if data.len() == 3 * pixels {
            Some(Visibility::Rgb(
                data.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect(),
            ))
        } else {
            None
        }
    }

    /// A stable hash of the values by bit pattern (scalar images hash as their `f32` data,
    /// colour images with a tag in front).
    pub fn hash(&self) -> u64 {
        match self {
            Visibility::Scalar(v) => hash_f32(v),
            Visibility::Rgb(v) => v
                .iter()
                .flat_map(|c| c.to_array())
                .fold(fnv1a(FNV_OFFSET, b"rgb"), |h, x| fnv1a(h, &x.to_bits().to_le_bytes())),
        }
    }
}

impl From<Vec<f32>> for Visibility {
    fn from(v: Vec<f32>) -> Self {
        Visibility::Scalar(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_round_trip_and_luminance() {
        let v = Visibility::Rgb(vec![Vec3::new(1.0, 0.0, 0.5), Vec3::ONE]);
        assert_eq!(Visibility::from_flat(2, v.to_flat()), Some(v.clone()));
        assert!((v.value(1) - 1.0).abs() < 1e-6);
        assert!((v.value(0) - (0.2126 + 0.5 * 0.0722)).abs() < 1e-6);
        let s = Visibility::Scalar(vec![0.25, f32::NAN]);
        assert_eq!(s.rgb(0), Vec3::splat(0.25));
        assert_eq!(s.hash(), hash_f32(&[0.25, f32::NAN]));
        assert_ne!(v.hash(), Visibility::Scalar(v.to_flat()).hash());
        assert!(Visibility::from_flat(2, vec![0.0; 5]).is_none());
    }
}
