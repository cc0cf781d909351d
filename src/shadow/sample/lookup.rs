//! The per-pixel half of every depth-map technique: from a camera pixel to its place in the
//! light's maps, the reference depth with every bias applied, and the filters that compare
//! it. A technique holds one [`MapLookup`] (its [`Setup`] built from the technique's own
//! options), runs [`MapLookup::light_pass`], then per pixel [`MapLookup::prepare`] and one of
//! the filters:
//!
//! - [`MapLookup::compare`]: one comparison of the nearest texel, or hardware-style 2x2 PCF;
//! - [`MapLookup::filter`] / [`MapLookup::filter4`]: a wide PCF kernel of [`super::kernel`]
//!   (grid, tent, Poisson, rotated Poisson, spiral) with the receiver plane and the bias
//!   cone across it, classified first by the map's hierarchy ([`super::planes`]) when the
//!   setup asks for it.
//!
//! The bias terms (RTR 7.4): the polygon offset is the map pass's ([`MapOptions`]); the
//! normal offset (Holbert 2011) and the receiver-plane depth bias (Isidoro 2006) are
//! [`Bias`], applied in [`MapLookup::prepare`] ([`super::bias`]); the bias cone (Burley 2006)
//! is [`Wide::cone`]. Where the point falls in the maps is [`crate::shadow::light::locate`]'s
//! rule, so every technique has the same view choice and the same edge.

use super::bias::{normal_offset, receiver_plane, receiver_plane4};
use super::kernel::{
    axis_weights, filter_disk4, filter_grid4, separable4, Class, Kernel, MinMax, Pattern, Reference, Reference4,
};
use super::planes::PlaneChain;
use crate::frame::Frame;
use crate::pipeline::sampler::{bilerp_weights, sample_nearest, Address, CompareSampler, Pcf2x2};
use crate::pipeline::*;
use crate::shadow::inspect::{NoTrace, Step, Steps, Trace};
use crate::shadow::light::cascades::{self, Blend};
use crate::shadow::light::{self, Layer, LightMaps, LightView, MapOptions};
use crate::shadow::options::within;
use crate::shadow::options::Field;
use crate::shadow::stage::Stage;
use crate::Error;
use glam::{Vec2, Vec4};

/// The lookup's depth-bias terms applied per pixel (the polygon offset is the map pass's).
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct Bias {
    /// Normal-offset bias: texels along the normal, times sin(angle to the light)
    /// (Holbert 2011). Default: 0.
    pub normal: f32,
    /// Receiver-plane depth bias: one texel of the receiver's depth slope, and across wide
    /// kernels the receiver's plane (Isidoro 2006). Default: false.
    pub receiver: bool,
}

impl Bias {
    /// The declaration of the bias fields (`normal`, `receiver`), for options that hold a
    /// `Bias` ([`crate::shadow::options::within`]).
    pub fn fields() -> Vec<Field<Bias>> {
        vec![
            Field::range(
                "normal",
                "normal-offset bias: texels along the normal, times sin(angle to the light)",
                0.0,
                100.0,
                |b: &mut Bias| &mut b.normal,
            ),
            Field::new(
                "receiver",
                "receiver-plane depth bias (one texel of the receiver's depth slope; across wide kernels, the receiver's plane)",
                |b: &mut Bias| &mut b.receiver,
            ),
        ]
    }
}

/// What a lookup that filters with wide kernels prepares beyond the reference depth.
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct Wide {
    /// Bias cone slope (Burley 2006): the reference moved toward the light by `cone` times
    /// each tap's distance from the centre. Default: 0.
    pub cone: f32,
    /// Classify kernels as fully lit or shadowed from a hierarchy of the map (per block the
    /// least and greatest depth and the depths' bounds around a plane,
    /// [`super::planes::PlaneChain`]) and skip their taps (identical result). Default: false.
    pub hierarchy: bool,
}

