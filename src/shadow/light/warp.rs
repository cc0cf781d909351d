//! Perspective warping of a directional light's map (RTR 7.4.1, fig. 7.15): a perspective
//! transform in light space that spends more texels near the eye, shared by LiSPSM (Wimmer
//! et al. 2004) and TSM (Martin and Tan 2004).
//!
//! Light space: `y` points to the light, `z` along the view direction projected onto the
//! plane perpendicular to the light (the warp axis), `x = light direction × z`. A
//! perspective frustum looks down `z` from a centre of projection `P` at distance `n` before
//! the body it covers (the camera's view range, clipped to the scene); after its divide the
//! light's rays (constant `x`, `z`) stay parallel, so an orthographic map of that space along
//! `y` is a shadow map whose texels shrink towards `P`, i.e. towards the eye. The map's `u`
//! is the post-perspective `x`, its `v` the post-perspective `z`, its depth the
//! post-perspective `y` (Wimmer et al. 2004, section 4). Along one light ray the divide is
//! the same, so depth comparisons within a texel are exact; across texels the depth scale
//! changes, so no technique that unprojects depths takes a warp.
//!
//! The two warps differ only in `P` and `n`:
//! - LiSPSM: `P` under the eye, `n_opt = (z_n + sqrt(z_n z_f)) / sin(gamma)` (Wimmer et al.
//!   2004, section 5: the `n` that spreads the error evenly over the view range `z_n .. z_f`;
//!   `gamma` the angle between the view and light directions, so the warp fades as the view
//!   turns towards the light), times an option `n_scale`.
//! - TSM: `P` on the centre line through the near plane's centre; `n` the trapezoid's `eta`
//!   that maps the focus point (`focus` of the view range past the near plane) to the 80 %
//!   line `xi = -0.6` of the map (Martin and Tan 2004, section 4):
//!   `eta = (lambda delta' + lambda delta' xi) / (lambda - 2 delta' - lambda xi)`, with
//!   `lambda` the trapezoid's height and `delta'` the focus point's distance from its top.
//!
//! Falls back to the orthographic map of the same body ([`WarpInfo::fallback`] says why)
//! where the parameterization degenerates: the light along the view direction (no warp
//! axis), a focus region already past the 80 % line, or a camera frustum that misses the
//! scene (the map then covers the scene).

use super::cascades::{convex_hull, depth_plane, slice_corners, view_range};
use super::{corners, up_for, Fit, LightView};
use crate::choice_enum;
use crate::frame::Frame;
use crate::shadow::Field;
use glam::{Mat4, Vec2, Vec3, Vec4};

choice_enum! {
    /// Which warp sets the centre of projection and `n`.
    pub enum WarpKind {
        /// Light space perspective shadow maps (Wimmer et al. 2004), `n_opt`.
        Lispsm = "lispsm",
        /// Trapezoidal shadow maps (Martin and Tan 2004), the 80 % rule.
        Tsm = "tsm",
    }
}

/// TSM's 80 % line: the focus point's post-perspective coordinate (Martin and Tan 2004).
pub const TSM_XI: f32 = -0.6;

/// Below this sine of the angle between view and light directions the warp axis is
/// undefined and the map falls back to the orthographic one (about 0.57 degrees).
pub const MIN_SIN_GAMMA: f32 = 0.01;

/// Settings of a warp.
#[derive(Clone, Debug, PartialEq)]
pub struct Warp {
    /// The warp. Default: LiSPSM.
    pub kind: WarpKind,
    /// LiSPSM: factor on `n_opt` (1: the paper's; larger: a weaker warp, towards the
    /// orthographic map; smaller: more texels near the eye, fewer far away). Default: 1.
    pub n_scale: f32,
    /// TSM: the focus point's distance past the near plane, as a fraction of the view range;
    /// the region up to it takes 80 % of the map. Default: 0.5.
    pub focus: f32,
}

impl Default for Warp {
    fn default() -> Self {
        Warp {
            kind: WarpKind::Lispsm,
            n_scale: 1.0,
            focus: 0.5,
        }
    }
}

