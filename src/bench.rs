//! The benchmark workloads, shared by the CLI (`penumbra bench ...`) and `benches/`:
//!
//! - the **spheres frame**: a shadow-mapped frame that other renderers (Mesa's llvmpipe) can
//!   run identically: ground plane, 8 x 8 UV spheres, a directional light with a fitted
//!   orthographic depth pass, then a 1920 x 1080 camera pass with 2x2 or 5x5 hardware PCF, or
//!   the classic PCSS shader ([`pcss_shadow`]), or a variance shadow map ([`FrameMode::Vsm`]:
//!   moments, a 5-tap box blur, Chebyshev's bound);
//! - **random triangles**: `T` triangles of about `A` pixels each at 1920 x 1080, depth-only
//!   or colour + depth, for triangles/s and pixels/s.

pub use crate::hash::SplitMix;
use crate::hash::{hash_f32, hash_rgba8};
use crate::pipeline::compute::{box_weights, separable_blur_rows};
use crate::pipeline::sampler::CompareSampler;
use crate::pipeline::sampler::{sample_bilinear, Address};
use crate::pipeline::*;
pub use crate::scene::spheres::{sphere_tessellation, spheres_as_scene, spheres_scene, BenchMesh, BenchVertex};
use crate::Error;
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::time::Instant;

/// Shadow filter of the frame benchmark's camera pass.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum FrameMode {
    /// Depth pass only.
    Depth,
    /// One 2x2 hardware comparison per pixel.
    Pcf2,
    /// 25 comparisons on a 5 x 5 texel grid.
    Pcf5,
    /// The classic PCSS shader, fixed so that any renderer runs the same frame
    /// ([`pcss_shadow`]).
    Pcss,
    /// A variance shadow map, fixed so that any renderer runs the same frame: the depth pass
    /// of the same light with no polygon offset gives each texel's moments `(z, z²)` of its
    /// light-space depth `z` in [0, 1] (a two-channel f32 target: [`FrameTargets::moments`]);
    /// a separable 5-tap box blur of both moments (horizontal, then vertical; clamp to edge;
    /// each tap weighted `0.2` and summed from left to right); the camera pass reads the
    /// blurred moments bilinearly at the pixel's map position and shades with Chebyshev's
    /// bound ([`vsm_shadow`]). No bleeding reduction.
    Vsm,
}

impl std::str::FromStr for FrameMode {
    type Err = crate::pipeline::state::UnknownChoice;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let modes = [
            ("depth", FrameMode::Depth),
            ("pcf2", FrameMode::Pcf2),
            ("pcf5", FrameMode::Pcf5),
            ("pcss", FrameMode::Pcss),
            ("vsm", FrameMode::Vsm),
        ];
        crate::pipeline::state::parse_choice(s, "frame mode", &modes)
    }
}

/// Matrices of the spheres frame.
#[derive(Copy, Clone, Debug)]
pub struct FrameSetup {
    /// World to light clip space (orthographic, fitted).
    pub light_vp: Mat4,
    /// World to camera clip space.
    pub camera_vp: Mat4,
    /// Unit direction towards the light.
    pub to_light: Vec3,
    /// When the camera pass runs its program (default: [`Shading::Deferred`]).
    pub shading: Shading,
    /// Face culling of the camera pass (default: [`FRAME_CAMERA_CULL`]).
    pub camera_cull: CullMode,
}

/// The fixed camera and the light frustum fitted to the scene bounds (+0.1 in x/y, +1 in depth).
pub fn frame_setup(mesh: &BenchMesh, width: u32, height: u32) -> FrameSetup {
    let to_light = Vec3::new(0.55, 1.0, 0.35).normalize();
    let (lo, hi) = mesh
        .vertices
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), v| {
            (a.min(v.pos), b.max(v.pos))
        });
    let center = (lo + hi) * 0.5;
    let view = Mat4::look_at_rh(center + to_light * 50.0, center, Vec3::Z);
    let mut vlo = Vec3::splat(f32::MAX);
    let mut vhi = Vec3::splat(f32::MIN);
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let p = view.transform_point3(c);
        vlo = vlo.min(p);
        vhi = vhi.max(p);
    }
    let proj = Mat4::orthographic_rh(
        vlo.x - 0.1,
        vhi.x + 0.1,
        vlo.y - 0.1,
        vhi.y + 0.1,
        -vhi.z - 1.0,
        -vlo.z + 1.0,
    );
    let camera = Mat4::perspective_rh(45f32.to_radians(), width as f32 / height as f32, 0.5, 100.0)
        * Mat4::look_at_rh(Vec3::new(0.0, 13.0, 21.0), Vec3::new(0.0, 0.0, 1.0), Vec3::Y);
    FrameSetup {
        light_vp: proj * view,
        camera_vp: camera,
        to_light,
        shading: Shading::Deferred,
        camera_cull: FRAME_CAMERA_CULL,
    }
}