/// The declaration of the bias cone's slope ([`Wide::cone`]) at `access`.
pub fn cone_field<O: Clone + Default + 'static>(access: fn(&mut O) -> &mut f32) -> Field<O> {
    Field::range(
        "cone",
        "wide filters: bias cone slope (Burley), depth toward the light per unit of tap distance",
        0.0,
        100.0,
        access,
    )
}

impl Wide {
    /// The declaration of the wide kernels' fields (`cone`, `hierarchy`), for options that
    /// hold a `Wide` ([`crate::shadow::options::within`]).
    pub fn fields() -> Vec<Field<Wide>> {
        vec![
            cone_field(|w: &mut Wide| &mut w.cone),
            Field::new(
                "hierarchy",
                "wide filters: skip the taps of kernels the map's hierarchy shows fully lit or shadowed (per block min/max depth and bounds around a plane: pays with the receiver plane and wide kernels; with a flat reference on sloped receivers it rarely decides, and for PCSS's 16-tap search, which costs no more than a classification, it saves less than it costs)",
                |w: &mut Wide| &mut w.hierarchy,
            ),
        ]
    }
}

/// The fields of a technique whose lookup is a [`MapLookup`] with wide kernels: the map
/// pass's, the bias's and the kernels', for options holding them at `map`, `bias`, `wide`.
pub fn lookup_fields<O: Clone + Default + 'static>(
    map: fn(&mut O) -> &mut MapOptions,
    bias: fn(&mut O) -> &mut Bias,
    wide: fn(&mut O) -> &mut Wide,
) -> Vec<Field<O>> {
    let mut fields = within(MapOptions::fields(), map);
    fields.extend(within(Bias::fields(), bias));
    fields.extend(within(Wide::fields(), wide));
    fields
}

/// What a technique's lookup needs: the map pass, the layer it stores, the bias, and, for
/// wide kernels, their bias cone and hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// The map pass.
    pub map: MapOptions,
    /// What the maps store.
    pub layer: Layer,
    /// The per-pixel bias.
    pub bias: Bias,
    /// Wide kernels: the receiver plane's gradient across them, their cone and hierarchy
    /// (`None`: one comparison or 2x2 PCF only).
    pub wide: Option<Wide>,
    /// Build each map's min/max mip chains ([`MapLookup::min_max`]), for techniques that read
    /// coarse levels of the map.
    pub min_max: bool,
}

/// The light's maps of the last pass and the lookups into them (see the module docs).
pub struct MapLookup {
    setup: Setup,
    maps: LightMaps,
    /// With `setup.min_max`: the maps' min/max chains.
    minmax: Vec<MinMax>,
    /// With a hierarchy for wide kernels: the maps' plane-residual chains.
    planes: Vec<PlaneChain>,
}

impl MapLookup {
    /// Lookups with `setup` (nothing drawn until [`MapLookup::light_pass`]).
    pub fn new(setup: Setup) -> MapLookup {
        MapLookup {
            setup,
            maps: LightMaps::default(),
            minmax: Vec::new(),
            planes: Vec::new(),
        }
    }

    /// The setup.
    #[inline(always)]
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// The map pass of `frame` ([`LightMaps::render`]), and the chains the setup asks for.
    pub fn light_pass(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error> {
        self.maps.render(p, frame, &self.setup.map, self.setup.layer)?;
        self.minmax.clear();
        self.planes.clear();
        if self.setup.min_max {
            self.minmax = self.maps.maps().iter().map(|(m, _)| MinMax::new(p, m)).collect();
        }
        if self.setup.wide.is_some_and(|w| w.hierarchy) {
            self.planes = self.maps.maps().iter().map(|(m, _)| PlaneChain::new(p, m)).collect();
        }
        Ok(())
    }

    /// The maps of the last pass.
    #[inline(always)]
    pub fn light_maps(&self) -> &LightMaps {
        &self.maps
    }

    /// The maps of the last pass, one per light view (six for cube maps), with their views.
    #[inline(always)]
    pub fn maps(&self) -> &[(Surface<f32>, LightView)] {
        self.maps.maps()
    }

    /// The light views of the last pass.
    pub fn views(&self) -> Vec<LightView> {
        self.maps.views()
    }

    /// Texels of the last pass's maps, all views.
    pub fn texels(&self) -> usize {
        self.maps.texels()
    }

    /// The last pass's buffers for `dump` ([`LightMaps::stages`]).
    pub fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        self.maps.stages(p, frame)
    }

