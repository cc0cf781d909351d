//! The reference registered as a technique (`reference`): the ray-traced ground truth, so it
//! sits on the chart as the point every technique is measured against (error 0, its own cost).

use crate::frame::Frame;
use crate::pipeline::{Pipeline, Surface};
use crate::reference::{Reference, ReferenceOptions};
use crate::shadow::inspect::{self, Step};
use crate::shadow::technique::{Declaration, Entry, Family, Field, ShadowTechnique, Stage, Visibility};
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "reference",
    family: Family::Reference,
    summary: "BVH ray tracer: exact hard visibility; area lights by stratified sampling (ground truth)",
    sweep: &[&[]],
    ..Entry::BASE
};

/// Options of the reference technique.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Sample the area of area lights (false: hard visibility from the centre). Default: true.
    pub area: bool,
    /// Samples per penumbra pixel (n x n strata). Default: 1024.
    pub samples: u32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            area: true,
            samples: 1024,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new(
        "reference",
        vec![
            Field::new(
                "area",
                "sample the area of area lights (false: hard visibility from the centre)",
                |o: &mut Options| &mut o.area,
            ),
            Field::range(
                "samples",
                "samples per penumbra pixel (n x n strata)",
                1,
                1 << 16,
                |o: &mut Options| &mut o.samples,
            ),
        ],
    )
}

/// The ray tracer as a technique.
pub struct RefTechnique {
    opts: ReferenceOptions,
    last: Option<Visibility>,
    /// The last run's ray tracer (its BVH), for `inspect`.
    tracer: Option<Reference>,
}

impl RefTechnique {
    /// The reference with `opts`.
    pub fn new(opts: Options) -> Result<RefTechnique, Error> {
        declaration().check(&opts)?;
        Ok(RefTechnique {
            opts: ReferenceOptions {
                area: opts.area,
                area_samples: opts.samples,
                ..Default::default()
            },
            last: None,
            tracer: None,
        })
    }
}

impl ShadowTechnique for RefTechnique {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let r = p.install(|| Reference::new(frame.scene));
        let pts = frame.points();
        let v = p.install(|| r.visibility(pts, frame.width() as usize, &frame.light, &self.opts));
        self.last = Some(v.clone());
        self.tracer = Some(r);
        Ok(v)
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let (Some(v), Some(r)) = (&self.last, &self.tracer) else {
            return Vec::new();
        };
        let i = (y * frame.width() + x) as usize;
        let Some(s) = frame.point(x, y) else {
            return vec![inspect::result(v.value(i))];
        };
        // The image's own per-point function, reporting what it traced.
        let (rgb, report) = r.explain(&s, &frame.light, i as u64, &self.opts);
        debug_assert_eq!(rgb, v.rgb(i), "the reference explains the value it drew");
        let mut st = Step::new(
            "ray tracing",
            "hard: one ray to the light's centre; area lights: stratified samples over the light (adaptive: 8x8 pilot and 32 rim rays, then the full count where they disagree)",
        )
        .flag("area", self.opts.area)
        .int("samples", self.opts.area_samples)
        .vec3("ray origin (off the surface)", report.origin)
        .int("light samples", report.rays);
        if let Some((_, d, t)) = report.hard_ray {
            st = st.vec3("ray direction", d).num("ray length", t);
        }
        if let Some(pilot) = report.pilot {
            st = st.vec3("pilot (8 x 8 strata) per channel", pilot);
        }
        if let Some(agrees) = report.rim_agrees {
            st = st.flag("rim rays agree with the pilot", agrees);
        }
        if report.strata > 0 {
            st = st.int("strata per side", report.strata);
        }
        vec![st.vec3("per channel", rgb), inspect::result(v.value(i))]
    }

    fn stages(&self, _: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        self.last
            .iter()
            .map(|v| {
                Surface::from_vec(frame.width(), frame.height(), v.to_scalar())
                    .map(|data| Stage::Scalar {
                        name: "visibility".into(),
                        data,
                        lo: 0.0,
                        hi: 1.0,
                    })
                    .map_err(Error::from)
            })
            .collect()
    }
}
