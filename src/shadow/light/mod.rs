//! Shared light-space machinery for every map-based technique (shadow maps, cookies and all
//! the filtered, volumetric, exact and penumbra techniques that start from a light view).
//!
//! - [`light_views`]: one view per light kind: orthographic along a directional light
//!   (fitted to the scene), the spot's perspective cone, six 90-degree cube faces for point
//!   and area lights (their centre), in [`CubeFace::ALL`] order.
//! - [`fit`]: a directional light's frustum fitted to the receivers the camera sees, with
//!   the casters that cannot shadow them culled (RTR 7.4, fig. 7.11), and optional texel
//!   snapping so sub-texel camera motion keeps the sampling grid in place.
//! - [`depth`]: the casters merged into one draw and the depth pass into any depth format
//!   with polygon offset, face culling and depth peeling.
//! - [`maps`]: the map pass ([`LightMaps`], [`MapOptions`]) and [`locate`], where a world
//!   point falls in the maps (the view that sees it, its texture coordinate and depth), with
//!   the one edge rule [`inside`].
//! - [`pass`]: the one light pass ([`ViewMaps::render`]): any set of views drawn in turn,
//!   each storing what a technique's [`Payload`] keeps per texel.
//! - [`soft`]: an area light's soft-shadow geometry (light width, blocker-search and
//!   penumbra widths, RTR eq. 7.6).
//! - [`LightView::lookup`] / [`project`]: a world point to one view's texture coordinates and
//!   depth.

pub mod cascades;
pub mod depth;
pub mod maps;
pub mod pass;
pub mod sdsm;
pub mod soft;
pub mod warp;

use crate::frame::Frame;
use crate::math;
use crate::pipeline::{CubeFace, Pipeline, Rgba8, Surface};
use crate::scene::{Light, LightKind};
use crate::Error;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

pub use depth::{merged_casters, scene_depth, Casters, DepthPass};
pub use maps::{
    inside, inside4, locate, locate_on, texel, view_of, FitTo, Layer, LightMaps, MapOptions, MapPoint, OnView, Views,
};
pub use pass::{Payload, ViewMaps};

/// One light view: world to light clip, and the world size of one texel at unit distance
/// (orthographic: everywhere; perspective: times the distance to the light).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LightView {
    /// World to light clip space (depth in [0, 1]).
    pub matrix: Mat4,
    /// Texel size in world units (perspective views: per unit of distance from the light;
    /// warped views: in texture coordinates, `1 / size`).
    pub texel: f32,
    /// What kind of view it is: one of, never a mix.
    pub kind: ViewKind,
}

/// The kind of a [`LightView`]: how its matrix projects and how a point picks it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum ViewKind {
    /// Orthographic along a directional light, fitted to the scene or to the receivers.
    Ortho,
    /// A perspective cone from the light's position (a spot light, or one face of a point or
    /// area light's cube): the texel size grows with the distance.
    Perspective,
    /// One cascade of a directional light's set (orthographic): the view depths it covers and
    /// how points pick it ([`cascades::Slice`]).
    Cascade(cascades::Slice),
    /// A directional light's warped view ([`warp`]: PSM, TSM, LiSPSM): a projective matrix
    /// whose texel size varies over the map ([`LightView::texel_at`] takes it from the
    /// matrix) and whose depth is not linear along the light (no [`LightView::distance`]).
    /// With LogPSM's logarithmic rows ([`warp::LogRows`]) the map's `v` is the logarithm of
    /// the distance along the warp axis instead of the matrix's perspective `v`, and the map
    /// is drawn at the rows' sample table.
    Warped {
        /// LogPSM's rows; `None` for the other warps.
        log: Option<warp::LogRows>,
    },
}

impl LightView {
    /// True for perspective views ([`ViewKind::Perspective`]: texel size grows with distance).
    #[inline]
    pub fn perspective(&self) -> bool {
        self.kind == ViewKind::Perspective
    }

    /// True for a directional light's warped view ([`ViewKind::Warped`]).
    #[inline]
    pub fn warped(&self) -> bool {
        matches!(self.kind, ViewKind::Warped { .. })
    }

