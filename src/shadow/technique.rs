//! The technique contract, the ground floor of every family: the [`ShadowTechnique`] trait,
//! its vocabulary ([`Stage`], [`Step`], [`Visibility`], the option [`Declaration`]s) and the
//! description the registry holds of each technique ([`TechniqueInfo`], [`Family`]).
//!
//! This module imports no family: families import it, and the registry
//! ([`super::registry`]) sits above them all.

pub use super::inspect::{Step, Value};
pub use super::options::{Declaration, Field, OptionInfo};
pub use super::stage::Stage;
pub use crate::visibility::Visibility;

use super::light::LightView;
use crate::frame::Frame;
use crate::pipeline::Pipeline;
use crate::scene::{Light, Scene};
use crate::Error;

/// A shadow technique.
pub trait ShadowTechnique: Send {
    /// Registry name.
    fn name(&self) -> &'static str;
    /// Visibility of `frame.light`, the light the technique is given (never the scene's
    /// first or any other light), for every camera pixel of `frame`, row-major (NaN: no
    /// geometry).
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
    /// the texel-footprint metric ([`super::light::texel_footprint`]) measures their resolution at
    /// each camera pixel. Default: none.
    fn light_views(&self) -> Vec<LightView> {
        Vec::new()
    }
}

/// Declares [`Family`] from one list: each family's variant, folder (its key) and legend
/// title, written once.
macro_rules! families {
    ($($(#[$doc:meta])* $variant:ident => $key:literal, $title:literal;)*) => {
        /// The family a technique belongs to: its folder under `src/shadow/` (DESIGN.md
        /// section 3). Charts colour techniques by it.
        #[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Family {
            $($(#[$doc])* $variant,)*
        }

        impl Family {
            /// Every family, in legend order (the order of [`Ord`]).
            pub const ALL: &'static [Family] = &[$(Family::$variant),*];

            /// The folder name (`map`, `volume`...), as the CSV writes it.
            pub fn key(self) -> &'static str {
                match self {
                    $(Family::$variant => $key,)*
                }
            }

            /// A name for legends.
            pub fn title(self) -> &'static str {
                match self {
                    $(Family::$variant => $title,)*
                }
            }
        }
    };
}

families! {
    /// The ray tracer as a technique (the ground truth).
    #[default]
    Reference => "reference", "reference (ray traced)";
    /// Shadow maps and their filters (`map/`).
    Map => "map", "shadow maps and filtering";
    /// Shadow volumes (`volume/`).
    Volume => "volume", "shadow volumes";
    /// Planar shadows and cookies (`planar/`).
    Planar => "planar", "planar and projective";
    /// The irregular z-buffer and its hybrid (`exact/`).
    Exact => "exact", "exact hard (IZB)";
    /// Penumbra volumes (`penumbra/`).
    Penumbra => "penumbra", "penumbra volumes";
    /// Volumetric shadows (`volumetric/`).
    Volumetric => "volumetric", "volumetric";
    /// Screen-space shadows and terrain occlusion height (`screen/`).
    Screen => "screen", "screen-space and terrain";
    /// Filtered shadow maps: VSM, convolution maps, ESM, EVSM, MSM (`filtered/`).
    Filtered => "filtered", "filtered shadow maps";
}

impl Family {
    /// The family of [`Family::key`] `key`.
    pub fn from_key(key: &str) -> Option<Family> {
        Family::ALL.iter().copied().find(|f| f.key() == key)
    }
}

/// What a technique's module says of it for the registry ([`TechniqueInfo`] without the
/// options and the constructor, which the registry takes from the module's declaration and
/// type): its name, family, summary, sweep sets, the lights it works on and what it models.
#[derive(Copy, Clone)]
pub struct Entry {
    /// Name for `--technique`.
    pub name: &'static str,
    /// Its family (its folder).
    pub family: Family,
    /// One line: what it is, the source, the failure it is known for.
    pub summary: &'static str,
    /// Option sets the sweep runs ([`TechniqueInfo::sweep`]).
    pub sweep: &'static [&'static [(&'static str, &'static str)]],
    /// Option sets only `penumbra sweep --all` runs ([`TechniqueInfo::extended`]). Default:
    /// none.
    pub extended: &'static [&'static [(&'static str, &'static str)]],
    /// The lights it works on ([`TechniqueInfo::applies`]). Default: every light.
    pub applies: Option<fn(&Scene, &Light) -> bool>,
    /// What it models beyond a hard shadow of opaque casters ([`TechniqueInfo::models`]).
    /// Default: nothing.
    pub models: &'static [Effect],
}

impl Entry {
    /// The defaults an entry's struct update takes (`..Entry::BASE`): no extended sets, every
    /// light, nothing modelled beyond a hard shadow; the name, family, summary and sweep are
    /// each entry's own.
    pub const BASE: Entry = Entry {
        name: "",
        family: Family::Map,
        summary: "",
        sweep: &[&[]],
        extended: &[],
        applies: None,
        models: &[],
    };

    /// The registry's record of the technique: this entry with its options and constructor.
    pub fn info(self, options: Vec<OptionInfo>, create: Constructor) -> TechniqueInfo {
        TechniqueInfo {
            name: self.name,
            family: self.family,
            summary: self.summary,
            options,
            sweep: self.sweep,
            extended: self.extended,
            create,
            applies: self.applies,
            models: self.models,
        }
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
    /// The lights (and their scenes) the technique works on, for harnesses that run every
    /// technique on every scene (the sweep, the golden hashes): `None` for every light. On
    /// another its `visibility` is an error that says what is missing.
    pub applies: Option<fn(&Scene, &Light) -> bool>,
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
    /// Whether `light` of `scene` (the light, the scene's materials) has this effect.
    pub fn in_light(self, scene: &Scene, light: &Light) -> bool {
        match self {
            Effect::AreaLight => matches!(light.kind, crate::scene::LightKind::Area(_)),
            Effect::Transmittance => scene.objects.iter().any(|o| {
                scene
                    .materials
                    .get(o.material)
                    .is_some_and(crate::scene::Material::is_transparent)
            }),
        }
    }

    /// Whether any light of `scene` has this effect ([`Effect::in_light`]).
    pub fn in_scene(self, scene: &Scene) -> bool {
        scene.lights.iter().any(|l| self.in_light(scene, l))
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
    /// Whether the technique works on `light` of `scene` ([`TechniqueInfo::applies`]).
    pub fn applies_to_light(&self, scene: &Scene, light: &Light) -> bool {
        self.applies.is_none_or(|f| f(scene, light))
    }

    /// Whether the technique works on every light of `scene` ([`TechniqueInfo::applies`]).
    pub fn applies_to(&self, scene: &Scene) -> bool {
        scene.lights.iter().all(|l| self.applies_to_light(scene, l))
    }
}

/// A technique's constructor from `key=value` settings.
pub type Constructor = fn(&[(String, String)]) -> Result<Box<dyn ShadowTechnique>, Error>;

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
