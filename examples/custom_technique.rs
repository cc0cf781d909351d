//! A map-based shadow technique written outside the library, on its shared layer (the
//! README's "Adding a shadow technique" walks through it): a shadow map compared with 2x2
//! PCF, with the normal-offset and receiver-plane bias. It renders a scene, measures it
//! against the ray-traced reference and explains one pixel from the code that drew it.
//!
//! `cargo run --release --example custom_technique -- fixtures/scenes/contact.toml`

use penumbra::frame::Frame;
use penumbra::pipeline::Pipeline;
use penumbra::reference::{Reference, ReferenceOptions};
use penumbra::shadow::inspect::{self, NoTrace, Trace};
use penumbra::shadow::light::{Layer, MapOptions};
use penumbra::shadow::options::within;
use penumbra::shadow::pixels::per_pixel_counted;
use penumbra::shadow::sample::lookup::{Bias, MapLookup, Prepared, Setup};
use penumbra::shadow::timing::Passes;
use penumbra::shadow::{Declaration, ShadowTechnique, Stage, Step, Visibility};
use penumbra::Error;
use penumbra::{frame, metrics, scene};
use std::path::Path;

/// Options of the technique: only what it reads.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Options {
    /// The map pass. Default: its defaults (2048 texels, f32, 4 units, slope 1.1).
    pub map: MapOptions,
    /// Normal-offset and receiver-plane bias. Default: none.
    pub bias: Bias,
}

/// The option declaration (`key=value` settings, ranges, the constructor's check).
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(MapOptions::fields(), |o: &mut Options| &mut o.map);
    fields.extend(within(Bias::fields(), |o: &mut Options| &mut o.bias));
    Declaration::new("soft-edge", fields)
}

/// A shadow map compared with 2x2 PCF.
pub struct SoftEdge {
    lookup: MapLookup,
    taps: u64,
    times: Vec<(&'static str, f64)>,
}

impl SoftEdge {
    /// The technique with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<SoftEdge, Error> {
        declaration().check(&opts)?;
        Ok(SoftEdge {
            lookup: MapLookup::new(Setup {
                map: opts.map,
                layer: Layer::First,
                bias: opts.bias,
                wide: None,
                min_max: false,
            }),
            taps: 0,
            times: Vec::new(),
        })
    }

    /// The per-pixel work, once: the image runs it with `NoTrace`, `inspect` with a recording
    /// trace.
    fn pixel(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        match self.lookup.prepare(frame, x, y, t) {
            Prepared::Done(v, n) => (v, n),
            Prepared::At(at) => (self.lookup.compare(&at, true, t), 1),
        }
    }
}

impl ShadowTechnique for SoftEdge {
    fn name(&self) -> &'static str {
        "soft-edge"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        self.lookup.light_pass(p, frame)?;
        passes.end("light pass");
        let this = &*self;
        let (out, taps) = per_pixel_counted(p, frame, |x, y| this.pixel(frame, x, y, &mut NoTrace));
        passes.end("lookup pass");
        (self.taps, self.times) = (taps, passes.finish());
        Ok(Visibility::Scalar(out))
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        self.lookup.stages(p, frame)
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        inspect::explain(|t| self.pixel(frame, x as usize, y as usize, t).0)
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![("taps", self.taps as f64)]
    }
}

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().collect();
    let scene_path = args.get(1).map_or("fixtures/scenes/contact.toml", String::as_str);
    let scene = scene::file::load(Path::new(scene_path))?;
    let p = Pipeline::new(0)?;
    let f = frame::frame(&p, &scene, 0, 0)?;

    // `--set`-style settings go through the same declaration as the library constructor.
    let sets = [("size".to_string(), "1024".to_string()), ("normal".into(), "1".into())];
    let mut t = SoftEdge::new(declaration().parse(&sets)?)?;
    let v = t.visibility(&p, &f)?;

    let r = p.install(|| Reference::new(&scene));
    let reference = p.install(|| r.visibility(f.points(), f.width() as usize, &f.light, &ReferenceOptions::default()));
    let e = metrics::compare(&v, &reference, &f.metric_mask());
    println!(
        "soft-edge on {}: RMSE {:.4}, wrong {:.3} %; passes {:?}",
        scene.name,
        e.rmse,
        e.wrong_pct,
        t.timings()
    );

    // One pixel, explained by the code that drew it: its last step is the image's value.
    let (x, y) = (f.width() / 2, f.height() * 3 / 4);
    let steps = t.inspect(&f, x, y);
    for s in &steps {
        println!("  {}: {}", s.name, s.what);
    }
    let i = (y * f.width() + x) as usize;
    match steps.last().and_then(|s| s.values.first()) {
        Some((_, inspect::Value::Num(n))) if (*n as f32).to_bits() == v.value(i).to_bits() => Ok(()),
        _ if f.point(x, y).is_none() => Ok(()),
        other => Err(Error::input(format!(
            "inspect's result {other:?} is not the image's {}",
            v.value(i)
        ))),
    }
}
