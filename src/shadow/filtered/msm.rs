//! Moment shadow maps (Peters and Klein 2015; RTR 7.7).
//!
//! Each texel stores four power moments of its linear depth, `b = (z, z^2, z^3, z^4)`. After
//! filtering, `b` is the moment vector of the depth distribution in the kernel, and the
//! Hamburger reconstruction gives the sharpest lower bound on the share of that distribution
//! in front of the receiver's depth `z_f` that any distribution with these moments allows:
//!
//! 1. The moment bias: `b' = (1 - alpha) b + alpha (0.5, 0.5, 0.5, 0.5)`, which keeps the
//!    Hankel matrix below positive definite against rounding (`bias`, MJP's default 3e-6).
//! 2. The 3x3 Hankel matrix `B = [[1, b1, b2], [b1, b2, b3], [b2, b3, b4]]` is factored as
//!    `L D L^T` (Cholesky without square roots), and `B c = (1, z_f, z_f^2)^T` solved by
//!    forward substitution, scaling by `D` and back substitution.
//! 3. The kernel polynomial `c1 + c2 z + c3 z^2` (the quadratic left of the paper's cubic once
//!    its root `z_f` is factored out) has the roots `z2 <= z3`: with `z_f`, the support of the
//!    three-point distribution that has moments `b` and puts the most weight at or behind
//!    `z_f`.
//! 4. Its weights give the bound: 0 where `z_f <= z2`; the weight of `z2`,
//!    `(z_f z3 - b1 (z_f + z3) + b2) / ((z_f - z2)(z3 - z2))`, where `z2 < z_f <= z3`; and one
//!    less the weight of `z_f`, `1 - (z2 z3 - b1 (z2 + z3) + b2) / ((z_f - z2)(z_f - z3))`,
//!    where `z3 < z_f`. The visibility is one less that shadow intensity. Where rounding
//!    leaves `B` singular (the kernel holds one depth to the moments' precision) or a root
//!    falls on `z_f`, the bound is the hard test against the mean depth `b1`. The
//!    reconstruction runs in f64: in f32 its rounding undoes a bias of 3e-6 on kernels of
//!    nearly one depth, and receivers shadow themselves (63 % wrong on `pergola`).
//!
//! Storage (Peters and Klein 2015, sec. 4.3): 128-bit float (`f32`), or the paper's 64-bit
//! quantization (`u16`): the moments go through the paper's affine transform into `[0, 1]`,
//! are stored as 16-bit unorm and transformed back at the lookup (the transform is affine, so
//! filtering the stored values filters the moments).
//!
//! Known failures: with three or more depth layers in the filter's footprint the four moments
//! cannot tell them apart and the bound leaks light (the `stack` fixture: three slabs under a
//! disk light); the 16-bit quantization needs a larger bias and leaks more.

use super::{bleeding_field, build, reduce_bleeding, FilteredPass, Filtering, Moments, Storage};
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::options::within;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;
use glam::{Mat4, Vec2, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "msm",
    family: Family::Filtered,
    summary: "moment shadow map (Peters and Klein 2015): four moments, Hamburger reconstruction: leaks with three or more layers in a kernel",
    sweep: &[&[], &[("storage", "u16"), ("bias", "0.00003")]],
    extended: &[&[("prefilter", "sat")]],
    ..Entry::BASE
};

/// Options of the moment shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass, the prefilter and the channel storage (f32, or u16: the paper's 64-bit
    /// quantization). Default: their defaults (512 texels, 9x9 Gaussian, f32).
    pub filtering: Filtering,
    /// The moment bias alpha, in [0, 1]. Default: 0.000003.
    pub bias: f32,
    /// The receiver's depth moved toward the light (linear depth). Default: 0.
    pub depth_bias: f32,
    /// Light-bleeding reduction amount (0: none). Default: 0.
    pub bleeding: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            filtering: Filtering::default(),
            bias: 0.000003,
            depth_bias: 0.0,
            bleeding: 0.0,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(Filtering::fields(), |o: &mut Options| &mut o.filtering);
    fields.extend([
        Field::range(
            "bias",
            "moment bias alpha: the moments blended toward (0.5, 0.5, 0.5, 0.5)",
            0.0,
            1.0,
            |o: &mut Options| &mut o.bias,
        ),
        Field::range(
            "depth_bias",
            "the receiver's depth moved toward the light, in linear depth",
            0.0,
            1.0,
            |o: &mut Options| &mut o.depth_bias,
        ),
        bleeding_field(|o: &mut Options| &mut o.bleeding),
    ]);
    Declaration::new("msm", fields)
}