    /// The explanation of a pixel of a technique whose pixels read these maps: nothing before
    /// a run (`None`); else `header` (what the run made) and the pixel's steps from `pixel`
    /// (the same per-pixel function as the image's, recording) into `t`, and the value
    /// `pixel` returns.
    pub fn explain(
        &self,
        t: &mut Steps,
        header: impl FnOnce() -> Step,
        pixel: impl FnOnce(&mut Steps) -> f32,
    ) -> Option<f32> {
        if self.maps().is_empty() {
            return None;
        }
        t.step(header);
        Some(pixel(t))
    }

    /// `inspect`'s opening step: what the light pass made.
    pub fn pass_step(&self) -> Step {
        let step = Step::new("maps", "the light pass of the last run")
            .int("views", self.maps.maps().len())
            .int("size", self.setup.map.size)
            .text(
                "format",
                crate::shadow::options::OptionValue::show(&self.setup.map.format),
            )
            .text("layer", self.setup.layer.as_str())
            .int("casters culled by fitting", self.maps.culled());
        let step = match self.maps.depth_samples() {
            Some((d, _)) => step
                .num("sdsm: least view depth seen", d.near)
                .num("sdsm: greatest view depth seen", d.far)
                .int("sdsm: depths of frame", d.frame)
                .int("sdsm: histogram bins", d.histogram.len()),
            None => step,
        };
        match self.maps.warp() {
            Some(w) => {
                let step = step
                    .text("warp", w.kind.as_str())
                    .num("angle between view and light (degrees)", w.gamma_deg)
                    .num("warp n (infinite: none)", w.n)
                    .num("body depth along the warp axis", w.depth);
                let step = match &w.psm {
                    Some(psm) => step
                        .num("psm: nearest view depth seen", psm.near)
                        .num("psm: farthest view depth seen", psm.far)
                        .num("psm: virtual camera moved back", psm.shift)
                        .flag("psm: light behind the viewer (inverted, depths reversed)", psm.inverted)
                        .flag("psm: light across the view (orthographic)", psm.parallel)
                        .int("psm: casters reaching behind the virtual eye (clipped)", psm.behind),
                    None => step,
                };
                let step = match &w.log {
                    Some(rows) => step
                        .num("logpsm: rows' nearest distance n", rows.n)
                        .num("logpsm: rows' farthest distance f", rows.f)
                        .text("logpsm: v of distance w", "1 - ln(w / n) / ln(f / n)"),
                    None => step,
                };
                let step = match w.log_limited {
                    Some(was) => step.num("logpsm: n raised for the rasterizer's precision, from", was),
                    None => step,
                };
                match &w.fallback {
                    Some(why) => step.text("fall-back", why.clone()),
                    None => step,
                }
            }
            None => step,
        }
    }

    /// One comparison at a prepared lookup: the nearest texel's, or with `pcf` the
    /// hardware-style 2x2 PCF of the four texels around it (bilinearly weighted), reported
    /// to `t`.
    #[inline(always)]
    pub fn compare(&self, at: &At, pcf: bool, t: &mut impl Trace) -> f32 {
        compare(&self.maps.maps()[at.face].0, at.uv, at.r.z, pcf, t)
    }

