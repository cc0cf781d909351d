//! Stage 6, four fragments at a time: the shaded path of [`super::fragment`] for draws that
//! need nothing serial per pixel (no stencil, no fragment lists, a program that cannot
//! discard). A triangle's row span is cut into runs of four consecutive pixels; depth is
//! tested lane by lane, and the run is shaded by [`FragmentProgram::shade4`] in
//! structure-of-arrays form (one `Vec4` lane per pixel), then stored.
//!
//! Every lane computes exactly what the one-pixel path computes, in the same operation order
//! (mul then add, no FMA), so images are bit-identical whichever path runs; a program that
//! overrides `shade4` promises the same of itself (tests check the bundled ones).

use super::fragment::{blend_masked, ColorFormat, Fragment, FragmentProgram, RawTargets};
use super::setup::{SetupTri, TilePlane};
use super::state::{BlendMode, CompareFunc, DepthFormat, RenderState};
use super::vertex::Varyings;
use super::DrawStats;
use glam::{BVec4A, Vec3, Vec4};

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

/// Four RGBA colours in structure-of-arrays form: what [`FragmentProgram::shade4`] returns.
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

/// Four floats from `p` (unaligned).
///
/// # Safety
/// `p .. p + 4` is readable.
#[inline(always)]
unsafe fn load4(p: *const f32) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        Vec4::from(unsafe { std::arch::x86_64::_mm_loadu_ps(p) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Vec4::from_array(unsafe { std::ptr::read_unaligned(p as *const [f32; 4]) })
    }
}

/// Four floats to `p` (unaligned).
///
/// # Safety
/// `p .. p + 4` is writable and not aliased.
#[inline(always)]
unsafe fn store4(p: *mut f32, v: Vec4) {
    #[cfg(target_arch = "x86_64")]
    {
        unsafe { std::arch::x86_64::_mm_storeu_ps(p, v.into()) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        unsafe { std::ptr::write_unaligned(p as *mut [f32; 4], v.to_array()) }
    }
}

/// Lanes of `v` outside `bits` replaced by lane `first` (a lane inside `bits`).
#[inline(always)]
fn fill_off_lanes(v: Vec4, bits: u8, first: usize) -> Vec4 {
    Vec4::select(lane_mask(bits), v, Vec4::splat(v.to_array()[first]))
}

/// What [`shade_row4`] needs of the triangle, re-based at the tile origin.
pub(crate) struct WideTri<'a, V> {
    pub tri: &'a SetupTri,
    pub persp: [TilePlane; 3],
    pub var: &'a [V; 3],
    pub zp: TilePlane,
}

impl<V> WideTri<'_, V> {
    /// Depth of the lanes at tile-local columns `lx` and rows `ly`, by the formula of every
    /// path, lane by lane: `clamp(((c + dz/dy * ly) + offset) + dz/dx * lx, 0, 1)` (float depth;
    /// other formats quantize after).
    #[inline(always)]
    pub fn depth4(&self, lx: Vec4, ly: Vec4) -> Vec4 {
        let zrow = (Vec4::splat(self.zp.c) + Vec4::splat(self.zp.dy) * ly) + Vec4::splat(self.tri.z_offset);
        clamp01(zrow + Vec4::splat(self.zp.dx) * lx)
    }
}

/// What [`shade_row4`] needs of the render state, derived once per tile.
pub(crate) struct WideState {
    func: CompareFunc,
    fmt: DepthFormat,
    depth_test: bool,
    depth_write: bool,
    /// Replace with every channel written: texels are stored without reading them.
    replace: bool,
    blend: BlendMode,
    mask: [bool; 4],
}

impl WideState {
    pub fn new(state: &RenderState) -> Self {
        let mask = state.color_mask.0;
        WideState {
            func: state.depth.func,
            fmt: state.depth.format,
            depth_test: state.depth.func != CompareFunc::Always,
            depth_write: state.depth.write,
            replace: state.blend == BlendMode::Replace && mask == [true; 4],
            blend: state.blend,
            mask,
        }
    }
}

