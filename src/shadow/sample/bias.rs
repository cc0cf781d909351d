//! Depth-bias terms shared by the shadow-map family's lookups (the constant and slope-scaled
//! terms are the pipeline's polygon offset, applied in the light pass).
//!
//! - normal offset (Holbert 2011): the lookup point moves along the surface normal by
//!   `k * texel size * sin(angle to the light)`;
//! - receiver-plane depth bias (Isidoro 2006): the receiver's depth slope in shadow-map
//!   texels, from its screen-space neighbours.

use crate::frame::Frame;
use crate::reference::SamplePoint;
use crate::scene::Light;
use crate::shadow::light::LightView;
use glam::{Vec2, Vec3, Vec4};

/// The normal-offset lookup point (Holbert 2011): `s` moved along `normal` by `k` texels of
/// `view` at `s`, times the sine of the angle between the normal and the light direction.
#[inline(always)]
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
pub fn receiver_plane(frame: &Frame, x: usize, y: usize, view: &LightView, size: u32) -> (Option<Vec2>, f32) {
    let Some(d) = plane_slopes(frame, x, y, view) else {
        return (None, 0.0);
    };
    plane_terms(d / size as f32, (d.x.abs() + d.y.abs()) / size as f32)
}

/// The receiver plane's gradient `g` and bias `b` as lookups use them: no gradient unless
/// finite, a bias of at most 0.05 (0 unless finite).
#[inline(always)]
fn plane_terms(g: Vec2, b: f32) -> (Option<Vec2>, f32) {
    (
        g.is_finite().then_some(g),
        if b.is_finite() { b.min(0.05) } else { 0.0 },
    )
}

/// The G-buffer's points and object ids, and its width and height.
#[inline(always)]
fn gbuffer<'f>(f: &'f Frame) -> (&'f [Option<SamplePoint>], &'f [u32], usize, usize) {
    (
        f.points(),
        f.gbuffer.object.data(),
        f.width() as usize,
        f.height() as usize,
    )
}