    /// Prepares pixels `x .. x + n` of row `y` for a four-lane lookup: the pixels decided
    /// without filtering are written to `out` and counted, the others to `ats`; the light
    /// view of the first of those, `None` if there is none. (Pixels on another view, at a
    /// cube map's edge, are the caller's to take out.)
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn prepare4(
        &self,
        frame: &Frame,
        (x, y): (usize, usize),
        n: usize,
        ats: &mut [Option<At>; 4],
        out: &mut [f32; 4],
        count: &mut u64,
    ) -> Option<usize> {
        let planes = self.planes4(frame, (x, y), n);
        for (l, a) in ats.iter_mut().enumerate().take(n) {
            match self.prepare_with(frame, x + l, y, &mut NoTrace, planes[l], None) {
                Prepared::Done(v, c) => (out[l], *count) = (v, *count + c),
                Prepared::At(at) => *a = Some(at),
            }
        }
        Some(ats.iter().flatten().next()?.face)
    }

    /// The receiver planes of pixels `x .. x + n` of row `y` on four lanes
    /// ([`receiver_plane4`]) when the lookups use them and one light view sees every pixel
    /// with geometry; `None` per lane otherwise (each lookup then solves its own).
    fn planes4(&self, frame: &Frame, (x, y): (usize, usize), n: usize) -> [Option<(Option<Vec2>, f32)>; 4] {
        let o = &self.setup;
        if !o.bias.receiver || o.layer == Layer::Id {
            return [None; 4];
        }
        let (w, pts) = (frame.width() as usize, frame.points());
        let mut face = None;
        for s in pts[y * w + x..y * w + x + n].iter().flatten() {
            let f = light::view_of(self.maps.maps(), &frame.light, s.position);
            if face.is_some_and(|g| g != f) {
                return [None; 4];
            }
            face = Some(f);
        }
        let Some(face) = face else { return [None; 4] };
        let (map, view) = &self.maps.maps()[face];
        receiver_plane4(frame, (x, y), n, view, map.width()).map(Some)
    }

