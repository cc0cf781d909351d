//! Math with the same bits on every platform.
//!
//! `f32::sin`, `acos`, `exp`, `powf` and the other transcendentals of the standard library
//! call the platform's C library, and glibc's results differ between x86-64 and aarch64 for a
//! fraction of inputs (about 0.5 % of `acosf` in [-1, 1]). glam's SIMD `Vec4::dot` and
//! `Mat4::inverse` sum in a different order with SSE2 and with NEON. Where a result reaches
//! an image, the library calls these functions instead:
//! - the transcendentals come from the `libm` crate, a pure Rust port of musl's libm, which
//!   computes them in the same operations everywhere (glam is built with its `libm` feature,
//!   so its perspective matrices and rotations do too);
//! - dot products, the 4x4 determinant and inverse are written out here in one order of
//!   operations, scalar, without fused multiply-adds.
//!
//! `sqrt`, `floor`, `ceil`, `round`, `abs`, `min`/`max` of non-NaN values and the four
//! arithmetic operations are correctly rounded (exact) in IEEE 754 on every target, so they
//! stay the standard library's. `clippy.toml` forbids the platform versions, so a new call
//! site cannot bring them back.

use glam::{Mat4, Vec4};

/// Sine (radians).
#[inline]
pub fn sin(x: f32) -> f32 {
    libm::sinf(x)
}

/// Cosine (radians).
#[inline]
pub fn cos(x: f32) -> f32 {
    libm::cosf(x)
}

/// Sine and cosine (radians), `(sin, cos)`.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    libm::sincosf(x)
}

/// Sine and cosine (radians) in double precision, `(sin, cos)`.
#[inline]
pub fn sin_cos_f64(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// Tangent (radians).
#[inline]
pub fn tan(x: f32) -> f32 {
    libm::tanf(x)
}

/// Arc cosine, in `[0, pi]` (NaN outside `[-1, 1]`).
#[inline]
pub fn acos(x: f32) -> f32 {
    libm::acosf(x)
}

/// Arc tangent, in radians.
#[inline]
pub fn atan(x: f32) -> f32 {
    libm::atanf(x)
}

/// `e^x`.
#[inline]
pub fn exp(x: f32) -> f32 {
    libm::expf(x)
}

/// `e^x` in double precision.
#[inline]
pub fn exp_f64(x: f64) -> f64 {
    libm::exp(x)
}

/// Natural logarithm.
#[inline]
pub fn ln(x: f32) -> f32 {
    libm::logf(x)
}

/// Natural logarithm in double precision.
#[inline]
pub fn ln_f64(x: f64) -> f64 {
    libm::log(x)
}

/// Base-2 logarithm.
#[inline]
pub fn log2(x: f32) -> f32 {
    libm::log2f(x)
}

/// `x^y`.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    libm::powf(x, y)
}

/// `a . b`, summed left to right: `((ax bx + ay by) + az bz) + aw bw`.
#[inline]
pub fn dot4(a: Vec4, b: Vec4) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w
}

/// The 2x2 minors of a matrix's rows 0-1 (`s`) and rows 2-3 (`c`) that the determinant and
/// the inverse share (Laplace expansion along the first two rows).
#[inline]
fn minors(a: &[[f32; 4]; 4]) -> ([f32; 6], [f32; 6]) {
    let s = [
        a[0][0] * a[1][1] - a[1][0] * a[0][1],
        a[0][0] * a[1][2] - a[1][0] * a[0][2],
        a[0][0] * a[1][3] - a[1][0] * a[0][3],
        a[0][1] * a[1][2] - a[1][1] * a[0][2],
        a[0][1] * a[1][3] - a[1][1] * a[0][3],
        a[0][2] * a[1][3] - a[1][2] * a[0][3],
    ];
    let c = [
        a[2][0] * a[3][1] - a[3][0] * a[2][1],
        a[2][0] * a[3][2] - a[3][0] * a[2][2],
        a[2][0] * a[3][3] - a[3][0] * a[2][3],
        a[2][1] * a[3][2] - a[3][1] * a[2][2],
        a[2][1] * a[3][3] - a[3][1] * a[2][3],
        a[2][2] * a[3][3] - a[3][2] * a[2][3],
    ];
    (s, c)
}

/// The matrix as rows: `a[r][c]` is row `r`, column `c`.
#[inline]
fn rows(m: &Mat4) -> [[f32; 4]; 4] {
    m.transpose().to_cols_array_2d()
}

/// The determinant of `m`, in one fixed order of operations.
pub fn determinant(m: &Mat4) -> f32 {
    let (s, c) = minors(&rows(m));
    s[0] * c[5] - s[1] * c[4] + s[2] * c[3] + s[3] * c[2] - s[4] * c[1] + s[5] * c[0]
}

