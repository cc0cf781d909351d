//! Pass 4's test: a texel's samples against one occluding triangle, exactly (the segment to
//! the light against the triangle, Möller-Trumbore), four samples at a time.

use super::*;

/// A triangle as the occluder test needs it (Möller–Trumbore), with its plane for an early
/// out.
#[derive(Copy, Clone, Debug)]
pub(super) struct Occluder {
    pub(super) v0: Vec3,
    pub(super) e1: Vec3,
    pub(super) e2: Vec3,
    /// `e1 x e2` and its squared length.
    pub(super) n: Vec3,
    pub(super) n2: f32,
    /// `n . (light - v0)` (directional: `n . direction to the light`): the light's side.
    pub(super) light_side: f32,
    pub(super) id: u32,
    /// Directional lights: the Möller–Trumbore terms that depend on the direction alone
    /// ([`segment_terms`] of the direction to the light), made once per triangle instead of
    /// per sample.
    pub(super) pv: Vec3,
    pub(super) inv: f32,
}

impl Occluder {
    pub(super) fn new(a: Vec3, b: Vec3, c: Vec3, light: &Light, id: u32) -> Occluder {
        let (e1, e2) = (b - a, c - a);
        let n = e1.cross(e2);
        let light_side = match light.kind {
            LightKind::Directional => n.dot(-light.direction),
            _ => n.dot(light.position - a),
        };
        let (pv, inv) = match light.kind {
            LightKind::Directional => segment_terms(e1, e2, -light.direction),
            _ => (Vec3::ZERO, f32::NAN),
        };
        Occluder {
            v0: a,
            e1,
            e2,
            n,
            n2: n.length_squared(),
            light_side,
            id,
            pv,
            inv,
        }
    }

    /// True when `p` lies clearly on the light's side of the triangle's plane (by more than
    /// 1e-4 of its distance to the triangle's first vertex, so rounding cannot decide): then
    /// the segment to the light cannot cross the triangle, and the exact test is skipped.
    #[cfg(all(test, feature = "files"))]
    pub(super) fn same_side_as_light(&self, p: Vec3) -> bool {
        let tv = p - self.v0;
        let a = self.n.dot(tv);
        a * self.light_side > 0.0 && a * a > 1e-8 * self.n2 * tv.length_squared()
    }

    /// Whether the segment from `p` to the light (`to_light` = light position - p, `t` in
    /// (0, 1); directional: the direction to the light, `t` > 0) hits the triangle.
    #[cfg(all(test, feature = "files"))]
    pub(super) fn blocks(&self, p: Vec3, to_light: Vec3, directional: bool) -> bool {
        // A directional light's terms depend on its direction alone: made once per triangle.
        let (pv, inv) = if directional {
            (self.pv, self.inv)
        } else {
            segment_terms(self.e1, self.e2, to_light)
        };
        if inv.is_nan() {
            return false;
        }
        let tv = p - self.v0;
        let u = tv.dot(pv) * inv;
        if !(0.0..=1.0).contains(&u) {
            return false;
        }
        let qv = tv.cross(self.e1);
        let v = to_light.dot(qv) * inv;
        if v < 0.0 || u + v > 1.0 {
            return false;
        }
        let t = self.e2.dot(qv) * inv;
        t > 0.0 && (directional || t < 1.0)
    }
}

/// The Möller–Trumbore terms (Möller and Trumbore 1997) of a triangle with edges `e1`,
/// `e2` and a segment along `to_light`: `pv = to_light x e2` and `1 / (e1 . pv)`, the latter
/// NaN where the segment is parallel to the triangle or the determinant is not finite (no
/// crossing).
#[inline(always)]
pub(super) fn segment_terms(e1: Vec3, e2: Vec3, to_light: Vec3) -> (Vec3, f32) {
    let pv = to_light.cross(e2);
    let det = e1.dot(pv);
    (
        pv,
        if det == 0.0 || !det.is_finite() {
            f32::NAN
        } else {
            1.0 / det
        },
    )
}

/// The light and view as the list test sees them.
#[derive(Copy, Clone, Debug)]
pub(super) struct ListLight {
    /// Whether the light is directional.
    pub directional: bool,
    /// A point or spot light's position.
    pub position: Vec3,
    /// A directional light's direction toward the light.
    pub direction: Vec3,
    /// The view's depth axis ([`axis_depth`]).
    pub axis: Vec4,
}

