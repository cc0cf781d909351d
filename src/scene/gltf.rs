//! glTF 2.0 scenes (the `gltf` crate): meshes placed by their node transforms, materials'
//! base colour, alpha (opacity, for `BLEND` materials) and double-sidedness, perspective
//! cameras, and `KHR_lights_punctual` lights (directional, point, spot). Errors name the file
//! and the node, mesh, primitive or accessor that is wrong.
//!
//! What is not taken: textures (albedo is the base colour factor), `MASK` alpha (treated as
//! opaque), light colours and photometric intensities (every light has intensity 1, as scene
//! files do), orthographic cameras.

use super::{Camera, Light, LightKind, Material, Mesh};
use crate::Error;
use glam::{Mat4, Vec3};
use std::path::Path;

/// One mesh primitive in world space with its material.
pub struct GltfObject {
    /// `node name/mesh name/primitive index`.
    pub name: String,
    /// World-space triangles.
    pub mesh: Mesh,
    /// Index into [`GltfScene::materials`].
    pub material: usize,
}

/// A glTF perspective camera placed by its node.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GltfCamera {
    /// Eye position.
    pub position: Vec3,
    /// A point on the view axis (the node's -z).
    pub target: Vec3,
    /// The node's +y.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
    /// Near plane.
    pub near: f32,
    /// Far plane (glTF allows none: infinite).
    pub far: Option<f32>,
    /// Width over height, when the file gives it.
    pub aspect: Option<f32>,
}

/// What a glTF file's default scene (or its first) holds.
pub struct GltfScene {
    /// Materials, one per glTF material, then one default (for primitives without one).
    pub materials: Vec<Material>,
    /// Every triangle primitive, in node order.
    pub objects: Vec<GltfObject>,
    /// The first perspective camera met in node order.
    pub camera: Option<GltfCamera>,
    /// Punctual lights.
    pub lights: Vec<Light>,
}

impl GltfScene {
    /// All primitives merged into one mesh (a glTF used as an object's `mesh`).
    pub fn merged(&self) -> Mesh {
        let mut m = Mesh::default();
        for o in &self.objects {
            m.append(&o.mesh);
        }
        m
    }

    /// The camera as a scene [`Camera`] of `resolution` (or 640 pixels wide at the file's
    /// aspect ratio, 640x360 without one).
    pub fn scene_camera(&self, resolution: Option<[u32; 2]>) -> Option<Camera> {
        let GltfCamera {
            position,
            target,
            up,
            fov_deg,
            near,
            far,
            aspect,
        } = self.camera?;
        let [width, height] = resolution.unwrap_or_else(|| match aspect {
            Some(a) if a.is_finite() && a > 0.0 => [640, ((640.0 / a).round() as u32).clamp(1, 8192)],
            _ => [640, 360],
        });
        Some(Camera {
            position,
            target,
            up,
            fov_deg,
            near,
            far: far.unwrap_or(near * 1e4).max(near * 2.0),
            width,
            height,
        })
    }
}

