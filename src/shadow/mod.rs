//! Shadow techniques: one technique, one file, one options struct, one trait.
//!
//! Every technique takes the same [`Frame`] (scene, light, camera G-buffer) and returns the
//! same thing, a visibility image (1 = lit, 0 = shadowed, NaN where no geometry), so techniques
//! are comparable, chartable and testable against one reference. Each lists the intermediate
//! buffers of its last run as [`Stage`]s for `penumbra dump`.

pub mod cookie;
pub mod planar;
pub mod reference;
pub mod shadow_map;
pub mod silhouette;
pub mod volume;

use crate::frame::Frame;
use crate::pipeline::{Pipeline, Rgba8, Surface};

/// An intermediate buffer of a technique, for `dump`.
pub enum Stage {
    /// Scalar data (depth, counts...) shown in false colour from `lo` to `hi`.
    Scalar {
        /// File-friendly name.
        name: String,
        /// The data.
        data: Surface<f32>,
        /// Value shown black.
        lo: f32,
        /// Value shown white.
        hi: f32,
    },
    /// A colour image.
    Color {
        /// File-friendly name.
        name: String,
        /// The image.
        data: Surface<Rgba8>,
    },
}

impl Stage {
    /// The stage's name.
    pub fn name(&self) -> &str {
        match self {
            Stage::Scalar { name, .. } | Stage::Color { name, .. } => name,
        }
    }
}

/// A shadow technique.
pub trait ShadowTechnique: Send {
    /// Registry name.
    fn name(&self) -> &'static str;
    /// Light visibility for every camera pixel of `frame`, row-major (NaN: no geometry).
    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Vec<f32>, String>;
    /// Intermediate buffers of the last call, which was on `frame`; `p` draws the buffers
    /// that are only worth making when somebody looks (overviews, overdraw), so that they do
    /// not count in the technique's time.
    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, String>;
    /// Wall time of each pass of the last call, in milliseconds (for users comparing where a
    /// technique spends its time). Default: none.
    fn timings(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// Warnings about the input of the last call that users should see (meshes that are not
    /// closed, for example): what was found and how it was handled. Default: none.
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
    /// Work counters of the last call (silhouette edges, stencil fragments...), for users
    /// comparing what a technique does as the view moves. Default: none.
    fn counters(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
}

/// One option of a technique: name, default, documentation.
#[derive(Copy, Clone, Debug)]
pub struct OptionInfo {
    /// Key for `--set key=value`.
    pub key: &'static str,
    /// Default value, as text.
    pub default: &'static str,
    /// What it does.
    pub doc: &'static str,
}

/// A registered technique.
pub struct TechniqueInfo {
    /// Name for `--technique`.
    pub name: &'static str,
    /// One line: what it is, the source, the failure it is known for.
    pub summary: &'static str,
    /// Its options.
    pub options: &'static [OptionInfo],
    /// Option sets the sweep runs (each a list of `key=value`).
    pub sweep: &'static [&'static [(&'static str, &'static str)]],
    /// Constructor from `key=value` settings.
    pub create: fn(&Settings) -> Result<Box<dyn ShadowTechnique>, String>,
}

/// `key=value` settings handed to a technique, checked against its options.
pub struct Settings<'a> {
    technique: &'static str,
    options: &'static [OptionInfo],
    pairs: &'a [(String, String)],
}

impl Settings<'_> {
    /// The value of `key`: the setting, or the option's default. Unknown keys never reach
    /// here: [`create`] rejects them.
    pub fn get(&self, key: &str) -> &str {
        self.pairs
            .iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
            .unwrap_or_else(|| {
                self.options
                    .iter()
                    .find(|o| o.key == key)
                    .map(|o| o.default)
                    .expect("technique asks for an option it declares")
            })
    }

    /// `key` parsed as a number in `[lo, hi]`.
    pub fn num<T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy>(
        &self,
        key: &str,
        lo: T,
        hi: T,
    ) -> Result<T, String> {
        let s = self.get(key);
        let v: T = s
            .parse()
            .map_err(|_| format!("technique '{}': option {key}={s} is not a number", self.technique))?;
        if v < lo || v > hi {
            return Err(format!(
                "technique '{}': option {key}={s} is outside [{lo}, {hi}]",
                self.technique
            ));
        }
        Ok(v)
    }

    /// `key` as one of `choices`.
    pub fn choice(&self, key: &str, choices: &[&'static str]) -> Result<&'static str, String> {
        let s = self.get(key);
        choices.iter().copied().find(|c| *c == s).ok_or_else(|| {
            format!(
                "technique '{}': option {key}={s} is not one of {}",
                self.technique,
                choices.join(", ")
            )
        })
    }
}

/// All techniques, in chart order.
pub fn registry() -> Vec<TechniqueInfo> {
    vec![
        reference::info(),
        shadow_map::info(),
        volume::info(),
        planar::info(),
        cookie::info(),
    ]
}

/// Creates technique `name` with `key=value` settings; errors name unknown techniques and
/// options and list the valid ones.
pub fn create(name: &str, pairs: &[(String, String)]) -> Result<Box<dyn ShadowTechnique>, String> {
    let reg = registry();
    let Some(info) = reg.iter().find(|t| t.name == name) else {
        let names: Vec<&str> = reg.iter().map(|t| t.name).collect();
        return Err(format!("unknown technique '{name}' (known: {})", names.join(", ")));
    };
    for (k, _) in pairs {
        if !info.options.iter().any(|o| o.key == k) {
            let keys: Vec<&str> = info.options.iter().map(|o| o.key).collect();
            return Err(format!(
                "technique '{name}' has no option '{k}' (options: {})",
                if keys.is_empty() {
                    "none".into()
                } else {
                    keys.join(", ")
                }
            ));
        }
    }
    (info.create)(&Settings {
        technique: info.name,
        options: info.options,
        pairs,
    })
}

/// Parses `key=value` strings.
pub fn parse_sets(sets: &[String]) -> Result<Vec<(String, String)>, String> {
    sets.iter()
        .map(|s| match s.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
            _ => Err(format!("--set '{s}' is not key=value")),
        })
        .collect()
}

