//! What a fragment program sees, one pixel ([`Fragment`]) or four ([`Fragment4`]), and the
//! four-lane vocabulary: four-lane vectors and colours, and lane helpers that give the one-pixel
//! path's bits on every target (SSE2 where the build has it, portable code elsewhere). The
//! four-pixel path itself is `wide.rs`.

use super::vertex::Varyings;
use glam::{BVec4A, Vec3, Vec4};

/// What the fragment program sees.
#[derive(Copy, Clone, Debug)]
pub struct Fragment<V> {
    /// Pixel column.
    pub x: u32,
    /// Pixel row (0 at the top).
    pub y: u32,
    /// Depth after polygon offset and clamp.
    pub z: f32,
    /// Perspective-correct varyings.
    pub var: V,
    /// The triangle faces the viewer.
    pub front: bool,
    /// Index of the source triangle in the draw.
    pub prim: u32,
}

/// Four fragments of one triangle: lane `i` is pixel (`x[i]`, `y[i]`). The one-pixel-per-
/// run path fills lanes with consecutive pixels of a row; the deferred path
/// ([`crate::pipeline::Shading::Deferred`]) packs any four visible pixels of the triangle in a
/// tile. Lanes outside the triangle (or that failed the depth test) are off in
/// [`Fragment4::mask`]; they carry a copy of the first live lane's values, so a program never
/// sees values extrapolated beyond the triangle, and their results are ignored.
#[derive(Copy, Clone, Debug)]
pub struct Fragment4<'a, V> {
    /// Pixel column of each lane.
    pub x: [u32; 4],
    /// Pixel row of each lane (0 at the top).
    pub y: [u32; 4],
    /// Bit `i` set: lane `i` is shaded and stored.
    pub mask: u8,
    /// Depth per lane after polygon offset, clamp and quantization.
    pub z: Vec4,
    /// Perspective-correct barycentric weights of the three vertices, per lane.
    pub bary: [Vec4; 3],
    /// The triangle's varyings at its three vertices.
    pub verts: &'a [V; 3],
    /// The triangle faces the viewer.
    pub front: bool,
    /// Index of the source triangle in the draw.
    pub prim: u32,
}

impl<V: Varyings> Fragment4<'_, V> {
    /// Lane `i` as the one-pixel path's [`Fragment`] (varyings combined by
    /// [`Varyings::combine`] with this lane's weights).
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Fragment<V> {
        let var = if V::EMPTY {
            self.verts[0]
        } else {
            let w = [
                self.bary[0].to_array()[i],
                self.bary[1].to_array()[i],
                self.bary[2].to_array()[i],
            ];
            V::combine(&self.verts[0], &self.verts[1], &self.verts[2], w)
        };
        Fragment {
            x: self.x[i],
            y: self.y[i],
            z: self.z.to_array()[i],
            var,
            front: self.front,
            prim: self.prim,
        }
    }

    /// One scalar varying per lane: `(a * w0 + b * w1) + c * w2`, the order of the linear
    /// [`Varyings::combine`] implementations, so each lane equals the one-pixel path bit for bit.
    #[inline(always)]
    pub fn interpolate(&self, a: f32, b: f32, c: f32) -> Vec4 {
        Vec4::splat(a) * self.bary[0] + Vec4::splat(b) * self.bary[1] + Vec4::splat(c) * self.bary[2]
    }

    /// A `Vec3` varying per lane (see [`Fragment4::interpolate`]).
    #[inline(always)]
    pub fn interpolate3(&self, a: Vec3, b: Vec3, c: Vec3) -> Vec3x4 {
        Vec3x4 {
            x: self.interpolate(a.x, b.x, c.x),
            y: self.interpolate(a.y, b.y, c.y),
            z: self.interpolate(a.z, b.z, c.z),
        }
    }
}

/// Four `Vec3`s in structure-of-arrays form, with the few operations fragment programs need,
/// each matching glam's `Vec3` operation lane by lane.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Vec3x4 {
    /// x of each lane.
    pub x: Vec4,
    /// y of each lane.
    pub y: Vec4,
    /// z of each lane.
    pub z: Vec4,
}

impl Vec3x4 {
    /// `Vec3::dot` per lane: `(x * o.x + y * o.y) + z * o.z`.
    #[inline(always)]
    pub fn dot(self, o: Vec3) -> Vec4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// `Vec3::normalize_or_zero` per lane: times `1 / sqrt(dot(v, v))` when that is finite and
    /// positive, else zero.
    #[inline(always)]
    pub fn normalize_or_zero(self) -> Vec3x4 {
        let rcp = Vec4::ONE / sqrt4(self.x * self.x + self.y * self.y + self.z * self.z);
        let ok = rcp.is_finite_mask() & rcp.cmpgt(Vec4::ZERO);
        Vec3x4 {
            x: Vec4::select(ok, self.x * rcp, Vec4::ZERO),
            y: Vec4::select(ok, self.y * rcp, Vec4::ZERO),
            z: Vec4::select(ok, self.z * rcp, Vec4::ZERO),
        }
    }

