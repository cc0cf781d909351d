//! Stage 1, vertex: user programs map each input vertex to a clip-space position and varyings.
//!
//! Programs are Rust types implementing [`VertexProgram`]; the pipeline is generic over them,
//! so each draw is monomorphised and the hot loops have no dynamic dispatch.

use glam::{Mat4, Vec2, Vec3, Vec4};

/// Values interpolated across a triangle (perspective-correct).
pub trait Varyings: Copy + Default + Send + Sync + 'static {
    /// `a * w[0] + b * w[1] + c * w[2]`.
    fn combine(a: &Self, b: &Self, c: &Self, w: [f32; 3]) -> Self;
    /// `a + (b - a) * t`, used by the clipper.
    fn lerp(a: &Self, b: &Self, t: f32) -> Self {
        Self::combine(a, b, a, [1.0 - t, t, 0.0])
    }
    /// True when there is nothing to interpolate (lets the pipeline skip the work).
    const EMPTY: bool = false;
}

impl Varyings for () {
    #[inline(always)]
    fn combine(_: &(), _: &(), _: &(), _: [f32; 3]) {}
    const EMPTY: bool = true;
}

macro_rules! linear_varyings {
    ($($t:ty),*) => {$(
        impl Varyings for $t {
            #[inline(always)]
            fn combine(a: &Self, b: &Self, c: &Self, w: [f32; 3]) -> Self {
                *a * w[0] + *b * w[1] + *c * w[2]
            }
        }
    )*};
}
linear_varyings!(f32, Vec2, Vec3, Vec4);

macro_rules! array_varyings {
    ($($n:literal),*) => {$(
        impl Varyings for [f32; $n] {
            #[inline(always)]
            fn combine(a: &Self, b: &Self, c: &Self, w: [f32; 3]) -> Self {
                std::array::from_fn(|i| a[i] * w[0] + b[i] * w[1] + c[i] * w[2])
            }
        }
    )*};
}
array_varyings!(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16);

impl<A: Varyings, B: Varyings> Varyings for (A, B) {
    #[inline(always)]
    fn combine(a: &Self, b: &Self, c: &Self, w: [f32; 3]) -> Self {
        (A::combine(&a.0, &b.0, &c.0, w), B::combine(&a.1, &b.1, &c.1, w))
    }
}

impl<A: Varyings, B: Varyings, C: Varyings> Varyings for (A, B, C) {
    #[inline(always)]
    fn combine(a: &Self, b: &Self, c: &Self, w: [f32; 3]) -> Self {
        (
            A::combine(&a.0, &b.0, &c.0, w),
            B::combine(&a.1, &b.1, &c.1, w),
            C::combine(&a.2, &b.2, &c.2, w),
        )
    }
}

/// A vertex program: one input vertex to clip-space position plus varyings.
pub trait VertexProgram: Sync {
    /// The input vertex type.
    type In: Sync;
    /// The varyings handed to the fragment program.
    type Out: Varyings;
    /// Runs the program on one vertex: (clip position, varyings). Must be a pure function of
    /// `v`: the pipeline may run it more than once per vertex (draws that share no vertices
    /// run it during set-up, and again for a triangle that needs clipping).
    fn run(&self, v: &Self::In) -> (Vec4, Self::Out);
}

/// The simplest program: positions times one matrix, no varyings (depth-only passes).
#[derive(Copy, Clone, Debug)]
pub struct TransformPositions(pub Mat4);

impl VertexProgram for TransformPositions {
    type In = Vec3;
    type Out = ();
    #[inline(always)]
    fn run(&self, v: &Vec3) -> (Vec4, ()) {
        (self.0 * v.extend(1.0), ())
    }
}

/// Positions already in clip space, passed through with no varyings.
#[derive(Copy, Clone, Debug, Default)]
pub struct ClipPassthrough;

impl VertexProgram for ClipPassthrough {
    type In = Vec4;
    type Out = ();
    #[inline(always)]
    fn run(&self, v: &Vec4) -> (Vec4, ()) {
        (*v, ())
    }
}

/// Transforms homogeneous positions (`w = 0`: points at infinity, as shadow volumes and planar
/// projections use them) by a matrix; no varyings.
#[derive(Copy, Clone, Debug)]
pub struct TransformHomogeneous(pub Mat4);

impl VertexProgram for TransformHomogeneous {
    type In = Vec4;
    type Out = ();
    #[inline(always)]
    fn run(&self, v: &Vec4) -> (Vec4, ()) {
        (self.0 * *v, ())
    }
}
