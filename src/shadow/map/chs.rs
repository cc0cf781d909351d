//! Contact-hardening shadows (AMD CHS; Sikachev et al., RTR 7.6): PCSS's three steps on a
//! mip chain of the shadow map, so that the work per pixel is fixed and the penumbra is set
//! in world units, not by the map's resolution.
//!
//! 1. **Blocker search, 8x8 in 16 gathers.** The search width `S` (texels of the base map)
//!    is PCSS's cone at the nearest caster ([`super::pcss`]). The search reads the 8x8 texels
//!    around the point at the level `L_s = ceil(log2(S / 8))` of the *minimum* chain (the
//!    pipeline's reduction, [`crate::shadow::sample::kernel::MinMax`]): 16 gathers of 2x2. A texel is a
//!    blocker if its minimum depth is nearer than the receiver's plane anywhere in its block
//!    (`z + g . d - (|g_x| + |g_y|) 2^L / 2` with `g` the receiver-plane gradient, Isidoro
//!    2006), and the blockers' distances are averaged.
//! 2. **Penumbra.** RTR eq. 7.6 as in PCSS: `w_penumbra = w_light (d_r - d_o) / d_o`, `P`
//!    texels at the receiver.
//! 3. **Filtering at the penumbra's level.** A `kernel x kernel` grid of 2x2 comparisons at
//!    the fractional level `L_f = log2(P / kernel)`: sharp levels (the base map) where the
//!    penumbra is narrow, coarse ones where it is wide, blended between the two nearest levels
//!    so the width varies smoothly. A coarse level compares against both chains, the minimum
//!    (which widens shadows by up to a texel of the level) and the maximum (which narrows
//!    them), and averages the two, so an edge stays where it is.
//!
//! Known failures: PCSS's average-blocker assumption; the minimum chain's blockers are the
//! nearest caster of each block, so the average leans toward the light and the penumbra
//! toward too wide where a block mixes casters; the coarse levels' blocks blur small
//! shadows and lose thin occluders in wide penumbrae.

use crate::frame::Frame;
use crate::math;
use crate::pipeline::{Pipeline, Surface};
use crate::shadow::inspect::{self, NoTrace, Step, Trace};
use crate::shadow::light::soft::light_size_fields;
use crate::shadow::light::soft::{light_width, penumbra_texels, search_texels};
use crate::shadow::light::{DepthToDistance, Layer, LightView, MapOptions};
use crate::shadow::options::within;
use crate::shadow::pixels::{per_pixel, per_pixel4_counted};
use crate::shadow::sample::kernel::{Kernel, MinMax, Pattern, Reference, Reference4};
use crate::shadow::sample::lookup::cone_field;
use crate::shadow::sample::lookup::{At, Bias, Estimate, MapLookup, Prepared, Setup, Wide};
use crate::shadow::technique::{Declaration, Entry, Family, Field, ShadowTechnique, Stage, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;
use glam::{Vec2, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "chs",
    family: Family::Map,
    summary: "contact-hardening shadows (AMD): PCSS on a min/max mip chain, 8x8 search, filter level from the penumbra",
    sweep: &[&[], &[("size", "512")]],
    extended: &[&[("kernel", "3")], &[("kernel", "11")], &[("size", "4096")]],
    models: &[crate::shadow::technique::Effect::AreaLight],
    ..Entry::BASE
};

/// Taps per axis of the blocker search (8x8 texels in 16 gathers).
pub const SEARCH: u32 = 8;

/// Options of contact-hardening shadows.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass. Default: its defaults (2048 texels, f32, 4 units, slope 1.1).
    pub map: MapOptions,
    /// Normal-offset and receiver-plane bias. Default: the receiver plane on, which the
    /// coarse levels need.
    pub bias: Bias,
    /// The bias cone across the filter (Burley 2006). Default: 0.
    pub cone: f32,
    /// The light's width as a multiple of the scene's area light (0: a hard shadow).
    /// Default: 1.
    pub light: f32,
    /// Directional lights: angular diameter in degrees. Default: 0 (hard).
    pub angle: f32,
    /// Filter taps per axis at the penumbra's level (odd, 1 to 15). Default: 7.
    pub kernel: u32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            map: MapOptions::default(),
            bias: Bias {
                receiver: true,
                ..Default::default()
            },
            cone: 0.0,
            light: 1.0,
            angle: 0.0,
            kernel: 7,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(MapOptions::fields(), |o: &mut Options| &mut o.map);
    fields.extend(within(Bias::fields(), |o: &mut Options| &mut o.bias));
    fields.push(cone_field(|o: &mut Options| &mut o.cone));
    fields.extend(light_size_fields(
        |o: &mut Options| &mut o.light,
        |o: &mut Options| &mut o.angle,
    ));
    fields.extend([Field::range(
        "kernel",
        "filter taps per axis at the penumbra's mip level (made odd)",
        1,
        15,
        |o: &mut Options| &mut o.kernel,
    )]);
    Declaration::new("chs", fields)
}