struct LightDepthVs(Mat4);
impl VertexProgram for LightDepthVs {
    type In = BenchVertex;
    type Out = ();
    #[inline(always)]
    fn run(&self, v: &BenchVertex) -> (Vec4, ()) {
        (self.0 * v.pos.extend(1.0), ())
    }
}

struct CameraVs {
    vp: Mat4,
    light: Mat4,
}
impl VertexProgram for CameraVs {
    type In = BenchVertex;
    type Out = (Vec3, Vec3, Vec3);
    #[inline(always)]
    fn run(&self, v: &BenchVertex) -> (Vec4, (Vec3, Vec3, Vec3)) {
        let p = v.pos.extend(1.0);
        (self.vp * p, (v.normal, (self.light * p).truncate(), v.albedo))
    }
}

/// Blocker-search disk radius of the frame's PCSS shader, in texels.
pub const PCSS_SEARCH_TEXELS: f32 = 16.0;
/// Depth bias of its blocker search (map depth units).
pub const PCSS_SEARCH_BIAS: f32 = 0.0015;
/// Texels of filter radius per unit of map depth between receiver and blockers.
pub const PCSS_PENUMBRA_SCALE: f32 = 400.0;

/// The frame benchmark's PCSS shader (Fernando 2005 with the constants commonly used with
/// it), at map position `uv` and depth `z`: 16 raw-depth taps of [`POISSON16`] scaled to 16
/// texels (nearest texel, clamped to the edge); a tap nearer than `z - 0.0015` is a blocker.
/// No blocker: lit. Otherwise the filter radius `r = clamp((z - 0.0015 - mean blocker depth)
/// * 400, 1, 16)` texels and 16 hardware 2x2 comparisons against `z` on the same disk scaled
/// to `r`, averaged. `tools/llvmpipe_bench.py` runs the same shader in GLSL.
///
/// [`POISSON16`]: crate::shadow::sample::kernel::POISSON16
#[inline]
pub fn pcss_shadow(map: &Surface<f32>, uv: Vec2, z: f32) -> f32 {
    pcss_shadow4(map, Vec4::splat(uv.x), Vec4::splat(uv.y), Vec4::splat(z)).x
}

/// [`pcss_shadow`] of four pixels at once (`u`, `v`, `z` per lane), each lane the shader of
/// its pixel: the lanes are pixels, so the sums run down the lanes in tap order; the filter
/// runs when any lane found a blocker, and lanes without one are lit. (The specification,
/// written tap by tap, is the test's `plain_pcss`.)
#[inline(always)]
pub fn pcss_shadow4(map: &Surface<f32>, u: Vec4, v: Vec4, z: Vec4) -> Vec4 {
    use crate::pipeline::lanes::floor4;
    use crate::pipeline::sampler::texels4;
    use crate::shadow::sample::kernel::{bilinear_compare4, POISSON16};
    let size = map.width() as f32;
    let reference = z - Vec4::splat(PCSS_SEARCH_BIAS);
    let k = PCSS_SEARCH_TEXELS / size;
    let (mut sum, mut found) = (Vec4::ZERO, Vec4::ZERO);
    for p in POISSON16 {
        // The one-pixel call's `floor().clamp(0, size - 1)`, the clamp inside `texels4`.
        let tx = floor4((u + Vec4::splat(p.x * k)) * size);
        let ty = floor4((v + Vec4::splat(p.y * k)) * size);
        let depth = texels4(map, tx, ty);
        let blocker = depth.cmplt(reference);
        sum += Vec4::select(blocker, depth, Vec4::ZERO);
        found += Vec4::select(blocker, Vec4::ONE, Vec4::ZERO);
    }
    let any = found.cmpgt(Vec4::ZERO);
    if !any.any() {
        return Vec4::ONE;
    }
    // Lanes without a blocker take radius 1 (their result is replaced by 1 below).
    let r = Vec4::select(
        any,
        ((reference - sum / found) * PCSS_PENUMBRA_SCALE).clamp(Vec4::ONE, Vec4::splat(PCSS_SEARCH_TEXELS)),
        Vec4::ONE,
    );
    let s = r / Vec4::splat(size);
    let mut lit = Vec4::ZERO;
    for p in POISSON16 {
        lit += bilinear_compare4(map, u + Vec4::splat(p.x) * s, v + Vec4::splat(p.y) * s, z);
    }
    Vec4::select(any, lit / Vec4::splat(16.0), Vec4::ONE)
}

