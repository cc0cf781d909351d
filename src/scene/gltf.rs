//! glTF 2.0 scenes (the `gltf` crate): meshes placed by their node transforms, materials'
//! base colour, alpha (opacity, for `BLEND` materials) and double-sidedness, perspective
//! cameras, and `KHR_lights_punctual` lights (directional, point, spot). Errors name the file
//! and the node, mesh, primitive or accessor that is wrong.
//!
//! What is not taken: textures (albedo is the base colour factor), `MASK` alpha (treated as
//! opaque), light colours and photometric intensities (every light has intensity 1, as scene
//! files do), orthographic cameras.

use super::{Camera, Light, LightKind, Material, Mesh};
use crate::error::quoted;
use crate::error::Reason;
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
///
/// Everything the file refers to is checked before it is read or expanded: buffer URIs must
/// be relative paths inside the file's folder naming regular files (or bounded `data:`
/// URIs); images are never opened (textures are not taken); every accessor a primitive uses
/// is checked against its type, its buffer view and its buffer; the node graph is counted,
/// instances included, against the triangle budget before any mesh is built.
pub fn load(path: &Path) -> Result<GltfScene, Error> {
    let bytes = super::read::read_regular(path, "glTF file", super::mesh::MAX_OBJ_BYTES)?;
    let (doc, blob) = document(path, &bytes)?;
    let buffers = load_buffers(path, &doc, blob)?;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| Error::scene(path, "the file has no scene"))?;
    check_graph(path, &scene, &buffers)?;
    let mut materials = materials(path, &doc)?;
    let default_material = materials.len();
    materials.push(Material {
        name: "gltf_default".into(),
        ..Material::default()
    });
    let mut out = GltfScene {
        materials,
        objects: Vec::new(),
        camera: None,
        lights: Vec::new(),
    };
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    // `check_graph` has bounded the instances, their depth and triangles, and found no cycle.
    while let Some((node, parent)) = stack.pop() {
        if let gltf::scene::Transform::Decomposed { rotation, .. } = node.transform() {
            let n = rotation.iter().map(|v| v * v).sum::<f32>().sqrt();
            if !(n > 0.99 && n < 1.01) {
                return Err(Error::scene(
                    path,
                    format!(
                        "node {} {}: rotation {rotation:?} is not a unit quaternion (length {n})",
                        node.index(),
                        quoted(node.name().unwrap_or(""))
                    ),
                ));
            }
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        let node_name = match node.name() {
            Some(n) => format!("node {} {}", node.index(), quoted(n)),
            None => format!("node {}", node.index()),
        };
        if !world.is_finite() {
            return Err(Error::scene(path, format!("{node_name}: its transform is not finite")));
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let object =
                    primitive_object(path, &buffers, &node, &mesh, &prim, world, default_material, &node_name)?;
                out.objects.push(object);
            }
        }
        if let (None, Some(cam)) = (&out.camera, node.camera()) {
            out.camera = node_camera(path, &cam, world, &node_name)?;
        }
        if let Some(l) = node.light() {
            out.lights.push(node_light(path, &l, world, &node_name)?);
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

/// The file's document and binary chunk, its JSON checked where the crate's validation would
/// panic, then validated, and its version 2.x.
fn document(path: &Path, bytes: &[u8]) -> Result<(gltf::Document, Option<Vec<u8>>), Error> {
    let read_error = |e: gltf::Error| {
        Error::scene(
            path,
            match e {
                gltf::Error::Binary(e) => format!("not a valid binary glTF (GLB) container: {e}"),
                gltf::Error::Deserialize(e) => format!("not valid glTF JSON: {e}"),
                gltf::Error::Validation(v) => {
                    let (p, e) = &v[0];
                    format!(
                        "invalid glTF 2.0: {p}: {e}{}",
                        if v.len() > 1 {
                            format!(" (and {} more)", v.len() - 1)
                        } else {
                            String::new()
                        }
                    )
                }
                e => format!("cannot read glTF: {e}"),
            },
        )
    };
    check_glb_length(path, bytes)?;
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes).map_err(read_error)?;
    let root = document.into_json();
    check_required(path, &root)?;
    check_transforms(path, &root)?;
    // The crate's validation indexes a primitive's POSITION accessor before it checks that
    // the index exists (a panic): checked here first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (k, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, a) in &prim.attributes {
                if a.value() >= root.accessors.len() {
                    let semantic = match semantic {
                        gltf::json::validation::Checked::Valid(s) => s.to_string(),
                        gltf::json::validation::Checked::Invalid => "(unknown)".into(),
                    };
                    return Err(Error::scene(
                        path,
                        format!(
                            "mesh {m}, primitive {k}: attribute {semantic} names accessor {}, but the file has {}",
                            a.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    let doc = gltf::Document::from_json(root).map_err(read_error)?;
    let version = &doc.as_json().asset.version;
    if !version.starts_with("2.") {
        return Err(Error::scene(
            path,
            format!("asset.version is '{version}': only glTF 2.x is read"),
        ));
    }
    Ok((doc, blob))
}

/// The extensions penumbra implements: a file that requires another is refused.
const IMPLEMENTED: &[&str] = &["KHR_lights_punctual"];

/// A GLB container's header gives the file's whole length (bytes 8 to 12): one that differs
/// from the file's is refused, not read as far as it says.
fn check_glb_length(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    if bytes.len() < 12 || &bytes[..4] != b"glTF" {
        return Ok(());
    }
    let said = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
    if said != bytes.len() {
        return Err(Error::scene(
            path,
            format!(
                "not a valid binary glTF (GLB) container: its header gives a length of {said} bytes, the file has {}",
                bytes.len()
            ),
        ));
    }
    Ok(())
}

/// glTF 2.0 (3.12): a loader must refuse a file whose `extensionsRequired` names an
/// extension it does not implement, rather than draw it without.
fn check_required(path: &Path, root: &gltf::json::Root) -> Result<(), Error> {
    match root
        .extensions_required
        .iter()
        .find(|e| !IMPLEMENTED.contains(&e.as_str()))
    {
        Some(e) => Err(Error::scene(
            path,
            format!(
                "the file requires the extension {}, which penumbra does not implement (it implements {})",
                crate::error::quoted(e),
                IMPLEMENTED.join(", ")
            ),
        )),
        None => Ok(()),
    }
}

/// A node's `matrix` is an affine transform (bottom row 0, 0, 0, 1), and a node has either a
/// `matrix` or translation, rotation and scale, never both (glTF 2.0, 5.25): what would be
/// dropped or projected is refused, naming the node.
fn check_transforms(path: &Path, root: &gltf::json::Root) -> Result<(), Error> {
    for (i, n) in root.nodes.iter().enumerate() {
        let Some(m) = n.matrix else { continue };
        let name = format!("node {i} {}", crate::error::quoted(n.name.as_deref().unwrap_or("")));
        if n.translation.is_some() || n.rotation.is_some() || n.scale.is_some() {
            return Err(Error::scene(
                path,
                format!(
                    "{name} has both a matrix and translation, rotation or scale (glTF 2.0 allows one or the other)"
                ),
            ));
        }
        if [m[3], m[7], m[11], m[15]] != [0.0, 0.0, 0.0, 1.0] {
            return Err(Error::scene(
                path,
                format!(
                    "{name}: its matrix's bottom row is {:?}, not [0, 0, 0, 1] (a node's transform is affine)",
                    [m[3], m[7], m[11], m[15]]
                ),
            ));
        }
    }
    Ok(())
}

/// The file's materials (base colour, alpha blending, two-sided), each colour checked.
fn materials(path: &Path, doc: &gltf::Document) -> Result<Vec<Material>, Error> {
    let mut materials = Vec::new();
    for (i, m) in doc.materials().enumerate() {
        let c = m.pbr_metallic_roughness().base_color_factor();
        let name = m.name().map_or_else(|| format!("gltf_material{i}"), str::to_string);
        if let Some(v) = c.iter().find(|v| !(**v >= 0.0 && **v <= 1.0)) {
            return Err(Error::scene(
                path,
                format!(
                    "material {i} {}: baseColorFactor {c:?} has {v}, outside [0, 1]",
                    quoted(&name)
                ),
            ));
        }
        materials.push(Material {
            name,
            albedo: Vec3::new(c[0], c[1], c[2]),
            opacity: match m.alpha_mode() {
                gltf::material::AlphaMode::Blend => c[3],
                _ => 1.0,
            },
            transmittance: None,
            two_sided: m.double_sided(),
        });
    }
    Ok(materials)
}

/// The object of primitive `prim` of `mesh` at node `node_name` with transform `world`:
/// its triangles checked (mode, finite positions, whole triangles, indices in range, one
/// normal per position) and moved to the world, their winding turned where `world` mirrors.
#[allow(clippy::too_many_arguments)]
fn primitive_object(
    path: &Path,
    buffers: &[Vec<u8>],
    node: &gltf::Node,
    mesh: &gltf::Mesh,
    prim: &gltf::Primitive,
    world: Mat4,
    default_material: usize,
    node_name: &str,
) -> Result<GltfObject, Error> {
    let what = format!(
        "{node_name}, mesh {} {}, primitive {}",
        mesh.index(),
        quoted(mesh.name().unwrap_or("")),
        prim.index()
    );
    if prim.mode() != gltf::mesh::Mode::Triangles {
        return Err(Error::scene(
            path,
            format!("{what}: mode {:?} is not supported (only TRIANGLES)", prim.mode()),
        ));
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d[..]));
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
    Ok(GltfObject {
        name: format!(
            "{}/{}/{}",
            node.name().unwrap_or("node"),
            mesh.name().unwrap_or("mesh"),
            prim.index()
        ),
        mesh: m,
        material: prim.material().index().unwrap_or(default_material),
    })
}

/// The camera `cam` of node `node_name` with transform `world` (perspective cameras; `None`
/// for an orthographic one), its view and projection checked.
fn node_camera(path: &Path, cam: &gltf::Camera, world: Mat4, node_name: &str) -> Result<Option<GltfCamera>, Error> {
    let origin = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
    let gltf::camera::Projection::Perspective(p) = cam.projection() else {
        return Ok(None);
    };
    let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
    if forward == Vec3::ZERO || up == Vec3::ZERO {
        return Err(Error::scene(
            path,
            format!("{node_name}: the camera's transform is degenerate"),
        ));
    }
    let fov = p.yfov().to_degrees();
    if !(super::limits::FOV_DEGREES.contains(&fov) && p.znear() > 0.0 && p.znear().is_finite()) {
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
    if let Some(a) = p.aspect_ratio().filter(|a| !(a.is_finite() && *a > 0.0)) {
        return Err(Error::scene(
            path,
            format!("{node_name}: camera {}: aspectRatio {a} is not positive", cam.index()),
        ));
    }
    if let Some(f) = p.zfar().filter(|f| !(f.is_finite() && *f > p.znear())) {
        return Err(Error::scene(
            path,
            format!(
                "{node_name}: camera {}: zfar {f} is not beyond znear {}",
                cam.index(),
                p.znear()
            ),
        ));
    }
    Ok(Some(GltfCamera {
        position: origin,
        target: origin + forward,
        up,
        fov_deg: fov,
        near: p.znear(),
        far: p.zfar(),
        aspect: p.aspect_ratio(),
    }))
}

/// The punctual light `l` (KHR_lights_punctual) of node `node_name` with transform `world`,
/// its intensity, range, colour and cone checked.
fn node_light(path: &Path, l: &gltf::khr_lights_punctual::Light, world: Mat4, node_name: &str) -> Result<Light, Error> {
    let origin = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
    use gltf::khr_lights_punctual::Kind;
    let bad = |field: &str, v: String, want: &str| {
        Err(Error::scene(
            path,
            format!("{node_name}: light {}: {field} {v} {want}", l.index()),
        ))
    };
    if !(l.intensity() >= 0.0 && l.intensity().is_finite()) {
        return bad("intensity", l.intensity().to_string(), "is not a finite number >= 0");
    }
    if let Some(r) = l.range().filter(|r| !(r.is_finite() && *r > 0.0)) {
        return bad("range", r.to_string(), "is not a finite number > 0");
    }
    if l.color().iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
        return bad(
            "color",
            format!("{:?}", l.color()),
            "has a negative or non-finite component",
        );
    }
    if let Kind::Spot {
        inner_cone_angle,
        outer_cone_angle,
    } = l.kind()
    {
        if !(inner_cone_angle >= 0.0 && inner_cone_angle < outer_cone_angle) {
            return bad(
                "innerConeAngle",
                inner_cone_angle.to_string(),
                &format!("is not in [0, outerConeAngle = {outer_cone_angle})"),
            );
        }
    }
    let kind = match l.kind() {
        Kind::Directional => LightKind::Directional,
        Kind::Point => LightKind::Point,
        Kind::Spot { outer_cone_angle, .. } => {
            let angle_deg = 2.0 * outer_cone_angle.to_degrees();
            if !super::limits::FOV_DEGREES.contains(&angle_deg) {
                return Err(Error::scene(
                    path,
                    format!(
                        "{node_name}: light {}: outerConeAngle {outer_cone_angle} makes a cone of {angle_deg} degrees, outside {:?}",
                        l.index(),
                        super::limits::FOV_DEGREES
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
    Ok(Light {
        kind,
        position: origin,
        direction: forward,
        intensity: 1.0,
    })
}

/// Most bytes of a buffer, whether a file or a `data:` URI (the scene files' limit).
const MAX_BUFFER_BYTES: u64 = super::mesh::MAX_OBJ_BYTES;

/// Deepest node graph taken (a cycle is refused by name before this).
const MAX_NODE_DEPTH: usize = 256;

/// Most node visits, instances included.
const MAX_NODE_VISITS: u64 = 1_000_000;

/// Every buffer's bytes: the GLB's binary chunk, a `data:` URI or a file inside the glTF
/// file's folder, at least its `byteLength` long.
fn load_buffers(path: &Path, doc: &gltf::Document, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>, Error> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        let (data, source) = match b.source() {
            gltf::buffer::Source::Bin => (
                blob.take().ok_or_else(|| {
                    Error::scene(
                        path,
                        format!("buffer {}: has no uri, and the file has no binary chunk", b.index()),
                    )
                })?,
                "the binary chunk".to_string(),
            ),
            gltf::buffer::Source::Uri(uri) => (
                read_uri(path, uri)
                    .map_err(|why| Error::scene(path, format!("buffer {}: uri '{uri}': {why}", b.index())))?,
                format!("uri '{uri}'"),
            ),
        };
        if data.len() < b.length() {
            return Err(Error::scene(
                path,
                format!(
                    "buffer {} ({source}) has {} bytes, fewer than its byteLength {}",
                    b.index(),
                    data.len(),
                    b.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes a buffer URI names, or why it is refused: `data:` URIs in base64 (bounded), or
/// a relative path (percent-decoded) to a regular file inside the glTF file's folder or its
/// subfolders. Other schemes, absolute paths, `..` and links out of the folder are refused.
fn read_uri(gltf_path: &Path, uri: &str) -> Result<Vec<u8>, Reason> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, payload) = rest.split_once(',').ok_or("a data URI without a ','")?;
        if !meta.ends_with(";base64") {
            return Err("only base64 data URIs are read".into());
        }
        if payload.len() as u64 / 4 * 3 > MAX_BUFFER_BYTES {
            return Err(format!("decodes to more than {MAX_BUFFER_BYTES} bytes").into());
        }
        return base64_decode(payload);
    }
    if let Some(i) = uri.find(':') {
        if !uri[..i].contains('/') {
            return Err(format!(
                "the scheme '{}:' is not read (only relative paths inside the glTF file's folder, and data: URIs)",
                &uri[..i]
            )
            .into());
        }
    }
    let decoded = percent_decode(uri)?;
    let rel = Path::new(&decoded);
    for c in rel.components() {
        match c {
            std::path::Component::Normal(_) | std::path::Component::CurDir => {}
            std::path::Component::ParentDir => return Err("'..' climbs out of the glTF file's folder".into()),
            _ => return Err("an absolute path (only paths inside the glTF file's folder are read)".into()),
        }
    }
    let base = gltf_path.parent().unwrap_or(Path::new("."));
    let base = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    let full = base.join(rel);
    // A link inside the folder may point out of it: compare the resolved paths.
    let (real_base, real) = (
        base.canonicalize().map_err(|e| format!("{}: {e}", base.display()))?,
        full.canonicalize().map_err(|e| format!("{}: {e}", full.display()))?,
    );
    if !real.starts_with(&real_base) {
        return Err(format!("{} leads out of the glTF file's folder", full.display()).into());
    }
    super::read::read_regular(&full, "glTF buffer", MAX_BUFFER_BYTES).map_err(|e| Reason(e.to_string()))
}

/// `%XX` escapes of a URI decoded (the result must be UTF-8).
fn percent_decode(s: &str) -> Result<String, Reason> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("a bad percent escape at byte {i}"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    let s = String::from_utf8(out).map_err(|_| "its percent escapes do not decode to UTF-8".to_string())?;
    if s.contains('\0') {
        return Err("it holds a NUL character".into());
    }
    Ok(s)
}

/// Standard base64 (RFC 4648, `=` padding optional), or which character is wrong.
fn base64_decode(s: &str) -> Result<Vec<u8>, Reason> {
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let data = s.trim_end_matches('=').as_bytes();
    if s.len() - data.len() > 2 || data.len() % 4 == 1 {
        return Err("base64 of a length no data has".into());
    }
    let mut out = Vec::with_capacity(data.len() / 4 * 3 + 2);
    for (k, chunk) in data.chunks(4).enumerate() {
        let mut acc = 0u32;
        for (j, &c) in chunk.iter().enumerate() {
            let v = value(c).ok_or_else(|| format!("base64 has the character {:?} at {}", c as char, k * 4 + j))?;
            acc |= v << (18 - 6 * j);
        }
        let bytes = acc.to_be_bytes();
        out.extend_from_slice(&bytes[1..chunk.len()]);
    }
    Ok(out)
}

/// Checks the scene's node graph before anything is built: no cycle, at most
/// [`MAX_NODE_DEPTH`] deep, at most [`MAX_NODE_VISITS`] node instances, every accessor a
/// primitive reads valid ([`check_accessor`]), and the triangles of every instance within
/// the scene's budget.
fn check_graph(path: &Path, scene: &gltf::Scene, buffers: &[Vec<u8>]) -> Result<(), Error> {
    // Per node: (visits, triangles) of its subtree; None while it is being counted.
    let mut memo: std::collections::HashMap<usize, Option<(u64, u64)>> = std::collections::HashMap::new();
    fn count(
        path: &Path,
        node: gltf::Node,
        depth: usize,
        memo: &mut std::collections::HashMap<usize, Option<(u64, u64)>>,
        buffers: &[Vec<u8>],
    ) -> Result<(u64, u64), Error> {
        let name = format!("node {} {}", node.index(), quoted(node.name().unwrap_or("")));
        match memo.get(&node.index()) {
            Some(Some(c)) => return Ok(*c),
            Some(None) => return Err(Error::scene(path, format!("{name} is its own descendant (a cycle)"))),
            None => {}
        }
        if depth > MAX_NODE_DEPTH {
            return Err(Error::scene(
                path,
                format!("{name} is more than {MAX_NODE_DEPTH} levels deep in the node graph"),
            ));
        }
        memo.insert(node.index(), None);
        let mut tris = 0u64;
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let what = format!("{name}, mesh {}, primitive {}", mesh.index(), prim.index());
                let pos = prim
                    .get(&gltf::Semantic::Positions)
                    .ok_or_else(|| Error::scene(path, format!("{what}: no POSITION attribute")))?;
                check_accessor(
                    path,
                    &what,
                    "POSITION",
                    &pos,
                    buffers,
                    &[(DataType::F32, Dimensions::Vec3)],
                )?;
                if let Some(n) = prim.get(&gltf::Semantic::Normals) {
                    check_accessor(path, &what, "NORMAL", &n, buffers, &[(DataType::F32, Dimensions::Vec3)])?;
                }
                let corners = match prim.indices() {
                    Some(ix) => {
                        let ok = [DataType::U8, DataType::U16, DataType::U32].map(|t| (t, Dimensions::Scalar));
                        check_accessor(path, &what, "indices", &ix, buffers, &ok)?;
                        ix.count()
                    }
                    None => pos.count(),
                };
                tris += corners as u64 / 3;
            }
        }
        let mut visits = 1u64;
        for child in node.children() {
            let (v, t) = count(path, child, depth + 1, memo, buffers)?;
            visits = visits.saturating_add(v);
            tris = tris.saturating_add(t);
        }
        memo.insert(node.index(), Some((visits, tris)));
        Ok((visits, tris))
    }
    let (mut visits, mut tris) = (0u64, 0u64);
    for node in scene.nodes() {
        let (v, t) = count(path, node, 0, &mut memo, buffers)?;
        visits = visits.saturating_add(v);
        tris = tris.saturating_add(t);
    }
    if visits > MAX_NODE_VISITS {
        return Err(Error::scene(
            path,
            format!("the node graph makes {visits} node instances, more than {MAX_NODE_VISITS}"),
        ));
    }
    let budget = super::limits::triangle_budget();
    if tris > budget {
        return Err(Error::scene(
            path,
            format!("the node graph makes {tris} triangles (instances included), beyond the budget of {budget} (raise it with PENUMBRA_MAX_TRIANGLES)"),
        ));
    }
    Ok(())
}

use gltf::accessor::{DataType, Dimensions};

/// Checks accessor `acc`, read as `role` of `what`, before any reader sees it: one of the
/// component types and shapes `want`, not sparse, with a buffer view whose elements (offset,
/// stride, count) lie inside the view, and a view inside its buffer.
fn check_accessor(
    path: &Path,
    what: &str,
    role: &str,
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
    want: &[(DataType, Dimensions)],
) -> Result<(), Error> {
    let err = |why: String| {
        Err(Error::scene(
            path,
            format!("{what}: accessor {} ({role}): {why}", acc.index()),
        ))
    };
    if !want.contains(&(acc.data_type(), acc.dimensions())) {
        let names: Vec<String> = want.iter().map(|(t, d)| format!("{t:?} {d:?}")).collect();
        return err(format!(
            "is {:?} {:?}, not {}",
            acc.data_type(),
            acc.dimensions(),
            names.join(" or ")
        ));
    }
    if acc.sparse().is_some() {
        return err("sparse accessors are not read".into());
    }
    let Some(view) = acc.view() else {
        return err("has no bufferView".into());
    };
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return err(format!(
            "bufferView {} has byteStride {stride}, less than its {elem}-byte elements",
            view.index()
        ));
    }
    let count = acc.count();
    let need = match count {
        0 => Some(0),
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|v| v.checked_add(acc.offset() + elem)),
    };
    match need {
        Some(need) if need <= view.length() => {}
        _ => {
            return err(format!(
            "{count} elements of {elem} bytes (stride {stride}) from byteOffset {} run past bufferView {}'s {} bytes",
            acc.offset(),
            view.index(),
            view.length()
        ))
        }
    }
    let buffer = view.buffer();
    let have = buffers.get(buffer.index()).map_or(0, |b| b.len());
    if view.offset().checked_add(view.length()).is_none_or(|end| end > have) {
        return err(format!(
            "bufferView {} (byteOffset {}, byteLength {}) runs past buffer {}'s {have} bytes",
            view.index(),
            view.offset(),
            view.length(),
            buffer.index()
        ));
    }
    Ok(())
}