    /// [`MapLookup::filter`] of the lanes with a kernel, all prepared on view `face`: the
    /// hierarchy's decisions and lanes outside the map one by one; disks, and grids and tents
    /// of one size whose lanes are all flat (separable) or all not (tap by tap), on four lanes
    /// (each lane with the one-pixel operations); anything else one by one. Values go to
    /// `out`, taps to `count`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn filter4(
        &self,
        face: usize,
        ats: &[Option<At>; 4],
        mut kernels: [Option<Kernel>; 4],
        x: usize,
        y: usize,
        out: &mut [f32; 4],
        count: &mut u64,
    ) {
        for l in 0..4 {
            let (Some(at), Some(kernel)) = (&ats[l], &kernels[l]) else {
                continue;
            };
            if let Some((v, c)) = self.decide(at, kernel) {
                (out[l], *count) = (v, *count + c);
                kernels[l] = None;
            }
        }
        let xs = std::array::from_fn(|l| (x + l) as u32);
        self.filter_lanes(face, ats, kernels, xs, y, out, count);
    }

    /// A wide kernel decided without its taps: by the hierarchy (lit or shadowed: one
    /// lookup), or outside the map (lit, no taps, as `Kernel::filter`).
    #[inline(always)]
    pub fn decide(&self, at: &At, kernel: &Kernel) -> Option<(f32, u64)> {
        match self.classify(at, kernel.extent(), &mut NoTrace) {
            Class::Lit => Some((1.0, 1)),
            Class::Shadowed => Some((0.0, 1)),
            Class::Mixed if !light::inside(at.uv) => Some((1.0, 0)),
            Class::Mixed => None,
        }
    }

    /// The taps of the lanes with a kernel, all prepared on view `face`, lane `l` the pixel in
    /// column `xs[l]` of row `y` (any columns: each lane's value depends on its pixel alone):
    /// disks, and grids and tents of one size whose lanes are all flat (separable) or all not
    /// (tap by tap), on four lanes (each lane with the one-pixel operations); anything else one
    /// by one. Values go to `out`, taps to `count`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn filter_lanes(
        &self,
        face: usize,
        ats: &[Option<At>; 4],
        kernels: [Option<Kernel>; 4],
        xs: [u32; 4],
        y: usize,
        out: &mut [f32; 4],
        count: &mut u64,
    ) {
        let map = &self.maps.maps()[face].0;
        let go: [bool; 4] = kernels.map(|k| k.is_some());
        let Some(first) = kernels.iter().flatten().next().copied() else {
            return;
        };
        let lane = |f: &dyn Fn(&At) -> f32| Vec4::from_array(std::array::from_fn(|l| ats[l].as_ref().map_or(0.0, f)));
        let (u, v) = (lane(&|a| a.uv.x), lane(&|a| a.uv.y));
        match first.pattern {
            Pattern::Grid | Pattern::Tent
                if (0..4).all(|l| {
                    kernels[l].is_none_or(|k| k.grid_n() == first.grid_n() && ats[l].is_some_and(|a| a.r.is_flat()))
                }) =>
            {
                let k = first.grid_n();
                // The per-axis weights on the stack for the common sizes.
                let (mut small, mut large) = ([0.0f32; 16], Vec::new());
                let t = if k < 16 {
                    &mut small[..k as usize]
                } else {
                    large.resize(k as usize, 0.0);
                    &mut large[..]
                };
                axis_weights(first.pattern, k, t);
                let values = separable4(map, u, v, lane(&|a| a.r.z), t);
                for l in 0..4 {
                    if go[l] {
                        (out[l], *count) = (values[l], *count + (k * k) as u64);
                    }
                }
            }
            Pattern::Grid | Pattern::Tent
                if (0..4).all(|l| {
                    kernels[l].is_none_or(|k| k.grid_n() == first.grid_n() && ats[l].is_some_and(|a| !a.r.is_flat()))
                }) =>
            {
                let refs = Reference4::new(std::array::from_fn(|l| ats[l].map_or(Reference::default(), |a| a.r)));
                let (values, taps) = filter_grid4(map, u, v, &refs, &first, go);
                for l in 0..4 {
                    if go[l] {
                        (out[l], *count) = (values[l], *count + taps[l] as u64);
                    }
                }
            }
            Pattern::Poisson | Pattern::Rotated | Pattern::Spiral => {
                let widths = Vec4::from_array(kernels.map(|k| k.map_or(1.0, |k| k.width)));
                let disk = first.disk4(xs, y as u32, widths).expect("a disk pattern");
                let refs = Reference4::new(std::array::from_fn(|l| ats[l].map_or(Reference::default(), |a| a.r)));
                let (values, taps) = filter_disk4(map, u, v, &refs, &disk, go);
                for l in 0..4 {
                    if go[l] {
                        (out[l], *count) = (values[l], *count + taps[l] as u64);
                    }
                }
            }
            _ => {
                for l in 0..4 {
                    if let (Some(k), Some(at)) = (kernels[l], &ats[l]) {
                        let f = k.filter(map, at.uv, &at.r, xs[l], y as u32, &mut NoTrace);
                        (out[l], *count) = (f.value, *count + f.taps as u64);
                    }
                }
            }
        }
    }

    /// The lookup up to its filter: the view that sees pixel `(x, y)`, its map position and
    /// the reference depth with every bias applied (normal offset, receiver plane, polygon
    /// offset in the map, quantization; for wide filters the receiver-plane gradient and the
    /// bias cone across the kernel). Pixels without geometry, behind the light or decided by
    /// the id map are [`Prepared::Done`]. The soft techniques of the family filter from here.
    #[inline(always)]
    pub fn prepare(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> Prepared {
        self.prepare_with(frame, x, y, t, None, None)
    }

    /// [`MapLookup::prepare`] in light view `face` whichever view the point picks (the next
    /// cascade of a blend band).
    #[inline(always)]
    pub fn prepare_on(&self, frame: &Frame, x: usize, y: usize, face: usize, t: &mut impl Trace) -> Prepared {
        self.prepare_with(frame, x, y, t, None, Some(face))
    }

    /// With cascades: the weight of the next cascade at a prepared lookup in the blend band
    /// at its cascade's end ([`cascades::next_weight`]; 0 outside it). A dithered blend
    /// decides per pixel: 0 or 1 by the pixel's 4x4 ordered-dither threshold.
    #[inline(always)]
    pub fn next_cascade(&self, at: &At, x: usize, y: usize, t: &mut impl Trace) -> f32 {
        let views = self.maps.maps();
        if views[at.face].1.slice().is_none() {
            return 0.0;
        }
        let Some(c) = self.setup.map.views.cascades() else {
            return 0.0;
        };
        let w = cascades::next_weight(views, at.face, at.pos, at.uv, c.band);
        let used = match c.blend {
            Blend::Dither if w > 0.0 => {
                if w > cascades::dither_threshold(x, y) {
                    1.0
                } else {
                    0.0
                }
            }
            _ => w,
        };
        if w > 0.0 {
            t.step(|| {
                Step::new(
                    "cascade blend",
                    "in the band at the cascade's end the next cascade is mixed in, against seams",
                )
                .num("band", c.band)
                .text("blend", c.blend.as_str())
                .num("position across the band", w)
                .num("weight of the next cascade", used)
            });
        }
        used
    }

    /// [`MapLookup::prepare`] with the pixel's receiver plane already solved (`plane`:
    /// [`receiver_plane`]'s value for the view that sees the pixel; `None`: solve it here).
    #[inline(always)]
    fn prepare_with(
        &self,
        frame: &Frame,
        x: usize,
        y: usize,
        t: &mut impl Trace,
        plane: Option<(Option<Vec2>, f32)>,
        on: Option<usize>,
    ) -> Prepared {
        let w = frame.width() as usize;
        let (pts, objs) = (frame.points(), frame.gbuffer.object.data());
        let Some(s) = pts[y * w + x] else {
            return Prepared::Done(f32::NAN, 0);
        };
        let o = &self.setup;
        let light = &frame.light;
        let face = on.unwrap_or_else(|| light::view_of(self.maps.maps(), light, s.position));
        let (map, view) = &self.maps.maps()[face];
        // Normal offset: move the lookup point along the normal (Holbert 2011).
        let pos = normal_offset(view, light, &s, o.bias.normal);
        t.step(|| {
            let step = Step::new(
                "light view",
                "the view that sees the point (one of six cube faces for point lights, a cascade by view depth or map bounds)",
            )
            .int("view", face)
            .int("views", self.maps.maps().len())
            .flag("perspective", view.perspective())
            .flag("warped", view.warped())
            .num("texel size at the point", view.texel_at(light, s.position));
            match view.slice() {
                Some(c) => step
                    .num("view depth", c.depth(s.position))
                    .num("cascade from", c.near)
                    .num("cascade to", c.far)
                    .text("selected by", if on.is_some() { "blend band" } else if c.by_bounds { "map bounds" } else { "depth" }),
                None => step,
            }
        });
        if o.bias.normal > 0.0 {
            t.step(|| {
                Step::new("normal offset", "lookup point moved along the normal (Holbert 2011)")
                    .num("texels", o.bias.normal)
                    .vec3("lookup point", pos)
                    .num("moved by", (pos - s.position).length())
            });
        }
        // The surface point chose the view; the (offset) lookup point is located in it.
        let Some(light::MapPoint { uv, depth: z, .. }) = light::locate_on(self.maps.maps(), face, pos) else {
            t.step(|| Step::new("behind the light", "the point is behind the view's eye: lit"));
            return Prepared::Done(1.0, 0);
        };
        let size = map.width();
        t.step(|| {
            Step::new(
                "light-space position",
                "texture coordinate (top-left origin) and depth in the view",
            )
            .vec2("uv", uv)
            .vec2("texel", uv * size as f32)
            .num("depth", z)
        });
        if o.layer == Layer::Id {
            let id = sample_nearest(self.maps.ids(face).expect("an id map per view"), uv, Address::Clamp);
            let inside = light::inside(uv);
            let own = objs[y * w + x];
            let lit = !inside || id == 0.0 || id as u32 == own + 1;
            t.step(|| {
                Step::new(
                    "id comparison",
                    "lit when the nearest surface stored is the pixel's own object",
                )
                .int("stored object id + 1", id as i64)
                .int("own object id + 1", own as i64 + 1)
                .flag("inside the map", inside)
                .flag("lit", lit)
            });
            return Prepared::Done(if lit { 1.0 } else { 0.0 }, 1);
        }
        let mut z = z;
        let mut gradient = Vec2::ZERO;
        if o.bias.receiver {
            let (g, b) = plane.unwrap_or_else(|| receiver_plane(frame, x, y, view, size));
            if o.wide.is_some() {
                gradient = g.unwrap_or(Vec2::ZERO);
            }
            z -= b;
            t.step(|| {
                Step::new(
                    "receiver-plane bias",
                    "one texel of the receiver's depth slope (Isidoro 2006)",
                )
                .num("bias", b)
            });
        }
        let z = o.map.format.quantize(z.clamp(0.0, 1.0));
        t.step(|| {
            Step::new(
                "reference depth",
                "the point's depth, clamped and quantized to the map's format; the polygon offset was added to the map",
            )
            .num("depth", z)
            .num("polygon offset units", o.map.units)
            .num("polygon offset slope", o.map.slope)
        });
        let cone = match o.wide {
            // Burley's bias cone: the depth change of one texel's world size toward the
            // light, times the slope.
            Some(Wide { cone, .. }) if cone > 0.0 => {
                let step = view.texel_at(light, pos);
                match view.lookup(pos + light.to_light(pos) * step) {
                    Some((_, zl)) => cone * (zl - z).min(0.0),
                    None => 0.0,
                }
            }
            _ => 0.0,
        };
        Prepared::At(At {
            face,
            uv,
            pos,
            r: Reference { z, gradient, cone },
        })
    }

    /// A wide kernel at a prepared lookup: one lookup in the hierarchy when it
    /// classifies the kernel (fully lit or shadowed), otherwise the kernel's taps.
    #[inline(always)]
    pub fn filter(&self, at: &At, kernel: &Kernel, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        let map = &self.maps.maps()[at.face].0;
        let r = &at.r;
        match self.classify(at, kernel.extent(), t) {
            Class::Lit => return (1.0, 1),
            Class::Shadowed => return (0.0, 1),
            Class::Mixed => {}
        }
        let f = kernel.filter(map, at.uv, r, x as u32, y as u32, t);
        (f.value, f.taps as u64)
    }

    /// The plane-residual chains of the last run's maps (with `hierarchy` and a wide filter).
    #[inline(always)]
    pub fn planes(&self, face: usize) -> Option<&PlaneChain> {
        self.planes.get(face)
    }

    /// The min/max chains of the last run's maps (with [`Setup::min_max`]).
    #[inline(always)]
    pub fn min_max(&self, face: usize) -> Option<&MinMax> {
        self.minmax.get(face)
    }

    /// What the hierarchy ([`PlaneChain`]) says of a kernel whose bilinear taps lie within
    /// `extent` texels of `at` (their 2x2 footprints one texel further), reported to `t`;
    /// `Mixed` without the hierarchy.
    pub fn classify(&self, at: &At, extent: f32, t: &mut impl Trace) -> Class {
        let Some(pc) = self.planes.get(at.face) else {
            return Class::Mixed;
        };
        let class = pc.classify(at.uv, extent, 1.0, &at.r);
        let (lo, hi) = at.r.range(extent);
        t.step(|| class_step(lo, hi, class));
        class
    }
}