/// Smallest variance of the frame's VSM shader (in squared map depth units).
pub const VSM_MIN_VARIANCE: f32 = 0.00002;

/// Taps each side of the frame's VSM box blur (5 taps).
pub const VSM_BLUR_RADIUS: usize = 2;

/// The frame benchmark's VSM shader at map position `uv` and depth `z`: the blurred moments
/// `(μ, m2)` read bilinearly (clamp to edge), then Chebyshev's bound (RTR eq. 7.8): 1 where
/// `z <= μ`, else `σ² / (σ² + (z − μ)²)` with `σ² = max(m2 − μ², 0.00002)`.
/// `tools/llvmpipe_bench.py` runs the same shader in GLSL.
#[inline]
pub fn vsm_shadow(moments: &Surface<Vec2>, uv: Vec2, z: f32) -> f32 {
    let m = sample_bilinear(moments, uv, Address::Clamp);
    crate::shadow::filtered::chebyshev(m.x, m.y, z, VSM_MIN_VARIANCE).0
}

struct CameraFs<'a> {
    map: &'a Surface<f32>,
    /// The blurred moments (VSM mode).
    moments: Option<&'a Surface<Vec2>>,
    to_light: Vec3,
    mode: FrameMode,
    sampler: CompareSampler,
}
impl FragmentProgram<(Vec3, Vec3, Vec3)> for CameraFs<'_> {
    const PREFETCHES: bool = true;

    #[inline(always)]
    fn shade(&self, f: &Fragment<(Vec3, Vec3, Vec3)>) -> Option<Vec4> {
        let (n, l, albedo) = f.var;
        let ndl = n.normalize_or_zero().dot(self.to_light).max(0.0);
        let uv = Vec2::new(l.x * 0.5 + 0.5, 0.5 - l.y * 0.5);
        let shadow = match self.mode {
            FrameMode::Pcf5 => self.sampler.pcf_grid(self.map, uv, l.z, 5),
            FrameMode::Pcss => pcss_shadow(self.map, uv, l.z),
            FrameMode::Vsm => vsm_shadow(self.moments.expect("VSM mode has moments"), uv, l.z),
            _ => self.sampler.pcf2x2(self.map, uv, l.z),
        };
        Some((albedo * (0.15 + 0.85 * ndl * shadow)).extend(1.0))
    }

    /// The 2 x 2 footprints' texels, ahead of `shade4` (the map is 16 MB: far beyond the
    /// caches, so its lines are fetched from memory once per frame). Not for `pcf5`: its 25
    /// taps per pixel hide the latency already, and prefetching its 6 x 6 footprints measured
    /// slower.
    #[inline(always)]
    fn prefetch4(&self, f: &Fragment4<(Vec3, Vec3, Vec3)>) {
        if self.mode == FrameMode::Pcf2 {
            let (u, v, _) = map_coords4(f);
            CompareSampler::prefetch2x2_4(self.map, u, v);
        }
    }

    /// `shade` on four lanes, in the same operation order (bit-identical per lane).
    #[inline(always)]
    fn shade4(&self, f: &Fragment4<(Vec3, Vec3, Vec3)>) -> Color4 {
        let [a, b, c] = f.verts;
        let n = f.interpolate3(a.0, b.0, c.0);
        let albedo = f.interpolate3(a.2, b.2, c.2);
        let ndl = n.normalize_or_zero().dot(self.to_light).max(Vec4::ZERO);
        let (u, v, z) = map_coords4(f);
        let shadow = match self.mode {
            FrameMode::Pcf5 => self.sampler.pcf_grid_4(self.map, u, v, z, 5),
            FrameMode::Pcss => pcss_shadow4(self.map, u, v, z),
            FrameMode::Vsm => {
                let m = self.moments.expect("VSM mode has moments");
                Vec4::from_array(std::array::from_fn(|i| vsm_shadow(m, Vec2::new(u[i], v[i]), z[i])))
            }
            _ => self.sampler.pcf2x2_4(self.map, u, v, z),
        };
        let k = Vec4::splat(0.15) + Vec4::splat(0.85) * ndl * shadow;
        let rgb = albedo.scale(k);
        Color4 {
            r: rgb.x,
            g: rgb.y,
            b: rgb.z,
            a: Vec4::ONE,
        }
    }
}

