//! The plain shadow map's pass (Williams 1978; RTR 7.4), shared by the techniques that look
//! up one map per pixel with the options of `shadow-map`: the `shadow-map` technique itself
//! ([`super::shadow_map`], which documents the options and failures) and the map under the
//! contact march of `contact-map` (`screen/contact.rs`).

use crate::error::Reason;
use crate::frame::Frame;
use crate::pipeline::*;
use crate::shadow::inspect::{NoTrace, Step, Steps, Trace};
pub use crate::shadow::light::{FitTo, Layer};
use crate::shadow::light::{LightView, MapOptions};
use crate::shadow::options::OptionValue;
use crate::shadow::pass::Pass;
use crate::shadow::pixels::{per_pixel4_counted, per_row_counted};
use crate::shadow::sample::kernel::{Kernel, Pattern, MAX_TAPS};
use crate::shadow::sample::lookup::{lookup_fields, At, Bias, MapLookup, Prepared, Setup, Wide};
use crate::shadow::technique::{Declaration, Field, Stage};
use crate::shadow::timing::Passes;
use crate::Error;

/// How the map is sampled: one comparison, hardware 2x2 PCF, or a kernel of 2x2 comparisons
/// (its option names are the [`Pattern`]s': `grid`, `tent`, `poisson`, `rotated`, `spiral`,
/// and `depth-bilinear`, the wrong order shown for contrast).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Filter {
    /// One comparison of the nearest texel (`none`).
    None,
    /// Hardware-style 2x2 PCF: four comparisons, bilinearly weighted (`pcf2`).
    Pcf2,
    /// A kernel of `pattern`, `kernel` texels wide, of `taps` taps where the pattern has a
    /// tap count.
    Kernel(Pattern),
}

impl Filter {
    /// The PCF kernel pattern of the wide filters.
    pub fn pattern(self) -> Option<Pattern> {
        match self {
            Filter::Kernel(p) => Some(p),
            Filter::None | Filter::Pcf2 => None,
        }
    }
}

impl OptionValue for Filter {
    fn type_name() -> String {
        format!("none|pcf2|{}", Pattern::type_name())
    }

    fn parse(s: &str) -> Result<Self, Reason> {
        match s {
            "none" => Ok(Filter::None),
            "pcf2" => Ok(Filter::Pcf2),
            _ => Pattern::parse(s)
                .map(Filter::Kernel)
                .map_err(|_| format!("is not one of none, pcf2, {}", Pattern::NAMES.join(", ")).into()),
        }
    }
}

/// The filter's option name.
impl std::fmt::Display for Filter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Filter::None => f.write_str("none"),
            Filter::Pcf2 => f.write_str("pcf2"),
            Filter::Kernel(p) => p.fmt(f),
        }
    }
}

/// Options of the shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass (size, format, polygon offset, fitting, snapping). Default: its defaults
    /// (2048 texels, f32, 4 units, slope 1.1, fitted to the scene, not snapped).
    pub map: MapOptions,
    /// Normal-offset and receiver-plane bias. Default: none.
    pub bias: Bias,
    /// What the map stores. Default: first.
    pub layer: Layer,
    /// Lookup filter. Default: none.
    pub filter: Filter,
    /// Wide filters: kernel width in texels (grid and tent: taps per axis, made odd). Default: 5.
    pub kernel: f32,
    /// Wide filters: kernel width in world units at the receiver instead (0: use `kernel`).
    /// Default: 0.
    pub world: f32,
    /// Poisson, rotated and spiral filters: taps (1 to 256). Default: 16.
    pub taps: u32,
    /// Wide filters: the bias cone and the hierarchy. Default: no cone, no hierarchy.
    pub wide: Wide,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            map: MapOptions::default(),
            bias: Bias::default(),
            layer: Layer::First,
            filter: Filter::None,
            kernel: 5.0,
            world: 0.0,
            taps: 16,
            wide: Wide::default(),
        }
    }
}

impl Options {
    /// `shadow-map`'s defaults with the map pass `map` (the techniques that draw their own
    /// light views: cascades, warps).
    pub fn with_map(map: MapOptions) -> Options {
        Options {
            map,
            ..Options::default()
        }
    }
}

