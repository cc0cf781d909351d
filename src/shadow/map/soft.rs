//! Percentage-closer soft shadows, the shared part (Fernando 2005; RTR 7.6, eq. 7.6 and fig.
//! 7.25): what the `pcss` technique runs and the hybrid blends. One shadow map from the
//! light's centre, and per pixel three steps.
//!
//! 1. **Blocker search.** The texels that can hold casters between the receiver and the
//!    light lie inside the cone from the receiver to the light's extent. At the nearest
//!    caster of the map (distance `d_min` from the light) that cone is
//!    `w_light (d_r - d_min) / d_r` wide, so the search disk is that width in the map's
//!    texels there: `w_light (d_r - d_min) / (d_r d_min texel)` for a light at a point (the
//!    texel grows with distance), `(d_r - d_min) 2 tan(angle / 2) / texel` for a directional
//!    light of angular diameter `angle`. `blockers` taps of a Poisson disk (rotated or spiral
//!    with those filters) read the raw depths; a tap nearer than the reference is a blocker.
//! 2. **Penumbra estimate.** No blocker: lit; every tap a blocker: umbra (the classic early
//!    outs). Otherwise the blockers' distances from the light, unprojected from the map's
//!    depth ([`crate::shadow::light::LightView::distance`]), are averaged to `d_o`, and RTR eq. 7.6 gives the
//!    penumbra width at the receiver, `w_penumbra = w_light (d_r - d_o) / d_o` (directional:
//!    `(d_r - d_o) 2 tan(angle / 2)`), taken to texels at the receiver's distance.
//! 3. **Filtering.** A PCF disk of `taps` hardware 2x2 comparisons that wide
//!    ([`crate::shadow::sample::kernel`]), with the shadow map's receiver-plane bias and bias cone across it.
//!
//! With `hierarchy`, the map's hierarchy ([`crate::shadow::sample::planes::PlaneChain`]: per block the least
//! and greatest depth and the depths' bounds around a plane, so that kernels on a sloped
//! receiver with the receiver-plane bias are classified too) classifies the search disk (no
//! blocker or all blockers: one lookup) and the filter disk (fully lit or in umbra) and skips
//! their taps; the image is identical. On the scenes measured (spheres, `contact`,
//! `pergola`) it makes PCSS slower, not faster: a classification costs as much as or more
//! than the 16 taps of the search it saves, and a curved receiver's disks stay mixed
//! (docs/performance.md).
//!
//! The lookup pass runs four pixels at a time: each is prepared alone, then the searches and
//! filters of pixels on the same light view run on four lanes (one pixel per lane) with the
//! one-pixel operations in the same order, so the image is the one-pixel pass's bit for bit.
//!
//! The light's width is the scene's area light (a disk's or sphere's diameter, a
//! rectangle's mean side) times `light`; point and spot lights have none, so PCSS gives their
//! hard shadow; a directional light has the angular diameter `angle` (default 0: hard). A
//! width of zero skips the search and filters with one 2x2 comparison: exactly the
//! `shadow-map [filter=pcf2]` image with the same map options.
//!
//! Known failures: the average-blocker assumption (RTR: "a street lamp and a distant
//! mountain"): where occluders at two heights cover the search disk, the average lies between
//! them and the penumbra is wrong for both; the search disk's 16 taps miss thin blockers; the
//! all-blockers early out turns a penumbra into umbra when the filter disk is narrower than
//! the search disk but still crosses an edge; and the estimate is quantized by the map's
//! resolution (contact-hardening shadows use a mip chain against that).

use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::lanes::floor4;
use crate::pipeline::sampler::{texels_at4, Indices4};
use crate::pipeline::Pipeline;
use crate::shadow::inspect::{NoTrace, Step, Steps, Trace};
use crate::shadow::light::soft::{light_width, penumbra_texels, search_texels, world};
use crate::shadow::light::{DepthToDistance, Layer, MapOptions};
use crate::shadow::pass::Pass;
use crate::shadow::pixels::{per_pixel, per_pixel4_counted};
use crate::shadow::sample::kernel::{Class, Kernel, Pattern, Reference, Reference4};
use crate::shadow::sample::lookup::{At, Bias, Estimate, MapLookup, Prepared, Setup, Wide};
use crate::shadow::technique::Stage;
use crate::shadow::timing::Passes;
use crate::Error;
use glam::{BVec4A, Vec2, Vec4};