/// Shadow-map coordinates and reference depth of four lanes of the frame's camera pass: the
/// light-space position (second varying) as `(x * 0.5 + 0.5, 0.5 - y * 0.5, z)`, as `shade`
/// computes them.
#[inline(always)]
fn map_coords4(f: &Fragment4<(Vec3, Vec3, Vec3)>) -> (Vec4, Vec4, Vec4) {
    let [a, b, c] = f.verts;
    let l = f.interpolate3(a.1, b.1, c.1);
    let half = Vec4::splat(0.5);
    (l.x * half + half, half - l.y * half, l.z)
}

/// The render targets of one spheres frame, reused across repetitions.
pub struct FrameTargets {
    /// Light depth map (S x S).
    pub shadow: Surface<f32>,
    /// Camera colour.
    pub color: Surface<Rgba8>,
    /// Camera depth.
    pub depth: Surface<f32>,
    /// The blurred moments of the light's depth (VSM mode; made by its first frame).
    pub moments: Option<Surface<Vec2>>,
}

impl FrameTargets {
    /// Targets for an `s` x `s` map and a `w` x `h` image.
    pub fn new(s: u32, w: u32, h: u32) -> Result<Self, PipelineError> {
        Ok(FrameTargets {
            shadow: Surface::new(s, s, 1.0)?,
            color: Surface::new(w, h, [0; 4])?,
            depth: Surface::new(w, h, 1.0)?,
            moments: None,
        })
    }
}

/// Per-pass counters and times of one frame.
#[derive(Copy, Clone, Debug, Default)]
pub struct FrameTimes {
    /// Light depth pass, milliseconds.
    pub ms_depth: f64,
    /// Camera pass, milliseconds (0 in depth mode).
    pub ms_main: f64,
    /// The moments and their blur, milliseconds (VSM mode; else 0).
    pub ms_prefilter: f64,
    /// Depth-pass counters.
    pub depth_stats: DrawStats,
    /// Camera-pass counters.
    pub main_stats: DrawStats,
    /// Light depth pass, per-stage times.
    pub depth_stages: StageTimes,
    /// Camera pass, per-stage times.
    pub main_stages: StageTimes,
}

/// Polygon offset of the spheres frame's depth pass (slope 1.1, constant 4 units).
pub const FRAME_POLYGON_OFFSET: PolygonOffset = PolygonOffset {
    factor: 1.1,
    units: 4.0,
};

/// The depth pass's polygon offset in `mode`: [`FRAME_POLYGON_OFFSET`], none for VSM (its
/// moments need the surface's own depth; Chebyshev's bound is its bias).
pub fn frame_polygon_offset(mode: FrameMode) -> PolygonOffset {
    match mode {
        FrameMode::Vsm => PolygonOffset::default(),
        _ => FRAME_POLYGON_OFFSET,
    }
}

/// Default face culling of the spheres frame's camera pass: back faces, which the closed
/// spheres seen from outside always hide behind their front faces (the image is the same as
/// without culling, a test checks it; the pass skips their set-up and depth tests). The light
/// pass culls nothing, as issue 2 asks.
pub const FRAME_CAMERA_CULL: CullMode = CullMode::Back;

/// Colour the spheres frame's camera pass clears to.
pub const FRAME_CLEAR_COLOR: Rgba8 = [13, 13, 20, 255];

