//! Filtered shadow maps (RTR 7.7): maps whose texels store a function of the depth that can
//! be filtered *before* the comparison, so a blur, a mip chain or a summed-area table gives
//! soft-edged, anti-aliased shadows from one lookup per pixel.
//!
//! - [`vsm`]: variance shadow maps (Donnelly and Lauritzen 2006; RTR eqs. 7.7-7.8),
//!   Chebyshev's bound, light-bleeding reduction, variable width from the summed-area table.
//! - [`convolution`]: convolution shadow maps (Annen et al. 2007), a Fourier series of the
//!   depth test.
//! - [`esm`]: exponential shadow maps (Salvi 2008; Annen et al. 2008), `e^(c z)` filtered, in
//!   log space against overflow.
//! - [`evsm`]: exponential variance shadow maps (Lauritzen and McCool 2008), VSM of the
//!   positive and negative exponential warps.
//! - [`msm`]: moment shadow maps (Peters and Klein 2015), four power moments and the
//!   Hamburger reconstruction, in 128-bit float or the paper's 64-bit quantized storage.
//!
//! One pass serves them all ([`FilteredPass`]): the light pass of [`crate::shadow::light`]
//! (the same fitting, caster culling, snapping and cube faces as every map, its views behind
//! the same [`light::locate`]), then the technique's [`Moments`] encode each texel's linear
//! depth, the storage format rounds them ([`Storage`]), [`prefilter`] filters them (box or
//! Gaussian blur, mip chain, summed-area table: the pipeline's compute helpers), and per pixel
//! one filtered lookup goes to [`Moments::visibility`]. The image and `inspect` come from the
//! same per-pixel function ([`FilteredPass::lookup`]).
//!
//! Depth here is *linear* depth `t` in `[0, 1]` between each view's near and far planes (an
//! orthographic view's clip depth; a perspective view's distance along its axis, rescaled),
//! so that a filter's average means the same everywhere in the map.
//!
//! What the whole family shares as a failure: a filtered map has one penumbra width, the
//! filter's (or, for VSM with `variable=true`, one estimated from the average blocker), where
//! the reference's grows with the distance to the occluder; and every representation but the
//! plain depth leaks light somewhere (VSM where occluders overlap, ESM near contact, the
//! convolution series where it rings, MSM where three or more depths share a kernel).

pub mod convolution;
pub mod esm;
pub mod evsm;
pub mod msm;
pub mod prefilter;
pub mod vsm;

use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::*;
use crate::shadow::inspect::{NoTrace, Step, Steps, Trace};
use crate::shadow::light::soft::{light_width, penumbra_texels, search_texels};
use crate::shadow::light::{self, DepthToDistance, Layer, LightMaps, LightView, MapOptions};
use crate::shadow::options::{within, OptionValue};
use crate::shadow::pass::{Pass, PassTechnique};
use crate::shadow::pixels::per_pixel_counted;
use crate::shadow::technique::{Declaration, Field, Stage};
use crate::shadow::timing::Passes;
use crate::Error;
use glam::{Vec2, Vec4};
pub use prefilter::{Prefilter, Prefiltered, SatSums};
use rayon::prelude::*;

choice_enum! {
    /// How a filtered map's channels are stored (the render target's format, which the
    /// prefilter's targets share).
    pub enum Storage {
        /// 32-bit float per channel.
        F32 = "f32",
        /// 16-bit float per channel (IEEE half: 11 significant bits, largest finite 65504).
        F16 = "f16",
        /// 16-bit normalized integer per channel (values in [0, 1], steps of 1/65535).
        U16 = "u16",
    }
}

/// Most four-channel planes a representation stores per texel (the convolution map's 16
/// terms are 32 channels).
pub const MAX_PLANES: usize = 8;

impl Storage {
    /// The largest finite value the format holds.
    pub fn max(self) -> f32 {
        match self {
            Storage::F32 => f32::MAX,
            Storage::F16 => 65504.0,
            Storage::U16 => 1.0,
        }
    }

    /// Bits per channel.
    pub fn bits(self) -> u32 {
        match self {
            Storage::F32 => 32,
            Storage::F16 | Storage::U16 => 16,
        }
    }

