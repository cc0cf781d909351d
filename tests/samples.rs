//! Rasterization at non-uniform sample positions (`pipeline::samples`): watertight over
//! random meshes and random monotone tables, conservative modes exact against independent
//! tests of each sample's cell, depth on the plane at the warped positions, the same output
//! for 1, 2 and 4 threads, bad tables refused.

use crate::common;
use common::{fan, fan_covers, jittered_grid, orient, quads};
use glam::Vec4;
use penumbra::bench::SplitMix;
use penumbra::pipeline::samples::SampleGrid;
use penumbra::pipeline::*;
use proptest::prelude::*;

/// Target size: a power of two, so fixed-point window coordinates survive the trip through
/// NDC exactly.
const W: u32 = 256;
const H: u32 = 256;

/// A window position in 1/256 pixels to clip space (w = 1).
fn clip(x: i64, y: i64, z: f32) -> Vec4 {
    common::window_to_clip(x, y, z, (W, H))
}

/// A strictly increasing table of `n` fixed-point positions in `[0, n * 256]` (random
/// spacing, some runs dense, some sparse), and the same in pixels.
fn table(rng: &mut SplitMix, n: usize) -> (Vec<i64>, Vec<f64>) {
    let mut set = std::collections::BTreeSet::new();
    let dense = (rng.next_u64() % (n as u64 * 256)) as i64;
    while set.len() < n {
        let v = if rng.next_u64().is_multiple_of(3) {
            // A dense cluster: the warped axis crowds samples.
            (dense + (rng.next_u64() % 2048) as i64).min(n as i64 * 256)
        } else {
            (rng.next_u64() % (n as u64 * 256 + 1)) as i64
        };
        set.insert(v);
    }
    let fixed: Vec<i64> = set.into_iter().collect();
    let px = fixed.iter().map(|v| *v as f64 / 256.0).collect();
    (fixed, px)
}

fn pipeline(threads: usize) -> Pipeline {
    Pipeline::new(threads).unwrap()
}

/// Per-sample coverage counts of window-space triangles at the grid's samples.
fn counts(p: &Pipeline, tris: &[[(i64, i64); 3]], mode: RasterMode, grid: &SampleGrid) -> Vec<u32> {
    let verts: Vec<Vec4> = tris.iter().flatten().map(|&(x, y)| clip(x, y, 0.5)).collect();
    let idx: Vec<u32> = (0..verts.len() as u32).collect();
    let state = RenderState {
        raster: mode,
        ..Default::default()
    };
    p.coverage_at(&state, &verts, &idx, grid).unwrap()
}