/// Contact-hardening shadows (see the module docs).
pub struct Chs {
    opts: Options,
    lookup: MapLookup,
    nearest: Vec<f32>,
    width: f32,
    taps: u64,
    times: Vec<(&'static str, f64)>,
}

impl Chs {
    /// CHS with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Chs, Error> {
        declaration().check(&opts)?;
        let lookup = MapLookup::new(Setup {
            map: opts.map.clone(),
            layer: Layer::First,
            bias: opts.bias,
            // Wide kernels (the receiver plane and cone across the filter), no hierarchy.
            wide: Some(Wide {
                cone: opts.cone,
                hierarchy: false,
            }),
            // The map's min/max chains are CHS's mip chain.
            min_max: true,
        });
        Ok(Chs {
            opts,
            lookup,
            nearest: Vec::new(),
            width: 0.0,
            taps: 0,
            times: Vec::new(),
        })
    }

    /// Level `l` of the minimum (`max == false`) or maximum chain of view `face`; level 0 is
    /// the map itself.
    fn level(&self, face: usize, l: usize, max: bool) -> &Surface<f32> {
        if l == 0 {
            return &self.lookup.maps()[face].0;
        }
        let c = self.chains(face);
        let chain = if max { &c.max } else { &c.min };
        &chain.levels()[(l - 1).min(chain.level_count() - 1)]
    }

    /// The min/max chains of view `face` (the lookup builds them: [`Setup::min_max`]).
    fn chains(&self, face: usize) -> &MinMax {
        self.lookup.min_max(face).expect("the map builds its min/max chains")
    }

    fn levels(&self, face: usize) -> usize {
        self.chains(face).min.level_count() + 1
    }

    /// Steps 1 and 2 (the search on the minimum chain and the penumbra estimate).
    fn estimate(&self, at: &At) -> (Estimate, usize) {
        let view: &LightView = &self.lookup.maps()[at.face].1;
        let size = self.lookup.maps()[at.face].0.width() as f32;
        let d_r = view.distance(at.r.z);
        let d_min = self.nearest[at.face].min(d_r);
        let search = search_texels(view, self.width, d_r, d_min).clamp(1.0, size);
        let ls = (math::log2(search / SEARCH as f32).ceil().max(0.0) as usize).min(self.levels(at.face) - 1);
        let lvl = self.level(at.face, ls, false);
        let scale = (1u32 << ls) as f32;
        let (lw, lh) = (lvl.width() as i64, lvl.height() as i64);
        // The 8x8 texels around the point at level ls: 16 gathers of 2x2.
        let c = at.uv * Vec2::new(lw as f32, lh as f32);
        let (x0, y0) = (
            (c.x - SEARCH as f32 / 2.0).round() as i64,
            (c.y - SEARCH as f32 / 2.0).round() as i64,
        );
        let slack = (at.r.gradient.x.abs() + at.r.gradient.y.abs()) * scale * 0.5;
        let (sum, found) = Search {
            lvl,
            corner: (x0, y0),
            c,
            scale,
            slack,
            r: at.r,
            // `view.distance`, its constants made once.
            distance: view.depth_to_distance(),
        }
        .run();
        let mut e = Estimate {
            search,
            found,
            taps: SEARCH * SEARCH,
            receiver: d_r,
            blocker: f32::NAN,
            penumbra: 0.0,
            class: crate::shadow::sample::kernel::Class::Mixed,
        };
        if found == 0 {
            e.class = crate::shadow::sample::kernel::Class::Lit;
            return (e, ls);
        }
        let d_o = sum / found as f32;
        e.blocker = d_o;
        e.penumbra = penumbra_texels(view, self.width, d_r, d_o).min(size);
        (e, ls)
    }