    /// `v` as the format stores it (round to nearest even; an overflow is an infinity, as a
    /// GPU's conversion gives; NaN stays NaN).
    #[inline(always)]
    pub fn store(self, v: f32) -> f32 {
        match self {
            Storage::F32 => v,
            Storage::F16 => to_f16(v),
            Storage::U16 => (v.clamp(0.0, 1.0) * 65535.0).round() / 65535.0,
        }
    }
}

/// `v` rounded to the nearest IEEE half-precision value (ties to even), returned as `f32`:
/// infinities beyond 65504, subnormal halves below 2^-14.
#[inline(always)]
pub fn to_f16(v: f32) -> f32 {
    if !v.is_finite() {
        return v;
    }
    let a = v.abs();
    if a < 6.103_515_6e-5 {
        // Subnormal halves: multiples of 2^-24.
        const S: f32 = 16_777_216.0;
        return (v * S).round_ties_even() / S;
    }
    // Keep 10 of the 23 fraction bits, rounding to nearest even.
    let b = v.to_bits();
    let lsb = (b >> 13) & 1;
    let r = f32::from_bits((b + 0x0fff + lsb) & !0x1fff);
    if r.abs() > 65504.0 {
        f32::INFINITY.copysign(v)
    } else {
        r
    }
}

/// What a filtered technique stores per texel and how it reads it back: the one part of each
/// technique that differs ([`FilteredPass`] does the rest).
pub trait Moments: Send + Sync + 'static {
    /// Four-channel planes per texel (at most [`MAX_PLANES`]).
    fn planes(&self) -> usize;
    /// Names of the channels used, in plane order (for `dump` and `inspect`).
    fn channels(&self) -> Vec<String>;
    /// The storage format.
    fn storage(&self) -> Storage;
    /// The storage formats the representation defines ([`build`] refuses another).
    const STORAGES: &'static [Storage];
    /// Whether the channels hold logarithms to be filtered in log space (ESM). Default: no.
    fn log_space(&self) -> bool {
        false
    }
    /// The planes of a texel at linear depth `t` whose depth changes by `slope` per texel
    /// (x and y; zero unless [`Moments::uses_slope`]): `out` has [`Moments::planes`] entries.
    fn encode(&self, t: f32, slope: Vec2, out: &mut [Vec4]);
    /// Whether [`Moments::encode`] reads the depth's slope (computed from four neighbours
    /// only then). Default: no.
    fn uses_slope(&self) -> bool {
        false
    }
    /// Visibility (1 = lit) of a receiver at linear depth `t` from the filtered planes `m`,
    /// every step reported to `tr`.
    fn visibility(&self, m: &[Vec4], t: f32, tr: &mut impl Trace) -> f32;
    /// The average blocker's linear depth over a filtered region in front of a receiver at
    /// `t` (`None`: no blocker), for the variable-width lookup. Default: not supported.
    fn blocker(&self, m: &[Vec4], t: f32) -> Option<f32> {
        let _ = (m, t);
        None
    }
}

/// The options every filtered technique has: the map pass, the prefilter and its width.
#[derive(Clone, Debug, PartialEq)]
pub struct Filtering {
    /// The map pass (size, depth format, polygon offset, fitting, snapping). Default: 512
    /// texels (a cube map is six faces of four or more channels, all blurred: at 1024 the
    /// family would double the default sweep's time), f32, no polygon offset (a filtered
    /// map's bias is in its representation), fitted to the scene, not snapped.
    pub map: MapOptions,
    /// How the stored map is filtered. Default: gaussian.
    pub prefilter: Prefilter,
    /// Filter radius in texels: box and Gaussian blurs are `2 radius + 1` taps wide
    /// (Gaussian sigma `radius / 2`), mip lookups and summed-area boxes at least that wide.
    /// Default: 4 (a 9x9 kernel).
    pub radius: u32,
    /// Summed-area tables: sums in f64 (exact enough at any map size) or naive f32 sums (to
    /// show what is lost). Default: f64.
    pub sums: SatSums,
    /// Cascades over the view range ([`crate::shadow::light::cascades`], practical splits
    /// with lambda 0.5, each prefiltered alone), directional lights only: another light keeps
    /// one map and says so in `notes`. 0: one map. Default: 0.
    pub cascades: u32,
    /// Channel storage, one of those the technique defines ([`Moments::STORAGES`]): the
    /// render target's format, which the prefilter's targets share. Default: f32.
    pub storage: Storage,
}