/// dz/du and dz/dv of the receiver's plane in light texture space (see [`receiver_plane`]).
fn plane_slopes(frame: &Frame, x: usize, y: usize, view: &LightView) -> Option<Vec2> {
    let (pts, objs, w, h) = gbuffer(frame);
    let own = objs[y * w + x];
    let at = |xx: usize, yy: usize| {
        if objs[yy * w + xx] == own {
            pts[yy * w + xx].and_then(|s| view.lookup(s.position))
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

/// [`receiver_plane`] of pixels `x .. x + n` of row `y` (`n` at most 4), all seen through
/// `view`, lane `l` for pixel `x + l` (lanes past `n`: `(None, 0.0)`). Where a pixel and its right
/// and lower neighbours are on one object, inside the image and in front of the light, the
/// three projections and the slope solve run on four lanes with the one-pixel operations in
/// the same order (glam's `Mat4 * Vec4`: `((x_axis x + y_axis y) + z_axis z) + w_axis`), so
/// the values are [`receiver_plane`]'s bit for bit; other lanes take [`receiver_plane`].
pub fn receiver_plane4(
    frame: &Frame,
    (x, y): (usize, usize),
    n: usize,
    view: &LightView,
    size: u32,
) -> [(Option<Vec2>, f32); 4] {
    let (pts, objs, w, h) = gbuffer(frame);
    let m = &view.matrix;
    let mut out = [(None, 0.0); 4];
    // Per lane: the pixel and its neighbours' positions, when all three are usable.
    let mut general = [false; 4];
    let mut p = [[Vec3::ZERO; 4]; 3];
    // (LogPSM's logarithmic `v` takes the one-pixel path.)
    if y + 1 < h && view.log().is_none() {
        for l in 0..n.min(4) {
            let i = y * w + x + l;
            if x + l + 1 >= w || objs[i + 1] != objs[i] || objs[i + w] != objs[i] {
                continue;
            }
            if let (Some(a), Some(b), Some(c)) = (pts[i], pts[i + 1], pts[i + w]) {
                general[l] = true;
                (p[0][l], p[1][l], p[2][l]) = (a.position, b.position, c.position);
            }
        }
    }
    if general.iter().any(|&g| g) {
        // Clip position of four points, lane by lane as `Mat4 * Vec4` (the `w_axis` term is
        // times 1, exactly itself), then the projection's divide.
        let project = |q: &[Vec3; 4]| {
            let (qx, qy, qz) = (
                Vec4::from_array(q.map(|v| v.x)),
                Vec4::from_array(q.map(|v| v.y)),
                Vec4::from_array(q.map(|v| v.z)),
            );
            let row = |k: usize| {
                let (a, b, c, d) = (m.x_axis[k], m.y_axis[k], m.z_axis[k], m.w_axis[k]);
                ((Vec4::splat(a) * qx + Vec4::splat(b) * qy) + Vec4::splat(c) * qz) + Vec4::splat(d)
            };
            let cw = row(3);
            let (nx, ny, nz) = (row(0) / cw, row(1) / cw, row(2) / cw);
            let half = Vec4::splat(0.5);
            (nx * half + half, half - ny * half, nz, cw.cmpgt(Vec4::ZERO))
        };
        let (u0, v0, z0, f0) = project(&p[0]);
        let (ux, vx, zx, fx) = project(&p[1]);
        let (uy, vy, zy, fy) = project(&p[2]);
        let front = f0 & fx & fy;
        // `plane_slopes` and `receiver_plane` on four lanes.
        let (du1x, du1y, dz1) = (ux - u0, vx - v0, zx - z0);
        let (du2x, du2y, dz2) = (uy - u0, vy - v0, zy - z0);
        let det = du1x * du2y - du2x * du1y;
        let solved = det.abs().cmpge(Vec4::splat(1e-20));
        let dzdu = (dz1 * du2y - dz2 * du1y) / det;
        let dzdv = (du1x * dz2 - du2x * dz1) / det;
        let s = Vec4::splat(size as f32);
        let (gx, gy) = (dzdu / s, dzdv / s);
        let b = (dzdu.abs() + dzdv.abs()) / s;
        for l in 0..4 {
            if !general[l] || !front.test(l) {
                general[l] = false;
                continue;
            }
            if !solved.test(l) {
                continue; // (None, 0.0)
            }
            out[l] = plane_terms(Vec2::new(gx[l], gy[l]), b[l]);
        }
    }
    for (l, o) in out.iter_mut().enumerate().take(n.min(4)) {
        if !general[l] {
            *o = receiver_plane(frame, x + l, y, view, size);
        }
    }
    out
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;
    use crate::pipeline::Pipeline;
    use crate::shadow::light::light_views;

    /// The four-lane receiver plane is the one-pixel one, bit for bit, for every group of four
    /// pixels (short groups at the rows' ends, the last row, object edges, pixels without
    /// geometry) and every light view of every kind of light.
    #[test]
    fn four_lane_receiver_planes_equal_one_pixel_ones() {
        let p = Pipeline::new(2).unwrap();
        let bits = |(g, b): (Option<Vec2>, f32)| (g.map(|g| [g.x.to_bits(), g.y.to_bits()]), b.to_bits());
        for light in crate::shadow::sample::testing::LIGHTS {
            let scene = crate::shadow::sample::testing::scene(light);
            let f = crate::frame::frame(&p, &scene, 0, 0).unwrap();
            let (w, h) = (f.width() as usize, f.height() as usize);
            let mut general = 0;
            for (view, size) in light_views(&f, 512).iter().zip([512, 300, 2048, 64, 512, 1000]) {
                for y in 0..h {
                    for x in (0..w).step_by(4) {
                        let n = (w - x).min(4);
                        let four = receiver_plane4(&f, (x, y), n, view, size);
                        for (l, got) in four.into_iter().enumerate().take(n) {
                            let one = receiver_plane(&f, x + l, y, view, size);
                            assert_eq!(bits(got), bits(one), "{light} ({}, {y}) size {size}", x + l);
                            general += one.0.is_some() as usize;
                        }
                    }
                }
            }
            assert!(general > w * h / 4, "{light}: only {general} pixels have a plane");
        }
    }
}
