//! Percentage-closer filtering kernels shared by the shadow-map family (RTR 7.5; the CS300 and
//! Cesium slides): every kernel compares first and filters the 0/1 results, except
//! [`Pattern::DepthBilinear`], which filters the depths and compares once, the wrong way the
//! Cesium slides show ("not exactly correct"), kept so that the difference can be seen.
//!
//! - **Grid** and **tent**: `n x n` hardware 2x2 comparisons (bilinear taps) at whole-texel
//!   offsets `-(n/2)..=n/2`, equally weighted (box) or weighted `n/2 + 1 - |k|` per axis (tent).
//!   All taps share one bilinear fraction, so the sum collapses to `(n + 1)^2` texel
//!   comparisons with separable weights: a gather of 2x2 texels serves four taps, as
//!   `textureGather` does (16 texels in 4 gathers for a 4x4 footprint).
//! - **Poisson**: taps of a Poisson disk of radius `r` texels, each a hardware 2x2 comparison;
//!   16 taps are the disk commonly used with PCSS, other counts a best-candidate disk from a
//!   fixed seed. **Rotated**: the same disk rotated per pixel by an angle hashed from the
//!   pixel's coordinates (aliasing turned into noise; never a thread-local random generator).
//!   **Spiral**: a Vogel (golden-angle) spiral rotated by Jimenez's interleaved gradient noise
//!   of the pixel, "halfway between dithering and random" (RTR 7.6, Jimenez 2014).
//! - **Bias across the kernel**: with a receiver-plane gradient (Isidoro 2006) each tap
//!   compares against the receiver's plane at its offset, `z + dz/dtexel . offset`; with the
//!   bias cone (Burley 2006, RTR fig. 7.24) against `z` moved toward the light in proportion to
//!   the tap's distance from the centre.
//!
//! - **Four pixels at once**: [`Disk4`] and [`filter_disk4`] (disks), [`separable4`] (flat
//!   grids and tents) run four pixels' kernels on four lanes, each lane with the one-pixel
//!   path's operations in its order, so each value is that path's bit for bit.
//!
//! A filter returns `lit / total`, the lit weights summed in the same order as all weights
//! (and a 2x2 comparison of four passing texels is exactly 1), so a kernel whose taps all pass
//! returns exactly 1 and one whose taps all fail exactly 0: the hierarchy's classification
//! ([`super::planes::PlaneChain`]) can skip the taps and still give the identical result.

use crate::choice_enum;
use crate::hash::SplitMix;
use crate::math;
use crate::pipeline::compute::min_max_chains;
use crate::pipeline::sampler::{footprint, sample_bilinear, Address, CompareSampler};
use crate::pipeline::{MipChain, Pipeline, Surface};
use crate::shadow::inspect::{Step, Trace};
use glam::{Vec2, Vec4};
use std::sync::OnceLock;

choice_enum! {
    /// The sampling pattern of a PCF kernel.
    pub enum Pattern {
        /// Bilinear filtering of the depths, then one comparison (wrong: shown for contrast).
        DepthBilinear = "depth-bilinear",
        /// `n x n` bilinear taps at whole-texel offsets, equal weights (box).
        Grid = "grid",
        /// `n x n` bilinear taps weighted by a tent per axis.
        Tent = "tent",
        /// A fixed Poisson disk of bilinear taps.
        Poisson = "poisson",
        /// The Poisson disk rotated per pixel by a hashed angle.
        Rotated = "rotated",
        /// A Vogel spiral rotated by interleaved gradient noise (Jimenez 2014).
        Spiral = "spiral",
    }
}

/// Most taps a kernel may have.
pub const MAX_TAPS: u32 = 256;

/// The 16-point Poisson disk commonly used with PCSS (in [-1, 1]^2; a few points lie beyond
/// the unit circle, as in the original set).
pub const POISSON16: [Vec2; 16] = [
    Vec2::new(-0.942_016_24, -0.399_062_16),
    Vec2::new(0.945_586_1, -0.768_907_25),
    Vec2::new(-0.094_184_1, -0.929_388_7),
    Vec2::new(0.344_959_38, 0.293_877_6),
    Vec2::new(-0.915_885_8, 0.457_714_32),
    Vec2::new(-0.815_442_3, -0.879_124_64),
    Vec2::new(-0.382_775_43, 0.276_768_45),
    Vec2::new(0.974_844, 0.756_483_8),
    Vec2::new(0.443_233_25, -0.975_115_54),
    Vec2::new(0.537_429_8, -0.473_734_2),
    Vec2::new(-0.264_969_1, -0.418_930_23),
    Vec2::new(0.791_975_14, 0.190_901_88),
    Vec2::new(-0.241_888_4, 0.997_065_07),
    Vec2::new(-0.814_099_55, 0.914_375_9),
    Vec2::new(0.199_841_26, 0.786_413_7),
    Vec2::new(0.143_831_61, -0.141_007_9),
];

/// A Poisson disk of `n` points in the unit disk: [`POISSON16`] for 16, otherwise Mitchell's
/// best-candidate algorithm (each point the farthest of `10 k` uniform candidates from the
/// points so far) from a fixed seed, so the same on every run and machine.
pub fn poisson_disk(n: u32) -> &'static [Vec2] {
    // One disk per count, built on first use (a best-candidate disk of 256 points takes a
    // while; the counts nobody asks for cost nothing).
    static DISKS: [OnceLock<Vec<Vec2>>; MAX_TAPS as usize + 1] = [const { OnceLock::new() }; MAX_TAPS as usize + 1];
    let n = n.min(MAX_TAPS);
    DISKS[n as usize].get_or_init(|| {
        if n == 16 {
            POISSON16.to_vec()
        } else {
            best_candidate(n as usize)
        }
    })
}