choice_enum! {
    /// The disk PCSS searches and filters with.
    pub enum Disk {
        /// A fixed Poisson disk (16 taps: the disk commonly used with PCSS).
        Poisson = "poisson",
        /// The Poisson disk rotated per pixel by a hashed angle.
        Rotated = "rotated",
        /// A Vogel spiral rotated by interleaved gradient noise (Jimenez 2014).
        Spiral = "spiral",
    }
}

impl Disk {
    /// The kernel pattern.
    pub fn pattern(self) -> Pattern {
        match self {
            Disk::Poisson => Pattern::Poisson,
            Disk::Rotated => Pattern::Rotated,
            Disk::Spiral => Pattern::Spiral,
        }
    }
}

/// Options of PCSS.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass. Default: its defaults (2048 texels, f32, 4 units, slope 1.1).
    pub map: MapOptions,
    /// Normal-offset and receiver-plane bias. Default: none.
    pub bias: Bias,
    /// The bias cone across the disks and the hierarchy that classifies them. Default: no
    /// cone, no hierarchy.
    pub wide: Wide,
    /// The light's width as a multiple of the scene's area light (0: a hard shadow).
    /// Default: 1.
    pub light: f32,
    /// Directional lights: angular diameter in degrees (the sun: 0.53). Default: 0 (hard).
    pub angle: f32,
    /// Blocker-search taps (1 to 256). Default: 16.
    pub blockers: u32,
    /// Filter taps (1 to 256). Default: 16.
    pub taps: u32,
    /// The disk of both steps. Default: poisson.
    pub disk: Disk,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            map: MapOptions::default(),
            bias: Bias::default(),
            wide: Wide::default(),
            light: 1.0,
            angle: 0.0,
            blockers: 16,
            taps: 16,
            disk: Disk::Poisson,
        }
    }
}

/// Percentage-closer soft shadows: the maps, the blocker search, the penumbra estimate and
/// the filter (see the module docs), with what the last run found.
pub struct SoftShadows {
    opts: Options,
    lookup: MapLookup,
    /// Per light view of the last run: the nearest caster's distance from the light.
    nearest: Vec<f32>,
    /// The light's width (world units; for directional lights `2 tan(angle / 2)`).
    width: f32,
    pub(crate) taps: u64,
    pub(crate) early: u64,
    /// [`SoftShadows::keep_penumbra`], and the last run's widths.
    keep: bool,
    kept: Vec<f32>,
}

impl SoftShadows {
    /// PCSS with `opts` (the technique checks their ranges).
    pub fn new(opts: Options) -> SoftShadows {
        // Wide kernels: the lookup prepares the disks' receiver plane and cone, and builds the
        // hierarchy when asked.
        let lookup = MapLookup::new(Setup {
            map: opts.map.clone(),
            layer: Layer::First,
            bias: opts.bias,
            wide: Some(opts.wide),
            min_max: false,
        });
        SoftShadows {
            opts,
            lookup,
            nearest: Vec::new(),
            width: 0.0,
            taps: 0,
            early: 0,
            keep: false,
            kept: Vec::new(),
        }
    }

    /// The start of step 1 at a prepared lookup: the receiver's distance (`distance` is the
    /// view's [`LightView::depth_to_distance`], its constants made once), the search width,
    /// and the hierarchy's decision where it makes one (the class is then not mixed).
    fn begin(&self, at: &At, distance: &DepthToDistance) -> Estimate {
        let (map, view) = &self.lookup.maps()[at.face];
        let size = map.width() as f32;
        let d_r = distance.at(at.r.z);
        let d_min = self.nearest[at.face].min(d_r);
        let search = search_texels(view, self.width, d_r, d_min).clamp(1.0, size);
        let mut e = Estimate {
            search,
            found: 0,
            taps: 1,
            receiver: d_r,
            blocker: f32::NAN,
            penumbra: 0.0,
            class: Class::Mixed,
        };
        if let Some(pc) = self.lookup.planes(at.face) {
            let kernel = self.search_kernel(search);
            // The search reads the nearest texel of each tap.
            e.class = pc.classify(at.uv, kernel.extent(), 0.5, &at.r);
            if e.class != Class::Mixed {
                e.found = if e.class == Class::Shadowed {
                    self.opts.blockers
                } else {
                    0
                };
                e.penumbra = if e.class == Class::Shadowed { search } else { 0.0 };
            }
        }
        e
    }

