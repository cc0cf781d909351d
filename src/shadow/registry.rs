//! The registry, the top floor of `shadow/`: every technique by name, with its options, and
//! `key=value` settings onto them. It imports every family; no family imports it.

use super::technique::{Family, ShadowTechnique, Stage, Step, TechniqueInfo, Visibility};
use super::{exact, filtered, light, map, penumbra, planar, reference, screen, volume, volumetric};
use crate::error::quoted;
use crate::frame::Frame;
use crate::pipeline::Pipeline;
use crate::Error;

impl Family {
    /// The family of the registered technique `name`.
    pub fn of(name: &str) -> Option<Family> {
        registry().into_iter().find(|t| t.name == name).map(|t| t.family)
    }
}

/// Declares the registry from one list, each technique written once: its module (whose
/// `ENTRY` and `declaration()` make its registry record) and its type, built by `Type::new`
/// (or by the module's function named after `by`), re-exported with the module in
/// [`techniques`].
macro_rules! techniques {
    ($($($seg:ident)::+ => $ty:ident $(by $make:ident)?,)*) => {
        /// All techniques, in chart order.
        pub fn registry() -> Vec<TechniqueInfo> {
            vec![$(
                $($seg)::+::ENTRY.info($($seg)::+::declaration().infos(), |pairs| {
                    let options = $($seg)::+::declaration().parse(pairs)?;
                    Ok(Box::new(constructor!([$($seg)::+] $ty $($make)?)(options)?))
                }),
            )*]
        }

        /// Every technique's type, and its module with its `Options`, under one name: build
        /// one in code with `techniques::ShadowMap::new(techniques::shadow_map::Options { .. })`,
        /// or by name with [`create`]. The same list as [`registry`].
        pub mod techniques {
            pub use crate::reference::ReferenceOptions;
            pub use crate::shadow::reference as reference_technique;
            $(pub use crate::shadow::$($seg)::+::{self, $ty};)*
        }
    };
}

/// A technique's constructor from its options: `Type::new`, or the module's function `by`
/// names (for types shared by several techniques, as the warped maps share theirs).
macro_rules! constructor {
    ([$($path:tt)*] $ty:ident) => {
        $($path)*::$ty::new
    };
    ([$($path:tt)*] $ty:ident $make:ident) => {
        $($path)*::$make
    };
}

techniques! {
    reference => RefTechnique,
    map::shadow_map => ShadowMap,
    map::cascaded => Csm by csm,
    map::sdsm => Sdsm by sdsm,
    map::lispsm => Lispsm by lispsm,
    map::logpsm => Logpsm by logpsm,
    map::tsm => Tsm by tsm,
    map::psm => Psm by psm,
    map::pcss => Pcss,
    map::chs => Chs,
    map::multi_sample => MultiSample,
    filtered::vsm => Vsm,
    filtered::convolution => Convolution,
    filtered::esm => Esm,
    filtered::evsm => Evsm,
    filtered::msm => Msm,
    volume::shadow_volume => ShadowVolume,
    planar::projected => Planar,
    planar::cookie => Cookie,
    exact::izb => Izb,
    exact::hybrid => Hybrid,
    penumbra::pvm => Pvm,
    penumbra::pvmf => Pvmf,
    volumetric::transparency_map => TransparencyMap,
    volumetric::opacity_maps => OpacityMaps,
    volumetric::deep_shadow_map => DeepShadowMap,
    volumetric::avsm => Avsm,
    screen::screen_space => ScreenSpace,
    screen::contact => ContactMap,
    screen::terrain => TerrainHeight,
}

/// Creates technique `name` with `key=value` settings; errors name unknown techniques and
/// options and list the valid ones.
pub fn create(name: &str, pairs: &[(String, String)]) -> Result<Box<dyn ShadowTechnique>, Error> {
    let reg = registry();
    let Some(info) = reg.iter().find(|t| t.name == name) else {
        let names: Vec<&str> = reg.iter().map(|t| t.name).collect();
        return Err(Error::technique(format!(
            "unknown technique {} (known: {})",
            quoted(name),
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
