//! The ground truth: a BVH ray tracer of its own ([`bvh`]), independent of the pipeline and of
//! every technique it judges.
//!
//! - hard visibility: one ray from the shading point to the light's centre (for directional
//!   lights, along the negated direction), attenuated by every surface it crosses with
//!   opacity < 1 (transmittance `prod (1 - opacity)`, multiplied front to back so that the
//!   result does not depend on the order the hierarchy finds the surfaces in);
//! - area visibility: the fraction of the light (disk, rectangle: area; sphere: solid angle) seen
//!   from the point, by stratified jittered sampling, adaptively: a pilot of 8 x 8 strata and 32
//!   rim points; if every pilot ray agrees the pixel is umbra or fully lit, otherwise
//!   `area_samples` fresh stratified samples. Jitter comes from a hash of
//!   (pixel, sample, seed), so the result is deterministic;
//! - colour: where a scene has materials with a coloured `transmittance`, every ray carries
//!   one transmittance per channel (the product of the crossed surfaces' colours) and the
//!   result is a [`Visibility::Rgb`]; otherwise one value ([`Visibility::Scalar`]).

pub mod bvh;

use crate::math;
use crate::scene::{AreaShape, Light, LightKind, Scene};
use crate::visibility::Visibility;
use bvh::{Bvh, Tri, PACKET};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Options of the reference.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ReferenceOptions {
    /// Use the light's area (false: hard visibility from its centre even for area lights).
    /// Default: true.
    pub area: bool,
    /// Samples per penumbra pixel, rounded to a square (n x n strata). Default: 1024, which keeps
    /// the error of a straight shadow edge across a disk light below 0.01 (tested against the
    /// closed form of the circular segment).
    pub area_samples: u32,
    /// Seed of the jitter hash. Default: 1.
    pub seed: u64,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        ReferenceOptions {
            area: true,
            area_samples: 1024,
            seed: 1,
        }
    }
}

/// A shading point: world position and the unit normal of the surface (facing the viewer).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SamplePoint {
    /// World position.
    pub position: Vec3,
    /// Unit surface normal (the shading normal, interpolated across smooth surfaces).
    pub normal: Vec3,
    /// Unit normal of the triangle the point lies on, turned to `normal`'s side: shadow rays
    /// start offset along it ([`offset_origin`]). Offset along an interpolated normal that
    /// leans away from the triangle, the per-axis scaled offset can land under the
    /// triangle's plane, and the ray then hits the point's own triangle. Equal to `normal`
    /// for flat-shaded surfaces.
    pub face: Vec3,
}

impl SamplePoint {
    /// A point on a flat surface: the face normal is the normal.
    pub fn flat(position: Vec3, normal: Vec3) -> SamplePoint {
        SamplePoint {
            position,
            normal,
            face: normal,
        }
    }
}

/// The ray tracer of one scene.
pub struct Reference {
    bvh: Bvh,
    transmit: Vec<f32>,
    transmit_rgb: Vec<Vec3>,
    coloured: bool,
    rays: std::sync::atomic::AtomicU64,
}

/// What a shadow ray carries: one transmittance (`f32`) or one per channel (`Vec3`).
trait Channels: Copy + PartialEq + std::ops::Add<Output = Self> + std::ops::Div<f32, Output = Self> + Send + Sync {
    const ZERO: Self;
    const ONE: Self;
    fn trace(r: &Reference, o: Vec3, d: Vec3, tmax: f32) -> Self;
    /// [`Channels::trace`] of up to [`PACKET`] rays at once, into `out`.
    fn trace_packet(r: &Reference, rays: &[Ray], out: &mut [Self]);
    /// The value per colour channel (one value: the same in all three).
    fn rgb(self) -> Vec3;
}

/// What the reference did at one point, for `inspect`: recorded by the function that computes
/// the image's value there ([`Reference::explain`]), so the account cannot disagree with it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointReport {
    /// The shadow rays' origin: the point moved off its surface ([`offset_origin`]).
    pub origin: Vec3,
    /// The hard shadow ray to the light's centre (hard lights; `None` for area sampling, or
    /// a point at the light).
    pub hard_ray: Option<Ray>,
    /// Area lights: the 8 x 8 pilot strata's mean, per channel.
    pub pilot: Option<Vec3>,
    /// Area lights: whether the 32 rim rays agreed with a pilot that was all lit or all
    /// shadowed (then the pilot is the answer); `None` where the pilot was mixed.
    pub rim_agrees: Option<bool>,
    /// Area lights: the side of the full strata grid traced after the pilot (0: none).
    pub strata: u32,
    /// Light samples taken at the point (each one shadow ray, or none where the point is on
    /// or inside the light).
    pub rays: u32,
}