    /// LogPSM's logarithmic rows, if the view has them ([`ViewKind::Warped`]).
    #[inline]
    pub fn log(&self) -> Option<&warp::LogRows> {
        match &self.kind {
            ViewKind::Warped { log } => log.as_ref(),
            _ => None,
        }
    }

    /// The depths a cascade covers ([`ViewKind::Cascade`]); `None` for every other view.
    #[inline]
    pub fn slice(&self) -> Option<cascades::Slice> {
        match self.kind {
            ViewKind::Cascade(s) => Some(s),
            _ => None,
        }
    }

    /// Texture coordinate (origin top-left, [0, 1]²) and depth of world point `p`; `None`
    /// behind a perspective view's eye.
    #[inline]
    pub fn lookup(&self, p: Vec3) -> Option<(Vec2, f32)> {
        match self.log() {
            None => project(&self.matrix, p),
            Some(rows) => rows.project(&self.matrix, p),
        }
    }

    /// World size of one texel at world point `p` (seen from `light`).
    pub fn texel_at(&self, light: &Light, p: Vec3) -> f32 {
        if self.warped() {
            warp::texel_at(&self.matrix, self.log(), light.direction, p, self.texel)
        } else if self.perspective() {
            self.texel * (p - light.position).length()
        } else {
            self.texel
        }
    }

    /// Distance along the view's axis of a point at map depth `z` (in [0, 1]): from the eye
    /// for perspective views (the depth unprojected), from a fixed plane for orthographic
    /// ones (only differences of distances mean something there). Not for warped views,
    /// whose depth scale changes over the map: the techniques that unproject depths (PCSS,
    /// CHS, the filtered maps) take no warp.
    #[inline]
    pub fn distance(&self, z: f32) -> f32 {
        self.depth_to_distance().at(z)
    }

    /// [`LightView::distance`] with its constants computed once, for loops over many depths
    /// (the same operations, so the same values).
    #[inline]
    pub fn depth_to_distance(&self) -> DepthToDistance {
        let (r2, r3) = (self.matrix.row(2), self.matrix.row(3));
        if self.perspective() {
            // A perspective projection's depth row is `-a * (w row) + b * e_w`, so
            // `z = -a + b / w` and `w` (the distance along the axis) is `b / (z + a)`.
            let a = -r2.truncate().dot(r3.truncate()) / r3.truncate().length_squared();
            DepthToDistance {
                perspective: true,
                a,
                b: r2.w + a * r3.w,
            }
        } else {
            DepthToDistance {
                perspective: false,
                a: r2.w,
                b: r2.truncate().length(),
            }
        }
    }

    /// Whether the view's handedness is mirrored (cube faces): winding flips, so a pass that
    /// culls faces must swap front and back.
    pub fn mirrored(&self) -> bool {
        Mat3::from_mat4(self.matrix).determinant() > 0.0
    }
}

/// Light-space texture coordinate and depth of a world point, if in front of the light.
#[inline]
pub fn project(m: &Mat4, p: Vec3) -> Option<(Vec2, f32)> {
    let c = *m * p.extend(1.0);
    if c.w <= 0.0 {
        return None;
    }
    // One four-lane divide (the w lane is unused): per lane the same IEEE quotient as the
    // three scalar ones.
    let ndc = c / Vec4::splat(c.w);
    Some((Vec2::new(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5), ndc.z))
}