fn best_candidate(n: usize) -> Vec<Vec2> {
    let mut rng = SplitMix(0x5eed_d15c + n as u64);
    let mut pts: Vec<Vec2> = Vec::with_capacity(n);
    let mut point = || loop {
        let p = Vec2::new(rng.next_f32(), rng.next_f32()) * 2.0 - Vec2::ONE;
        if p.length_squared() <= 1.0 {
            return p;
        }
    };
    while pts.len() < n {
        let k = pts.len();
        let mut best = (point(), -1.0f32);
        for _ in 0..(10 * k).max(1) {
            let c = point();
            let d = pts.iter().map(|q| q.distance_squared(c)).fold(f32::INFINITY, f32::min);
            if d > best.1 {
                best = (c, d);
            }
        }
        pts.push(best.0);
    }
    pts
}

/// Jimenez's interleaved gradient noise of pixel `(x, y)`, in [0, 1) (Jimenez 2014).
pub fn interleaved_gradient_noise(x: u32, y: u32) -> f32 {
    let f = 0.067_110_56 * x as f32 + 0.005_837_15 * y as f32;
    (52.982_918 * f.fract()).fract()
}

/// A rotation angle in [0, 2 pi) hashed from pixel `(x, y)` (SplitMix64 of its coordinates).
pub fn pixel_angle(x: u32, y: u32) -> f32 {
    SplitMix(((y as u64) << 32) | x as u64).next_f32() * std::f32::consts::TAU
}

/// The `n`-point Vogel spiral unturned (`phi = 0`), computed once per count.
pub fn spiral(n: u32) -> &'static [Vec2] {
    static SPIRALS: OnceLock<Vec<Vec<Vec2>>> = OnceLock::new();
    let all = SPIRALS.get_or_init(|| {
        (0..=MAX_TAPS)
            .map(|n| (0..n).map(|i| vogel(i, n, 0.0)).collect())
            .collect()
    });
    &all[n.min(MAX_TAPS) as usize]
}

/// Point `i` of an `n`-point Vogel spiral in the unit disk turned by `phi`.
pub fn vogel(i: u32, n: u32, phi: f32) -> Vec2 {
    const GOLDEN_ANGLE: f32 = 2.399_963_2;
    let r = ((i as f32 + 0.5) / n as f32).sqrt();
    let a = i as f32 * GOLDEN_ANGLE + phi;
    Vec2::new(math::cos(a), math::sin(a)) * r
}

/// What each tap compares against: the centre's depth, the receiver plane's depth change per
/// texel of offset, and the bias cone's depth change per texel of distance from the centre.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Reference {
    /// Reference depth at the kernel's centre.
    pub z: f32,
    /// Receiver-plane depth gradient, per texel in x and y (Isidoro 2006).
    pub gradient: Vec2,
    /// Bias cone: depth added per texel of distance from the centre (negative: toward the
    /// light).
    pub cone: f32,
}

impl Reference {
    /// A plain reference depth.
    pub fn flat(z: f32) -> Reference {
        Reference {
            z,
            ..Default::default()
        }
    }

    /// Whether every tap compares against the same depth: [`Reference::at`] adds only zeros
    /// then, so loops may compare against `z`.
    #[inline]
    pub fn is_flat(&self) -> bool {
        self.gradient == Vec2::ZERO && self.cone == 0.0
    }

    /// The reference depth of a tap `d` texels from the centre.
    #[inline]
    pub fn at(&self, d: Vec2) -> f32 {
        let plane = self.z + self.gradient.dot(d);
        // Without a cone its term is a zero (left out: only a zero's sign could differ, which
        // no comparison sees).
        if self.cone == 0.0 {
            return plane;
        }
        plane + self.cone * d.length()
    }

    /// The lowest and highest reference over a kernel of radius `r` texels.
    pub fn range(&self, r: f32) -> (f32, f32) {
        let spread = self.gradient.x.abs() * r + self.gradient.y.abs() * r;
        let cone = self.cone * r * std::f32::consts::SQRT_2;
        (self.z - spread + cone.min(0.0), self.z + spread + cone.max(0.0))
    }
}

/// A PCF kernel: pattern, tap count (Poisson family) and size.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Kernel {
    /// Sampling pattern.
    pub pattern: Pattern,
    /// Taps of the Poisson, rotated and spiral patterns.
    pub taps: u32,
    /// Width in texels: grid and tent use `n` taps per axis, the nearest odd whole number at or
    /// above 1; the disks have radius `width / 2`.
    pub width: f32,
}

/// One filtered lookup: the visibility and the work it did.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Filtered {
    /// Fraction of the kernel lit.
    pub value: f32,
    /// Bilinear taps (hardware 2x2 comparisons, or one bilinear depth fetch).
    pub taps: u32,
}

impl Kernel {
    /// Taps per axis of the grid and tent patterns: the nearest odd whole number to `width`,
    /// at least 1.
    pub fn grid_n(&self) -> u32 {
        let n = self.width.round().max(1.0) as u32;
        (n | 1).min(2 * MAX_TAPS + 1)
    }

    /// The largest offset of a tap from the centre along either axis, in texels (what a
    /// footprint must cover).
    pub fn extent(&self) -> f32 {
        match self.pattern {
            Pattern::Poisson | Pattern::Rotated if self.taps == 16 => self.radius() * std::f32::consts::SQRT_2,
            _ => self.radius(),
        }
    }

    /// Half the kernel's extent in texels (the disks' radius; the grid's `n / 2`).
    pub fn radius(&self) -> f32 {
        match self.pattern {
            Pattern::DepthBilinear => 0.0,
            Pattern::Grid | Pattern::Tent => (self.grid_n() / 2) as f32,
            _ => 0.5 * self.width,
        }
    }