/// The cells of a fixed-point table (midpoints between samples, the ends mirrored and kept
/// in `[0, end]`), computed here independently of the pipeline.
fn cells(t: &[i64], end: i64) -> Vec<(i64, i64)> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let lo = if i > 0 {
                t[i - 1] + (t[i] - t[i - 1]) / 2
            } else if n > 1 {
                (2 * t[0] - (t[0] + (t[1] - t[0]) / 2)).max(0)
            } else {
                (t[0] - 128).max(0)
            };
            let hi = if i + 1 < n {
                t[i] + (t[i + 1] - t[i]) / 2
            } else if n > 1 {
                (2 * t[i] - (t[i - 1] + (t[i] - t[i - 1]) / 2)).min(end)
            } else {
                (t[i] + 128).min(end)
            };
            (lo, hi)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// A jittered grid of quads (two triangles each, either diagonal) covers every sample
    /// strictly inside it exactly once and nothing outside, for random monotone tables on
    /// both axes.
    #[test]
    fn grids_are_watertight_at_any_samples(nx in 1usize..9, ny in 1usize..9, seed in any::<u64>(), x0 in 0i64..3000, y0 in 0i64..3000) {
        let mut rng = SplitMix(seed);
        let (xs, xpx) = table(&mut rng, W as usize);
        let (ys, ypx) = table(&mut rng, H as usize);
        let grid = SampleGrid::new(&xpx, &ypx).unwrap();
        let (x1, y1) = (W as i64 * 256 - 1 - (rng.next_u64() % 3000) as i64, H as i64 * 256 - 1 - (rng.next_u64() % 3000) as i64);
        let tris = jittered_grid(&mut rng, nx, ny, (x0, y0), (x1, y1));
        let threads = 1 + (seed % 4) as usize;
        let n = counts(&pipeline(threads), &tris, RasterMode::Standard, &grid);
        for (j, &sy) in ys.iter().enumerate() {
            for (i, &sx) in xs.iter().enumerate() {
                let c = n[j * W as usize + i];
                prop_assert!(c <= 1, "sample ({}, {}) covered {} times", i, j, c);
                if sx > x0 && sx < x1 && sy > y0 && sy < y1 {
                    prop_assert_eq!(c, 1, "sample ({}, {}) at ({}, {}) inside the grid", i, j, sx, sy);
                }
                if sx < x0 || sx > x1 || sy < y0 || sy > y1 {
                    prop_assert_eq!(c, 0, "sample ({}, {}) outside the grid", i, j);
                }
            }
        }
    }

    /// Meshes whose vertices lie on samples, so shared edges (the grid's lines and its
    /// diagonals) pass through samples: the fill rule gives each such sample to exactly one
    /// triangle (a test that random positions, which seldom land on an edge, cannot make).
    #[test]
    fn edges_through_samples_cover_them_once(nx in 1usize..7, ny in 1usize..7, seed in any::<u64>()) {
        let mut rng = SplitMix(seed);
        let (xs, xpx) = table(&mut rng, W as usize);
        let (ys, ypx) = table(&mut rng, H as usize);
        let grid = SampleGrid::new(&xpx, &ypx).unwrap();
        // Grid lines at distinct sample indices.
        let pick = |rng: &mut SplitMix, n: usize, k: usize| {
            let mut v: Vec<usize> = Vec::new();
            while v.len() < k + 1 {
                let i = (rng.next_u64() % n as u64) as usize;
                if !v.contains(&i) { v.push(i); }
            }
            v.sort();
            v
        };
        let (ci, cj) = (pick(&mut rng, W as usize, nx), pick(&mut rng, H as usize, ny));
        let g: Vec<Vec<(i64, i64)>> = cj.iter().map(|&j| ci.iter().map(|&i| (xs[i], ys[j])).collect()).collect();
        let tris = quads(&mut rng, &g);
        let n = counts(&pipeline(2), &tris, RasterMode::Standard, &grid);
        let (i0, i1, j0, j1) = (ci[0], ci[nx], cj[0], cj[ny]);
        for j in 0..H as usize {
            for i in 0..W as usize {
                let c = n[j * W as usize + i];
                prop_assert!(c <= 1, "sample ({}, {}) covered {} times", i, j, c);
                // Inside the outer rectangle (its left and top sides included, by the rule).
                let inside = i >= i0 && i < i1 && j >= j0 && j < j1;
                prop_assert_eq!(c == 1, inside, "sample ({}, {})", i, j);
            }
        }
    }

    /// A fan of triangles around a centre (with slivers) never covers a sample twice and
    /// covers every sample strictly inside one of its triangles or on a spoke, with the rows
    /// warped and the columns at pixel centres (LogPSM's case) or both warped.
    #[test]
    fn fans_are_watertight_at_any_samples(n in 3usize..40, cx in 0i64..65536, cy in 0i64..65536, seed in any::<u64>(), both in any::<bool>()) {
        let mut rng = SplitMix(seed);
        let (ys, ypx) = table(&mut rng, H as usize);
        let (xs, grid) = if both {
            let (xs, xpx) = table(&mut rng, W as usize);
            (xs, SampleGrid::new(&xpx, &ypx).unwrap())
        } else {
            ((0..W as i64).map(|i| i * 256 + 128).collect(), SampleGrid::rows(W, &ypx).unwrap())
        };
        let c = (cx, cy);
        let (tris, rim) = fan(&mut rng, n, c);
        let counts = counts(&pipeline(2), &tris, RasterMode::Standard, &grid);
        for (j, &sy) in ys.iter().enumerate() {
            for (i, &sx) in xs.iter().enumerate() {
                let p = (sx, sy);
                let v = counts[j * W as usize + i];
                prop_assert!(v <= 1, "sample ({}, {}) covered {} times", i, j, v);
                if fan_covers(&tris, &rim, c, p) {
                    prop_assert_eq!(v, 1, "sample ({}, {}) must be covered once", i, j);
                }
            }
        }
    }

    /// Conservative modes at warped samples: overestimate covers exactly the samples whose
    /// closed cell meets the closed triangle (separating axes: the cell's box and the
    /// triangle's three edge normals), underestimate exactly those whose cell lies inside it;
    /// underestimate within standard within overestimate.
    #[test]
    fn conservative_modes_are_exact_at_any_samples(c in (0i64..65536, 0i64..65536), d in proptest::array::uniform3((-9000i64..9000, -9000i64..9000)), seed in any::<u64>()) {
        let t = [(c.0 + d[0].0, c.1 + d[0].1), (c.0 + d[1].0, c.1 + d[1].1), (c.0 + d[2].0, c.1 + d[2].1)];
        let area = orient(t[0], t[1], t[2]);
        prop_assume!(area != 0);
        // Counter-clockwise in window space (y down) for the orientation tests below.
        let t = if area > 0 { t } else { [t[0], t[2], t[1]] };
        let mut rng = SplitMix(seed);
        let (xs, xpx) = table(&mut rng, W as usize);
        let (ys, ypx) = table(&mut rng, H as usize);
        let grid = SampleGrid::new(&xpx, &ypx).unwrap();
        let p = pipeline(2);
        let over = counts(&p, &[t], RasterMode::Overestimate, &grid);
        let under = counts(&p, &[t], RasterMode::Underestimate, &grid);
        let standard = counts(&p, &[t], RasterMode::Standard, &grid);
        let (xc, yc) = (cells(&xs, W as i64 * 256), cells(&ys, H as i64 * 256));
        let (bx0, bx1) = (t.iter().map(|v| v.0).min().unwrap(), t.iter().map(|v| v.0).max().unwrap());
        let (by0, by1) = (t.iter().map(|v| v.1).min().unwrap(), t.iter().map(|v| v.1).max().unwrap());
        for (j, &(y0, y1)) in yc.iter().enumerate() {
            for (i, &(x0, x1)) in xc.iter().enumerate() {
                let k = j * W as usize + i;
                let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
                let edges = [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
                let touches = x1 >= bx0 && x0 <= bx1 && y1 >= by0 && y0 <= by1
                    && edges.iter().all(|(a, b)| corners.iter().any(|q| orient(*a, *b, *q) >= 0));
                let inside = edges.iter().all(|(a, b)| corners.iter().all(|q| orient(*a, *b, *q) >= 0));
                prop_assert_eq!(over[k] == 1, touches, "overestimate at sample ({}, {})", i, j);
                prop_assert_eq!(under[k] == 1, inside, "underestimate at sample ({}, {})", i, j);
                prop_assert!(under[k] <= standard[k] && standard[k] <= over[k]);
            }
        }
    }
}