    /// Each lane times its scalar `s`.
    #[inline(always)]
    pub fn scale(self, s: Vec4) -> Vec3x4 {
        Vec3x4 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    /// `Vec3::dot` lane by lane with another four: `(x * o.x + y * o.y) + z * o.z`.
    #[inline(always)]
    pub fn dot4(self, o: Vec3x4) -> Vec4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// The same `Vec3` in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Vec3x4 {
        Vec3x4 {
            x: Vec4::splat(v.x),
            y: Vec4::splat(v.y),
            z: Vec4::splat(v.z),
        }
    }

    /// `Vec3::cross(self, r)` per lane:
    /// `(y * r.z - r.y * z, z * r.x - r.z * x, x * r.y - r.x * y)`.
    #[inline(always)]
    pub fn cross(self, r: Vec3) -> Vec3x4 {
        Vec3x4 {
            x: self.y * r.z - self.z * r.y,
            y: self.z * r.x - self.x * r.z,
            z: self.x * r.y - self.y * r.x,
        }
    }
}

impl std::ops::Sub for Vec3x4 {
    type Output = Vec3x4;

    /// `Vec3`'s subtraction per lane.
    #[inline(always)]
    fn sub(self, o: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

/// Four RGBA colours in structure-of-arrays form: what a fragment program's
/// `shade4` returns.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Color4 {
    /// Red of each lane.
    pub r: Vec4,
    /// Green of each lane.
    pub g: Vec4,
    /// Blue of each lane.
    pub b: Vec4,
    /// Alpha of each lane.
    pub a: Vec4,
}

impl Color4 {
    /// From four colours, lane by lane.
    #[inline(always)]
    pub fn from_lanes(c: [Vec4; 4]) -> Color4 {
        Color4 {
            r: Vec4::new(c[0].x, c[1].x, c[2].x, c[3].x),
            g: Vec4::new(c[0].y, c[1].y, c[2].y, c[3].y),
            b: Vec4::new(c[0].z, c[1].z, c[2].z, c[3].z),
            a: Vec4::new(c[0].w, c[1].w, c[2].w, c[3].w),
        }
    }

    /// The colour of lane `i`.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec4 {
        Vec4::new(
            self.r.to_array()[i],
            self.g.to_array()[i],
            self.b.to_array()[i],
            self.a.to_array()[i],
        )
    }
}

/// `x.floor()` per lane, exact (keeps -0.0, NaN and values beyond 2^23 as `f32::floor` does).
#[inline(always)]
pub fn floor4(x: Vec4) -> Vec4 {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
    {
        // SAFETY: SSE4.1 is enabled for this build.
        Vec4::from(unsafe { std::arch::x86_64::_mm_floor_ps(x.into()) })
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse4.1")))]
    {
        Vec4::from_array(x.to_array().map(f32::floor))
    }
}

/// `x.sqrt()` per lane (IEEE, correctly rounded on every path).
#[inline(always)]
pub fn sqrt4(x: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE is part of x86-64.
        Vec4::from(unsafe { std::arch::x86_64::_mm_sqrt_ps(x.into()) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Vec4::from_array(x.to_array().map(f32::sqrt))
    }
}

/// `x.clamp(0.0, 1.0)` per lane as `f32::clamp` does it: NaN and -0.0 pass through.
#[inline(always)]
pub fn clamp01(x: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        // maxps/minps return their second operand when either is NaN or both are zeros.
        Vec4::ONE.min(Vec4::ZERO.max(x))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Vec4::from_array(x.to_array().map(|v| v.clamp(0.0, 1.0)))
    }
}

/// A float holding an integer (from [`floor4`]) to `i64` as `as i64` does, then clamped to
/// `0..=max`, per lane. NaN becomes 0 before the clamp, as with `as`. `max` must be below
/// 2^24 (texture sizes are).
#[inline(always)]
pub fn index4(f: Vec4, max: i64) -> [usize; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // Clamping in float first gives the same integer: `maxps` maps NaN to its second
        // operand (0), and every clamp bound is an exact float.
        let c = Vec4::splat(max as f32).min(f.max(Vec4::ZERO));
        // SAFETY: SSE2 is part of x86-64.
        let i: [i32; 4] = unsafe { std::mem::transmute(_mm_cvttps_epi32(c.into())) };
        i.map(|v| v as usize)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        f.to_array().map(|v| (v as i64).clamp(0, max) as usize)
    }
}

/// The mask of the lanes set in `bits` (bit `i` = lane `i`).
#[inline(always)]
pub fn lane_mask(bits: u8) -> BVec4A {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; BVec4A is an all-ones/all-zeros __m128 per lane.
        unsafe {
            let b = _mm_setr_epi32(1, 2, 4, 8);
            let m = _mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(bits as i32), b), b);
            std::mem::transmute::<__m128, BVec4A>(_mm_castsi128_ps(m))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    BVec4A::new(bits & 1 != 0, bits & 2 != 0, bits & 4 != 0, bits & 8 != 0)
}