    /// The tap offsets in texels and weights at pixel `(x, y)` (the pixel turns the rotated and
    /// spiral patterns), for the Poisson family and for grids and tents compared tap by tap.
    pub fn taps_at(&self, x: u32, y: u32, out: &mut Vec<(Vec2, f32)>) {
        out.clear();
        let r = self.radius();
        match self.pattern {
            Pattern::DepthBilinear => out.push((Vec2::ZERO, 1.0)),
            Pattern::Grid | Pattern::Tent => {
                let n = self.grid_n() as i32;
                let h = n / 2;
                for j in -h..=h {
                    for i in -h..=h {
                        let w = match self.pattern {
                            Pattern::Tent => ((h + 1 - i.abs()) * (h + 1 - j.abs())) as f32,
                            _ => 1.0,
                        };
                        out.push((Vec2::new(i as f32, j as f32), w));
                    }
                }
            }
            Pattern::Poisson => out.extend(poisson_disk(self.taps).iter().map(|&p| (p * r, 1.0))),
            Pattern::Rotated => {
                let (s, c) = math::sin_cos(pixel_angle(x, y));
                out.extend(
                    poisson_disk(self.taps)
                        .iter()
                        .map(|&p| (Vec2::new(c * p.x - s * p.y, s * p.x + c * p.y) * r, 1.0)),
                );
            }
            Pattern::Spiral => {
                let (s, c) = math::sin_cos(interleaved_gradient_noise(x, y) * std::f32::consts::TAU);
                out.extend(
                    spiral(self.taps)
                        .iter()
                        .map(|&p| (Vec2::new(c * p.x - s * p.y, s * p.x + c * p.y) * r, 1.0)),
                );
            }
        }
    }

    /// The kernel's visibility at `uv` of `map` for pixel `(x, y)`, lit outside the map, and
    /// its account to `t` from the same loop: the kernel, and each tap (at most 32) with its
    /// offset, weight, reference depth and the comparison the sum took. Flat grids and tents
    /// take the separable path (texel comparisons with collapsed weights); everything else
    /// compares tap by tap with each tap's own reference.
    pub fn filter(&self, map: &Surface<f32>, uv: Vec2, r: &Reference, x: u32, y: u32, t: &mut impl Trace) -> Filtered {
        if !crate::shadow::light::inside(uv) {
            t.step(|| self.step(r, 0).flag("inside the map", false));
            return Filtered { value: 1.0, taps: 0 };
        }
        let size = Vec2::new(map.width() as f32, map.height() as f32);
        match self.pattern {
            Pattern::DepthBilinear => {
                let d = sample_bilinear(map, uv, Address::Clamp);
                t.step(|| self.step(r, 1).num("filtered depth", d));
                Filtered {
                    value: if r.z <= d { 1.0 } else { 0.0 },
                    taps: 1,
                }
            }
            Pattern::Grid | Pattern::Tent if r.is_flat() => {
                let n = self.grid_n();
                t.step(|| {
                    self.step(r, (n * n) as usize).text(
                        "path",
                        "separable: each texel compared once, weighted by the taps' collapsed bilinear weights",
                    )
                });
                Filtered {
                    value: if n < 16 {
                        let mut t = [0.0f32; 16];
                        axis_weights(self.pattern, n, &mut t);
                        separable::<17>(map, uv, r.z, &t[..n as usize])
                    } else {
                        let mut t = [0.0f32; 2 * MAX_TAPS as usize + 1];
                        axis_weights(self.pattern, n, &mut t);
                        separable::<{ 2 * MAX_TAPS as usize + 3 }>(map, uv, r.z, &t[..n as usize])
                    },
                    taps: n * n,
                }
            }
            _ => TAPS.with(|taps| {
                let mut taps = taps.borrow_mut();
                self.taps_at(x, y, &mut taps);
                let mut sums = TapSums::default();
                // What the sums took, per tap (kept only for a recording trace).
                let mut seen: Vec<f32> = Vec::new();
                let mut chunks = taps.chunks_exact(4);
                for c in &mut chunks {
                    let v = sums.four(map, uv, size, r, c.try_into().expect("four taps"));
                    if t.records() {
                        seen.extend(v.to_array());
                    }
                }
                for &(d, w) in chunks.remainder() {
                    let v = sums.one(map, uv, size, r, d, w);
                    if t.records() {
                        seen.push(v);
                    }
                }
                t.step(|| {
                    let mut st = self.step(r, taps.len());
                    for (i, (&(d, w), lit)) in taps.iter().zip(&seen).enumerate().take(32) {
                        st = st
                            .vec2(&format!("tap {i} offset"), d)
                            .num(&format!("tap {i} weight"), w)
                            .num(&format!("tap {i} reference"), r.at(d))
                            .num(&format!("tap {i} lit"), *lit);
                    }
                    st
                });
                Filtered {
                    value: sums.lit / sums.total,
                    taps: taps.len() as u32,
                }
            }),
        }
    }

    /// The head of the kernel's step in `inspect`: the kernel, its `taps` and the reference.
    fn step(&self, r: &Reference, taps: usize) -> Step {
        Step::new(
            "kernel",
            match self.pattern {
                Pattern::DepthBilinear => {
                    "the four nearest depths filtered bilinearly, then one comparison (the wrong order)"
                }
                Pattern::Grid => "n x n hardware 2x2 comparisons at whole-texel offsets, equal weights",
                Pattern::Tent => "n x n hardware 2x2 comparisons at whole-texel offsets, tent weights",
                Pattern::Poisson => "hardware 2x2 comparisons on a fixed Poisson disk",
                Pattern::Rotated => "hardware 2x2 comparisons on a Poisson disk rotated by the pixel's hashed angle",
                Pattern::Spiral => "hardware 2x2 comparisons on a Vogel spiral rotated by interleaved gradient noise",
            },
        )
        .text("pattern", self.pattern.as_str())
        .int("taps", taps)
        .num("width in texels", self.width)
        .num("reference depth", r.z)
        .vec2("receiver-plane gradient per texel", r.gradient)
        .num("bias cone per texel", r.cone)
    }
}

/// [`Reference`]s of four lanes (pixels), structure of arrays.
#[derive(Copy, Clone, Debug)]
pub struct Reference4 {
    /// Reference depths at the kernels' centres.
    pub z: Vec4,
    /// Receiver-plane gradients, x and y.
    pub gx: Vec4,
    /// See `gx`.
    pub gy: Vec4,
    /// Bias cones.
    pub cone: Vec4,
    /// Every lane flat ([`Reference::is_flat`]): taps compare against `z`.
    pub flat: bool,
    /// Some lane has a bias cone.
    pub coned: bool,
}

