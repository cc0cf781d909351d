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
//! mesh = "plane"          # plane | box | sphere | cylinder | cone | heightfield | pleated | file.obj
//! size = [10, 10]
//! material = "ground"     # also: translate, rotate (degrees x, y, z), scale, and per-mesh
//!                         # subdivisions, stacks, slices, segments, radius, height, amplitude,
//!                         # seed, pleats
//!
//! [[camera_path]]         # optional keyframes
//! position = [4, 3, 6]
//! target = [0, 0.5, 0]
//!
//! [[light_path]]          # optional keyframes of the light: direction (directional), or
//! direction = [-0.4, -1, -0.3]   # position and optionally direction (the others)
//! ```

use super::mesh;
use super::*;
use crate::error::quoted;
use crate::error::Reason;
use crate::Error;
use glam::{EulerRot, Mat4, Quat, Vec2, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use toml::Spanned;

pub use super::limits::*;
pub use super::read::{check_regular, read_regular, read_unlinked};

/// A list of exactly `N` values (TOML arrays with more or fewer are errors, not truncated).
fn exact<'de, D: serde::Deserializer<'de>, T: Deserialize<'de>, const N: usize>(d: D) -> Result<[T; N], D::Error> {
    let v: Vec<T> = Vec::deserialize(d)?;
    let n = v.len();
    v.try_into()
        .map_err(|_| serde::de::Error::custom(format!("expected a list of {N} values, got {n}")))
}

fn exact_opt<'de, D: serde::Deserializer<'de>, T: Deserialize<'de>, const N: usize>(
    d: D,
) -> Result<Option<[T; N]>, D::Error> {
    exact::<D, T, N>(d).map(Some)
}

#[derive(Default, Deserialize)]
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
    #[serde(default)]
    light_path: Vec<Spanned<RawLightKey>>,
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    #[serde(deserialize_with = "exact")]
    position: [f32; 3],
    #[serde(deserialize_with = "exact")]
    target: [f32; 3],
    #[serde(default, deserialize_with = "exact_opt")]
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    near: Option<f32>,
    far: Option<f32>,
    #[serde(default, deserialize_with = "exact_opt")]
    resolution: Option<[u32; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(rename = "type")]
    kind: String,
    #[serde(default, deserialize_with = "exact_opt")]
    position: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "exact_opt")]
    direction: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "exact_opt")]
    target: Option<[f32; 3]>,
    angle: Option<f32>,
    radius: Option<f32>,
    #[serde(default, deserialize_with = "exact_opt")]
    size: Option<[f32; 2]>,
    intensity: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    name: String,
    #[serde(default, deserialize_with = "exact_opt")]
    albedo: Option<[f32; 3]>,
    opacity: Option<f32>,
    #[serde(default, deserialize_with = "exact_opt")]
    transmittance: Option<[f32; 3]>,
    two_sided: Option<bool>,
}

enum NumOrVec {
    Num(f32),
    Vec(Vec<f32>),
}

impl<'de> Deserialize<'de> for NumOrVec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = NumOrVec;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or a list of numbers")
            }
            fn visit_f64<E>(self, v: f64) -> Result<NumOrVec, E> {
                Ok(NumOrVec::Num(v as f32))
            }
            fn visit_i64<E>(self, v: i64) -> Result<NumOrVec, E> {
                Ok(NumOrVec::Num(v as f32))
            }
            fn visit_u64<E>(self, v: u64) -> Result<NumOrVec, E> {
                Ok(NumOrVec::Num(v as f32))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<NumOrVec, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<f32>()? {
                    v.push(x);
                }
                Ok(NumOrVec::Vec(v))
            }
        }
        d.deserialize_any(V)
    }
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
    #[serde(default, deserialize_with = "exact_opt")]
    translate: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "exact_opt")]
    rotate: Option<[f32; 3]>,
    scale: Option<NumOrVec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKey {
    #[serde(deserialize_with = "exact")]
    position: [f32; 3],
    #[serde(deserialize_with = "exact")]
    target: [f32; 3],
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLightKey {
    #[serde(default, deserialize_with = "exact_opt")]
    direction: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "exact_opt")]
    position: Option<[f32; 3]>,
}