/// Shades the span `lo..=hi` of tile row `ly` four pixels at a time: depth test and write per
/// lane, [`FragmentProgram::shade4`] on the lanes that passed, then blend and store. Only for
/// draws without stencil, lists or discard (the caller checks).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn shade_row4<V: Varyings, P: FragmentProgram<V>, C: ColorFormat>(
    t: &WideTri<V>,
    origin: (i32, i32),
    (ly, lo, hi): (i32, u32, u32),
    tw: u32,
    st: &WideState,
    targets: &RawTargets<C>,
    program: &P,
    stats: &mut DrawStats,
) {
    let (ox, oy) = origin;
    let y = oy + ly;
    let lyf = ly as f32;
    let depth = targets.depth.as_ref();
    let ramp = Vec4::new(0.0, 1.0, 2.0, 3.0);
    let mut c = lo;
    while c <= hi {
        let n = (hi - c + 1).min(4);
        let live = ((1u32 << n) - 1) as u8;
        let lx = Vec4::splat(c as f32) + ramp;
        let x0 = ox + c as i32;
        let mut z = t.depth4(lx, Vec4::splat(lyf));
        if st.fmt != DepthFormat::F32 {
            z = Vec4::from_array(z.to_array().map(|v| st.fmt.quantize(v)));
        }
        let mut pass = live;
        // SAFETY (all target accesses below): pixels x0 .. x0 + 4 of row y lie in this
        // worker's tile when `in_tile`, else only live lanes (c + i <= hi) are touched.
        let in_tile = c + 3 < tw;
        if let Some(d) = depth {
            let row = unsafe { d.ptr.add(y as usize * d.stride + x0 as usize) };
            let dv = if in_tile {
                unsafe { load4(row) }
            } else {
                Vec4::from_array(std::array::from_fn(|i| {
                    if i < n as usize {
                        unsafe { *row.add(i) }
                    } else {
                        0.0
                    }
                }))
            };
            if st.depth_test {
                pass &= st.func.test4(z, dv).bitmask() as u8;
            }
            if st.depth_write && pass != 0 {
                let out = Vec4::select(lane_mask(pass), z, dv);
                if in_tile {
                    unsafe { store4(row, out) };
                } else {
                    for (i, &v) in out.to_array().iter().enumerate().take(n as usize) {
                        unsafe { *row.add(i) = v };
                    }
                }
            }
        }
        let np = pass.count_ones() as u64;
        stats.early_z_killed += n as u64 - np;
        if pass != 0 {
            stats.fragments_passed += np;
            let xs = std::array::from_fn(|i| (x0 + i as i32) as u32);
            let frag = fragment4(t, (xs, [y as u32; 4]), (lx, Vec4::splat(lyf)), z, pass);
            shade_fragment4(&frag, Stores::Masked, st, targets, program, stats);
        }
        c += 4;
    }
}

/// The lanes `pass` (non-empty) of triangle `t` at pixels (`x[i]`, `y[i]`) as a
/// [`Fragment4`]: `lx` and `ly` are the lanes' tile-local column and row (as floats), `z` the
/// lanes' depth. Barycentrics come from the triangle's planes at each pixel, so a lane's values
/// depend only on its pixel, never on which lanes share the group. Off lanes get the first
/// live lane's values.
#[inline(always)]
pub(crate) fn fragment4<'a, V: Varyings>(
    t: &WideTri<'a, V>,
    xy: ([u32; 4], [u32; 4]),
    lxy: (Vec4, Vec4),
    z: Vec4,
    pass: u8,
) -> Fragment4<'a, V> {
    let mut f = fragment4_at(t, xy, lxy, z, pass);
    let first = pass.trailing_zeros() as usize;
    f.z = fill_off_lanes(f.z, pass, first);
    if !V::EMPTY {
        f.bary = f.bary.map(|b| fill_off_lanes(b, pass, first));
    }
    f
}