    /// PCF of the kernel at level `l` (both chains averaged above level 0).
    fn pcf_at(&self, at: &At, l: usize, x: usize, y: usize, t: &mut impl Trace) -> (f32, u32) {
        let scale = (1u32 << l) as f32;
        let r = Reference {
            z: at.r.z,
            gradient: at.r.gradient * scale,
            cone: at.r.cone * scale,
        };
        let k = Kernel {
            pattern: Pattern::Grid,
            taps: 16,
            width: self.opts.kernel as f32,
        };
        let lo = k.filter(self.level(at.face, l, false), at.uv, &r, x as u32, y as u32, t);
        if l == 0 {
            return (lo.value, lo.taps);
        }
        let hi = k.filter(self.level(at.face, l, true), at.uv, &r, x as u32, y as u32, t);
        (0.5 * (lo.value + hi.value), lo.taps + hi.taps)
    }

    #[inline(always)]
    fn lookup(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        match self.lookup.prepare(frame, x, y, t) {
            Prepared::Done(v, n) => (v, n),
            Prepared::At(at) => self.lookup_at(&at, x, y, t),
        }
    }

    /// [`Chs::lookup`] of pixels `x .. x + n` of row `y` (`n` at most 4): prepared together
    /// ([`MapLookup::prepare4`]: the receiver planes on four lanes), then one at a time, so
    /// every value and count is the one-pixel lookup's.
    fn lookup4(&self, frame: &Frame, x: usize, y: usize, n: usize) -> ([f32; 4], u64) {
        let (mut out, mut count) = ([f32::NAN; 4], 0u64);
        let mut ats = [None; 4];
        self.lookup.prepare4(frame, (x, y), n, &mut ats, &mut out, &mut count);
        for (l, at) in ats.iter().enumerate() {
            if let Some(at) = at {
                let (v, c) = self.lookup_at(at, x + l, y, &mut NoTrace);
                (out[l], count) = (v, count + c);
            }
        }
        (out, count)
    }

    /// [`Chs::lookup`] from its prepared position on.
    #[inline(always)]
    fn lookup_at(&self, at: &At, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        let at = *at;
        if self.width <= 0.0 {
            t.step(|| Step::new("hard", "the light has no width: one 2x2 comparison"));
            let map = &self.lookup.maps()[at.face].0;
            return (crate::shadow::sample::kernel::bilinear_compare(map, at.uv, at.r.z), 1);
        }
        let (e, ls) = self.estimate(&at);
        t.step(|| {
            Step::new(
                "blocker search",
                "8x8 texels of the minimum chain at the level whose 8 texels span the search width",
            )
            .num("search width in texels", e.search)
            .int("search level", ls)
            .int("blockers found", e.found)
            .num("receiver distance", e.receiver)
            .num("average blocker distance", e.blocker)
        });
        if e.found == 0 {
            return (1.0, e.taps as u64);
        }
        // The fractional level where the kernel spans the penumbra.
        let lf = math::log2(e.penumbra / self.opts.kernel as f32)
            .max(0.0)
            .min((self.levels(at.face) - 1) as f32);
        let (l0, frac) = (lf.floor() as usize, lf.fract());
        let (v0, n0) = self.pcf_at(&at, l0, x, y, t);
        let (v, n) = if frac > 0.0 && l0 + 1 < self.levels(at.face) {
            let (v1, n1) = self.pcf_at(&at, l0 + 1, x, y, t);
            (v0 + (v1 - v0) * frac, n0 + n1)
        } else {
            (v0, n0)
        };
        t.step(|| {
            Step::new(
                "filter",
                "a kernel x kernel grid of 2x2 comparisons at the penumbra's level, blended with the next level",
            )
            .num("penumbra width in texels", e.penumbra)
            .num("filter level", lf)
            .num("visibility at the finer level", v0)
            .num("visibility", v)
        });
        (v, (n + e.taps) as u64)
    }
}

