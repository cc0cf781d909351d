//! The benchmark's "spheres" scene, procedurally: a ground quad and an 8 x 8 grid of UV
//! spheres, as one indexed mesh with per-vertex albedo ([`spheres_scene`], what the frame
//! benchmark draws) and as a [`Scene`] of one object per sphere ([`spheres_as_scene`], for the
//! ray and technique benchmarks).

use super::*;
use glam::Vec3;

/// A vertex of the benchmark meshes.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BenchVertex {
    /// World position.
    pub pos: Vec3,
    /// Unit normal.
    pub normal: Vec3,
    /// Albedo.
    pub albedo: Vec3,
}

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct BenchMesh {
    /// Vertices.
    pub vertices: Vec<BenchVertex>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
}

impl BenchMesh {
    /// Triangle count.
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }
}

/// Stacks and slices of each sphere for a target total of `t` triangles:
/// `per = (T - 2) / 64`, `n = round(sqrt(per / 4))`, `stacks = n + 1`, `slices = round(per / 2n)`.
pub fn sphere_tessellation(t: usize) -> (usize, usize) {
    let per = t.saturating_sub(2) as f64 / 64.0;
    let n = ((per / 4.0).sqrt().round() as usize).max(1);
    let slices = ((per / (2.0 * n as f64)).round() as usize).max(3);
    (n + 1, slices)
}

/// The "spheres" scene with about `t` triangles: ground y = 0 over x, z in [-12, 12], an 8 x 8
/// grid of UV spheres of radius 0.8, spacing 2.5, centred on the origin, bottoms 0.6 above
/// the ground; each sphere `2 * slices * (stacks - 1)` triangles.
pub fn spheres_scene(t: usize) -> BenchMesh {
    let mut m = BenchMesh::default();
    let g = Vec3::splat(0.7);
    for (x, z) in [(-12.0, -12.0), (12.0, -12.0), (12.0, 12.0), (-12.0, 12.0)] {
        m.vertices.push(BenchVertex {
            pos: Vec3::new(x, 0.0, z),
            normal: Vec3::Y,
            albedo: g,
        });
    }
    // Counter-clockwise seen from above (+y).
    m.indices.extend_from_slice(&[0, 2, 1, 0, 3, 2]);
    let (stacks, slices) = sphere_tessellation(t);
    let r = 0.8f32;
    for i in 0..8 {
        for j in 0..8 {
            let c = Vec3::new((i as f32 - 3.5) * 2.5, 0.6 + r, (j as f32 - 3.5) * 2.5);
            let albedo = Vec3::new(0.35 + 0.08 * i as f32, 0.45, 0.35 + 0.08 * j as f32);
            let base = m.vertices.len() as u32;
            for s in 0..stacks as u32 {
                for k in 0..=slices as u32 {
                    let n = crate::scene::mesh::sphere_point(s, stacks as u32, k, slices as u32);
                    m.vertices.push(BenchVertex {
                        pos: c + n * r,
                        normal: n,
                        albedo,
                    });
                }
            }
            let row = slices as u32 + 1;
            for s in 0..stacks as u32 - 1 {
                for k in 0..slices as u32 {
                    let a = base + s * row + k;
                    let b = a + row;
                    // Outward-facing, counter-clockwise.
                    m.indices.extend_from_slice(&[a, b, a + 1, a + 1, b, b + 1]);
                }
            }
        }
    }
    m
}

/// The spheres scene as a [`crate::scene::Scene`] (same geometry as [`spheres_scene`]), for the
/// reference's ray benchmark and the shadow-volume benchmark: one object for the ground and
/// one per sphere (each closed).
pub fn spheres_as_scene(t: usize) -> crate::scene::Scene {
    let m = spheres_scene(t);
    let (stacks, slices) = sphere_tessellation(t);
    let object = |name: String, verts: std::ops::Range<usize>, tris: std::ops::Range<usize>| Object {
        name,
        mesh: Mesh {
            positions: m.vertices[verts.clone()].iter().map(|v| v.pos).collect(),
            normals: m.vertices[verts.clone()].iter().map(|v| v.normal).collect(),
            indices: m.indices[tris].iter().map(|&i| i - verts.start as u32).collect(),
        },
        material: 0,
        heightfield: false,
    };
    let (nv, ni) = (stacks * (slices + 1), 6 * slices * (stacks - 1));
    let mut objects = vec![object("ground".into(), 0..4, 0..6)];
    for k in 0..64 {
        objects.push(object(
            format!("sphere_{k}"),
            4 + k * nv..4 + (k + 1) * nv,
            6 + k * ni..6 + (k + 1) * ni,
        ));
    }
    Scene {
        name: "spheres".into(),
        description: "benchmark spheres".into(),
        objects,
        materials: vec![Material::default()],
        camera: Camera {
            position: Vec3::new(0.0, 13.0, 21.0),
            target: Vec3::new(0.0, 0.0, 1.0),
            up: Vec3::Y,
            fov_deg: 45.0,
            near: 0.5,
            far: 100.0,
            width: 1920,
            height: 1080,
        },
        lights: vec![Light {
            kind: LightKind::Directional,
            position: Vec3::new(55.0, 100.0, 35.0),
            direction: -Vec3::new(0.55, 1.0, 0.35).normalize(),
            intensity: 1.0,
        }],
        camera_path: vec![],
        light_path: vec![],
        notes: Vec::new(),
    }
}