/// Where in which file: builds error messages.
struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
    /// The scene is a glTF file alone: it has no lines of scene text to cite, so errors name
    /// the glTF file and the part of the scene (its camera, its lights) without a line.
    gltf_alone: bool,
    /// OBJ files held in memory (name, text), taken before the disk ([`parse_with_files`]).
    files: &'a [(String, String)],
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
    ) -> Result<T, Error> {
        Err(Error::Scene {
            file: self.path.into(),
            line: (!self.gltf_alone).then(|| self.line(span.start)),
            section: Some(what.to_string()),
            field: Some(field.to_string()),
            message: msg.to_string(),
        })
    }

    /// An error about the glTF file the scene names: at the scene's `gltf` field, or (a glTF
    /// file alone) at the glTF file itself.
    fn gltf_err<T>(&self, raw: &RawScene, msg: impl std::fmt::Display) -> Result<T, Error> {
        if self.gltf_alone {
            return Err(Error::scene(self.path, msg.to_string()));
        }
        self.err(raw.gltf.as_ref().map_or(0..0, |g| g.span()), "top level", "gltf", msg)
    }

    /// The `[camera]` section, or the glTF's first perspective camera without one.
    fn camera(&self, raw: &RawScene, gltf: Option<&super::gltf::GltfScene>) -> Result<Camera, Error> {
        let (cs, c, cam) = match (&raw.camera, gltf) {
            (Some(c), _) => (c.span(), c.get_ref().clone(), "[camera]"),
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
                    "the glTF's camera",
                ),
                None if self.gltf_alone => {
                    return Err(Error::scene(
                        self.path,
                        "the glTF file has no perspective camera (a scene file that names it with `gltf = \"...\"` can add a [camera])",
                    ))
                }
                None => {
                    return Err(Error::scene(
                        self.path,
                        "the scene has no [camera] and its glTF file has no perspective camera",
                    ))
                }
            },
            (None, None) => return Err(Error::scene(self.path, "the scene has no [camera]")),
        };
        let (position, target, up) = match check_view(c.position, c.target, c.up) {
            Ok(v) => v,
            Err((field, msg)) => return self.err(cs, cam, field, msg),
        };
        let fov = c.fov.unwrap_or(45.0);
        if !FOV_DEGREES.contains(&fov) {
            return self.err(cs, cam, "fov", format!("{} is outside {FOV_TEXT} degrees", shown(fov)));
        }
        let (near, far) = (c.near.unwrap_or(0.1), c.far.unwrap_or(100.0));
        if !(near > 0.0 && near.is_finite()) {
            return self.err(cs, cam, "near", format!("{near} must be positive"));
        }
        if !(far > near && far.is_finite()) {
            return self.err(cs, cam, "far", format!("{far} must be finite and beyond near ({near})"));
        }
        if far / near > MAX_DEPTH_RATIO {
            return self.err(
                cs,
                cam,
                "near",
                format!(
                    "{} is too close for far = {}: far / near may be at most {MAX_DEPTH_RATIO:e} (the depth buffer's precision)",
                    shown(near),
                    shown(far)
                ),
            );
        }
        let [width, height] = c.resolution.unwrap_or([640, 360]);
        if width == 0 || height == 0 || width > MAX_RESOLUTION || height > MAX_RESOLUTION {
            return self.err(
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
        Ok(camera)
    }

    /// The `[[material]]`s after the built-in one.
    fn materials(&self, raw: &RawScene) -> Result<Vec<Material>, Error> {
        let mut materials = vec![Material::default()];
        for (i, m) in raw.materials.iter().enumerate() {
            let (s, m) = (m.span(), m.get_ref());
            let what = format!("[[material]] #{} {}", i + 1, quoted(&m.name));
            let albedo = finite3(m.albedo.unwrap_or([0.8, 0.8, 0.8]))
                .filter(|a| a.min_element() >= 0.0 && a.max_element() <= 1.0);
            let Some(albedo) = albedo else {
                return self.err(s, &what, "albedo", "each channel must be in [0, 1]");
            };
            let opacity = m.opacity.unwrap_or(1.0);
            if !(0.0..=1.0).contains(&opacity) {
                return self.err(s, &what, "opacity", format!("{opacity} is outside [0, 1]"));
            }
            let transmittance = match m.transmittance {
                None => None,
                Some(t) => match finite3(t).filter(|t| t.min_element() >= 0.0 && t.max_element() <= 1.0) {
                    Some(t) => Some(t),
                    None => return self.err(s, &what, "transmittance", "each channel must be in [0, 1]"),
                },
            };
            // (The built-in material at index 0 has no name users can clash with.)
            if materials[1..].iter().any(|x| x.name == m.name) {
                return self.err(s, &what, "name", "used by an earlier material");
            }
            materials.push(Material {
                name: m.name.clone(),
                albedo,
                opacity,
                transmittance,
                two_sided: m.two_sided.unwrap_or(false),
            });
        }
        Ok(materials)
    }

    /// The `[[object]]`s (meshes under `dir`), counting their triangles into `triangles`
    /// against `budget`.
    fn objects(
        &self,
        raw: &RawScene,
        materials: &[Material],
        dir: &Path,
        (triangles, budget): (&mut u64, u64),
    ) -> Result<Vec<Object>, Error> {
        let mut objects: Vec<Object> = Vec::new();
        for (i, o) in raw.objects.iter().enumerate() {
            let (s, o) = (o.span(), o.get_ref());
            let what = format!("[[object]] #{} ({})", i + 1, o.mesh);
            let estimate = estimated_triangles(o);
            *triangles += estimate;
            if *triangles > budget {
                return self.err(
                    s,
                    &what,
                    "mesh",
                    format!(
                        "about {estimate} triangles here make {triangles} in the scene, beyond its budget of {budget} (lower stacks, slices, segments or subdivisions, or raise the budget with PENUMBRA_MAX_TRIANGLES)"
                    ),
                );
            }
            let mesh = self.object_mesh(s.clone(), &what, o, dir)?;
            let (m, t) = self.object_transform(s.clone(), &what, o)?;
            let material = match &o.material {
                None => 0,
                Some(name) => match materials[1..].iter().position(|m| &m.name == name) {
                    Some(k) => k + 1,
                    None => return self.err(s, &what, "material", format!("no material named {}", quoted(name))),
                },
            };
            let name = o.name.clone().unwrap_or_else(|| format!("object{}", i + 1));
            if let Some(j) = objects.iter().position(|x| x.name == name) {
                return self.err(
                    s,
                    &what,
                    "name",
                    format!(
                        "{} is also object #{}'s name (options such as receiver= and occluders= pick objects by name)",
                        quoted(&name),
                        j + 1
                    ),
                );
            }
            if estimate == 0 {
                // Files: their real count.
                *triangles += mesh.triangles() as u64;
                if *triangles > budget {
                    return self.err(
                        s,
                        &what,
                        "mesh",
                        format!("{} triangles make {triangles} in the scene, beyond its budget of {budget} (raise it with PENUMBRA_MAX_TRIANGLES)", mesh.triangles()),
                    );
                }
            }
            let mesh = mesh.transformed(m);
            if let Some(p) = mesh
                .positions
                .iter()
                .find(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE)
            {
                let field = if t.abs().max_element() > MAX_COORDINATE {
                    "translate"
                } else {
                    "scale"
                };
                return self.err(
                    s,
                    &what,
                    field,
                    format!("a vertex lands at {p} after the transform, beyond ±{MAX_COORDINATE:e} (the largest coordinate a scene may use)"),
                );
            }
            let heightfield = o.mesh == "heightfield";
            objects.push(Object {
                name,
                mesh,
                material,
                heightfield,
            });
        }
        Ok(objects)
    }

    /// The mesh of object `o` (`what`, at `s`): procedural with its parameters checked, or read
    /// from an OBJ or glTF file under `dir` (or from the files given with the text).
    fn object_mesh(&self, s: std::ops::Range<usize>, what: &str, o: &RawObject, dir: &Path) -> Result<Mesh, Error> {
        let num = |v: Option<f32>, field: &str, default: f32| -> Result<f32, Error> {
            let v = v.unwrap_or(default);
            if v.is_finite() && v > 0.0 && v < 1e6 {
                Ok(v)
            } else {
                self.err(s.clone(), what, field, format!("{v} must be positive and below 1e6"))
            }
        };
        let size_vec = |n: usize, default: &[f32]| -> Result<Vec<f32>, Error> {
            let v = match &o.size {
                None => default.to_vec(),
                Some(NumOrVec::Num(x)) => vec![*x; n],
                Some(NumOrVec::Vec(v)) if v.len() == n => v.clone(),
                Some(NumOrVec::Vec(v)) => {
                    return self.err(s.clone(), what, "size", format!("needs {n} numbers, got {}", v.len()))
                }
            };
            if v.iter().all(|x| x.is_finite() && *x > 0.0 && *x < 1e6) {
                Ok(v)
            } else {
                self.err(s.clone(), what, "size", "every entry must be positive and below 1e6")
            }
        };
        let count = |v: Option<u32>, field: &str, default: u32, max: u32| -> Result<u32, Error> {
            let v = v.unwrap_or(default);
            if (1..=max).contains(&v) {
                Ok(v)
            } else {
                self.err(s.clone(), what, field, format!("{v} is outside 1..={max}"))
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
            "cone" => mesh::cone(
                num(o.radius, "radius", 0.5)?,
                num(o.height, "height", 1.0)?,
                count(o.segments, "segments", 32, 4096)?,
            ),
            "heightfield" => {
                let sz = size_vec(2, &[20.0, 20.0])?;
                let amp = o.amplitude.unwrap_or(1.0);
                if !(amp.is_finite() && amp.abs() < 1e6) {
                    return self.err(s, what, "amplitude", format!("{amp} is not a finite height"));
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
                    return self.err(s, what, "amplitude", format!("{amp} is not a finite height"));
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
                match self.files.iter().find(|(name, _)| name == p) {
                    Some((_, text)) => mesh::obj_from_bytes(text.as_bytes(), &full),
                    None => mesh::load_obj(&full),
                }
                .or_else(|e| self.err(s.clone(), what, "mesh", e))?
            }
            p if p.to_ascii_lowercase().ends_with(".gltf") || p.to_ascii_lowercase().ends_with(".glb") => {
                let full: PathBuf = dir.join(p);
                super::gltf::load(&full)
                    .map(|g| g.merged())
                    .or_else(|e| self.err(s.clone(), what, "mesh", e))?
            }
            other => {
                return self.err(
                    s,
                    what,
                    "mesh",
                    format!(
                        "unknown mesh '{other}' (plane, box, sphere, cylinder, cone, heightfield, pleated, or a .obj, .gltf or .glb path)"
                    ),
                )
            }
        };
        Ok(mesh)
    }

    /// Object `o`'s transform (`what`, at `s`): translate, rotate (degrees x, y, z) and scale,
    /// each checked; with its translation.
    fn object_transform(&self, s: std::ops::Range<usize>, what: &str, o: &RawObject) -> Result<(Mat4, Vec3), Error> {
        let t = finite3(o.translate.unwrap_or([0.0; 3]))
            .map_or_else(|| self.err(s.clone(), what, "translate", "not finite"), Ok)?;
        let r = finite3(o.rotate.unwrap_or([0.0; 3]))
            .map_or_else(|| self.err(s.clone(), what, "rotate", "not finite"), Ok)?;
        let sc = match &o.scale {
            None => Vec3::ONE,
            Some(NumOrVec::Num(x)) => Vec3::splat(*x),
            Some(NumOrVec::Vec(v)) if v.len() == 3 => Vec3::new(v[0], v[1], v[2]),
            Some(NumOrVec::Vec(_)) => return self.err(s, what, "scale", "needs 1 or 3 numbers"),
        };
        if !sc.is_finite() || sc.abs().min_element() < 1e-6 {
            return self.err(s, what, "scale", "must be finite and non-zero");
        }
        let rot = Quat::from_euler(EulerRot::XYZ, r.x.to_radians(), r.y.to_radians(), r.z.to_radians());
        Ok((Mat4::from_scale_rotation_translation(sc, rot, t), t))
    }

    /// The glTF's materials and objects after the file's own (names made unique), counting
    /// its triangles into `triangles` against `budget`; its lights.
    fn add_gltf(
        &self,
        raw: &RawScene,
        g: super::gltf::GltfScene,
        (materials, objects): (&mut Vec<Material>, &mut Vec<Object>),
        (triangles, budget): (&mut u64, u64),
    ) -> Result<Vec<Light>, Error> {
        {
            let base = materials.len();
            let mut names = Names::of(materials.iter().map(|m| m.name.as_str()));
            for mut m in g.materials {
                m.name = names.prefixed(m.name);
                materials.push(m);
            }
            let mut names = Names::of(objects.iter().map(|o| o.name.as_str()));
            for o in g.objects {
                *triangles += o.mesh.triangles() as u64;
                if *triangles > budget {
                    return self.gltf_err(
                        raw,
                        format!("{triangles} triangles in the scene with the glTF's, beyond its budget of {budget} (raise it with PENUMBRA_MAX_TRIANGLES)"),
                    );
                }
                if let Some(p) = o.mesh.positions.iter().find(|p| p.abs().max_element() > MAX_COORDINATE) {
                    return self.gltf_err(
                        raw,
                        format!("{} has a vertex at {p}, beyond ±{MAX_COORDINATE:e}", quoted(&o.name)),
                    );
                }
                objects.push(Object {
                    name: names.numbered(o.name),
                    mesh: o.mesh,
                    material: base + o.material,
                    heightfield: false,
                });
            }
            Ok(g.lights)
        }
    }

    /// The `[[light]]`s (a light without a direction faces the centre of `objects`), or
    /// `gltf_lights` without any.
    fn lights(&self, raw: &RawScene, objects: &[Object], gltf_lights: Vec<Light>) -> Result<Vec<Light>, Error> {
        let center = objects
            .iter()
            .filter_map(|o| o.mesh.bounds())
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
            .map_or(Vec3::ZERO, |(a, b)| (a + b) * 0.5);
        if let [first, second, ..] = &raw.lights[..] {
            return self.err(
                second.span(),
                &format!("[[light]] #2 ({})", second.get_ref().kind),
                "type",
                format!(
                    "a scene has one light, and its first [[light]] is at line {} (give each light its own scene file)",
                    self.line(first.span().start)
                ),
            );
        }
        let mut lights = Vec::new();
        for (i, l) in raw.lights.iter().enumerate() {
            let (s, l) = (l.span(), l.get_ref());
            let what = format!("[[light]] #{} ({})", i + 1, l.kind);
            // The fields of one kind of light are errors on another: never accepted and
            // ignored.
            let own: &[&str] = match l.kind.as_str() {
                "spot" => &["angle"],
                "disk" | "sphere" => &["radius"],
                "rectangle" => &["size"],
                _ => &[],
            };
            for (field, given) in [
                ("angle", l.angle.is_some()),
                ("radius", l.radius.is_some()),
                ("size", l.size.is_some()),
            ] {
                if given && !own.contains(&field) {
                    return self.err(
                        s,
                        &what,
                        field,
                        format!(
                            "does not apply to a {} light (angle is a spot light's, radius a disk or sphere light's, size a rectangle light's)",
                            l.kind
                        ),
                    );
                }
            }
            let pos = match l.position {
                Some(p) => Some(point3(p).or_else(|e| self.err(s.clone(), &what, "position", e))?),
                None => None,
            };
            let directional = l.kind == "directional";
            // Lights that shine the same way everywhere need not face anywhere.
            let omni = matches!(l.kind.as_str(), "point" | "sphere");
            if pos.is_none()
                && !directional
                && ["spot", "point", "disk", "sphere", "rectangle"].contains(&l.kind.as_str())
            {
                return self.err(s, &what, "position", format!("a {} light needs a position", l.kind));
            }
            let dir = self.light_direction(s.clone(), &what, l, pos, (center, omni))?;
            let kind = self.light_kind(s.clone(), &what, l)?;
            let position = match (kind, pos) {
                (_, Some(p)) => p,
                (LightKind::Directional, None) => center - dir * 100.0,
                (_, None) => return self.err(s, &what, "position", "a positional light needs a position"),
            };
            let intensity = l.intensity.unwrap_or(1.0);
            if !(intensity.is_finite() && intensity >= 0.0) {
                return self.err(
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
        Ok(lights)
    }

    /// Light `l`'s direction (`what`, at `s`): given, towards its target, or towards the
    /// scene's `center` from its position `pos` (an `omni` light that sits there faces down).
    fn light_direction(
        &self,
        s: std::ops::Range<usize>,
        what: &str,
        l: &RawLight,
        pos: Option<Vec3>,
        (center, omni): (Vec3, bool),
    ) -> Result<Vec3, Error> {
        match (l.direction, l.target, pos) {
            (Some(d), _, _) => match finite3(d).and_then(unit3) {
                Some(d) => Ok(d),
                None => self.err(s, what, "direction", "zero or not finite"),
            },
            (None, Some(t), Some(p)) => {
                let t = point3(t).or_else(|e| self.err(s.clone(), what, "target", e))?;
                match unit3(t - p).filter(|_| (t - p).length() > 1e-6) {
                    Some(d) => Ok(d),
                    None => self.err(s, what, "target", "equals the position"),
                }
            }
            (None, None, Some(p)) => match unit3(center - p).filter(|_| (center - p).length() > 1e-6) {
                Some(d) => Ok(d),
                None if omni => Ok(Vec3::NEG_Y),
                None => {
                    self.err(
                        s,
                        what,
                        "direction",
                        "missing, and the light sits at the centre of the scene's bounds, so it faces nowhere (give direction or target)",
                    )
                }
            },
            (None, _, None) => {
                self.err(s, what, "direction", "missing (a directional light needs direction = [x, y, z])")
            }
        }
    }

    /// Light `l`'s kind (`what`, at `s`) with its size: a spot's angle, an area light's
    /// radius or sides, each checked.
    fn light_kind(&self, s: std::ops::Range<usize>, what: &str, l: &RawLight) -> Result<LightKind, Error> {
        let radius = |default: f32| -> Result<f32, Error> {
            let r = l.radius.unwrap_or(default);
            if r.is_finite() && r > 0.0 && r <= MAX_COORDINATE {
                Ok(r)
            } else {
                self.err(
                    s.clone(),
                    what,
                    "radius",
                    format!("{} must be positive and at most {MAX_COORDINATE:e}", shown(r)),
                )
            }
        };
        let kind = match l.kind.as_str() {
            "directional" => LightKind::Directional,
            "spot" => {
                let a = l.angle.unwrap_or(60.0);
                if !FOV_DEGREES.contains(&a) {
                    return self.err(s, what, "angle", format!("{} is outside {FOV_TEXT} degrees", shown(a)));
                }
                LightKind::Spot { angle_deg: a }
            }
            "point" => LightKind::Point,
            "disk" => LightKind::Area(AreaShape::Disk { radius: radius(0.25)? }),
            "sphere" => LightKind::Area(AreaShape::Sphere { radius: radius(0.25)? }),
            "rectangle" => {
                let [w, h] = l.size.unwrap_or([0.5, 0.5]);
                if !(w > 0.0 && h > 0.0 && w <= MAX_COORDINATE && h <= MAX_COORDINATE) {
                    return self.err(
                        s,
                        what,
                        "size",
                        format!(
                            "[{}, {}]: both sides must be positive and at most {MAX_COORDINATE:e}",
                            shown(w),
                            shown(h)
                        ),
                    );
                }
                LightKind::Area(AreaShape::Rectangle { width: w, height: h })
            }
            other => {
                return self.err(
                    s,
                    what,
                    "type",
                    format!("unknown light type '{other}' (directional, spot, point, disk, sphere, rectangle)"),
                )
            }
        };
        Ok(kind)
    }

    /// The `[[camera_path]]` keyframes, checked as `camera` is.
    fn camera_path(&self, raw: &RawScene, camera: &Camera) -> Result<Vec<Keyframe>, Error> {
        if raw.camera_path.len() > MAX_KEYFRAMES {
            let s = raw.camera_path[MAX_KEYFRAMES].span();
            return self.err(
                s,
                &format!("[[camera_path]] #{}", MAX_KEYFRAMES + 1),
                "position",
                format!(
                    "a camera path has at most {MAX_KEYFRAMES} keyframes (this one has {})",
                    raw.camera_path.len()
                ),
            );
        }
        let mut camera_path = Vec::new();
        for (i, k) in raw.camera_path.iter().enumerate() {
            let (s, k) = (k.span(), k.get_ref());
            let what = format!("[[camera_path]] #{}", i + 1);
            // Checked as [camera] is (with its up), so that no frame of the path is blank.
            let (position, target, _) = check_view(k.position, k.target, Some(camera.up.to_array()))
                .or_else(|(field, msg)| self.err(s, &what, field, msg))?;
            camera_path.push(Keyframe { position, target });
        }
        Ok(camera_path)
    }
}

impl Ctx<'_> {
    /// The `[[light_path]]` keyframes of `light` (the scene's first): a directional light's
    /// take a `direction` and no `position`; the others a `position` and, optionally, a
    /// `direction` (their own otherwise). A light path as long as the camera path, if both.
    fn light_path(&self, raw: &RawScene, light: &Light, camera_frames: usize) -> Result<Vec<Light>, Error> {
        if let Some(k) = raw.light_path.get(MAX_KEYFRAMES) {
            return self.err(
                k.span(),
                &format!("[[light_path]] #{}", MAX_KEYFRAMES + 1),
                "direction",
                format!(
                    "a light path has at most {MAX_KEYFRAMES} keyframes (this one has {})",
                    raw.light_path.len()
                ),
            );
        }
        if camera_frames > 0 && !raw.light_path.is_empty() && raw.light_path.len() != camera_frames {
            let k = &raw.light_path[0];
            return self.err(
                k.span(),
                "[[light_path]] #1",
                "direction",
                format!(
                    "the light path has {} keyframes and the camera path {camera_frames}: both paths step through the same frames",
                    raw.light_path.len()
                ),
            );
        }
        let directional = light.kind == LightKind::Directional;
        let mut path = Vec::new();
        for (i, k) in raw.light_path.iter().enumerate() {
            let (s, k) = (k.span(), k.get_ref());
            let what = format!("[[light_path]] #{}", i + 1);
            if directional && k.position.is_some() {
                return self.err(
                    s,
                    &what,
                    "position",
                    "a directional light has no position (its keyframes give direction)",
                );
            }
            let direction = match k.direction {
                Some(d) => match finite3(d).and_then(unit3) {
                    Some(d) => d,
                    None => return self.err(s, &what, "direction", "zero or not finite"),
                },
                None if directional => {
                    return self.err(
                        s,
                        &what,
                        "direction",
                        "missing (a directional light's keyframe is its direction)",
                    )
                }
                None => light.direction,
            };
            let position = match (k.position, directional) {
                (Some(p), _) => point3(p).or_else(|e| self.err(s.clone(), &what, "position", e))?,
                (None, false) => {
                    return self.err(
                        s,
                        &what,
                        "position",
                        "missing (a positional light's keyframe is its position)",
                    )
                }
                // As the [[light]]'s: far out along the direction from where it was.
                (None, true) => light.position + light.direction * 100.0 - direction * 100.0,
            };
            path.push(Light {
                position,
                direction,
                ..*light
            });
        }
        Ok(path)
    }
}

/// The key whose value starts at or contains `offset` (`translate` in `translate = [0, "x"]`):
/// the nearest `key =` at or before it on its line.
fn key_before(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[line_start..line_end];
    let (key, _) = line.split_once('=')?;
    let key = key.trim().trim_matches('"');
    (!key.is_empty() && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')).then(|| key.to_string())
}

/// The name of the single-table header (`[name]`, not `[[name]]`) on the line holding
/// `offset`, if that line is one.
fn single_table(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next()?.trim();
    let name = line.strip_prefix('[')?.strip_suffix(']')?.trim();
    (!name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'))
        .then(|| name.to_string())
}

fn finite3(v: [f32; 3]) -> Option<Vec3> {
    let v = Vec3::from(v);
    v.is_finite().then_some(v)
}

/// A number as a message shows it: plainly, or in exponent form where the plain form would
/// be a long run of zeros (1e-38, not 0.00000000000000000000000000000000000001).
fn shown(v: f32) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// The triangles an object's parameters make, before anything is tessellated (each parameter
/// clamped to its own limit, which the object's check refuses beyond): the scene-wide
/// triangle budget is counted from these. 0 for meshes from files (counted once read).
fn estimated_triangles(o: &RawObject) -> u64 {
    let param = |v: Option<u32>, default: u32, max: u32| v.unwrap_or(default).min(max) as u64;
    match o.mesh.as_str() {
        "plane" => 2 * param(o.subdivisions, 1, 1024).pow(2),
        "box" => 12,
        "sphere" => 2 * param(o.stacks, 24, 2048) * param(o.slices, 48, 4096),
        "cylinder" => 4 * param(o.segments, 32, 4096),
        "cone" => 2 * param(o.segments, 32, 4096),
        "heightfield" => 2 * param(o.subdivisions, 64, 1024).pow(2),
        "pleated" => {
            let n = param(o.subdivisions, 16 * param(o.pleats, 6, 1024) as u32, 4096);
            2 * n * (n / 4).max(1)
        }
        _ => 0,
    }
}

/// A point: finite and within [`MAX_COORDINATE`].
fn point3(v: [f32; 3]) -> Result<Vec3, Reason> {
    let p = Vec3::from(v);
    if !p.is_finite() {
        Err(format!("{p} is not finite").into())
    } else if p.abs().max_element() > MAX_COORDINATE {
        Err(format!("{p} is beyond ±{MAX_COORDINATE:e}, the largest coordinate a scene may use").into())
    } else {
        Ok(p)
    }
}

/// A direction of any finite length (scaled before it is normalized, so that 1e38 is as
/// good a length as 1), unit; `None` if zero or not finite.
fn unit3(v: Vec3) -> Option<Vec3> {
    let m = v.abs().max_element();
    if !(v.is_finite() && m > 0.0) {
        return None;
    }
    // The plain normalization where it is defined (the bits every scene has always had);
    // scaled first where the length overflows or underflows.
    match v.normalize_or_zero() {
        n if n != Vec3::ZERO => Some(n),
        _ => Some((v / m).normalize()),
    }
}

/// Checks a camera's view: position and target points, distinct, `up` not along the view.
fn check_view(
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
) -> Result<(Vec3, Vec3, Vec3), (&'static str, Reason)> {
    let position = point3(position).map_err(|e| ("position", e))?;
    let target = point3(target).map_err(|e| ("target", e))?;
    let Some(view) = unit3(target - position).filter(|_| (target - position).length() >= 1e-6) else {
        return Err(("target", "equals the position".into()));
    };
    let up_v = finite3(up.unwrap_or([0.0, 1.0, 0.0])).unwrap_or(Vec3::ZERO);
    match unit3(up_v) {
        // The unit vector: an up of 1e38 or 1e-45 would overflow or vanish in the view matrix.
        Some(u) if u.cross(view).length() >= 1e-4 => Ok((position, target, u)),
        _ => Err(("up", "zero, not finite, or parallel to the view direction".into())),
    }
}

/// Loads a scene file. Relative OBJ paths resolve against the file's folder.
pub fn load(path: &Path) -> Result<Scene, Error> {
    load_with_text(path).map(|(s, _)| s)
}

/// [`load`], also returning the scene's text (for a glTF file, a comment line that names it:
/// the scene is built from the glTF alone, without scene text).
pub fn load_with_text(path: &Path) -> Result<(Scene, String), Error> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if matches!(ext.as_deref(), Some("gltf" | "glb")) {
        let file = path
            .file_name()
            .map_or(String::new(), |f| f.to_string_lossy().into_owned());
        // The comment names the file with its control characters (a newline) shown as '?'.
        let shown: String = file.chars().map(|c| if c.is_control() { '?' } else { c }).collect();
        let text = format!("# {shown} (glTF)\n");
        let raw = RawScene {
            gltf: Some(Spanned::new(0..0, file)),
            ..RawScene::default()
        };
        let ctx = Ctx {
            path,
            text: &text,
            gltf_alone: true,
            files: &[],
        };
        return build(&ctx, raw, format!("{shown} (glTF)")).map(|s| (s, text));
    }
    let bytes = read_regular(path, "scene file", MAX_SCENE_BYTES)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let line = e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        Error::Scene {
            file: path.into(),
            line: Some(line),
            section: None,
            field: None,
            message: "not UTF-8 text (a scene file is TOML)".into(),
        }
    })?;
    parse(&text, path).map(|s| (s, text))
}

/// Parses scene text; `path` names the file in errors and anchors relative OBJ and glTF paths.
///
/// A top-level `gltf = "file.glb"` (or `.gltf`) takes that file's primitives as objects after
/// the `[[object]]`s, its materials after the `[[material]]`s, its punctual lights when the
/// scene has no `[[light]]`, and its first perspective camera when the scene has no
/// `[camera]` ([`super::gltf`]).
pub fn parse(text: &str, path: &Path) -> Result<Scene, Error> {
    parse_with_files(text, path, &[])
}

/// [`parse`], with OBJ files held in memory: an object whose `mesh` is one of `files`' names
/// takes that text instead of reading the file (generated scenes, [`super::random`]).
pub fn parse_with_files(text: &str, path: &Path, files: &[(String, String)]) -> Result<Scene, Error> {
    let ctx = Ctx {
        path,
        text,
        gltf_alone: false,
        files,
    };
    let raw: RawScene = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| ctx.line(s.start)).unwrap_or(0);
        Error::Scene {
            file: path.into(),
            line: Some(line),
            section: None,
            field: e.span().and_then(|s| key_before(text, s.start)),
            message: match e.span().and_then(|s| single_table(text, s.start)) {
                // `[object]` where the scene takes `[[object]]`: serde says "invalid type:
                // map, expected a sequence", which names neither.
                Some(name) if e.message().starts_with("invalid type: map, expected a sequence") => format!(
                    "[{name}] is one table, but a scene takes a list of them here: write [[{name}]] (one [[{name}]] per entry)"
                ),
                _ => e.message().trim_end().to_string(),
            },
        }
    })?;
    let description: String = text
        .lines()
        .take_while(|l| l.trim_start().starts_with('#'))
        .map(|l| l.trim_start().trim_start_matches('#').trim())
        .collect::<Vec<_>>()
        .join(" ");
    build(&ctx, raw, description)
}