/// The eight corners of a box.
pub fn corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Light views fitted to the whole scene: one (directional, spot) or six (cube faces in
/// [`CubeFace::ALL`] order). `size` is the map side in texels.
pub fn light_views(frame: &Frame, size: u32) -> Vec<LightView> {
    let l = &frame.light;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let cs = corners(lo, hi);
    let far_from = |p: Vec3| cs.iter().map(|c| (*c - p).length()).fold(0.0f32, f32::max) * 1.01 + 1e-3;
    match l.kind {
        LightKind::Directional => vec![directional_view(frame, &cs, &cs, size, false)],
        LightKind::Spot { angle_deg } => {
            let view = Mat4::look_at_rh(l.position, l.position + l.direction, up_for(l.direction));
            let far = far_from(l.position);
            let half = math::tan(angle_deg.to_radians() * 0.5);
            vec![LightView {
                matrix: Mat4::perspective_rh(angle_deg.to_radians(), 1.0, (far * 1e-4).max(1e-3), far) * view,
                texel: 2.0 * half / size as f32,
                kind: ViewKind::Perspective,
            }]
        }
        LightKind::Point | LightKind::Area(_) => cube_views(frame, size),
    }
}

/// Six 90-degree cube-face views around the light's position (in [`CubeFace::ALL`] order),
/// whatever its kind: point and area lights use them, and techniques that must see every
/// direction from a spot light (its cone aside) too.
pub fn cube_views(frame: &Frame, size: u32) -> Vec<LightView> {
    let l = &frame.light;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let cs = corners(lo, hi);
    let far_from = |p: Vec3| cs.iter().map(|c| (*c - p).length()).fold(0.0f32, f32::max) * 1.01 + 1e-3;
    let far = far_from(l.position);
    let proj = Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, (far * 1e-4).max(1e-3), far);
    CubeFace::ALL
        .iter()
        .map(|f| {
            // Rows: x = u, y = -v (texture v points down), z = -forward (looking down -z).
            let (fwd, u, v) = f.basis();
            let e = l.position;
            let view = Mat4::from_cols(
                Vec4::new(u.x, -v.x, -fwd.x, 0.0),
                Vec4::new(u.y, -v.y, -fwd.y, 0.0),
                Vec4::new(u.z, -v.z, -fwd.z, 0.0),
                Vec4::new(-u.dot(e), v.dot(e), fwd.dot(e), 1.0),
            );
            LightView {
                matrix: proj * view,
                texel: 2.0 / size as f32,
                kind: ViewKind::Perspective,
            }
        })
        .collect()
}

fn up_for(d: Vec3) -> Vec3 {
    if d.y.abs() < 0.99 {
        Vec3::Y
    } else {
        Vec3::Z
    }
}

/// An orthographic view along a directional light: x/y fitted to `receivers`, depth range
/// covering `receivers` and `casters` (RTR fig. 7.11). With `snap`, the extent is quantized and
/// the origin moved to whole texels, so small camera motions keep the sampling grid in place.
pub fn directional_view(frame: &Frame, receivers: &[Vec3], casters: &[Vec3], size: u32, snap: bool) -> LightView {
    let l = &frame.light;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let view = Mat4::look_at_rh(center - l.direction * radius * 2.0, center, up_for(l.direction));
    let bounds = |pts: &[Vec3]| {
        pts.iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| {
                let q = view.transform_point3(*p);
                (a.min(q), b.max(q))
            })
    };
    let (rlo, rhi) = bounds(receivers);
    let (_, chi) = bounds(casters);
    let m = radius * 0.01;
    let (mut x0, mut x1, mut y0, mut y1) = (rlo.x - m, rhi.x + m, rlo.y - m, rhi.y + m);
    if snap {
        // A stable extent (rounded up to 1/16 of the scene's diameter) and an origin on whole
        // texels of it: a sub-texel camera move changes neither.
        let q = radius / 8.0;
        let ext = ((x1 - x0).max(y1 - y0) / q).ceil() * q;
        let texel = ext / size as f32;
        x0 = (x0 / texel).floor() * texel;
        y0 = (y0 / texel).floor() * texel;
        x1 = x0 + ext;
        y1 = y0 + ext;
    }
    // Near: the caster closest to the light; far: the farthest receiver.
    let near = -(chi.z.max(rhi.z)) - m;
    let far = -rlo.z + m;
    LightView {
        matrix: Mat4::orthographic_rh(x0, x1, y0, y1, near, far) * view,
        texel: (x1 - x0).max(y1 - y0) / size as f32,
        kind: ViewKind::Ortho,
    }
}