/// Loads a `.gltf` (with its buffers) or `.glb` file.
pub fn load(path: &Path) -> Result<GltfScene, Error> {
    super::file::check_regular(path, "glTF file", super::mesh::MAX_OBJ_BYTES)?;
    let (doc, buffers, _) = gltf::import(path).map_err(|e| Error::scene(path, format!("cannot load glTF: {e}")))?;
    let mut materials: Vec<Material> = doc
        .materials()
        .enumerate()
        .map(|(i, m)| {
            let [r, g, b, a] = m.pbr_metallic_roughness().base_color_factor();
            let name = m.name().map_or_else(|| format!("gltf_material{i}"), str::to_string);
            Material {
                name,
                albedo: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
                opacity: match m.alpha_mode() {
                    gltf::material::AlphaMode::Blend => a.clamp(0.0, 1.0),
                    _ => 1.0,
                },
                transmittance: None,
                two_sided: m.double_sided(),
            }
        })
        .collect();
    for m in &materials {
        if !m.albedo.is_finite() || !m.opacity.is_finite() {
            return Err(Error::scene(
                path,
                format!("material '{}': base colour is not finite", m.name),
            ));
        }
    }
    let default_material = materials.len();
    materials.push(Material {
        name: "gltf_default".into(),
        ..Material::default()
    });
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| Error::scene(path, "the file has no scene"))?;
    let mut out = GltfScene {
        materials,
        objects: Vec::new(),
        camera: None,
        lights: Vec::new(),
    };
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 1_000_000 {
            return Err(Error::scene(path, "more than a million nodes (a cycle?)"));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        let node_name = match node.name() {
            Some(n) => format!("node {} '{n}'", node.index()),
            None => format!("node {}", node.index()),
        };
        if !world.is_finite() {
            return Err(Error::scene(path, format!("{node_name}: its transform is not finite")));
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let what = format!(
                    "{node_name}, mesh {} '{}', primitive {}",
                    mesh.index(),
                    mesh.name().unwrap_or(""),
                    prim.index()
                );
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    return Err(Error::scene(
                        path,
                        format!("{what}: mode {:?} is not supported (only TRIANGLES)", prim.mode()),
                    ));
                }
                let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let positions: Vec<Vec3> = reader
                    .read_positions()
                    .ok_or_else(|| Error::scene(path, format!("{what}: no POSITION accessor")))?
                    .map(Vec3::from)
                    .collect();
                if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
                    return Err(Error::scene(
                        path,
                        format!(
                            "{what}: accessor {}: a position is not finite ({p})",
                            prim.get(&gltf::Semantic::Positions).map_or(0, |a| a.index())
                        ),
                    ));
                }
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(ix) => ix.into_u32().collect(),
                    None => (0..positions.len() as u32).collect(),
                };
                if !indices.len().is_multiple_of(3) {
                    return Err(Error::scene(
                        path,
                        format!("{what}: {} indices are not whole triangles", indices.len()),
                    ));
                }
                if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                    return Err(Error::scene(
                        path,
                        format!(
                            "{what}: accessor {}: index {bad} beyond the {} positions",
                            prim.indices().map_or(0, |a| a.index()),
                            positions.len()
                        ),
                    ));
                }
                let normals: Vec<Vec3> = match reader.read_normals() {
                    Some(n) => n.map(|v| Vec3::from(v).normalize_or_zero()).collect(),
                    None => super::mesh::face_normals(&positions, &indices),
                };
                if normals.len() != positions.len() {
                    return Err(Error::scene(
                        path,
                        format!("{what}: {} normals for {} positions", normals.len(), positions.len()),
                    ));
                }
                let mut m = Mesh {
                    positions,
                    normals,
                    indices,
                }
                .transformed(world);
                // A mirroring transform turns the faces' winding around (glTF 2.0, 3.7.4).
                if crate::math::determinant(&world) < 0.0 {
                    for t in m.indices.chunks_exact_mut(3) {
                        t.swap(1, 2);
                    }
                }
                out.objects.push(GltfObject {
                    name: format!(
                        "{}/{}/{}",
                        node.name().unwrap_or("node"),
                        mesh.name().unwrap_or("mesh"),
                        prim.index()
                    ),
                    mesh: m,
                    material: prim.material().index().unwrap_or(default_material),
                });
            }
        }
        let origin = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        if let Some(cam) = node.camera() {
            if let (None, gltf::camera::Projection::Perspective(p)) = (&out.camera, cam.projection()) {
                let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
                if forward == Vec3::ZERO || up == Vec3::ZERO {
                    return Err(Error::scene(
                        path,
                        format!("{node_name}: the camera's transform is degenerate"),
                    ));
                }
                let fov = p.yfov().to_degrees();
                if !(fov > 0.0 && fov < 180.0 && p.znear() > 0.0 && p.znear().is_finite()) {
                    return Err(Error::scene(
                        path,
                        format!(
                            "{node_name}: camera {}: yfov {} rad or znear {} is out of range",
                            cam.index(),
                            p.yfov(),
                            p.znear()
                        ),
                    ));
                }
                out.camera = Some(GltfCamera {
                    position: origin,
                    target: origin + forward,
                    up,
                    fov_deg: fov,
                    near: p.znear(),
                    far: p.zfar(),
                    aspect: p.aspect_ratio(),
                });
            }
        }
        if let Some(l) = node.light() {
            use gltf::khr_lights_punctual::Kind;
            let kind = match l.kind() {
                Kind::Directional => LightKind::Directional,
                Kind::Point => LightKind::Point,
                Kind::Spot { outer_cone_angle, .. } => {
                    let angle_deg = 2.0 * outer_cone_angle.to_degrees();
                    if !(angle_deg > 0.0 && angle_deg < 180.0) {
                        return Err(Error::scene(
                            path,
                            format!(
                                "{node_name}: light {}: outerConeAngle {outer_cone_angle} is outside (0, pi/2)",
                                l.index()
                            ),
                        ));
                    }
                    LightKind::Spot { angle_deg }
                }
            };
            if forward == Vec3::ZERO {
                return Err(Error::scene(
                    path,
                    format!("{node_name}: the light's transform is degenerate"),
                ));
            }
            out.lights.push(Light {
                kind,
                position: origin,
                direction: forward,
                intensity: 1.0,
            });
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world));
        }
    }
    if out.objects.iter().all(|o| o.mesh.indices.is_empty()) {
        return Err(Error::scene(path, "no triangles in the scene"));
    }
    Ok(out)
}
