//! Shadow techniques: one technique, one file, in a folder per family; one `Options` struct
//! and one shared trait each.
//!
//! Every technique takes the same [`Frame`] (scene, light, camera G-buffer) and returns the
//! same thing, a [`Visibility`] image (1 = lit, 0 = shadowed, NaN where no geometry; one
//! value per pixel, or one per colour channel), so techniques are comparable, chartable and
//! testable against one reference. Each lists the intermediate buffers of its last run as
//! [`Stage`]s for `penumbra dump` and explains one pixel as [`Step`]s for `penumbra inspect`.
//!
//! Families (DESIGN.md section 3): [`light`] (shared light-space machinery), [`map`] (shadow
//! maps), [`filtered`] (VSM, convolution maps, ESM, EVSM, MSM), [`volume`] (shadow volumes and silhouettes), [`planar`] (planar shadows and
//! cookies), [`exact`] (the irregular z-buffer), [`volumetric`] (coloured transparency maps, opacity and deep opacity maps, deep shadow
//! maps, AVSM), [`screen`] (screen-space shadows, terrain occlusion height), [`mod@reference`] (the ray tracer as a technique). Options are declared once per
//! field ([`options`]); the registry below maps names and `key=value` settings onto them.
//!
//! Under every technique: [`light`] owns the light side (the map pass, [`light::locate`] with
//! its one edge rule, the soft-shadow geometry); [`map::lookup`] is the per-pixel half of the
//! depth-map techniques (bias, comparisons, kernels); [`inspect`] and [`timing`] give every
//! technique one per-pixel contract (the image and `inspect` from one function) and one way
//! to time its passes; [`pass`] makes a shared pass (PCSS, the irregular z-buffer, the
//! stencil volumes) a technique, so that no technique holds another.

pub mod exact;
pub mod filtered;
pub mod inspect;
pub mod light;
pub mod map;
pub mod options;
pub mod overview;
pub mod pass;
pub mod penumbra;
pub mod pixels;
pub mod planar;
pub mod reference;
pub mod screen;
pub mod timing;
pub mod volume;
pub mod volumetric;

use crate::Error;
pub use inspect::{Step, Value};
pub use options::{Declaration, Field, OptionInfo};

use crate::frame::Frame;
use crate::pipeline::{Pipeline, Rgba8, Surface};
use crate::scene::Scene;
pub use crate::visibility::Visibility;

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

    /// Per-pixel values of `frame` (row-major) as a scalar stage shown from `lo` to `hi`.
    pub fn pixels(frame: &Frame, name: &str, data: Vec<f32>, lo: f32, hi: f32) -> Result<Stage, Error> {
        Ok(Stage::Scalar {
            name: name.into(),
            data: Surface::from_vec(frame.width(), frame.height(), data)?,
            lo,
            hi,
        })
    }
}

/// A shadow technique.
pub trait ShadowTechnique: Send {
    /// Registry name.
    fn name(&self) -> &'static str;
    /// Light visibility for every camera pixel of `frame`, row-major (NaN: no geometry).
    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error>;
    /// Intermediate buffers of the last call, which was on `frame`; `p` draws the buffers
    /// that are only worth making when somebody looks (overviews, overdraw), so that they do
    /// not count in the technique's time.
    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error>;
    /// What the last call (on `frame`) did at pixel (`x`, `y`), step by step: the light-space
    /// position, texels read and their values, each bias term and comparison, filter taps,
    /// the result. The caller adds the pixel's surface point and the reference's value.
    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step>;
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
    /// The light views of the last call's maps (map-based techniques; empty for the others):
    /// the texel-footprint metric ([`light::texel_footprint`]) measures their resolution at
    /// each camera pixel. Default: none.
    fn light_views(&self) -> Vec<light::LightView> {
        Vec::new()
    }
}

/// The family a technique belongs to: its folder under `src/shadow/` (DESIGN.md section 3).
/// Charts colour techniques by it.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// The ray tracer as a technique (the ground truth).
    #[default]
    Reference,
    /// Shadow maps and their filters ([`map`]).
    Map,
    /// Shadow volumes ([`volume`]).
    Volume,
    /// Planar shadows and cookies ([`planar`]).
    Planar,
    /// The irregular z-buffer and its hybrid ([`exact`]).
    Exact,
    /// Penumbra volumes ([`penumbra`]).
    Penumbra,
    /// Volumetric shadows ([`volumetric`]).
    Volumetric,
    /// Screen-space shadows and terrain occlusion height ([`screen`]).
    Screen,
    /// Filtered shadow maps: VSM, convolution maps, ESM, EVSM, MSM ([`filtered`]).
    Filtered,
}