    /// The blocker search's kernel for a disk `width` texels wide.
    fn search_kernel(&self, width: f32) -> Kernel {
        Kernel {
            pattern: self.opts.disk.pattern(),
            taps: self.opts.blockers,
            width,
        }
    }

    /// Step 2 on view `face` after a search of `n` taps that found `found` blockers whose
    /// distances sum to `sum`: the early outs, or RTR eq. 7.6's penumbra,
    /// `w_penumbra = w_light (d_r - d_o) / d_o`, in texels at the receiver.
    fn conclude(&self, e: &mut Estimate, face: usize, n: u32, found: u32, sum: f32) {
        let (map, view) = &self.lookup.maps()[face];
        e.taps = n;
        e.found = found;
        if found == 0 {
            e.class = Class::Lit;
        } else if found == n {
            e.class = Class::Shadowed;
            e.penumbra = e.search;
        } else {
            let d_o = sum / found as f32;
            e.blocker = d_o;
            e.penumbra = penumbra_texels(view, self.width, e.receiver, d_o).min(map.width() as f32);
        }
    }

    /// Steps 1 and 2 at a prepared lookup.
    fn estimate(&self, at: &At, x: usize, y: usize) -> Estimate {
        let (map, view) = &self.lookup.maps()[at.face];
        let size = map.width() as f32;
        let distance = view.depth_to_distance();
        let mut e = self.begin(at, &distance);
        if e.class != Class::Mixed {
            return e;
        }
        let kernel = self.search_kernel(e.search);
        let inv = Vec2::ONE / size;
        let (mut sum, mut found, mut n) = (0.0f32, 0u32, 0u32);
        let flat = at.r.is_flat();
        SEARCH.with(|t| {
            let mut taps = t.borrow_mut();
            kernel.taps_at(x as u32, y as u32, &mut taps);
            n = taps.len() as u32;
            for &(d, _) in taps.iter() {
                let uv = at.uv + d * inv;
                if !crate::shadow::light::inside(uv) {
                    continue;
                }
                let depth = map.at((uv.x * size) as u32, (uv.y * size) as u32);
                if depth < if flat { at.r.z } else { at.r.at(d) } {
                    sum += distance.at(depth);
                    found += 1;
                }
            }
        });
        self.conclude(&mut e, at.face, n, found, sum);
        e
    }

    /// The penumbra's world width at pixel `(x, y)` of the last run's maps, from the blocker
    /// search (in umbra, the search disk's); `None` without geometry, light width or blockers.
    pub fn penumbra_world(&self, frame: &Frame, x: usize, y: usize) -> Option<f32> {
        if self.width <= 0.0 || self.lookup.maps().is_empty() {
            return None;
        }
        let Prepared::At(at) = self.lookup.prepare(frame, x, y, &mut NoTrace) else {
            return None;
        };
        self.world(at.face, &self.estimate(&at, x, y))
    }

    /// [`SoftShadows::penumbra_world`] of an estimate on view `face`.
    fn world(&self, face: usize, e: &Estimate) -> Option<f32> {
        if e.class == Class::Lit {
            return None;
        }
        Some(world(&self.lookup.maps()[face].1, e.penumbra, e.receiver))
    }

    /// Keep each pixel's [`SoftShadows::penumbra_world`] from the lookup pass of every run
    /// ([`SoftShadows::kept_penumbra`]), for techniques built on PCSS's estimate.
    pub fn keep_penumbra(&mut self, on: bool) {
        self.keep = on;
        if !on {
            self.kept = Vec::new();
        }
    }

    /// Per pixel of the last run (row-major), with [`SoftShadows::keep_penumbra`]: the penumbra's
    /// world width, [`SoftShadows::penumbra_world`]'s value, NaN where it is `None`; empty otherwise.
    pub fn kept_penumbra(&self) -> &[f32] {
        &self.kept
    }

    /// The three steps at one pixel: visibility and taps (blocker search plus filter), every
    /// step reported to `t`; the count's bit 32 marks an early out.
    #[inline(always)]
    pub(crate) fn lookup(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        match self.lookup.prepare(frame, x, y, t) {
            Prepared::Done(v, n) => (v, n),
            Prepared::At(at) => self.lookup_at(&at, x, y, t),
        }
    }