impl Reference4 {
    /// The four lanes' references (idle lanes: any, e.g. the default).
    pub fn new(r: [Reference; 4]) -> Reference4 {
        Reference4 {
            z: Vec4::from_array(r.map(|r| r.z)),
            gx: Vec4::from_array(r.map(|r| r.gradient.x)),
            gy: Vec4::from_array(r.map(|r| r.gradient.y)),
            cone: Vec4::from_array(r.map(|r| r.cone)),
            flat: r.iter().all(Reference::is_flat),
            coned: r.iter().any(|r| r.cone != 0.0),
        }
    }

    /// [`Reference::at`] per lane, tap offsets `(dx, dy)`: the same operations, so the same
    /// values (a flat lane's is exactly its `z`: it adds only zeros to it; without cones, the
    /// cone's term is a zero too, left out: the value can differ only in the sign of a zero,
    /// which no comparison sees).
    #[inline(always)]
    pub fn at(&self, dx: Vec4, dy: Vec4) -> Vec4 {
        if self.flat {
            return self.z;
        }
        let plane = self.z + (self.gx * dx + self.gy * dy);
        if !self.coned {
            return plane;
        }
        plane + self.cone * crate::pipeline::lanes::sqrt4(dx * dx + dy * dy)
    }
}

/// The taps of four lanes' disk kernels (Poisson, rotated Poisson or spiral, one tap count),
/// each lane turned by its own pixel and scaled by its own radius: tap `i` of lane `l` is
/// [`Kernel::taps_at`]'s tap `i` of that lane's kernel, bit for bit.
pub struct Disk4 {
    base: &'static [Vec2],
    /// Per lane: sine and cosine of the turn (rotated and spiral), and the radius.
    s: Vec4,
    c: Vec4,
    r: Vec4,
    turned: bool,
}

impl Disk4 {
    /// The taps.
    pub fn len(&self) -> usize {
        self.base.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.base.is_empty()
    }

    /// Tap `i`'s offsets in texels, x and y per lane.
    #[inline(always)]
    pub fn tap(&self, i: usize) -> (Vec4, Vec4) {
        let p = self.base[i];
        let (px, py) = (Vec4::splat(p.x), Vec4::splat(p.y));
        if self.turned {
            (
                (self.c * px - self.s * py) * self.r,
                (self.s * px + self.c * py) * self.r,
            )
        } else {
            (px * self.r, py * self.r)
        }
    }
}

impl Kernel {
    /// The disk taps of four kernels of this pattern and tap count whose widths are `width`
    /// per lane, at pixels `(xs[l], y)`; `None` for grids, tents and depth filtering.
    pub fn disk4(&self, xs: [u32; 4], y: u32, width: Vec4) -> Option<Disk4> {
        let r = Vec4::splat(0.5) * width;
        let turn = |a: [f32; 4]| {
            let sc = a.map(math::sin_cos);
            (Vec4::from_array(sc.map(|v| v.0)), Vec4::from_array(sc.map(|v| v.1)))
        };
        let (base, (s, c), turned) = match self.pattern {
            Pattern::Poisson => (poisson_disk(self.taps), (Vec4::ZERO, Vec4::ONE), false),
            Pattern::Rotated => (poisson_disk(self.taps), turn(xs.map(|x| pixel_angle(x, y))), true),
            Pattern::Spiral => (
                spiral(self.taps),
                turn(xs.map(|x| interleaved_gradient_noise(x, y) * std::f32::consts::TAU)),
                true,
            ),
            _ => return None,
        };
        Some(Disk4 { base, s, c, r, turned })
    }
}

/// The weighted sums of [`Kernel::filter`]'s tap-by-tap path: lit and total weight, summed
/// in tap order.
#[derive(Default)]
struct TapSums {
    lit: f32,
    total: f32,
}

impl TapSums {
    /// Four taps `(offset in texels, weight)` around `uv` of a `size` map against `r`, in
    /// one vector of 2x2 comparisons, summed in order (as one at a time, bit for bit).
    #[inline(always)]
    fn four(&mut self, map: &Surface<f32>, uv: Vec2, size: Vec2, r: &Reference, c: &[(Vec2, f32); 4]) -> Vec4 {
        let p: [Vec2; 4] = std::array::from_fn(|i| uv + c[i].0 / size);
        let z = if r.is_flat() {
            Vec4::splat(r.z)
        } else {
            Vec4::from_array(std::array::from_fn(|i| r.at(c[i].0)))
        };
        let u4 = Vec4::new(p[0].x, p[1].x, p[2].x, p[3].x);
        let v4 = Vec4::new(p[0].y, p[1].y, p[2].y, p[3].y);
        let v = bilinear_compare4(map, u4, v4, z);
        for i in 0..4 {
            self.lit += c[i].1 * v[i];
            self.total += c[i].1;
        }
        v
    }

    /// One tap at offset `d` with weight `w` (the taps after the last four of a kernel);
    /// the comparison it took.
    #[inline(always)]
    fn one(&mut self, map: &Surface<f32>, uv: Vec2, size: Vec2, r: &Reference, d: Vec2, w: f32) -> f32 {
        let v = bilinear_compare(map, uv + d / size, r.at(d));
        self.lit += w * v;
        self.total += w;
        v
    }
}