/// The blocker search's 8x8 texels of one level (see [`Chs`]'s step 1).
struct Search<'a> {
    lvl: &'a Surface<f32>,
    /// The first texel, and the point, in the level's texels.
    corner: (i64, i64),
    c: Vec2,
    /// Base texels per texel of the level.
    scale: f32,
    /// The receiver plane's rise over half a texel of the level.
    slack: f32,
    r: Reference,
    distance: DepthToDistance,
}

impl Search<'_> {
    /// The blockers' distance sum and count (texels outside the level are skipped).
    fn run(&self) -> (f32, u32) {
        self.inside().unwrap_or_else(|| self.clipped())
    }

    /// [`Search::run`] one texel at a time.
    fn clipped(&self) -> (f32, u32) {
        let (lw, lh) = (self.lvl.width() as i64, self.lvl.height() as i64);
        let (x0, y0) = self.corner;
        let (mut sum, mut found) = (0.0f32, 0u32);
        for j in 0..SEARCH as i64 {
            for i in 0..SEARCH as i64 {
                let (x, y) = (x0 + i, y0 + j);
                if x < 0 || y < 0 || x >= lw || y >= lh {
                    continue;
                }
                // The texel block's centre, in base texels from the point.
                let d = (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - self.c) * self.scale;
                let depth = self.lvl.at(x as u32, y as u32);
                if depth < self.r.at(d) - self.slack {
                    sum += self.distance.at(depth);
                    found += 1;
                }
            }
        }
        (sum, found)
    }

    /// [`Search::clipped`] where every texel is inside the level: each row's texels four at a
    /// time with the same operations per texel, the blockers' distances added in the same
    /// order, so the same sum. `None` near the level's edges.
    fn inside(&self) -> Option<(f32, u32)> {
        let (lw, lh) = (self.lvl.width() as i64, self.lvl.height() as i64);
        let (x0, y0) = self.corner;
        let n = SEARCH as i64;
        if !(x0 >= 0 && y0 >= 0 && x0 + n <= lw && y0 + n <= lh) {
            return None;
        }
        let r = Reference4::new([self.r; 4]);
        let (cx, sc, sl) = (Vec4::splat(self.c.x), Vec4::splat(self.scale), Vec4::splat(self.slack));
        let data = self.lvl.data();
        let (mut sum, mut found) = (0.0f32, 0u32);
        for j in 0..n {
            let y = y0 + j;
            let dy = Vec4::splat(((y as f32 + 0.5) - self.c.y) * self.scale);
            let row = &data[(y * lw + x0) as usize..(y * lw + x0 + n) as usize];
            for (q, texels) in row.chunks_exact(4).enumerate() {
                let x = Vec4::from_array(std::array::from_fn(|k| (x0 + 4 * q as i64 + k as i64) as f32));
                let dx = ((x + Vec4::splat(0.5)) - cx) * sc;
                let depth = Vec4::from_slice(texels);
                let mut bits = depth.cmplt(r.at(dx, dy) - sl).bitmask();
                if bits != 0 {
                    let d = self.distance.at4(depth);
                    while bits != 0 {
                        sum += d[bits.trailing_zeros() as usize];
                        found += 1;
                        bits &= bits - 1;
                    }
                }
            }
        }
        Some((sum, found))
    }
}

