//! Shadow maps (Williams 1978; RTR 7.4; Cournia 3.1): depth from the light through the
//! pipeline, then a depth comparison per camera pixel. Directional lights get an orthographic
//! map, spot lights a perspective map of their cone, point and area lights (their centre) a
//! cube map of six 90-degree faces, looked up per pixel by the face its direction selects.
//!
//! Options combine: depth format (16/24/32 bit); constant and slope-scaled bias (the
//! pipeline's polygon offset); normal-offset bias (Holbert 2011: the lookup point moves along
//! the normal by `k * texel size * sin(angle to the light)`); receiver-plane depth bias
//! (Isidoro 2006: the receiver's depth slope in shadow-map texels, from its screen-space
//! derivatives); which layer is stored (`first`; `second`, back faces only, Wang and Molnar
//! 1994; `midpoint`, the average of the two nearest layers, Woo 1992, by depth peeling; `id`,
//! object ids instead of depth, Cournia 3.1.2); fitting of a directional light's frustum to
//! the casters that can shadow visible receivers, with other casters culled (RTR fig. 7.11);
//! and texel snapping so camera motion does not move the sampling grid; and the lookup's
//! filter: one comparison, 2x2 hardware PCF, or a wide PCF kernel of [`super::kernel`] (grid,
//! tent, Poisson, rotated Poisson, spiral; width in texels or world units; receiver-plane
//! depth and bias cone across the kernel; a hierarchy of the map, [`super::planes`], to skip
//! the taps of kernels fully lit or shadowed), or the depths filtered before one comparison,
//! the wrong order.
//!
//! Known failures: acne without bias, Peter Panning with too much, aliasing where the map is
//! magnified, shimmering of fitted maps without snapping, light leaks of second-depth maps on
//! open (two-sided) geometry, self-shadowing lost by id maps, acne of wide kernels without bias
//! across the kernel, uniform penumbrae of fixed-width PCF.

use super::bias::{normal_offset, receiver_plane, receiver_plane4};
use super::kernel::{
    axis_weights, filter_disk4, filter_grid4, separable4, Class, Kernel, MinMax, Pattern, Reference, Reference4,
    MAX_TAPS,
};
use super::planes::PlaneChain;
use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::sampler::{footprint, sample_nearest, Address, CompareSampler};
use crate::pipeline::*;
use crate::shadow::inspect::{self, NoTrace, Step, Steps, Trace};
use crate::shadow::light::{self, fitted_overview, merged_casters, DepthPass, LightView};
use crate::shadow::pixels::{per_pixel4_counted, per_row_counted};
use crate::shadow::{Declaration, Family, Field, ShadowTechnique, Stage, TechniqueInfo, Visibility};
use glam::{Vec2, Vec4};

choice_enum! {
    /// What the map stores.
    pub enum Layer {
        /// The nearest surface (Williams).
        First = "first",
        /// Back faces only (Wang and Molnar 1994).
        Second = "second",
        /// The average of the two nearest layers, by depth peeling (Woo 1992).
        Midpoint = "midpoint",
        /// Object ids of the nearest surface instead of depth (Cournia 3.1.2).
        Id = "id",
    }
}

choice_enum! {
    /// Which frustum a directional light's map covers.
    pub enum FitTo {
        /// The whole scene's bounds.
        Scene = "scene",
        /// The receivers the camera sees, with casters that cannot shadow them culled.
        Receivers = "receivers",
    }
}

choice_enum! {
    /// How the map is sampled.
    pub enum Filter {
        /// One comparison of the nearest texel.
        None = "none",
        /// Hardware-style 2x2 PCF: four comparisons, bilinearly weighted.
        Pcf2 = "pcf2",
        /// Bilinear filtering of the depths, then one comparison (the wrong order).
        DepthBilinear = "depth-bilinear",
        /// `n x n` 2x2 comparisons at whole-texel offsets, box weights (`kernel` = n).
        Grid = "grid",
        /// `n x n` 2x2 comparisons at whole-texel offsets, tent weights.
        Tent = "tent",
        /// A fixed Poisson disk of `taps` 2x2 comparisons, `kernel` texels wide.
        Poisson = "poisson",
        /// The Poisson disk rotated per pixel by a hashed angle.
        Rotated = "rotated",
        /// A Vogel spiral rotated by interleaved gradient noise (Jimenez 2014).
        Spiral = "spiral",
    }
}