    /// [`SoftShadows::lookup`] from its prepared position on.
    #[inline(always)]
    fn lookup_at(&self, at: &At, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        let at = *at;
        let map = &self.lookup.maps()[at.face].0;
        if self.width <= 0.0 {
            t.step(|| {
                Step::new(
                    "hard",
                    "the light has no width: one 2x2 comparison, the hard shadow map's",
                )
            });
            return (crate::shadow::sample::kernel::bilinear_compare(map, at.uv, at.r.z), 1);
        }
        let e = self.estimate(&at, x, y);
        t.step(|| {
            Step::new(
                "blocker search",
                "taps of the search disk nearer than the reference are blockers (Fernando 2005)",
            )
            .num("light width", self.width)
            .num("receiver distance", e.receiver)
            .num("nearest caster distance", self.nearest[at.face])
            .num("search width in texels", e.search)
            .int("taps", e.taps)
            .int("blockers found", e.found)
            .text(
                "decided by",
                match (e.class, e.taps) {
                    (Class::Mixed, _) => "the taps: filter",
                    (Class::Lit, 1) => "the hierarchy: no blocker, lit",
                    (Class::Shadowed, 1) => "the hierarchy: all blockers, umbra",
                    (Class::Lit, _) => "no blocker: lit",
                    (Class::Shadowed, _) => "all blockers: umbra",
                },
            )
        });
        match e.class {
            Class::Lit => return (1.0, e.taps as u64 | 1 << 32),
            Class::Shadowed => return (0.0, e.taps as u64 | 1 << 32),
            Class::Mixed => {}
        }
        t.step(|| {
            Step::new(
                "penumbra estimate",
                "RTR eq. 7.6: w_penumbra = w_light (d_receiver - d_blocker) / d_blocker, in texels at the receiver",
            )
            .num("average blocker distance", e.blocker)
            .num("penumbra width in texels", e.penumbra)
        });
        let kernel = Kernel {
            pattern: self.opts.disk.pattern(),
            taps: self.opts.taps,
            width: e.penumbra,
        };
        let (v, n) = self.lookup.filter(&at, &kernel, x, y, t);
        (v, n + e.taps as u64)
    }
}

impl SoftShadows {
    /// [`SoftShadows::lookup`] of pixels `x .. x + n` of row `y` (`n` at most 4): each pixel is
    /// prepared alone, then the blocker searches and the filters of the pixels that look up
    /// the same view run on four lanes (lanes are pixels; each lane's sums run in tap order
    /// with the one-pixel operations, so every value and count is the one-pixel lookup's).
    /// With `keep`, each pixel's [`SoftShadows::penumbra_world`] too (NaN for none).
    fn lookup4(&self, frame: &Frame, x: usize, y: usize, n: usize, keep: bool) -> ([(f32, f32); 4], u64) {
        let (out, pen, count) = self.lookup4_parts(frame, x, y, n, keep);
        (std::array::from_fn(|l| (out[l], pen[l])), count)
    }

    /// [`SoftShadows::lookup4`]'s values, penumbrae and count.
    #[inline(always)]
    fn lookup4_parts(&self, frame: &Frame, x: usize, y: usize, n: usize, keep: bool) -> ([f32; 4], [f32; 4], u64) {
        let mut out = [f32::NAN; 4];
        let mut pen = [f32::NAN; 4];
        let mut count = 0u64;
        if self.width <= 0.0 {
            // No light width: the hard 2x2 comparison, one pixel at a time.
            for (l, o) in out.iter_mut().enumerate().take(n) {
                let (v, c) = self.lookup(frame, x + l, y, &mut NoTrace);
                (*o, count) = (v, count + c);
            }
            return (out, pen, count);
        }
        let mut ats = [None; 4];
        let Some(face) = self.lookup.prepare4(frame, (x, y), n, &mut ats, &mut out, &mut count) else {
            return (out, pen, count);
        };
        // Pixels on another view (a cube map's edge): one at a time.
        for (l, a) in ats.iter_mut().enumerate() {
            if let Some(at) = a.filter(|at| at.face != face) {
                let (v, c) = self.lookup_at(&at, x + l, y, &mut NoTrace);
                (out[l], count) = (v, count + c);
                if keep {
                    pen[l] = self.world(at.face, &self.estimate(&at, x + l, y)).unwrap_or(f32::NAN);
                }
                *a = None;
            }
        }
        let es = self.estimate4(&ats, x, y);
        // The early outs lane by lane; the other lanes filter (RTR eq. 7.6's width).
        let mut kernels = [None; 4];
        for l in 0..4 {
            let Some(e) = &es[l] else { continue };
            if keep {
                pen[l] = self.world(face, e).unwrap_or(f32::NAN);
            }
            match e.class {
                Class::Lit => (out[l], count) = (1.0, count + (e.taps as u64 | 1 << 32)),
                Class::Shadowed => (out[l], count) = (0.0, count + (e.taps as u64 | 1 << 32)),
                Class::Mixed => {
                    count += e.taps as u64;
                    kernels[l] = Some(self.filter_kernel(e.penumbra));
                }
            }
        }
        self.lookup.filter4(face, &ats, kernels, x, y, &mut out, &mut count);
        (out, pen, count)
    }

