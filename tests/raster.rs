//! Pipeline invariants: watertightness, conservative coverage against exact tests, fragment
//! lists, stencil counting, clipping and depth clamp, blending, bad input, determinism.

use crate::common;
use common::{fan, fan_covers, jittered_grid, orient};
use glam::{Vec3, Vec4};
use penumbra::bench::SplitMix;
use penumbra::pipeline::*;
use proptest::prelude::*;

/// Target size used by the window-space tests: a power of two, so fixed-point window
/// coordinates survive the trip through NDC exactly.
const W: u32 = 256;
const H: u32 = 256;

/// A window position in 1/256 pixels to clip space (w = 1).
fn clip(x: i64, y: i64, z: f32) -> Vec4 {
    common::window_to_clip(x, y, z, (W, H))
}

/// Draws window-space triangles (fixed-point vertices) with additive blending into a count
/// target; returns the per-pixel counts and the stats.
fn coverage(p: &Pipeline, tris: &[[(i64, i64); 3]], mode: RasterMode) -> (Surface<f32>, DrawStats) {
    let mut verts = Vec::new();
    for t in tris {
        for &(x, y) in t {
            verts.push(clip(x, y, 0.5));
        }
    }
    let idx: Vec<u32> = (0..verts.len() as u32).collect();
    let mut count = Surface::new(W, H, 0.0f32).unwrap();
    let state = RenderState {
        raster: mode,
        blend: BlendMode::Add,
        depth: DepthState {
            func: CompareFunc::Always,
            write: false,
            ..Default::default()
        },
        ..Default::default()
    };
    let stats = p
        .draw(
            &mut Targets::color(&mut count),
            &state,
            &verts,
            &idx,
            &ClipPassthrough,
            &Shader(|_: &Fragment<()>| Vec4::ONE),
        )
        .unwrap();
    (count, stats)
}

/// Point inside the closed triangle (either winding).
fn in_closed_tri(t: &[(i64, i64); 3], p: (i64, i64)) -> bool {
    let d = [orient(t[0], t[1], p), orient(t[1], t[2], p), orient(t[2], t[0], p)];
    (d.iter().all(|&v| v >= 0)) || (d.iter().all(|&v| v <= 0))
}

/// Closed segments intersect (exact).
fn segs_intersect(a: (i64, i64), b: (i64, i64), c: (i64, i64), d: (i64, i64)) -> bool {
    let o1 = orient(a, b, c).signum();
    let o2 = orient(a, b, d).signum();
    let o3 = orient(c, d, a).signum();
    let o4 = orient(c, d, b).signum();
    let on = |p: (i64, i64), q: (i64, i64), r: (i64, i64)| {
        r.0 >= p.0.min(q.0) && r.0 <= p.0.max(q.0) && r.1 >= p.1.min(q.1) && r.1 <= p.1.max(q.1)
    };
    if o1 != o2 && o3 != o4 {
        return true;
    }
    (o1 == 0 && on(a, b, c)) || (o2 == 0 && on(a, b, d)) || (o3 == 0 && on(c, d, a)) || (o4 == 0 && on(c, d, b))
}

/// Exact test, independent of the rasterizer's edge-shift method: does the closed pixel
/// square (px, py) touch the closed triangle? (A vertex inside the square, a corner inside the
/// triangle, or two edges crossing.)
fn square_touches(t: &[(i64, i64); 3], px: i64, py: i64) -> bool {
    let (x0, y0, x1, y1) = (px * 256, py * 256, px * 256 + 256, py * 256 + 256);
    if t.iter().any(|&(x, y)| x >= x0 && x <= x1 && y >= y0 && y <= y1) {
        return true;
    }
    let c = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)];
    if c.iter().any(|&q| in_closed_tri(t, q)) {
        return true;
    }
    (0..3).any(|i| (0..4).any(|j| segs_intersect(t[i], t[(i + 1) % 3], c[j], c[(j + 1) % 4])))
}