impl Warp {
    /// LiSPSM's field (`n_scale`).
    pub fn lispsm_fields() -> Vec<Field<Warp>> {
        vec![Field::range(
            "n_scale",
            "factor on LiSPSM's n_opt (1: the paper's; larger: weaker warp, towards the uniform map)",
            0.01,
            100.0,
            |w: &mut Warp| &mut w.n_scale,
        )]
    }

    /// TSM's field (`focus`).
    pub fn tsm_fields() -> Vec<Field<Warp>> {
        vec![Field::range(
            "focus",
            "TSM: focus distance past the near plane, as a fraction of the view range; it takes 80 % of the map",
            0.01,
            0.99,
            |w: &mut Warp| &mut w.focus,
        )]
    }
}

/// What the last warp fitted: its parameters, for `counters`, `inspect` and `notes`.
#[derive(Clone, Debug, PartialEq)]
pub struct WarpInfo {
    /// The warp asked for.
    pub kind: WarpKind,
    /// Angle between the view and light directions, in degrees.
    pub gamma_deg: f32,
    /// Distance from the centre of projection to the body's near side (infinite: no warp).
    pub n: f32,
    /// The body's extent along the warp axis (the frustum's depth).
    pub depth: f32,
    /// Why the map fell back to the orthographic one, if it did.
    pub fallback: Option<String>,
}

/// The light space of a warp: unit axes `x`, `y` (to the light) and `z` (the warp axis).
#[derive(Copy, Clone, Debug)]
struct Basis {
    x: Vec3,
    y: Vec3,
    z: Vec3,
}

impl Basis {
    fn of(&self, p: Vec3) -> Vec3 {
        Vec3::new(self.x.dot(p), self.y.dot(p), self.z.dot(p))
    }
}