/// Draws the 2D segment `a`-`b` (pixel coordinates) into `img`, clipped to its bounds: for
/// overview stages (frusta, silhouettes).
pub fn draw_segment(img: &mut Surface<Rgba8>, a: glam::Vec2, b: glam::Vec2, color: Rgba8) {
    let (w, h) = (img.width() as f32, img.height() as f32);
    // Clip the parameter range to the image (Liang-Barsky), so huge segments cost nothing.
    let d = b - a;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for (p, q) in [(-d.x, a.x), (d.x, w - a.x), (-d.y, a.y), (d.y, h - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    // Also rejects NaN ends.
    if t0.partial_cmp(&t1).is_none_or(|o| o.is_gt()) {
        return;
    }
    let (a, b) = (a + d * t0, a + d * t1);
    let steps = ((b - a).abs().max_element().ceil() as u32).max(1) * 2;
    for k in 0..=steps {
        let q = a + (b - a) * (k as f32 / steps as f32);
        if q.x >= 0.0 && q.y >= 0.0 && q.x < w && q.y < h {
            img.set(q.x as u32, q.y as u32, color);
        }
    }
}

/// Draws the world segment `a`-`b` as the camera of `frame` sees it, clipped to the near
/// plane.
pub fn draw_world_segment(img: &mut Surface<Rgba8>, frame: &Frame, a: glam::Vec3, b: glam::Vec3, color: Rgba8) {
    let vp = frame.camera.view_projection();
    let (mut ca, mut cb) = (vp * a.extend(1.0), vp * b.extend(1.0));
    // Clip to z >= 0 (the near plane of a [0, 1] depth range).
    let (da, db) = (ca.z, cb.z);
    if da < 0.0 && db < 0.0 {
        return;
    }
    if da < 0.0 {
        ca = ca + (cb - ca) * (da / (da - db));
    } else if db < 0.0 {
        cb = cb + (ca - cb) * (db / (db - da));
    }
    let (w, h) = (img.width() as f32, img.height() as f32);
    let to_px = |c: glam::Vec4| {
        let n = c.truncate() / c.w.max(1e-12);
        glam::Vec2::new((n.x * 0.5 + 0.5) * w, (0.5 - n.y * 0.5) * h)
    };
    draw_segment(img, to_px(ca), to_px(cb), color);
}

/// A grey, light-independent picture of the camera view (normals facing the camera bright),
/// the backdrop that overview stages draw on.
pub fn backdrop(frame: &Frame) -> Surface<Rgba8> {
    let eye = frame.camera.position;
    let mut img = frame.gbuffer.normal.map(|_| [30, 30, 40, 255]);
    for (o, px) in frame.points().iter().zip(img.data_mut()) {
        if let Some(s) = o {
            let g = (40.0 + 120.0 * s.normal.dot((eye - s.position).normalize_or_zero()).abs()) as u8;
            *px = [g, g, g, 255];
        }
    }
    img
}

/// Depth of every object of `frame`'s scene for which `keep(object index)` holds, seen
/// through `matrix`, into a fresh `w` x `h` target (1 = empty).
pub fn scene_depth(
    p: &Pipeline,
    frame: &Frame,
    matrix: glam::Mat4,
    w: u32,
    h: u32,
    keep: impl Fn(usize) -> bool,
) -> Result<Surface<f32>, String> {
    use crate::pipeline::{DepthOnly, RenderState, Targets, TransformPositions};
    let mut d = Surface::new(w, h, 1.0f32).map_err(|e| e.to_string())?;
    for (_, o) in frame.scene.objects.iter().enumerate().filter(|(i, _)| keep(*i)) {
        p.draw(
            &mut Targets::depth_only(&mut d),
            &RenderState::default(),
            &o.mesh.positions,
            &o.mesh.indices,
            &TransformPositions(matrix),
            &DepthOnly,
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(d)
}

/// The index of the object called `name` in `frame`'s scene; the error names the technique,
/// the option and the objects there are.
pub fn object_named(frame: &Frame, technique: &str, option: &str, name: &str) -> Result<usize, String> {
    let objs = &frame.scene.objects;
    objs.iter().position(|o| o.name == name).ok_or_else(|| {
        format!(
            "technique '{technique}': option {option}: the scene has no object '{name}' (objects: {})",
            objs.iter().map(|o| o.name.as_str()).collect::<Vec<_>>().join(", ")
        )
    })
}

/// Which light view of a point light's six cube faces (in [`crate::pipeline::CubeFace::ALL`] order) sees
/// `position`; 0 for single-view lights.
pub fn light_face(views: usize, light: &crate::scene::Light, position: glam::Vec3) -> usize {
    if views == 6 {
        crate::pipeline::CubeFace::from_direction(position - light.position).map_or(0, |f| f.0 as usize)
    } else {
        0
    }
}

/// The homogeneous light position: `(p, 1)` for lights at a point, `(-direction, 0)` for
/// directional ones (shadow volumes extrude from it, planar shadows project through it).
pub fn light_position(frame: &Frame) -> glam::Vec4 {
    match frame.light.kind {
        crate::scene::LightKind::Directional => (-frame.light.direction).extend(0.0),
        _ => frame.light.position.extend(1.0),
    }
}