/// The `Options` of a technique that is the plain map pass over other views (warped,
/// cascaded): a struct of one field, `shadow`, documented by `$field`, whose default is the
/// plain map's options with the map pass `$map`; its `Default` and its [`HoldsMapPass`].
macro_rules! map_pass_options {
    ($technique:literal, $map:expr, $field:expr) => {
        #[doc = concat!("Options of ", $technique, ".")]
        #[derive(Clone, Debug, PartialEq)]
        pub struct Options {
            #[doc = $field]
            pub shadow: $crate::shadow::map::plain::Options,
        }

        impl Default for Options {
            fn default() -> Self {
                Options {
                    shadow: $crate::shadow::map::plain::Options::with_map($map),
                }
            }
        }

        impl $crate::shadow::map::plain::HoldsMapPass for Options {
            fn shadow(&mut self) -> &mut $crate::shadow::map::plain::Options {
                &mut self.shadow
            }
        }
    };
}
pub(crate) use map_pass_options;

/// Options of a technique that is the plain map's pass with its own light views (cascades,
/// warps): they hold the plain map's options.
pub trait HoldsMapPass: Clone + Default + 'static {
    /// The shadow map's options.
    fn shadow(&mut self) -> &mut Options;
}

/// `shadow-map`'s fields but `without`, as fields of `O` (which holds them at
/// [`HoldsMapPass::shadow`]).
pub fn fields_within<O: HoldsMapPass>(without: &[&str]) -> Vec<Field<O>> {
    crate::shadow::options::within(
        declaration().fields.into_iter().filter(|f| !without.contains(&f.key)),
        O::shadow,
    )
}

/// The technique `d.technique` that is the plain map's pass with `opts`: an option out of its
/// range is an error.
pub fn build<O: HoldsMapPass>(
    d: &Declaration<O>,
    mut opts: O,
) -> Result<crate::shadow::pass::PassTechnique<MapPass>, Error> {
    d.check(&opts)?;
    let shadow = opts.shadow().clone();
    if let Some((key, value, message)) = beyond_ranges(&shadow) {
        return Err(d.error(key, &value, message));
    }
    Ok(crate::shadow::pass::PassTechnique::with(
        d.technique,
        MapPass::new(shadow),
    ))
}

/// The option declaration (`--set`, `penumbra list`, the constructor's check).
pub fn declaration() -> Declaration<Options> {
    let mut fields = lookup_fields(
        |o: &mut Options| &mut o.map,
        |o: &mut Options| &mut o.bias,
        |o: &mut Options| &mut o.wide,
    );
    fields.extend([
        Field::new(
            "layer",
            "first, second (back faces), midpoint (two nearest layers) or id (object ids)",
            |o: &mut Options| &mut o.layer,
        ),
        Field::new(
            "filter",
            "none (one comparison), pcf2 (2x2 hardware PCF), depth-bilinear (depths filtered, then compared: wrong), grid, tent, poisson, rotated or spiral (wide PCF kernels)",
            |o: &mut Options| &mut o.filter,
        ),
        Field::range(
            "kernel",
            "wide filters: kernel width in texels (grid and tent: taps per axis, made odd)",
            1.0,
            MAX_DIMENSION as f32,
            |o: &mut Options| &mut o.kernel,
        ),
        Field::range(
            "world",
            "wide filters: kernel width in world units at the receiver (0: use kernel)",
            0.0,
            1e6,
            |o: &mut Options| &mut o.world,
        ),
        Field::range("taps", "poisson, rotated and spiral filters: taps", 1, MAX_TAPS, |o: &mut Options| {
            &mut o.taps
        }),
    ]);
    Declaration::new("shadow-map", fields)
}

/// The plain shadow map as a pass: the light pass of [`crate::shadow::light`], then one
/// lookup per pixel through [`MapLookup`] with the options' filter (the `shadow-map`
/// technique, and the map under the contact march of `contact-map`).
pub struct MapPass {
    opts: Options,
    /// The maps and the lookups into them.
    lookup: MapLookup,
    /// Last run: bilinear taps of all lookups, and lookups the hierarchy classified.
    pub(crate) taps: u64,
}

/// What is wrong with `opts` beyond each field's range (a wide kernel wider than the map), as
/// `(key, value, message)` for the holding technique's [`Declaration::error`].
pub fn beyond_ranges(opts: &Options) -> Option<(&'static str, String, String)> {
    (opts.filter.pattern().is_some() && opts.kernel > opts.map.size as f32).then(|| {
        (
            "kernel",
            opts.kernel.to_string(),
            format!("is wider than the map (size={})", opts.map.size),
        )
    })
}

impl MapPass {
    /// The pass with `opts` (checked by the technique that holds it).
    pub fn new(opts: Options) -> MapPass {
        let lookup = MapLookup::new(Setup {
            map: opts.map.clone(),
            layer: opts.layer,
            bias: opts.bias,
            wide: opts.filter.pattern().map(|_| opts.wide),
            min_max: false,
        });
        MapPass { opts, lookup, taps: 0 }
    }