/// A warped view of `frame`'s directional light at `size` texels ([`Warp`]; see the module
/// docs), with the casters that can shadow the body.
pub fn warp_fit(frame: &Frame, size: u32, w: &Warp) -> (Fit, WarpInfo) {
    let light = &frame.light;
    let d = light.direction.normalize_or_zero();
    let forward = depth_plane(frame).truncate().normalize_or_zero();
    let cos_g = forward.dot(d).clamp(-1.0, 1.0);
    let sin_g = (1.0 - cos_g * cos_g).max(0.0).sqrt();
    let gamma_deg = crate::math::acos(cos_g).to_degrees();
    let mut fallback = None;
    let axis = forward - d * cos_g;
    let z = if sin_g >= MIN_SIN_GAMMA {
        axis.normalize()
    } else {
        fallback = Some(format!(
            "the light is {:.2} degrees off the view direction's line: no warp axis, so the orthographic map of the view",
            gamma_deg.min(180.0 - gamma_deg)
        ));
        let u = up_for(d);
        (u - d * u.dot(d)).normalize()
    };
    let basis = Basis {
        x: d.cross(z),
        y: -d,
        z,
    };
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let scene: Vec<Vec3> = corners(lo, hi).iter().map(|c| basis.of(*c)).collect();
    let (slo, shi) = scene
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), q| {
            (a.min(*q), b.max(*q))
        });
    let (near, far) = view_range(frame);
    let frustum = slice_corners(frame, near, far).map(|c| basis.of(c));
    // The body seen from the light: the frustum's outline clipped to the scene's.
    let outline = convex_hull(&frustum.map(|q| Vec2::new(q.x, q.z)));
    let mut body = clip_to_rect(&outline, Vec2::new(slo.x, slo.z), Vec2::new(shi.x, shi.z));
    let mut y0 = frustum.iter().map(|q| q.y).fold(f32::MAX, f32::min).max(slo.y);
    if body.len() < 3 {
        fallback = Some("the camera frustum misses the scene: the map covers the scene".into());
        body = vec![
            Vec2::new(slo.x, slo.z),
            Vec2::new(shi.x, slo.z),
            Vec2::new(shi.x, shi.z),
            Vec2::new(slo.x, shi.z),
        ];
        y0 = slo.y;
    }
    let (blo, bhi) = body
        .iter()
        .fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(a, b), q| {
            (a.min(*q), b.max(*q))
        });
    let diameter = (hi - lo).length().max(1e-3);
    let margin = diameter * 1e-3;
    let (z0, z1) = (blo.y - margin, bhi.y + margin);
    let lambda = z1 - z0;
    // Casters up to the scene's top; receivers down to the body's bottom.
    let (y0, y1) = (y0.min(shi.y) - margin, shi.y + margin);
    let eye = basis.of(frame.camera.position);
    let (n, px) = if fallback.is_some() {
        (f32::INFINITY, eye.x)
    } else {
        match w.kind {
            WarpKind::Lispsm => ((near + (near * far).sqrt()) / sin_g * w.n_scale, eye.x),
            WarpKind::Tsm => {
                let top = basis.of(frame.camera.position + forward * near);
                let focus = basis.of(frame.camera.position + forward * (near + w.focus * (far - near)));
                let dp = (focus.z - z0).clamp(lambda * 1e-4, lambda);
                let den = lambda - 2.0 * dp - lambda * TSM_XI;
                if den <= lambda * 1e-4 {
                    fallback = Some(format!(
                        "the focus point lies {:.0} % of the way down the trapezoid, past the 80 % line: no warp",
                        100.0 * dp / lambda
                    ));
                    (f32::INFINITY, top.x)
                } else {
                    ((lambda * dp + lambda * dp * TSM_XI) / den, top.x)
                }
            }
        }
    };
    let n = if n.is_finite() && n < lambda * 1e5 {
        n
    } else {
        f32::INFINITY
    };
    let matrix = if n.is_finite() {
        perspective_matrix(&basis, &body, Vec3::new(px, 0.0, z0 - n), n, lambda, (y0, y1), margin)
    } else {
        orthographic_matrix(&basis, (blo.x - margin, bhi.x + margin), (z0, z1), (y0, y1))
    };
    // Casters: objects whose light-space box meets the body's rectangle and reaches above its
    // bottom (shadows fall along y).
    let keep: Vec<bool> = frame
        .scene
        .objects
        .iter()
        .map(|o| {
            o.mesh.bounds().is_some_and(|(a, b)| {
                let (ca, cb) = corners(a, b)
                    .iter()
                    .map(|c| basis.of(*c))
                    .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(p, q), c| {
                        (p.min(c), q.max(c))
                    });
                ca.x <= bhi.x + margin && cb.x >= blo.x - margin && ca.z <= z1 && cb.z >= z0 && cb.y >= y0
            })
        })
        .collect();
    let view = LightView {
        matrix,
        texel: 1.0 / size as f32,
        perspective: false,
        warped: true,
        slice: None,
    };
    let fit = Fit {
        views: vec![view],
        culled: keep.iter().filter(|k| !**k).count(),
        casters: keep,
        fitted: Some(view),
        per_view: Vec::new(),
    };
    let info = WarpInfo {
        kind: w.kind,
        gamma_deg,
        n,
        depth: lambda,
        fallback,
    };
    (fit, info)
}

/// World to light space relative to `origin` (rows: the basis' axes).
fn light_space(b: &Basis, origin: Vec3) -> Mat4 {
    Mat4::from_cols(
        Vec4::new(b.x.x, b.y.x, b.z.x, 0.0),
        Vec4::new(b.x.y, b.y.y, b.z.y, 0.0),
        Vec4::new(b.x.z, b.y.z, b.z.z, 0.0),
        Vec4::new(-origin.x, -origin.y, -origin.z, 1.0),
    )
}

