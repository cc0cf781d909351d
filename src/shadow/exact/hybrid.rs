//! Hybrid frustum-traced shadows (Story and Wyman 2016; RTR 7.9): the irregular z-buffer's
//! exact hard shadow where the penumbra is narrow, PCSS where it is wide, blended by the
//! penumbra PCSS estimates.
//!
//! Per pixel, PCSS's blocker search ([`crate::shadow::map::pcss`]) gives the average blocker
//! distance `d_o` and, by RTR eq. 7.6, the penumbra's world width at the receiver,
//! `w = w_light (d_r - d_o) / d_o`. Measured in the camera pixel's world size at the point
//! (`s = 2 |p - eye| tan(fov / 2) / height`), `t = smoothstep(from, to, w / s)` blends:
//! `v = (1 - t) v_izb + t v_pcss`. Near contact (`w` below `from` pixels) the shadow is the
//! IZB's, exact and without bias, so there is no Peter Panning and no leak under a caster
//! whatever the map's bias; far from it PCSS's soft penumbra. No blocker found: the IZB (the
//! search's taps can miss a thin caster; the IZB cannot).
//!
//! Known failures: the blend inherits PCSS's average-blocker estimate (a wrong `w` picks the
//! wrong side), and in the blend band the mix of a hard and a soft edge is neither.

use crate::frame::Frame;
use crate::math;
use crate::pipeline::{Pipeline, Surface};
use crate::shadow::exact::irregular::{self, IrregularZBuffer};
use crate::shadow::inspect::{self, NoTrace, Step, Trace};
use crate::shadow::light::soft::light_size_fields;
use crate::shadow::map::soft::{self, SoftShadows};
use crate::shadow::pass::Pass;
use crate::shadow::pixels::per_pixel_map;
use crate::shadow::sample::lookup::lookup_fields;
use crate::shadow::technique::{Declaration, Entry, Family, Field, ShadowTechnique, Stage, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "hybrid",
    family: Family::Exact,
    summary: "hybrid frustum-traced shadows (Story and Wyman): the IZB's exact shadow where PCSS's penumbra is narrow, PCSS where wide",
    sweep: &[&[], &[("units", "100000")]],
    extended: &[&[("from", "0"), ("to", "1")], &[("from", "2"), ("to", "12")]],
    models: &[crate::shadow::technique::Effect::AreaLight],
    ..Entry::BASE
};

/// Options of the hybrid.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// PCSS's options (its map, bias, light width, taps). Default: PCSS's defaults.
    pub pcss: soft::Options,
    /// The IZB's grid side in texels. Default: 512.
    pub grid: u32,
    /// Penumbra width, in camera pixels at the point, below which the IZB's hard shadow is
    /// used alone. Default: 1.
    pub from: f32,
    /// Penumbra width in pixels above which PCSS is used alone. Default: 4.
    pub to: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            pcss: soft::Options::default(),
            grid: 512,
            from: 1.0,
            to: 4.0,
        }
    }
}

/// The option declaration: PCSS's, the IZB's grid and the blend band.
pub fn declaration() -> Declaration<Options> {
    let mut fields = lookup_fields(
        |o: &mut Options| &mut o.pcss.map,
        |o: &mut Options| &mut o.pcss.bias,
        |o: &mut Options| &mut o.pcss.wide,
    );
    fields.extend(light_size_fields(
        |o: &mut Options| &mut o.pcss.light,
        |o: &mut Options| &mut o.pcss.angle,
    ));
    fields.extend([
        Field::range(
            "grid",
            "the IZB's light-space grid side in texels",
            16,
            crate::pipeline::MAX_DIMENSION,
            |o: &mut Options| &mut o.grid,
        ),
        Field::range(
            "from",
            "penumbra width in camera pixels below which the IZB's exact hard shadow is used alone",
            0.0,
            1e6,
            |o: &mut Options| &mut o.from,
        ),
        Field::range(
            "to",
            "penumbra width in camera pixels above which PCSS is used alone",
            0.0,
            1e6,
            |o: &mut Options| &mut o.to,
        ),
    ]);
    Declaration::new("hybrid", fields)
}

/// The hybrid (see the module docs).
pub struct Hybrid {
    opts: Options,
    pcss: SoftShadows,
    izb: IrregularZBuffer,
    /// Last run: the blend weight of PCSS per pixel.
    weight: Vec<f32>,
    times: Vec<(&'static str, f64)>,
}

impl Hybrid {
    /// The hybrid with `opts`; an option out of its range, or `to` below `from`, is an error.
    pub fn new(opts: Options) -> Result<Hybrid, Error> {
        declaration().check(&opts)?;
        if opts.to < opts.from {
            return Err(declaration().error(
                "to",
                &opts.to.to_string(),
                format!("is below from={} (the blend band runs from from to to)", opts.from),
            ));
        }
        let mut pcss = SoftShadows::new(opts.pcss.clone());
        pcss.keep_penumbra(true);
        Ok(Hybrid {
            pcss,
            izb: IrregularZBuffer::new(irregular::Options {
                size: opts.grid,
                ..Default::default()
            }),
            opts,
            weight: Vec::new(),
            times: Vec::new(),
        })
    }