/// [`fragment4`] for lanes whose off lanes already repeat the first lane's pixel (so their
/// values are the first lane's without a copy).
#[inline(always)]
pub(crate) fn fragment4_at<'a, V: Varyings>(
    t: &WideTri<'a, V>,
    (x, y): ([u32; 4], [u32; 4]),
    (lx, ly): (Vec4, Vec4),
    z: Vec4,
    pass: u8,
) -> Fragment4<'a, V> {
    let bary = if V::EMPTY {
        [Vec4::ONE, Vec4::ZERO, Vec4::ZERO]
    } else {
        // The one-pixel path's `w = 1 / p0`, `b1 = p1 * w`, `b2 = p2 * w`, `1 - b1 - b2`, with
        // each plane evaluated as `(c + dx * lx) + dy * ly`.
        let at = |p: &TilePlane| Vec4::splat(p.c) + Vec4::splat(p.dx) * lx + Vec4::splat(p.dy) * ly;
        let w = Vec4::ONE / at(&t.persp[0]);
        let b1 = at(&t.persp[1]) * w;
        let b2 = at(&t.persp[2]) * w;
        [Vec4::ONE - b1 - b2, b1, b2]
    };
    Fragment4 {
        x,
        y,
        mask: pass,
        z,
        bary,
        verts: t.var,
        front: t.tri.front,
        prim: t.tri.prim,
    }
}

/// How [`shade_fragment4`] stores a group's colours with `Replace` blending.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Stores {
    /// Off lanes are other pixels: only live lanes are stored (four consecutive live pixels
    /// of a row in one store).
    Masked,
    /// Off lanes are the first lane's pixel again (as [`fragment4_at`] takes them): four
    /// stores, no branch (an off lane's store comes before the first lane's).
    Scatter,
    /// As `Scatter`, but four consecutive pixels of a row go in one store: for groups that
    /// mostly are such runs (large triangles), where the test predicts well.
    Runs,
}