/// Renders one spheres frame into `t`. Per-stage times of each pass are taken from the
/// pipeline's accumulator ([`Pipeline::take_times`]) into the result.
pub fn render_frame(
    p: &Pipeline,
    mesh: &BenchMesh,
    setup: &FrameSetup,
    mode: FrameMode,
    t: &mut FrameTargets,
) -> Result<FrameTimes, PipelineError> {
    let mut out = FrameTimes::default();
    // Pass 1: depth from the light, no culling, polygon offset (slope 1.1, constant 4).
    let t0 = Instant::now();
    let state = RenderState {
        offset: frame_polygon_offset(mode),
        ..Default::default()
    };
    // The clear rides along with the draw (tile by tile, in cache).
    out.depth_stats = p.draw(
        &mut Targets::depth_only(&mut t.shadow).clearing_depth(1.0),
        &state,
        &mesh.vertices,
        &mesh.indices,
        &LightDepthVs(setup.light_vp),
        &DepthOnly,
    )?;
    out.ms_depth = t0.elapsed().as_secs_f64() * 1e3;
    out.depth_stages = p.take_times();
    if mode == FrameMode::Depth {
        return Ok(out);
    }
    if mode == FrameMode::Vsm {
        // The moments (z, z²) of each texel, blurred by 5 x 5 box taps, the source rows
        // computed from the depth map as the blur reads them.
        let t0 = Instant::now();
        let s = t.shadow.width();
        let moments = match &mut t.moments {
            Some(m) if m.width() == s && m.height() == s => m,
            slot => slot.insert(Surface::new(s, s, Vec2::ZERO)?),
        };
        let shadow = &t.shadow;
        separable_blur_rows(p, moments, &box_weights(VSM_BLUR_RADIUS), |y, row| {
            for (o, &z) in row.iter_mut().zip(shadow.row(y)) {
                *o = Vec2::new(z, z * z);
            }
        })?;
        out.ms_prefilter = t0.elapsed().as_secs_f64() * 1e3;
    }
    // Pass 2: camera view, colour + depth, shadowed Lambert.
    let t1 = Instant::now();
    let fs = CameraFs {
        map: &t.shadow,
        moments: t.moments.as_ref().filter(|_| mode == FrameMode::Vsm),
        to_light: setup.to_light,
        mode,
        sampler: CompareSampler::default(),
    };
    let vs = CameraVs {
        vp: setup.camera_vp,
        light: setup.light_vp,
    };
    out.main_stats = p.draw(
        &mut Targets::color(&mut t.color)
            .clearing_color(FRAME_CLEAR_COLOR)
            .with_depth(&mut t.depth)
            .clearing_depth(1.0),
        &RenderState {
            shading: setup.shading,
            cull: setup.camera_cull,
            ..Default::default()
        },
        &mesh.vertices,
        &mesh.indices,
        &vs,
        &fs,
    )?;
    out.ms_main = t1.elapsed().as_secs_f64() * 1e3;
    out.main_stages = p.take_times();
    Ok(out)
}

/// Hash of a frame's outputs (the image in colour modes, the shadow map in depth mode).
pub fn frame_hash(t: &FrameTargets, mode: FrameMode) -> u64 {
    match mode {
        FrameMode::Depth => hash_f32(t.shadow.data()),
        _ => hash_rgba8(t.color.data()),
    }
}

/// `t` random triangles of about `area` pixels each (equilateral, random rotation, position and
/// depth) in clip space for a `w` x `h` target, with a per-vertex colour.
pub fn random_triangles(t: usize, area: f32, w: u32, h: u32, seed: u64) -> (Vec<(Vec4, Vec4)>, Vec<u32>) {
    let mut rng = SplitMix(seed);
    let side = (4.0 * area / 3f32.sqrt()).sqrt();
    let circum = side / 3f32.sqrt();
    let mut verts = Vec::with_capacity(3 * t);
    for _ in 0..t {
        let cx = rng.next_f32() * w as f32;
        let cy = rng.next_f32() * h as f32;
        let z = rng.next_f32();
        let rot = rng.next_f32() * std::f32::consts::TAU;
        let col = Vec4::new(rng.next_f32(), rng.next_f32(), rng.next_f32(), 1.0);
        for k in 0..3 {
            let a = rot + k as f32 * std::f32::consts::TAU / 3.0;
            let x = cx + circum * crate::math::cos(a);
            let y = cy + circum * crate::math::sin(a);
            verts.push((
                Vec4::new(x / w as f32 * 2.0 - 1.0, 1.0 - y / h as f32 * 2.0, z, 1.0),
                col,
            ));
        }
    }
    let indices = (0..3 * t as u32).collect();
    (verts, indices)
}

