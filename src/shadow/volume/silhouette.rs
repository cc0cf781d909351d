//! Shadow-volume geometry: silhouette edges from edge adjacency, extruded to infinity, with
//! front and back caps (Crow 1977; RTR 7.3; CS300 "shadow volumes"; Cournia section 3.2).
//!
//! The volume of a set of triangles, each facing the light, is the sum of the semi-infinite
//! prisms that the triangles cut out of the light's rays: a point's count is the number of
//! those triangles crossed by its segment to the light. Summing the prisms' boundaries, the
//! side quads of an edge shared by two such triangles cancel (they run in opposite directions),
//! and what is left is one quad per *silhouette* edge plus the caps. So:
//!
//! - a closed, consistently wound, manifold mesh uses its light-facing triangles only: the
//!   classic silhouette volume, count 1 behind the mesh;
//! - any other mesh (holes, an edge shared by more than two triangles, inconsistent winding)
//!   uses *every* triangle, turned to face the light: a sheet blocks light from both sides,
//!   and the edge sums still cancel exactly where they should. An open edge of a light-facing
//!   triangle is a silhouette edge (CS300). The count is then the number of surfaces crossed,
//!   still 0 exactly where the light is visible (modulo the 8-bit stencil's 256).
//!
//! Edges are matched on positions welded by exact bit pattern, so flat-shaded meshes whose
//! faces repeat corner vertices (boxes) still find their neighbours. Triangles with two equal
//! welded corners or zero area are dropped and counted. Every irregularity is counted in a
//! [`MeshReport`] that the technique reports.

use glam::{DVec3, Vec3, Vec4};
use std::collections::HashMap;

use crate::frame::Frame;
use crate::pipeline::Pipeline;
use crate::scene::Mesh;
use rayon::prelude::*;

/// What the adjacency pass found in one mesh.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct MeshReport {
    /// Vertices merged with an earlier vertex at the same position.
    pub welded_vertices: usize,
    /// Triangles dropped: two corners at one position, or zero area.
    pub degenerate_triangles: usize,
    /// Edges used by one triangle only (holes, borders).
    pub open_edges: usize,
    /// Edges used by more than two triangles.
    pub nonmanifold_edges: usize,
    /// Edges whose two triangles run in the same direction (inconsistent winding).
    pub inconsistent_edges: usize,
}

impl MeshReport {
    /// Whether the mesh is a closed, consistently wound 2-manifold (the classic volume works).
    pub fn is_closed_manifold(&self) -> bool {
        self.open_edges == 0 && self.nonmanifold_edges == 0 && self.inconsistent_edges == 0
    }

    /// One line for users, e.g. `open (12 open edges), 2 degenerate triangles dropped`.
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        for (n, what) in [
            (self.open_edges, "open edges"),
            (self.nonmanifold_edges, "non-manifold edges"),
            (self.inconsistent_edges, "edges with inconsistent winding"),
            (self.degenerate_triangles, "degenerate triangles dropped"),
        ] {
            if n > 0 {
                parts.push(format!("{n} {what}"));
            }
        }
        if parts.is_empty() {
            "closed manifold".into()
        } else {
            parts.join(", ")
        }
    }
}

/// A mesh's adjacency, independent of the light: welded triangles and their edges.
pub struct Adjacency {
    /// Triangles as indices into the mesh's positions, degenerate ones removed.
    tris: Vec<[u32; 3]>,
    /// Welded id of every mesh vertex.
    ids: Vec<u32>,
    /// What was found.
    pub report: MeshReport,
}

/// Key of an undirected welded edge, and +1 if `a -> b` runs from the lower id to the higher.
#[inline]
fn edge_key(ia: u32, ib: u32) -> (u64, i32) {
    if ia < ib {
        (((ia as u64) << 32) | ib as u64, 1)
    } else {
        (((ib as u64) << 32) | ia as u64, -1)
    }
}

impl Adjacency {
    /// Welds `mesh`'s positions and classifies its edges.
    pub fn new(mesh: &Mesh) -> Adjacency {
        let mut weld: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
        let ids: Vec<u32> = mesh
            .positions
            .iter()
            .map(|p| {
                let n = weld.len() as u32;
                // + 0.0 folds -0.0 into 0.0, so both weld.
                let key = [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()];
                *weld.entry(key).or_insert(n)
            })
            .collect();
        let mut report = MeshReport {
            welded_vertices: mesh.positions.len() - weld.len(),
            ..Default::default()
        };
        let tris: Vec<[u32; 3]> = mesh
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .filter(|t| {
                let [a, b, c] = t.map(|i| ids[i as usize]);
                let [pa, pb, pc] = t.map(|i| mesh.positions[i as usize].as_dvec3());
                let ok = a != b && b != c && a != c && (pb - pa).cross(pc - pa) != DVec3::ZERO;
                report.degenerate_triangles += !ok as usize;
                ok
            })
            .collect();
        // Sorting directed edges by their undirected key groups each edge's uses together,
        // in the same order on every run.
        let mut uses: Vec<(u64, i32)> = tris
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .map(|(a, b)| edge_key(ids[a as usize], ids[b as usize]))
            .collect();
        uses.sort_unstable();
        for group in uses.chunk_by(|x, y| x.0 == y.0) {
            match group {
                [_] => report.open_edges += 1,
                [(_, s0), (_, s1)] => report.inconsistent_edges += (s0 == s1) as usize,
                _ => report.nonmanifold_edges += 1,
            }
        }
        Adjacency { tris, ids, report }
    }
}