/// The scene from its parsed sections.
fn build(ctx: &Ctx, raw: RawScene, description: String) -> Result<Scene, Error> {
    let path = ctx.path;
    let dir = path.parent().unwrap_or(Path::new("."));
    let gltf = match &raw.gltf {
        None => None,
        // A glTF file alone: its own errors name it (a scene file's cite its `gltf` field).
        Some(g) if ctx.gltf_alone => Some(super::gltf::load(&dir.join(g.get_ref()))?),
        Some(g) => {
            Some(super::gltf::load(&dir.join(g.get_ref())).or_else(|e| ctx.err(g.span(), "top level", "gltf", e))?)
        }
    };
    let camera = ctx.camera(&raw, gltf.as_ref())?;
    let mut materials = ctx.materials(&raw)?;
    let (mut triangles, budget) = (0u64, triangle_budget());
    let mut objects = ctx.objects(&raw, &materials, dir, (&mut triangles, budget))?;
    let gltf_lights = match gltf {
        Some(g) => ctx.add_gltf(&raw, g, (&mut materials, &mut objects), (&mut triangles, budget))?,
        None => Vec::new(),
    };
    let mut notes = Vec::new();
    if raw.lights.is_empty() && gltf_lights.len() > 1 {
        notes.push(format!(
            "the glTF file has {} lights: the first in node order ({}) is the scene's light",
            gltf_lights.len(),
            gltf_lights[0].kind.describe().trim_start_matches("a ")
        ));
    }
    let lights = ctx.lights(&raw, &objects, gltf_lights)?;
    if lights.is_empty() && ctx.gltf_alone {
        return Err(Error::scene(
            path,
            "the glTF file has no KHR_lights_punctual light (a scene file that names it with `gltf = \"...\"` can add a [[light]])",
        ));
    }
    if lights.is_empty() {
        return Err(Error::scene(path, "the scene has no [[light]]"));
    }
    if objects.is_empty() {
        return Err(Error::scene(path, "the scene has no [[object]]"));
    }
    let camera_path = ctx.camera_path(&raw, &camera)?;
    let light_path = ctx.light_path(&raw, &lights[0], camera_path.len())?;
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
        light_path,
        notes,
    })
}