    /// The filter's kernel for a penumbra `width` texels wide.
    fn filter_kernel(&self, width: f32) -> Kernel {
        Kernel {
            pattern: self.opts.disk.pattern(),
            taps: self.opts.taps,
            width,
        }
    }

    /// [`SoftShadows::estimate`] of up to four pixels `x + l` of row `y` on one view (lanes `None`
    /// idle): the searches the hierarchy does not decide run on four lanes, each lane's
    /// blocker count and distance sum in tap order with the one-pixel operations.
    fn estimate4(&self, ats: &[Option<At>; 4], x: usize, y: usize) -> [Option<Estimate>; 4] {
        let mut es: [Option<Estimate>; 4] = [None; 4];
        let face = ats.iter().flatten().next().map_or(0, |a| a.face);
        let (map, view) = &self.lookup.maps()[face];
        let size = map.width() as f32;
        let mut go = [false; 4];
        let mut widths = [1.0f32; 4];
        let mut refs = [Reference::default(); 4];
        let (mut u, mut v) = ([0.0f32; 4], [0.0f32; 4]);
        let distance = view.depth_to_distance();
        for l in 0..4 {
            let Some(at) = &ats[l] else { continue };
            let e = self.begin(at, &distance);
            let search = e.search;
            if e.class == Class::Mixed {
                go[l] = true;
                widths[l] = search;
                refs[l] = at.r;
                (u[l], v[l]) = (at.uv.x, at.uv.y);
            }
            es[l] = Some(e);
        }
        if !go.iter().any(|&g| g) {
            return es;
        }
        let xs = std::array::from_fn(|l| (x + l) as u32);
        let disk = self
            .search_kernel(1.0)
            .disk4(xs, y as u32, Vec4::from_array(widths))
            .expect("PCSS searches a disk");
        let inv = Vec4::splat(1.0 / size);
        let sz = Vec4::splat(size);
        let (u, v) = (Vec4::from_array(u), Vec4::from_array(v));
        let r = Reference4::new(refs);
        let (mut sum, mut found) = (Vec4::ZERO, Vec4::ZERO);
        // For a power-of-two size, a tap's texel coordinate `(u + d / size) * size` is
        // exactly `u * size + d`: the reciprocal and the scalings by `size` are exact, and
        // scaling by a power of two commutes with rounding (a sum below the normal range is
        // exact). So the texel (the truncation, inside the map) and the inside test are the
        // same, for two multiplies and the floors less per tap (maps are square; the test
        // keeps to them).
        let texel_units = map.width().is_power_of_two() && map.height() == map.width();
        let (us, vs) = (u * sz, v * sz);
        // Taps in batches: first every tap's texel, reference and inside test, then the
        // loads and sums in tap order (the loads no longer wait behind the arithmetic).
        const BATCH: usize = 16;
        let mut taps = [(Indices4::default(), Vec4::ZERO, BVec4A::FALSE); BATCH];
        for first in (0..disk.len()).step_by(BATCH) {
            let batch = &mut taps[..BATCH.min(disk.len() - first)];
            if texel_units {
                for (j, t) in batch.iter_mut().enumerate() {
                    let (dx, dy) = disk.tap(first + j);
                    let (tx, ty) = (us + dx, vs + dy);
                    let inside = tx.cmpge(Vec4::ZERO) & tx.cmplt(sz) & ty.cmpge(Vec4::ZERO) & ty.cmplt(sz);
                    *t = (Indices4::kept(map, tx, ty, inside), r.at(dx, dy), inside);
                }
            } else {
                for (j, t) in batch.iter_mut().enumerate() {
                    let (dx, dy) = disk.tap(first + j);
                    let (tu, tv) = (u + dx * inv, v + dy * inv);
                    let inside =
                        tu.cmpge(Vec4::ZERO) & tu.cmplt(Vec4::ONE) & tv.cmpge(Vec4::ZERO) & tv.cmplt(Vec4::ONE);
                    // Inside the map, `(uv * size) as u32` is the floor.
                    *t = (
                        Indices4::new(map, floor4(tu * sz), floor4(tv * sz)),
                        r.at(dx, dy),
                        inside,
                    );
                }
            }
            for &(at, reference, inside) in batch.iter() {
                let depth = texels_at4(map, at);
                let blocker = depth.cmplt(reference) & inside;
                sum += Vec4::select(blocker, distance.at4(depth), Vec4::ZERO);
                found += Vec4::select(blocker, Vec4::ONE, Vec4::ZERO);
            }
        }
        let n = disk.len() as u32;
        for l in 0..4 {
            if let Some(e) = es[l].as_mut().filter(|_| go[l]) {
                self.conclude(e, face, n, found[l] as u32, sum[l]);
            }
        }
        es
    }
}

