//! Depth-bias terms shared by the shadow-map family's lookups (the constant and slope-scaled
//! terms are the pipeline's polygon offset, applied in the light pass).
//!
//! - normal offset (Holbert 2011): the lookup point moves along the surface normal by
//!   `k * texel size * sin(angle to the light)`;
//! - receiver-plane depth bias (Isidoro 2006): the receiver's depth slope in shadow-map
//!   texels, from its screen-space neighbours.

use super::super::light::{project, LightView};
use crate::reference::SamplePoint;
use crate::scene::Light;
use glam::{Mat4, Vec2, Vec3};

/// The normal-offset lookup point (Holbert 2011): `s` moved along `normal` by `k` texels of
/// `view` at `s`, times the sine of the angle between the normal and the light direction.
pub fn normal_offset(view: &LightView, light: &Light, s: &SamplePoint, k: f32) -> Vec3 {
    if k <= 0.0 {
        return s.position;
    }
    let l = light.to_light(s.position);
    let sin = (1.0 - s.normal.dot(l).clamp(-1.0, 1.0).powi(2)).sqrt();
    s.position + s.normal * (k * view.texel_at(light, s.position) * sin)
}

/// The receiver plane at pixel `(x, y)` (Isidoro 2006), from one solve of its light-space
/// depth slopes for a map of side `size`:
/// - the gradient: dz/du and dz/dv per shadow-map texel, from the light-space (u, v, z) of
///   this pixel and its right and lower neighbours (same surface), `None` where the
///   neighbours are missing, the Jacobian is singular or the result is not finite;
/// - the bias: the depth change across one texel, `(|dz/du| + |dz/dv|) / size`, at most
///   0.05, zero without a gradient.
#[allow(clippy::too_many_arguments)]
pub fn receiver_plane(
    pts: &[Option<SamplePoint>],
    objs: &[u32],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    m: &Mat4,
    size: u32,
) -> (Option<Vec2>, f32) {
    let Some(d) = plane_slopes(pts, objs, w, h, x, y, m) else {
        return (None, 0.0);
    };
    let g = d / size as f32;
    let b = (d.x.abs() + d.y.abs()) / size as f32;
    (
        g.is_finite().then_some(g),
        if b.is_finite() { b.min(0.05) } else { 0.0 },
    )
}

/// dz/du and dz/dv of the receiver's plane in light texture space (see [`receiver_plane`]).
fn plane_slopes(
    pts: &[Option<SamplePoint>],
    objs: &[u32],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    m: &Mat4,
) -> Option<Vec2> {
    let own = objs[y * w + x];
    let at = |xx: usize, yy: usize| {
        if objs[yy * w + xx] == own {
            pts[yy * w + xx].and_then(|s| project(m, s.position))
        } else {
            None
        }
    };
    let (uv0, z0) = at(x, y)?;
    let nx = if x + 1 < w {
        at(x + 1, y)
    } else if x > 0 {
        at(x - 1, y)
    } else {
        None
    };
    let ny = if y + 1 < h {
        at(x, y + 1)
    } else if y > 0 {
        at(x, y - 1)
    } else {
        None
    };
    let ((uvx, zx), (uvy, zy)) = (nx?, ny?);
    let (du1, dz1) = (uvx - uv0, zx - z0);
    let (du2, dz2) = (uvy - uv0, zy - z0);
    let det = du1.x * du2.y - du2.x * du1.y;
    if det.abs() < 1e-20 {
        return None;
    }
    let dzdu = (dz1 * du2.y - dz2 * du1.y) / det;
    let dzdv = (du1.x * dz2 - du2.x * dz1) / det;
    Some(Vec2::new(dzdu, dzdv))
}