/// Vertex program of the random-triangle workload: clip position and a colour varying.
pub struct ColoredClip;
impl VertexProgram for ColoredClip {
    type In = (Vec4, Vec4);
    type Out = Vec4;
    #[inline(always)]
    fn run(&self, v: &(Vec4, Vec4)) -> (Vec4, Vec4) {
        (v.0, v.1)
    }
}

/// Fragment program of the random-triangle workload: the interpolated colour.
pub struct VaryingColor;
impl FragmentProgram<Vec4> for VaryingColor {
    #[inline(always)]
    fn shade(&self, f: &Fragment<Vec4>) -> Option<Vec4> {
        Some(f.var)
    }
    #[inline(always)]
    fn shade4(&self, f: &Fragment4<Vec4>) -> Color4 {
        let [a, b, c] = f.verts;
        Color4 {
            r: f.interpolate(a.x, b.x, c.x),
            g: f.interpolate(a.y, b.y, c.y),
            b: f.interpolate(a.z, b.z, c.z),
            a: f.interpolate(a.w, b.w, c.w),
        }
    }
}

pub use crate::metrics::median_of as median;

/// Draws the random-triangle workload ([`random_triangles`]) as `bench raster` and the
/// criterion benches time it: colour + depth when `color` is given (per-vertex colour), else
/// depth only; both targets cleared with the draw (black, depth 1), as a render pass's
/// load-op clear.
pub fn draw_random(
    p: &Pipeline,
    color: Option<&mut Surface<Rgba8>>,
    depth: &mut Surface<f32>,
    state: &RenderState,
    verts: &[(Vec4, Vec4)],
    idx: &[u32],
) -> Result<DrawStats, PipelineError> {
    match color {
        Some(color) => p.draw(
            &mut Targets::color(color)
                .clearing_color([0, 0, 0, 255])
                .with_depth(depth)
                .clearing_depth(1.0),
            state,
            verts,
            idx,
            &ColoredClip,
            &VaryingColor,
        ),
        None => p.draw(
            &mut Targets::depth_only(depth).clearing_depth(1.0),
            state,
            verts,
            idx,
            &ColoredClip,
            &DepthOnly,
        ),
    }
}

/// Writes a workload for another renderer to run identically (the llvmpipe comparison,
/// `tools/llvmpipe_bench.py`): `dir/vertices.f32` (little-endian `f32`, as many per vertex as
/// `meta`'s `floats_per_vertex` says), `dir/indices.u32` (little-endian, three per triangle)
/// and `dir/workload.json` (`meta`, a JSON object that names the layout, targets and
/// matrices).
pub fn export_workload(dir: &std::path::Path, vertices: &[f32], indices: &[u32], meta: &str) -> Result<(), Error> {
    let write = |name: &str, bytes: &[u8]| crate::output::write_plain(&dir.join(name), bytes);
    crate::output::create_folder(dir)?;
    write(
        "vertices.f32",
        &vertices.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>(),
    )?;
    write(
        "indices.u32",
        &indices.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>(),
    )?;
    write("workload.json", meta.as_bytes())
}

