//! The scene file format (TOML). Every error names the file, the line and the field.
//!
//! ```toml
//! # A box resting on a plane: contact shadows, Peter Panning.   <- the opening comment
//! [camera]
//! position = [4, 3, 6]
//! target = [0, 0.5, 0]
//! fov = 45                # vertical, degrees; also: up = [0, 1, 0], near, far
//! resolution = [640, 360]
//!
//! [[light]]
//! type = "directional"    # directional | spot | point | disk | sphere | rectangle
//! direction = [-0.4, -1, -0.3]   # or target = [...]; spot: angle = 60; area: radius / size
//!
//! [[material]]
//! name = "ground"
//! albedo = [0.8, 0.8, 0.8] # also: opacity = 1, two_sided = false, transmittance = [r, g, b]
//!
//! [[object]]
//! mesh = "plane"          # plane | box | sphere | cylinder | heightfield | pleated | file.obj
//! size = [10, 10]
//! material = "ground"     # also: translate, rotate (degrees x, y, z), scale, and per-mesh
//!                         # subdivisions, stacks, slices, segments, radius, height, amplitude,
//!                         # seed, pleats
//!
//! [[camera_path]]         # optional keyframes
//! position = [4, 3, 6]
//! target = [0, 0.5, 0]
//! ```

use super::mesh;
use super::*;
use glam::{EulerRot, Mat4, Quat, Vec2, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Largest image side a scene may ask for.
pub const MAX_RESOLUTION: u32 = 8192;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    /// A glTF file whose objects, materials, lights and camera the scene takes (see [`parse`]).
    gltf: Option<Spanned<String>>,
    camera: Option<Spanned<RawCamera>>,
    #[serde(default, rename = "light")]
    lights: Vec<Spanned<RawLight>>,
    #[serde(default, rename = "material")]
    materials: Vec<Spanned<RawMaterial>>,
    #[serde(default, rename = "object")]
    objects: Vec<Spanned<RawObject>>,
    #[serde(default)]
    camera_path: Vec<Spanned<RawKey>>,
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    near: Option<f32>,
    far: Option<f32>,
    resolution: Option<[u32; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(rename = "type")]
    kind: String,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    angle: Option<f32>,
    radius: Option<f32>,
    size: Option<[f32; 2]>,
    intensity: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    name: String,
    albedo: Option<[f32; 3]>,
    opacity: Option<f32>,
    transmittance: Option<[f32; 3]>,
    two_sided: Option<bool>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum NumOrVec {
    Num(f32),
    Vec(Vec<f32>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObject {
    name: Option<String>,
    mesh: String,
    size: Option<NumOrVec>,
    radius: Option<f32>,
    height: Option<f32>,
    subdivisions: Option<u32>,
    stacks: Option<u32>,
    slices: Option<u32>,
    segments: Option<u32>,
    amplitude: Option<f32>,
    seed: Option<u64>,
    pleats: Option<u32>,
    material: Option<String>,
    translate: Option<[f32; 3]>,
    rotate: Option<[f32; 3]>,
    scale: Option<NumOrVec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKey {
    position: [f32; 3],
    target: [f32; 3],
}

/// Where in which file: builds error messages.
struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Ctx<'_> {
    fn line(&self, offset: usize) -> usize {
        self.text[..offset.min(self.text.len())].matches('\n').count() + 1
    }

    fn err<T>(
        &self,
        span: std::ops::Range<usize>,
        what: &str,
        field: &str,
        msg: impl std::fmt::Display,
    ) -> Result<T, String> {
        Err(format!(
            "{}:{}: {what}, field `{field}`: {msg}",
            self.path.display(),
            self.line(span.start)
        ))
    }
}

fn finite3(v: [f32; 3]) -> Option<Vec3> {
    let v = Vec3::from(v);
    v.is_finite().then_some(v)
}

/// Loads a scene file. Relative OBJ paths resolve against the file's folder.
pub fn load(path: &Path) -> Result<Scene, String> {
    load_with_text(path).map(|(s, _)| s)
}

/// [`load`], also returning the scene's text (for a glTF file, the one-line scene that
/// stands for it).
pub fn load_with_text(path: &Path) -> Result<(Scene, String), String> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if matches!(ext.as_deref(), Some("gltf" | "glb")) {
        // A glTF file alone is the scene `gltf = "<its name>"`.
        let file = path
            .file_name()
            .map_or(String::new(), |f| f.to_string_lossy().into_owned());
        let text = format!("# {file} (glTF)\ngltf = {}\n", toml::Value::String(file.clone()));
        return parse(&text, path).map(|s| (s, text));
    }
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read scene file: {e}", path.display()))?;
    parse(&text, path).map(|s| (s, text))
}

/// Parses scene text; `path` names the file in errors and anchors relative OBJ and glTF paths.
///
/// A top-level `gltf = "file.glb"` (or `.gltf`) takes that file's primitives as objects after
/// the `[[object]]`s, its materials after the `[[material]]`s, its punctual lights when the
/// scene has no `[[light]]`, and its first perspective camera when the scene has no
/// `[camera]` ([`super::gltf`]).
pub fn parse(text: &str, path: &Path) -> Result<Scene, String> {
    let ctx = Ctx { path, text };
    let raw: RawScene = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| ctx.line(s.start)).unwrap_or(0);
        format!("{}:{line}: {}", path.display(), e.message())
    })?;
    let description: String = text
        .lines()
        .take_while(|l| l.trim_start().starts_with('#'))
        .map(|l| l.trim_start().trim_start_matches('#').trim())
        .collect::<Vec<_>>()
        .join(" ");

    // glTF.
    let dir = path.parent().unwrap_or(Path::new("."));
    let gltf = match &raw.gltf {
        None => None,
        Some(g) => {
            Some(super::gltf::load(&dir.join(g.get_ref())).or_else(|e| ctx.err(g.span(), "top level", "gltf", e))?)
        }
    };

    // Camera.
    let (cs, c) = match (&raw.camera, &gltf) {
        (Some(c), _) => (c.span(), c.get_ref().clone()),
        (None, Some(g)) => match g.camera {
            Some(gc) => (
                raw.gltf.as_ref().map_or(0..0, |g| g.span()),
                RawCamera {
                    position: gc.position.to_array(),
                    target: gc.target.to_array(),
                    up: Some(gc.up.to_array()),
                    fov: Some(gc.fov_deg),
                    near: Some(gc.near),
                    far: gc.far.or(Some(gc.near * 1e4)),
                    resolution: g.scene_camera(None).map(|c| [c.width, c.height]),
                },
            ),
            None => {
                return Err(format!(
                    "{}: the scene has no [camera] and its glTF file has no perspective camera",
                    path.display()
                ))
            }
        },
        (None, None) => return Err(format!("{}: the scene has no [camera]", path.display())),
    };
    let cam = "[camera]";
    let position = finite3(c.position).map_or_else(|| ctx.err(cs.clone(), cam, "position", "not finite"), Ok)?;
    let target = finite3(c.target).map_or_else(|| ctx.err(cs.clone(), cam, "target", "not finite"), Ok)?;
    if (target - position).length() < 1e-6 {
        return ctx.err(cs, cam, "target", "equals the position");
    }
    let up = finite3(c.up.unwrap_or([0.0, 1.0, 0.0])).unwrap_or(Vec3::ZERO);
    if up.length() < 1e-6 || up.normalize().cross((target - position).normalize()).length() < 1e-4 {
        return ctx.err(cs, cam, "up", "zero, not finite, or parallel to the view direction");
    }
    let fov = c.fov.unwrap_or(45.0);
    if !(fov > 0.0 && fov < 180.0) {
        return ctx.err(cs, cam, "fov", format!("{fov} is outside (0, 180) degrees"));
    }
    let (near, far) = (c.near.unwrap_or(0.1), c.far.unwrap_or(100.0));
    if !(near > 0.0 && near.is_finite()) {
        return ctx.err(cs, cam, "near", format!("{near} must be positive"));
    }
    if !(far > near && far.is_finite()) {
        return ctx.err(cs, cam, "far", format!("{far} must be finite and beyond near ({near})"));
    }
    let [width, height] = c.resolution.unwrap_or([640, 360]);
    if width == 0 || height == 0 || width > MAX_RESOLUTION || height > MAX_RESOLUTION {
        return ctx.err(
            cs,
            cam,
            "resolution",
            format!("{width}x{height} (each side must be 1..={MAX_RESOLUTION})"),
        );
    }
    let camera = Camera {
        position,
        target,
        up,
        fov_deg: fov,
        near,
        far,
        width,
        height,
    };

    // Materials.
    let mut materials = vec![Material::default()];
    for (i, m) in raw.materials.iter().enumerate() {
        let (s, m) = (m.span(), m.get_ref());
        let what = format!("[[material]] #{} '{}'", i + 1, m.name);
        let albedo =
            finite3(m.albedo.unwrap_or([0.8, 0.8, 0.8])).filter(|a| a.min_element() >= 0.0 && a.max_element() <= 1.0);
        let Some(albedo) = albedo else {
            return ctx.err(s, &what, "albedo", "each channel must be in [0, 1]");
        };
        let opacity = m.opacity.unwrap_or(1.0);
        if !(0.0..=1.0).contains(&opacity) {
            return ctx.err(s, &what, "opacity", format!("{opacity} is outside [0, 1]"));
        }
        let transmittance = match m.transmittance {
            None => None,
            Some(t) => match finite3(t).filter(|t| t.min_element() >= 0.0 && t.max_element() <= 1.0) {
                Some(t) => Some(t),
                None => return ctx.err(s, &what, "transmittance", "each channel must be in [0, 1]"),
            },
        };
        if materials.iter().any(|x| x.name == m.name) {
            return ctx.err(s, &what, "name", "used by an earlier material");
        }
        materials.push(Material {
            name: m.name.clone(),
            albedo,
            opacity,
            transmittance,
            two_sided: m.two_sided.unwrap_or(false),
        });
    }

    // Objects.
    let mut objects = Vec::new();
    for (i, o) in raw.objects.iter().enumerate() {
        let (s, o) = (o.span(), o.get_ref());
        let what = format!("[[object]] #{} ({})", i + 1, o.mesh);
        let num = |v: Option<f32>, field: &str, default: f32| -> Result<f32, String> {
            let v = v.unwrap_or(default);
            if v.is_finite() && v > 0.0 && v < 1e6 {
                Ok(v)
            } else {
                ctx.err(s.clone(), &what, field, format!("{v} must be positive and below 1e6"))
            }
        };
        let size_vec = |n: usize, default: &[f32]| -> Result<Vec<f32>, String> {
            let v = match &o.size {
                None => default.to_vec(),
                Some(NumOrVec::Num(x)) => vec![*x; n],
                Some(NumOrVec::Vec(v)) if v.len() == n => v.clone(),
                Some(NumOrVec::Vec(v)) => {
                    return ctx.err(s.clone(), &what, "size", format!("needs {n} numbers, got {}", v.len()))
                }
            };
            if v.iter().all(|x| x.is_finite() && *x > 0.0 && *x < 1e6) {
                Ok(v)
            } else {
                ctx.err(s.clone(), &what, "size", "every entry must be positive and below 1e6")
            }
        };
        let count = |v: Option<u32>, field: &str, default: u32, max: u32| -> Result<u32, String> {
            let v = v.unwrap_or(default);
            if (1..=max).contains(&v) {
                Ok(v)
            } else {
                ctx.err(s.clone(), &what, field, format!("{v} is outside 1..={max}"))
            }
        };
        let mesh = match o.mesh.as_str() {
            "plane" => {
                let sz = size_vec(2, &[10.0, 10.0])?;
                mesh::plane(Vec2::new(sz[0], sz[1]), count(o.subdivisions, "subdivisions", 1, 1024)?)
            }
            "box" => {
                let sz = size_vec(3, &[1.0, 1.0, 1.0])?;
                mesh::cuboid(Vec3::new(sz[0], sz[1], sz[2]))
            }
            "sphere" => mesh::sphere(
                num(o.radius, "radius", 0.5)?,
                count(o.stacks, "stacks", 24, 2048)?,
                count(o.slices, "slices", 48, 4096)?,
            ),
            "cylinder" => mesh::cylinder(
                num(o.radius, "radius", 0.5)?,
                num(o.height, "height", 1.0)?,
                count(o.segments, "segments", 32, 4096)?,
            ),
            "heightfield" => {
                let sz = size_vec(2, &[20.0, 20.0])?;
                let amp = o.amplitude.unwrap_or(1.0);
                if !(amp.is_finite() && amp.abs() < 1e6) {
                    return ctx.err(s, &what, "amplitude", format!("{amp} is not a finite height"));
                }
                mesh::heightfield(
                    Vec2::new(sz[0], sz[1]),
                    count(o.subdivisions, "subdivisions", 64, 1024)?,
                    amp,
                    o.seed.unwrap_or(1),
                )
            }
            "pleated" => {
                let sz = size_vec(2, &[4.0, 2.0])?;
                let amp = o.amplitude.unwrap_or(0.2);
                if !(amp.is_finite() && amp.abs() < 1e6) {
                    return ctx.err(s, &what, "amplitude", format!("{amp} is not a finite height"));
                }
                let pleats = count(o.pleats, "pleats", 6, 1024)?;
                mesh::pleated(
                    Vec2::new(sz[0], sz[1]),
                    count(o.subdivisions, "subdivisions", 16 * pleats, 4096)?,
                    amp,
                    pleats,
                )
            }
            p if p.to_ascii_lowercase().ends_with(".obj") => {
                let full: PathBuf = dir.join(p);
                mesh::load_obj(&full).or_else(|e| ctx.err(s.clone(), &what, "mesh", e))?
            }
            p if p.to_ascii_lowercase().ends_with(".gltf") || p.to_ascii_lowercase().ends_with(".glb") => {
                let full: PathBuf = dir.join(p);
                super::gltf::load(&full)
                    .map(|g| g.merged())
                    .or_else(|e| ctx.err(s.clone(), &what, "mesh", e))?
            }
            other => {
                return ctx.err(
                    s,
                    &what,
                    "mesh",
                    format!(
                        "unknown mesh '{other}' (plane, box, sphere, cylinder, heightfield, pleated, or a .obj, .gltf or .glb path)"
                    ),
                )
            }
        };
        let t = finite3(o.translate.unwrap_or([0.0; 3]))
            .map_or_else(|| ctx.err(s.clone(), &what, "translate", "not finite"), Ok)?;
        let r = finite3(o.rotate.unwrap_or([0.0; 3]))
            .map_or_else(|| ctx.err(s.clone(), &what, "rotate", "not finite"), Ok)?;
        let sc = match &o.scale {
            None => Vec3::ONE,
            Some(NumOrVec::Num(x)) => Vec3::splat(*x),
            Some(NumOrVec::Vec(v)) if v.len() == 3 => Vec3::new(v[0], v[1], v[2]),
            Some(NumOrVec::Vec(_)) => return ctx.err(s, &what, "scale", "needs 1 or 3 numbers"),
        };
        if !sc.is_finite() || sc.abs().min_element() < 1e-6 {
            return ctx.err(s, &what, "scale", "must be finite and non-zero");
        }
        let rot = Quat::from_euler(EulerRot::XYZ, r.x.to_radians(), r.y.to_radians(), r.z.to_radians());
        let m = Mat4::from_scale_rotation_translation(sc, rot, t);
        let material = match &o.material {
            None => 0,
            Some(name) => match materials.iter().position(|m| &m.name == name) {
                Some(k) => k,
                None => return ctx.err(s, &what, "material", format!("no material named '{name}'")),
            },
        };
        objects.push(Object {
            name: o.name.clone().unwrap_or_else(|| format!("object{}", i + 1)),
            mesh: mesh.transformed(m),
            material,
        });
    }

    // The glTF's objects and materials, after the file's own.
    let mut gltf_lights = Vec::new();
    if let Some(g) = gltf {
        let base = materials.len();
        for mut m in g.materials {
            while materials.iter().any(|x| x.name == m.name) {
                m.name = format!("gltf:{}", m.name);
            }
            materials.push(m);
        }
        for o in g.objects {
            objects.push(Object {
                name: o.name,
                mesh: o.mesh,
                material: base + o.material,
            });
        }
        gltf_lights = g.lights;
    }

    // Lights.
    let center = objects
        .iter()
        .filter_map(|o| o.mesh.bounds())
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
        .map_or(Vec3::ZERO, |(a, b)| (a + b) * 0.5);
    let mut lights = Vec::new();
    for (i, l) in raw.lights.iter().enumerate() {
        let (s, l) = (l.span(), l.get_ref());
        let what = format!("[[light]] #{} ({})", i + 1, l.kind);
        let pos = match l.position {
            Some(p) => Some(finite3(p).map_or_else(|| ctx.err(s.clone(), &what, "position", "not finite"), Ok)?),
            None => None,
        };
        let dir = match (l.direction, l.target, pos) {
            (Some(d), _, _) => finite3(d),
            (None, Some(t), Some(p)) => finite3(t).map(|t| t - p),
            (None, None, Some(p)) => Some(center - p),
            _ => None,
        };
        let Some(dir) = dir.filter(|d| d.length() > 1e-6).map(|d| d.normalize()) else {
            return ctx.err(
                s,
                &what,
                "direction",
                "missing, zero or not finite (give direction, or position and target)",
            );
        };
        let radius = |default: f32| -> Result<f32, String> {
            let r = l.radius.unwrap_or(default);
            if r.is_finite() && r > 0.0 {
                Ok(r)
            } else {
                ctx.err(s.clone(), &what, "radius", format!("{r} must be positive"))
            }
        };
        let kind = match l.kind.as_str() {
            "directional" => LightKind::Directional,
            "spot" => {
                let a = l.angle.unwrap_or(60.0);
                if !(a > 0.0 && a < 180.0) {
                    return ctx.err(s, &what, "angle", format!("{a} is outside (0, 180) degrees"));
                }
                LightKind::Spot { angle_deg: a }
            }
            "point" => LightKind::Point,
            "disk" => LightKind::Area(AreaShape::Disk { radius: radius(0.25)? }),
            "sphere" => LightKind::Area(AreaShape::Sphere { radius: radius(0.25)? }),
            "rectangle" => {
                let [w, h] = l.size.unwrap_or([0.5, 0.5]);
                if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
                    return ctx.err(s, &what, "size", "both sides must be positive");
                }
                LightKind::Area(AreaShape::Rectangle { width: w, height: h })
            }
            other => {
                return ctx.err(
                    s,
                    &what,
                    "type",
                    format!("unknown light type '{other}' (directional, spot, point, disk, sphere, rectangle)"),
                )
            }
        };
        let position = match (kind, pos) {
            (_, Some(p)) => p,
            (LightKind::Directional, None) => center - dir * 100.0,
            (_, None) => return ctx.err(s, &what, "position", "a positional light needs a position"),
        };
        let intensity = l.intensity.unwrap_or(1.0);
        if !(intensity.is_finite() && intensity >= 0.0) {
            return ctx.err(
                s,
                &what,
                "intensity",
                format!("{intensity} must be finite and non-negative"),
            );
        }
        lights.push(Light {
            kind,
            position,
            direction: dir,
            intensity,
        });
    }
    if lights.is_empty() {
        lights = gltf_lights;
    }
    if lights.is_empty() {
        return Err(format!("{}: the scene has no [[light]]", path.display()));
    }
    if objects.is_empty() {
        return Err(format!("{}: the scene has no [[object]]", path.display()));
    }
    let mut camera_path = Vec::new();
    for (i, k) in raw.camera_path.iter().enumerate() {
        let (s, k) = (k.span(), k.get_ref());
        let what = format!("[[camera_path]] #{}", i + 1);
        let (Some(position), Some(target)) = (finite3(k.position), finite3(k.target)) else {
            return ctx.err(s, &what, "position", "position and target must be finite");
        };
        camera_path.push(Keyframe { position, target });
    }
    let name = path
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    Ok(Scene {
        name,
        description,
        objects,
        materials,
        camera,
        lights,
        camera_path,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const OK: &str = r#"# A box on a plane.
[camera]
position = [4, 3, 6]
target = [0, 0.5, 0]
resolution = [64, 32]

[[light]]
type = "directional"
direction = [-0.4, -1, -0.3]

[[material]]
name = "ground"
albedo = [0.5, 0.5, 0.5]

[[object]]
mesh = "plane"
size = [10, 10]
material = "ground"

[[object]]
mesh = "box"
size = 1
translate = [0, 0.5, 0]
"#;

    fn err(text: &str) -> String {
        parse(text, Path::new("s.toml")).unwrap_err()
    }

    #[test]
    fn parses_a_scene() {
        let s = parse(OK, Path::new("dir/boxes.toml")).unwrap();
        assert_eq!(s.name, "boxes");
        assert_eq!(s.description, "A box on a plane.");
        assert_eq!(s.objects.len(), 2);
        assert_eq!(s.triangles(), 2 + 12);
        assert_eq!(s.objects[0].material, 1);
        assert_eq!((s.camera.width, s.camera.height), (64, 32));
        let (lo, hi) = s.bounds().unwrap();
        assert_eq!((lo.y, hi.y), (0.0, 1.0));
    }

    #[test]
    fn coloured_transmittance_is_parsed_and_checked() {
        let glass = OK.replace(
            "[[material]]\nname = \"ground\"",
            "[[material]]\nname = \"ground\"\ntransmittance = [1, 0.5, 0]",
        );
        let s = parse(&glass, Path::new("s.toml")).unwrap();
        let m = s.materials.iter().find(|m| m.name == "ground").unwrap();
        assert_eq!(m.transmittance_rgb(), glam::Vec3::new(1.0, 0.5, 0.0));
        assert_eq!(s.materials[0].transmittance_rgb(), glam::Vec3::ZERO, "opaque default");
        let e = err(&glass.replace("[1, 0.5, 0]", "[1, 2, 0]"));
        assert!(
            e.contains("field `transmittance`: each channel must be in [0, 1]"),
            "{e}"
        );
        let e = err(&glass.replace("[1, 0.5, 0]", "[1, nan, 0]"));
        assert!(e.contains("transmittance"), "{e}");
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let e = err(&OK.replace("size = [10, 10]", "size = [10, -1]"));
        assert!(e.starts_with("s.toml:15: [[object]] #1 (plane), field `size`"), "{e}");
        let e = err(&OK.replace("material = \"ground\"", "material = \"stone\""));
        assert!(e.contains("field `material`: no material named 'stone'"), "{e}");
        let e = err(&OK.replace("resolution = [64, 32]", "resolution = [0, 32]"));
        assert!(e.starts_with("s.toml:2: [camera], field `resolution`"), "{e}");
        let e = err(&OK.replace("type = \"directional\"", "type = \"laser\""));
        assert!(e.contains("unknown light type 'laser'"), "{e}");
        let e = err(&OK.replace("mesh = \"box\"", "mesh = \"teapot\""));
        assert!(e.contains("unknown mesh 'teapot'"), "{e}");
        let e = err(&OK.replace("target = [0, 0.5, 0]", "target = [0, nan, 0]"));
        assert!(e.contains("field `target`: not finite"), "{e}");
        let e = err(&OK.replace("size = 1", "sise = 1"));
        assert!(e.starts_with("s.toml:") && e.contains("sise"), "{e}");
        let e = err(&OK.replace("mesh = \"box\"", "mesh = \"missing.obj\""));
        assert!(e.contains("missing.obj") && e.contains("field `mesh`"), "{e}");
        let e = err("[camera]\nposition = [1, 2, 3]\n");
        assert!(e.contains("target"), "{e}");
        let e = err(&OK.replace("[camera]", "[camera\n"));
        assert!(e.starts_with("s.toml:2:"), "{e}");
    }
}
