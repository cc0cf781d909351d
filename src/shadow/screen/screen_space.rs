//! Screen-space shadows alone (Sousa et al. 2013; RTR 7.10): every pixel's visibility is the
//! march of [`super::march`] through the camera's depth buffer, with no light-space data at
//! all. Hard shadows of what the camera sees, cast no farther than the march's length.
//!
//! Known failures: occluders outside the view cast nothing (`offscreen`); an occluder is only
//! `thickness` deep, so thin ones cast shadows far longer than they are and thick ones leak
//! behind their front faces (`thin_sheet`); surfaces hidden from the camera do not occlude.

use super::march::{self, DepthField, Hit, March};
use crate::frame::Frame;
use crate::pipeline::Pipeline;
use crate::shadow::inspect::Steps;
use crate::shadow::options::within;
use crate::shadow::pass::{Pass, PassTechnique};
use crate::shadow::technique::{Declaration, Entry, Family, Stage};
use crate::shadow::timing::Passes;
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "screen-space",
    family: Family::Screen,
    summary: "a ray march through the camera's depth buffer towards the light (RTR 7.10): occluders off screen, hidden or behind their front faces cast nothing",
    sweep: &[
        &[],
        &[("steps", "8")],
        &[("steps", "32")],
        &[("jitter", "false")],
        &[("thickness", "0.05")],
        &[("thickness", "5")],
    ],
    extended: &[&[("steps", "64")], &[("length", "0.5")]],
    ..Entry::BASE
};

/// Options of screen-space shadows.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The march. Default: 16 steps over 2 world units (a room-scale caster's shadow), an
    /// occluder thickness of 0.5 world units, jittered.
    pub march: March,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            march: March::new(16, 2.0, 0.5),
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new("screen-space", within(March::fields(), |o: &mut Options| &mut o.march))
}

/// The screen-space march as a pass.
pub struct ScreenPass {
    opts: Options,
    field: Option<DepthField>,
    hits: Vec<Hit>,
}

/// Screen-space shadows (see the module docs).
pub type ScreenSpace = PassTechnique<ScreenPass>;

impl ScreenSpace {
    /// Screen-space shadows with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<ScreenSpace, Error> {
        declaration().check(&opts)?;
        Ok(PassTechnique::with(
            "screen-space",
            ScreenPass {
                opts,
                field: None,
                hits: Vec::new(),
            },
        ))
    }
}

impl Pass for ScreenPass {
    type Output = Vec<f32>;

    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Vec<f32>, Error> {
        let field = DepthField::new(p, frame)?;
        passes.end("linear depth");
        self.hits = march::march_all(p, frame, &field, &self.opts.march, |_, _| false);
        passes.end("march");
        self.field = Some(field);
        Ok(self.hits.iter().map(|h| h.v).collect())
    }

    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32> {
        let field = self.field.as_ref()?;
        Some(match frame.point(x, y) {
            None => f32::NAN,
            Some(s) => field.march(frame, &self.opts.march, x, y, s.position, t).v,
        })
    }

    fn stages(&self, _: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let Some(field) = &self.field else {
            return Ok(Vec::new());
        };
        Ok(vec![
            field.stage(frame),
            march::hit_stage(frame, &self.hits, self.opts.march.length)?,
        ])
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        march::counters(&self.hits)
    }
}