/// The spheres frame as an [`export_workload`] (position, normal, albedo per vertex; the
/// matrices column-major, as OpenGL takes them).
pub fn export_frame(
    dir: &std::path::Path,
    mesh: &BenchMesh,
    setup: &FrameSetup,
    mode: FrameMode,
    map: u32,
    (width, height): (u32, u32),
) -> Result<(), Error> {
    let verts: Vec<f32> = mesh
        .vertices
        .iter()
        .flat_map(|v| [v.pos.to_array(), v.normal.to_array(), v.albedo.to_array()].concat())
        .collect();
    let [r, g, b, a] = FRAME_CLEAR_COLOR;
    // f32 values in their shortest form that reads back to the same f32.
    let meta = serde_json::json!({
        "kind": "frame",
        "floats_per_vertex": 9,
        "mode": format!("{mode:?}").to_lowercase(),
        "map": map,
        "width": width,
        "height": height,
        "polygon_offset": [frame_polygon_offset(mode).factor, frame_polygon_offset(mode).units],
        "vsm": {"blur_taps": 2 * VSM_BLUR_RADIUS + 1, "min_variance": VSM_MIN_VARIANCE},
        "light_vp": setup.light_vp.to_cols_array(),
        "camera_vp": setup.camera_vp.to_cols_array(),
        "to_light": setup.to_light.to_array(),
        "clear_color": [r, g, b, a],
        "camera_cull": setup.camera_cull.name(),
    })
    .to_string()
        + "\n";
    export_workload(dir, &verts, &mesh.indices, &meta)
}

/// The random-triangle workload as an [`export_workload`] (clip position and colour per
/// vertex, `Vec4` each).
pub fn export_raster(
    dir: &std::path::Path,
    verts: &[(Vec4, Vec4)],
    indices: &[u32],
    color: bool,
    (width, height): (u32, u32),
) -> Result<(), Error> {
    let floats: Vec<f32> = verts
        .iter()
        .flat_map(|(p, c)| [p.to_array(), c.to_array()].concat())
        .collect();
    let meta = serde_json::json!({
        "kind": "raster",
        "floats_per_vertex": 8,
        "mode": if color { "color" } else { "depth" },
        "width": width,
        "height": height,
    })
    .to_string()
        + "\n";
    export_workload(dir, &floats, indices, &meta)
}