/// The orthographic map of the body: `u` along `x`, `v` along `z`, depth down from the light.
fn orthographic_matrix(b: &Basis, (x0, x1): (f32, f32), (z0, z1): (f32, f32), (y0, y1): (f32, f32)) -> Mat4 {
    let sx = 2.0 / (x1 - x0);
    let sz = 2.0 / (z1 - z0);
    let sy = 1.0 / (y1 - y0);
    // Rows of the map on light-space coordinates (x, y, z, 1).
    let a = Mat4::from_cols(
        Vec4::new(sx, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, -sy, 0.0),
        Vec4::new(0.0, sz, 0.0, 0.0),
        Vec4::new(-(x0 + x1) / (x1 - x0), -(z0 + z1) / (z1 - z0), y1 * sy, 1.0),
    );
    a * light_space(b, Vec3::ZERO)
}

/// The warped map: the perspective from `p` (light-space coordinates) down `z` over the
/// body's near `n` to `n + lambda`, then the orthographic map of its post-perspective box
/// (`u`: `x / z`, `v`: the perspective depth, depth: `y / z`, Wimmer et al. 2004 fig. 4).
fn perspective_matrix(
    b: &Basis,
    body: &[Vec2],
    p: Vec3,
    n: f32,
    lambda: f32,
    (y0, y1): (f32, f32),
    margin: f32,
) -> Mat4 {
    let f = n + lambda;
    // Post-perspective x over the body (the x / z extremes lie at the outline's vertices).
    let (mut xa, mut xb) = body.iter().fold((f32::MAX, f32::MIN), |(a, c), q| {
        let x = (q.x - p.x) / (q.y - p.z);
        (a.min(x), c.max(x))
    });
    let pad = (xb - xa).max(margin / f) * 1e-3;
    (xa, xb) = (xa - pad, xb + pad);
    // Post-perspective y over the depth range's corners (y / z is monotone in each).
    let (mut ya, mut yb) = [(y0, n), (y0, f), (y1, n), (y1, f)]
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, c), (y, z)| {
            let v = (y - p.y) / z;
            (a.min(v), c.max(v))
        });
    let pad = (yb - ya) * 1e-3;
    (ya, yb) = (ya - pad, yb + pad);
    // Homogeneous rows on light coordinates relative to p: clip x = x, clip y = y,
    // clip z = z (f + n) / (f - n) - 2 f n / (f - n) (z / w in [-1, 1] over [n, f]), w = z.
    let (zz, zw) = ((f + n) / (f - n), -2.0 * f * n / (f - n));
    let sx = 2.0 / (xb - xa);
    let tx = -(xa + xb) / (xb - xa);
    let sy = 1.0 / (yb - ya);
    // u = sx X + tx, v = Z, depth = (yb - Y) sy, each times w.
    let m = Mat4::from_cols(
        Vec4::new(sx, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, -sy, 0.0),
        Vec4::new(tx, zz, yb * sy, 1.0),
        Vec4::new(0.0, zw, 0.0, 0.0),
    );
    m * light_space(b, p)
}

/// The part of convex polygon `poly` inside the rectangle `lo .. hi` (Sutherland-Hodgman
/// against its four sides).
pub fn clip_to_rect(poly: &[Vec2], lo: Vec2, hi: Vec2) -> Vec<Vec2> {
    let mut out: Vec<Vec2> = poly.to_vec();
    // Each side as (axis, bound, keep-below).
    for (axis, bound, below) in [(0, lo.x, false), (0, hi.x, true), (1, lo.y, false), (1, hi.y, true)] {
        if out.is_empty() {
            break;
        }
        let inside = |q: Vec2| if below { q[axis] <= bound } else { q[axis] >= bound };
        let input = std::mem::take(&mut out);
        for i in 0..input.len() {
            let (a, c) = (input[i], input[(i + 1) % input.len()]);
            if inside(a) {
                out.push(a);
            }
            if inside(a) != inside(c) {
                let t = (bound - a[axis]) / (c[axis] - a[axis]);
                out.push(a + (c - a) * t);
            }
        }
    }
    out
}