    /// Casters culled by fitting in the last run.
    pub fn culled(&self) -> usize {
        self.lookup.light_maps().culled()
    }

    /// Texels of the last run's maps, all views.
    pub fn texels(&self) -> usize {
        self.lookup.texels()
    }

    /// The maps of the last run, one per light view (six for point lights).
    pub fn maps(&self) -> &[(Surface<f32>, LightView)] {
        self.lookup.maps()
    }

    /// Pass 2 at one pixel: the lookup and its bilinear taps, every step reported to `t`.
    #[inline(always)]
    pub(crate) fn lookup(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        match self.lookup.prepare(frame, x, y, t) {
            Prepared::Done(v, n) => (v, n),
            Prepared::At(at) => self.blended(frame, &at, x, y, t),
        }
    }

    /// [`MapPass::lookup_at`], with cascades mixing in the next cascade across the blend band
    /// at the end of each ([`MapLookup::next_cascade`]).
    #[inline(always)]
    fn blended(&self, frame: &Frame, at: &At, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        let w = self.lookup.next_cascade(at, x, y, t);
        if w == 0.0 {
            return self.lookup_at(frame, at, x, y, t);
        }
        let (a, na) = if w < 1.0 {
            self.lookup_at(frame, at, x, y, t)
        } else {
            (0.0, 0)
        };
        let (b, nb) = match self.lookup.prepare_on(frame, x, y, at.face + 1, t) {
            Prepared::Done(v, n) => (v, n),
            Prepared::At(next) => self.lookup_at(frame, &next, x, y, t),
        };
        let v = if w < 1.0 { a + (b - a) * w } else { b };
        t.step(|| {
            let step = Step::new("blended", "this cascade's value and the next's, weighted");
            let step = if w < 1.0 { step.num("this cascade", a) } else { step };
            step.num("next cascade", b).num("weight of the next", w).num("value", v)
        });
        (v, na + nb)
    }

    /// Whether a prepared lookup lies in a cascade's blend band (it then takes the one-pixel
    /// path, [`MapPass::blended`]).
    #[inline(always)]
    fn in_band(&self, at: &At, x: usize, y: usize) -> bool {
        self.lookup.next_cascade(at, x, y, &mut NoTrace) > 0.0
    }

    /// The kernel of a wide filter at a prepared lookup (its width from world units at the
    /// point if asked).
    #[inline(always)]
    fn kernel_at(&self, frame: &Frame, at: &At, pattern: Pattern) -> Kernel {
        let o = &self.opts;
        let (map, view) = self.lookup.light_maps().get(at.face);
        let width = if o.world > 0.0 {
            (o.world / view.texel_at(&frame.light, at.pos)).clamp(1.0, map.width() as f32)
        } else {
            o.kernel
        };
        Kernel {
            pattern,
            taps: o.taps,
            width,
        }
    }

    /// [`MapPass::lookup`] of pixels `x .. x + n` of row `y` (`n` at most 4): each pixel is
    /// prepared alone, then the wide filters (disks, and flat grids and tents of one size) of
    /// the pixels that look up the same view run on four lanes, with the one-pixel operations
    /// per lane, so every value and count is the one-pixel lookup's.
    #[inline(always)]
    fn lookup4(&self, frame: &Frame, x: usize, y: usize, n: usize) -> ([f32; 4], u64) {
        let mut out = [f32::NAN; 4];
        let mut count = 0u64;
        let pattern = match self.opts.filter.pattern() {
            Some(p) if p != Pattern::DepthBilinear => p,
            _ => {
                for (l, o) in out.iter_mut().enumerate().take(n) {
                    let (v, c) = self.lookup(frame, x + l, y, &mut NoTrace);
                    (*o, count) = (v, count + c);
                }
                return (out, count);
            }
        };
        let mut ats = [None; 4];
        let Some(face) = self.lookup.prepare4(frame, (x, y), n, &mut ats, &mut out, &mut count) else {
            return (out, count);
        };
        // Pixels on another view (a cube map's edge, another cascade) or in a cascade's
        // blend band: one at a time.
        for (l, a) in ats.iter_mut().enumerate() {
            if let Some(at) = a.filter(|at| at.face != face || self.in_band(at, x + l, y)) {
                let (v, c) = self.blended(frame, &at, x + l, y, &mut NoTrace);
                (out[l], count) = (v, count + c);
                *a = None;
            }
        }
        let mut kernels = [None; 4];
        for (k, a) in kernels.iter_mut().zip(&ats) {
            *k = a.map(|at| self.kernel_at(frame, &at, pattern));
        }
        self.lookup.filter4(face, &ats, kernels, x, y, &mut out, &mut count);
        (out, count)
    }