/// The light views of one frame and the objects that can cast into them.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The views (one, or six cube faces).
    pub views: Vec<LightView>,
    /// Per scene object: whether it is drawn as a caster.
    pub casters: Vec<bool>,
    /// Objects culled as casters.
    pub culled: usize,
    /// The fitted view when a directional light was fitted to receivers (for overviews).
    pub fitted: Option<LightView>,
    /// Cascades: per view, which objects it draws (empty: every view draws `casters`).
    pub per_view: Vec<Vec<bool>>,
}

/// The views of `frame` at `size` texels: with `to_receivers` and a directional light, fitted
/// to the visible receivers (the G-buffer's points) with the casters whose light-space box
/// misses theirs culled, and snapped to whole texels with `snap`; otherwise [`light_views`]
/// with every object a caster.
pub fn fit(frame: &Frame, size: u32, to_receivers: bool, snap: bool) -> Fit {
    let all = vec![true; frame.scene.objects.len()];
    let unfitted = |casters| Fit {
        views: light_views(frame, size),
        casters,
        culled: 0,
        fitted: None,
        per_view: Vec::new(),
    };
    if !(to_receivers && frame.light.kind == LightKind::Directional) {
        return unfitted(all);
    }
    let pts: Vec<Vec3> = frame.points().iter().flatten().map(|s| s.position).collect();
    if pts.is_empty() {
        return unfitted(all);
    }
    // Casters: objects whose light-space x/y box overlaps the receivers' (and so can shadow
    // them); the rest are culled.
    let probe = directional_view(frame, &pts, &pts, size, false);
    let ndc_box = |ps: &[Vec3]| {
        ps.iter()
            .fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(a, b), p| {
                let q = probe.matrix.project_point3(*p).truncate();
                (a.min(q), b.max(q))
            })
    };
    let (rlo, rhi) = ndc_box(&pts);
    let mut caster_pts = Vec::new();
    let keep: Vec<bool> = frame
        .scene
        .objects
        .iter()
        .map(|o| {
            let Some((lo, hi)) = o.mesh.bounds() else { return false };
            let cs = corners(lo, hi);
            let (a, b) = ndc_box(&cs);
            let k = a.x <= rhi.x && b.x >= rlo.x && a.y <= rhi.y && b.y >= rlo.y;
            if k {
                caster_pts.extend_from_slice(&cs);
            }
            k
        })
        .collect();
    let view = directional_view(frame, &pts, &caster_pts, size, snap);
    Fit {
        views: vec![view],
        culled: keep.iter().filter(|k| !**k).count(),
        casters: keep,
        fitted: Some(view),
        per_view: Vec::new(),
    }
}

/// Per camera pixel of `frame`, row-major: the footprint of the shadow-map texel that
/// [`locate`] finds for the pixel's point in `views`, measured in camera pixels (Lloyd et al.
/// 2008's perspective aliasing factor, along one axis): the texel's world size over the
/// pixel's at the point, each stretched onto the surface by its view's slant,
/// `(texel / cos(light angle)) / (pixel / cos(eye angle))`. Above 1 the map is magnified
/// (aliasing: one texel over several pixels), below 1 texels are wasted; 1 is ideal. NaN
/// where there is no geometry or the surface faces away from the light.
pub fn texel_footprint(frame: &Frame, views: &[impl OnView]) -> Vec<f32> {
    let cam = &frame.camera;
    let light = &frame.light;
    let plane = cascades::depth_plane(frame);
    // World size of one pixel per unit of view depth.
    let pixel = 2.0 * math::tan(cam.fov_deg.to_radians() * 0.5) / cam.height.max(1) as f32;
    frame
        .points()
        .iter()
        .map(|s| {
            let Some(s) = s else { return f32::NAN };
            let cos_l = s.face.dot(light.to_light(s.position));
            if cos_l <= 0.0 || views.is_empty() {
                return f32::NAN;
            }
            let v = views[view_of(views, light, s.position)].light_view();
            let texel = v.texel_at(light, s.position);
            let cos_e = s
                .face
                .dot((cam.position - s.position).normalize_or_zero())
                .abs()
                .max(1e-3);
            let px = pixel * math::dot4(plane, s.position.extend(1.0)).max(1e-6);
            texel * cos_e / (px * cos_l.max(1e-3))
        })
        .collect()
}