/// Exact test: the closed pixel square lies inside the closed triangle.
fn square_inside(t: &[(i64, i64); 3], px: i64, py: i64) -> bool {
    let (x0, y0, x1, y1) = (px * 256, py * 256, px * 256 + 256, py * 256 + 256);
    [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        .iter()
        .all(|&q| in_closed_tri(t, q))
}

fn center(px: i64, py: i64) -> (i64, i64) {
    (px * 256 + 128, py * 256 + 128)
}

/// Draws clip-space triangles into a depth target only.
fn draw_depth(
    p: &Pipeline,
    depth: &mut Surface<f32>,
    state: RenderState,
    verts: &[Vec4],
    idx: &[u32],
) -> Result<DrawStats, PipelineError> {
    p.draw(
        &mut Targets::depth_only(depth),
        &state,
        verts,
        idx,
        &ClipPassthrough,
        &DepthOnly,
    )
}

fn pipeline(threads: usize) -> Pipeline {
    Pipeline::new(threads).unwrap()
}

fn fixed_coord() -> impl Strategy<Value = i64> {
    // Inside and a little beyond a 256-pixel target (so triangles cross tile and target edges).
    -2048i64..(W as i64 * 256 + 2048)
}

fn fixed_tri() -> impl Strategy<Value = [(i64, i64); 3]> {
    proptest::array::uniform3((fixed_coord(), fixed_coord()))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// A jittered grid of quads (two triangles each, both diagonals) covers every pixel centre
    /// inside it exactly once and nothing outside.
    #[test]
    fn grids_are_watertight(nx in 1usize..9, ny in 1usize..9, seed in any::<u64>(), x0 in 0i64..3000, y0 in 0i64..3000) {
        let mut rng = SplitMix(seed);
        let (x1, y1) = (W as i64 * 256 - 1 - (rng.next_u64() % 3000) as i64, H as i64 * 256 - 1 - (rng.next_u64() % 3000) as i64);
        let tris = jittered_grid(&mut rng, nx, ny, (x0, y0), (x1, y1));
        let (count, _) = coverage(&pipeline(2), &tris, RasterMode::Standard);
        for py in 0..H as i64 {
            for px in 0..W as i64 {
                let (cx, cy) = center(px, py);
                let c = count.at(px as u32, py as u32);
                let inside = cx > x0 && cx < x1 && cy > y0 && cy < y1;
                let outside = cx < x0 || cx > x1 || cy < y0 || cy > y1;
                if inside { prop_assert_eq!(c, 1.0, "pixel ({}, {}) inside the grid", px, py); }
                if outside { prop_assert_eq!(c, 0.0, "pixel ({}, {}) outside the grid", px, py); }
                prop_assert!(c <= 1.0);
            }
        }
    }

    /// A fan of triangles around a centre (including thin slivers) never covers a pixel twice,
    /// and covers every centre that is strictly inside one of its triangles or on a spoke.
    #[test]
    fn fans_are_watertight(n in 3usize..40, cx in 0i64..65536, cy in 0i64..65536, seed in any::<u64>()) {
        let mut rng = SplitMix(seed);
        let c = (cx, cy);
        let (tris, rim) = fan(&mut rng, n, c);
        let (count, _) = coverage(&pipeline(2), &tris, RasterMode::Standard);
        for py in 0..H as i64 {
            for px in 0..W as i64 {
                let p = center(px, py);
                let v = count.at(px as u32, py as u32);
                prop_assert!(v <= 1.0, "pixel ({}, {}) covered {} times", px, py, v);
                if fan_covers(&tris, &rim, c, p) {
                    prop_assert_eq!(v, 1.0, "pixel ({}, {}) must be covered once", px, py);
                }
            }
        }
    }

    /// The same for small triangles (under 32 pixels: the rasterizer's `i32` path), placed
    /// across tile corners and the target's edges.
    #[test]
    fn conservative_modes_are_exact_for_small_triangles(c in (-4096i64..69632, -4096i64..69632), d in proptest::array::uniform3((-4000i64..4000, -4000i64..4000))) {
        let t = [(c.0 + d[0].0, c.1 + d[0].1), (c.0 + d[1].0, c.1 + d[1].1), (c.0 + d[2].0, c.1 + d[2].1)];
        check_modes(t)?;
    }

    /// Overestimate equals the exact "square touches triangle" test and contains standard
    /// coverage; underestimate equals the exact "square inside triangle" test.
    #[test]
    fn conservative_modes_are_exact(t in fixed_tri()) {
        check_modes(t)?;
    }

}

fn check_modes(t: [(i64, i64); 3]) -> Result<(), TestCaseError> {
    if orient(t[0], t[1], t[2]) == 0 {
        return Ok(());
    }
    let p = pipeline(2);
    let (std_c, _) = coverage(&p, &[t], RasterMode::Standard);
    let (over, _) = coverage(&p, &[t], RasterMode::Overestimate);
    let (under, _) = coverage(&p, &[t], RasterMode::Underestimate);
    for py in 0..H as i64 {
        for px in 0..W as i64 {
            let (s, o, u) = (
                std_c.at(px as u32, py as u32),
                over.at(px as u32, py as u32),
                under.at(px as u32, py as u32),
            );
            prop_assert_eq!(o == 1.0, square_touches(&t, px, py), "overestimate at ({}, {})", px, py);
            prop_assert_eq!(u == 1.0, square_inside(&t, px, py), "underestimate at ({}, {})", px, py);
            prop_assert!(
                s <= o && u <= s,
                "standard not between under and over at ({}, {})",
                px,
                py
            );
            if s == 1.0 {
                prop_assert!(in_closed_tri(&t, center(px, py)));
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Lists hold exactly the fragments that passed, each pixel's list in submission order,
    /// identically for 1 and 3 threads.
    #[test]
    fn fragment_lists_count_and_order(seed in any::<u64>(), n in 1usize..60) {
        let mut rng = SplitMix(seed);
        let tris: Vec<[(i64, i64); 3]> = (0..n).map(|_| {
            let r = |rng: &mut SplitMix| (rng.next_u64() % (W as u64 * 256)) as i64;
            [(r(&mut rng), r(&mut rng)), (r(&mut rng), r(&mut rng)), (r(&mut rng), r(&mut rng))]
        }).collect();
        let mut verts = Vec::new();
        for t in &tris { for &(x, y) in t { verts.push(clip(x, y, rng.next_f32())); } }
        let idx: Vec<u32> = (0..verts.len() as u32).collect();
        let run = |threads: usize| {
            let mut lists = FragmentLists::new(W, H, 1 << 22).unwrap();
            let state = RenderState { depth: DepthState { func: CompareFunc::Always, write: false, ..Default::default() }, ..Default::default() };
            let stats = pipeline(threads).draw(&mut Targets::none().with_lists(&mut lists), &state, &verts, &idx, &ClipPassthrough,
                &Shader(|f: &Fragment<()>| Vec4::splat(f.prim as f32))).unwrap();
            (lists, stats)
        };
        let (lists, stats) = run(1);
        let (lists3, stats3) = run(3);
        prop_assert_eq!(stats, stats3);
        prop_assert_eq!(lists.nodes(), lists3.nodes());
        prop_assert_eq!(lists.len() as u64, stats.fragments_passed);
        prop_assert_eq!(stats.list_nodes, stats.fragments_passed);
        let (count, _) = coverage(&pipeline(2), &tris, RasterMode::Standard);
        for y in 0..H { for x in 0..W {
            let prims: Vec<u32> = lists.iter(x, y).map(|n| n.prim).collect();
            prop_assert!(prims.windows(2).all(|w| w[0] < w[1]), "list at ({}, {}) out of order: {:?}", x, y, prims);
            prop_assert_eq!(prims.len() as f32, count.at(x, y));
        }}
    }

    /// Two-sided stencil over closed boxes in front of a receiver: z-pass (incr front, decr back
    /// on depth pass) and z-fail (incr back, decr front on depth fail) both give, per pixel,
    /// the number of boxes containing the receiver point (exact ray cast, orthographic view).
    #[test]
    fn stencil_counts_volumes(seed in any::<u64>(), n in 1usize..12) {
        let mut rng = SplitMix(seed);
        let zr = 0.5f32;
        let boxes: Vec<(Vec3, Vec3)> = (0..n).map(|_| {
            let a = Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 0.9 + 0.05);
            let s = Vec3::new(rng.next_f32() * 0.8 + 0.05, rng.next_f32() * 0.8 + 0.05, rng.next_f32() * 0.5 + 0.05);
            (a, (a + s).min(Vec3::new(1.5, 1.5, 0.99)))
        }).collect();
        let mut verts = Vec::new();
        let mut idx = Vec::new();
        for (lo, hi) in &boxes { push_box(&mut verts, &mut idx, *lo, *hi); }
        let p = pipeline(2);
        for zfail in [false, true] {
            let mut depth = Surface::new(W, H, zr).unwrap();
            let mut stencil = Surface::new(W, H, 0u8).unwrap();
            let (front, back) = if zfail {
                (StencilFace { depth_fail: StencilOp::DecrWrap, ..Default::default() }, StencilFace { depth_fail: StencilOp::IncrWrap, ..Default::default() })
            } else {
                (StencilFace { pass: StencilOp::IncrWrap, ..Default::default() }, StencilFace { pass: StencilOp::DecrWrap, ..Default::default() })
            };
            let state = RenderState {
                depth: DepthState { func: CompareFunc::Less, write: false, ..Default::default() },
                stencil: StencilState { enabled: true, front, back, ..Default::default() },
                ..Default::default()
            };
            p.draw(&mut Targets::none().with_depth(&mut depth).with_stencil(&mut stencil), &state, &verts, &idx, &ClipPassthrough3, &DepthOnly).unwrap();
            for py in 0..H { for px in 0..W {
                let x = (px as f32 + 0.5) / W as f32 * 2.0 - 1.0;
                let y = 1.0 - (py as f32 + 0.5) / H as f32 * 2.0;
                let near_edge = boxes.iter().any(|(lo, hi)| {
                    [lo.x - x, hi.x - x].iter().any(|d| d.abs() < 2e-3) || [lo.y - y, hi.y - y].iter().any(|d| d.abs() < 2e-3)
                        || (lo.z - zr).abs() < 1e-4 || (hi.z - zr).abs() < 1e-4
                });
                if near_edge { continue; }
                let expect = boxes.iter().filter(|(lo, hi)| x > lo.x && x < hi.x && y > lo.y && y < hi.y && zr > lo.z && zr < hi.z).count();
                prop_assert_eq!(stencil.at(px, py) as usize, expect, "zfail={} pixel ({}, {})", zfail, px, py);
            }}
        }
    }
}

/// Positions already in clip space (w = 1), as `Vec3`.
struct ClipPassthrough3;
impl VertexProgram for ClipPassthrough3 {
    type In = Vec3;
    type Out = ();
    fn run(&self, v: &Vec3) -> (Vec4, ()) {
        (v.extend(1.0), ())
    }
}

/// An axis-aligned box as 12 outward-facing (CCW seen from outside, NDC y up) triangles.
fn push_box(verts: &mut Vec<Vec3>, idx: &mut Vec<u32>, lo: Vec3, hi: Vec3) {
    let b = verts.len() as u32;
    for i in 0..8 {
        verts.push(Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        ));
    }
    // Faces as quads (a, b, c, d) counter-clockwise seen from outside, in NDC (x right, y up,
    // depth z away from the viewer: a left-handed frame). The z = lo face faces the viewer.
    let quads = [
        [0, 1, 3, 2], // z = lo
        [4, 6, 7, 5], // z = hi
        [0, 4, 5, 1], // y = lo
        [2, 3, 7, 6], // y = hi
        [0, 2, 6, 4], // x = lo
        [1, 5, 7, 3], // x = hi
    ];
    for q in quads {
        idx.extend_from_slice(&[b + q[0], b + q[1], b + q[2], b + q[0], b + q[2], b + q[3]]);
    }
}

#[test]
fn box_faces_toward_viewer_are_front_facing() {
    // The z = lo face of a box seen from the viewer must count as front-facing (sanity check of
    // push_box's winding against the pipeline's FrontFace::Ccw convention).
    let (mut v, mut i) = (Vec::new(), Vec::new());
    push_box(&mut v, &mut i, Vec3::new(-0.5, -0.5, 0.2), Vec3::new(0.5, 0.5, 0.6));
    let p = pipeline(1);
    let mut depth = Surface::new(64, 64, 1.0).unwrap();
    let state = RenderState {
        cull: CullMode::Back,
        ..Default::default()
    };
    let stats = p
        .draw(
            &mut Targets::depth_only(&mut depth),
            &state,
            &v,
            &i,
            &ClipPassthrough3,
            &DepthOnly,
        )
        .unwrap();
    // Orthographic view along z: the four side faces are edge-on (zero area), the far face is
    // a back face.
    assert_eq!((stats.culled_backface, stats.culled_degenerate), (2, 8));
    assert!(
        (depth.at(32, 32) - 0.2).abs() < 1e-6,
        "the front face at z = 0.2 is what remains"
    );
}

#[test]
fn near_plane_clipping_matches_analytic_depth() {
    // A perspective view of a ground plane running from behind the camera to far away: pixels
    // show the plane's analytic depth, and nothing of the part behind the near plane.
    let proj = glam::Mat4::perspective_rh(60f32.to_radians(), 1.0, 0.5, 50.0);
    let view = glam::Mat4::look_at_rh(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, -10.0), Vec3::Y);
    let vp = proj * view;
    let verts = [
        Vec3::new(-100.0, 0.0, 20.0),
        Vec3::new(100.0, 0.0, 20.0),
        Vec3::new(0.0, 0.0, -40.0),
    ];
    let p = pipeline(2);
    let mut depth = Surface::new(128, 128, 1.0).unwrap();
    let stats = p
        .draw(
            &mut Targets::depth_only(&mut depth),
            &RenderState::default(),
            &verts,
            &[0, 1, 2],
            &TransformPositions(vp),
            &DepthOnly,
        )
        .unwrap();
    assert_eq!(stats.clipped, 1);
    let inv = penumbra::math::inverse(&vp);
    let mut checked = 0;
    for y in 0..128u32 {
        for x in 0..128u32 {
            let d = depth.at(x, y);
            if d >= 1.0 {
                continue;
            }
            // Unproject the pixel centre at the stored depth: the point must lie on the plane y = 0.
            let ndc = Vec3::new((x as f32 + 0.5) / 64.0 - 1.0, 1.0 - (y as f32 + 0.5) / 64.0, d);
            let w = inv.project_point3(ndc);
            assert!(
                w.y.abs() < 2e-3 * (1.0 + w.z.abs()),
                "pixel ({x}, {y}) depth {d} unprojects to {w}"
            );
            checked += 1;
        }
    }
    assert!(
        checked > 3000,
        "the plane covers the lower half of the view ({checked} pixels)"
    );
}

#[test]
fn depth_clamp_keeps_geometry_beyond_the_far_plane() {
    let verts = [
        Vec4::new(-1.0, -1.0, 1.5, 1.0),
        Vec4::new(3.0, -1.0, 1.5, 1.0),
        Vec4::new(-1.0, 3.0, 1.5, 1.0),
    ];
    let p = pipeline(2);
    let mut depth = Surface::new(32, 32, 1.0).unwrap();
    let le = DepthState {
        func: CompareFunc::LessEqual,
        ..Default::default()
    };
    let s = draw_depth(
        &p,
        &mut depth,
        RenderState {
            depth: le,
            ..Default::default()
        },
        &verts,
        &[0, 1, 2],
    )
    .unwrap();
    assert_eq!(s.fragments_rasterized, 0, "without clamp the far plane clips it away");
    depth.fill(0.75);
    let clamp = DepthState {
        clamp: true,
        func: CompareFunc::Always,
        ..Default::default()
    };
    let s = draw_depth(
        &p,
        &mut depth,
        RenderState {
            depth: clamp,
            ..Default::default()
        },
        &verts,
        &[0, 1, 2],
    )
    .unwrap();
    assert_eq!(s.fragments_rasterized, 32 * 32);
    assert!(depth.data().iter().all(|&d| d == 1.0), "clamped to the far plane");
}

#[test]
fn triangles_crossing_w_zero_render_only_their_visible_part() {
    // One vertex behind the eye (w < 0): the visible part is bounded and covers no pixel twice.
    let proj = glam::Mat4::perspective_rh(90f32.to_radians(), 1.0, 0.1, 10.0);
    let verts = [
        Vec3::new(-1.0, -0.5, -2.0),
        Vec3::new(1.0, -0.5, -2.0),
        Vec3::new(0.0, -0.5, 3.0),
    ];
    let p = pipeline(2);
    let mut count = Surface::new(64, 64, 0.0f32).unwrap();
    let state = RenderState {
        blend: BlendMode::Add,
        depth: DepthState {
            func: CompareFunc::Always,
            write: false,
            ..Default::default()
        },
        ..Default::default()
    };
    let s = p
        .draw(
            &mut Targets::color(&mut count),
            &state,
            &verts,
            &[0, 1, 2],
            &TransformPositions(proj),
            &Shader(|_: &Fragment<()>| Vec4::ONE),
        )
        .unwrap();
    assert_eq!(s.clipped, 1);
    assert!(count.data().iter().all(|&c| c <= 1.0));
    // The floor below the eye fills the bottom rows and nothing above the horizon.
    assert_eq!(count.at(32, 63), 1.0);
    assert_eq!(count.at(32, 20), 0.0);
}

#[test]
fn perspective_correct_varyings() {
    // A quad receding in depth carries u in [0, 1]; at the pixel where the world-space
    // midpoint projects, the interpolated u must be 0.5 (screen-linear would be wrong).
    let proj = glam::Mat4::perspective_rh(90f32.to_radians(), 1.0, 0.1, 100.0);
    struct Vs(glam::Mat4);
    impl VertexProgram for Vs {
        type In = (Vec3, f32);
        type Out = f32;
        fn run(&self, v: &(Vec3, f32)) -> (Vec4, f32) {
            (self.0 * v.0.extend(1.0), v.1)
        }
    }
    let verts = [
        (Vec3::new(-1.0, -1.0, -1.0), 0.0),
        (Vec3::new(1.0, -1.0, -1.0), 0.0),
        (Vec3::new(1.0, -1.0, -21.0), 1.0),
        (Vec3::new(-1.0, -1.0, -21.0), 1.0),
    ];
    let p = pipeline(2);
    let mut out = Surface::new(256, 256, -1.0f32).unwrap();
    p.draw(
        &mut Targets::color(&mut out),
        &RenderState::default(),
        &verts,
        &[0, 1, 2, 0, 2, 3],
        &Vs(proj),
        &Shader(|f: &Fragment<f32>| Vec4::splat(f.var)),
    )
    .unwrap();
    let mid = proj.project_point3(Vec3::new(0.0, -1.0, -11.0));
    let py = ((1.0 - mid.y) * 128.0) as u32;
    let u = out.at(128, py);
    assert!((u - 0.5).abs() < 0.02, "u at the midpoint's pixel is {u}");
}

#[test]
fn polygon_offset_is_slope_scaled_plus_constant() {
    // A plane with depth slope 0.001 per pixel in x; offset factor 2 and units 3 (float depth).
    let verts = [
        Vec4::new(-1.0, -1.0, 0.3, 1.0),
        Vec4::new(1.0, -1.0, 0.3 + 0.001 * 64.0, 1.0),
        Vec4::new(-1.0, 1.0, 0.3, 1.0),
    ];
    let p = pipeline(1);
    let draw = |offset: PolygonOffset| {
        let mut d = Surface::new(64, 64, 1.0).unwrap();
        draw_depth(
            &p,
            &mut d,
            RenderState {
                offset,
                ..Default::default()
            },
            &verts,
            &[0, 1, 2],
        )
        .unwrap();
        d.at(10, 40)
    };
    let base = draw(PolygonOffset::default());
    let off = draw(PolygonOffset {
        factor: 2.0,
        units: 3.0,
    });
    let r = DepthFormat::F32.resolvable(0.3 + 0.064);
    let expect = 2.0 * 0.001 + 3.0 * r;
    assert!(
        ((off - base) - expect).abs() < 1e-6,
        "offset {} expected {}",
        off - base,
        expect
    );
}

#[test]
fn stencil_ops_and_masks() {
    for (op, s, expect) in [
        (StencilOp::Keep, 5u8, 5u8),
        (StencilOp::Zero, 5, 0),
        (StencilOp::Replace, 5, 9),
        (StencilOp::IncrSat, 255, 255),
        (StencilOp::DecrSat, 0, 0),
        (StencilOp::IncrWrap, 255, 0),
        (StencilOp::DecrWrap, 0, 255),
        (StencilOp::Invert, 0x0f, 0xf0),
    ] {
        assert_eq!(op.apply(s, 9), expect, "{op:?}");
    }
    // Write mask keeps the masked-out bits; read mask applies to the compare.
    let verts = [
        Vec4::new(-1.0, -1.0, 0.5, 1.0),
        Vec4::new(3.0, -1.0, 0.5, 1.0),
        Vec4::new(-1.0, 3.0, 0.5, 1.0),
    ];
    let mut st = Surface::new(8, 8, 0xA5u8).unwrap();
    let face = StencilFace {
        func: CompareFunc::Equal,
        pass: StencilOp::Replace,
        fail: StencilOp::Zero,
        ..Default::default()
    };
    let state = RenderState {
        stencil: StencilState {
            enabled: true,
            front: face,
            back: face,
            reference: 0x15,
            read_mask: 0x0f,
            write_mask: 0xf0,
        },
        ..Default::default()
    };
    pipeline(1)
        .draw(
            &mut Targets::none().with_stencil(&mut st),
            &state,
            &verts,
            &[0, 1, 2],
            &ClipPassthrough,
            &DepthOnly,
        )
        .unwrap();
    // (0x15 & 0x0f) == (0xA5 & 0x0f): pass -> replace with 0x15 under write mask 0xf0 -> 0x15.
    assert!(st.data().iter().all(|&v| v == 0x15), "{:x}", st.at(0, 0));
}

#[test]
fn blend_modes_and_color_mask() {
    let s = Vec4::new(0.5, 0.25, 1.0, 0.5);
    let d = Vec4::new(0.5, 1.0, 0.0, 1.0);
    assert_eq!(program::blend(BlendMode::Replace, s, d), s);
    assert_eq!(program::blend(BlendMode::Add, s, d), s + d);
    assert_eq!(program::blend(BlendMode::Multiply, s, d), s * d);
    assert_eq!(program::blend(BlendMode::Min, s, d), s.min(d));
    assert_eq!(program::blend(BlendMode::Max, s, d), s.max(d));
    assert_eq!(program::blend(BlendMode::Alpha, s, d), Vec4::new(0.5, 0.625, 0.5, 1.0));
    let verts = [
        Vec4::new(-1.0, -1.0, 0.5, 1.0),
        Vec4::new(3.0, -1.0, 0.5, 1.0),
        Vec4::new(-1.0, 3.0, 0.5, 1.0),
    ];
    let mut c = Surface::new(8, 8, Vec4::splat(0.25)).unwrap();
    let state = RenderState {
        color_mask: ColorMask([true, false, true, false]),
        ..Default::default()
    };
    pipeline(1)
        .draw(
            &mut Targets::color(&mut c),
            &state,
            &verts,
            &[0, 1, 2],
            &ClipPassthrough,
            &Shader(|_: &Fragment<()>| Vec4::ONE),
        )
        .unwrap();
    assert!(c.data().iter().all(|&v| v == Vec4::new(1.0, 0.25, 1.0, 0.25)));
}

#[test]
fn early_z_kills_are_counted_and_never_shaded() {
    let near = [
        Vec4::new(-1.0, -1.0, 0.2, 1.0),
        Vec4::new(3.0, -1.0, 0.2, 1.0),
        Vec4::new(-1.0, 3.0, 0.2, 1.0),
    ];
    let far = [
        Vec4::new(-1.0, -1.0, 0.8, 1.0),
        Vec4::new(3.0, -1.0, 0.8, 1.0),
        Vec4::new(-1.0, 3.0, 0.8, 1.0),
    ];
    let p = pipeline(2);
    let mut c = Surface::new(100, 100, [0u8; 4]).unwrap();
    let mut d = Surface::new(100, 100, 1.0f32).unwrap();
    let fs = Shader(|_: &Fragment<()>| Vec4::ONE);
    p.draw(
        &mut Targets::color(&mut c).with_depth(&mut d),
        &RenderState::default(),
        &near,
        &[0, 1, 2],
        &ClipPassthrough,
        &fs,
    )
    .unwrap();
    let s = p
        .draw(
            &mut Targets::color(&mut c).with_depth(&mut d),
            &RenderState::default(),
            &far,
            &[0, 1, 2],
            &ClipPassthrough,
            &fs,
        )
        .unwrap();
    assert_eq!(s.early_z_killed, 10_000);
    assert_eq!(s.fragments_shaded, 0);
    // A discarding program must run before the depth test: counted as late depth fails.
    let ds = DiscardingShader(|_: &Fragment<()>| Some(Vec4::ONE));
    let s = p
        .draw(
            &mut Targets::color(&mut c).with_depth(&mut d),
            &RenderState::default(),
            &far,
            &[0, 1, 2],
            &ClipPassthrough,
            &ds,
        )
        .unwrap();
    assert_eq!(
        (s.early_z_killed, s.depth_failed, s.fragments_shaded),
        (0, 10_000, 10_000)
    );
}

#[test]
fn bad_input_is_an_error_or_counted_never_a_panic() {
    let p = pipeline(2);
    let mut d = Surface::new(64, 64, 1.0f32).unwrap();
    let nan = [
        Vec4::new(f32::NAN, 0.0, 0.5, 1.0),
        Vec4::new(1.0, 0.0, 0.5, 1.0),
        Vec4::new(0.0, 1.0, 0.5, 1.0),
    ];
    let s = draw_depth(&p, &mut d, RenderState::default(), &nan, &[0, 1, 2]).unwrap();
    assert_eq!(s.dropped_nonfinite, 1);
    let inf = [
        Vec4::new(f32::INFINITY, 0.0, 0.5, 1.0),
        Vec4::new(1.0, 0.0, 0.5, 1.0),
        Vec4::new(0.0, 1.0, 0.5, 1.0),
    ];
    let s = draw_depth(&p, &mut d, RenderState::default(), &inf, &[0, 1, 2]).unwrap();
    assert_eq!(s.dropped_nonfinite, 1);
    // Huge coordinates: clipped to the guard band (in f64) and drawn correctly ...
    let huge = [
        Vec4::new(-1e8, -1e8, 0.5, 1.0),
        Vec4::new(1e8, -1e8, 0.5, 1.0),
        Vec4::new(0.0, 1e8, 0.5, 1.0),
    ];
    let s = draw_depth(&p, &mut d, RenderState::default(), &huge, &[0, 1, 2]).unwrap();
    assert_eq!(s.fragments_rasterized, 64 * 64);
    // ... or, beyond what the clipper can place to a pixel, dropped and counted.
    let absurd = [
        Vec4::new(-1e30, -1e30, 0.5, 1.0),
        Vec4::new(1e30, -1e30, 0.5, 1.0),
        Vec4::new(0.0, 1e30, 0.5, 1.0),
    ];
    let s = draw_depth(&p, &mut d, RenderState::default(), &absurd, &[0, 1, 2]).unwrap();
    assert_eq!(s.dropped_nonfinite, 1);
    let huge_w = [
        Vec4::new(1e38, 1e38, 1e38, 1e38),
        Vec4::new(-3e38, 1e38, 0.5, 3e38),
        Vec4::new(0.0, -1e38, 0.5, 1e-38),
    ];
    draw_depth(&p, &mut d, RenderState::default(), &huge_w, &[0, 1, 2]).unwrap();
    // Degenerate (zero-area) triangles are counted.
    let line = [
        Vec4::new(0.0, 0.0, 0.5, 1.0),
        Vec4::new(0.5, 0.5, 0.5, 1.0),
        Vec4::new(1.0, 1.0, 0.5, 1.0),
    ];
    let s = draw_depth(&p, &mut d, RenderState::default(), &line, &[0, 1, 2]).unwrap();
    assert_eq!(s.culled_degenerate, 1);
    // Index errors, mismatched sizes, absurd sizes, missing mip level, thread count.
    assert_eq!(
        draw_depth(&p, &mut d, RenderState::default(), &line, &[0, 1]),
        Err(PipelineError::BadIndexCount(2))
    );
    assert!(matches!(
        draw_depth(&p, &mut d, RenderState::default(), &line, &[0, 1, 7]),
        Err(PipelineError::IndexOutOfRange {
            triangle: 0,
            index: 7,
            vertices: 3
        })
    ));
    let mut c = Surface::new(32, 64, [0u8; 4]).unwrap();
    let e = p.draw(
        &mut Targets::color(&mut c).with_depth(&mut d),
        &RenderState::default(),
        &line,
        &[0, 1, 2],
        &ClipPassthrough,
        &DepthOnly,
    );
    assert!(
        matches!(e, Err(PipelineError::SizeMismatch { what: "depth", .. })),
        "{e:?}"
    );
    assert!(Surface::new(0, 10, 0u8).is_err());
    assert!(Surface::new(100_000, 10, 0u8).is_err());
    let m = MipChain::build(Surface::new(4, 4, 1.0f32).unwrap(), surface::average_f32);
    assert!(matches!(
        sampler::sample_level(&m, glam::Vec2::ZERO, 9, sampler::Address::Clamp),
        Err(PipelineError::BadMipLevel { level: 9, levels: 3 })
    ));
    assert!(Pipeline::new(100_000).is_err());
    assert!(p
        .draw(
            &mut Targets::none(),
            &RenderState::default(),
            &line,
            &[0, 1, 2],
            &ClipPassthrough,
            &DepthOnly
        )
        .is_err());
}

#[test]
fn full_fragment_pool_is_an_error_and_leaves_lists_untouched() {
    let verts = [
        Vec4::new(-1.0, -1.0, 0.5, 1.0),
        Vec4::new(3.0, -1.0, 0.5, 1.0),
        Vec4::new(-1.0, 3.0, 0.5, 1.0),
    ];
    let mut lists = FragmentLists::new(16, 16, 100).unwrap();
    let r = pipeline(2).draw(
        &mut Targets::none().with_lists(&mut lists),
        &RenderState::default(),
        &verts,
        &[0, 1, 2],
        &ClipPassthrough,
        &DepthOnly,
    );
    assert_eq!(
        r,
        Err(PipelineError::FragmentPoolFull {
            capacity: 100,
            needed: 256
        })
    );
    assert!(lists.is_empty());
    let mut lists = FragmentLists::new(16, 16, 512).unwrap();
    let p = pipeline(2);
    for _ in 0..2 {
        p.draw(
            &mut Targets::none().with_lists(&mut lists),
            &RenderState::default(),
            &verts,
            &[0, 1, 2],
            &ClipPassthrough,
            &DepthOnly,
        )
        .unwrap();
    }
    assert_eq!(lists.len(), 512);
    assert!(
        lists.iter(3, 3).map(|n| n.draw).eq([0, 1]),
        "second draw appended behind the first"
    );
}

#[test]
fn unorm8_store_rounds_to_nearest_and_saturates() {
    let c = |v: f32| <Rgba8 as ColorFormat>::from_vec4(Vec4::splat(v))[0];
    assert_eq!(c(0.0), 0);
    assert_eq!(c(1.0), 255);
    assert_eq!(c(2.0), 255);
    assert_eq!(c(-1.0), 0);
    assert_eq!(c(f32::NAN), 0);
    assert_eq!(c(0.4 / 255.0), 0);
    assert_eq!(c(0.6 / 255.0), 1);
    assert_eq!(c(127.4 / 255.0), 127);
    for i in 0..=255u8 {
        assert_eq!(c(i as f32 / 255.0), i, "round trip of {i}");
    }
}

/// Two triangles that touch some tiles of a 150 x 97 target only (for the load-op clear tests,
/// with index lists of two, one and no triangles).
const CLEAR_TEST_VERTS: [Vec4; 6] = [
    Vec4::new(-0.9, -0.9, 0.3, 1.0),
    Vec4::new(0.2, -0.8, 0.6, 1.0),
    Vec4::new(-0.5, 0.1, 0.9, 1.0),
    Vec4::new(0.5, 0.5, 0.2, 1.0),
    Vec4::new(0.9, 0.6, 0.4, 1.0),
    Vec4::new(0.6, 0.95, 0.7, 1.0),
];

#[test]
fn clearing_depth_with_the_draw_equals_clear_then_draw() {
    // A target that is not a whole number of tiles, triangles that touch some tiles only, and
    // a draw with no triangles at all; old contents must not survive anywhere.
    let p = pipeline(2);
    let verts = CLEAR_TEST_VERTS;
    for idx in [&[0u32, 1, 2, 3, 4, 5][..], &[0, 1, 2], &[]] {
        let mut a = Surface::new(150, 97, 0.25f32).unwrap();
        let mut b = a.clone();
        p.clear(&mut a, 0.8);
        let draw = |t: &mut Targets<'_, Rgba8>| {
            p.draw(t, &RenderState::default(), &verts, idx, &ClipPassthrough, &DepthOnly)
                .unwrap()
        };
        let sa = draw(&mut Targets::depth_only(&mut a));
        let sb = draw(&mut Targets::depth_only(&mut b).clearing_depth(0.8));
        assert_eq!(a.data(), b.data(), "{} triangles", idx.len() / 3);
        assert_eq!(sa, sb);
    }
}