/// Runs the program on `frag`'s live lanes and blends and stores their colours.
#[inline(always)]
pub(crate) fn shade_fragment4<V: Varyings, P: FragmentProgram<V>, C: ColorFormat>(
    frag: &Fragment4<V>,
    stores: Stores,
    st: &WideState,
    targets: &RawTargets<C>,
    program: &P,
    stats: &mut DrawStats,
) {
    let pass = frag.mask;
    let (x0, y) = (frag.x[0] as i32, frag.y[0] as i32);
    // Four consecutive pixels of one row: one store.
    let run = stores != Stores::Scatter && pass == 0xf && frag.y[3] == frag.y[0] && frag.x[3] == frag.x[0] + 3;
    stats.fragments_shaded += pass.count_ones() as u64;
    let col = program.shade4(frag);
    let Some(ct) = targets.color.as_ref() else {
        return;
    };
    if st.replace {
        let texels = C::from_color4(&col);
        if run {
            // SAFETY: all four lanes are live, so the four pixels are in this worker's tile.
            unsafe {
                let dst = ct.ptr.add(y as usize * ct.stride + x0 as usize);
                std::ptr::copy_nonoverlapping(texels.as_ptr(), dst, 4);
            }
        } else {
            // Last lane first: an off lane of `Scatter` or `Runs` holds the first lane's pixel
            // with a colour that may be anything (programs may skip off lanes); the first
            // lane's own store comes after it.
            for (i, &tx) in texels.iter().enumerate().rev() {
                if stores != Stores::Masked || pass & (1 << i) != 0 {
                    // SAFETY: lanes are pixels of this worker's tile (off lanes of `Scatter`
                    // and `Runs` are the first lane's pixel).
                    unsafe { ct.set(frag.x[i] as i32, frag.y[i] as i32, tx) };
                }
            }
        }
    } else {
        for i in 0..4 {
            if pass & (1 << i) == 0 {
                continue;
            }
            let (x, y, src) = (frag.x[i] as i32, frag.y[i] as i32, col.lane(i));
            // SAFETY: as above.
            let out = blend_masked(st.blend, st.mask, src, unsafe { ct.get(x, y) }.to_vec4());
            unsafe { ct.set(x, y, C::from_vec4(out)) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Rgba8;

    /// Awkward values: signed zeros, NaN, infinities, tiny, huge, ties and plain numbers.
    fn values() -> Vec<f32> {
        let mut v = vec![
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-40,
            -1e-40,
            1e30,
            -1e30,
            0.5,
            -0.5,
            1.5,
            2.5,
            8_388_607.5,
            -8_388_608.5,
            3e9,
            0.5 / 255.0,
            1.0,
            255.5 / 255.0,
        ];
        let mut rng = crate::hash::SplitMix(3);
        v.extend((0..200).map(|_| rng.next_f32() * 4.0 - 2.0));
        v
    }

    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    #[test]
    fn lane_helpers_equal_their_scalar_counterparts() {
        let v = values();
        for w in v.chunks(4).filter(|w| w.len() == 4) {
            let x = Vec4::from_slice(w);
            for (i, &wi) in w.iter().enumerate() {
                assert!(same(floor4(x).to_array()[i], wi.floor()), "floor {wi}");
                assert!(same(clamp01(x).to_array()[i], wi.clamp(0.0, 1.0)), "clamp {wi}");
                assert!(same(sqrt4(x).to_array()[i], wi.sqrt()), "sqrt {wi}");
                let idx = index4(floor4(x), 37)[i];
                assert_eq!(idx, (wi.floor() as i64).clamp(0, 37) as usize, "index {wi}");
            }
        }
        for bits in 0..16u8 {
            let m = lane_mask(bits).bitmask() as u8;
            assert_eq!(m, bits);
        }
    }

    #[test]
    fn vec3x4_matches_glam_vec3() {
        let v = values();
        let l = Vec3::new(0.3, -0.8, 0.52).normalize();
        for w in v.chunks(12).filter(|w| w.len() == 12) {
            let lanes: [Vec3; 4] = std::array::from_fn(|i| Vec3::new(w[i], w[4 + i], w[8 + i]));
            let s = Vec3x4 {
                x: Vec4::from_slice(&w[0..4]),
                y: Vec4::from_slice(&w[4..8]),
                z: Vec4::from_slice(&w[8..12]),
            };
            let n = s.normalize_or_zero();
            let d = s.dot(l);
            for (i, a) in lanes.iter().enumerate() {
                let e = a.normalize_or_zero();
                assert!(same(n.x.to_array()[i], e.x) && same(n.y.to_array()[i], e.y) && same(n.z.to_array()[i], e.z));
                assert!(same(d.to_array()[i], a.dot(l)));
            }
        }
        // Zero, infinite and NaN vectors normalize to zero.
        let s = Vec3x4 {
            x: Vec4::new(0.0, f32::INFINITY, f32::NAN, 1e-30),
            y: Vec4::ZERO,
            z: Vec4::ZERO,
        };
        let n = s.normalize_or_zero();
        assert_eq!(n.x.to_array()[..3], [0.0; 3]);
    }

    #[test]
    fn rgba8_four_lanes_equal_one_lane() {
        let v = values();
        for w in v.chunks(16).filter(|w| w.len() == 16) {
            let c = Color4 {
                r: Vec4::from_slice(&w[0..4]),
                g: Vec4::from_slice(&w[4..8]),
                b: Vec4::from_slice(&w[8..12]),
                a: Vec4::from_slice(&w[12..16]),
            };
            let four = Rgba8::from_color4(&c);
            for (i, t) in four.iter().enumerate() {
                assert_eq!(*t, Rgba8::from_vec4(c.lane(i)), "{:?}", c.lane(i));
            }
            let back = Color4::from_lanes(std::array::from_fn(|i| c.lane(i)));
            for (x, y) in [(back.r, c.r), (back.g, c.g), (back.b, c.b), (back.a, c.a)] {
                assert!((0..4).all(|i| same(x.to_array()[i], y.to_array()[i])));
            }
        }
    }
}