impl Filter {
    /// The PCF kernel pattern of the wide filters.
    pub fn pattern(self) -> Option<Pattern> {
        match self {
            Filter::None | Filter::Pcf2 => None,
            Filter::DepthBilinear => Some(Pattern::DepthBilinear),
            Filter::Grid => Some(Pattern::Grid),
            Filter::Tent => Some(Pattern::Tent),
            Filter::Poisson => Some(Pattern::Poisson),
            Filter::Rotated => Some(Pattern::Rotated),
            Filter::Spiral => Some(Pattern::Spiral),
        }
    }
}

/// Options of the shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Map side in texels (a cube map has six faces of this size). Default: 2048.
    pub size: u32,
    /// Depth storage. Default: f32.
    pub format: DepthFormat,
    /// Constant polygon offset, in units of the format's resolvable depth step. Default: 4.
    pub units: f32,
    /// Slope-scaled polygon offset factor. Default: 1.1.
    pub slope: f32,
    /// Normal-offset bias: texels along the normal, times sin(angle to the light). Default: 0.
    pub normal: f32,
    /// Receiver-plane depth bias (one texel of the receiver's depth slope). Default: false.
    pub receiver: bool,
    /// What the map stores. Default: first.
    pub layer: Layer,
    /// Directional lights: fit the map to the scene or to the visible receivers. Default: scene.
    pub fit: FitTo,
    /// Snap the fitted frustum to whole texels (against shimmering). Default: false.
    pub snap: bool,
    /// Lookup filter. Default: none.
    pub filter: Filter,
    /// Wide filters: kernel width in texels (grid and tent: taps per axis, made odd). Default: 5.
    pub kernel: f32,
    /// Wide filters: kernel width in world units at the receiver instead (0: use `kernel`).
    /// Default: 0.
    pub world: f32,
    /// Poisson, rotated and spiral filters: taps (1 to 256). Default: 16.
    pub taps: u32,
    /// Wide filters: bias cone slope (Burley 2006), the reference moved toward the light by
    /// `cone` times each tap's distance from the centre. Default: 0.
    pub cone: f32,
    /// Wide filters: classify kernels as fully lit or shadowed from a hierarchy of the map
    /// (per block the least and greatest depth and the depths' bounds around a plane,
    /// [`super::planes::PlaneChain`]) and skip their taps (identical result). Default: false.
    pub hierarchy: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            size: 2048,
            format: DepthFormat::F32,
            units: 4.0,
            slope: 1.1,
            normal: 0.0,
            receiver: false,
            layer: Layer::First,
            fit: FitTo::Scene,
            snap: false,
            filter: Filter::None,
            kernel: 5.0,
            world: 0.0,
            taps: 16,
            cone: 0.0,
            hierarchy: false,
        }
    }
}

/// The declaration of the map options the shadow-map family shares (size, format, bias,
/// fitting, bias cone, hierarchy), for an options struct whose [`Options`] is reached by
/// `|o| path`: `shadow_map_fields!(Options, |o| o)` here, `|o| o.map` in techniques that hold
/// one.
#[macro_export]
macro_rules! shadow_map_fields {
    ($o:ty, |$x:ident| $($path:tt)+) => {{
        use $crate::shadow::Field;
        vec![
            Field::range(
                "size",
                "map side in texels (a cube map has six faces of this size)",
                16,
                $crate::pipeline::MAX_DIMENSION,
                |$x: &mut $o| &mut $($path)+.size,
            ),
            Field::new("format", "depth storage: f32, u24 or u16", |$x: &mut $o| &mut $($path)+.format),
            Field::range(
                "units",
                "constant polygon offset, in units of the format's resolvable depth step",
                -1e6,
                1e6,
                |$x: &mut $o| &mut $($path)+.units,
            ),
            Field::range(
                "slope",
                "slope-scaled polygon offset factor",
                -1e3,
                1e3,
                |$x: &mut $o| &mut $($path)+.slope,
            ),
            Field::range(
                "normal",
                "normal-offset bias: texels along the normal, times sin(angle to the light)",
                0.0,
                100.0,
                |$x: &mut $o| &mut $($path)+.normal,
            ),
            Field::new(
                "receiver",
                "receiver-plane depth bias (one texel of the receiver's depth slope; across wide kernels, the receiver's plane)",
                |$x: &mut $o| &mut $($path)+.receiver,
            ),
            Field::new(
                "fit",
                "directional lights: scene bounds, or receivers (casters that shadow visible receivers)",
                |$x: &mut $o| &mut $($path)+.fit,
            ),
            Field::new(
                "snap",
                "snap the fitted frustum to whole texels (against shimmering)",
                |$x: &mut $o| &mut $($path)+.snap,
            ),
            Field::range(
                "cone",
                "wide filters: bias cone slope (Burley), depth toward the light per unit of tap distance",
                0.0,
                100.0,
                |$x: &mut $o| &mut $($path)+.cone,
            ),
            Field::new(
                "hierarchy",
                "wide filters: skip the taps of kernels the map's hierarchy shows fully lit or shadowed (per block min/max depth and bounds around a plane: pays with the receiver plane and wide kernels; with a flat reference on sloped receivers it rarely decides, and for PCSS's 16-tap search, which costs no more than a classification, it saves less than it costs)",
                |$x: &mut $o| &mut $($path)+.hierarchy,
            ),
        ]
    }};
}

