//! Stage 3, setup: viewport transform, snapping to [`Fx8`] fixed point, culling by winding,
//! integer edge functions with the top-left fill rule (or the conservative shifts), the
//! bounding box, and plane equations for depth, `1/w` and the perspective-correct barycentrics.
//! Polygon offset (constant + slope-scaled, as glPolygonOffset) is computed here once per
//! triangle.
//!
//! Edge function of edge `i -> j` (window coordinates, y down, counter-clockwise on screen
//! after a swap that makes the signed area positive):
//! `E(p) = (xj - xi) (py - yi) - (yj - yi) (px - xi)`, inside where `E >= 0` for all three.
//! A sample exactly on an edge belongs to the triangle only if the edge is a *top* edge
//! (horizontal, interior below) or a *left* edge (interior to the right): the rule is a bias
//! of -1 on the integer function, so shared edges are covered exactly once.

use super::clip::ClipVertex;
use super::fixed::{Fx8, HALF, ONE};
use super::state::{CullMode, FrontFace, PolygonOffset, RasterMode, RenderState};
use super::vertex::Varyings;

/// Largest |window coordinate| in pixels accepted after clipping (the guard band is smaller).
pub const MAX_WINDOW_COORD: f64 = 131072.0;

/// One integer edge function, evaluated at pixel centres: `E(px, py) = c + dx * px + dy * py`.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Edge {
    /// Change of `E` per pixel step in x.
    pub dx: i64,
    /// Change of `E` per pixel step in y.
    pub dy: i64,
    /// `E` at the centre of pixel (0, 0), including the fill-rule bias or conservative shift.
    pub c: i64,
}

impl Edge {
    /// `E` at the centre of pixel (px, py).
    #[inline(always)]
    pub fn at(&self, px: i64, py: i64) -> i64 {
        self.c + self.dx * px + self.dy * py
    }
}

/// A plane `v(px, py) = c + dx * px + dy * py` over pixel centres (pixel (0, 0) centre at origin).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Plane {
    /// Value at the centre of pixel (0, 0).
    pub c: f64,
    /// Gradient per pixel in x.
    pub dx: f64,
    /// Gradient per pixel in y.
    pub dy: f64,
}

impl Plane {
    /// Plane through three values at three window positions (pixels); `inv_area2` is
    /// 1 / ((x1-x0)(y2-y0) - (x2-x0)(y1-y0)).
    #[inline]
    fn through(p: &[(f64, f64); 3], v: [f64; 3], inv_area2: f64) -> Plane {
        let (x0, y0) = p[0];
        let (ex1, ey1) = (p[1].0 - x0, p[1].1 - y0);
        let (ex2, ey2) = (p[2].0 - x0, p[2].1 - y0);
        let (d1, d2) = (v[1] - v[0], v[2] - v[0]);
        let dx = (d1 * ey2 - d2 * ey1) * inv_area2;
        let dy = (d2 * ex1 - d1 * ex2) * inv_area2;
        // Pixel (0, 0) centre is window (0.5, 0.5).
        let c = v[0] + dx * (0.5 - x0) + dy * (0.5 - y0);
        Plane { c, dx, dy }
    }

    /// The plane re-based at pixel (ox, oy), in `f32` for the per-pixel loop.
    #[inline(always)]
    pub fn at_origin(&self, ox: i64, oy: i64) -> TilePlane {
        TilePlane {
            c: (self.c + self.dx * ox as f64 + self.dy * oy as f64) as f32,
            dx: self.dx as f32,
            dy: self.dy as f32,
        }
    }
}

/// A [`Plane`] re-based at a tile origin, in `f32`.
#[derive(Copy, Clone, Debug, Default)]
pub struct TilePlane {
    /// Value at the tile origin pixel's centre.
    pub c: f32,
    /// Gradient per pixel in x.
    pub dx: f32,
    /// Gradient per pixel in y.
    pub dy: f32,
}

impl TilePlane {
    /// Value at (lx, ly) pixels from the tile origin.
    #[inline(always)]
    pub fn at(&self, lx: f32, ly: f32) -> f32 {
        self.c + self.dx * lx + self.dy * ly
    }
}

/// A triangle ready to rasterize (what coverage and depth need: two cache lines).
#[derive(Copy, Clone, Debug)]
pub struct SetupTri {
    /// Edge functions (fill rule or conservative shift already folded into `c`).
    pub edges: [Edge; 3],
    /// Inclusive pixel bounding box `[x0, y0, x1, y1]`, clipped to the viewport.
    pub bbox: [i32; 4],
    /// Window depth (z/w in [0, 1] before offset and clamp).
    pub z: Plane,
    /// Polygon offset added to every fragment's depth.
    pub z_offset: f32,
    /// Triangle faces the viewer (per [`FrontFace`]).
    pub front: bool,
    /// Index of the source triangle in the draw.
    pub prim: u32,
    /// Every edge spans less than [`SMALL_EXTENT`] pixels in x and y, so edge values over the
    /// triangle's bounding box fit in `i32` (the rasterizer's small-triangle path).
    pub small: bool,
    /// Index of its [`TriAttrs`] in its chunk.
    pub attr: u32,
}

