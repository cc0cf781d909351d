//! A bounding volume hierarchy over triangles: binned SAH build (Wald 2007), watertight
//! ray-triangle test (Woop, Benthin and Wald 2013, "Watertight Ray/Triangle Intersection"),
//! any-hit queries for shadow rays. Built sequentially (deterministic), queried in parallel.

use glam::Vec3;

/// One node: bounds, and either two children (`count == 0`, children at `first` and
/// `first + 1`) or a leaf of `count` triangles starting at `first`.
#[derive(Copy, Clone, Debug)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    first: u32,
    count: u32,
}

/// A triangle with its user tag (object index).
#[derive(Copy, Clone, Debug)]
pub struct Tri {
    /// Vertices.
    pub v: [Vec3; 3],
    /// Tag returned by hits (e.g. object index).
    pub tag: u32,
}

/// The hierarchy.
pub struct Bvh {
    nodes: Vec<Node>,
    tris: Vec<Tri>,
}

const BINS: usize = 12;
const LEAF_MAX: usize = 4;

impl Bvh {
    /// Builds over `tris` (degenerate and non-finite triangles are dropped).
    pub fn build(mut tris: Vec<Tri>) -> Bvh {
        tris.retain(|t| {
            t.v.iter().all(|p| p.is_finite()) && (t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]).length_squared() > 0.0
        });
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * tris.len() / LEAF_MAX + 1),
            tris,
        };
        let n = bvh.tris.len();
        bvh.nodes.push(Node {
            lo: Vec3::ZERO,
            hi: Vec3::ZERO,
            first: 0,
            count: n as u32,
        });
        if n > 0 {
            bvh.subdivide(0);
        }
        bvh
    }

    /// Triangles held.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    fn subdivide(&mut self, root: usize) {
        let mut stack = vec![root];
        while let Some(ni) = stack.pop() {
            let (first, count) = (self.nodes[ni].first as usize, self.nodes[ni].count as usize);
            let tris = &self.tris[first..first + count];
            let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            let (mut clo, mut chi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for t in tris {
                for p in t.v {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                let c = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
                clo = clo.min(c);
                chi = chi.max(c);
            }
            self.nodes[ni].lo = lo;
            self.nodes[ni].hi = hi;
            if count <= LEAF_MAX {
                continue;
            }
            // Binned SAH over the centroid bounds, all three axes.
            let mut best = (f32::MAX, 0usize, 0usize);
            for axis in 0..3 {
                let (a0, a1) = (clo[axis], chi[axis]);
                if a1 - a0 <= 0.0 {
                    continue;
                }
                let mut bins = [(Vec3::splat(f32::MAX), Vec3::splat(f32::MIN), 0u32); BINS];
                let scale = BINS as f32 / (a1 - a0);
                for t in tris {
                    let c = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
                    let b = (((c[axis] - a0) * scale) as usize).min(BINS - 1);
                    for p in t.v {
                        bins[b].0 = bins[b].0.min(p);
                        bins[b].1 = bins[b].1.max(p);
                    }
                    bins[b].2 += 1;
                }
                let area = |lo: Vec3, hi: Vec3| {
                    let d = (hi - lo).max(Vec3::ZERO);
                    d.x * d.y + d.y * d.z + d.z * d.x
                };
                let mut left = [(0.0f32, 0u32); BINS];
                let (mut l, mut h, mut n) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN), 0);
                for i in 0..BINS {
                    l = l.min(bins[i].0);
                    h = h.max(bins[i].1);
                    n += bins[i].2;
                    left[i] = (if n > 0 { area(l, h) } else { 0.0 }, n);
                }
                let (mut l, mut h, mut n) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN), 0);
                for i in (1..BINS).rev() {
                    l = l.min(bins[i].0);
                    h = h.max(bins[i].1);
                    n += bins[i].2;
                    let (la, ln) = left[i - 1];
                    if ln == 0 || n == 0 {
                        continue;
                    }
                    let cost = la * ln as f32 + area(l, h) * n as f32;
                    if cost < best.0 {
                        best = (cost, axis, i);
                    }
                }
            }
            let parent_cost = {
                let d = hi - lo;
                (d.x * d.y + d.y * d.z + d.z * d.x) * count as f32
            };
            let (cost, axis, split) = best;
            let mid = if cost < parent_cost && cost < f32::MAX {
                let (a0, a1) = (clo[axis], chi[axis]);
                let scale = BINS as f32 / (a1 - a0);
                let slice = &mut self.tris[first..first + count];
                let mut i = 0;
                for j in 0..slice.len() {
                    let c = (slice[j].v[0] + slice[j].v[1] + slice[j].v[2]) / 3.0;
                    if ((((c[axis] - a0) * scale) as usize).min(BINS - 1)) < split {
                        slice.swap(i, j);
                        i += 1;
                    }
                }
                i
            } else if count > 4 * LEAF_MAX {
                // No useful SAH split (e.g. identical centroids): split in the middle.
                count / 2
            } else {
                continue;
            };
            if mid == 0 || mid == count {
                continue;
            }
            let l = self.nodes.len();
            self.nodes.push(Node {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                first: first as u32,
                count: mid as u32,
            });
            self.nodes.push(Node {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                first: (first + mid) as u32,
                count: (count - mid) as u32,
            });
            self.nodes[ni].first = l as u32;
            self.nodes[ni].count = 0;
            stack.push(l + 1);
            stack.push(l);
        }
    }

    /// Calls `hit(tag, t)` for triangles hit by the ray `o + t d` with `t` in `(0, tmax)`, in
    /// traversal order; stops when `hit` returns true. Returns whether it was stopped.
    pub fn traverse(&self, o: Vec3, d: Vec3, tmax: f32, mut hit: impl FnMut(u32, f32) -> bool) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let ray = WatertightRay::new(o, d);
        let (oa, inv) = (o, d.recip());
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let n = &self.nodes[stack[sp] as usize];
            if !slab(n.lo, n.hi, oa, inv, tmax) {
                continue;
            }
            if n.count > 0 {
                for t in &self.tris[n.first as usize..(n.first + n.count) as usize] {
                    if let Some(th) = ray.intersect(&t.v, tmax) {
                        if hit(t.tag, th) {
                            return true;
                        }
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = n.first;
                stack[sp + 1] = n.first + 1;
                sp += 2;
            }
        }
        false
    }

    /// True if anything is hit in `(0, tmax)`.
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.traverse(o, d, tmax, |_, _| true)
    }
}