#[test]
fn clearing_color_and_depth_with_the_draw_equals_clear_then_draw() {
    // As above, for a shaded draw that clears both targets (the frame benchmark's camera pass).
    let p = pipeline(2);
    let verts = CLEAR_TEST_VERTS;
    let fs = Shader(|f: &Fragment<()>| Vec4::new(f.z, 0.5, f.x as f32 / 150.0, 1.0));
    for idx in [&[0u32, 1, 2, 3, 4, 5][..], &[0, 1, 2], &[]] {
        let (mut ca, mut da) = (
            Surface::new(150, 97, [9u8; 4]).unwrap(),
            Surface::new(150, 97, 0.25f32).unwrap(),
        );
        let (mut cb, mut db) = (ca.clone(), da.clone());
        p.clear(&mut ca, [1, 2, 3, 4]);
        p.clear(&mut da, 0.8);
        let draw = |t: &mut Targets<'_, Rgba8>| {
            p.draw(t, &RenderState::default(), &verts, idx, &ClipPassthrough, &fs)
                .unwrap()
        };
        let sa = draw(&mut Targets::color(&mut ca).with_depth(&mut da));
        let sb = draw(
            &mut Targets::color(&mut cb)
                .clearing_color([1, 2, 3, 4])
                .with_depth(&mut db)
                .clearing_depth(0.8),
        );
        assert_eq!(ca.data(), cb.data(), "{} triangles", idx.len() / 3);
        assert_eq!(da.data(), db.data(), "{} triangles", idx.len() / 3);
        assert_eq!(sa, sb);
    }
}