impl Family {
    /// Every family, in legend order.
    pub const ALL: [Family; 9] = [
        Family::Reference,
        Family::Map,
        Family::Filtered,
        Family::Volume,
        Family::Planar,
        Family::Exact,
        Family::Penumbra,
        Family::Volumetric,
        Family::Screen,
    ];

    /// The folder name (`map`, `volume`...), as the CSV writes it.
    pub fn key(self) -> &'static str {
        match self {
            Family::Reference => "reference",
            Family::Map => "map",
            Family::Volume => "volume",
            Family::Planar => "planar",
            Family::Exact => "exact",
            Family::Penumbra => "penumbra",
            Family::Volumetric => "volumetric",
            Family::Screen => "screen",
            Family::Filtered => "filtered",
        }
    }

    /// A name for legends.
    pub fn title(self) -> &'static str {
        match self {
            Family::Reference => "reference (ray traced)",
            Family::Map => "shadow maps and filtering",
            Family::Volume => "shadow volumes",
            Family::Planar => "planar and projective",
            Family::Exact => "exact hard (IZB)",
            Family::Penumbra => "penumbra volumes",
            Family::Volumetric => "volumetric",
            Family::Screen => "screen-space and terrain",
            Family::Filtered => "filtered shadow maps",
        }
    }

    /// The family of [`Family::key`] `key`.
    pub fn from_key(key: &str) -> Option<Family> {
        Family::ALL.into_iter().find(|f| f.key() == key)
    }

    /// The family of the registered technique `name`.
    pub fn of(name: &str) -> Option<Family> {
        registry().into_iter().find(|t| t.name == name).map(|t| t.family)
    }
}

/// A registered technique.
pub struct TechniqueInfo {
    /// Name for `--technique`.
    pub name: &'static str,
    /// Its family (its folder).
    pub family: Family,
    /// One line: what it is, the source, the failure it is known for.
    pub summary: &'static str,
    /// Its options (from its [`Declaration`]).
    pub options: Vec<OptionInfo>,
    /// Option sets the sweep runs (each a list of `key=value`): a representative few.
    pub sweep: &'static [&'static [(&'static str, &'static str)]],
    /// More option sets that only `penumbra sweep --all` runs (variants and slow settings).
    pub extended: &'static [&'static [(&'static str, &'static str)]],
    /// Constructor from `key=value` settings (parsed by the technique's [`Declaration`]).
    pub create: Constructor,
    /// The scenes the technique works on, for harnesses that run every technique on every
    /// scene (the sweep, the golden hashes): `None` for every scene. On another scene its
    /// `visibility` is an error that says what is missing.
    pub applies: Option<fn(&Scene) -> bool>,
    /// What the technique models beyond the hard shadow of opaque casters from a point (empty:
    /// nothing more). `penumbra choose` skips a technique whose scene has none of these: no
    /// penumbra technique under a point light, no volumetric one where nothing transmits light.
    pub models: &'static [Effect],
}

/// An effect a technique models beyond the hard shadow of opaque casters from a point
/// ([`TechniqueInfo::models`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Effect {
    /// The penumbra of an area light (a light with a size).
    AreaLight,
    /// Light through translucent or coloured casters (partial and coloured transmittance).
    Transmittance,
}

impl Effect {
    /// Whether `scene` (its first light, its materials) has this effect.
    pub fn in_scene(self, scene: &Scene) -> bool {
        match self {
            Effect::AreaLight => matches!(
                scene.lights.first().map(|l| l.kind),
                Some(crate::scene::LightKind::Area(_))
            ),
            Effect::Transmittance => scene.objects.iter().any(|o| {
                scene
                    .materials
                    .get(o.material)
                    .is_some_and(crate::scene::Material::is_transparent)
            }),
        }
    }

