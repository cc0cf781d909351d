//! Stage 6, four fragments at a time: the shaded path of [`super::fragment`] for draws that
//! need nothing serial per pixel (no stencil, no fragment lists, a program that cannot
//! discard). A triangle's row span is cut into runs of four consecutive pixels; depth is
//! tested lane by lane, and the run is shaded by [`FragmentProgram::shade4`] in
//! structure-of-arrays form (one `Vec4` lane per pixel), then stored.
//!
//! Every lane computes exactly what the one-pixel path computes, in the same operation order
//! (mul then add, no FMA), so images are bit-identical whichever path runs; a program that
//! overrides `shade4` promises the same of itself (tests check the bundled ones).

use super::lanes::{clamp01, lane_mask, Fragment4};
use super::program::{blend_masked, ColorFormat, FragmentProgram, RawTargets};
use super::setup::{SetupTri, TilePlane};
use super::state::{BlendMode, CompareFunc, DepthFormat, RenderState};
use super::stats::DrawStats;
use super::vertex::Varyings;
use glam::Vec4;

/// Four floats from `p` (unaligned).
///
/// # Safety
/// `p .. p + 4` is readable.
#[inline(always)]
unsafe fn load4(p: *const f32) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: the caller guarantees `p .. p + 4` is readable; the load is unaligned.
        Vec4::from(unsafe { std::arch::x86_64::_mm_loadu_ps(p) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        // SAFETY: the caller guarantees `p .. p + 4` is readable; the read is unaligned.
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
        // SAFETY: the caller guarantees `p .. p + 4` is writable and unaliased; the store is unaligned.
        unsafe { std::arch::x86_64::_mm_storeu_ps(p, v.into()) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        // SAFETY: the caller guarantees `p .. p + 4` is writable and unaliased; the write is unaligned.
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
            // SAFETY: pixel x0 of row y is a live lane's, in this worker's tile (above).
            let row = unsafe { d.ptr.add(y as usize * d.stride + x0 as usize) };
            let dv = if in_tile {
                // SAFETY: `in_tile`: the four pixels lie in this worker's tile row.
                unsafe { load4(row) }
            } else {
                Vec4::from_array(std::array::from_fn(|i| {
                    if i < n as usize {
                        // SAFETY: lane i < n is live, so its pixel lies in the tile row.
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
                    // SAFETY: `in_tile`: the four pixels lie in this worker's tile row.
                    unsafe { store4(row, out) };
                } else {
                    for (i, &v) in out.to_array().iter().enumerate().take(n as usize) {
                        // SAFETY: lane i < n is live, so its pixel lies in the tile row.
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
            // SAFETY: a live lane's pixel, in this worker's tile.
            unsafe { ct.set(x, y, C::from_vec4(out)) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::lanes::*;
    use crate::pipeline::Rgba8;
    use glam::Vec3;

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