/// Random triangles in front of a warped grid.
fn scene(seed: u64, n: usize) -> (Vec<Vec4>, Vec<u32>) {
    let mut rng = SplitMix(seed);
    let mut v = Vec::new();
    for _ in 0..n {
        let (cx, cy, z) = (rng.next_f32() * 2.2 - 1.1, rng.next_f32() * 2.2 - 1.1, rng.next_f32());
        let s = 0.02 + 0.3 * rng.next_f32();
        for _ in 0..3 {
            v.push(Vec4::new(
                cx + s * (rng.next_f32() - 0.5),
                cy + s * (rng.next_f32() - 0.5),
                (z + 0.1 * (rng.next_f32() - 0.5)).clamp(0.0, 1.0),
                1.0,
            ));
        }
    }
    let idx = (0..v.len() as u32).collect();
    (v, idx)
}

/// The same depths and counters for 1, 2 and 4 threads, in every raster mode, and across
/// runs.
#[test]
fn draws_at_samples_are_identical_for_1_2_4_threads() {
    let mut rng = SplitMix(7);
    let (_, ypx) = table(&mut rng, 300);
    let grid = SampleGrid::rows(200, &ypx).unwrap();
    let (v, idx) = scene(11, 3000);
    for raster in [
        RasterMode::Standard,
        RasterMode::Overestimate,
        RasterMode::Underestimate,
    ] {
        let state = RenderState {
            raster,
            offset: PolygonOffset {
                factor: 1.1,
                units: 4.0,
            },
            ..Default::default()
        };
        let run = |threads: usize| {
            let mut d = Surface::new(200, 300, 1.0f32).unwrap();
            let s = pipeline(threads)
                .draw_depth_at(&mut d, Some(1.0), &state, &v, &idx, &grid)
                .unwrap();
            (d.data().to_vec(), s)
        };
        let one = run(1);
        assert!(one.1.fragments_passed > 10_000, "{:?}", one.1);
        for threads in [2, 4, 2] {
            let other = run(threads);
            assert!(one.0 == other.0 && one.1 == other.1, "{raster:?}, {threads} threads");
        }
    }
}

