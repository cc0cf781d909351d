//! The multi-sample area light (the CS300 slides; Heckbert and Herf 1997; RTR 7.1): the area
//! light replaced by `samples` point lights spread over it, a hard shadow from each, averaged.
//! `v = (1 / N) sum_i v_i`, where `v_i` is the hard visibility from sample point `i`: a shadow
//! map (a cube map from the point, 2x2 PCF) or, with `method=volumes`, an exact stencil
//! shadow-volume pass. It converges to the area light's visibility as `N` grows, at `N` times
//! the cost of one hard shadow: the honest baseline every soft technique must beat at equal
//! time.
//!
//! The points are a Hammersley set over the unit square, `((i + 1/2) / N, radical_inverse_2(i))`
//! (stratified for any `N`, the same on every run), taken onto the light: a disk by the
//! concentric map (Shirley and Chiu 1997), a rectangle by its sides; a sphere light by the
//! disk of its radius facing its direction (the sphere's silhouette seen from afar). Point,
//! spot and directional lights have no area: one sample, the hard shadow.
//!
//! Known failures: banding, `N` overlapping copies of the hard shadow, where a penumbra is
//! wider than `N`'s spacing allows (few samples, large lights); each map's own bias and
//! aliasing, repeated `N` times.

use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::{Pipeline, Rgba8, Surface};
use crate::reference::concentric_disk;
use crate::scene::{AreaShape, Light, LightKind};
use crate::shadow::inspect::{self, NoTrace, Step};
use crate::shadow::light::{Layer, MapOptions};
use crate::shadow::pass::Pass;
use crate::shadow::pixels::per_pixel_counted;
use crate::shadow::sample::lookup::{MapLookup, Prepared, Setup};
use crate::shadow::technique::{Declaration, Entry, Family, Field, ShadowTechnique, Stage, Visibility};
use crate::shadow::timing::Passes;
use crate::shadow::volume::stencil::{Mode, StencilVolumes};
use crate::Error;
use glam::{Vec2, Vec3};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "multi-sample",
    family: Family::Map,
    summary: "N hard shadows from points over the area light, averaged (Heckbert and Herf): converges to the reference",
    sweep: &[
        &[("samples", "4"), ("size", "512")],
        &[("samples", "16"), ("size", "512")],
        &[("samples", "16"), ("method", "volumes")],
    ],
    extended: &[
        &[],
        &[("samples", "64"), ("size", "512")],
        &[("samples", "256"), ("size", "512")],
        &[("samples", "64"), ("method", "volumes")],
    ],
    models: &[crate::shadow::technique::Effect::AreaLight],
    ..Entry::BASE
};

choice_enum! {
    /// How each sample's hard shadow is computed.
    pub enum Method {
        /// A shadow map (cube map) per sample point.
        Maps = "maps",
        /// A stencil shadow-volume pass per sample point (exact hard shadows).
        Volumes = "volumes",
    }
}

/// Most samples.
pub const MAX_SAMPLES: u32 = 1024;

/// Options of the multi-sample area light.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Point lights over the area light (1 to 1024). Default: 16.
    pub samples: u32,
    /// Hard shadow per sample. Default: maps.
    pub method: Method,
    /// Maps: side of each cube face in texels. Default: 1024.
    pub size: u32,
    /// Maps: 2x2 PCF (false: one comparison). Default: true.
    pub pcf: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            samples: 16,
            method: Method::Maps,
            size: 1024,
            pcf: true,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new(
        "multi-sample",
        vec![
            Field::range(
                "samples",
                "point lights over the area light",
                1,
                MAX_SAMPLES,
                |o: &mut Options| &mut o.samples,
            ),
            Field::new(
                "method",
                "hard shadow per sample: maps (cube shadow maps) or volumes (stencil shadow volumes, exact)",
                |o: &mut Options| &mut o.method,
            ),
            Field::size("maps: side of each cube face in texels", |o: &mut Options| &mut o.size),
            Field::new("pcf", "maps: 2x2 PCF (false: one comparison)", |o: &mut Options| {
                &mut o.pcf
            }),
        ],
    )
}