/// Peters and Klein 2015, sec. 4.3: the affine transform of the moments `(b1, b2, b3, b4)`
/// into `[0, 1]` for 16-bit quantization (rows: the stored channels), and its offset.
const QUANTIZE: [[f64; 4]; 4] = [
    [-2.07224649, 32.23703778, -68.571074599, 39.3703274134],
    [13.7948857237, -59.4683975703, 82.0359750338, -35.364903257],
    [0.105877704, -1.9077466311, 9.3496555107, -6.6543490743],
    [9.7924062118, -33.7652110555, 47.9456096605, -23.9728048165],
];
const OFFSET: f64 = 0.035955884801;

/// The inverse of a 4x4 matrix by Gauss-Jordan elimination with partial pivoting, in f64
/// (computed once per technique; the same operations on every machine).
fn inverse4(m: [[f64; 4]; 4]) -> [[f64; 4]; 4] {
    let mut a = m;
    let mut inv = [[0.0; 4]; 4];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for c in 0..4 {
        let p = (c..4)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .expect("a row");
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for k in 0..4 {
            a[c][k] /= d;
            inv[c][k] /= d;
        }
        for r in 0..4 {
            if r != c {
                let f = a[r][c];
                for k in 0..4 {
                    a[r][k] -= f * a[c][k];
                    inv[r][k] -= f * inv[c][k];
                }
            }
        }
    }
    inv
}

/// A row-major f64 matrix as glam's `Mat4` (column-major, column vectors).
fn mat4(m: [[f64; 4]; 4]) -> Mat4 {
    Mat4::from_cols_array_2d(&std::array::from_fn(|c| std::array::from_fn(|r| m[r][c] as f32)))
}

/// The four power moments and the Hamburger reconstruction.
#[derive(Clone, Debug, PartialEq)]
pub struct PowerMoments {
    storage: Storage,
    alpha: f32,
    depth_bias: f32,
    bleeding: f32,
    /// The quantization transform and its inverse (u16 storage).
    forward: Mat4,
    back: Mat4,
}

/// Transforms `v` by `m` with a fixed order of operations (column by column), the same on
/// every target.
#[inline(always)]
fn transform(m: &Mat4, v: Vec4) -> Vec4 {
    let c = m.to_cols_array_2d();
    let mut out = [0.0f32; 4];
    for (r, o) in out.iter_mut().enumerate() {
        *o = ((c[0][r] * v.x + c[1][r] * v.y) + c[2][r] * v.z) + c[3][r] * v.w;
    }
    Vec4::from_array(out)
}

impl PowerMoments {
    /// The moments with `alpha`, stored as `storage`.
    fn new(storage: Storage, alpha: f32, depth_bias: f32, bleeding: f32) -> PowerMoments {
        PowerMoments {
            storage,
            alpha,
            depth_bias,
            bleeding,
            forward: mat4(QUANTIZE),
            back: mat4(inverse4(QUANTIZE)),
        }
    }

    /// The shadow intensity (0 = lit) of a receiver at `zf` given moments `b` (biased):
    /// steps 2-4 of the module docs. Returns it with the roots `z2`, `z3`.
    #[inline(always)]
    fn hamburger(b: Vec4, zf: f32, mean: f32) -> (f32, f32, f32) {
        // In f64: the Hankel matrix of a kernel of nearly one depth is within the bias of
        // singular, which f32's rounding in the solve would not keep positive definite.
        let (b1, b2, b3, b4) = (b.x as f64, b.y as f64, b.z as f64, b.w as f64);
        let z = zf as f64;
        // L D L^T of the Hankel matrix.
        let d22 = b2 - b1 * b1;
        let l32 = (b3 - b1 * b2) / d22;
        let d33 = (b4 - b2 * b2) - l32 * l32 * d22;
        // B c = (1, zf, zf^2): forward substitution (L y = rhs), scaling, back substitution.
        let y2 = z - b1;
        let y3 = (z * z - b2) - l32 * y2;
        let (s2, s3) = (y2 / d22, y3 / d33);
        let c3 = s3;
        let c2 = s2 - l32 * c3;
        let c1 = 1.0 - b1 * c2 - b2 * c3;
        // The roots of c1 + c2 z + c3 z^2.
        let p = c2 / c3;
        let q = c1 / c3;
        let r = (0.25 * p * p - q).max(0.0).sqrt();
        let (z2, z3) = (-0.5 * p - r, -0.5 * p + r);
        // Where the bias did not keep the matrix definite (the kernel holds one depth to the
        // moments' precision) or a weight's denominator vanishes: the hard test against the
        // kernel's mean depth, lit where the receiver is at or before it.
        let hard = || if zf > mean { 1.0 } else { 0.0 };
        if !(d22 > 0.0 && d33 > 0.0 && r.is_finite() && c3 != 0.0) {
            return (hard(), mean, mean);
        }
        let shadow = if z <= z2 {
            0.0
        } else if z <= z3 {
            (z * z3 - b1 * (z + z3) + b2) / ((z - z2) * (z3 - z2))
        } else {
            1.0 - (z2 * z3 - b1 * (z2 + z3) + b2) / ((z - z2) * (z - z3))
        };
        if shadow.is_finite() {
            (shadow as f32, z2 as f32, z3 as f32)
        } else {
            (hard(), z2 as f32, z3 as f32)
        }
    }
}