/// The names already taken in a scene, and how to make a new one unique, in time linear in
/// the names (a glTF file may bring hundreds of thousands of instances of one name).
struct Names {
    taken: std::collections::HashSet<String>,
    /// Per name: the next `#k` suffix to try for it.
    next: std::collections::HashMap<String, usize>,
}

impl Names {
    /// The names of `taken`.
    fn of<'a>(taken: impl Iterator<Item = &'a str>) -> Names {
        Names {
            taken: taken.map(str::to_string).collect(),
            next: Default::default(),
        }
    }

    /// `name`, or `name#k` with the least `k` from 2 that is free; taken from now on.
    fn numbered(&mut self, name: String) -> String {
        let unique = if self.taken.contains(&name) {
            let k = self.next.entry(name.clone()).or_insert(2);
            while self.taken.contains(&format!("{name}#{k}")) {
                *k += 1;
            }
            *k += 1;
            format!("{name}#{}", *k - 1)
        } else {
            name
        };
        self.taken.insert(unique.clone());
        unique
    }

    /// `name`, or `gltf:name` where that is taken (made unique by [`Names::numbered`] if
    /// that is taken too); taken from now on.
    fn prefixed(&mut self, name: String) -> String {
        let name = if self.taken.contains(&name) {
            format!("gltf:{name}")
        } else {
            name
        };
        self.numbered(name)
    }
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
        parse(text, Path::new("s.toml")).unwrap_err().to_string()
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
        assert!(e.contains("field `target`: [0, NaN, 0] is not finite"), "{e}");
        let e = err(&OK.replace("size = 1", "sise = 1"));
        assert!(e.starts_with("s.toml:") && e.contains("sise"), "{e}");
        let e = err(&OK.replace("mesh = \"box\"", "mesh = \"missing.obj\""));
        assert!(e.contains("missing.obj") && e.contains("field `mesh`"), "{e}");
        let e = err("[camera]\nposition = [1, 2, 3]\n");
        assert!(e.contains("target"), "{e}");
        let e = err(&OK.replace("[camera]", "[camera\n"));
        assert!(e.starts_with("s.toml:2:"), "{e}");
    }

    /// The hostile-input cases of the scene format, each a clear error naming the field (or a
    /// documented, correct behaviour), never garbage.
    #[test]
    fn hostile_scene_fields_get_errors_that_name_them() {
        let cases: &[(&str, &str, &str)] = &[
            // Fixed-length arrays take exactly their length.
            (
                "translate = [0, 0.5, 0]",
                "translate = [0, 0.5, 0, \"junk\", true]",
                "s.toml:23: field `translate`: invalid type: string \"junk\", expected f32",
            ),
            (
                "translate = [0, 0.5, 0]",
                "translate = [0, 0.5, 0, 4]",
                "expected a list of 3 values, got 4",
            ),
            (
                "resolution = [64, 32]",
                "resolution = [64, 36, 99999]",
                "field `resolution`: expected a list of 2 values, got 3",
            ),
            // Type errors name the field and say what was expected, not an internal type.
            (
                "size = 1",
                "size = \"big\"",
                "field `size`: invalid type: string \"big\", expected a number or a list of numbers",
            ),
            // Coordinates beyond the scene's range blame the field the user wrote.
            (
                "position = [4, 3, 6]",
                "position = [1e38, 3, 6]",
                "[camera], field `position`: [100000000000000000000000000000000000000, 3, 6] is beyond",
            ),
            (
                "translate = [0, 0.5, 0]",
                "translate = [0, 0.5, 0]\nscale = 1e34",
                "[[object]] #2 (box), field `scale`: a vertex lands at",
            ),
            (
                "translate = [0, 0.5, 0]",
                "translate = [3e38, 0, 0]",
                "field `translate`",
            ),
            // Lights: a point light needs a position, and the error says so.
            (
                "type = \"directional\"\ndirection = [-0.4, -1, -0.3]",
                "type = \"point\"",
                "[[light]] #1 (point), field `position`: a point light needs a position",
            ),
            (
                "direction = [-0.4, -1, -0.3]",
                "position = [1e38, 0, 0]",
                "field `position`",
            ),
            // Duplicate object names would make receiver= and occluders= pick the first.
            ("mesh = \"box\"", "mesh = \"box\"\nname = \"a\"", ""),
        ];
        for (from, to, want) in cases {
            assert!(OK.contains(from), "{from}");
            let text = OK.replacen(from, to, 1);
            let r = parse(&text, Path::new("s.toml"));
            if want.is_empty() {
                assert!(r.is_ok(), "{to}: {:?}", r.err());
            } else {
                let e = r.unwrap_err().to_string();
                assert!(e.contains(want), "{to}:\n  got  {e}\n  want {want}");
            }
        }
        let dup = OK
            .replace("mesh = \"plane\"", "mesh = \"plane\"\nname = \"a\"")
            .replace("mesh = \"box\"", "mesh = \"box\"\nname = \"a\"");
        let e = err(&dup);
        assert!(e.contains("field `name`: 'a' is also object #1's name"), "{e}");
    }

    /// Regression: directions scaled before normalizing changed their last bits, and so the
    /// multi-sample area light's samples (golden hashes caught it).
    #[test]
    fn light_directions_keep_the_plain_normalization_bits() {
        let s = parse(OK, Path::new("s.toml")).unwrap();
        assert_eq!(s.lights[0].direction, Vec3::new(-0.4, -1.0, -0.3).normalize());
    }

    #[test]
    fn valid_but_unusual_scenes_are_taken() {
        // A huge direction is a direction.
        let s = parse(&OK.replace("[-0.4, -1, -0.3]", "[0, -1e38, 0]"), Path::new("s.toml")).unwrap();
        assert_eq!(s.lights[0].direction, Vec3::NEG_Y);
        // A point light exactly at the centre of the scene's bounds (it shines everywhere).
        let at_centre = OK.replace(
            "type = \"directional\"\ndirection = [-0.4, -1, -0.3]",
            "type = \"point\"\nposition = [0, 0.5, 0]",
        );
        let s = parse(&at_centre, Path::new("s.toml")).unwrap();
        assert_eq!(s.lights[0].position, Vec3::new(0.0, 0.5, 0.0));
        assert!(s.lights[0].direction.is_normalized());
        // A spot there faces nowhere: it needs a direction.
        let e = err(&at_centre.replace("\"point\"", "\"spot\""));
        assert!(e.contains("field `direction`") && e.contains("faces nowhere"), "{e}");
        // A material may be called `default` (the built-in one has no name to clash with).
        let d = OK
            .replace("name = \"ground\"", "name = \"default\"")
            .replace("material = \"ground\"", "material = \"default\"");
        let s = parse(&d, Path::new("s.toml")).unwrap();
        assert_eq!(s.materials[s.objects[0].material].albedo, Vec3::splat(0.5));
    }

    #[test]
    fn camera_paths_are_checked_as_the_camera_is() {
        let with = |k: &str| format!("{OK}\n[[camera_path]]\n{k}\n");
        let e = err(&with("position = [1, 2, 3]\ntarget = [1, 2, 3]"));
        assert!(
            e.contains("[[camera_path]] #1, field `target`: equals the position"),
            "{e}"
        );
        let e = err(&with("position = [0, 5, 0]\ntarget = [0, 0, 0]"));
        assert!(e.contains("[[camera_path]] #1, field `up`"), "{e}");
        let e = err(&with("position = [1e38, 2, 3]\ntarget = [0, 0, 0]"));
        assert!(e.contains("field `position`") && e.contains("beyond"), "{e}");
        let many: String = (0..=MAX_KEYFRAMES)
            .map(|i| format!("[[camera_path]]\nposition = [{i}, 3, 6]\ntarget = [0, 0, 0]\n"))
            .collect();
        let e = err(&format!("{OK}\n{many}"));
        assert!(e.contains("at most 1000 keyframes"), "{e}");
    }

    #[test]
    fn light_paths_move_the_first_light_and_are_checked() {
        let with = |k: &str| format!("{OK}\n{k}\n");
        // OK's light is directional: its keyframes are directions, one per frame.
        let s = parse(
            &with("[[light_path]]\ndirection = [0, -1, 0]\n[[light_path]]\ndirection = [1, -1, 0]"),
            Path::new("t.toml"),
        )
        .unwrap();
        assert_eq!(s.frame_count(), 2);
        assert_eq!(s.light_at(0, 0).unwrap().direction, Vec3::NEG_Y);
        assert!((s.light_at(0, 1).unwrap().direction - Vec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-6);
        assert_eq!(
            s.light_at(0, 5).unwrap(),
            s.lights[0],
            "past the path: the scene's light"
        );
        let e = err(&with("[[light_path]]\nposition = [0, 5, 0]"));
        assert!(
            e.contains("[[light_path]] #1, field `position`") && e.contains("no position"),
            "{e}"
        );
        let e = err(&with("[[light_path]]\ndirection = [0, 0, 0]"));
        assert!(e.contains("field `direction`: zero or not finite"), "{e}");
        let e = err(&with("[[light_path]]\ndirection = [0, -1, 0]\nspeed = 2"));
        assert!(e.contains("speed"), "{e}");
        // A camera path and a light path step through the same frames.
        let e = err(&with(
            "[[camera_path]]\nposition = [4, 3, 6]\ntarget = [0, 0, 0]\n[[light_path]]\ndirection = [0, -1, 0]\n[[light_path]]\ndirection = [0, -1, 1]",
        ));
        assert!(e.contains("2 keyframes and the camera path 1"), "{e}");
        // A point light's keyframes are positions.
        let point = OK.replacen("type = \"directional\"", "type = \"point\"\nposition = [0, 4, 0]", 1);
        let point = point.replacen("direction = [", "# direction = [", 1);
        let e = err(&format!("{point}\n[[light_path]]\ndirection = [0, -1, 0]"));
        assert!(e.contains("field `position`: missing"), "{e}");
        let s = parse(
            &format!("{point}\n[[light_path]]\nposition = [1, 4, 0]"),
            Path::new("t.toml"),
        )
        .unwrap();
        assert_eq!(s.light_at(0, 0).unwrap().position, Vec3::new(1.0, 4.0, 0.0));
        let e = err(&format!("{point}\n[[light_path]]\nposition = [1e38, 4, 0]"));
        assert!(e.contains("field `position`") && e.contains("beyond"), "{e}");
    }

    #[test]
    fn the_triangle_budget_is_checked_before_tessellating() {
        let spheres: String = (0..8)
            .map(|i| format!("[[object]]\nmesh = \"sphere\"\nstacks = 2048\nslices = 4096\ntranslate = [{i}, 0, 0]\n"))
            .collect();
        let t = std::time::Instant::now();
        let e = err(&format!("{OK}\n{spheres}"));
        assert!(
            e.contains("beyond its budget") && e.contains("PENUMBRA_MAX_TRIANGLES"),
            "{e}"
        );
        assert!(e.contains("[[object]] #4 (sphere)"), "the second sphere passes it: {e}");
        // Refused before any allocation of the meshes (16 M triangles each): well within a second.
        assert!(t.elapsed().as_secs_f64() < 5.0);
    }

    #[test]
    fn files_that_are_not_scene_or_obj_files_are_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("penumbra-hostile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        #[cfg(unix)]
        {
            let e = load(Path::new("/dev/zero")).unwrap_err().to_string();
            assert!(e.contains("/dev/zero") && e.contains("not a regular file"), "{e}");
            let e = parse(
                &OK.replace("mesh = \"box\"", "mesh = \"/dev/zero.obj\""),
                Path::new("s.toml"),
            )
            .unwrap_err()
            .to_string();
            assert!(e.contains("field `mesh`"), "{e}");
        }
        let e = load(&dir).unwrap_err().to_string();
        assert!(e.contains("it is a folder"), "{e}");
        // A named pipe would block a reader for ever: refused by its kind, without opening it.
        #[cfg(unix)]
        {
            let fifo = dir.join("pipe.toml");
            let _ = std::fs::remove_file(&fifo);
            if std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .is_ok_and(|s| s.success())
            {
                let e = load(&fifo).unwrap_err().to_string();
                assert!(e.contains("pipe.toml") && e.contains("not a regular file"), "{e}");
            }
        }
        let e = load(&dir.join("missing.toml")).unwrap_err().to_string();
        assert!(e.contains("missing.toml") && e.contains("No such file"), "{e}");
        std::fs::write(dir.join("bin.toml"), b"# ok\n\xff\xfe\n").unwrap();
        let e = load(&dir.join("bin.toml")).unwrap_err().to_string();
        assert!(e.contains("bin.toml:2: not UTF-8"), "{e}");
        // OBJ files: a folder, faces of fewer than three vertices, indices past the vertices
        // (with line numbers), polylines only, and a non-UTF-8 comment (fine).
        let obj = |name: &str, body: &[u8]| -> String {
            let p = dir.join(name);
            if !p.is_dir() {
                std::fs::write(&p, body).unwrap();
            }
            let scene = dir.join(format!("{name}.toml"));
            std::fs::write(&scene, OK.replace("mesh = \"box\"", &format!("mesh = \"{name}\""))).unwrap();
            match load(&scene) {
                Ok(s) => format!("ok {}", s.triangles()),
                Err(e) => e.to_string(),
            }
        };
        let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        assert!(obj("f1.obj", format!("{v}f 1\n").as_bytes())
            .contains("f1.obj:4: a face needs 3 or more vertices, this one has 1"));
        assert!(obj("f2.obj", format!("{v}f 1 2\n").as_bytes()).contains("this one has 2"));
        let e = obj("far.obj", format!("{v}f 1 2 9\n").as_bytes());
        assert!(
            e.contains("far.obj:4: face vertex `9` names vertex 9, but 3 are defined"),
            "{e}"
        );
        let e = obj("badv.obj", b"v 0 0 0\nv 1 x 0\n");
        assert!(e.contains("badv.obj:2: `v`: `x` is not a number"), "{e}");
        let e = obj("shortv.obj", b"v 0 0\n");
        assert!(e.contains("shortv.obj:1: `v` needs 3 numbers, this line has 2"), "{e}");
        let e = obj("lines.obj", format!("{v}l 1 2\nl 2 3\n").as_bytes());
        assert!(e.contains("no triangles in the file"), "{e}");
        let mut bytes = b"# caf\xe9\n".to_vec();
        bytes.extend_from_slice(format!("{v}f 1 2 3\n").as_bytes());
        assert_eq!(obj("latin1.obj", &bytes), "ok 3");
        std::fs::create_dir_all(dir.join("folder.obj")).unwrap();
        let e = obj("folder.obj", b"");
        assert!(e.contains("folder.obj: cannot read OBJ file: it is a folder"), "{e}");
    }
}