/// A lookup prepared up to its filter ([`MapLookup::prepare`]).
pub enum Prepared {
    /// Decided without filtering: the value and the taps it took.
    Done(f32, u64),
    /// Where to filter.
    At(At),
}

/// The map position of one pixel's lookup.
#[derive(Copy, Clone)]
pub struct At {
    /// The light view (cube face) that sees the point.
    pub face: usize,
    /// Texture coordinate in that view's map.
    pub uv: Vec2,
    /// The lookup point (after the normal offset).
    pub pos: glam::Vec3,
    /// The reference depth and its change across a kernel.
    pub r: Reference,
}

/// `inspect`'s account of the hierarchy's classification.
pub fn class_step(lo: f32, hi: f32, class: Class) -> Step {
    Step::new(
        "hierarchy",
        "the kernel's footprint in the map's blocks (least and greatest depth, and depths around a plane): fully lit or shadowed skips the taps",
    )
    .num("lowest reference", lo)
    .num("highest reference", hi)
    .text(
        "class",
        match class {
            Class::Lit => "lit",
            Class::Shadowed => "shadowed",
            Class::Mixed => "mixed",
        },
    )
}

/// One pixel's blocker search and penumbra estimate.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Estimate {
    /// Search disk width in texels.
    pub search: f32,
    /// Taps that found a blocker, of `taps`.
    pub found: u32,
    /// Search taps read (1 when the hierarchy classified the disk).
    pub taps: u32,
    /// The receiver's distance from the light along the view axis.
    pub receiver: f32,
    /// The blockers' average distance (NaN without blockers).
    pub blocker: f32,
    /// Penumbra width in texels (0 without blockers; the search width in umbra).
    pub penumbra: f32,
    /// What decided the search: mixed (filter), lit (no blocker) or shadowed (all blockers).
    pub class: Class,
}