thread_local! {
    /// Scratch search taps per worker.
    static SEARCH: std::cell::RefCell<Vec<(Vec2, f32)>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl Pass for SoftShadows {
    type Output = Vec<f32>;

    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Vec<f32>, Error> {
        self.lookup.light_pass(p, frame)?;
        self.width = light_width(frame, self.opts.light, self.opts.angle);
        self.nearest = self.lookup.light_maps().nearest_casters(p);
        passes.end("light pass");
        let this = &*self;
        let keep = self.keep;
        let (both, count) = per_pixel4_counted(p, frame, (f32::NAN, f32::NAN), |x, y, n| {
            this.lookup4(frame, x, y, n, keep)
        });
        let out: Vec<f32> = both.iter().map(|b| b.0).collect();
        self.kept = if keep {
            both.iter().map(|b| b.1).collect()
        } else {
            Vec::new()
        };
        self.taps = count & 0xffff_ffff;
        self.early = count >> 32;
        passes.end("lookup pass");
        Ok(out)
    }

    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32> {
        let header = || {
            Step::new("map", "the light pass of the last run")
                .int("views", self.lookup.maps().len())
                .int("size", self.opts.map.size)
                .num("light width", self.width)
                .flag("hierarchy", self.opts.wide.hierarchy)
        };
        self.lookup
            .explain(t, header, |t| self.lookup(frame, x as usize, y as usize, t).0)
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("map texels", self.lookup.texels() as f64),
            // Search taps (raw depth reads) plus filter taps (2x2 comparisons); one per
            // kernel the hierarchy classified.
            ("taps", self.taps as f64),
            ("early outs", self.early as f64),
        ]
    }

    fn light_views(&self) -> Vec<crate::shadow::light::LightView> {
        self.lookup.views()
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v = self.lookup.stages(p, frame)?;
        if self.lookup.maps().is_empty() || self.width <= 0.0 {
            return Ok(v);
        }
        let est = |x: usize, y: usize| match self.lookup.prepare(frame, x, y, &mut NoTrace) {
            Prepared::At(at) => Some(self.estimate(&at, x, y)),
            Prepared::Done(..) => None,
        };
        let penumbra = per_pixel(p, frame, |x, y| est(x, y).map_or(f32::NAN, |e| e.penumbra));
        let blockers = per_pixel(p, frame, |x, y| {
            est(x, y).map_or(f32::NAN, |e| e.found as f32 / self.opts.blockers as f32)
        });
        let hi = penumbra
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(1.0f32, f32::max);
        v.push(Stage::pixels(frame, "penumbra_texels", penumbra, 0.0, hi)?);
        v.push(Stage::pixels(frame, "blocker_fraction", blockers, 0.0, 1.0)?);
        Ok(v)
    }
}