impl Moments for PowerMoments {
    const STORAGES: &'static [Storage] = &[Storage::F32, Storage::U16];

    fn planes(&self) -> usize {
        1
    }

    fn channels(&self) -> Vec<String> {
        let q = if self.storage == Storage::U16 { "q" } else { "b" };
        (1..=4).map(|i| format!("{q}{i}")).collect()
    }

    fn storage(&self) -> Storage {
        self.storage
    }

    fn encode(&self, t: f32, _: Vec2, out: &mut [Vec4]) {
        let t2 = t * t;
        let b = Vec4::new(t, t2, t2 * t, t2 * t2);
        out[0] = if self.storage == Storage::U16 {
            transform(&self.forward, b) + Vec4::new(OFFSET as f32, 0.0, 0.0, 0.0)
        } else {
            b
        };
    }

    fn visibility(&self, m: &[Vec4], t: f32, tr: &mut impl Trace) -> f32 {
        let stored = m[0];
        let b = if self.storage == Storage::U16 {
            transform(&self.back, stored - Vec4::new(OFFSET as f32, 0.0, 0.0, 0.0))
        } else {
            stored
        };
        // Step 1: the moment bias.
        let biased = b * (1.0 - self.alpha) + Vec4::splat(0.5 * self.alpha);
        let zf = t - self.depth_bias;
        let (shadow, z2, z3) = Self::hamburger(biased, zf, b.x);
        let v = reduce_bleeding(1.0 - shadow.clamp(0.0, 1.0), self.bleeding);
        tr.step(|| {
            Step::new(
                "hamburger reconstruction",
                "the biased moments' Hankel matrix solved by L D L^T against (1, z, z^2); the kernel polynomial's roots and the three-point distribution's weights bound the shadow",
            )
            .vec3("biased moments b1..b3", biased.truncate())
            .num("biased moment b4", biased.w)
            .num("receiver depth", zf)
            .num("root z2", z2)
            .num("root z3", z3)
            .num("shadow intensity", shadow)
        });
        v
    }
}

/// The moment shadow map (see the module docs).
pub type Msm = PassTechnique<FilteredPass<PowerMoments>>;

impl Msm {
    /// A moment shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Msm, Error> {
        build(declaration(), &opts, &opts.filtering, None, |_| {
            Ok(PowerMoments::new(
                opts.filtering.storage,
                opts.bias,
                opts.depth_bias,
                opts.bleeding,
            ))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_quantization_transform_round_trips_and_stays_in_unit_range() {
        let m = PowerMoments::new(Storage::U16, 0.0, 0.0, 0.0);
        for i in 0..=20 {
            let t = i as f32 / 20.0;
            let mut out = [Vec4::ZERO];
            m.encode(t, Vec2::ZERO, &mut out);
            assert!(
                out[0].cmpge(Vec4::splat(-1e-4)).all() && out[0].cmple(Vec4::splat(1.0 + 1e-4)).all(),
                "{t}: {}",
                out[0]
            );
            let back = transform(&m.back, out[0] - Vec4::new(OFFSET as f32, 0.0, 0.0, 0.0));
            let t2 = t * t;
            let want = Vec4::new(t, t2, t2 * t, t2 * t2);
            assert!((back - want).abs().max_element() < 2e-4, "{t}: {back} vs {want}");
        }
    }

    #[test]
    fn one_occluder_depth_is_reconstructed_as_a_hard_test() {
        // All texels at depth 0.4: receivers in front lit, behind shadowed.
        let m = PowerMoments::new(Storage::F32, 3e-6, 0.0, 0.0);
        let z = 0.4f32;
        let b = [Vec4::new(z, z * z, z * z * z, z * z * z * z)];
        let mut t = crate::shadow::inspect::NoTrace;
        assert!(m.visibility(&b, 0.3, &mut t) > 0.99);
        assert!(m.visibility(&b, 0.6, &mut t) < 0.02);
        // Two depths, 0.2 and 0.7 in equal shares: between them half the light is blocked
        // at most; behind both, all.
        let mix = |z: f32| Vec4::new(z, z * z, z * z * z, z * z * z * z) * 0.5;
        let b = [mix(0.2) + mix(0.7)];
        let between = m.visibility(&b, 0.5, &mut t);
        assert!((0.4..=0.6).contains(&between), "{between}");
        assert!(m.visibility(&b, 0.9, &mut t) < 0.05);
    }
}