impl Default for Filtering {
    fn default() -> Self {
        Filtering {
            map: MapOptions {
                size: 512,
                units: 0.0,
                slope: 0.0,
                ..MapOptions::default()
            },
            prefilter: Prefilter::Gaussian,
            radius: 4,
            sums: SatSums::F64,
            cascades: 0,
            storage: Storage::F32,
        }
    }
}

impl Filtering {
    /// The declaration of the shared fields (the map pass's, `prefilter`, `radius`, `sums`),
    /// for a technique's options that hold a `Filtering` ([`within`]).
    pub fn fields() -> Vec<Field<Filtering>> {
        let mut f = within(MapOptions::fields(), |o: &mut Filtering| &mut o.map);
        f.extend([
            Field::new(
                "prefilter",
                "none (bilinear lookups only), box or gaussian (separable blur), mips (trilinear, at least the kernel wide), sat (summed-area table box)",
                |o: &mut Filtering| &mut o.prefilter,
            ),
            Field::range(
                "radius",
                "filter radius in texels (blurs 2r+1 taps wide; mips and summed-area boxes at least that wide)",
                1,
                4096,
                |o: &mut Filtering| &mut o.radius,
            ),
            Field::new(
                "sums",
                "summed-area tables: f64 sums, or naive f32 sums (loses precision on large maps)",
                |o: &mut Filtering| &mut o.sums,
            ),
            Field::range(
                "cascades",
                "cascades over the view range, each prefiltered alone (directional lights; 0: one map)",
                0,
                crate::shadow::light::cascades::MAX_CASCADES,
                |o: &mut Filtering| &mut o.cascades,
            ),
            Field::new(
                "storage",
                "channel storage: f32, f16 or u16, of those the technique defines (vsm: all three; esm, evsm, convolution: f32 or f16; msm: f32 or u16, the paper's 64-bit quantization)",
                |o: &mut Filtering| &mut o.storage,
            ),
        ]);
        f
    }

    /// What is wrong beyond each field's range (a blur wider than the map), as `(key, value,
    /// message)` for the technique's [`Declaration::error`].
    pub fn beyond_ranges(&self) -> Option<(&'static str, String, String)> {
        (2 * self.radius + 1 > self.map.size).then(|| {
            (
                "radius",
                self.radius.to_string(),
                format!(
                    "makes a kernel of {} texels, wider than the map (size={})",
                    2 * self.radius + 1,
                    self.map.size
                ),
            )
        })
    }
}

/// The light-size options of the variable-width lookup (PCSS's blocker estimate from the
/// filtered map, RTR eq. 7.6).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Variable {
    /// The light's width as a multiple of the scene's area light.
    pub light: f32,
    /// Directional lights: angular diameter in degrees.
    pub angle: f32,
}

/// Light-bleeding reduction (Lauritzen 2007, RTR 7.7): visibilities below `amount` become 0
/// and the rest are rescaled to [0, 1], `linstep(amount, 1, p)`.
#[inline(always)]
pub fn reduce_bleeding(p: f32, amount: f32) -> f32 {
    if amount <= 0.0 {
        return p;
    }
    ((p - amount) / (1.0 - amount)).clamp(0.0, 1.0)
}

/// The declaration of a light-bleeding reduction amount at `access`.
pub fn bleeding_field<O: Clone + Default + 'static>(access: fn(&mut O) -> &mut f32) -> Field<O> {
    Field::range(
        "bleeding",
        "light-bleeding reduction: visibilities below this become 0, the rest are rescaled (linstep)",
        0.0,
        0.999,
        access,
    )
}

/// Chebyshev's one-tailed bound (RTR eq. 7.8): the largest share of a distribution of mean
/// `mean` and second moment `m2` that lies at or beyond `t`; 1 where `t <= mean`. The
/// variance is at least `min_variance`. Returns the bound and the variance used.
#[inline(always)]
pub fn chebyshev(mean: f32, m2: f32, t: f32, min_variance: f32) -> (f32, f32) {
    let var = (m2 - mean * mean).max(min_variance);
    if t <= mean {
        return (1.0, var);
    }
    let d = t - mean;
    (var / (var + d * d), var)
}