/// Van der Corput's radical inverse in base 2.
fn radical_inverse(i: u32) -> f32 {
    (i.reverse_bits() as f64 / 4_294_967_296.0) as f32
}

/// The `n` sample points of `light` (see the module docs); one, its centre, without an area.
pub fn sample_points(light: &Light, n: u32) -> Vec<Vec3> {
    let LightKind::Area(shape) = light.kind else {
        return vec![light.position];
    };
    let (t1, t2) = light.tangents();
    (0..n)
        .map(|i| {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, radical_inverse(i));
            let q = match shape {
                AreaShape::Disk { radius } | AreaShape::Sphere { radius } => concentric_disk(u) * radius,
                AreaShape::Rectangle { width, height } => (u - Vec2::splat(0.5)) * Vec2::new(width, height),
            };
            light.position + t1 * q.x + t2 * q.y
        })
        .collect()
}

/// The multi-sample area light (see the module docs).
pub struct MultiSample {
    opts: Options,
    /// With `method=maps`: the sample's cube map and its lookups.
    lookup: MapLookup,
    /// With `method=volumes`: the sample's stencil pass.
    volume: StencilVolumes,
    points: Vec<Vec3>,
    taps: f64,
    times: Vec<(&'static str, f64)>,
}

impl MultiSample {
    /// The technique with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<MultiSample, Error> {
        declaration().check(&opts)?;
        Ok(MultiSample {
            lookup: MapLookup::new(Self::setup(&opts)),
            volume: StencilVolumes::new(Mode::Auto),
            opts,
            points: Vec::new(),
            taps: 0.0,
            times: Vec::new(),
        })
    }

    /// The lookup of each sample's map: the default map pass at `size`, no per-pixel bias,
    /// one comparison or 2x2 PCF.
    fn setup(o: &Options) -> Setup {
        Setup {
            map: MapOptions {
                size: o.size,
                ..Default::default()
            },
            layer: Layer::First,
            bias: Default::default(),
            wide: None,
            min_max: false,
        }
    }

    /// One sample's hard shadow at pixel `(x, y)` of `frame` (whose light is the sample's)
    /// from `lookup`'s last pass: the visibility and the taps.
    #[inline(always)]
    fn hard(lookup: &MapLookup, frame: &Frame, pcf: bool, x: usize, y: usize) -> (f32, u64) {
        match lookup.prepare(frame, x, y, &mut NoTrace) {
            Prepared::Done(v, n) => (v, n),
            Prepared::At(at) => (lookup.compare(&at, pcf, &mut NoTrace), 1),
        }
    }