/// Rows crowded near the top of a `w` x `h` target, as a logarithmic warp of one axis would
/// put them (64:1).
fn log_grid(w: u32, h: u32) -> SampleGrid {
    let ys: Vec<f64> = (0..h)
        .map(|j| h as f64 * ((1.0 + 63.0f64).powf((j as f64 + 0.5) / h as f64) - 1.0) / 63.0)
        .collect();
    SampleGrid::rows(w, &ys).unwrap()
}

/// The whole viewport (two triangles) at depth `z(x_ndc, y_ndc)`, a plane.
fn plane_quad(z: impl Fn(f32, f32) -> f32) -> ([Vec4; 4], [u32; 6]) {
    let corner = |x: f32, y: f32| Vec4::new(x, y, z(x, y), 1.0);
    (
        [
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
        ],
        [0, 1, 2, 0, 2, 3],
    )
}

/// A sample's depth is the triangle's plane at the sample's own position: a plane tilted in
/// x and y, drawn at a logarithmic row table, matches the plane evaluated at each sample.
#[test]
fn depth_is_the_plane_at_the_warped_sample() {
    let (w, h) = (64u32, 128u32);
    let grid = log_grid(w, h);
    let z = |x: f32, y: f32| 0.5 + 0.2 * x + 0.1 * y;
    let (v, idx) = plane_quad(z);
    let mut d = Surface::new(w, h, 1.0f32).unwrap();
    let state = RenderState::default();
    let s = pipeline(2)
        .draw_depth_at(&mut d, Some(1.0), &state, &v, &idx, &grid)
        .unwrap();
    assert_eq!(s.fragments_passed, (w * h) as u64, "every sample once");
    for j in 0..h as usize {
        for i in 0..w as usize {
            let (xn, yn) = (grid.x(i) / w as f64 * 2.0 - 1.0, 1.0 - grid.y(j) / h as f64 * 2.0);
            let want = z(xn as f32, yn as f32);
            let got = d.at(i as u32, j as u32);
            assert!((got - want).abs() < 2e-6, "({i}, {j}): {got} against {want}");
        }
    }
}