    /// [`MapPass::lookup`] of every pixel of row `y` into `row`, for wide filters with the
    /// hierarchy: each pixel is prepared and classified, and the pixels the hierarchy leaves
    /// mixed are queued per light view and filtered four at a time, so that every group of
    /// lanes is full (a pixel the hierarchy decides frees its lane for the next mixed one)
    /// and each lane runs the one-pixel operations. Returns the row's count.
    fn lookup_row(&self, frame: &Frame, y: usize, pattern: Pattern, row: &mut [f32]) -> u64 {
        let mut count = 0u64;
        let mut queues = vec![Queued::default(); self.lookup.maps().len()];
        let flush = |face: usize, q: &mut Queued, row: &mut [f32], count: &mut u64| {
            let mut out = [f32::NAN; 4];
            self.lookup
                .filter_lanes(face, &q.ats, q.kernels, q.xs, y, &mut out, count);
            for l in 0..q.n {
                row[q.xs[l] as usize] = out[l];
            }
            *q = Queued::default();
        };
        for x in (0..row.len()).step_by(4) {
            let n = (row.len() - x).min(4);
            let (mut ats, mut out) = ([None; 4], [f32::NAN; 4]);
            self.lookup.prepare4(frame, (x, y), n, &mut ats, &mut out, &mut count);
            for l in 0..n {
                let Some(at) = ats[l] else {
                    row[x + l] = out[l];
                    continue;
                };
                if self.in_band(&at, x + l, y) {
                    let (v, c) = self.blended(frame, &at, x + l, y, &mut NoTrace);
                    (row[x + l], count) = (v, count + c);
                    continue;
                }
                let kernel = self.kernel_at(frame, &at, pattern);
                if let Some((v, c)) = self.lookup.decide(&at, &kernel) {
                    (row[x + l], count) = (v, count + c);
                    continue;
                }
                let q = &mut queues[at.face];
                (q.ats[q.n], q.kernels[q.n], q.xs[q.n]) = (Some(at), Some(kernel), (x + l) as u32);
                q.n += 1;
                if q.n == 4 {
                    flush(at.face, q, row, &mut count);
                }
            }
        }
        for (face, q) in queues.iter_mut().enumerate() {
            if q.n > 0 {
                flush(face, q, row, &mut count);
            }
        }
        count
    }

    /// [`MapPass::lookup`] from its prepared position on.
    #[inline(always)]
    fn lookup_at(&self, frame: &Frame, at: &At, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        let at = *at;
        let Some(pattern) = self.opts.filter.pattern() else {
            return (self.lookup.compare(&at, self.opts.filter == Filter::Pcf2, t), 1);
        };
        // Wide kernels (RTR 7.5): the width in texels (from world units at the point if asked),
        // then the hierarchy or the taps.
        let kernel = self.kernel_at(frame, &at, pattern);
        self.lookup.filter(&at, &kernel, x, y, t)
    }
}

/// The passes of each cascade's map, for `timings`.
const CASCADE_PASSES: [&str; 8] = [
    "cascade 1 pass",
    "cascade 2 pass",
    "cascade 3 pass",
    "cascade 4 pass",
    "cascade 5 pass",
    "cascade 6 pass",
    "cascade 7 pass",
    "cascade 8 pass",
];

/// The caster triangles each cascade drew, for `counters`.
const CASCADE_CASTERS: [&str; 8] = [
    "cascade 1 casters",
    "cascade 2 casters",
    "cascade 3 casters",
    "cascade 4 casters",
    "cascade 5 casters",
    "cascade 6 casters",
    "cascade 7 casters",
    "cascade 8 casters",
];

/// The view depth where each cascade ends, for `counters`.
const CASCADE_ENDS: [&str; 8] = [
    "cascade 1 ends at",
    "cascade 2 ends at",
    "cascade 3 ends at",
    "cascade 4 ends at",
    "cascade 5 ends at",
    "cascade 6 ends at",
    "cascade 7 ends at",
    "cascade 8 ends at",
];

/// Pixels of a row queued for one four-lane filter ([`ShadowMap::lookup_row`]): how many,
/// their prepared lookups, kernels and columns.
#[derive(Copy, Clone, Default)]
struct Queued {
    n: usize,
    ats: [Option<At>; 4],
    kernels: [Option<Kernel>; 4],
    xs: [u32; 4],
}