/// Per light view: the map's depth to linear depth, and back to distance.
#[derive(Copy, Clone, Debug)]
pub struct Linear {
    /// The view's clip depth to distance along its axis.
    pub to_distance: DepthToDistance,
    /// Distance of the near plane (clip depth 0).
    pub near: f32,
    /// Distance of the far plane (clip depth 1).
    pub far: f32,
    /// Whether the view is perspective (orthographic clip depth is already linear).
    pub perspective: bool,
}

impl Linear {
    /// The linear depth of view `v`.
    pub fn of(v: &LightView) -> Linear {
        let d = v.depth_to_distance();
        Linear {
            to_distance: d,
            near: d.at(0.0),
            far: d.at(1.0),
            perspective: v.perspective(),
        }
    }

    /// Linear depth in [0, 1] of clip depth `z`.
    #[inline(always)]
    pub fn t(&self, z: f32) -> f32 {
        if !self.perspective {
            return z.clamp(0.0, 1.0);
        }
        ((self.to_distance.at(z) - self.near) / (self.far - self.near)).clamp(0.0, 1.0)
    }

    /// Distance along the view's axis of linear depth `t`.
    #[inline(always)]
    pub fn distance(&self, t: f32) -> f32 {
        if self.perspective {
            self.near + t * (self.far - self.near)
        } else {
            self.to_distance.at(t)
        }
    }
}

/// One light view's filtered map.
struct ViewMap {
    /// The encoded planes before filtering (kept for `dump`).
    encoded: Vec<Surface<Vec4>>,
    /// The filtered planes.
    filtered: Prefiltered,
    linear: Linear,
}

/// The shared pass of every filtered technique (see the module docs): the light pass, the
/// encoding into `M`'s representation, the prefilter and one filtered lookup per pixel.
pub struct FilteredPass<M> {
    /// The representation.
    pub moments: M,
    opts: Filtering,
    variable: Option<Variable>,
    maps: LightMaps,
    views: Vec<ViewMap>,
    /// Per view, the nearest caster's distance (variable width only).
    nearest: Vec<f32>,
    /// Last run's counts: prefilter texel reads, clamped texels, lookups, non-finite results.
    prefilter_reads: u64,
    clamped: u64,
    lookups: u64,
    nonfinite: u64,
    /// Last run: cascades were asked of a light that is not directional (one map was drawn).
    uncascaded: bool,
}

/// One pixel's lookup counts (packed into the per-pixel counter: lookups in the low 32 bits,
/// non-finite results above).
const NONFINITE: u64 = 1 << 32;

impl<M: Moments> FilteredPass<M> {
    /// The pass for `moments` with the shared options `opts` and, for a variable-width lookup
    /// (summed-area tables only), the light's size.
    pub fn new(moments: M, opts: Filtering, variable: Option<Variable>) -> FilteredPass<M> {
        FilteredPass {
            moments,
            opts,
            variable,
            maps: LightMaps::default(),
            views: Vec::new(),
            nearest: Vec::new(),
            prefilter_reads: 0,
            clamped: 0,
            lookups: 0,
            nonfinite: 0,
            uncascaded: false,
        }
    }

    /// The shared options.
    pub fn options(&self) -> &Filtering {
        &self.opts
    }

    /// Texels clamped to the storage's largest value in the last run (infinities from an
    /// exponent past the storage's limit).
    pub fn clamped(&self) -> u64 {
        self.clamped
    }

    /// Lookups of the last run whose result was not finite (replaced by 1, lit).
    pub fn nonfinite(&self) -> u64 {
        self.nonfinite
    }

    /// The filtered planes of view `i` of the last run.
    pub fn filtered(&self, i: usize) -> Option<&Prefiltered> {
        self.views.get(i).map(|v| &v.filtered)
    }

    /// The light's depth maps of the last run.
    pub fn light_maps(&self) -> &LightMaps {
        &self.maps
    }