/// One comparison of reference depth `z` at `uv` of `map`: the nearest texel's, or with `pcf`
/// the hardware 2x2 PCF of the four texels around it, weighted bilinearly (lit outside the
/// map, the samplers' border); the texels it compared, with their stored depths and
/// outcomes, reported to `t` from the parts the value was computed from
/// ([`CompareSampler::pcf2x2_parts`], the code of the image's [`CompareSampler::pcf2x2`]).
#[inline(always)]
fn compare(map: &Surface<f32>, uv: Vec2, z: f32, pcf: bool, t: &mut impl Trace) -> f32 {
    let sampler = CompareSampler::default();
    if !t.records() {
        // The image: the sampler's own calls, `pcf2x2` being `pcf2x2_parts`'s value.
        return if pcf {
            sampler.pcf2x2(map, uv, z)
        } else {
            sampler.nearest(map, uv, z)
        };
    }
    if !light::inside(uv) {
        t.step(|| Step::new("comparison", "outside the map: lit (the samplers' border)").vec2("uv", uv));
        return sampler.nearest(map, uv, z);
    }
    let parts = if pcf {
        sampler.pcf2x2_parts(map, uv, z)
    } else {
        let texel = light::texel(uv, map.width(), map.height());
        let lit = sampler.nearest(map, uv, z);
        Pcf2x2 {
            texels: [texel; 4],
            lit: [lit; 4],
            fraction: Vec2::ZERO,
            value: lit,
        }
    };
    t.step(|| {
        let mut step = Step::new(
            "comparison",
            match pcf {
                true => "four texels compared, then weighted bilinearly by the fraction (hardware PCF)",
                _ => "the nearest texel's stored depth against the reference depth (lit if less-equal)",
            },
        );
        let n = if pcf {
            step = step.vec2("fraction", parts.fraction);
            4
        } else {
            1
        };
        let weights = if pcf { bilerp_weights(parts.fraction) } else { [1.0; 4] };
        let texels = parts.texels.iter().zip(parts.lit).zip(weights).take(n);
        for (i, ((&(tx, ty), lit), weight)) in texels.enumerate() {
            step = step
                .vec2(&format!("texel {i}"), Vec2::new(tx as f32, ty as f32))
                .num(&format!("stored depth {i}"), map.at(tx, ty))
                .flag(&format!("lit {i}"), lit == 1.0)
                .num(&format!("weight {i}"), weight);
        }
        step
    });
    parts.value
}