/// The polygon offset's slope term is the depth's change across the sample's own cell:
/// `factor * max(|dz/dx| w_i, |dz/dy| h_j)` plus `units * r`, so rows spread wider get a
/// proportionally larger bias; on pixel centres it is the standard draw's offset.
#[test]
fn the_slope_offset_scales_with_the_sample_cell() {
    let (w, h) = (32u32, 64u32);
    let grid = log_grid(w, h);
    // Depth rising in y much faster than in x, so the row term is the larger one.
    let (v, idx) = plane_quad(|x, y| 0.5 + 0.01 * x + 0.2 * y);
    let offset = PolygonOffset {
        factor: 2.0,
        units: 3.0,
    };
    let draw = |offset: PolygonOffset, grid: &SampleGrid| {
        let mut d = Surface::new(grid.width(), grid.height(), 1.0f32).unwrap();
        let state = RenderState {
            offset,
            ..Default::default()
        };
        pipeline(2)
            .draw_depth_at(&mut d, Some(1.0), &state, &v, &idx, grid)
            .unwrap();
        d
    };
    let (plain, biased) = (draw(PolygonOffset::default(), &grid), draw(offset, &grid));
    // Per pixel in window units: dz/dy = 0.2 * 2 / h.
    let (dzdx, dzdy) = (0.01 * 2.0 / w as f64, 0.2 * 2.0 / h as f64);
    let r = DepthFormat::F32.resolvable(1.0) as f64;
    let (mut small, mut large) = (f64::MAX, 0.0f64);
    for j in 0..h {
        let want = 2.0 * (dzdx * grid.cell_width(0)).max(dzdy * grid.cell_height(j as usize)) + 3.0 * r;
        let got = (biased.at(5, j) - plain.at(5, j)) as f64;
        assert!((got - want).abs() < 1e-6, "row {j}: offset {got} against {want}");
        small = small.min(got);
        large = large.max(got);
    }
    assert!(
        large > 4.0 * small,
        "the rows' cells differ, so must their offsets: {small} .. {large}"
    );
    // On pixel centres: the standard draw's offset.
    let uniform = SampleGrid::uniform(w, h).unwrap();
    let at = draw(offset, &uniform);
    let mut standard = Surface::new(w, h, 1.0f32).unwrap();
    let state = RenderState {
        offset,
        ..Default::default()
    };
    pipeline(2)
        .draw(
            &mut Targets::depth_only(&mut standard).clearing_depth(1.0),
            &state,
            &v,
            &idx,
            &ClipPassthrough,
            &DepthOnly,
        )
        .unwrap();
    // (The standard rasterizer steps its depth plane incrementally: the same values to
    // within one rounding.)
    let worst = at
        .data()
        .iter()
        .zip(standard.data())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 1.2e-7,
        "pixel centres: the standard draw's offset, but {worst} apart"
    );
}

/// Bad tables and mismatched targets are errors that say what was wrong.
#[test]
fn bad_tables_are_refused() {
    for (xs, ys, what) in [
        (vec![0.5, 0.5], vec![0.5], "x[1]"),
        (vec![0.5], vec![f64::NAN], "y[0]"),
        (vec![0.5, 3.0], vec![0.5], "x[1]"),
        (vec![], vec![0.5], "x"),
    ] {
        let e = SampleGrid::new(&xs, &ys).unwrap_err();
        assert!(format!("{e:?}").contains(what), "{e:?}");
    }
    let grid = SampleGrid::uniform(8, 8).unwrap();
    for (height, idx, want) in [(9, [0, 1, 2], "SizeMismatch"), (8, [0, 1, 5], "IndexOutOfRange")] {
        let mut d = Surface::new(8, height, 1.0f32).unwrap();
        let e = pipeline(1)
            .draw_depth_at(&mut d, None, &RenderState::default(), &[Vec4::ONE; 3], &idx, &grid)
            .unwrap_err();
        assert!(format!("{e:?}").starts_with(want), "{e:?}");
    }
}