/// The homogeneous light position: `(p, 1)` for lights at a point, `(-direction, 0)` for
/// directional ones (shadow volumes extrude from it, planar shadows project through it).
pub fn homogeneous_position(light: &Light) -> Vec4 {
    match light.kind {
        LightKind::Directional => (-light.direction).extend(0.0),
        _ => light.position.extend(1.0),
    }
}

/// The whole scene seen from the light (256 x 256, grey depth) with a fitted frustum's
/// footprint drawn over it in red: RTR fig. 7.11, for `dump`.
pub fn fitted_overview(p: &Pipeline, frame: &Frame, fitted: &LightView) -> Result<Surface<Rgba8>, Error> {
    const N: u32 = 256;
    let all = light_views(frame, N)[0];
    let d = scene_depth(p, frame, all.matrix, N, N, |_| true)?;
    let mut img = d.map(|z| {
        let g = ((1.0 - z) * 220.0 + 20.0) as u8;
        [g, g, g, 255]
    });
    // The fitted frustum's x/y outline, taken to world at mid depth and into the overview.
    let inv = math::inverse(&fitted.matrix);
    let c = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(x, y)| {
        let w = inv.project_point3(Vec3::new(x, y, 0.5));
        let q = all.matrix.project_point3(w);
        Vec2::new((q.x * 0.5 + 0.5) * N as f32, (0.5 - q.y * 0.5) * N as f32)
    });
    for i in 0..4 {
        super::overview::draw_segment(&mut img, c[i], c[(i + 1) % 4], [230, 40, 40, 255]);
    }
    Ok(img)
}

/// A view's map depth to distance along its axis ([`LightView::depth_to_distance`]).
#[derive(Copy, Clone, Debug)]
pub struct DepthToDistance {
    perspective: bool,
    a: f32,
    b: f32,
}

impl DepthToDistance {
    /// The distance of map depth `z`: `b / (z + a)` for perspective views, `(z - a) / b` for
    /// orthographic ones.
    #[inline(always)]
    pub fn at(&self, z: f32) -> f32 {
        if self.perspective {
            self.b / (z + self.a)
        } else {
            (z - self.a) / self.b
        }
    }

    /// [`DepthToDistance::at`] of four depths (the same operations per lane).
    #[inline(always)]
    pub fn at4(&self, z: glam::Vec4) -> glam::Vec4 {
        use glam::Vec4;
        if self.perspective {
            Vec4::splat(self.b) / (z + Vec4::splat(self.a))
        } else {
            (z - Vec4::splat(self.a)) / Vec4::splat(self.b)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_unprojects_map_depth() {
        // A perspective view: points at known distances along the axis come back.
        let eye = Vec3::new(1.0, 4.0, -2.0);
        let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
        let m = Mat4::perspective_rh(1.2, 1.0, 0.05, 40.0) * Mat4::look_at_rh(eye, eye + dir, up_for(dir));
        let v = LightView {
            matrix: m,
            texel: 0.001,
            kind: ViewKind::Perspective,
        };
        for d in [0.1f32, 1.0, 7.5, 30.0] {
            let (_, z) = v.lookup(eye + dir * d).unwrap();
            assert!((v.distance(z) - d).abs() < 1e-3 * d, "{d}: {}", v.distance(z));
        }
        // Orthographic: differences of distances are world distances.
        let o = LightView {
            matrix: Mat4::orthographic_rh(-5.0, 5.0, -5.0, 5.0, 1.0, 30.0)
                * Mat4::look_at_rh(eye, eye + dir, up_for(dir)),
            texel: 0.01,
            kind: ViewKind::Ortho,
        };
        let (_, z1) = o.lookup(eye + dir * 3.0).unwrap();
        let (_, z2) = o.lookup(eye + dir * 8.0 + Vec3::X * 0.0).unwrap();
        assert!((o.distance(z2) - o.distance(z1) - 5.0).abs() < 1e-4);
    }
}