/// The option declaration (`--set`, `penumbra list`, the constructor's check).
pub fn declaration() -> Declaration<Options> {
    let mut fields = crate::shadow_map_fields!(Options, |o| o);
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
    Declaration {
        technique: "shadow-map",
        fields,
    }
}

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "shadow-map",
        family: Family::Map,
        summary:
            "depth map from the light, one comparison per pixel (RTR 7.4): acne, Peter Panning, aliasing, shimmering",
        options: declaration().infos(),
        sweep: &[
            &[("size", "256")],
            &[("size", "512")],
            &[("size", "2048")],
            &[("units", "0"), ("slope", "0")],
            &[("units", "100000")],
            &[("units", "0"), ("slope", "0"), ("normal", "1.5")],
            &[("units", "0"), ("slope", "0"), ("receiver", "true")],
            &[("layer", "second"), ("units", "0"), ("slope", "0")],
            &[("layer", "midpoint"), ("units", "0"), ("slope", "0")],
            &[("layer", "id")],
            &[("fit", "receivers"), ("snap", "true")],
            &[("filter", "pcf2")],
            &[("filter", "depth-bilinear")],
            &[("filter", "grid")],
            &[("filter", "tent")],
            &[("filter", "poisson")],
            &[("filter", "rotated")],
            &[("filter", "spiral")],
        ],
        extended: &[
            &[("size", "1024")],
            &[("size", "4096")],
            &[("format", "u16")],
            &[("filter", "grid"), ("kernel", "9"), ("cone", "2")],
            &[("format", "u24")],
            &[("fit", "receivers")],
            &[("filter", "grid"), ("hierarchy", "true")],
            &[("filter", "grid"), ("kernel", "9")],
            &[
                ("filter", "grid"),
                ("kernel", "9"),
                ("receiver", "true"),
                ("units", "0"),
                ("slope", "0"),
            ],
            &[("filter", "poisson"), ("taps", "64")],
            &[("filter", "poisson"), ("world", "0.1")],
        ],
        create: |pairs| Ok(Box::new(ShadowMap::new(declaration().parse(pairs)?)?)),
    }
}

/// The shadow-map technique (see the module docs).
pub struct ShadowMap {
    opts: Options,
    /// Last run: one map per light view.
    maps: Vec<(Surface<f32>, LightView)>,
    /// Last run (id maps): object id + 1 per texel, per view.
    ids: Vec<Surface<f32>>,
    culled: usize,
    /// The fitted view of the last run (directional lights fitted to receivers), for `stages`.
    fitted: Option<LightView>,
    /// Whether the light pass builds the maps' min/max chains ([`ShadowMap::with_min_max`]).
    chains: bool,
    /// Last run with `chains`: the maps' min/max chains.
    minmax: Vec<MinMax>,
    /// Last run with `hierarchy` and a wide filter: the maps' plane-residual chains.
    planes: Vec<PlaneChain>,
    /// Last run: bilinear taps of all lookups, and lookups the hierarchy classified.
    taps: u64,
    times: Vec<(&'static str, f64)>,
}

impl ShadowMap {
    /// A shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<ShadowMap, String> {
        declaration().check(&opts)?;
        if opts.filter.pattern().is_some() && opts.kernel > opts.size as f32 {
            return Err(format!(
                "technique 'shadow-map': option kernel={} is wider than the map (size={})",
                opts.kernel, opts.size
            ));
        }
        Ok(ShadowMap {
            opts,
            maps: Vec::new(),
            ids: Vec::new(),
            culled: 0,
            fitted: None,
            chains: false,
            minmax: Vec::new(),
            planes: Vec::new(),
            taps: 0,
            times: Vec::new(),
        })
    }

    /// Casters culled by fitting in the last run.
    pub fn culled(&self) -> usize {
        self.culled
    }

    /// Texels of the last run's maps, all views.
    pub fn texels(&self) -> usize {
        self.maps.iter().map(|(m, _)| m.data().len()).sum()
    }

    /// The maps of the last run, one per light view (six for point lights).
    pub fn maps(&self) -> &[(Surface<f32>, LightView)] {
        &self.maps
    }

