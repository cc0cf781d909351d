//! Scenes: triangle meshes with materials, one camera, lights and an optional camera path.
//! A scene is data: it knows nothing of the pipeline (DESIGN.md section 1).
//!
//! Scenes are written as TOML files ([`mod@file`]) naming procedural or OBJ meshes ([`mesh`]).

#[cfg(feature = "files")]
pub mod file;
#[cfg(feature = "files")]
pub mod gltf;
pub mod limits;
pub mod mesh;
#[cfg(feature = "files")]
pub mod random;
#[cfg(feature = "files")]
pub mod read;
pub mod spheres;

use glam::{Mat4, Vec3};

/// A triangle mesh in world space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions (world space).
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<Vec3>,
    /// Three indices per triangle, counter-clockwise seen from the front.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// The mesh with `m` applied to positions and the inverse transpose to normals.
    pub fn transformed(&self, m: Mat4) -> Mesh {
        let n = crate::math::inverse(&m).transpose();
        Mesh {
            positions: self.positions.iter().map(|&p| m.transform_point3(p)).collect(),
            normals: self
                .normals
                .iter()
                .map(|&v| n.transform_vector3(v).normalize_or_zero())
                .collect(),
            indices: self.indices.clone(),
        }
    }

    /// Appends another mesh.
    pub fn append(&mut self, o: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&o.positions);
        self.normals.extend_from_slice(&o.normals);
        self.indices.extend(o.indices.iter().map(|i| i + base));
    }

    /// World-space bounds (min, max); `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(a, b), &p| (a.min(p), b.max(p))),
        )
    }
}

/// Surface properties of an object.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name used by objects.
    pub name: String,
    /// Diffuse albedo (linear RGB).
    pub albedo: Vec3,
    /// Opacity in [0, 1] (1 = opaque); below 1 the object transmits light.
    pub opacity: f32,
    /// The colour of the light it transmits, per channel in [0, 1] (stained glass). Default:
    /// none, which means `1 - opacity` in every channel.
    pub transmittance: Option<Vec3>,
    /// Lit from both sides (thin sheets).
    pub two_sided: bool,
}

impl Material {
    /// The fraction of light it transmits per channel: [`Material::transmittance`], or
    /// `1 - opacity` in every channel.
    pub fn transmittance_rgb(&self) -> Vec3 {
        self.transmittance.unwrap_or(Vec3::splat(1.0 - self.opacity))
    }

    /// Whether the material lets any light through (in some channel).
    pub fn is_transparent(&self) -> bool {
        self.transmittance_rgb().max_element() > 0.0
    }
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            albedo: Vec3::splat(0.8),
            opacity: 1.0,
            transmittance: None,
            two_sided: false,
        }
    }
}

/// One object: a world-space mesh and a material index.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name (from the scene file, or `object<i>`).
    pub name: String,
    /// World-space mesh.
    pub mesh: Mesh,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Made as a heightfield (`mesh = "heightfield"`): a height function `y(x, z)` that
    /// terrain techniques build on.
    pub heightfield: bool,
}

/// The camera.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov_deg: f32,
    /// Near plane distance.
    pub near: f32,
    /// Far plane distance.
    pub far: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// World to view (right-handed, looking down -z).
    pub fn view(&self) -> Mat4 {
        Mat4::look_at_rh(self.position, self.target, self.up)
    }

    /// View to clip (depth in [0, 1]).
    pub fn projection(&self) -> Mat4 {
        Mat4::perspective_rh(
            self.fov_deg.to_radians(),
            self.width as f32 / self.height as f32,
            self.near,
            self.far,
        )
    }

    /// World to clip.
    pub fn view_projection(&self) -> Mat4 {
        self.projection() * self.view()
    }
}

/// Shape of an area light.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum AreaShape {
    /// A disk of the given radius facing the light's direction.
    Disk {
        /// Radius.
        radius: f32,
    },
    /// A sphere of the given radius.
    Sphere {
        /// Radius.
        radius: f32,
    },
    /// A rectangle `width` x `height` facing the light's direction.
    Rectangle {
        /// Extent along the light's first tangent.
        width: f32,
        /// Extent along the second tangent.
        height: f32,
    },
}

impl AreaShape {
    /// The light's width for penumbra estimates (PCSS's `w_light`): a disk's or sphere's
    /// diameter, a rectangle's mean side.
    pub fn width(&self) -> f32 {
        match *self {
            AreaShape::Disk { radius } | AreaShape::Sphere { radius } => 2.0 * radius,
            AreaShape::Rectangle { width, height } => 0.5 * (width + height),
        }
    }
}

/// What kind of light.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum LightKind {
    /// Parallel light travelling along `direction`.
    Directional,
    /// A point light shining into a cone of full angle `angle_deg` around `direction`.
    Spot {
        /// Full cone angle in degrees, in [`file::FOV_DEGREES`].
        angle_deg: f32,
    },
    /// A point light shining everywhere.
    Point,
    /// An area light; hard-shadow techniques use its centre as a point light.
    Area(AreaShape),
}

impl LightKind {
    /// A name for messages: `a directional light`, `a spot light`, `a point light`, `an area
    /// light`.
    pub fn describe(self) -> &'static str {
        match self {
            LightKind::Directional => "a directional light",
            LightKind::Spot { .. } => "a spot light",
            LightKind::Point => "a point light",
            LightKind::Area(_) => "an area light",
        }
    }
}