/// Four lanes' disk filters at once ([`Kernel::filter`] of each lane's kernel at `(u, v)`
/// against its reference, lanes in `active`): the values (1 outside the map, as there) and
/// the taps of each lane. Each lane's sums run in tap order with the one-lane path's
/// operations, so each value equals that path's bit for bit.
pub fn filter_disk4(
    map: &Surface<f32>,
    u: Vec4,
    v: Vec4,
    r: &Reference4,
    disk: &Disk4,
    active: [bool; 4],
) -> ([f32; 4], [u32; 4]) {
    let Some(go) = lanes_inside(u, v, active) else {
        return ([1.0; 4], [0; 4]);
    };
    let (w, h) = (map.width(), map.height());
    // A tap's offset over the map's size: for a power-of-two size, times its reciprocal,
    // which is exactly the quotient (the reciprocal is exact, and both are the one rounding
    // of the same real number).
    let value = if w.is_power_of_two() && h.is_power_of_two() {
        let (sx, sy) = (Vec4::splat(1.0 / w as f32), Vec4::splat(1.0 / h as f32));
        disk_sum(map, disk, r, |dx, dy| (u + dx * sx, v + dy * sy))
    } else {
        let (sx, sy) = (Vec4::splat(w as f32), Vec4::splat(h as f32));
        disk_sum(map, disk, r, |dx, dy| (u + dx / sx, v + dy / sy))
    };
    lane_results(go, value, disk.len() as u32)
}

/// The lanes of `active` whose point `(u, v)` lies in the map (the edge rule of
/// [`crate::shadow::light::inside`], as [`Kernel::filter`]); `None` if there are none.
fn lanes_inside(u: Vec4, v: Vec4, active: [bool; 4]) -> Option<[bool; 4]> {
    let inside = crate::shadow::light::inside4(u, v);
    let go: [bool; 4] = std::array::from_fn(|l| active[l] && inside.test(l));
    go.iter().any(|&g| g).then_some(go)
}

/// The values and tap counts of the lanes in `go` (`value`'s lane, `taps`); the others are
/// lit with no taps (outside the map, as in [`Kernel::filter`], or idle).
fn lane_results(go: [bool; 4], value: Vec4, taps: u32) -> ([f32; 4], [u32; 4]) {
    (
        std::array::from_fn(|l| if go[l] { value[l] } else { 1.0 }),
        go.map(|g| if g { taps } else { 0 }),
    )
}

/// Four lanes' flat grid or tent filters: [`Kernel::filter`]'s separable path at `(u, v)`
/// against `z` per lane, with the per-axis tap weights `t` (every lane inside the map: the
/// caller checks). Lanes whose footprints stay inside the map take the texels without
/// clamping, on four lanes in the one-lane path's order, so the same values; if any lane's
/// footprint reaches past an edge, each lane takes the one-lane path.
pub fn separable4(map: &Surface<f32>, u: Vec4, v: Vec4, z: Vec4, t: &[f32]) -> Vec4 {
    if t.len() < 16 {
        separable4_n::<17>(map, u, v, z, t)
    } else {
        separable4_n::<{ 2 * MAX_TAPS as usize + 3 }>(map, u, v, z, t)
    }
}

fn separable4_n<const C: usize>(map: &Surface<f32>, u: Vec4, v: Vec4, z: Vec4, t: &[f32]) -> Vec4 {
    use crate::pipeline::lanes::floor4;
    let (w, h) = (map.width() as usize, map.height() as usize);
    let n = t.len();
    let r = (n / 2) as f32;
    // `footprint`'s corner and fractions, per lane.
    let tx = u * w as f32 - Vec4::splat(0.5);
    let ty = v * h as f32 - Vec4::splat(0.5);
    let (x, y) = (floor4(tx), floor4(ty));
    let (x0, y0) = (x - Vec4::splat(r), y - Vec4::splat(r));
    let interior = x0.cmpge(Vec4::ZERO)
        & (x0 + Vec4::splat(n as f32)).cmple(Vec4::splat((w - 1) as f32))
        & y0.cmpge(Vec4::ZERO)
        & (y0 + Vec4::splat(n as f32)).cmple(Vec4::splat((h - 1) as f32));
    if !interior.all() {
        return Vec4::from_array(std::array::from_fn(|l| {
            separable::<C>(map, Vec2::new(u[l], v[l]), z[l], t)
        }));
    }
    let (fx, fy) = (tx - x, ty - y);
    // `texel_weights` per lane.
    let weights = |f: Vec4, out: &mut [Vec4; C]| {
        for (j, o) in out.iter_mut().enumerate().take(n + 1) {
            let a = if j < n {
                Vec4::splat(t[j]) * (Vec4::ONE - f)
            } else {
                Vec4::ZERO
            };
            let b = if j > 0 { Vec4::splat(t[j - 1]) * f } else { Vec4::ZERO };
            *o = a + b;
        }
    };
    let mut wx = [Vec4::ZERO; C];
    let mut wy = [Vec4::ZERO; C];
    weights(fx, &mut wx);
    weights(fy, &mut wy);
    // Whole, non-negative and inside the map: exact as integers.
    let base: [usize; 4] = std::array::from_fn(|l| y0[l] as usize * w + x0[l] as usize);
    let d = map.data();
    debug_assert!(base.iter().all(|&b| b + n * w + n < d.len()));
    // The weights' sum along a row, the same for every row (the one-lane path sums it per
    // row, in this order).
    let mut rt = Vec4::ZERO;
    for &wxi in wx.iter().take(n + 1) {
        rt += wxi;
    }
    let (mut lit, mut total) = (Vec4::ZERO, Vec4::ZERO);
    for (j, &wyj) in wy.iter().enumerate().take(n + 1) {
        let row = base.map(|b| b + j * w);
        let mut rl = Vec4::ZERO;
        // `if z <= texel { rl += w }`: adding zero leaves a sum of non-negative weights.
        let mut add = |i: usize, texel: Vec4| rl += Vec4::select(z.cmple(texel), wx[i], Vec4::ZERO);
        if n + 1 >= 4 {
            // Four columns at a time: each lane's four texels in one load, turned into four
            // columns of four lanes (the last group overlaps the one before it).
            let mut done = 0;
            while done < n + 1 {
                let at = done.min(n + 1 - 4);
                // SAFETY: every lane's footprint lies inside the map (`interior`), so
                // `row + at + 3 <= base + n w + n < w h`.
                let cols = unsafe { columns4(d, row, at) };
                for (k, &c) in cols.iter().enumerate() {
                    if at + k >= done {
                        add(at + k, c);
                    }
                }
                done = at + 4;
            }
        } else {
            for i in 0..=n {
                // SAFETY: as above, `row + i <= base + n w + n < w h`.
                let texel = unsafe {
                    Vec4::new(
                        *d.get_unchecked(row[0] + i),
                        *d.get_unchecked(row[1] + i),
                        *d.get_unchecked(row[2] + i),
                        *d.get_unchecked(row[3] + i),
                    )
                };
                add(i, texel);
            }
        }
        lit += wyj * rl;
        total += wyj * rt;
    }
    lit / total
}

