//! Shadow techniques: one technique, one file, in a folder per family; one `Options` struct
//! and one shared trait each.
//!
//! Every technique takes the same [`crate::Frame`] (scene, light, camera G-buffer) and returns
//! the same thing, a [`Visibility`] image (1 = lit, 0 = shadowed, NaN where no geometry; one
//! value per pixel, or one per colour channel), so techniques are comparable, chartable and
//! testable against one reference. Each lists the intermediate buffers of its last run as
//! [`Stage`]s for `penumbra dump` and explains one pixel as [`Step`]s for `penumbra inspect`.
//!
//! The floors of `shadow/`, bottom up (no module imports one above it):
//! 1. the vocabulary: [`options`] (every option declared once per field), [`inspect`]
//!    (steps), [`stage`] (dumped buffers), [`timing`], [`pixels`], [`overview`];
//! 2. [`light`]: the light side (view kinds, the map pass, [`light::locate`] with its one
//!    edge rule, the soft-shadow geometry);
//! 3. [`technique`]: the contract ([`ShadowTechnique`], [`Family`], [`TechniqueInfo`]);
//! 4. [`pass`] (a shared pass as a technique) and the families: [`map`] (shadow maps, and
//!    in [`sample::lookup`] the per-pixel half of the depth-map techniques), [`filtered`] (VSM,
//!    convolution maps, ESM, EVSM, MSM), [`volume`] (shadow volumes and silhouettes),
//!    [`planar`] (planar shadows and cookies), [`exact`] (the irregular z-buffer),
//!    [`volumetric`] (coloured transparency maps, opacity and deep opacity maps, deep shadow
//!    maps, AVSM), [`penumbra`] (PVM, PVMF), [`screen`] (screen-space shadows, terrain
//!    occlusion height), [`mod@reference`] (the ray tracer as a technique);
//! 5. [`registry`]: every technique by name, `key=value` settings onto its options, and
//!    [`registry::techniques`], every technique's type.

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
pub mod registry;
pub mod sample;
pub mod screen;
pub mod stage;
pub mod technique;
pub mod timing;
pub mod volume;
pub mod volumetric;

pub use technique::{
    object_named, Constructor, Declaration, Effect, Family, Field, OptionInfo, ShadowTechnique, Stage, Step,
    TechniqueInfo, Value, Visibility,
};