/// World size of one texel of a warped view with matrix `m` at world point `p`, for a light
/// along `dir` and texels of `uv_texel` in texture coordinates: the texel's area on the plane
/// perpendicular to the light is `uv_texel² / |det J|`, `J` the Jacobian of the texture
/// coordinate there, and its side the square root (the geometric mean of the two axes).
pub fn texel_at(m: &Mat4, dir: Vec3, p: Vec3, uv_texel: f32) -> f32 {
    let c = *m * p.extend(1.0);
    let u = up_for(dir);
    let e1 = dir.cross(u).normalize_or_zero();
    let e2 = dir.normalize_or_zero().cross(e1);
    let derivative = |e: Vec3| {
        let dc = *m * e.extend(0.0);
        Vec2::new(dc.x * c.w - c.x * dc.w, dc.y * c.w - c.y * dc.w) * (0.5 / (c.w * c.w))
    };
    let (a, b) = (derivative(e1), derivative(e2));
    let det = (a.x * b.y - a.y * b.x).abs();
    let t = uv_texel / det.sqrt();
    if t.is_finite() && c.w > 0.0 {
        t
    } else {
        uv_texel
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_the_inside() {
        let square = [
            Vec2::new(-1.0, -1.0),
            Vec2::new(1.0, -1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(-1.0, 1.0),
        ];
        let c = clip_to_rect(&square, Vec2::new(0.0, -0.5), Vec2::new(2.0, 2.0));
        let area: f32 = (0..c.len())
            .map(|i| {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                a.x * b.y - a.y * b.x
            })
            .sum::<f32>()
            * 0.5;
        assert!((area.abs() - 1.5).abs() < 1e-5, "{area}");
        assert!(clip_to_rect(&square, Vec2::new(2.0, 2.0), Vec2::new(3.0, 3.0)).is_empty());
    }

    #[test]
    fn texel_at_is_the_side_of_a_texel_on_the_plane_across_the_light() {
        // A warped matrix: a world square of the returned side, across the light, covers
        // one texel's area of the map.
        // The light straight down, the warp axis along x: x = light × z = z.
        let dir = -Vec3::Y;
        let b = Basis {
            x: Vec3::Z,
            y: Vec3::Y,
            z: Vec3::X,
        };
        let body = [
            Vec2::new(-5.0, 1.0),
            Vec2::new(5.0, 1.0),
            Vec2::new(20.0, 30.0),
            Vec2::new(-20.0, 30.0),
        ];
        let m = perspective_matrix(&b, &body, Vec3::new(0.0, 0.0, -2.0), 3.0, 29.0, (-1.0, 10.0), 0.01);
        let size = 1024.0f32;
        for p in [
            Vec3::new(2.0, 0.5, 0.0),
            Vec3::new(25.0, 3.0, -10.0),
            Vec3::new(10.0, 0.0, 8.0),
        ] {
            let t = texel_at(&m, dir, p, 1.0 / size);
            let u = up_for(dir);
            let e1 = dir.cross(u).normalize();
            let e2 = dir.cross(e1);
            let uv = |q: Vec3| super::super::project(&m, q).unwrap().0;
            let (a, c) = ((uv(p + e1 * t) - uv(p)) * size, (uv(p + e2 * t) - uv(p)) * size);
            let area = (a.x * c.y - a.y * c.x).abs();
            assert!((area - 1.0).abs() < 0.02, "{p}: {area} texels");
        }
    }

    #[test]
    fn tsm_eta_puts_the_focus_on_the_80_percent_line() {
        // The projective map along the centre line, 1 at the top, -1 at the base.
        for (lambda, dp) in [(10.0f32, 2.0f32), (3.0, 0.5), (100.0, 70.0)] {
            let eta = (lambda * dp + lambda * dp * TSM_XI) / (lambda - 2.0 * dp - lambda * TSM_XI);
            let b = 2.0 * eta * (lambda + eta) / lambda;
            let a = -(lambda + 2.0 * eta) / lambda;
            let at = |t: f32| a + b / (t + eta);
            assert!((at(0.0) - 1.0).abs() < 1e-4);
            assert!((at(lambda) + 1.0).abs() < 1e-4);
            assert!((at(dp) - TSM_XI).abs() < 1e-4, "{}", at(dp));
        }
    }
}
