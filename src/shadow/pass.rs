//! Techniques that are one shared pass. The irregular z-buffer, PCSS and stencil shadow
//! volumes live in their families' shared modules ([`super::exact::irregular`],
//! [`super::map::soft`], [`super::volume::stencil`]), because composite techniques hold them
//! too (the hybrid holds the first two, the multi-sample light the third); their technique
//! files keep only the options, the declaration and the registry entry, and the technique is
//! a [`PassTechnique`] of the pass. The volumetric techniques are a [`PassTechnique`] of
//! their light pass and the family's lookup ([`super::volumetric::Volumetric`]).

use crate::frame::Frame;
use crate::pipeline::Pipeline;
use crate::shadow::inspect::Steps;
use crate::shadow::technique::{ShadowTechnique, Stage, Step, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;

/// A shared pass that a technique can be: what [`ShadowTechnique`] asks, less the name and
/// the timing.
pub trait Pass: Send {
    /// What a run gives: one value per pixel (`Vec<f32>`) or a [`Visibility`].
    type Output: Into<Visibility>;
    /// Visibility per pixel of `frame` (NaN where no geometry), each pass timed into `passes`.
    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Self::Output, Error>;
    /// What the last run did at pixel `(x, y)`, step by step into `t`, and the image's value
    /// there, from the code that drew it (a composite reads its parts' values from here);
    /// `None`, with no steps, where the pass has not run or the pixel has no geometry.
    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32>;
    /// What the last run did at pixel `(x, y)`: [`Pass::explain`]'s steps, closed by the
    /// image's value as the result.
    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        crate::shadow::inspect::closed(|t| self.explain(frame, x, y, t))
    }
    /// The last run's buffers for `dump`.
    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error>;
    /// Work counters of the last run. Default: none.
    fn counters(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// Input warnings of the last run. Default: none.
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
    /// The light views of the last run's maps ([`ShadowTechnique::light_views`]). Default:
    /// none.
    fn light_views(&self) -> Vec<crate::shadow::light::LightView> {
        Vec::new()
    }
}

/// The technique `name` that is the pass `P`.
pub struct PassTechnique<P> {
    name: &'static str,
    /// The pass.
    pub(crate) pass: P,
    times: Vec<(&'static str, f64)>,
}

impl<P> PassTechnique<P> {
    /// The technique `name` running `pass`.
    pub fn with(name: &'static str, pass: P) -> PassTechnique<P> {
        PassTechnique {
            name,
            pass,
            times: Vec::new(),
        }
    }

    /// The pass.
    pub fn pass(&self) -> &P {
        &self.pass
    }
}

impl<P: Pass> ShadowTechnique for PassTechnique<P> {
    fn name(&self) -> &'static str {
        self.name
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        let out = self.pass.run(p, frame, &mut passes)?;
        self.times = passes.finish();
        Ok(out.into())
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        self.pass.inspect(frame, x, y)
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        self.pass.stages(p, frame)
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        self.pass.counters()
    }

    fn notes(&self) -> Vec<String> {
        self.pass.notes()
    }

    fn light_views(&self) -> Vec<crate::shadow::light::LightView> {
        self.pass.light_views()
    }
}