    /// The light pass, then per view the encoding into the representation, rounded to the
    /// storage format (an infinity clamped to the format's largest value and counted).
    fn encode(&mut self, p: &Pipeline) -> Result<Vec<Vec<Surface<Vec4>>>, Error> {
        let np = self.moments.planes();
        let storage = self.moments.storage();
        let mut clamped = 0u64;
        let mut out = Vec::new();
        for (map, view) in self.maps.maps() {
            let lin = Linear::of(view);
            let (w, h) = (map.width() as usize, map.height() as usize);
            check_room(map.width(), map.height(), 16, 3 * np as u64).map_err(|e| {
                Error::from(e).within(&format!(
                    "the filtered map ({np} planes of 4 channels, option size={})",
                    self.opts.map.size
                ))
            })?;
            let m = &self.moments;
            let uses_slope = m.uses_slope();
            let data = map.data();
            let tz = |x: usize, y: usize| lin.t(data[y * w + x]);
            // One texel: encoded, rounded to the storage, an infinity clamped and counted.
            let texel = |x: usize, y: usize, o: &mut [Vec4]| {
                let slope = if uses_slope {
                    slope_at(&tz, w, h, x, y)
                } else {
                    Vec2::ZERO
                };
                m.encode(tz(x, y), slope, o);
                let mut n = 0u64;
                for v in o.iter_mut() {
                    let s = Vec4::from_array(v.to_array().map(|c| storage.store(c)));
                    let lim = storage.max();
                    let c = s.clamp(Vec4::splat(-lim), Vec4::splat(lim));
                    n += (c != s) as u64;
                    *v = c;
                }
                n
            };
            let (planes, n) = if np == 1 {
                // One plane: written in place.
                let mut plane = vec![Vec4::ZERO; w * h];
                let n: u64 = p.install(|| {
                    plane
                        .par_chunks_mut(w)
                        .enumerate()
                        .map(|(y, row)| (0..w).map(|x| texel(x, y, &mut row[x..x + 1])).sum::<u64>())
                        .sum()
                });
                (vec![Surface::from_vec(map.width(), map.height(), plane)?], n)
            } else {
                // Several planes: interleaved per texel, then one surface per plane.
                let mut inter = vec![Vec4::ZERO; w * h * np];
                let n: u64 = p.install(|| {
                    inter
                        .par_chunks_mut(w * np)
                        .enumerate()
                        .map(|(y, row)| (0..w).map(|x| texel(x, y, &mut row[x * np..(x + 1) * np])).sum::<u64>())
                        .sum()
                });
                let planes = (0..np)
                    .map(|k| {
                        let data: Vec<Vec4> = inter.iter().skip(k).step_by(np).copied().collect();
                        Surface::from_vec(map.width(), map.height(), data)
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                (planes, n)
            };
            clamped += n;
            out.push(planes);
        }
        self.clamped = clamped;
        Ok(out)
    }

    /// One pixel's lookup (the per-pixel contract: the image and `inspect` both come from
    /// here): the view that sees the pixel's point, its linear depth, the filtered planes at
    /// its map position (the filter at least the pixel's footprint wide; for the variable
    /// width, first a blocker estimate over the search region), and the representation's
    /// visibility. Returns the value and the count (lookups in the low 32 bits; bit 32 set
    /// for a non-finite result that was replaced).
    pub fn lookup(&self, frame: &Frame, x: usize, y: usize, tr: &mut impl Trace) -> (f32, u64) {
        let w = frame.width() as usize;
        let Some(s) = frame.points()[y * w + x] else {
            return (f32::NAN, 0);
        };
        let light = &frame.light;
        let maps = self.maps.maps();
        let Some(at) = light::locate(maps, light, s.position) else {
            tr.step(|| Step::new("behind the light", "the point is behind the view's eye: lit"));
            return (1.0, 0);
        };
        let (map, view) = &maps[at.view];
        let size = map.width() as f32;
        let vm = &self.views[at.view];
        let t = vm.linear.t(at.depth);
        tr.step(|| {
            Step::new(
                "light-space position",
                "the view that sees the point, its texture coordinate (top-left origin) and linear depth between the view's planes",
            )
            .int("view", at.view)
            .vec2("uv", at.uv)
            .vec2("texel", at.uv * size)
            .num("clip depth", at.depth)
            .num("linear depth", t)
        });
        if !at.inside() {
            tr.step(|| Step::new("outside", "the point is outside the light's map: lit"));
            return (1.0, 0);
        }
        // A blurred map is read bilinearly whatever the footprint: only the mip chain and the
        // summed-area table widen their filter to it.
        let foot = match vm.filtered {
            Prefiltered::Plain(_) => 1.0,
            _ => footprint(frame, x, y, at.view, maps, at.uv, size),
        };
        let kernel = (2 * self.opts.radius + 1) as f32;
        let np = self.moments.planes();
        let log = self.moments.log_space();
        let mut m = [Vec4::ZERO; MAX_PLANES];
        let mut lookups = 1u64;
        let mut width = kernel.max(foot);
        if let (Some(var), Prefiltered::Sat(_)) = (self.variable, &vm.filtered) {
            // Variable width (Lauritzen 2007's summed-area VSM, PCSS's estimate of RTR eq.
            // 7.6): the blocker search region of the light's cone, one box lookup there, the
            // average blocker from the representation, the penumbra from it.
            let lw = light_width(frame, var.light, var.angle);
            if lw > 0.0 {
                let d_r = vm.linear.distance(t);
                let search = search_texels(view, lw, d_r, self.nearest[at.view]).clamp(1.0, size);
                vm.filtered.sample(at.uv, search, log, &mut m[..np]);
                lookups += 1;
                let blocker = self.moments.blocker(&m[..np], t);
                let pen = blocker.map(|b| penumbra_texels(view, lw, d_r, vm.linear.distance(b)));
                width = pen.map_or(kernel, |p| p.max(kernel)).max(foot).min(size);
                tr.step(|| {
                    Step::new(
                        "blocker estimate",
                        "the filtered map over the blocker-search region of the light's cone; the average blocker depth from the representation, the penumbra width from RTR eq. 7.6",
                    )
                    .num("light width", lw)
                    .num("search width (texels)", search)
                    .num("average blocker depth", blocker.unwrap_or(f32::NAN))
                    .num("penumbra width (texels)", pen.unwrap_or(0.0))
                });
            }
        }
        let info = vm.filtered.sample(at.uv, width, log, &mut m[..np]);
        tr.step(|| {
            let names = self.moments.channels();
            let mut st = Step::new("filtered lookup", info.what())
                .num("pixel footprint (texels)", foot)
                .num("filter width (texels)", width);
            if let Some(l) = info.level {
                st = st.num("mip level", l);
            }
            for (i, n) in names.iter().enumerate() {
                st = st.num(n, m[i / 4][i % 4]);
            }
            st
        });
        let v = self.moments.visibility(&m[..np], t, tr);
        if v.is_finite() {
            (v.clamp(0.0, 1.0), lookups)
        } else {
            tr.step(|| {
                Step::new(
                    "not finite",
                    "the representation gave no finite value (overflowed moments): lit, and counted",
                )
            });
            (1.0, lookups | NONFINITE)
        }
    }
}

/// The smaller one-sided difference of linear depth `t(x, y)` per texel, per axis (a
/// silhouette's jump is not a slope).
#[inline(always)]
fn slope_at(t: &impl Fn(usize, usize) -> f32, w: usize, h: usize, x: usize, y: usize) -> Vec2 {
    let c = t(x, y);
    let d = |a: Option<f32>, b: Option<f32>| match (a, b) {
        (Some(a), Some(b)) => {
            let (da, db) = (c - a, b - c);
            if da.abs() < db.abs() {
                da
            } else {
                db
            }
        }
        (Some(a), None) => c - a,
        (None, Some(b)) => b - c,
        (None, None) => 0.0,
    };
    let dx = d((x > 0).then(|| t(x - 1, y)), (x + 1 < w).then(|| t(x + 1, y)));
    let dy = d((y > 0).then(|| t(x, y - 1)), (y + 1 < h).then(|| t(x, y + 1)));
    Vec2::new(dx, dy)
}

/// The camera pixel's footprint in texels of view `view`: per screen axis, the smaller change
/// of the map position to the pixel's neighbours on either side that lie on the same object
/// (a GPU's derivatives, without their jump across silhouettes); the larger of the two axes
/// (1 where there is no such neighbour).
fn footprint(
    frame: &Frame,
    x: usize,
    y: usize,
    view: usize,
    maps: &[(Surface<f32>, LightView)],
    uv: Vec2,
    size: f32,
) -> f32 {
    let (w, h) = (frame.width() as usize, frame.height() as usize);
    let (pts, objs) = (frame.points(), frame.gbuffer.object.data());
    let own = objs[y * w + x];
    let dist = |xx: usize, yy: usize| {
        let i = yy * w + xx;
        if objs[i] != own {
            return None;
        }
        let (q, _) = maps[view].1.lookup(pts[i]?.position)?;
        Some(((q - uv) * size).length())
    };
    let least = |a: Option<f32>, b: Option<f32>| match (a, b) {
        (Some(a), Some(b)) => a.min(b),
        (a, b) => a.or(b).unwrap_or(0.0),
    };
    let dx = least(
        (x + 1 < w).then(|| dist(x + 1, y)).flatten(),
        (x > 0).then(|| dist(x - 1, y)).flatten(),
    );
    let dy = least(
        (y + 1 < h).then(|| dist(x, y + 1)).flatten(),
        (y > 0).then(|| dist(x, y - 1)).flatten(),
    );
    let f = dx.max(dy);
    if f.is_finite() {
        f.clamp(1.0, size)
    } else {
        1.0
    }
}

impl<M: Moments> Pass for FilteredPass<M> {
    type Output = Vec<f32>;

    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Vec<f32>, Error> {
        let mut map = self.opts.map.clone();
        self.uncascaded = self.opts.cascades > 0 && frame.light.kind != crate::scene::LightKind::Directional;
        if self.opts.cascades > 0 && !self.uncascaded {
            map.views = crate::shadow::light::Views::Cascades(crate::shadow::light::cascades::Cascades {
                count: self.opts.cascades,
                ..Default::default()
            });
        }
        self.maps.render(p, frame, &map, Layer::First)?;
        self.nearest = match self.variable {
            Some(_) => self
                .maps
                .maps()
                .iter()
                .map(|(m, v)| Linear::of(v).distance(Linear::of(v).t(compute::least(p, m, 1.0))))
                .collect(),
            None => Vec::new(),
        };
        passes.end("light pass");
        let encoded = self.encode(p)?;
        passes.end("encode");
        let mut views = Vec::new();
        let mut reads = 0u64;
        for (planes, (_, view)) in encoded.into_iter().zip(self.maps.maps()) {
            let (filtered, n) = Prefiltered::build(
                p,
                &planes,
                self.opts.prefilter,
                self.opts.radius,
                self.opts.sums,
                self.moments.log_space(),
                self.moments.storage(),
            )?;
            reads += n;
            views.push(ViewMap {
                encoded: planes,
                filtered,
                linear: Linear::of(view),
            });
        }
        self.views = views;
        self.prefilter_reads = reads;
        passes.end("prefilter");
        let this = &*self;
        let (out, count) = per_pixel_counted(p, frame, |x, y| this.lookup(frame, x, y, &mut NoTrace));
        self.lookups = count & (NONFINITE - 1);
        self.nonfinite = count >> 32;
        passes.end("lookup pass");
        Ok(out)
    }

    fn light_views(&self) -> Vec<crate::shadow::light::LightView> {
        self.maps.views()
    }

    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32> {
        if self.views.is_empty() || frame.point(x, y).is_none() {
            return None;
        }
        t.step(|| {
            Step::new("maps", "the light pass and the prefilter of the last run")
                .int("views", self.views.len())
                .int("size", self.opts.map.size)
                .text("prefilter", self.opts.prefilter.as_str())
                .int("radius", self.opts.radius)
                .text("storage", self.moments.storage().as_str())
                .int("casters culled by fitting", self.maps.culled())
        });
        Some(self.lookup(frame, x as usize, y as usize, t).0)
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v = self.maps.stages(p, frame)?;
        let names = self.moments.channels();
        let range = |s: &Surface<f32>| {
            let (lo, hi) = s
                .data()
                .iter()
                .filter(|v| v.is_finite())
                .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            if lo <= hi {
                (lo, if hi > lo { hi } else { lo + 1.0 })
            } else {
                (0.0, 1.0)
            }
        };
        // The first views' planes (a cube map's six faces would be many stages), at most
        // the first four channels of each.
        for (i, vm) in self.views.iter().enumerate().take(2) {
            let filtered = vm.filtered.plain();
            for (c, name) in names.iter().enumerate().take(4) {
                let enc = vm.encoded[c / 4].map(|t| t[c % 4]);
                let (lo, hi) = range(&enc);
                v.push(Stage::Scalar {
                    name: format!("encoded{i}_{name}"),
                    data: enc,
                    lo,
                    hi,
                });
                if let Some(f) = filtered {
                    let fl = f[c / 4].map(|t| t[c % 4]);
                    let (lo, hi) = range(&fl);
                    v.push(Stage::Scalar {
                        name: format!("filtered{i}_{name}"),
                        data: fl,
                        lo,
                        hi,
                    });
                }
            }
        }
        Ok(v)
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("map texels", self.maps.texels() as f64),
            ("casters culled", self.maps.culled() as f64),
            ("stored channels per texel", (4 * self.moments.planes()) as f64),
            ("prefilter texel reads", self.prefilter_reads as f64),
            ("filtered lookups", self.lookups as f64),
            ("clamped texels", self.clamped as f64),
            ("non-finite results", self.nonfinite as f64),
        ]
    }

    fn notes(&self) -> Vec<String> {
        let mut n = Vec::new();
        if self.uncascaded {
            n.push(format!(
                "cascades={} split a directional light's map: this light's views were drawn whole, without cascades",
                self.opts.cascades
            ));
        }
        if self.clamped > 0 {
            n.push(format!(
                "{} stored channels overflowed the {} storage (largest {}) and were clamped to it: the exponent is past the storage's limit",
                self.clamped,
                self.moments.storage().as_str(),
                self.moments.storage().max()
            ));
        }
        if self.nonfinite > 0 {
            n.push(format!(
                "{} lookups gave no finite visibility (overflowed moments) and were taken as lit",
                self.nonfinite
            ));
        }
        n
    }
}

/// A filtered technique's constructor: the declaration's ranges and the shared options'
/// beyond them are checked, then `moments` makes the representation (refusing a combination
/// of its own options with an error from the declaration it is given), whose storage must be
/// one it defines ([`Moments::STORAGES`]); the family's pass draws it over `filtering` and,
/// for a variable-width lookup, `variable`.
pub fn build<O: Clone + Default + 'static, M: Moments>(
    d: Declaration<O>,
    o: &O,
    filtering: &Filtering,
    variable: Option<Variable>,
    moments: impl FnOnce(&Declaration<O>) -> Result<M, Error>,
) -> Result<PassTechnique<FilteredPass<M>>, Error> {
    d.check(o)?;
    if let Some((k, v, m)) = filtering.beyond_ranges() {
        return Err(d.error(k, &v, m));
    }
    let m = moments(&d)?;
    if !M::STORAGES.contains(&m.storage()) {
        return Err(d.error(
            "storage",
            m.storage().as_str(),
            format!(
                "is not a storage this technique defines (it has {})",
                M::STORAGES.iter().map(|s| s.show()).collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    Ok(PassTechnique::with(
        d.technique,
        FilteredPass::new(m, filtering.clone(), variable),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_precision_rounds_as_ieee_half() {
        for (v, h) in [
            (1.0f32, 1.0f32),
            (1.0 + 1.0 / 2048.0, 1.0),                // a tie: to even
            (1.0 + 3.0 / 2048.0, 1.0 + 2.0 / 1024.0), // a tie: to even (up)
            (65504.0, 65504.0),
            (65519.0, 65504.0),
            (65520.0, f32::INFINITY),
            (-70000.0, f32::NEG_INFINITY),
            (1e-8, 0.0),
            (5.960_464_5e-8, 5.960_464_5e-8), // the least subnormal half
            (0.1, 0.099_975_586),
        ] {
            assert_eq!(to_f16(v), h, "{v}");
        }
        assert!(to_f16(f32::NAN).is_nan());
        assert_eq!(Storage::U16.store(0.5), (0.5f32 * 65535.0).round() / 65535.0);
        assert_eq!(Storage::U16.store(2.0), 1.0);
    }

    #[test]
    fn chebyshev_bounds_the_lit_share() {
        // Half the texels at 0.2, half at 0.6: at 0.8 the bound is var / (var + 0.4^2).
        let (mean, m2) = (0.4f32, 0.5 * (0.04 + 0.36));
        let (p, var) = chebyshev(mean, m2, 0.8, 0.0);
        assert!((var - 0.04).abs() < 1e-6 && (p - 0.04 / (0.04 + 0.16)).abs() < 1e-6);
        assert_eq!(chebyshev(mean, m2, 0.3, 0.0).0, 1.0);
        assert_eq!(reduce_bleeding(0.2, 0.3), 0.0);
        assert!((reduce_bleeding(0.65, 0.3) - 0.5).abs() < 1e-6);
    }
}