/// Where [`Reference`]'s per-point function reports what it did: nowhere for the image
/// (`()`, free), into a [`PointReport`] for `inspect`.
trait Report {
    fn hard_ray(&mut self, _ray: Option<Ray>) {}
    fn origin(&mut self, _o: Vec3) {}
    fn pilot(&mut self, _v: Vec3) {}
    fn rim(&mut self, _agrees: bool) {}
    fn strata(&mut self, _n: u32) {}
    fn rays(&mut self, _n: u32) {}
}

impl Report for () {}

impl Report for PointReport {
    fn hard_ray(&mut self, ray: Option<Ray>) {
        self.hard_ray = ray;
        self.rays += ray.is_some() as u32;
    }
    fn origin(&mut self, o: Vec3) {
        self.origin = o;
    }
    fn pilot(&mut self, v: Vec3) {
        self.pilot = Some(v);
    }
    fn rim(&mut self, agrees: bool) {
        self.rim_agrees = Some(agrees);
    }
    fn strata(&mut self, n: u32) {
        self.strata = n;
    }
    fn rays(&mut self, n: u32) {
        self.rays += n;
    }
}

/// A shadow ray: origin, unit direction, and the distance it ends at.
pub type Ray = (Vec3, Vec3, f32);

impl Channels for f32 {
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    #[inline]
    fn trace(r: &Reference, o: Vec3, d: Vec3, tmax: f32) -> f32 {
        r.transmittance(o, d, tmax)
    }
    #[inline]
    fn trace_packet(r: &Reference, rays: &[Ray], out: &mut [f32]) {
        r.transmittance_packet(rays, out);
    }
    #[inline]
    fn rgb(self) -> Vec3 {
        Vec3::splat(self)
    }
}

impl Channels for Vec3 {
    const ZERO: Vec3 = Vec3::ZERO;
    const ONE: Vec3 = Vec3::ONE;
    #[inline]
    fn trace(r: &Reference, o: Vec3, d: Vec3, tmax: f32) -> Vec3 {
        r.transmittance_rgb(o, d, tmax)
    }
    #[inline]
    fn trace_packet(r: &Reference, rays: &[Ray], out: &mut [Vec3]) {
        r.transmittance_rgb_packet(rays, out);
    }
    #[inline]
    fn rgb(self) -> Vec3 {
        self
    }
}

/// Moves a ray origin off its surface along the normal by a few ULPs of the position
/// (Wächter and Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing
/// Gems ch. 6, 2019): integer offsets far from the origin, a float offset near it.
///
/// On x86_64 the three components run on the lanes of one SSE register, without a branch
/// (the scalar form's two branches per component follow the signs and sizes of the
/// coordinates, which no predictor learns); the results are the scalar form's bit for bit,
/// for every input (a test compares them).
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86_64; only register operations.
        unsafe {
            let pv = _mm_setr_ps(p.x, p.y, p.z, 0.0);
            let nv = _mm_setr_ps(n.x, n.y, n.z, 0.0);
            // `(INT_SCALE * n) as i32`: saturating, NaN to 0. cvttps2dq gives i32::MIN for NaN
            // and out-of-range lanes: flipping every bit of the lanes at or above 2^31 makes
            // that i32::MAX, and NaN lanes are masked to 0.
            let scaled = _mm_mul_ps(_mm_set1_ps(OFFSET_INT_SCALE), nv);
            let big = _mm_castps_si128(_mm_cmpge_ps(scaled, _mm_set1_ps(2147483648.0)));
            let oi = _mm_and_si128(
                _mm_xor_si128(_mm_cvttps_epi32(scaled), big),
                _mm_castps_si128(_mm_cmpord_ps(scaled, scaled)),
            );
            // `p < 0 ? -oi : oi`, added to p's bits (wrapping, as the scalar form's i32 add).
            let neg = _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps()));
            let signed = _mm_sub_epi32(_mm_xor_si128(oi, neg), neg);
            let pi = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), signed));
            let pf = _mm_add_ps(pv, _mm_mul_ps(_mm_set1_ps(OFFSET_FLOAT_SCALE), nv));
            let abs = _mm_andnot_ps(_mm_set1_ps(-0.0), pv);
            let near = _mm_cmplt_ps(abs, _mm_set1_ps(OFFSET_ORIGIN));
            let r = _mm_or_ps(_mm_and_ps(near, pf), _mm_andnot_ps(near, pi));
            let mut out = [0.0f32; 4];
            _mm_storeu_ps(out.as_mut_ptr(), r);
            Vec3::new(out[0], out[1], out[2])
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    offset_origin_scalar(p, n)
}