    /// A name for people: `an area light`, `translucent casters`.
    pub fn describe(self) -> &'static str {
        match self {
            Effect::AreaLight => "an area light's penumbra",
            Effect::Transmittance => "light through translucent or coloured casters",
        }
    }
}

impl TechniqueInfo {
    /// Whether the technique works on `scene` ([`TechniqueInfo::applies`]).
    pub fn applies_to(&self, scene: &Scene) -> bool {
        self.applies.is_none_or(|f| f(scene))
    }
}

/// A technique's constructor from `key=value` settings.
pub type Constructor = fn(&[(String, String)]) -> Result<Box<dyn ShadowTechnique>, Error>;

/// All techniques, in chart order.
pub fn registry() -> Vec<TechniqueInfo> {
    vec![
        reference::info(),
        map::shadow_map::info(),
        map::cascaded::info(),
        map::sdsm::info(),
        map::lispsm::info(),
        map::logpsm::info(),
        map::tsm::info(),
        map::psm::info(),
        map::pcss::info(),
        map::chs::info(),
        map::multi_sample::info(),
        filtered::vsm::info(),
        filtered::convolution::info(),
        filtered::esm::info(),
        filtered::evsm::info(),
        filtered::msm::info(),
        volume::shadow_volume::info(),
        planar::projected::info(),
        planar::cookie::info(),
        exact::izb::info(),
        exact::hybrid::info(),
        penumbra::pvm::info(),
        penumbra::pvmf::info(),
        volumetric::transparency_map::info(),
        volumetric::opacity_maps::info(),
        volumetric::deep_shadow_map::info(),
        volumetric::avsm::info(),
        screen::screen_space::info(),
        screen::contact::info(),
        screen::terrain::info(),
    ]
}

/// Creates technique `name` with `key=value` settings; errors name unknown techniques and
/// options and list the valid ones.
pub fn create(name: &str, pairs: &[(String, String)]) -> Result<Box<dyn ShadowTechnique>, Error> {
    let reg = registry();
    let Some(info) = reg.iter().find(|t| t.name == name) else {
        let names: Vec<&str> = reg.iter().map(|t| t.name).collect();
        return Err(Error::technique(format!(
            "unknown technique '{name}' (known: {})",
            names.join(", ")
        )));
    };
    let inner = (info.create)(pairs).map_err(|e| e.in_technique(info.name))?;
    Ok(Box::new(Named(inner)))
}

/// A technique from the registry: its errors name it, whichever shared pass raised them.
struct Named(Box<dyn ShadowTechnique>);

impl ShadowTechnique for Named {
    fn name(&self) -> &'static str {
        self.0.name()
    }
    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let name = self.0.name();
        self.0.visibility(p, frame).map_err(|e| e.in_technique(name))
    }
    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        self.0.stages(p, frame).map_err(|e| e.in_technique(self.0.name()))
    }
    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        self.0.inspect(frame, x, y)
    }
    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.0.timings()
    }
    fn notes(&self) -> Vec<String> {
        self.0.notes()
    }
    fn counters(&self) -> Vec<(&'static str, f64)> {
        self.0.counters()
    }
    fn light_views(&self) -> Vec<light::LightView> {
        self.0.light_views()
    }
}

/// A registry option set (`sweep`, `extended`) as the owned `key=value` pairs [`create`] takes.
pub fn owned_sets(set: &[(&str, &str)]) -> Vec<(String, String)> {
    set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
}

/// Parses `key=value` strings.
pub fn parse_sets(sets: &[String]) -> Result<Vec<(String, String)>, Error> {
    sets.iter()
        .map(|s| match s.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
            _ => Err(Error::input(format!("option setting '{s}' is not key=value"))),
        })
        .collect()
}

/// The index of the object called `name` in `frame`'s scene; the error names the technique,
/// the option and the objects there are.
pub fn object_named(frame: &Frame, technique: &str, option: &str, name: &str) -> Result<usize, Error> {
    let objs = &frame.scene.objects;
    objs.iter().position(|o| o.name == name).ok_or_else(|| {
        Error::option(
            option,
            name,
            format!(
                "names no object of the scene (objects: {})",
                objs.iter().map(|o| o.name.as_str()).collect::<Vec<_>>().join(", ")
            ),
        )
        .in_technique(technique)
    })
}