    /// PCSS's weight at pixel `(x, y)` (0: the IZB alone) and the penumbra in pixels, from the
    /// penumbra world width PCSS kept for the pixel in its lookup pass (the image's and
    /// `inspect`'s one source).
    fn weight_at(&self, frame: &Frame, x: usize, y: usize) -> (f32, f32) {
        let world = self.pcss.kept_penumbra().get(y * frame.width() as usize + x).copied();
        self.weight_of(frame, x, y, world.filter(|w| !w.is_nan()))
    }

    /// [`Hybrid::weight_at`] from the pixel's penumbra world width (`None`: no penumbra).
    fn weight_of(&self, frame: &Frame, x: usize, y: usize, world: Option<f32>) -> (f32, f32) {
        let Some(world) = world else {
            return (0.0, 0.0);
        };
        let Some(s) = frame.points()[y * frame.width() as usize + x] else {
            return (0.0, 0.0);
        };
        let cam = &frame.camera;
        let pixel =
            2.0 * (s.position - cam.position).length() * math::tan(cam.fov_deg.to_radians() * 0.5) / cam.height as f32;
        let px = world / pixel.max(1e-12);
        let (a, b) = (self.opts.from, self.opts.to);
        let t = if px <= a {
            0.0
        } else if px >= b {
            1.0
        } else {
            let u = (px - a) / (b - a);
            u * u * (3.0 - 2.0 * u)
        };
        (t, px)
    }
}

impl Hybrid {
    /// The blend of the IZB's `hard` and PCSS's `soft` visibility with PCSS's weight `t`
    /// (`px`: the penumbra's width in pixels that gave it), reported to `trace`: the image's
    /// per-pixel function, and `inspect`'s.
    #[inline(always)]
    fn blend(&self, hard: f32, soft: f32, t: f32, px: f32, trace: &mut impl Trace) -> f32 {
        trace.step(|| {
            Step::new(
                "blend",
                "PCSS's weight: smoothstep(from, to, penumbra width in camera pixels at the point); (1 - weight) IZB + weight PCSS",
            )
            .num("penumbra width in pixels", px)
            .num("from", self.opts.from)
            .num("to", self.opts.to)
            .num("weight of PCSS", t)
            .num("IZB", hard)
            .num("PCSS", soft)
        });
        if t == 0.0 {
            hard
        } else {
            hard + (soft - hard) * t
        }
    }
}

impl ShadowTechnique for Hybrid {
    fn name(&self) -> &'static str {
        "hybrid"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        // Each part's own passes are timed as one.
        let soft = self.pcss.run(p, frame, &mut Passes::start())?;
        passes.end("pcss");
        let hard = self.izb.run(p, frame, &mut Passes::start())?;
        passes.end("izb");
        let this = &*self;
        // The penumbra widths PCSS kept from its lookup pass: its blocker searches are not
        // made twice.
        let w = frame.width() as usize;
        let both = per_pixel_map(p, frame, |x, y| {
            let i = y * w + x;
            let (t, px) = this.weight_at(frame, x, y);
            (this.blend(hard[i], soft[i], t, px, &mut NoTrace), t)
        });
        let out: Vec<f32> = both.iter().map(|b| b.0).collect();
        self.weight = both.iter().map(|b| b.1).collect();
        passes.end("blend");
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        // Each part explains the pixel with the code that drew it and gives its value, which
        // the blend takes (the values the image blended).
        inspect::closed(|t| {
            t.step(|| Step::new("pcss", "PCSS at the pixel: the blocker search gives the penumbra"));
            let soft = self.pcss.explain(frame, x, y, t)?;
            t.step(|| Step::new("izb", "the irregular z-buffer at the pixel: the exact hard shadow"));
            let hard = self.izb.explain(frame, x, y, t)?;
            let (w, px) = self.weight_at(frame, x as usize, y as usize);
            Some(self.blend(hard, soft, w, px, t))
        })
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let soft = self.weight.iter().filter(|&&t| t > 0.0).count();
        let mut c = vec![("pixels blended toward pcss", soft as f64)];
        c.extend(self.pcss.counters());
        c.extend(self.izb.counters());
        c
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v = vec![Stage::unit(
            "pcss_weight",
            Surface::from_vec(frame.width(), frame.height(), self.weight.clone())?,
        )];
        v.extend(self.pcss.stages(p, frame)?);
        v.extend(self.izb.stages(p, frame)?);
        Ok(v)
    }
}