/// Extent (pixels) below which a triangle is "small" (see [`SetupTri::small`]).
pub const SMALL_EXTENT: i64 = 32;

/// What only shading needs, stored apart from [`SetupTri`] so depth-only passes never load it.
#[derive(Copy, Clone, Debug)]
pub struct TriAttrs<V> {
    /// `1/w`, `b1/w`, `b2/w` for perspective-correct barycentrics.
    pub persp: [Plane; 3],
    /// Varyings at the three vertices (after the winding swap).
    pub var: [V; 3],
}

/// Why setup produced no triangle.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Rejected {
    /// Zero area after snapping.
    Degenerate,
    /// Culled by winding.
    Culled,
    /// No pixel of the viewport can be covered.
    Outside,
    /// Coordinates not finite or beyond [`MAX_WINDOW_COORD`].
    NonFinite,
}

/// Per-draw constants of setup.
#[derive(Copy, Clone, Debug)]
pub struct SetupParams {
    /// Viewport width in pixels.
    pub width: u32,
    /// Viewport height in pixels.
    pub height: u32,
    /// Culling.
    pub cull: CullMode,
    /// Front face.
    pub front_face: FrontFace,
    /// Coverage rule.
    pub raster: RasterMode,
    /// Polygon offset.
    pub offset: PolygonOffset,
    /// Depth format (for the offset's unit `r`).
    pub format: super::state::DepthFormat,
}

impl SetupParams {
    /// From a render state and viewport size.
    pub fn new(state: &RenderState, width: u32, height: u32) -> Self {
        SetupParams {
            width,
            height,
            cull: state.cull,
            front_face: state.front_face,
            raster: state.raster,
            offset: state.offset,
            format: state.depth.format,
        }
    }
}

/// A vertex after the viewport transform: snapped window position (8 sub-pixel bits), depth
/// z/w and 1/w. Computed once per vertex for triangles that need no clipping (shared by the
/// triangles around it), or per clipped vertex.
#[derive(Copy, Clone, Debug, Default)]
pub struct WinVertex {
    /// Snapped x, fixed point.
    pub x: i64,
    /// Snapped y (window y down), fixed point.
    pub y: i64,
    /// Depth z/w.
    pub z: f64,
    /// 1/w.
    pub iw: f64,
}

/// The viewport transform of one clip-space position: NDC y up -> window y down; depth z/w;
/// snapped to 8 sub-pixel bits. Non-finite or out-of-range results are rejected.
#[inline]
pub fn window_vertex(p: &SetupParams, pos: glam::Vec4) -> Result<WinVertex, Rejected> {
    let hw = p.width as f64 * 0.5;
    let hh = p.height as f64 * 0.5;
    let w = pos.w as f64;
    let iw = 1.0 / w;
    let x = (pos.x as f64 * iw + 1.0) * hw;
    let y = (1.0 - pos.y as f64 * iw) * hh;
    let z = pos.z as f64 * iw;
    if !(x.is_finite() && y.is_finite() && z.is_finite() && iw.is_finite())
        || x.abs() > MAX_WINDOW_COORD
        || y.abs() > MAX_WINDOW_COORD
    {
        return Err(Rejected::NonFinite);
    }
    let fx = |t: f64| (t * ONE as f64).round() as i64;
    Ok(WinVertex {
        x: fx(x),
        y: fx(y),
        z,
        iw,
    })
}

/// Sets up one (clipped) triangle.
pub fn setup_triangle<V: Varyings>(
    p: &SetupParams,
    v: [ClipVertex<V>; 3],
    prim: u32,
) -> Result<(SetupTri, TriAttrs<V>), Rejected> {
    let win = [
        window_vertex(p, v[0].pos)?,
        window_vertex(p, v[1].pos)?,
        window_vertex(p, v[2].pos)?,
    ];
    setup_window(p, win, [v[0].var, v[1].var, v[2].var], prim)
}

/// Sets up one triangle from its vertices' window positions and varyings.
#[inline]
pub fn setup_window<V: Varyings>(
    p: &SetupParams,
    win: [WinVertex; 3],
    vars: [V; 3],
    prim: u32,
) -> Result<(SetupTri, TriAttrs<V>), Rejected> {
    let (tri, persp, order) = setup_window_parts::<V>(p, win, prim)?;
    Ok((
        tri,
        TriAttrs {
            persp,
            var: order.map(|o| vars[o]),
        },
    ))
}