/// A light. Every light has a centre (`position`, the point a hard-shadow technique uses) and a
/// direction (where a directional light travels, where a spot or a disk/rectangle faces).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Light {
    /// Kind and shape.
    pub kind: LightKind,
    /// Centre (for directional lights, a point far along `-direction`, used only for fitting).
    pub position: Vec3,
    /// Unit direction the light travels in.
    pub direction: Vec3,
    /// Intensity multiplier.
    pub intensity: f32,
}

impl Light {
    /// Unit vector from `p` towards the light's centre (the negated direction for directional
    /// lights).
    pub fn to_light(&self, p: Vec3) -> Vec3 {
        match self.kind {
            LightKind::Directional => -self.direction,
            _ => (self.position - p).normalize_or_zero(),
        }
    }

    /// Two unit tangents orthogonal to the direction (for disk/rectangle sampling and frames).
    pub fn tangents(&self) -> (Vec3, Vec3) {
        let d = self.direction;
        let helper = if d.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
        let t = d.cross(helper).normalize();
        (t, d.cross(t))
    }
}

/// A camera keyframe.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Keyframe {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub target: Vec3,
}

/// What a scene's errors mean, for charts that average errors only where they are of one
/// kind: hard-light scenes are judged by wrong pixels, area-light scenes by the penumbra's
/// RMSE, scenes with transparent objects by the transmittance's RMSE.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SceneClass {
    /// Opaque objects under a point, spot or directional light (or an area light's centre).
    #[default]
    Hard,
    /// Opaque objects under an area light (penumbrae).
    Area,
    /// Some object transmits light (coloured or partial shadows).
    Transparent,
}

impl SceneClass {
    /// Every class, in chart order.
    pub const ALL: [SceneClass; 3] = [SceneClass::Hard, SceneClass::Area, SceneClass::Transparent];

    /// The name the CSV writes (`hard`, `area`, `transparent`).
    pub fn key(self) -> &'static str {
        match self {
            SceneClass::Hard => "hard",
            SceneClass::Area => "area",
            SceneClass::Transparent => "transparent",
        }
    }

    /// The class of [`SceneClass::key`] `key`.
    pub fn from_key(key: &str) -> Option<SceneClass> {
        SceneClass::ALL.into_iter().find(|c| c.key() == key)
    }

    /// A title for charts.
    pub fn title(self) -> &'static str {
        match self {
            SceneClass::Hard => "hard-light scenes",
            SceneClass::Area => "area-light scenes",
            SceneClass::Transparent => "transparent scenes",
        }
    }

    /// The error that judges a technique on this class, and its axis label.
    pub fn metric(self) -> &'static str {
        match self {
            SceneClass::Hard => "wrong pixels (%)",
            SceneClass::Area => "penumbra RMSE",
            SceneClass::Transparent => "transmittance RMSE",
        }
    }
}

/// A whole scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Name (file stem).
    pub name: String,
    /// What the scene shows (the file's opening comment).
    pub description: String,
    /// Objects.
    pub objects: Vec<Object>,
    /// Materials.
    pub materials: Vec<Material>,
    /// The camera.
    pub camera: Camera,
    /// Lights (techniques use the first unless told otherwise).
    pub lights: Vec<Light>,
    /// Camera path for stability tests (empty: a still camera).
    pub camera_path: Vec<Keyframe>,
    /// The first light at each frame of a light path (a moving sun, say; empty: a still
    /// light). When both paths are given they have as many frames.
    pub light_path: Vec<Light>,
    /// What loading chose on the user's behalf (which of a glTF file's lights is used), for
    /// the CLI to print.
    pub notes: Vec<String>,
}

impl Scene {
    /// The scene's [`SceneClass`]: transparent when any object transmits light, else area
    /// when the first light is an area light, else hard.
    pub fn class(&self) -> SceneClass {
        if self
            .objects
            .iter()
            .any(|o| self.materials.get(o.material).is_some_and(Material::is_transparent))
        {
            SceneClass::Transparent
        } else if matches!(self.lights.first().map(|l| l.kind), Some(LightKind::Area(_))) {
            SceneClass::Area
        } else {
            SceneClass::Hard
        }
    }

    /// The scene-wide id of each object's first triangle (objects' triangles numbered in
    /// scene order).
    pub fn triangle_bases(&self) -> Vec<u32> {
        let mut base = 0u32;
        self.objects
            .iter()
            .map(|o| {
                let b = base;
                base += o.mesh.triangles() as u32;
                b
            })
            .collect()
    }

    /// World bounds of all objects.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.objects
            .iter()
            .filter_map(|o| o.mesh.bounds())
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }

    /// Total triangle count.
    pub fn triangles(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.triangles()).sum()
    }

    /// Frames of the scene's paths: the camera path's or the light path's keyframes, 1 for
    /// a still scene.
    pub fn frame_count(&self) -> usize {
        self.camera_path.len().max(self.light_path.len()).max(1)
    }

    /// Light `light` at frame `i`: the light path's keyframe for the first light, the scene's
    /// light otherwise; `None` when the scene has no such light.
    pub fn light_at(&self, light: usize, i: usize) -> Option<Light> {
        match (light, self.light_path.get(i)) {
            (0, Some(l)) => Some(*l),
            _ => self.lights.get(light).copied(),
        }
    }

    /// The camera at frame `i` of the path (the scene camera when there is no path).
    pub fn camera_at(&self, i: usize) -> Camera {
        match self.camera_path.get(i) {
            Some(k) => Camera {
                position: k.position,
                target: k.target,
                ..self.camera
            },
            None => self.camera,
        }
    }
}