impl ShadowTechnique for Chs {
    fn name(&self) -> &'static str {
        "chs"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        self.lookup.light_pass(p, frame)?;
        self.width = light_width(frame, self.opts.light, self.opts.angle);
        self.nearest = self.lookup.light_maps().nearest_casters(p);
        passes.end("light pass and min/max chains");
        let this = &*self;
        let (out, taps) = per_pixel4_counted(p, frame, f32::NAN, |x, y, n| this.lookup4(frame, x, y, n));
        self.taps = taps;
        passes.end("lookup pass");
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let header = || {
            Step::new("map", "the light pass of the last run and its min/max chains")
                .int("views", self.lookup.maps().len())
                .int("size", self.opts.map.size)
                .int("levels", self.levels(0))
                .num("light width", self.width)
        };
        inspect::closed(|t| {
            self.lookup
                .explain(t, header, |t| self.lookup(frame, x as usize, y as usize, t).0)
        })
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![("map texels", self.lookup.texels() as f64), ("taps", self.taps as f64)]
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v = self.lookup.stages(p, frame)?;
        if self.lookup.maps().is_empty() || self.width <= 0.0 {
            return Ok(v);
        }
        // The filter level per pixel, and the min chain's levels 1-3 of the first view.
        let level = per_pixel(p, frame, |x, y| match self.lookup.prepare(frame, x, y, &mut NoTrace) {
            Prepared::At(at) => {
                let (e, _) = self.estimate(&at);
                if e.found == 0 {
                    f32::NAN
                } else {
                    math::log2(e.penumbra / self.opts.kernel as f32).max(0.0)
                }
            }
            Prepared::Done(..) => f32::NAN,
        });
        v.push(Stage::pixels(
            frame,
            "filter_level",
            level,
            0.0,
            (self.levels(0) - 1) as f32,
        )?);
        for l in 1..4.min(self.levels(0)) {
            v.push(Stage::unit(format!("min_level{l}"), self.level(0, l, false).clone()));
        }
        Ok(v)
    }
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;
    use crate::hash::SplitMix;
    use crate::shadow::light::LightView;

    /// `inspect`'s lookup is the image at every pixel of every fixture
    /// ([`crate::shadow::sample::testing::assert_lookups_on_fixtures`]).
    #[test]
    fn the_image_is_the_traced_lookup_on_every_fixture() {
        crate::shadow::sample::testing::assert_lookups_on_fixtures(&ENTRY, declaration, Chs::new, |t, f, x, y| {
            t.lookup(f, x, y, &mut NoTrace).0
        });
    }

    #[test]
    fn four_pixel_lookups_equal_one_pixel_ones() {
        let sets: [&[(&str, &str)]; 3] = [
            &[("angle", "3")],
            &[("angle", "3"), ("receiver", "false"), ("kernel", "3")],
            &[("light", "0")],
        ];
        crate::shadow::sample::testing::assert_lookups(
            &sets,
            |pairs| Chs::new(declaration().parse(pairs).unwrap()).unwrap(),
            |t, f, x, y| t.lookup(f, x, y, &mut NoTrace),
            |_, _, _, _, _| {},
            |t| t.taps,
        );
    }

    #[test]
    fn the_four_lane_search_equals_the_texel_by_texel_one() {
        let mut rng = SplitMix(21);
        let data: Vec<f32> = (0..40 * 30).map(|_| rng.next_f32()).collect();
        let lvl = Surface::from_vec(40, 30, data).unwrap();
        let view = LightView {
            matrix: glam::Mat4::orthographic_rh(-3.0, 3.0, -3.0, 3.0, 0.5, 20.0),
            texel: 0.01,
            kind: crate::shadow::light::ViewKind::Ortho,
        };
        let (mut inside, mut blockers) = (0, 0);
        for _ in 0..3000 {
            let c = Vec2::new(rng.next_f32() * 44.0 - 2.0, rng.next_f32() * 34.0 - 2.0);
            let r = Reference {
                z: rng.next_f32(),
                gradient: Vec2::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5) * 0.05,
                cone: if rng.next_f32() < 0.3 { -0.002 } else { 0.0 },
            };
            let s = Search {
                lvl: &lvl,
                corner: ((c.x - 4.0).round() as i64, (c.y - 4.0).round() as i64),
                c,
                scale: [1.0, 2.0, 8.0][(rng.next_f32() * 3.0) as usize % 3],
                slack: rng.next_f32() * 0.01,
                r,
                distance: view.depth_to_distance(),
            };
            let one = s.clipped();
            if let Some(four) = s.inside() {
                inside += 1;
                blockers += one.1;
                assert_eq!((four.0.to_bits(), four.1), (one.0.to_bits(), one.1), "{c}");
            }
            assert_eq!(s.run().0.to_bits(), one.0.to_bits());
        }
        assert!(
            inside > 1000 && blockers > 10_000,
            "{inside} searches inside, {blockers} blockers"
        );
    }
}