/// The spheres frame's light pass drawn at the samples of `grid` (the map `depth`, of the
/// grid's size): the same vertices, state and polygon offset as [`render_frame`]'s first
/// pass, for comparing the sample-position raster mode with the standard one.
pub fn depth_pass_at(
    p: &Pipeline,
    mesh: &BenchMesh,
    setup: &FrameSetup,
    grid: &crate::pipeline::samples::SampleGrid,
    depth: &mut Surface<f32>,
) -> Result<DrawStats, PipelineError> {
    use rayon::prelude::*;
    let state = RenderState {
        offset: frame_polygon_offset(FrameMode::Depth),
        ..Default::default()
    };
    let vp = setup.light_vp;
    let positions: Vec<Vec4> = p.install(|| {
        mesh.vertices
            .par_iter()
            .with_min_len(1024)
            .map(|v| vp * v.pos.extend(1.0))
            .collect()
    });
    p.draw_depth_at(depth, Some(1.0), &state, &positions, &mesh.indices, grid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shadow::sample::kernel::POISSON16;

    /// The frame's PCSS shader written plainly from its specification, one tap at a time.
    fn plain_pcss(map: &Surface<f32>, uv: Vec2, z: f32) -> f32 {
        let size = map.width() as f32;
        let reference = z - 0.0015;
        let (mut sum, mut found) = (0.0f32, 0u32);
        for d in POISSON16 {
            let t = (uv + d * (16.0 / size)) * size;
            let last = map.width() as i64 - 1;
            let (x, y) = ((t.x.floor() as i64).clamp(0, last), (t.y.floor() as i64).clamp(0, last));
            let depth = map.at(x as u32, y as u32);
            if depth < reference {
                sum += depth;
                found += 1;
            }
        }
        if found == 0 {
            return 1.0;
        }
        let r = ((reference - sum / found as f32) * 400.0).clamp(1.0, 16.0);
        let s = CompareSampler::default();
        POISSON16
            .iter()
            .map(|&d| s.pcf2x2(map, uv + d * (r / size), z))
            .fold(0.0, |a, b| a + b)
            / 16.0
    }

    /// The frame's VSM: the blurred moments are the 5 x 5 box of `(z, z²)` (clamped taps),
    /// and the shader is Chebyshev's bound on the bilinear moments, both written plainly.
    #[test]
    fn the_frames_vsm_is_its_specification() {
        let p = Pipeline::new(2).unwrap();
        let mesh = spheres_scene(2_000);
        let setup = frame_setup(&mesh, 96, 54);
        let mut t = FrameTargets::new(64, 96, 54).unwrap();
        render_frame(&p, &mesh, &setup, FrameMode::Vsm, &mut t).unwrap();
        let (map, m) = (&t.shadow, t.moments.as_ref().unwrap());
        let n = map.width() as i64;
        let z = |x: i64, y: i64| map.at(x.clamp(0, n - 1) as u32, y.clamp(0, n - 1) as u32);
        let mut worst = 0f32;
        for y in 0..n {
            for x in 0..n {
                let (mut s1, mut s2) = (0f64, 0f64);
                for j in -2..=2 {
                    for i in -2..=2 {
                        let d = z(x + i, y + j) as f64;
                        s1 += d;
                        s2 += d * d;
                    }
                }
                let got = m.at(x as u32, y as u32);
                worst = worst
                    .max((got.x - (s1 / 25.0) as f32).abs())
                    .max((got.y - (s2 / 25.0) as f32).abs());
            }
        }
        assert!(worst < 1e-6, "moments off the 5x5 box by {worst}");
        // The shader against the bound written out, on and between texel centres.
        let mut rng = SplitMix(5);
        let (mut lit, mut mixed) = (0, 0);
        for _ in 0..2000 {
            let uv = Vec2::new(rng.next_f32(), rng.next_f32());
            let zr = rng.next_f32();
            let f = uv * n as f32 - Vec2::splat(0.5);
            let (x0, y0) = (f.x.floor() as i64, f.y.floor() as i64);
            let (fx, fy) = (f.x - x0 as f32, f.y - y0 as f32);
            let at = |x: i64, y: i64| m.at(x.clamp(0, n - 1) as u32, y.clamp(0, n - 1) as u32);
            let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
            let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
            let mu = top * (1.0 - fy) + bottom * fy;
            let var = (mu.y - mu.x * mu.x).max(0.00002);
            let want = if zr <= mu.x {
                1.0
            } else {
                var / (var + (zr - mu.x) * (zr - mu.x))
            };
            let got = vsm_shadow(m, uv, zr);
            assert!((got - want).abs() < 1e-5, "{uv} {zr}: {got} against {want}");
            if got == 1.0 {
                lit += 1;
            } else if got < 0.99 {
                mixed += 1;
            }
        }
        assert!(lit > 100 && mixed > 100, "lit {lit}, shadowed {mixed}");
        assert!(t.color.data().iter().any(|c| c[0] > 40) && frame_hash(&t, FrameMode::Vsm) != 0);
    }

    #[test]
    fn the_frames_pcss_shader_is_its_specification_bit_for_bit() {
        let mut rng = SplitMix(21);
        // Smooth depths with steps, so that every branch (no blocker, some, all) is taken.
        let n = 128u32;
        let data: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32, (i / n) as f32);
                0.5 + 0.002 * crate::math::sin(x * 0.3) + if (x + y) as u32 % 37 < 9 { -0.01 } else { 0.0 }
            })
            .collect();
        let map = Surface::from_vec(n, n, data).unwrap();
        let (mut lit, mut mixed) = (0, 0);
        let mut quad = Vec::new();
        for _ in 0..5000 {
            let uv = Vec2::new(rng.next_f32() * 1.2 - 0.1, rng.next_f32() * 1.2 - 0.1);
            let z = 0.49 + 0.02 * rng.next_f32();
            let (a, b) = (pcss_shadow(&map, uv, z), plain_pcss(&map, uv, z));
            assert_eq!(a.to_bits(), b.to_bits(), "{uv} {z}: {a} vs {b}");
            quad.push((uv, z, a));
            if quad.len() == 4 {
                let lanes = |f: fn(&(Vec2, f32, f32)) -> f32| Vec4::from_array(std::array::from_fn(|i| f(&quad[i])));
                let four = pcss_shadow4(&map, lanes(|q| q.0.x), lanes(|q| q.0.y), lanes(|q| q.1));
                for (i, q) in quad.drain(..).enumerate() {
                    assert_eq!(four[i].to_bits(), q.2.to_bits(), "lane {i} at {} {}", q.0, q.1);
                }
            }
            if a == 1.0 {
                lit += 1;
            } else if a > 0.0 {
                mixed += 1;
            }
        }
        assert!(lit > 100 && mixed > 100, "lit {lit}, mixed {mixed}");
    }
}