    /// One sample's hard visibility per pixel of `frame` (whose light is the sample's), with
    /// the taps; the passes' times added to `passes`.
    fn sample(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<(Vec<f32>, u64), Error> {
        passes.skip();
        match self.opts.method {
            Method::Maps => {
                self.lookup.light_pass(p, frame)?;
                passes.end("light pass");
                let (lookup, pcf) = (&self.lookup, self.opts.pcf);
                let (v, taps) = per_pixel_counted(p, frame, |x, y| Self::hard(lookup, frame, pcf, x, y));
                passes.end("lookup pass");
                Ok((v, taps))
            }
            Method::Volumes => {
                let v = self.volume.run(p, frame, passes)?;
                Ok((v, 0))
            }
        }
    }

    /// The sample points of the last run.
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// The light of sample point `q`: a point light there, with the area light's intensity.
    fn point_light(light: &Light, q: Vec3) -> Light {
        Light {
            kind: LightKind::Point,
            position: q,
            ..*light
        }
    }
}

/// Runs `per` on each sample of `points` in order, with `frame` lit by the sample's light (a
/// point light there for an area light; the light itself otherwise): the one sampling loop
/// of the image and of `inspect`.
fn each_sample(
    frame: &Frame,
    points: &[Vec3],
    mut per: impl FnMut(usize, &Frame) -> Result<(), Error>,
) -> Result<(), Error> {
    let mut sampled = frame.with_light(frame.light);
    for (k, &q) in points.iter().enumerate() {
        sampled.light = match frame.light.kind {
            LightKind::Area(_) => MultiSample::point_light(&frame.light, q),
            _ => frame.light,
        };
        per(k, &sampled)?;
    }
    Ok(())
}

impl ShadowTechnique for MultiSample {
    fn name(&self) -> &'static str {
        "multi-sample"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        self.points = sample_points(&frame.light, self.opts.samples);
        let mut sum = vec![0.0f32; frame.points().len()];
        let mut passes = Passes::start();
        self.taps = 0.0;
        let points = self.points.clone();
        each_sample(frame, &points, |_, sampled| {
            let (v, taps) = self.sample(p, sampled, &mut passes)?;
            // The same order of additions at every pixel for any thread count.
            for (s, v) in sum.iter_mut().zip(&v) {
                *s += v;
            }
            self.taps += taps as f64;
            Ok(())
        })?;
        let n = self.points.len() as f32;
        sum.iter_mut().for_each(|s| *s /= n);
        self.times = passes.finish();
        Ok(Visibility::Scalar(sum))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let mut steps = vec![Step::new(
            "samples",
            "point lights over the area light (a Hammersley set), each a hard shadow, averaged",
        )
        .int("samples", self.points.len())
        .text("method", self.opts.method.as_str())];
        if self.points.is_empty() {
            return steps;
        }
        // Each sample's hard visibility at the pixel, from the passes the image ran for it (on
        // one worker, at most 32 listed), summed in the image's order.
        let Ok(p) = Pipeline::new(1) else { return steps };
        let i = (y * frame.width() + x) as usize;
        let mut sum = 0.0f32;
        // The same passes as the image's, in a technique of the same options.
        let Ok(mut again) = MultiSample::new(self.opts.clone()) else {
            return steps;
        };
        let _ = each_sample(frame, &self.points, |k, sampled| {
            let v = match self.opts.method {
                // The sample's map drawn again, and the pixel's comparison in it.
                Method::Maps => again
                    .lookup
                    .light_pass(&p, sampled)
                    .map(|()| Self::hard(&again.lookup, sampled, self.opts.pcf, x as usize, y as usize).0),
                Method::Volumes => again.volume.run(&p, sampled, &mut Passes::start()).map(|v| v[i]),
            }
            .unwrap_or(f32::NAN);
            sum += v;
            if k < 32 {
                steps.push(
                    Step::new("sample", "one point light's hard shadow at this pixel")
                        .int("sample", k)
                        .vec3("position", self.points[k])
                        .num("visibility", v),
                );
            }
            Ok(())
        });
        steps.push(inspect::result(sum / self.points.len() as f32));
        steps
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let mut c = vec![("samples", self.points.len() as f64)];
        if self.opts.method == Method::Maps {
            c.push(("map texels per sample", self.lookup.texels() as f64));
            c.push(("taps", self.taps));
        }
        c
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        // The sample points on the light (unit square of the light's tangents, 256 x 256).
        const N: u32 = 256;
        let mut img = Surface::new(N, N, [24u8, 24, 32, 255] as Rgba8)?;
        let (t1, t2) = frame.light.tangents();
        let extent = match frame.light.kind {
            LightKind::Area(s) => s.width().max(1e-6),
            _ => 1.0,
        };
        for &q in &self.points {
            let d = q - frame.light.position;
            let uv = Vec2::new(d.dot(t1), d.dot(t2)) / (1.2 * extent) + Vec2::splat(0.5);
            let (px, py) = ((uv.x * N as f32) as i64, (uv.y * N as f32) as i64);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (x, y) = (px + dx, py + dy);
                if (0..N as i64).contains(&x) && (0..N as i64).contains(&y) {
                    img.set(x as u32, y as u32, [250, 220, 90, 255]);
                }
            }
        }
        let mut v = vec![Stage::Color {
            name: "light_samples".into(),
            data: img,
        }];
        if self.opts.method == Method::Maps {
            // The last sample's maps.
            v.extend(self.lookup.stages(p, frame)?);
        }
        Ok(v)
    }
}