/// Ray-box slab test (inclusive, NaN-safe: a NaN from 0 * inf compares false and is skipped).
#[inline(always)]
fn slab(lo: Vec3, hi: Vec3, o: Vec3, inv: Vec3, tmax: f32) -> bool {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let tn = t0.min(t1).max_element().max(0.0);
    let tf = t0.max(t1).min_element().min(tmax);
    tn <= tf
}

/// Precomputed shear of Woop et al. 2013.
struct WatertightRay {
    o: Vec3,
    k: [usize; 3],
    s: Vec3,
}

impl WatertightRay {
    fn new(o: Vec3, d: Vec3) -> Self {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        WatertightRay {
            o,
            k: [kx, ky, kz],
            s: Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]),
        }
    }

    /// Distance to the triangle, if hit with `t` in `(0, tmax)`.
    #[inline(always)]
    fn intersect(&self, v: &[Vec3; 3], tmax: f32) -> Option<f32> {
        let [kx, ky, kz] = self.k;
        let (a, b, c) = (v[0] - self.o, v[1] - self.o, v[2] - self.o);
        let ax = a[kx] - self.s.x * a[kz];
        let ay = a[ky] - self.s.y * a[kz];
        let bx = b[kx] - self.s.x * b[kz];
        let by = b[ky] - self.s.y * b[kz];
        let cx = c[kx] - self.s.x * c[kz];
        let cy = c[ky] - self.s.y * c[kz];
        let mut u = cx * by - cy * bx;
        let mut vv = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            // Edge cases in double precision, as the paper prescribes.
            u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            vv = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        let t = u * (self.s.z * a[kz]) + vv * (self.s.z * b[kz]) + w * (self.s.z * c[kz]);
        let th = t / det;
        (th > 0.0 && th < tmax).then_some(th)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash::SplitMix;

    #[test]
    fn matches_brute_force_on_random_triangles() {
        let mut r = SplitMix(5);
        let mut p = || Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 10.0 - 5.0;
        let tris: Vec<Tri> = (0..500)
            .map(|i| Tri {
                v: [p(), p(), p()],
                tag: i,
            })
            .collect();
        let bvh = Bvh::build(tris.clone());
        for _ in 0..500 {
            let (o, d) = (p(), (p() - p()).normalize());
            let mut brute = f32::MAX;
            let ray = WatertightRay::new(o, d);
            for t in &tris {
                if let Some(h) = ray.intersect(&t.v, f32::MAX) {
                    brute = brute.min(h);
                }
            }
            let mut best = f32::MAX;
            bvh.traverse(o, d, f32::MAX, |_, t| {
                best = best.min(t);
                false
            });
            assert_eq!(best, brute);
        }
    }

    #[test]
    fn shared_edges_are_watertight() {
        // A fan of triangles around the z axis: rays down the shared edges hit at least once.
        let n = 7;
        let tris: Vec<Tri> = (0..n)
            .map(|i| {
                let a = |k: u32| {
                    let t = k as f32 / n as f32 * std::f32::consts::TAU;
                    Vec3::new(t.cos(), t.sin(), 0.0)
                };
                Tri {
                    v: [Vec3::ZERO, a(i), a(i + 1)],
                    tag: i,
                }
            })
            .collect();
        let bvh = Bvh::build(tris);
        for i in 0..n {
            let t = i as f32 / n as f32 * std::f32::consts::TAU;
            for s in [0.0f32, 0.25, 0.5, 0.999] {
                let o = Vec3::new(t.cos() * s, t.sin() * s, 1.0);
                assert!(bvh.occluded(o, -Vec3::Z, 10.0), "ray down edge {i} at {s} leaked");
            }
        }
    }
}