    /// Pass 1: the light's map(s) of `frame`.
    pub(crate) fn light_pass(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), String> {
        let o = &self.opts;
        let fit = light::fit(frame, o.size, o.fit == FitTo::Receivers, o.snap);
        self.culled = fit.culled;
        self.fitted = fit.fitted;
        let mut old: Vec<Surface<f32>> = self.maps.drain(..).map(|(m, _)| m).collect();
        self.ids.clear();
        // Every map this pass allocates (views × layers), checked against the memory budget
        // before the first is: the maps of the last run are reused, so they do not count.
        let layers: u64 = match o.layer {
            Layer::First | Layer::Second => 1,
            Layer::Midpoint => 3,
            Layer::Id => 2,
        };
        let reused = old.iter().filter(|m| m.width() == o.size).count() as u64;
        let new_maps = (fit.views.len() as u64 * layers).saturating_sub(reused);
        if new_maps > 0 {
            crate::pipeline::check_room(o.size, o.size, 4, new_maps).map_err(|e| {
                format!(
                    "technique 'shadow-map' ({} views, option size={}): {e}",
                    fit.views.len(),
                    o.size
                )
            })?;
        }
        let casters = merged_casters(frame, &fit.casters)?;
        let pass = DepthPass {
            size: o.size,
            format: o.format,
            offset: PolygonOffset {
                units: o.units,
                factor: o.slope,
            },
        };
        for view in fit.views {
            let reuse = old.pop();
            let map = match o.layer {
                Layer::First => pass.render(p, &casters, &view, CullMode::None, None, reuse)?,
                Layer::Second => pass.render(p, &casters, &view, CullMode::Front, None, reuse)?,
                Layer::Midpoint => {
                    let d1 = pass.render(p, &casters, &view, CullMode::None, None, reuse)?;
                    let d2 = pass.render(p, &casters, &view, CullMode::None, Some(&d1), None)?;
                    let mid: Vec<f32> = d1.data().iter().zip(d2.data()).map(|(a, b)| 0.5 * (a + b)).collect();
                    Surface::from_vec(o.size, o.size, mid).map_err(|e| e.to_string())?
                }
                Layer::Id => {
                    // Object ids (+1; 0 = empty) of the nearest surface; its depth is the map
                    // `dump` shows.
                    let mut ids = Surface::new(o.size, o.size, 0.0f32).map_err(|e| e.to_string())?;
                    let mut depth = Surface::new(o.size, o.size, 1.0f32).map_err(|e| e.to_string())?;
                    for (oi, ob) in frame.scene.objects.iter().enumerate().filter(|(i, _)| fit.casters[*i]) {
                        let id = oi as f32 + 1.0;
                        let fs = Shader(move |_: &Fragment<()>| Vec4::splat(id));
                        p.draw(
                            &mut Targets::color(&mut ids).with_depth(&mut depth),
                            &RenderState::default(),
                            &ob.mesh.positions,
                            &ob.mesh.indices,
                            &TransformPositions(view.matrix),
                            &fs,
                        )
                        .map_err(|e| e.to_string())?;
                    }
                    self.ids.push(ids);
                    depth
                }
            };
            self.maps.push((map, view));
        }
        self.minmax.clear();
        self.planes.clear();
        if self.chains {
            self.minmax = self.maps.iter().map(|(m, _)| MinMax::new(p, m)).collect();
        }
        if o.hierarchy && o.filter.pattern().is_some() {
            self.planes = self.maps.iter().map(|(m, _)| PlaneChain::new(p, m)).collect();
        }
        Ok(())
    }

    /// Pass 2 at one pixel: the lookup and its bilinear taps, every step reported to `t`.
    #[inline(always)]
    fn lookup(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        match self.prepare(frame, x, y, t) {
            Prepared::Done(v, n) => (v, n),
            Prepared::At(at) => self.lookup_at(frame, &at, x, y, t),
        }
    }

    /// The kernel of a wide filter at a prepared lookup (its width from world units at the
    /// point if asked).
    #[inline(always)]
    fn kernel_at(&self, frame: &Frame, at: &At, pattern: Pattern) -> Kernel {
        let o = &self.opts;
        let (map, view) = &self.maps[at.face];
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

    /// [`ShadowMap::lookup`] of pixels `x .. x + n` of row `y` (`n` at most 4): each pixel is
    /// prepared alone, then the wide filters (disks, and flat grids and tents of one size) of
    /// the pixels that look up the same view run on four lanes, with the one-pixel operations
    /// per lane, so every value and count is the one-pixel lookup's.
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
        let Some(face) = self.prepare4(frame, (x, y), n, &mut ats, &mut out, &mut count) else {
            return (out, count);
        };
        // Pixels on another view (a cube map's edge): one at a time.
        for (l, a) in ats.iter_mut().enumerate() {
            if let Some(at) = a.filter(|at| at.face != face) {
                let (v, c) = self.lookup_at(frame, &at, x + l, y, &mut NoTrace);
                (out[l], count) = (v, count + c);
                *a = None;
            }
        }
        let mut kernels = [None; 4];
        for (k, a) in kernels.iter_mut().zip(&ats) {
            *k = a.map(|at| self.kernel_at(frame, &at, pattern));
        }
        self.filter4(face, &ats, kernels, x, y, &mut out, &mut count);
        (out, count)
    }

