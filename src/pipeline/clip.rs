//! Stage 2, clip: homogeneous clipping (Sutherland-Hodgman in clip space).
//!
//! - near plane `z >= 0` always (clip depth range is [0, 1], D3D/Vulkan style);
//! - far plane `z <= w` unless depth clamp is on;
//! - x and y against a guard band of +-[`GUARD_PX`] pixels around the viewport centre, so
//!   ordinary triangles are never clipped in x/y while fixed-point edge functions stay far from
//!   overflow; the guard-band planes also imply `w > 0`, so triangles crossing `w = 0` are cut
//!   at the plane and render correctly;
//! - a tiny `w >= W_EPSILON` plane, so no vertex ever divides by zero.
//!
//! New vertices are always interpolated from the inside vertex towards the outside one, so a
//! clipped edge shared by two triangles produces bit-identical vertices in both (watertight).

use super::vertex::Varyings;
use glam::Vec4;

/// Guard band half-extent in pixels around the viewport centre.
pub const GUARD_PX: f32 = 32768.0;
/// Largest |component| of a clip-space vertex the pipeline accepts; triangles with a vertex
/// beyond it are dropped and counted (the clipper could not place their edges to a pixel).
pub const MAX_CLIP_COORD: f32 = 1e9;
/// Smallest `w` a vertex may have after clipping.
pub const W_EPSILON: f32 = 1e-12;

/// A vertex in clip space with its varyings.
#[derive(Copy, Clone, Debug)]
pub struct ClipVertex<V> {
    /// Clip-space position.
    pub pos: Vec4,
    /// Varyings.
    pub var: V,
}

const NEAR: u32 = 1;
const FAR: u32 = 2;
const LEFT: u32 = 4;
const RIGHT: u32 = 8;
const BOTTOM: u32 = 16;
const TOP: u32 = 32;
const WPOS: u32 = 64;
const PLANES: [u32; 7] = [WPOS, NEAR, FAR, LEFT, RIGHT, BOTTOM, TOP];

/// Clipping planes of one draw.
#[derive(Copy, Clone, Debug)]
pub struct Clipper {
    gx: f32,
    gy: f32,
    far: bool,
}

impl Clipper {
    /// Clipper for a `width` x `height` viewport; `clip_far` is false under depth clamp.
    pub fn new(width: u32, height: u32, clip_far: bool) -> Self {
        Clipper {
            gx: GUARD_PX / (width as f32 * 0.5),
            gy: GUARD_PX / (height as f32 * 0.5),
            far: clip_far,
        }
    }

    #[inline(always)]
    fn dist(&self, plane: u32, p: Vec4) -> f32 {
        let p = p.as_dvec4();
        let (gx, gy) = (self.gx as f64, self.gy as f64);
        (match plane {
            NEAR => p.z,
            FAR => p.w - p.z,
            LEFT => p.x + gx * p.w,
            RIGHT => gx * p.w - p.x,
            BOTTOM => p.y + gy * p.w,
            TOP => gy * p.w - p.y,
            _ => p.w - W_EPSILON as f64,
        }) as f32
    }

    /// Bit set of the planes `p` is outside of.
    #[inline(always)]
    pub fn outcode(&self, p: Vec4) -> u32 {
        let mut c = 0;
        if p.z < 0.0 {
            c |= NEAR;
        }
        if self.far && p.z > p.w {
            c |= FAR;
        }
        let gxw = self.gx * p.w;
        let gyw = self.gy * p.w;
        if p.x < -gxw {
            c |= LEFT;
        }
        if p.x > gxw {
            c |= RIGHT;
        }
        if p.y < -gyw {
            c |= BOTTOM;
        }
        if p.y > gyw {
            c |= TOP;
        }
        if p.w < W_EPSILON {
            c |= WPOS;
        }
        c
    }

    /// Clips a triangle against the planes in `mask` (the OR of its vertices' outcodes).
    /// The result polygon (0 or 3+ vertices, a convex fan in the input's winding) is left in `out`.
    pub fn clip_polygon<V: Varyings>(
        &self,
        tri: [ClipVertex<V>; 3],
        mask: u32,
        out: &mut Vec<ClipVertex<V>>,
        tmp: &mut Vec<ClipVertex<V>>,
    ) {
        out.clear();
        out.extend_from_slice(&tri);
        for plane in PLANES {
            if mask & plane == 0 {
                continue;
            }
            std::mem::swap(out, tmp);
            out.clear();
            let n = tmp.len();
            for i in 0..n {
                let a = tmp[i];
                let b = tmp[(i + 1) % n];
                let da = self.dist(plane, a.pos);
                let db = self.dist(plane, b.pos);
                let ina = da >= 0.0;
                let inb = db >= 0.0;
                if ina {
                    out.push(a);
                }
                if ina != inb {
                    // Interpolate from the inside vertex to the outside one (canonical direction).
                    let (p, q, dp, dq) = if ina { (a, b, da, db) } else { (b, a, db, da) };
                    let t = dp / (dp - dq);
                    out.push(ClipVertex {
                        pos: p.pos + (q.pos - p.pos) * t,
                        var: V::lerp(&p.var, &q.var, t),
                    });
                }
            }
            if out.len() < 3 {
                out.clear();
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32, w: f32) -> ClipVertex<()> {
        ClipVertex {
            pos: Vec4::new(x, y, z, w),
            var: (),
        }
    }

    #[test]
    fn near_plane_cuts_triangle_into_quad() {
        let c = Clipper::new(100, 100, true);
        let tri = [v(0.0, 0.0, -1.0, 1.0), v(1.0, 0.0, 0.5, 1.0), v(0.0, 1.0, 0.5, 1.0)];
        let mask = tri.iter().fold(0, |m, p| m | c.outcode(p.pos));
        let (mut o, mut t) = (Vec::new(), Vec::new());
        c.clip_polygon(tri, mask, &mut o, &mut t);
        assert_eq!(o.len(), 4);
        assert!(o.iter().all(|p| p.pos.z >= -1e-6));
    }

    #[test]
    fn crossing_w_zero_keeps_only_the_front_part() {
        let c = Clipper::new(100, 100, false);
        let tri = [v(0.0, 0.0, 0.5, 1.0), v(0.5, 0.0, 0.5, -1.0), v(0.0, 0.5, 0.5, 1.0)];
        let mask = tri.iter().fold(0, |m, p| m | c.outcode(p.pos));
        let (mut o, mut t) = (Vec::new(), Vec::new());
        c.clip_polygon(tri, mask, &mut o, &mut t);
        assert!(o.len() >= 3);
        assert!(o.iter().all(|p| p.pos.w > 0.0));
    }
}