/// The occluder pass's test of one texel's samples against occluder `o` (the light at
/// `l.position`, or along `l.direction` for a directional one): a lit sample not on `o` is
/// shadowed when its segment to the light crosses `o` (the plane test first, then
/// Möller–Trumbore). Returns the largest [`axis_at`] (`l.axis`) of the samples still lit
/// after it (`-inf` for none) and the tests it ran.
///
/// Four samples at a time, without a branch per sample (which samples are shadowed already,
/// lie on `o` or pass the plane test is data the branch predictor cannot learn); each lane
/// computes exactly the one-sample operations of `Occluder::same_side_as_light` and
/// `Occluder::blocks`, in their order, so the results are theirs (a test checks it).
#[inline(always)]
pub(super) fn test_list(o: &Occluder, list: &mut [ListSample], l: ListLight) -> (f32, u32) {
    let ListLight {
        directional,
        position: lp,
        direction: dir,
        axis,
    } = l;
    let mut far = Vec4::NEG_INFINITY;
    let mut tests = 0;
    let shadow = SHADOWED | o.id;
    let side = 1e-8 * o.n2;
    for chunk in list.chunks_mut(4) {
        // Lanes past the list's end count as shadowed: they take no part.
        let mut st = [SHADOWED; 4];
        let (mut x, mut y, mut z) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
        for (l, s) in chunk.iter().enumerate() {
            (x[l], y[l], z[l], st[l]) = (s.position.x, s.position.y, s.position.z, s.state);
        }
        let lit = BVec4A::new(st[0] < SHADOWED, st[1] < SHADOWED, st[2] < SHADOWED, st[3] < SHADOWED);
        if !lit.any() {
            continue;
        }
        let testing = lit & BVec4A::new(st[0] != o.id, st[1] != o.id, st[2] != o.id, st[3] != o.id);
        tests += testing.bitmask().count_ones();
        let p = Vec3x4 {
            x: Vec4::from_array(x),
            y: Vec4::from_array(y),
            z: Vec4::from_array(z),
        };
        // `same_side_as_light`, lane by lane.
        let tv = p - Vec3x4::splat(o.v0);
        let a = tv.dot(o.n);
        let same = (a * o.light_side).cmpgt(Vec4::ZERO) & (a * a).cmpgt(side * tv.dot4(tv));
        let candidates = testing & !same;
        let mut hit = BVec4A::FALSE;
        if candidates.any() {
            // `blocks`, lane by lane.
            let (to, pv, inv) = if directional {
                (Vec3x4::splat(dir), Vec3x4::splat(o.pv), Vec4::splat(o.inv))
            } else {
                // `segment_terms`, lane by lane.
                let to = Vec3x4::splat(lp) - p;
                let pv = to.cross(o.e2);
                let det = pv.dot(o.e1);
                let bad = det.cmpeq(Vec4::ZERO) | !det.is_finite_mask();
                (to, pv, Vec4::select(bad, Vec4::NAN, Vec4::ONE / det))
            };
            let u = tv.dot4(pv) * inv;
            let inside_u = u.cmpge(Vec4::ZERO) & u.cmple(Vec4::ONE);
            let qv = tv.cross(o.e1);
            let v = to.dot4(qv) * inv;
            let inside_v = !v.cmplt(Vec4::ZERO) & !(u + v).cmpgt(Vec4::ONE);
            let t = qv.dot(o.e2) * inv;
            let ahead = t.cmpgt(Vec4::ZERO) & if directional { BVec4A::TRUE } else { t.cmplt(Vec4::ONE) };
            hit = candidates & !inv.is_nan_mask() & inside_u & inside_v & ahead;
            let bits = hit.bitmask();
            if bits != 0 {
                for (l, s) in chunk.iter_mut().enumerate() {
                    if bits & (1 << l) != 0 {
                        s.state = shadow;
                    }
                }
            }
        }
        let d = p.dot(axis.truncate()) + axis.w;
        far = Vec4::select(lit & !hit, far.max(d), far);
    }
    (far.max_element(), tests)
}

/// A point's depth along a view's axis, `axis` from [`axis_depth`]:
/// `(axis.x p.x + axis.y p.y) + axis.z p.z + axis.w`.
#[inline(always)]
pub(super) fn axis_at(axis: Vec4, p: Vec3) -> f32 {
    p.dot(axis.truncate()) + axis.w
}

/// The row of `view`'s matrix whose dot product with `(p, 1)` is p's depth along the view's
/// axis, growing away from the light: clip `w` (the distance along the axis) for a
/// perspective view, clip `z` for an orthographic one. Linear in p, so a triangle's nearest
/// point along the axis is one of its vertices.
pub(super) fn axis_depth(view: &LightView) -> Vec4 {
    view.matrix.row(if view.perspective() { 3 } else { 2 })
}