/// [`offset_origin`]'s constants: below this coordinate size the float offset applies.
const OFFSET_ORIGIN: f32 = 1.0 / 32.0;
const OFFSET_FLOAT_SCALE: f32 = 1.0 / 65536.0;
const OFFSET_INT_SCALE: f32 = 256.0;

/// [`offset_origin`] one component at a time (its definition).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn offset_origin_scalar(p: Vec3, n: Vec3) -> Vec3 {
    let off = |p: f32, n: f32| -> f32 {
        let oi = (OFFSET_INT_SCALE * n) as i32;
        let pi = f32::from_bits((p.to_bits() as i32).wrapping_add(if p < 0.0 { oi.wrapping_neg() } else { oi }) as u32);
        if p.abs() < OFFSET_ORIGIN {
            p + OFFSET_FLOAT_SCALE * n
        } else {
            pi
        }
    };
    Vec3::new(off(p.x, n.x), off(p.y, n.y), off(p.z, n.z))
}

thread_local! {
    static RAYS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// SplitMix64 finaliser: a well-mixed hash of the inputs.
fn hash3(a: u64, b: u64, c: u64) -> u64 {
    let mut z = a.wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ b.wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
        ^ c.wrapping_mul(0x1656_67b1_9e37_79f9);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn unit(h: u64) -> f32 {
    (h >> 40) as f32 / (1u64 << 24) as f32
}

/// Concentric map of the unit square to the unit disk (Shirley and Chiu 1997).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    Vec2::new(math::cos(theta), math::sin(theta)) * r
}

impl Reference {
    /// Builds the BVH of a scene.
    pub fn new(scene: &Scene) -> Reference {
        let mut tris = Vec::with_capacity(scene.triangles());
        for (oi, o) in scene.objects.iter().enumerate() {
            for t in o.mesh.indices.chunks_exact(3) {
                let v = [
                    o.mesh.positions[t[0] as usize],
                    o.mesh.positions[t[1] as usize],
                    o.mesh.positions[t[2] as usize],
                ];
                tris.push(Tri { v, tag: oi as u32 });
            }
        }
        let transmit = scene
            .objects
            .iter()
            .map(|o| 1.0 - scene.materials[o.material].opacity)
            .collect();
        let transmit_rgb: Vec<Vec3> = scene
            .objects
            .iter()
            .map(|o| scene.materials[o.material].transmittance_rgb())
            .collect();
        let coloured = transmit_rgb.iter().any(|t| t.x != t.y || t.y != t.z);
        Reference {
            bvh: Bvh::build(tris),
            transmit,
            transmit_rgb,
            coloured,
            rays: Default::default(),
        }
    }

    /// Bytes of the hierarchy (nodes and triangle packets).
    pub fn bytes(&self) -> usize {
        self.bvh.bytes()
    }

    /// Shadow rays traced so far (rows of [`Reference::visibility`], plus the calling thread's
    /// own single queries).
    pub fn rays_traced(&self) -> u64 {
        self.flush_rays();
        self.rays.load(std::sync::atomic::Ordering::Relaxed)
    }

    fn flush_rays(&self) {
        let n = RAYS.with(|c| c.replace(0));
        self.rays.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
    }

    /// Transmittance along `o + t d`, `t` in `(0, tmax)`: 0 if an opaque surface is crossed,
    /// else the product of `1 - opacity` of the surfaces crossed, front to back.
    pub fn transmittance(&self, o: Vec3, d: Vec3, tmax: f32) -> f32 {
        // A thread-local count (a shared atomic per ray would bounce its cache line between cores).
        RAYS.with(|c| c.set(c.get() + 1));
        self.through(o, d, tmax, &self.transmit, |t| t <= 0.0).max(0.0)
    }

    /// Transmittance per channel along `o + t d`, `t` in `(0, tmax)`: the product of the
    /// crossed surfaces' transmittance colours, front to back (an opaque surface ends the ray
    /// at zero).
    pub fn transmittance_rgb(&self, o: Vec3, d: Vec3, tmax: f32) -> Vec3 {
        RAYS.with(|c| c.set(c.get() + 1));
        self.through(o, d, tmax, &self.transmit_rgb, |t| t.max_element() <= 0.0)
            .max(Vec3::ZERO)
    }

    /// The product of `per_object[tag]` over the surfaces the ray crosses, multiplied in
    /// order of distance (ties by object), so the result is the same whatever order the
    /// hierarchy finds them in (float products are not associative); an opaque surface ends
    /// the ray at zero.
    fn through<C>(&self, o: Vec3, d: Vec3, tmax: f32, per_object: &[C], opaque: impl Fn(C) -> bool) -> C
    where
        C: Copy + PartialEq + std::ops::Mul<Output = C> + Channels,
    {
        let mut few = [(0.0f32, 0u32); 16];
        let mut n = 0;
        let mut more: Vec<(f32, u32)> = Vec::new();
        let blocked = self.bvh.traverse(o, d, tmax, |tag, t| {
            let tr = per_object[tag as usize];
            if opaque(tr) {
                return true;
            }
            if tr != C::ONE {
                if n < few.len() {
                    few[n] = (t, tag);
                    n += 1;
                } else {
                    more.push((t, tag));
                }
            }
            false
        });
        if blocked {
            return C::ZERO;
        }
        let order = |a: &(f32, u32), b: &(f32, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        let product = |hits: &[(f32, u32)]| {
            hits.iter()
                .fold(C::ONE, |acc, &(_, tag)| acc * per_object[tag as usize])
        };
        if more.is_empty() {
            few[..n].sort_unstable_by(order);
            product(&few[..n])
        } else {
            more.extend_from_slice(&few);
            more.sort_unstable_by(order);
            product(&more)
        }
    }

    /// [`Reference::transmittance`] of up to [`PACKET`] rays traced together
    /// ([`Bvh::traverse_packet`]): each result is the single ray's, bit for bit.
    pub fn transmittance_packet(&self, rays: &[Ray], out: &mut [f32]) {
        RAYS.with(|c| c.set(c.get() + rays.len() as u64));
        self.through_packet(rays, &self.transmit, |t| t <= 0.0, out);
        for v in out.iter_mut() {
            *v = v.max(0.0);
        }
    }

    /// [`Reference::transmittance_rgb`] of up to [`PACKET`] rays traced together.
    pub fn transmittance_rgb_packet(&self, rays: &[Ray], out: &mut [Vec3]) {
        RAYS.with(|c| c.set(c.get() + rays.len() as u64));
        self.through_packet(rays, &self.transmit_rgb, |t| t.max_element() <= 0.0, out);
        for v in out.iter_mut() {
            *v = v.max(Vec3::ZERO);
        }
    }

    /// [`Reference::through`] for a packet: per ray the same surfaces, multiplied in the same
    /// order (by distance, ties by object), so the same bits.
    fn through_packet<C>(&self, rays: &[Ray], per_object: &[C], opaque: impl Fn(C) -> bool, out: &mut [C])
    where
        C: Copy + PartialEq + std::ops::Mul<Output = C> + Channels,
    {
        let mut few = [[(0.0f32, 0u32); 16]; PACKET];
        let mut n = [0usize; PACKET];
        // Past 16 surfaces on one ray: (ray, distance, object).
        let mut more: Vec<(usize, f32, u32)> = Vec::new();
        let blocked = self.bvh.traverse_packet(rays, |i, tag, t| {
            let tr = per_object[tag as usize];
            if opaque(tr) {
                return true;
            }
            if tr != C::ONE {
                if n[i] < 16 {
                    few[i][n[i]] = (t, tag);
                    n[i] += 1;
                } else {
                    more.push((i, t, tag));
                }
            }
            false
        });
        let order = |a: &(f32, u32), b: &(f32, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        let product = |hits: &[(f32, u32)]| {
            hits.iter()
                .fold(C::ONE, |acc, &(_, tag)| acc * per_object[tag as usize])
        };
        for (i, o) in out.iter_mut().enumerate().take(rays.len()) {
            *o = if blocked & (1 << i) != 0 {
                C::ZERO
            } else if more.iter().any(|m| m.0 == i) {
                let mut all: Vec<(f32, u32)> = more.iter().filter(|m| m.0 == i).map(|m| (m.1, m.2)).collect();
                all.extend_from_slice(&few[i][..n[i]]);
                all.sort_unstable_by(order);
                product(&all)
            } else {
                let hits = &mut few[i][..n[i]];
                hits.sort_unstable_by(order);
                product(hits)
            };
        }
    }

    /// Whether some material transmits a colour (different per channel): visibility is then
    /// computed per channel.
    pub fn is_coloured(&self) -> bool {
        self.coloured
    }

    /// Hard visibility of the light's centre from `s`.
    pub fn hard(&self, s: &SamplePoint, light: &Light) -> f32 {
        self.hard_c(s, light, &mut ())
    }

    fn hard_c<C: Channels>(&self, s: &SamplePoint, light: &Light, report: &mut impl Report) -> C {
        let ray = Self::hard_ray(s, light);
        report.origin(offset_origin(s.position, s.face));
        report.hard_ray(ray);
        match ray {
            Some((o, d, t)) => C::trace(self, o, d, t),
            None => C::ONE,
        }
    }

    /// The shadow ray from `s` to the light's centre (`None`: the point is at the light, lit).
    fn hard_ray(s: &SamplePoint, light: &Light) -> Option<Ray> {
        let o = offset_origin(s.position, s.face);
        match light.kind {
            LightKind::Directional => Some((o, -light.direction, f32::INFINITY)),
            _ => {
                let to = light.position - o;
                let d = to.length();
                (d > 0.0).then(|| (o, to / d, d))
            }
        }
    }

    /// Up to [`PACKET`] rays, `ray_of(0..m)`, traced together (`None`: lit, no ray); the
    /// results in order, each the single ray's.
    #[inline]
    fn trace_chunk<C: Channels>(&self, m: usize, ray_of: impl Fn(usize) -> Option<Ray>) -> [C; PACKET] {
        let mut rays = [(Vec3::ZERO, Vec3::ZERO, 0.0f32); PACKET];
        let mut slot = [0usize; PACKET];
        let mut nr = 0;
        let mut vals = [C::ONE; PACKET];
        for q in 0..m.min(PACKET) {
            if let Some(r) = ray_of(q) {
                rays[nr] = r;
                slot[nr] = q;
                nr += 1;
            }
        }
        if nr == 1 {
            let (o, d, t) = rays[0];
            vals[slot[0]] = C::trace(self, o, d, t);
        } else if nr > 1 {
            let mut res = [C::ZERO; PACKET];
            C::trace_packet(self, &rays[..nr], &mut res[..nr]);
            for k in 0..nr {
                vals[slot[k]] = res[k];
            }
        }
        vals
    }

    /// The shadow ray from `o` to the light sample at strata coordinate `u` in [0, 1)^2
    /// (`None`: `o` is on or inside the light, lit).
    fn sample_ray(o: Vec3, light: &Light, shape: AreaShape, u: Vec2) -> Option<Ray> {
        let (t1, t2) = light.tangents();
        let target = match shape {
            AreaShape::Disk { radius } => {
                let q = concentric_disk(u) * radius;
                light.position + t1 * q.x + t2 * q.y
            }
            AreaShape::Rectangle { width, height } => {
                light.position + t1 * ((u.x - 0.5) * width) + t2 * ((u.y - 0.5) * height)
            }
            AreaShape::Sphere { radius } => {
                // Uniform over the cone of directions subtended by the sphere.
                let to = light.position - o;
                let dist = to.length();
                if dist <= radius {
                    return None;
                }
                let w = to / dist;
                let cos_max = (1.0 - (radius / dist).powi(2)).max(0.0).sqrt();
                let cos_t = 1.0 - u.x * (1.0 - cos_max);
                let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * u.y;
                let helper = if w.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
                let a = w.cross(helper).normalize();
                let b = w.cross(a);
                let d = (a * (sin_t * math::cos(phi)) + b * (sin_t * math::sin(phi)) + w * cos_t).normalize();
                // Distance to the near side of the sphere along d.
                let tca = to.dot(d);
                let thc = (radius * radius - (dist * dist - tca * tca)).max(0.0).sqrt();
                return Some((o, d, (tca - thc).max(0.0)));
            }
        };
        let to = target - o;
        let d = to.length();
        (d > 0.0).then(|| (o, to / d, d))
    }

    /// Area visibility (stratified, adaptive; see the module docs). `pixel` seeds the jitter.
    pub fn area(&self, s: &SamplePoint, light: &Light, pixel: u64, opts: &ReferenceOptions) -> f32 {
        self.area_c(s, light, pixel, opts, &mut ())
    }

    /// [`Reference::area`] per colour channel.
    pub fn area_rgb(&self, s: &SamplePoint, light: &Light, pixel: u64, opts: &ReferenceOptions) -> Vec3 {
        self.area_c(s, light, pixel, opts, &mut ())
    }

    /// The value [`Reference::visibility`] gives point `s` of pixel `pixel` (per channel; one
    /// value in all three for scenes without coloured transmittance), and what was traced
    /// for it: the same function as the image's, reporting.
    pub fn explain(&self, s: &SamplePoint, light: &Light, pixel: u64, opts: &ReferenceOptions) -> (Vec3, PointReport) {
        let mut report = PointReport::default();
        let v = if self.coloured {
            self.area_c::<Vec3>(s, light, pixel, opts, &mut report)
        } else {
            self.area_c::<f32>(s, light, pixel, opts, &mut report).rgb()
        };
        (v, report)
    }

    fn area_c<C: Channels>(
        &self,
        s: &SamplePoint,
        light: &Light,
        pixel: u64,
        opts: &ReferenceOptions,
        report: &mut impl Report,
    ) -> C {
        let shape = match light.kind {
            LightKind::Area(shape) if opts.area => shape,
            _ => return self.hard_c(s, light, report),
        };
        let o = offset_origin(s.position, s.face);
        report.origin(o);
        // The strata's samples in packets of rays, summed in the strata's order.
        let strata = |n: u32, salt: u64| -> C {
            let total = (n * n) as usize;
            let mut sum = C::ZERO;
            for k in (0..total).step_by(PACKET) {
                let m = (total - k).min(PACKET);
                let vals = self.trace_chunk::<C>(m, |q| {
                    let idx = (k + q) as u32;
                    let (j, i) = (idx / n, idx % n);
                    let h = hash3(pixel, (salt << 32) | idx as u64, opts.seed);
                    let u = Vec2::new(
                        (i as f32 + unit(h)) / n as f32,
                        (j as f32 + unit(h.rotate_left(24))) / n as f32,
                    );
                    Self::sample_ray(o, light, shape, u.min(Vec2::splat(0.999_999_9)))
                });
                for v in &vals[..m] {
                    sum = sum + *v;
                }
            }
            sum / (n * n) as f32
        };
        // Pilot: 8 x 8 strata plus 32 points on the light's rim. A straight occluder edge that
        // cuts off even 1 % of a disk cuts a 45-degree arc of its rim, so the rim points catch
        // the slivers the strata can miss.
        let pilot = strata(8, 1);
        report.rays(64);
        report.pilot(pilot.rgb());
        if pilot == C::ZERO || pilot == C::ONE {
            let rim = |k: usize| {
                let t = (k as f32 + 0.5) / 8.0;
                let u = match (shape, k / 8) {
                    (AreaShape::Sphere { .. }, _) => Vec2::new(0.999, k as f32 / 32.0),
                    (_, 0) => Vec2::new(t, 0.0),
                    (_, 1) => Vec2::new(0.999_999, t - 1.0),
                    (_, 2) => Vec2::new(3.0 - t, 0.999_999),
                    _ => Vec2::new(0.0, 4.0 - t),
                };
                Self::sample_ray(o, light, shape, u)
            };
            let rim_agrees = (0..32).step_by(PACKET).all(|k| {
                let vals = self.trace_chunk::<C>(PACKET, |q| rim(k + q));
                vals.iter().all(|v| *v == pilot)
            });
            report.rays(32);
            report.rim(rim_agrees);
            if rim_agrees {
                return pilot;
            }
        }
        let n = (opts.area_samples as f32).sqrt().round().max(1.0) as u32;
        report.strata(n);
        report.rays(n * n);
        strata(n, 2)
    }

    /// Visibility of every point (`None`: no geometry, left as NaN), rows in parallel on the
    /// current rayon pool; `width` points per row, pixel index = row * width + column. Per
    /// channel when the scene has coloured transmittance ([`Reference::is_coloured`]).
    pub fn visibility(
        &self,
        points: &[Option<SamplePoint>],
        width: usize,
        light: &Light,
        opts: &ReferenceOptions,
    ) -> Visibility {
        if self.coloured {
            Visibility::Rgb(self.visibility_c(points, width, light, opts, Vec3::NAN))
        } else {
            Visibility::Scalar(self.visibility_c(points, width, light, opts, f32::NAN))
        }
    }

    fn visibility_c<C: Channels>(
        &self,
        points: &[Option<SamplePoint>],
        width: usize,
        light: &Light,
        opts: &ReferenceOptions,
        none: C,
    ) -> Vec<C> {
        let mut out = vec![none; points.len()];
        let rows = points.len().div_ceil(width.max(1));
        let _stage = crate::progress::stage("tracing the reference (rows)", rows as u64);
        // Hard shadows trace one ray per pixel: packets of neighbouring pixels' rays measured
        // no faster there (docs/performance.md); an area light's samples of one pixel go in
        // packets (`area_c`).
        out.par_chunks_mut(width.max(1)).enumerate().for_each(|(row, o)| {
            for (x, v) in o.iter_mut().enumerate() {
                let i = row * width + x;
                if let Some(s) = &points[i] {
                    *v = self.area_c(s, light, i as u64, opts, &mut ());
                }
            }
            self.flush_rays();
            crate::progress::advance(1);
        });
        out
    }
}

#[cfg(test)]
mod offset_tests {
    use super::*;
    use proptest::prelude::*;

    /// The components' bits, every NaN as one (Rust leaves a NaN result's sign and payload
    /// unspecified, so two correct forms may give different NaNs).
    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array()
            .map(|c| if c.is_nan() { f32::NAN.to_bits() } else { c.to_bits() })
    }

    /// Coordinates of every kind: any bit pattern (NaN, infinities, subnormals, both zeros),
    /// sizes around the float offset's threshold, and unit-normal-like components.
    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            any::<u32>().prop_map(f32::from_bits),
            (-1.0f32..1.0).prop_map(|t| t * OFFSET_ORIGIN * 2.0),
            -1e4f32..1e4,
            -1.0f32..1.0,
            Just(0.0f32),
            Just(-0.0f32),
            Just(OFFSET_ORIGIN),
            Just(-OFFSET_ORIGIN),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The one-register form is the component-by-component definition, bit for bit.
        #[test]
        fn offset_origin_equals_its_scalar_form(p in [coord(), coord(), coord()], n in [coord(), coord(), coord()]) {
            let (p, n) = (Vec3::from_array(p), Vec3::from_array(n));
            prop_assert_eq!(bits(offset_origin(p, n)), bits(offset_origin_scalar(p, n)), "p {:?} n {:?}", p, n);
        }
    }

    #[test]
    fn offset_origin_saturates_like_a_float_to_int_cast() {
        for n in [
            1e10f32,
            -1e10,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            8388608.0,
            -8388608.0,
        ] {
            for p in [1.0f32, -1.0, 100.0, -100.0, 1e-3] {
                let (p, n) = (Vec3::splat(p), Vec3::new(n, -n, 0.5));
                assert_eq!(
                    bits(offset_origin(p, n)),
                    bits(offset_origin_scalar(p, n)),
                    "p {p} n {n}"
                );
            }
        }
    }
}