/// Texels `at .. at + 4` of four lanes' rows starting at `row[l]`, as four columns of four
/// lanes (a 4 x 4 transpose of four row loads).
///
/// # Safety
/// `row[l] + at + 3` must be an index of `d` for every lane.
#[inline(always)]
unsafe fn columns4(d: &[f32], row: [usize; 4], at: usize) -> [Vec4; 4] {
    debug_assert!(row.iter().all(|&r| r + at + 3 < d.len()));
    let load = |l: usize| {
        // SAFETY: the caller's contract.
        unsafe { Vec4::from_slice(std::slice::from_raw_parts(d.as_ptr().add(row[l] + at), 4)) }
    };
    let (a, b, c, e) = (load(0), load(1), load(2), load(3));
    // Lane l of column k is texel k of row l.
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE is part of x86_64.
        unsafe {
            let (a, b, c, e) = (__m128::from(a), __m128::from(b), __m128::from(c), __m128::from(e));
            let (t0, t1) = (_mm_unpacklo_ps(a, b), _mm_unpacklo_ps(c, e));
            let (t2, t3) = (_mm_unpackhi_ps(a, b), _mm_unpackhi_ps(c, e));
            [
                Vec4::from(_mm_movelh_ps(t0, t1)),
                Vec4::from(_mm_movehl_ps(t1, t0)),
                Vec4::from(_mm_movelh_ps(t2, t3)),
                Vec4::from(_mm_movehl_ps(t3, t2)),
            ]
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    [
        Vec4::new(a.x, b.x, c.x, e.x),
        Vec4::new(a.y, b.y, c.y, e.y),
        Vec4::new(a.z, b.z, c.z, e.z),
        Vec4::new(a.w, b.w, c.w, e.w),
    ]
}

/// Four lanes' grid or tent filters of one kernel tap by tap, for references that are not
/// flat (a receiver plane or bias cone: each tap compares against its own reference, so the
/// separable path does not apply): [`Kernel::filter`]'s tap-by-tap path of each lane at
/// `(u, v)` against its reference, lanes in `active`, every tap a hardware 2x2 comparison.
/// Returns the values (1 outside the map, as there) and the taps of each lane; each lane's
/// sums run in tap order with the one-lane path's operations, so each value equals that
/// path's bit for bit.
pub fn filter_grid4(
    map: &Surface<f32>,
    u: Vec4,
    v: Vec4,
    r: &Reference4,
    kernel: &Kernel,
    active: [bool; 4],
) -> ([f32; 4], [u32; 4]) {
    let Some(go) = lanes_inside(u, v, active) else {
        return ([1.0; 4], [0; 4]);
    };
    let size = Vec2::new(map.width() as f32, map.height() as f32);
    let (value, n) = TAPS.with(|t| {
        let mut taps = t.borrow_mut();
        // Grid and tent taps do not depend on the pixel.
        kernel.taps_at(0, 0, &mut taps);
        let (mut lit, mut total) = (Vec4::ZERO, Vec4::ZERO);
        for &(d, w) in taps.iter() {
            let o = d / size;
            let (dx, dy) = (Vec4::splat(d.x), Vec4::splat(d.y));
            let c = bilinear_compare4(map, u + Vec4::splat(o.x), v + Vec4::splat(o.y), r.at(dx, dy));
            lit += Vec4::splat(w) * c;
            total += Vec4::splat(w);
        }
        (lit / total, taps.len() as u32)
    });
    lane_results(go, value, n)
}

/// `lit / total` of four lanes' disk taps at the positions `at` gives for each tap's offsets.
#[inline(always)]
fn disk_sum(map: &Surface<f32>, disk: &Disk4, r: &Reference4, at: impl Fn(Vec4, Vec4) -> (Vec4, Vec4)) -> Vec4 {
    let (mut lit, mut total) = (Vec4::ZERO, Vec4::ZERO);
    // Taps in batches: positions and references first, then the comparisons in tap order.
    const BATCH: usize = 16;
    let mut taps = [(Vec4::ZERO, Vec4::ZERO, Vec4::ZERO); BATCH];
    for first in (0..disk.len()).step_by(BATCH) {
        let batch = &mut taps[..BATCH.min(disk.len() - first)];
        for (j, t) in batch.iter_mut().enumerate() {
            let (dx, dy) = disk.tap(first + j);
            let (u, v) = at(dx, dy);
            *t = (u, v, r.at(dx, dy));
        }
        for &(u, v, reference) in batch.iter() {
            // Disk taps weigh 1: `lit += 1 * c` is `lit += c`, and `total += 1`.
            lit += bilinear_compare4(map, u, v, reference);
            total += Vec4::ONE;
        }
    }
    lit / total
}

thread_local! {
    /// Scratch tap list per worker (contents never outlive one call).
    static TAPS: std::cell::RefCell<Vec<(Vec2, f32)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// One hardware 2x2 comparison (lit if `z <= depth`, texels clamped to the edge, lit outside
/// the map): the pipeline's [`CompareSampler::pcf2x2`] with its default compare function and
/// border, inlined into the kernels' loops.
#[inline(always)]
pub fn bilinear_compare(map: &Surface<f32>, uv: Vec2, z: f32) -> f32 {
    CompareSampler::default().pcf2x2(map, uv, z)
}

/// [`bilinear_compare`] of four taps at once (`u`, `v` per lane), each lane equal to the
/// one-tap call bit for bit: the pipeline's [`CompareSampler::pcf2x2_4`] with its default
/// compare function and border.
#[inline(always)]
pub fn bilinear_compare4(map: &Surface<f32>, u: Vec4, v: Vec4, z: Vec4) -> Vec4 {
    CompareSampler::default().pcf2x2_4(map, u, v, z)
}

/// Per-axis tap weights of a grid (all 1) or tent (`h + 1 - |k|`) of `n` taps, into the first
/// `n` entries of `out` (on the stack: the per-pixel path allocates nothing).
pub(crate) fn axis_weights(pattern: Pattern, n: u32, out: &mut [f32]) {
    let h = (n / 2) as i32;
    for (o, k) in out.iter_mut().zip(-h..=h) {
        *o = match pattern {
            Pattern::Tent => (h + 1 - k.abs()) as f32,
            _ => 1.0,
        };
    }
}

/// The `n + 1` texel weights along one axis of `n` bilinear taps with tap weights `t` and
/// bilinear fraction `f`: texel `j` gets `t[j] (1 - f) + t[j - 1] f`.
fn texel_weights(t: &[f32], f: f32, out: &mut [f32]) {
    let n = t.len();
    for (j, o) in out.iter_mut().enumerate().take(n + 1) {
        let a = if j < n { t[j] * (1.0 - f) } else { 0.0 };
        let b = if j > 0 { t[j - 1] * f } else { 0.0 };
        *o = a + b;
    }
}

/// Separable PCF over `(n + 1)^2` texels: `lit / total`, both summed in the same order.
/// `C` is the weight arrays' capacity (at least `t.len() + 1`): small kernels clear small
/// arrays.
fn separable<const C: usize>(map: &Surface<f32>, uv: Vec2, z: f32, t: &[f32]) -> f32 {
    let (w, h) = (map.width() as i64, map.height() as i64);
    let (x, y, fx, fy) = footprint((map.width(), map.height()), uv);
    let n = t.len();
    let r = (n / 2) as i64;
    let mut wx = [0.0f32; C];
    let mut wy = [0.0f32; C];
    texel_weights(t, fx, &mut wx[..n + 1]);
    texel_weights(t, fy, &mut wy[..n + 1]);
    let d = map.data();
    let (mut lit, mut total) = (0.0f32, 0.0f32);
    for (j, &wyj) in wy.iter().enumerate().take(n + 1) {
        let yy = (y - r + j as i64).clamp(0, h - 1) as usize;
        let row = &d[yy * w as usize..(yy + 1) * w as usize];
        let (mut rl, mut rt) = (0.0f32, 0.0f32);
        for (i, &wxi) in wx.iter().enumerate().take(n + 1) {
            let xx = (x - r + i as i64).clamp(0, w - 1) as usize;
            if z <= row[xx] {
                rl += wxi;
            }
            rt += wxi;
        }
        lit += wyj * rl;
        total += wyj * rt;
    }
    lit / total
}

/// Min and max mip chains of a depth map (RTR 7.6's hierarchical min/max shadow map), built
/// by the pipeline's reduction (from half the map's size down; the map is level 0): the
/// coarse levels contact-hardening shadows search. (Kernels are classified on
/// [`super::planes::PlaneChain`], which keeps each block's min and max as well.)
pub struct MinMax {
    /// The map's size.
    pub size: (u32, u32),
    /// Minimum depth per texel of levels 1, 2, ... (half the map's size first).
    pub min: MipChain<f32>,
    /// Maximum depth per texel of levels 1, 2, ...
    pub max: MipChain<f32>,
}

/// What the hierarchy says of a kernel.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Class {
    /// Every tap passes.
    Lit,
    /// Every tap fails.
    Shadowed,
    /// The taps must be compared.
    Mixed,
}

impl MinMax {
    /// The chains of `map`.
    pub fn new(p: &Pipeline, map: &Surface<f32>) -> MinMax {
        let (min, max) = min_max_chains(p, map);
        MinMax {
            size: (map.width(), map.height()),
            min,
            max,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shadow::inspect::NoTrace;

    #[test]
    fn disks_are_deterministic_and_inside_the_unit_disk() {
        for n in [1, 16, 32, 64, 256] {
            let d = poisson_disk(n);
            assert_eq!(d.len(), n as usize);
            // The classic 16 lie in [-1, 1]^2 (some beyond the unit circle), the others in the disk.
            let r = if n == 16 { std::f32::consts::SQRT_2 } else { 1.0 };
            assert!(d.iter().all(|p| p.length() <= r + 1e-6));
            assert_eq!(d, best_or_classic(n).as_slice());
        }
        // Well spread: no two of 32 points closer than a fifth of the radius.
        let d = poisson_disk(32);
        for (i, a) in d.iter().enumerate() {
            for b in &d[i + 1..] {
                assert!(a.distance(*b) > 0.2, "{a} {b}");
            }
        }
        assert!((0..64).all(|i| vogel(i, 64, 0.3).length() <= 1.0));
        let n = interleaved_gradient_noise(17, 5);
        assert!((0.0..1.0).contains(&n));
    }

    fn best_or_classic(n: u32) -> Vec<Vec2> {
        if n == 16 {
            POISSON16.to_vec()
        } else {
            best_candidate(n as usize)
        }
    }

    #[test]
    fn four_lane_comparisons_equal_one_lane_ones_bit_for_bit() {
        let mut rng = SplitMix(9);
        let data: Vec<f32> = (0..37 * 29).map(|_| rng.next_f32()).collect();
        let map = Surface::from_vec(37, 29, data).unwrap();
        for _ in 0..2000 {
            // Coordinates inside, on and beyond the edges, and NaN.
            let mut c = || match rng.next_f32() {
                r if r < 0.02 => f32::NAN,
                r if r < 0.05 => 1.0,
                _ => rng.next_f32() * 1.4 - 0.2,
            };
            let (u, v) = (Vec4::new(c(), c(), c(), c()), Vec4::new(c(), c(), c(), c()));
            let z = Vec4::new(rng.next_f32(), rng.next_f32(), rng.next_f32(), rng.next_f32());
            let four = bilinear_compare4(&map, u, v, z);
            for i in 0..4 {
                let one = bilinear_compare(&map, Vec2::new(u[i], v[i]), z[i]);
                assert_eq!(four[i].to_bits(), one.to_bits(), "({}, {}) {}", u[i], v[i], z[i]);
            }
        }
    }

    #[test]
    fn four_pixel_filters_equal_one_pixel_ones_bit_for_bit() {
        let mut rng = SplitMix(11);
        // A power-of-two map (offsets times the reciprocal) and an odd-sized one (quotients).
        for (w, h) in [(64u32, 64u32), (61, 37)] {
            let data: Vec<f32> = (0..w * h).map(|_| rng.next_f32()).collect();
            let map = Surface::from_vec(w, h, data).unwrap();
            for _ in 0..400 {
                // Lanes near the edges too (footprints past the edge, outside the map, NaN).
                let mut c = || match rng.next_f32() {
                    r if r < 0.03 => f32::NAN,
                    _ => rng.next_f32() * 1.1 - 0.05,
                };
                let (u, v) = (Vec4::new(c(), c(), c(), c()), Vec4::new(c(), c(), c(), c()));
                let z = Vec4::new(rng.next_f32(), rng.next_f32(), rng.next_f32(), rng.next_f32());
                let uv = |l: usize| Vec2::new(u[l], v[l]);
                let inside = |l: usize| crate::shadow::light::inside(uv(l));
                for pattern in [Pattern::Grid, Pattern::Tent] {
                    let width = [1.0, 3.0, 5.0, 7.0, 9.0, 17.0][(rng.next_f32() * 6.0) as usize % 6];
                    let k = Kernel {
                        pattern,
                        taps: 16,
                        width,
                    };
                    let n = k.grid_n();
                    let mut t = vec![0.0; n as usize];
                    axis_weights(pattern, n, &mut t);
                    let (lu, lv) = (
                        Vec4::select(u.cmpge(Vec4::ZERO) & u.cmple(Vec4::ONE), u, Vec4::splat(0.5)),
                        v,
                    );
                    let lv = Vec4::select(lv.cmpge(Vec4::ZERO) & lv.cmple(Vec4::ONE), lv, Vec4::splat(0.5));
                    let four = separable4(&map, lu, lv, z, &t);
                    for l in 0..4 {
                        let one = k
                            .filter(
                                &map,
                                Vec2::new(lu[l], lv[l]),
                                &Reference::flat(z[l]),
                                0,
                                0,
                                &mut NoTrace,
                            )
                            .value;
                        assert_eq!(four[l].to_bits(), one.to_bits(), "{pattern:?} {width} lane {l}");
                    }
                }
                for (pattern, taps) in [
                    (Pattern::Poisson, 16),
                    (Pattern::Rotated, 16),
                    (Pattern::Spiral, 32),
                    (Pattern::Poisson, 7),
                ] {
                    let widths = Vec4::new(rng.next_f32() * 9.0 + 1.0, 1.0, rng.next_f32() * 30.0, 4.5);
                    let refs: [Reference; 4] = std::array::from_fn(|l| Reference {
                        z: z[l],
                        gradient: if l % 2 == 0 {
                            Vec2::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5) * 0.01
                        } else {
                            Vec2::ZERO
                        },
                        cone: if l == 1 { -0.001 } else { 0.0 },
                    });
                    let k = Kernel {
                        pattern,
                        taps,
                        width: 1.0,
                    };
                    let (x, y) = (rng.next_u64() as u32 % 5000, rng.next_u64() as u32 % 5000);
                    let xs = [x, x + 1, x + 2, x + 3];
                    let disk = k.disk4(xs, y, widths).unwrap();
                    let active = [true, true, rng.next_f32() < 0.5, true];
                    let (values, counts) = filter_disk4(&map, u, v, &Reference4::new(refs), &disk, active);
                    for l in 0..4 {
                        if !active[l] {
                            continue;
                        }
                        let lane = Kernel { width: widths[l], ..k };
                        let one = lane.filter(&map, uv(l), &refs[l], xs[l], y, &mut NoTrace);
                        assert_eq!(
                            values[l].to_bits(),
                            one.value.to_bits(),
                            "{pattern:?} lane {l} inside {}",
                            inside(l)
                        );
                        assert_eq!(counts[l], one.taps);
                    }
                }
            }
        }
    }

    #[test]
    fn grids_and_tents_match_their_tap_by_tap_sums() {
        // A random depth map; the separable path equals the tap-by-tap path up to rounding.
        let mut rng = SplitMix(3);
        let data: Vec<f32> = (0..64 * 64).map(|_| rng.next_f32()).collect();
        let map = Surface::from_vec(64, 64, data).unwrap();
        for pattern in [Pattern::Grid, Pattern::Tent] {
            for width in [1.0, 3.0, 5.0, 7.0] {
                let k = Kernel {
                    pattern,
                    taps: 16,
                    width,
                };
                for _ in 0..50 {
                    let uv = Vec2::new(rng.next_f32(), rng.next_f32()) * 0.8 + Vec2::splat(0.1);
                    let z = rng.next_f32();
                    let fast = k.filter(&map, uv, &Reference::flat(z), 0, 0, &mut NoTrace).value;
                    // A tiny gradient forces the tap-by-tap path.
                    let r = Reference {
                        z,
                        gradient: Vec2::new(1e-30, 0.0),
                        cone: 0.0,
                    };
                    let slow = k.filter(&map, uv, &r, 0, 0, &mut NoTrace).value;
                    assert!((fast - slow).abs() < 1e-5, "{pattern:?} {width}: {fast} vs {slow}");
                }
            }
        }
    }
}