/// [`setup_window`] without assembling [`TriAttrs`]: the triangle, the perspective planes
/// (default planes for empty varyings `V`) and the vertex order after the winding swap
/// (`TriAttrs::var[i]` is the varyings of vertex `order[i]`). Set-up writes the attributes
/// straight into its chunk with these (building them here and moving them there cost a
/// `memcpy` per triangle).
#[inline(always)]
pub(crate) fn setup_window_parts<V: Varyings>(
    p: &SetupParams,
    win: [WinVertex; 3],
    prim: u32,
) -> Result<(SetupTri, [Plane; 3], [usize; 3]), Rejected> {
    let mut xs = [Fx8(win[0].x), Fx8(win[1].x), Fx8(win[2].x)];
    let mut ys = [Fx8(win[0].y), Fx8(win[1].y), Fx8(win[2].y)];
    let area = (xs[1].0 - xs[0].0) * (ys[2].0 - ys[0].0) - (xs[2].0 - xs[0].0) * (ys[1].0 - ys[0].0);
    if area == 0 {
        return Err(Rejected::Degenerate);
    }
    // Winding: counter-clockwise in NDC (y up) has negative area in window space (y down).
    let ccw_ndc = area < 0;
    let front = match p.front_face {
        FrontFace::Ccw => ccw_ndc,
        FrontFace::Cw => !ccw_ndc,
    };
    match p.cull {
        CullMode::Back if !front => return Err(Rejected::Culled),
        CullMode::Front if front => return Err(Rejected::Culled),
        _ => {}
    }
    let mut order = [0usize, 1, 2];
    if area < 0 {
        order = [0, 2, 1];
        xs = [xs[0], xs[2], xs[1]];
        ys = [ys[0], ys[2], ys[1]];
    }
    let area = area.abs();

    // Bounding box in pixels (sample centres for standard/underestimate, squares for overestimate).
    let (xmin, xmax) = (xs.iter().min().unwrap().0, xs.iter().max().unwrap().0);
    let (ymin, ymax) = (ys.iter().min().unwrap().0, ys.iter().max().unwrap().0);
    let (bx0, bx1, by0, by1) = match p.raster {
        RasterMode::Overestimate => (
            Fx8(xmin).ceil_pixel() - 1,
            Fx8(xmax).floor_pixel(),
            Fx8(ymin).ceil_pixel() - 1,
            Fx8(ymax).floor_pixel(),
        ),
        _ => (
            Fx8(xmin - HALF).ceil_pixel(),
            Fx8(xmax - HALF).floor_pixel(),
            Fx8(ymin - HALF).ceil_pixel(),
            Fx8(ymax - HALF).floor_pixel(),
        ),
    };
    let bx0 = bx0.max(0);
    let by0 = by0.max(0);
    let bx1 = bx1.min(p.width as i64 - 1);
    let by1 = by1.min(p.height as i64 - 1);
    if bx0 > bx1 || by0 > by1 {
        return Err(Rejected::Outside);
    }

    // Edge functions at pixel centres.
    let mut edges = [Edge { dx: 0, dy: 0, c: 0 }; 3];
    for i in 0..3 {
        let j = (i + 1) % 3;
        let a = -(ys[j].0 - ys[i].0); // dE/dx (fixed units)
        let b = xs[j].0 - xs[i].0; // dE/dy
                                   // E at the centre of pixel (0, 0), i.e. fixed (HALF, HALF).
        let mut c = a * (HALF - xs[i].0) + b * (HALF - ys[i].0);
        let shift = (a.abs() + b.abs()) * HALF;
        match p.raster {
            RasterMode::Standard => {
                // Non-short-circuit `&` and `|`: no branch on the edge's direction (which no
                // predictor guesses for random triangles).
                let top_left = (a > 0) | ((a == 0) & (b > 0));
                c -= (!top_left) as i64;
            }
            RasterMode::Overestimate => c += shift,
            RasterMode::Underestimate => c -= shift,
        }
        edges[i] = Edge {
            dx: a * ONE,
            dy: b * ONE,
            c,
        };
    }

    // Plane equations from the snapped positions.
    let pts = [
        (xs[0].to_f64(), ys[0].to_f64()),
        (xs[1].to_f64(), ys[1].to_f64()),
        (xs[2].to_f64(), ys[2].to_f64()),
    ];
    let inv_area2 = (ONE * ONE) as f64 / area as f64;
    let wv = [win[order[0]], win[order[1]], win[order[2]]];
    let z = Plane::through(&pts, [wv[0].z, wv[1].z, wv[2].z], inv_area2);
    let persp = if V::EMPTY {
        [Plane::default(); 3]
    } else {
        [
            Plane::through(&pts, [wv[0].iw, wv[1].iw, wv[2].iw], inv_area2),
            Plane::through(&pts, [0.0, wv[1].iw, 0.0], inv_area2),
            Plane::through(&pts, [0.0, 0.0, wv[2].iw], inv_area2),
        ]
    };
    // glPolygonOffset: factor * max slope + units * r.
    let z_offset = if p.offset.factor != 0.0 || p.offset.units != 0.0 {
        let zmax = wv.iter().map(|w| w.z.abs()).fold(0.0, f64::max) as f32;
        let slope = z.dx.abs().max(z.dy.abs()) as f32;
        p.offset.factor * slope + p.offset.units * p.format.resolvable(zmax)
    } else {
        0.0
    };
    Ok((
        SetupTri {
            edges,
            bbox: [bx0 as i32, by0 as i32, bx1 as i32, by1 as i32],
            z,
            z_offset,
            front,
            prim,
            small: xmax - xmin < SMALL_EXTENT * ONE && ymax - ymin < SMALL_EXTENT * ONE,
            attr: 0,
        },
        persp,
        order,
    ))
}