/// A program that runs through the one-pixel path: it says it may discard (so the pipeline
/// shades before testing, pixel by pixel) but never does.
struct OnePixel<F>(F);
impl<V, F: Fn(&Fragment<V>) -> Vec4 + Sync> FragmentProgram<V> for OnePixel<F> {
    const MAY_DISCARD: bool = true;
    fn shade(&self, f: &Fragment<V>) -> Option<Vec4> {
        Some((self.0)(f))
    }
}

/// `VaryingColor` overrides `shade4`; this one keeps the default (one `shade` per lane).
struct DefaultWide;
impl FragmentProgram<Vec4> for DefaultWide {
    fn shade(&self, f: &Fragment<Vec4>) -> Option<Vec4> {
        Some(f.var * 1.5 - Vec4::splat(f.z) + Vec4::splat(f.x as f32 * 0.01 + f.y as f32 * 0.003))
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// The four-pixel path (`shade4`, SIMD depth test, lane stores) writes exactly what the
    /// one-pixel path writes, for perspective triangles, every blend mode, colour masks, depth
    /// functions and formats, on a target whose width is not a multiple of four.
    #[test]
    fn four_pixel_path_equals_one_pixel_path(seed in any::<u64>(), n in 1usize..40, state_bits in any::<u32>()) {
        let mut rng = SplitMix(seed);
        let verts: Vec<(Vec4, Vec4)> = (0..3 * n).map(|_| {
            let w = 0.4 + 2.5 * rng.next_f32();
            let p = Vec4::new(rng.next_f32() * 2.4 - 1.2, rng.next_f32() * 2.4 - 1.2, rng.next_f32() * 1.1 - 0.05, 1.0);
            let col = Vec4::new(rng.next_f32() * 1.4 - 0.2, rng.next_f32(), rng.next_f32(), rng.next_f32());
            (Vec4::new(p.x * w, p.y * w, p.z * w, w), col)
        }).collect();
        let idx: Vec<u32> = (0..3 * n as u32).collect();
        let blends = [BlendMode::Replace, BlendMode::Add, BlendMode::Alpha, BlendMode::Multiply, BlendMode::Min, BlendMode::Max];
        let funcs = [CompareFunc::Less, CompareFunc::LessEqual, CompareFunc::Greater, CompareFunc::Always, CompareFunc::NotEqual, CompareFunc::Equal];
        let formats = [DepthFormat::F32, DepthFormat::Unorm24, DepthFormat::Unorm16];
        let b = state_bits as usize;
        let mut state = RenderState {
            blend: blends[b % 6],
            ..Default::default()
        };
        state.depth.func = funcs[(b / 6) % 6];
        state.depth.format = formats[(b / 36) % 3];
        state.depth.write = !(b / 108).is_multiple_of(4);
        if (b / 432).is_multiple_of(3) {
            state.color_mask = ColorMask([b & 1 << 20 != 0, b & 1 << 21 != 0, true, b & 1 << 22 != 0]);
        }
        let p = pipeline(2);
        let run = |wide: bool, override_shade4: bool| {
            let mut c = Surface::new(150, 97, [40u8, 90, 140, 200]).unwrap();
            let mut d = Surface::new(150, 97, 0.6f32).unwrap();
            // One state in four draws without a depth target.
            let mut t = if (b >> 24) % 4 == 3 { Targets::color(&mut c) } else { Targets::color(&mut c).with_depth(&mut d) };
            let s = match (wide, override_shade4) {
                (true, true) => p.draw(&mut t, &state, &verts, &idx, &penumbra::bench::ColoredClip, &penumbra::bench::VaryingColor),
                (false, true) => p.draw(&mut t, &state, &verts, &idx, &penumbra::bench::ColoredClip, &OnePixel(|f: &Fragment<Vec4>| f.var)),
                (true, false) => p.draw(&mut t, &state, &verts, &idx, &penumbra::bench::ColoredClip, &DefaultWide),
                (false, false) => p.draw(&mut t, &state, &verts, &idx, &penumbra::bench::ColoredClip, &OnePixel(|f: &Fragment<Vec4>| DefaultWide.shade(f).unwrap())),
            }.unwrap();
            (c, d, s.fragments_passed, s.fragments_rasterized)
        };
        // No varyings at all (the draw keeps no shading attributes).
        let positions: Vec<Vec4> = verts.iter().map(|v| v.0).collect();
        let at = |f: &Fragment<()>| Vec4::new(f.z, f.x as f32 * 0.01, f.y as f32 * 0.007, 0.5);
        let run_empty = |wide: bool| {
            let mut c = Surface::new(150, 97, [40u8, 90, 140, 200]).unwrap();
            let mut d = Surface::new(150, 97, 0.6f32).unwrap();
            let mut t = Targets::color(&mut c).with_depth(&mut d);
            let s = if wide {
                p.draw(&mut t, &state, &positions, &idx, &ClipPassthrough, &Shader(at))
            } else {
                p.draw(&mut t, &state, &positions, &idx, &ClipPassthrough, &OnePixel(at))
            }
            .unwrap();
            (c, d, s.fragments_passed)
        };
        let (c1, d1, p1) = run_empty(true);
        let (c2, d2, p2) = run_empty(false);
        prop_assert_eq!(p1, p2);
        prop_assert!(c1.data() == c2.data(), "colour differs without varyings ({:?})", state);
        prop_assert!(d1.data().iter().zip(d2.data()).all(|(a, b)| a.to_bits() == b.to_bits()));
        for over in [true, false] {
            let (c1, d1, p1, r1) = run(true, over);
            let (c2, d2, p2, r2) = run(false, over);
            prop_assert_eq!((p1, r1), (p2, r2));
            prop_assert!(c1.data() == c2.data(), "colour differs ({:?}, override {})", state, over);
            let bits = |s: &Surface<f32>| s.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            prop_assert!(bits(&d1) == bits(&d2), "depth differs ({:?})", state);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// A draw that shares no vertices runs the vertex program during set-up instead of in its
    /// own stage; the output must not tell: the same soup drawn through the vertex stage (one
    /// extra degenerate triangle makes the indices outnumber the vertices) writes the same
    /// pixels and counts the same fragments. Includes near-plane clipping and NaN vertices.
    #[test]
    fn vertex_program_on_demand_equals_vertex_stage(seed in any::<u64>(), n in 1usize..200) {
        let mut rng = SplitMix(seed);
        let verts: Vec<(Vec4, Vec4)> = (0..3 * n).map(|k| {
            let w = 2.0 * rng.next_f32() - 0.3;
            let p = Vec4::new(rng.next_f32() * 2.4 - 1.2, rng.next_f32() * 2.4 - 1.2, rng.next_f32(), 1.0);
            let p = if k % 97 == 5 { Vec4::NAN } else { Vec4::new(p.x * w, p.y * w, p.z * w, w) };
            (p, Vec4::new(rng.next_f32(), rng.next_f32(), rng.next_f32(), 1.0))
        }).collect();
        let soup: Vec<u32> = (0..3 * n as u32).collect();
        let mut shared = soup.clone();
        shared.extend([0, 0, 0]);
        let p = pipeline(2);
        let run = |idx: &[u32]| {
            let mut c = Surface::new(173, 91, [0u8; 4]).unwrap();
            let mut d = Surface::new(173, 91, 1.0f32).unwrap();
            let s = p.draw(&mut Targets::color(&mut c).with_depth(&mut d), &RenderState::default(), &verts, idx,
                &penumbra::bench::ColoredClip, &penumbra::bench::VaryingColor).unwrap();
            (c, d, s)
        };
        let (c1, d1, s1) = run(&soup);
        let (c2, d2, s2) = run(&shared);
        prop_assert!(c1.data() == c2.data());
        prop_assert!(d1.data() == d2.data());
        prop_assert_eq!(s1.fragments_rasterized, s2.fragments_rasterized);
        prop_assert_eq!(s1.clipped, s2.clipped);
        // The extra triangle is degenerate, outside or non-finite, as its one vertex is.
        let rejected = |s: &DrawStats| s.culled_degenerate + s.culled_outside + s.dropped_nonfinite;
        prop_assert_eq!(rejected(&s1) + 1, rejected(&s2));
        prop_assert_eq!(s1.triangles_setup, s2.triangles_setup);
    }
}

/// A program with a per-pixel input of every kind (varyings, depth, position, facing and
/// primitive): any lane fed the wrong triangle or pixel changes the image.
struct Everything;
impl FragmentProgram<Vec4> for Everything {
    fn shade(&self, f: &Fragment<Vec4>) -> Option<Vec4> {
        let k = (f.prim % 7) as f32 * 0.1 + if f.front { 0.05 } else { 0.0 };
        Some(f.var * 0.9 + Vec4::splat(f.z * 0.3 + k) + Vec4::splat(f.x as f32 * 0.002 - f.y as f32 * 0.001))
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// Hidden surface removal before shading (`Shading::Deferred`) gives the image, depth and
    /// counters of shading every passing fragment (`Shading::Immediate`), for heavy overdraw of
    /// small and large, overlapping and coplanar triangles across tile and target edges, with
    /// `Less` and `LessEqual`, depth writes on and off and polygon offset; it shades exactly
    /// the fragments that stay visible, no more (`shaded + hidden = passed`).
    #[test]
    fn deferred_shading_equals_immediate(seed in any::<u64>(), n in 1usize..120, bits in any::<u32>()) {
        let mut rng = SplitMix(seed);
        let big = bits % 3 == 0;
        let mut verts: Vec<(Vec4, Vec4)> = Vec::new();
        for t in 0..n {
            let (cx, cy) = (rng.next_f32() * 2.6 - 1.3, rng.next_f32() * 2.6 - 1.3);
            let r = if big || t % 5 == 0 { 1.2 } else { 0.08 };
            // Every fourth triangle is flat at the previous vertex's depth (ties); the others
            // slope in depth.
            let tie = t % 4 == 3;
            let z = if tie { verts.last().map_or(0.5, |v: &(Vec4, Vec4)| v.0.z / v.0.w) } else { rng.next_f32() * 0.9 };
            for _ in 0..3 {
                let w = 0.5 + 2.0 * rng.next_f32();
                let zv = if tie { z } else { z + 0.1 * rng.next_f32() };
                let p = Vec4::new(cx + r * (rng.next_f32() * 2.0 - 1.0), cy + r * (rng.next_f32() * 2.0 - 1.0), zv, 1.0);
                let col = Vec4::new(rng.next_f32(), rng.next_f32(), rng.next_f32(), 1.0);
                verts.push((Vec4::new(p.x * w, p.y * w, p.z * w, w), col));
            }
        }
        let idx: Vec<u32> = (0..verts.len() as u32).collect();
        let mut state = RenderState::default();
        state.depth.func = if bits & 4 != 0 { CompareFunc::LessEqual } else { CompareFunc::Less };
        state.depth.write = bits & 8 == 0;
        if bits & 16 != 0 {
            state.offset = PolygonOffset { factor: 1.1, units: 4.0 };
        }
        let p = pipeline(2);
        let run = |shading: Shading| {
            let mut c = Surface::new(203, 141, [40u8, 90, 140, 200]).unwrap();
            let mut d = Surface::new(203, 141, 0.7f32).unwrap();
            let st = RenderState { shading, ..state };
            let s = p.draw(&mut Targets::color(&mut c).with_depth(&mut d), &st, &verts, &idx, &penumbra::bench::ColoredClip, &Everything).unwrap();
            (c, d, s)
        };
        let (c1, d1, s1) = run(Shading::Deferred);
        let (c2, d2, s2) = run(Shading::Immediate);
        prop_assert!(c1.data() == c2.data(), "colour differs ({:?})", state);
        let bits_of = |s: &Surface<f32>| s.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        prop_assert!(bits_of(&d1) == bits_of(&d2), "depth differs ({:?})", state);
        prop_assert_eq!(s2.fragments_shaded, s2.fragments_passed);
        prop_assert_eq!(s2.fragments_hidden, 0);
        prop_assert_eq!(s1.fragments_shaded + s1.fragments_hidden, s1.fragments_passed);
        // The rest of the counters agree.
        let strip = |s: DrawStats| DrawStats { fragments_shaded: 0, fragments_hidden: 0, ..s };
        prop_assert_eq!(strip(s1), strip(s2));
        // Each shaded fragment is a visible pixel: no more program runs than pixels written.
        let changed = c1.data().iter().filter(|&&t| t != [40u8, 90, 140, 200]).count() as u64;
        prop_assert!(s1.fragments_shaded >= changed);
        prop_assert!(s1.fragments_shaded <= 203 * 141);
    }
}

/// A program whose four-lane path fills the lanes outside `mask` with a poison colour (as a
/// program may leave them anything).
struct PoisonsOffLanes;
impl FragmentProgram<Vec4> for PoisonsOffLanes {
    fn shade(&self, f: &Fragment<Vec4>) -> Option<Vec4> {
        Some(f.var)
    }
    fn shade4(&self, f: &Fragment4<Vec4>) -> Color4 {
        let poison = Vec4::new(1.0, 0.0, 1.0, 1.0);
        Color4::from_lanes(std::array::from_fn(|i| {
            if f.mask & (1 << i) != 0 {
                f.lane(i).var
            } else {
                poison
            }
        }))
    }
}

/// Regression: deferred shading's last group of a triangle repeats its first pixel in the idle
/// lanes and stores all four lanes; an idle lane's colour (anything the program left there)
/// once overwrote that pixel. Small triangles in heavy overdraw leave many partial groups.
#[test]
fn deferred_idle_lanes_never_overwrite_a_pixel() {
    let mut rng = SplitMix(17);
    let mut verts: Vec<(Vec4, Vec4)> = Vec::new();
    for _ in 0..600 {
        let (cx, cy) = (rng.next_f32() * 2.2 - 1.1, rng.next_f32() * 2.2 - 1.1);
        let z = rng.next_f32();
        let col = Vec4::new(rng.next_f32() * 0.5, rng.next_f32(), rng.next_f32() * 0.5, 1.0);
        for _ in 0..3 {
            let p = Vec4::new(
                cx + 0.06 * (rng.next_f32() * 2.0 - 1.0),
                cy + 0.06 * (rng.next_f32() * 2.0 - 1.0),
                z,
                1.0,
            );
            verts.push((p, col));
        }
    }
    let idx: Vec<u32> = (0..verts.len() as u32).collect();
    let p = pipeline(2);
    let run = |shading: Shading| {
        let mut c = Surface::new(150, 130, [0u8; 4]).unwrap();
        let mut d = Surface::new(150, 130, 1.0f32).unwrap();
        let st = RenderState {
            shading,
            ..Default::default()
        };
        let s = p
            .draw(
                &mut Targets::color(&mut c).with_depth(&mut d),
                &st,
                &verts,
                &idx,
                &penumbra::bench::ColoredClip,
                &PoisonsOffLanes,
            )
            .unwrap();
        (c, s)
    };
    let (deferred, s) = run(Shading::Deferred);
    let (immediate, _) = run(Shading::Immediate);
    assert!(s.fragments_hidden > 0, "the scene has overdraw");
    assert!(
        !deferred.data().contains(&[255, 0, 255, 255]),
        "an idle lane's colour was stored"
    );
    assert!(deferred.data() == immediate.data());
}

/// The deferred path shades each visible pixel once: two full-screen layers drawn back to
/// front shade one layer's pixels, not two, and the counters say so.
#[test]
fn deferred_shading_runs_the_program_once_per_visible_pixel() {
    let p = pipeline(2);
    let quad = |z: f32| -> Vec<Vec4> {
        [
            (-1.0, -1.0),
            (1.0, -1.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
        ]
        .iter()
        .map(|&(x, y)| Vec4::new(x, y, z, 1.0))
        .collect()
    };
    let mut verts = quad(0.8);
    verts.extend(quad(0.2));
    let idx: Vec<u32> = (0..12).collect();
    let calls = std::sync::atomic::AtomicU64::new(0);
    let fs = Shader(|_: &Fragment<()>| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Vec4::ONE
    });
    for (shading, runs) in [(Shading::Deferred, 100 * 70), (Shading::Immediate, 2 * 100 * 70)] {
        calls.store(0, std::sync::atomic::Ordering::Relaxed);
        let mut c = Surface::new(100, 70, [0u8; 4]).unwrap();
        let mut d = Surface::new(100, 70, 1.0f32).unwrap();
        let state = RenderState {
            shading,
            ..Default::default()
        };
        let s = p
            .draw(
                &mut Targets::color(&mut c).with_depth(&mut d),
                &state,
                &verts,
                &idx,
                &ClipPassthrough,
                &fs,
            )
            .unwrap();
        assert_eq!(s.fragments_passed, 2 * 100 * 70);
        assert_eq!(s.fragments_shaded, runs, "{shading:?}");
        assert_eq!(s.fragments_hidden, 2 * 100 * 70 - runs, "{shading:?}");
        assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), runs, "{shading:?}");
        assert!(c.data().iter().all(|&t| t == [255u8; 4]));
    }
}

/// A draw larger than one batch (131 072 triangles) is set up, binned and shaded batch by
/// batch; the result must not tell: one draw of 140 000 triangles equals the same triangles in
/// two draws, deferred and immediate alike (with a load-op clear on the first).
#[test]
fn draws_larger_than_a_batch_equal_split_draws() {
    let (verts, idx) = penumbra::bench::random_triangles(140_000, 6.0, 320, 180, 5);
    let p = pipeline(2);
    for shading in [Shading::Deferred, Shading::Immediate] {
        let state = RenderState {
            shading,
            ..Default::default()
        };
        let draw = |c: &mut Surface<[u8; 4]>, d: &mut Surface<f32>, range: std::ops::Range<usize>, clear: bool| {
            let mut t = Targets::color(c).with_depth(d);
            if clear {
                t = t.clearing_color([1, 2, 3, 4]).clearing_depth(1.0);
            }
            p.draw(
                &mut t,
                &state,
                &verts,
                &idx[range],
                &penumbra::bench::ColoredClip,
                &penumbra::bench::VaryingColor,
            )
            .unwrap()
        };
        let (mut c1, mut d1) = (
            Surface::new(320, 180, [0u8; 4]).unwrap(),
            Surface::new(320, 180, 0.0f32).unwrap(),
        );
        let whole = draw(&mut c1, &mut d1, 0..idx.len(), true);
        let (mut c2, mut d2) = (
            Surface::new(320, 180, [0u8; 4]).unwrap(),
            Surface::new(320, 180, 0.0f32).unwrap(),
        );
        let a = draw(&mut c2, &mut d2, 0..3 * 70_000, true);
        let b = draw(&mut c2, &mut d2, 3 * 70_000..idx.len(), false);
        assert!(c1.data() == c2.data(), "{shading:?}: colour differs");
        assert!(
            d1.data().iter().zip(d2.data()).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{shading:?}"
        );
        assert_eq!(whole.fragments_passed, a.fragments_passed + b.fragments_passed);
        assert_eq!(whole.triangles_in, 140_000);
    }
}

/// A vertex at the clip-space origin (0, 0, 0, 0), where 1/w is infinite: its triangles go
/// to the clipper and their pieces are dropped and counted, never drawn; the vertex stage's
/// arrays (shared vertices) and vertices computed during set-up (one per index) agree on the
/// image, depth and every counter, with and without varyings. Regression test for the
/// compact per-vertex set-up record (flags folded into the outcode word, varyings read in
/// place).
#[test]
fn a_vertex_at_the_clip_origin_is_dropped_alike_on_both_vertex_paths() {
    use penumbra::bench::{ColoredClip, VaryingColor};
    let p = pipeline(2);
    // A colour per vertex, so that varyings taken from the wrong vertex show.
    let v = [
        (Vec4::new(-0.9, -0.9, 0.5, 1.0), Vec4::new(1.0, 0.0, 0.0, 1.0)),
        (Vec4::new(0.9, -0.9, 0.5, 1.0), Vec4::new(0.0, 1.0, 0.0, 1.0)),
        (Vec4::new(0.0, 0.9, 0.5, 1.0), Vec4::new(0.0, 0.0, 1.0, 1.0)),
        (Vec4::ZERO, Vec4::ONE),
    ];
    let shared_idx = [0u32, 1, 2, 0, 1, 3, 3, 2, 1];
    // Three triangles from four shared vertices: the stage's arrays.
    let shared: Vec<(Vec4, Vec4)> = v.to_vec();
    // The same triangles, one vertex per index: computed during set-up.
    let own: Vec<(Vec4, Vec4)> = shared_idx.iter().map(|&i| v[i as usize]).collect();
    let own_idx: Vec<u32> = (0..own.len() as u32).collect();
    let run = |verts: &[(Vec4, Vec4)], idx: &[u32]| {
        let mut c = Surface::new(40, 30, [0u8; 4]).unwrap();
        let mut d = Surface::new(40, 30, 1.0f32).unwrap();
        let s = p
            .draw(
                &mut Targets::color(&mut c).with_depth(&mut d),
                &RenderState::default(),
                verts,
                idx,
                &ColoredClip,
                &VaryingColor,
            )
            .unwrap();
        let mut dd = Surface::new(40, 30, 1.0f32).unwrap();
        let sd = p
            .draw(
                &mut Targets::depth_only(&mut dd),
                &RenderState::default(),
                verts,
                idx,
                &ColoredClip,
                &DepthOnly,
            )
            .unwrap();
        (s, sd, c.data().to_vec(), d.data().to_vec(), dd.data().to_vec())
    };
    let a = run(&shared, &shared_idx);
    let b = run(&own, &own_idx);
    for s in [&a.0, &a.1] {
        assert_eq!(s.triangles_in, 3);
        assert_eq!(s.triangles_setup, 1, "{s:?}");
        assert!(s.clipped == 2 && s.dropped_nonfinite == s.clip_triangles_out, "{s:?}");
        assert!(s.fragments_rasterized > 100, "{s:?}");
    }
    assert_eq!(format!("{:?}", a.0), format!("{:?}", b.0));
    assert_eq!(format!("{:?}", a.1), format!("{:?}", b.1));
    assert_eq!((&a.2, &a.3, &a.4), (&b.2, &b.3, &b.4));
    // The drawn triangle's colour is interpolated: red, green and blue corners.
    let px = |x: usize, y: usize| a.2[y * 40 + x];
    assert!(
        px(3, 27)[0] > 200 && px(36, 27)[1] > 200 && px(20, 3)[2] > 150,
        "{:?}",
        (px(3, 27), px(36, 27), px(20, 3))
    );
}

/// The order-dependent update the raster-ordered tests apply: slot 0 a running hash of the
/// primitive ids in arrival order, slot 1 a count, slot 2 the last depth's bits; a pixel with
/// more slots records its k-th fragment's primitive in slot `3 + k % (len - 3)`.
fn ordered_update(prim: u32, z: f32, px: &mut [u32]) {
    if px.is_empty() {
        return;
    }
    px[0] = px[0].wrapping_mul(0x9e37_79b1).wrapping_add(prim + 1);
    if px.len() > 2 {
        let k = px[1];
        px[1] += 1;
        px[2] = z.to_bits();
        if px.len() > 3 {
            let n = px.len() - 3;
            px[3 + k as usize % n] = prim;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Raster-ordered storage: for any thread count, with a depth test or without, with
    /// standard or conservative rasterization, fixed or indexed per-pixel storage, the store
    /// equals applying the passing fragments one by one in submission order (the fragment
    /// lists of the same draw, themselves tested to be in submission order), and the access
    /// counter counts every application.
    #[test]
    fn raster_ordered_storage_applies_fragments_in_submission_order(
        seed in any::<u64>(), n in 1usize..50, depth_test in any::<bool>(), conservative in any::<bool>(), indexed in any::<bool>()
    ) {
        let mut rng = SplitMix(seed);
        let mut verts = Vec::new();
        for _ in 0..n * 3 {
            let r = |rng: &mut SplitMix| (rng.next_u64() % (W as u64 * 256)) as i64;
            let (x, y) = (r(&mut rng), r(&mut rng));
            verts.push(clip(x, y, rng.next_f32()));
        }
        let idx: Vec<u32> = (0..verts.len() as u32).collect();
        let state = RenderState {
            depth: DepthState {
                func: if depth_test { CompareFunc::Less } else { CompareFunc::Always },
                write: depth_test,
                ..Default::default()
            },
            raster: if conservative { RasterMode::Overestimate } else { RasterMode::Standard },
            ..Default::default()
        };
        let counts: Vec<u32> = (0..W * H).map(|i| if indexed { (i * 7 + 3) % 9 } else { 6 }).collect();
        let new_store = || if indexed {
            PixelStore::indexed(W, H, &counts, 0u32).unwrap()
        } else {
            PixelStore::fixed(W, H, 6, 0u32).unwrap()
        };
        // The sequential truth: the same draw's fragment lists, applied in list order.
        let mut lists = FragmentLists::new(W, H, 1 << 22).unwrap();
        let mut d0 = Surface::new(W, H, 1.0f32).unwrap();
        let list_stats = pipeline(1).draw(&mut Targets::none().with_depth(&mut d0).with_lists(&mut lists), &state, &verts, &idx,
            &ClipPassthrough, &Shader(|_: &Fragment<()>| Vec4::ZERO)).unwrap();
        let mut want = new_store();
        for y in 0..H { for x in 0..W {
            let nodes: Vec<(u32, f32)> = lists.iter(x, y).map(|nd| (nd.prim, nd.depth)).collect();
            for (prim, z) in nodes { ordered_update(prim, z, want.pixel_mut(x, y)); }
        }}
        for threads in [1, 2, 4] {
            let mut store = new_store();
            let mut depth = Surface::new(W, H, 1.0f32).unwrap();
            let prog = |f: &Fragment<()>, px: &mut [u32]| ordered_update(f.prim, f.z, px);
            let stats = pipeline(threads).draw_ordered(&mut Targets::none().with_depth(&mut depth), &state, &verts, &idx,
                &ClipPassthrough, &prog, &mut store).unwrap();
            prop_assert!(store == want, "{} threads: the store differs from sequential application", threads);
            prop_assert_eq!(stats.fragments_shaded, list_stats.list_nodes, "accesses");
            prop_assert_eq!(stats.fragments_passed, list_stats.fragments_passed);
            prop_assert_eq!(depth.data(), d0.data());
        }
    }
}

#[test]
fn raster_ordered_draws_without_other_targets_and_reject_bad_ones() {
    // No depth or stencil target: every covered pixel applies, sizes come from the store.
    let verts = [clip(0, 0, 0.5), clip(256 * 200, 0, 0.5), clip(0, 256 * 200, 0.5)];
    let mut store = PixelStore::fixed(W, H, 1, 0u32).unwrap();
    let prog = |_: &Fragment<()>, px: &mut [u32]| px[0] += 1;
    let st = pipeline(2)
        .draw_ordered(
            &mut Targets::none(),
            &RenderState::default(),
            &verts,
            &[0, 1, 2],
            &ClipPassthrough,
            &prog,
            &mut store,
        )
        .unwrap();
    let touched = store.data().iter().filter(|&&v| v == 1).count() as u64;
    assert_eq!(
        (touched, st.fragments_shaded),
        (st.fragments_rasterized, st.fragments_rasterized)
    );
    assert!(touched > 10_000);
    // A colour target, or a store of another size, is an error.
    let mut c = Surface::new(W, H, [0u8; 4]).unwrap();
    assert!(pipeline(1)
        .draw_ordered(
            &mut Targets::color(&mut c),
            &RenderState::default(),
            &verts,
            &[0, 1, 2],
            &ClipPassthrough,
            &prog,
            &mut store
        )
        .is_err());
    let mut d = Surface::new(W / 2, H, 1.0f32).unwrap();
    let e = pipeline(1)
        .draw_ordered(
            &mut Targets::none().with_depth(&mut d),
            &RenderState::default(),
            &verts,
            &[0, 1, 2],
            &ClipPassthrough,
            &prog,
            &mut store,
        )
        .unwrap_err()
        .to_string();
    assert!(e.to_string().contains("pixel store"), "{e}");
    // Bad stores.
    assert!(PixelStore::fixed(0, 4, 1, 0u8).is_err());
    assert!(PixelStore::fixed(65536, 65536, 2, 0u8).is_err());
    assert!(PixelStore::indexed(2, 2, &[1, 2, 3], 0u8).is_err());
    assert!(PixelStore::indexed(1, 2, &[u32::MAX, 2], 0u8).is_err());
}

#[test]
fn a_store_rebuilt_row_by_row_equals_the_indexed_one() {
    // Counts per pixel of a 37 x 11 store; rows filled in parallel from their totals.
    let (w, h) = (37u32, 11u32);
    let counts: Vec<u32> = (0..w * h).map(|i| (i * 7 + 3) % 5).collect();
    let mut want = PixelStore::indexed(w, h, &counts, 0u32).unwrap();
    for y in 0..h {
        for x in 0..w {
            for (k, v) in want.pixel_mut(x, y).iter_mut().enumerate() {
                *v = (y * w + x) * 10 + k as u32;
            }
        }
    }
    let rows: Vec<u32> = counts.chunks(w as usize).map(|r| r.iter().sum()).collect();
    let fill = |y: usize, starts: &mut [u32], values: &mut [u32]| {
        let mut at = 0;
        for (x, s) in starts.iter_mut().enumerate() {
            *s = at;
            let c = counts[y * w as usize + x];
            for k in 0..c {
                values[(at + k) as usize] = (y as u32 * w + x as u32) * 10 + k;
            }
            at += c;
        }
    };
    // A store kept from a larger build is reused.
    let mut store = PixelStore::indexed(w, h, &vec![9; (w * h) as usize], 7u32).unwrap();
    for threads in [1, 2, 4] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| store.rebuild_rows(w, h, &rows, 0, fill).unwrap());
        assert!(store == want, "{threads} threads");
    }
    // So is an empty store.
    let mut fresh = PixelStore::<u32>::default();
    assert_eq!((fresh.width(), fresh.height(), fresh.data().len()), (0, 0, 0));
    fresh.rebuild_rows(w, h, &rows, 0, fill).unwrap();
    assert!(fresh == want, "from an empty store");
    // Starts that decrease, or pass the row's values, and wrong row totals are errors.
    let e = store
        .rebuild_rows(w, h, &rows, 0, |_, starts, _| starts[0] = 1)
        .unwrap_err()
        .to_string();
    assert!(e.to_string().contains("starts decrease"), "{e}");
    let e = store
        .rebuild_rows(w, h, &rows, 0, |_, starts, v| starts.fill(v.len() as u32 + 1))
        .unwrap_err()
        .to_string();
    assert!(e.to_string().contains("row 0"), "{e}");
    assert!(store.rebuild_rows(w, h, &rows[1..], 0, |_, _, _| {}).is_err());
}