/// The inverse of `m` (the adjugate over the determinant), in one fixed order of operations;
/// a singular `m` gives non-finite entries, as glam's `inverse` does.
pub fn inverse(m: &Mat4) -> Mat4 {
    let a = rows(m);
    let (s, c) = minors(&a);
    let det = s[0] * c[5] - s[1] * c[4] + s[2] * c[3] + s[3] * c[2] - s[4] * c[1] + s[5] * c[0];
    let k = 1.0 / det;
    // Row r of the inverse.
    let b = [
        [
            a[1][1] * c[5] - a[1][2] * c[4] + a[1][3] * c[3],
            -a[0][1] * c[5] + a[0][2] * c[4] - a[0][3] * c[3],
            a[3][1] * s[5] - a[3][2] * s[4] + a[3][3] * s[3],
            -a[2][1] * s[5] + a[2][2] * s[4] - a[2][3] * s[3],
        ],
        [
            -a[1][0] * c[5] + a[1][2] * c[2] - a[1][3] * c[1],
            a[0][0] * c[5] - a[0][2] * c[2] + a[0][3] * c[1],
            -a[3][0] * s[5] + a[3][2] * s[2] - a[3][3] * s[1],
            a[2][0] * s[5] - a[2][2] * s[2] + a[2][3] * s[1],
        ],
        [
            a[1][0] * c[4] - a[1][1] * c[2] + a[1][3] * c[0],
            -a[0][0] * c[4] + a[0][1] * c[2] - a[0][3] * c[0],
            a[3][0] * s[4] - a[3][1] * s[2] + a[3][3] * s[0],
            -a[2][0] * s[4] + a[2][1] * s[2] - a[2][3] * s[0],
        ],
        [
            -a[1][0] * c[3] + a[1][1] * c[1] - a[1][2] * c[0],
            a[0][0] * c[3] - a[0][1] * c[1] + a[0][2] * c[0],
            -a[3][0] * s[3] + a[3][1] * s[1] - a[3][2] * s[0],
            a[2][0] * s[3] - a[2][1] * s[1] + a[2][2] * s[0],
        ],
    ];
    Mat4::from_cols_array_2d(&b.map(|r| r.map(|v| v * k))).transpose()
}

#[cfg(test)]
#[allow(clippy::disallowed_methods)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3};

    /// The fixed-order inverse inverts: `m^-1 m` is the identity within rounding, and it agrees
    /// with glam's within rounding, for projections, rigid transforms and scales.
    #[test]
    fn inverse_and_determinant_agree_with_glam() {
        let ms = [
            Mat4::perspective_rh(1.0, 1.7, 0.1, 100.0)
                * Mat4::look_at_rh(Vec3::new(3.0, 2.0, 5.0), Vec3::ZERO, Vec3::Y),
            Mat4::orthographic_rh(-4.0, 5.0, -3.0, 2.0, 0.5, 40.0),
            Mat4::from_scale_rotation_translation(
                Vec3::new(2.0, 0.5, 3.0),
                Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
                Vec3::new(-1.0, 4.0, 2.0),
            ),
        ];
        for m in ms {
            let inv = inverse(&m);
            let e = (inv * m - Mat4::IDENTITY).abs().to_cols_array();
            assert!(e.iter().all(|&v| v < 1e-4), "{e:?}");
            let g = m.inverse().to_cols_array();
            for (x, y) in inv.to_cols_array().iter().zip(g) {
                assert!((x - y).abs() <= 1e-4 * y.abs().max(1.0), "{x} vs {y}");
            }
            let (d, dg) = (determinant(&m), m.determinant());
            assert!((d - dg).abs() <= 1e-4 * dg.abs().max(1.0), "{d} vs {dg}");
        }
        assert!(!inverse(&Mat4::ZERO).is_finite());
    }

    /// Known values, bit for bit: these are the musl algorithms' results, the same on every
    /// target (a change of the libm crate that moved them would show here).
    #[test]
    fn transcendentals_give_the_same_bits_everywhere() {
        assert_eq!(acos(0.5).to_bits(), std::f32::consts::FRAC_PI_3.to_bits());
        assert_eq!(sin(0.0), 0.0);
        assert_eq!(cos(0.0), 1.0);
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(ln(1.0), 0.0);
        assert_eq!(log2(8.0), 3.0);
        assert_eq!(powf(2.0, 10.0), 1024.0);
        assert_eq!(sin_cos(0.3), (sin(0.3), cos(0.3)));
        assert_eq!(dot4(Vec4::new(1.0, 2.0, 3.0, 4.0), Vec4::ONE), 10.0);
    }
}
