//! A shadow map with screen-space contact shadows (RTR 7.10; the way HDRP and Unreal ship
//! them): the map, with the bias that keeps it free of acne, gives the distant shadows; a short
//! march of [`super::march`] towards the light gives the last stretch, where the bias has
//! pushed the map's shadow away from its caster (Peter Panning) and where small features fall
//! between its texels. The pixel's visibility is the smaller of the two. Pixels the map already
//! shadows fully are not marched.
//!
//! Known failures: the march's own (off-screen and hidden occluders add nothing near them, a
//! thin occluder's contact shadow is `thickness` long); beyond `length` the map's errors stay.

use super::march::{self, DepthField, Hit, March};
use crate::frame::Frame;
use crate::pipeline::Pipeline;
use crate::shadow::inspect::{self, Trace};
use crate::shadow::map::plain::{self, MapPass};
use crate::shadow::map::shadow_map;
use crate::shadow::options::within;
use crate::shadow::pass::Pass;
use crate::shadow::technique::{Declaration, Entry, Family, ShadowTechnique, Stage, Step, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "contact-map",
    family: Family::Screen,
    summary: "a shadow map plus a short screen-space march to the light (HDRP, Unreal; RTR 7.10): contact shadows the bias lost, within the march's length",
    sweep: &[
        &[],
        &[("units", "100000")],
        &[("length", "0.5")],
        &[("filter", "pcf2"), ("steps", "8")],
    ],
    extended: &[&[("size", "512")], &[("steps", "32"), ("jitter", "false")]],
    ..Entry::BASE
};

/// Options of the shadow map with contact shadows.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The shadow map (every option of `shadow-map`). Default: its defaults, whose bias keeps
    /// it free of acne.
    pub map: shadow_map::Options,
    /// The contact march. Default: 16 steps over 0.15 world units (HDRP's default length, in
    /// metres), an occluder thickness of 0.1, jittered.
    pub march: March,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            map: shadow_map::Options::default(),
            march: March::new(16, 0.15, 0.1),
        }
    }
}

/// The option declaration: the shadow map's options, then the march's.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(shadow_map::declaration().fields, |o: &mut Options| &mut o.map);
    fields.extend(within(March::fields(), |o: &mut Options| &mut o.march));
    Declaration::new("contact-map", fields)
}

/// The shadow map with contact shadows (see the module docs).
pub struct ContactMap {
    opts: Options,
    map: MapPass,
    /// Last run: the map's visibility, the depth field and each pixel's march.
    map_v: Vec<f32>,
    field: Option<DepthField>,
    hits: Vec<Hit>,
    times: Vec<(&'static str, f64)>,
}

impl ContactMap {
    /// The technique with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<ContactMap, Error> {
        declaration().check(&opts)?;
        if let Some((key, value, message)) = plain::beyond_ranges(&opts.map) {
            return Err(declaration().error(key, &value, message));
        }
        Ok(ContactMap {
            map: MapPass::new(opts.map.clone()),
            opts,
            map_v: Vec::new(),
            field: None,
            hits: Vec::new(),
            times: Vec::new(),
        })
    }

    /// The pixel's value from its map value and march, each step reported to `t`.
    fn combine(&self, frame: &Frame, field: &DepthField, x: u32, y: u32, t: &mut impl Trace) -> f32 {
        let i = (y * frame.width() + x) as usize;
        let m = self.map_v[i];
        let Some(s) = frame.point(x, y) else {
            return f32::NAN;
        };
        t.step(|| Step::new("shadow map", "the map's visibility at the pixel").num("visibility", m));
        if m <= 0.0 {
            t.step(|| Step::new("contact", "the map shadows the pixel fully: no march"));
            return 0.0;
        }
        let h = field.march(frame, &self.opts.march, x, y, s.position, t);
        t.step(|| {
            Step::new("combine", "the smaller of the map's and the march's visibility")
                .num("map", m)
                .num("march", h.v)
        });
        m.min(h.v)
    }
}

impl ShadowTechnique for ContactMap {
    fn name(&self) -> &'static str {
        "contact-map"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        let map_v = self.map.run(p, frame, &mut passes)?;
        let field = DepthField::new(p, frame)?;
        passes.end("linear depth");
        let w = frame.width() as usize;
        self.hits = march::march_all(p, frame, &field, &self.opts.march, |x, y| map_v[y * w + x] <= 0.0);
        let out = map_v.iter().zip(&self.hits).map(|(&m, h)| m.min(h.v)).collect();
        passes.end("march");
        self.map_v = map_v;
        self.field = Some(field);
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let Some(field) = &self.field else {
            return Vec::new();
        };
        // The map's explanation (its value is the image's map visibility that `combine`
        // reads), then the combination.
        inspect::closed(|t| {
            self.map.explain(frame, x, y, t)?;
            Some(self.combine(frame, field, x, y, t))
        })
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v = self.map.stages(p, frame)?;
        v.push(Stage::pixels(frame, "map_visibility", self.map_v.clone(), 0.0, 1.0)?);
        if let Some(field) = &self.field {
            v.push(field.stage(frame));
            v.push(march::hit_stage(frame, &self.hits, self.opts.march.length)?);
        }
        Ok(v)
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let mut c = self.map.counters();
        c.extend(march::counters(&self.hits));
        c
    }
}