    /// [`ShadowMap::lookup`] of every pixel of row `y` into `row`, for wide filters with the
    /// hierarchy: each pixel is prepared and classified, and the pixels the hierarchy leaves
    /// mixed are queued per light view and filtered four at a time, so that every group of
    /// lanes is full (a pixel the hierarchy decides frees its lane for the next mixed one)
    /// and each lane runs the one-pixel operations. Returns the row's count.
    fn lookup_row(&self, frame: &Frame, y: usize, pattern: Pattern, row: &mut [f32]) -> u64 {
        let mut count = 0u64;
        let mut queues = vec![Queued::default(); self.maps.len()];
        let flush = |face: usize, q: &mut Queued, row: &mut [f32], count: &mut u64| {
            let mut out = [f32::NAN; 4];
            self.filter_lanes(face, &q.ats, q.kernels, q.xs, y, &mut out, count);
            for l in 0..q.n {
                row[q.xs[l] as usize] = out[l];
            }
            *q = Queued::default();
        };
        for x in (0..row.len()).step_by(4) {
            let n = (row.len() - x).min(4);
            let (mut ats, mut out) = ([None; 4], [f32::NAN; 4]);
            self.prepare4(frame, (x, y), n, &mut ats, &mut out, &mut count);
            for l in 0..n {
                let Some(at) = ats[l] else {
                    row[x + l] = out[l];
                    continue;
                };
                let kernel = self.kernel_at(frame, &at, pattern);
                if let Some((v, c)) = self.decide(&at, &kernel) {
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

    /// Prepares pixels `x .. x + n` of row `y` for a four-lane lookup: the pixels decided
    /// without filtering are written to `out` and counted, the others to `ats`; the light
    /// view of the first of those, `None` if there is none. (Pixels on another view, at a
    /// cube map's edge, are the caller's to take out.)
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn prepare4(
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
            match self.prepare_with(frame, x + l, y, &mut NoTrace, planes[l]) {
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
        let o = &self.opts;
        if !o.receiver || o.layer == Layer::Id {
            return [None; 4];
        }
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let (pts, objs) = (frame.points(), frame.gbuffer.object.data());
        let mut face = None;
        for s in pts[y * w + x..y * w + x + n].iter().flatten() {
            let f = light::face_of(self.maps.len(), &frame.light, s.position);
            if face.is_some_and(|g| g != f) {
                return [None; 4];
            }
            face = Some(f);
        }
        let Some(face) = face else { return [None; 4] };
        let (map, view) = &self.maps[face];
        receiver_plane4(pts, objs, w, h, (x, y), n, &view.matrix, map.width()).map(Some)
    }

    /// [`ShadowMap::filter`] of the lanes with a kernel, all prepared on view `face`: the
    /// hierarchy's decisions and lanes outside the map one by one; disks, and grids and tents
    /// of one size whose lanes are all flat (separable) or all not (tap by tap), on four lanes
    /// (each lane with the one-pixel operations); anything else one by one. Values go to
    /// `out`, taps to `count`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn filter4(
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
    fn decide(&self, at: &At, kernel: &Kernel) -> Option<(f32, u64)> {
        match self.classify(at, kernel.extent(), &mut NoTrace) {
            Class::Lit => Some((1.0, 1)),
            Class::Shadowed => Some((0.0, 1)),
            Class::Mixed if !(at.uv.cmpge(Vec2::ZERO).all() && at.uv.cmple(Vec2::ONE).all()) => Some((1.0, 0)),
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
    fn filter_lanes(
        &self,
        face: usize,
        ats: &[Option<At>; 4],
        kernels: [Option<Kernel>; 4],
        xs: [u32; 4],
        y: usize,
        out: &mut [f32; 4],
        count: &mut u64,
    ) {
        let map = &self.maps[face].0;
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
                        let f = k.filter(map, at.uv, &at.r, xs[l], y as u32);
                        (out[l], *count) = (f.value, *count + f.taps as u64);
                    }
                }
            }
        }
    }

    /// [`ShadowMap::lookup`] from its prepared position on.
    #[inline(always)]
    fn lookup_at(&self, frame: &Frame, at: &At, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        let at = *at;
        let o = &self.opts;
        let map = &self.maps[at.face].0;
        let Some(pattern) = o.filter.pattern() else {
            let sampler = CompareSampler::default();
            let v = match o.filter {
                Filter::Pcf2 => sampler.pcf2x2(map, at.uv, at.r.z),
                _ => sampler.nearest(map, at.uv, at.r.z),
            };
            t.step(|| texel_steps(map, at.uv, at.r.z, o.filter));
            return (v, 1);
        };
        // Wide kernels (RTR 7.5): the width in texels (from world units at the point if asked),
        // then the hierarchy or the taps.
        let kernel = self.kernel_at(frame, &at, pattern);
        self.filter(&at, &kernel, x, y, t)
    }

    /// The lookup up to its filter: the view that sees pixel `(x, y)`, its map position and
    /// the reference depth with every bias applied (normal offset, receiver plane, polygon
    /// offset in the map, quantization; for wide filters the receiver-plane gradient and the
    /// bias cone across the kernel). Pixels without geometry, behind the light or decided by
    /// the id map are [`Prepared::Done`]. The soft techniques of the family filter from here.
    #[inline(always)]
    pub(crate) fn prepare(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> Prepared {
        self.prepare_with(frame, x, y, t, None)
    }

    /// [`ShadowMap::prepare`] with the pixel's receiver plane already solved (`plane`:
    /// [`receiver_plane`]'s value for the view that sees the pixel; `None`: solve it here).
    #[inline(always)]
    fn prepare_with(
        &self,
        frame: &Frame,
        x: usize,
        y: usize,
        t: &mut impl Trace,
        plane: Option<(Option<Vec2>, f32)>,
    ) -> Prepared {
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let (pts, objs) = (frame.points(), frame.gbuffer.object.data());
        let Some(s) = pts[y * w + x] else {
            return Prepared::Done(f32::NAN, 0);
        };
        let o = &self.opts;
        let light = &frame.light;
        let face = light::face_of(self.maps.len(), light, s.position);
        let (map, view) = &self.maps[face];
        // Normal offset: move the lookup point along the normal (Holbert 2011).
        let pos = normal_offset(view, light, &s, o.normal);
        t.step(|| {
            Step::new(
                "light view",
                "the view that sees the point (one of six cube faces for point lights)",
            )
            .int("view", face)
            .int("views", self.maps.len())
            .flag("perspective", view.perspective)
            .num("texel size at the point", view.texel_at(light, s.position))
        });
        if o.normal > 0.0 {
            t.step(|| {
                Step::new("normal offset", "lookup point moved along the normal (Holbert 2011)")
                    .num("texels", o.normal)
                    .vec3("lookup point", pos)
                    .num("moved by", (pos - s.position).length())
            });
        }
        let Some((uv, z)) = view.lookup(pos) else {
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
            let id = sample_nearest(&self.ids[face], uv, Address::Clamp);
            let inside = uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all();
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
        if o.receiver {
            let (g, b) = plane.unwrap_or_else(|| receiver_plane(pts, objs, w, h, x, y, &view.matrix, size));
            if o.filter.pattern().is_some() {
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
        let z = o.format.quantize(z.clamp(0.0, 1.0));
        t.step(|| {
            Step::new(
                "reference depth",
                "the point's depth, clamped and quantized to the map's format; the polygon offset was added to the map",
            )
            .num("depth", z)
            .num("polygon offset units", o.units)
            .num("polygon offset slope", o.slope)
        });
        let cone = if o.cone > 0.0 && o.filter.pattern().is_some() {
            // Depth change of one texel's world size toward the light, times the slope.
            let step = view.texel_at(light, pos);
            match view.lookup(pos + light.to_light(pos) * step) {
                Some((_, zl)) => o.cone * (zl - z).min(0.0),
                None => 0.0,
            }
        } else {
            0.0
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
    pub(crate) fn filter(&self, at: &At, kernel: &Kernel, x: usize, y: usize, t: &mut impl Trace) -> (f32, u64) {
        let map = &self.maps[at.face].0;
        let r = &at.r;
        match self.classify(at, kernel.extent(), t) {
            Class::Lit => return (1.0, 1),
            Class::Shadowed => return (0.0, 1),
            Class::Mixed => {}
        }
        let f = kernel.filter(map, at.uv, r, x as u32, y as u32);
        t.step(|| kernel.explain(map, at.uv, r, x as u32, y as u32));
        (f.value, f.taps as u64)
    }

    /// The plane-residual chains of the last run's maps (with `hierarchy` and a wide filter).
    pub(crate) fn planes(&self, face: usize) -> Option<&PlaneChain> {
        self.planes.get(face)
    }

    /// The light pass also builds each map's min/max mip chains ([`ShadowMap::min_max`]), for
    /// techniques that read coarse levels of the map.
    pub(crate) fn with_min_max(mut self) -> ShadowMap {
        self.chains = true;
        self
    }

    /// The min/max chains of the last run's maps ([`ShadowMap::with_min_max`]).
    pub(crate) fn min_max(&self, face: usize) -> Option<&MinMax> {
        self.minmax.get(face)
    }

    /// What the hierarchy ([`PlaneChain`]) says of a kernel whose bilinear taps lie within
    /// `extent` texels of `at` (their 2x2 footprints one texel further), reported to `t`;
    /// `Mixed` without the hierarchy.
    pub(crate) fn classify(&self, at: &At, extent: f32, t: &mut impl Trace) -> Class {
        let Some(pc) = self.planes.get(at.face) else {
            return Class::Mixed;
        };
        let class = pc.classify(at.uv, extent, 1.0, &at.r);
        let (lo, hi) = at.r.range(extent);
        t.step(|| class_step(lo, hi, class));
        class
    }
}

/// Pixels of a row queued for one four-lane filter ([`ShadowMap::lookup_row`]): how many,
/// their prepared lookups, kernels and columns.
#[derive(Copy, Clone, Default)]
struct Queued {
    n: usize,
    ats: [Option<At>; 4],
    kernels: [Option<Kernel>; 4],
    xs: [u32; 4],
}

/// A lookup prepared up to its filter ([`ShadowMap::prepare`]).
pub(crate) enum Prepared {
    /// Decided without filtering: the value and the taps it took.
    Done(f32, u64),
    /// Where to filter.
    At(At),
}

/// The map position of one pixel's lookup.
#[derive(Copy, Clone)]
pub(crate) struct At {
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
pub(crate) fn class_step(lo: f32, hi: f32, class: Class) -> Step {
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

/// The texels a lookup compared, with their stored depths and outcomes (for `inspect`).
fn texel_steps(map: &Surface<f32>, uv: Vec2, z: f32, filter: Filter) -> Step {
    let (w, h) = (map.width() as i64, map.height() as i64);
    let mut step = Step::new(
        "comparison",
        match filter {
            Filter::Pcf2 => "four texels compared, then weighted bilinearly by the fraction (hardware PCF)",
            _ => "the nearest texel's stored depth against the reference depth (lit if less-equal)",
        },
    );
    let texels: Vec<(i64, i64, f32)> = match filter {
        Filter::Pcf2 => {
            let (x, y, fx, fy) = footprint((w as u32, h as u32), uv);
            step = step.vec2("fraction", Vec2::new(fx, fy));
            [
                (0, 0, (1.0 - fx) * (1.0 - fy)),
                (1, 0, fx * (1.0 - fy)),
                (0, 1, (1.0 - fx) * fy),
                (1, 1, fx * fy),
            ]
            .iter()
            .map(|&(dx, dy, wt)| ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1), wt))
            .collect()
        }
        _ => {
            let tx = ((uv.x * w as f32).floor() as i64).clamp(0, w - 1);
            let ty = ((uv.y * h as f32).floor() as i64).clamp(0, h - 1);
            vec![(tx, ty, 1.0)]
        }
    };
    for (i, (tx, ty, wt)) in texels.into_iter().enumerate() {
        let d = map.at(tx as u32, ty as u32);
        step = step
            .vec2(&format!("texel {i}"), Vec2::new(tx as f32, ty as f32))
            .num(&format!("stored depth {i}"), d)
            .flag(&format!("lit {i}"), z <= d)
            .num(&format!("weight {i}"), wt);
    }
    step
}

impl ShadowTechnique for ShadowMap {
    fn name(&self) -> &'static str {
        "shadow-map"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, String> {
        let t0 = std::time::Instant::now();
        self.light_pass(p, frame)?;
        let t1 = std::time::Instant::now();
        // Pass 2: one lookup per camera pixel.
        let this = &*self;
        let (out, taps) = match self.opts.filter.pattern() {
            // The hierarchy decides some pixels of a row: the others fill the lanes.
            Some(pattern) if !self.planes.is_empty() && pattern != Pattern::DepthBilinear => {
                per_row_counted(p, frame, f32::NAN, |y, row| this.lookup_row(frame, y, pattern, row))
            }
            _ => per_pixel4_counted(p, frame, f32::NAN, |x, y, n| this.lookup4(frame, x, y, n)),
        };
        self.taps = taps;
        self.times = vec![
            ("light pass", (t1 - t0).as_secs_f64() * 1e3),
            ("lookup pass", t1.elapsed().as_secs_f64() * 1e3),
        ];
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let mut t = Steps::default();
        if self.maps.is_empty() {
            return t.0;
        }
        t.step(|| {
            Step::new("maps", "the light pass of the last run")
                .int("views", self.maps.len())
                .int("size", self.opts.size)
                .text("format", crate::shadow::options::OptionValue::show(&self.opts.format))
                .text("layer", self.opts.layer.as_str())
                .int("casters culled by fitting", self.culled)
        });
        let (v, _) = self.lookup(frame, x as usize, y as usize, &mut t);
        t.0.push(inspect::result(v));
        t.0
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("map texels", self.texels() as f64),
            ("casters culled", self.culled as f64),
            // Bilinear taps (a hardware 2x2 comparison each; one per classified kernel).
            ("taps", self.taps as f64),
        ]
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, String> {
        let mut v: Vec<Stage> = self
            .maps
            .iter()
            .enumerate()
            .map(|(i, (m, _))| Stage::Scalar {
                name: format!("depth_map{i}"),
                data: m.clone(),
                lo: 0.0,
                hi: 1.0,
            })
            .collect();
        if let Some(fitted) = &self.fitted {
            v.push(Stage::Color {
                name: "fitted_frustum".into(),
                data: fitted_overview(p, frame, fitted)?,
            });
        }
        for (i, ids) in self.ids.iter().enumerate() {
            let hi = ids.data().iter().copied().fold(1.0f32, f32::max);
            v.push(Stage::Scalar {
                name: format!("id_map{i}"),
                data: ids.clone(),
                lo: 0.0,
                hi,
            });
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fitting_culls_casters_that_cannot_shadow_visible_receivers() {
        // A box far to the side of the view casts nowhere the camera looks: culled.
        let text = "[camera]\nposition = [0, 3, 6]\ntarget = [0, 0, 0]\nresolution = [64, 48]\n\n[[light]]\ntype = \"directional\"\ndirection = [0.2, -1, 0.1]\n\n[[object]]\nmesh = \"plane\"\nsize = 8\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [0, 0.5, 0]\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [60, 0.5, 0]\n";
        let scene = crate::scene::file::parse(text, std::path::Path::new("t.toml")).unwrap();
        let p = Pipeline::new(2).unwrap();
        let f = crate::frame::frame(&p, &scene, 0, 0).unwrap();
        let mut sm = ShadowMap::new(Options {
            size: 256,
            fit: FitTo::Receivers,
            ..Default::default()
        })
        .unwrap();
        sm.visibility(&p, &f).unwrap();
        assert_eq!(sm.culled(), 1);
    }

    #[test]
    fn four_pixel_lookups_equal_one_pixel_ones() {
        use crate::shadow::map::pcss::tests::assert_lookups;
        // The hierarchy's sets take the row pass (mixed pixels queued into full lane groups).
        let sets: [&[(&str, &str)]; 11] = [
            &[("filter", "grid"), ("kernel", "5")],
            &[("filter", "tent"), ("kernel", "5"), ("cone", "0.5"), ("size", "256")],
            &[("filter", "tent"), ("kernel", "3"), ("size", "128")],
            &[("filter", "grid"), ("kernel", "17")],
            &[("filter", "grid"), ("kernel", "3"), ("receiver", "true")],
            &[("filter", "poisson"), ("kernel", "6"), ("cone", "1")],
            &[("filter", "rotated"), ("world", "0.05")],
            &[("filter", "spiral"), ("taps", "9"), ("hierarchy", "true")],
            &[("filter", "grid"), ("receiver", "true"), ("hierarchy", "true")],
            &[
                ("filter", "rotated"),
                ("kernel", "4"),
                ("receiver", "true"),
                ("hierarchy", "true"),
            ],
            &[("filter", "pcf2")],
        ];
        assert_lookups(
            &sets,
            |pairs| ShadowMap::new(declaration().parse(pairs).unwrap()).unwrap(),
            |t, f, x, y| t.lookup(f, x, y, &mut NoTrace),
            |_, _, _, _, _| {},
            |t| t.taps,
        );
    }

    #[test]
    fn the_library_constructor_checks_ranges() {
        let e = ShadowMap::new(Options {
            size: 0,
            ..Default::default()
        })
        .err()
        .unwrap();
        assert_eq!(e, "technique 'shadow-map': option size=0 is outside [16, 16384]");
    }
}