impl Pass for MapPass {
    type Output = Vec<f32>;

    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Vec<f32>, Error> {
        self.lookup.light_pass(p, frame)?;
        let maps = self.lookup.light_maps();
        if maps.maps().first().is_some_and(|(_, v)| v.slice().is_some()) {
            // Cascades: SDSM's reduction and each cascade's pass on its own line.
            let times = maps.view_times();
            let reduce = maps.depth_samples().map_or(0.0, |(_, ms)| *ms);
            if maps.depth_samples().is_some() {
                passes.add("depth reduction", reduce);
            }
            for (name, ms) in CASCADE_PASSES.iter().zip(times) {
                passes.add(name, *ms);
            }
            passes.end_after("light pass", reduce + times.iter().sum::<f64>());
        } else if let Some(ms) = maps.warp().and_then(|w| w.reduce_ms) {
            // PSM, LogPSM: the reduction that found the depths seen, then the map.
            passes.add("depth reduction", ms);
            passes.end_after("light pass", ms);
        } else {
            passes.end("light pass");
        }
        // Pass 2: one lookup per camera pixel.
        let this = &*self;
        let (out, taps) = match self.opts.filter.pattern() {
            // The hierarchy decides some pixels of a row: the others fill the lanes.
            Some(pattern) if self.lookup.planes(0).is_some() && pattern != Pattern::DepthBilinear => {
                per_row_counted(p, frame, f32::NAN, |y, row| this.lookup_row(frame, y, pattern, row))
            }
            _ => per_pixel4_counted(p, frame, f32::NAN, |x, y, n| this.lookup4(frame, x, y, n)),
        };
        self.taps = taps;
        passes.end("lookup pass");
        Ok(out)
    }

    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32> {
        let header = || self.lookup.pass_step();
        self.lookup
            .explain(t, header, |t| self.lookup(frame, x as usize, y as usize, t).0)
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let mut c = vec![
            ("map texels", self.texels() as f64),
            ("casters culled", self.culled() as f64),
            // Bilinear taps (a hardware 2x2 comparison each; one per classified kernel).
            ("taps", self.taps as f64),
        ];
        // Cascades: the triangles each drew and where each ends.
        let maps = self.lookup.light_maps();
        c.extend(
            CASCADE_CASTERS
                .iter()
                .zip(maps.cascade_casters())
                .map(|(n, t)| (*n, *t as f64)),
        );
        let ends = maps.maps().iter().filter_map(|(_, v)| v.slice().map(|s| s.far));
        c.extend(CASCADE_ENDS.iter().zip(ends).map(|(n, d)| (*n, d as f64)));
        // SDSM: the range the cascades split and the frame its depths came from.
        if let Some((d, _)) = maps.depth_samples() {
            c.push(("sdsm near", d.near as f64));
            c.push(("sdsm far", d.far as f64));
            c.push(("sdsm depths of frame", d.frame as f64));
        }
        // Warps: the warp's n (0 where it fell back to no warp) and the light's angle to the
        // view.
        if let Some(w) = maps.warp() {
            c.push(("warp n (0: none)", if w.n.is_finite() { w.n as f64 } else { 0.0 }));
            c.push(("warp gamma (degrees)", w.gamma_deg as f64));
            if let Some(psm) = &w.psm {
                c.push(("psm near", psm.near as f64));
                c.push(("psm shift", psm.shift as f64));
                c.push(("psm inverted light", psm.inverted as u8 as f64));
                c.push(("psm casters behind the eye", psm.behind as f64));
            }
            if let Some(rows) = &w.log {
                c.push(("logpsm far / near", (rows.f / rows.n) as f64));
                c.push(("logpsm n raised (0: no)", w.log_limited.is_some() as u8 as f64));
            }
        }
        c
    }

    fn notes(&self) -> Vec<String> {
        let maps = self.lookup.light_maps();
        let Some(w) = maps.warp() else {
            return Vec::new();
        };
        let mut notes: Vec<String> = w
            .fallback
            .iter()
            .map(|why| format!("{}: {why}", w.kind.as_str()))
            .collect();
        if let (Some(was), Some(rows)) = (w.log_limited, &w.log) {
            notes.push(format!(
                "logpsm: n raised from {was:.3} to {:.3} so the farthest rows stay 1/64 pixel apart in the rasterized space (a view range deeper than the rasterizer's precision holds; the near texels grow)",
                rows.n
            ));
        }
        notes
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        self.lookup.stages(p, frame)
    }

    fn light_views(&self) -> Vec<LightView> {
        self.lookup.views()
    }
}