/// The shadow volume of one mesh for one light.
#[derive(Clone, Debug, Default)]
pub struct Volume {
    /// Homogeneous world positions (w = 0: at infinity, away from the light).
    pub vertices: Vec<Vec4>,
    /// Outward-facing triangles: side quads, front cap, back cap.
    pub indices: Vec<u32>,
    /// Silhouette edges (world space), each once, in the winding of its light-facing side.
    pub silhouette: Vec<(Vec3, Vec3)>,
    /// Triangles of the caps (turned towards the light); the eye count tests against these.
    pub caps: Vec<[Vec3; 3]>,
    /// Whether every triangle was used (not a closed manifold).
    pub all_triangles: bool,
}

/// Whether triangle `(a, b, c)` faces the homogeneous light position `l` (w = 0: a direction
/// towards the light): +1 facing, -1 facing away, 0 edge-on.
fn facing(a: Vec3, b: Vec3, c: Vec3, l: Vec4) -> i32 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let n = (b - a).cross(c - a);
    let to_light = l.truncate().as_dvec3() - a * l.w as f64;
    let d = n.dot(to_light);
    (d > 0.0) as i32 - (d < 0.0) as i32
}

/// Builds the volume of `mesh` (with adjacency `adj`) for the homogeneous light position
/// `light` (`(p, 1)` for point and spot lights, `(-direction, 0)` for directional ones).
pub fn volume(mesh: &Mesh, adj: &Adjacency, light: Vec4) -> Volume {
    let all = !adj.report.is_closed_manifold();
    let pos = |i: u32| mesh.positions[i as usize];
    // The triangles whose prisms make the volume, each wound to face the light.
    let caps: Vec<[u32; 3]> = adj
        .tris
        .iter()
        .filter_map(|&[a, b, c]| match facing(pos(a), pos(b), pos(c), light) {
            1 => Some([a, b, c]),
            -1 if all => Some([a, c, b]),
            _ => None,
        })
        .collect();
    // Net directed use of each undirected edge; what does not cancel is a silhouette edge,
    // extruded once per unit of net use. (Representative vertices: the lower id's own.)
    let mut edges: Vec<(u64, i32, u32, u32)> = caps
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .map(|(a, b)| {
            let (key, s) = edge_key(adj.ids[a as usize], adj.ids[b as usize]);
            let (lo, hi) = if s > 0 { (a, b) } else { (b, a) };
            (key, s, lo, hi)
        })
        .collect();
    edges.sort_unstable_by_key(|e| e.0);
    let far = |p: Vec3| -> Vec4 {
        if light.w == 0.0 {
            (-light.truncate()).extend(0.0)
        } else {
            (p - light.truncate()).extend(0.0)
        }
    };
    let mut v = Volume {
        all_triangles: all,
        ..Default::default()
    };
    for group in edges.chunk_by(|x, y| x.0 == y.0) {
        let net: i32 = group.iter().map(|e| e.1).sum();
        if net == 0 {
            continue;
        }
        let (lo, hi) = (pos(group[0].2), pos(group[0].3));
        let (a, b) = if net > 0 { (lo, hi) } else { (hi, lo) };
        v.silhouette.push((a, b));
        for _ in 0..net.unsigned_abs() {
            // Edge a -> b of a light-facing, counter-clockwise triangle: the side quad
            // (b, a, a_inf, b_inf) faces outward.
            let base = v.vertices.len() as u32;
            v.vertices
                .extend_from_slice(&[b.extend(1.0), a.extend(1.0), far(a), far(b)]);
            v.indices
                .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    // Caps: the light-facing triangles (front), and the same at infinity, reversed (back).
    for t in &caps {
        let p = t.map(pos);
        let base = v.vertices.len() as u32;
        v.vertices.extend_from_slice(&[
            p[0].extend(1.0),
            p[1].extend(1.0),
            p[2].extend(1.0),
            far(p[0]),
            far(p[1]),
            far(p[2]),
        ]);
        v.indices
            .extend_from_slice(&[base, base + 1, base + 2, base + 3, base + 5, base + 4]);
        v.caps.push(p);
    }
    v
}

/// The number of cap triangles the segment from `eye` to the light crosses: the count of
/// volumes that contain the eye, which z-pass starts its stencil at (Heidmann; RTR 7.3).
pub fn eye_count(volumes: &[Volume], eye: Vec3, light: Vec4) -> u32 {
    let o = eye.as_dvec3();
    // Segment o + t d, t in (0, 1]; directional lights: a ray (t unbounded).
    let (d, tmax) = if light.w == 0.0 {
        (light.truncate().as_dvec3(), f64::INFINITY)
    } else {
        (light.truncate().as_dvec3() - o, 1.0)
    };
    let mut n = 0;
    for t in volumes.iter().flat_map(|v| &v.caps) {
        // Möller-Trumbore in f64.
        let [a, b, c] = t.map(|p| p.as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det == 0.0 {
            continue;
        }
        let s = (o - a) / det;
        let u = s.dot(pv);
        let q = s.cross(e1);
        let w = d.dot(q);
        let t = e2.dot(q);
        if u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t > 0.0 && t <= tmax {
            n += 1;
        }
    }
    n
}

/// The volume of every object of `frame` for the homogeneous light position `light`, built in
/// parallel and collected in scene order (the same for any thread count), and the objects
/// whose mesh is irregular with [`MeshReport::describe`].
pub fn scene_volumes(p: &Pipeline, frame: &Frame, light: Vec4) -> (Vec<Volume>, Vec<(String, String)>) {
    let built: Vec<(MeshReport, Volume)> = p.install(|| {
        frame
            .scene
            .objects
            .par_iter()
            .map(|o| {
                let adj = Adjacency::new(&o.mesh);
                (adj.report, volume(&o.mesh, &adj, light))
            })
            .collect()
    });
    let mut irregular = Vec::new();
    let mut volumes = Vec::with_capacity(built.len());
    for (o, (report, v)) in frame.scene.objects.iter().zip(built) {
        if !report.is_closed_manifold() || report.degenerate_triangles > 0 {
            irregular.push((o.name.clone(), report.describe()));
        }
        volumes.push(v);
    }
    (volumes, irregular)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh;
    use glam::Mat4;

    fn box_mesh() -> Mesh {
        mesh::cuboid(Vec3::ONE).transformed(Mat4::IDENTITY)
    }

    #[test]
    fn a_box_is_closed_and_has_a_four_edge_silhouette_from_above() {
        let m = box_mesh();
        let adj = Adjacency::new(&m);
        assert!(adj.report.is_closed_manifold(), "{:?}", adj.report);
        let v = volume(&m, &adj, Vec4::new(0.0, 10.0, 0.0, 1.0));
        assert_eq!(v.silhouette.len(), 4);
        assert!(!v.all_triangles);
        // Directional light along a diagonal: a hexagonal silhouette.
        let v = volume(&m, &adj, Vec4::new(1.0, 1.0, 1.0, 0.0));
        assert_eq!(v.silhouette.len(), 6);
    }

    #[test]
    fn defects_are_counted_and_handled() {
        let mut m = box_mesh();
        // A hole: drop the last triangle.
        m.indices.truncate(m.indices.len() - 3);
        let r = Adjacency::new(&m).report;
        assert_eq!(r.open_edges, 3, "{r:?}");
        // Inconsistent winding: flip one triangle of the closed box.
        let mut m = box_mesh();
        m.indices.swap(0, 1);
        let r = Adjacency::new(&m).report;
        assert_eq!(r.inconsistent_edges, 3, "{r:?}");
        // Degenerate triangles and an edge with three triangles.
        let mut m = box_mesh();
        let i = m.indices[0];
        m.indices.extend_from_slice(&[i, i, m.indices[1]]);
        let (a, b) = (m.indices[0], m.indices[1]);
        m.positions.push(Vec3::new(5.0, 5.0, 5.0));
        let c = m.positions.len() as u32 - 1;
        m.indices.extend_from_slice(&[a, b, c]);
        let r = Adjacency::new(&m).report;
        assert_eq!(r.degenerate_triangles, 1, "{r:?}");
        assert_eq!(r.nonmanifold_edges, 1, "{r:?}");
        assert!(r.describe().contains("non-manifold"));
    }

    #[test]
    fn eye_count_counts_the_volumes_around_the_eye() {
        let m = box_mesh();
        let adj = Adjacency::new(&m);
        let light = Vec4::new(0.0, 10.0, 0.0, 1.0);
        let v = vec![volume(&m, &adj, light)];
        assert_eq!(eye_count(&v, Vec3::new(0.1, -3.0, 0.05), light), 1);
        assert_eq!(eye_count(&v, Vec3::new(3.0, -3.0, 0.0), light), 0);
        assert_eq!(eye_count(&v, Vec3::new(0.1, 3.0, 0.0), light), 0);
        // A box with a flipped triangle uses every triangle: two surfaces above the eye.
        let mut m = box_mesh();
        m.indices.swap(0, 1);
        let adj = Adjacency::new(&m);
        let v = vec![volume(&m, &adj, light)];
        assert!(v[0].all_triangles);
        assert_eq!(eye_count(&v, Vec3::new(0.1, -3.0, 0.05), light), 2);
    }
}
