//! The light's depth maps: the map pass every map-based technique starts with, and
//! [`locate`], where a world point falls in them.
//!
//! [`MapOptions`] are the pass's settings (size, depth format, polygon offset, fitting,
//! snapping); [`LightMaps::render`] draws one depth map per light view ([`super::fit`]: one
//! orthographic or perspective view, or six cube faces) with the casters merged into one
//! draw ([`super::depth`]), storing the [`Layer`] a technique asks for (the nearest surface,
//! back faces, the midpoint of two peeled layers, or object ids).
//!
//! [`locate`] is the one lookup from world to map: the view that sees the point (one of six
//! faces for cube maps), its texture coordinate and depth there. [`MapPoint::inside`] is the
//! one edge rule: `uv` in `[0, 1)²`, the coordinates whose texel `floor(uv * size)` exists.

use super::cascades::{cascade_fit, cascade_of, Cascades};
use super::pass::{Payload, ViewMaps};
use super::sdsm::{self, DepthSamples, Partition};
use super::warp::{warp_fit, Warp, WarpInfo};
use super::{fit, merged_casters, Casters, DepthPass, LightView};
use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::*;
use crate::scene::Light;
use crate::shadow::options::Field;
use crate::shadow::stage::Stage;
use crate::Error;
use glam::{BVec4A, Vec2, Vec3, Vec4};

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

/// Settings of the map pass ([`LightMaps::render`]).
#[derive(Clone, Debug, PartialEq)]
pub struct MapOptions {
    /// Map side in texels (a cube map has six faces of this size). Default: 2048.
    pub size: u32,
    /// Depth storage. Default: f32.
    pub format: DepthFormat,
    /// Constant polygon offset, in units of the format's resolvable depth step. Default: 4.
    pub units: f32,
    /// Slope-scaled polygon offset factor. Default: 1.1.
    pub slope: f32,
    /// Directional lights: fit the map to the scene or to the visible receivers. Default: scene.
    pub fit: FitTo,
    /// Snap the fitted frustum to whole texels (against shimmering); with cascades, fit each
    /// to its slice's bounding sphere on whole texels. Default: false.
    pub snap: bool,
    /// The views the pass draws: one per face (whole), cascades, or a warp. Default: whole.
    pub views: Views,
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

/// Which views a map pass draws for its light: one of, never a mix.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Views {
    /// One view per face of the light ([`super::light_views`]; a directional light's fitted
    /// as [`MapOptions::fit`] says).
    #[default]
    Whole,
    /// Cascades over the view range instead of one map (directional lights; declared by the
    /// techniques that offer them, [`Cascades::fields`]).
    Cascades(Cascades),
    /// A perspective warp of a directional light's map ([`Warp`]: PSM, TSM, LiSPSM, LogPSM;
    /// declared by the techniques that are one).
    Warp(Warp),
}

impl Views {
    /// The cascades, if these views are cascades.
    pub fn cascades(&self) -> Option<&Cascades> {
        match self {
            Views::Cascades(c) => Some(c),
            _ => None,
        }
    }

    /// The warp, if these views are warped.
    pub fn warp(&self) -> Option<&Warp> {
        match self {
            Views::Warp(w) => Some(w),
            _ => None,
        }
    }

    /// The cascades, made default cascades first unless these views are cascades (for
    /// option declarations that reach into them).
    pub fn cascades_mut(&mut self) -> &mut Cascades {
        if !matches!(self, Views::Cascades(_)) {
            *self = Views::Cascades(Cascades::default());
        }
        match self {
            Views::Cascades(c) => c,
            _ => unreachable!("just set to cascades"),
        }
    }

    /// The warp, made the default warp first unless these views are warped (for option
    /// declarations that reach into it).
    pub fn warp_mut(&mut self) -> &mut Warp {
        if !matches!(self, Views::Warp(_)) {
            *self = Views::Warp(Warp::default());
        }
        match self {
            Views::Warp(w) => w,
            _ => unreachable!("just set to a warp"),
        }
    }
}

impl Default for MapOptions {
    fn default() -> Self {
        MapOptions {
            size: 2048,
            format: DepthFormat::F32,
            units: 4.0,
            slope: 1.1,
            fit: FitTo::Scene,
            snap: false,
            views: Views::Whole,
        }
    }
}

impl MapOptions {
    /// The default map pass with cascades `c` at `size` texels a cascade.
    pub fn cascaded(size: u32, c: Cascades) -> MapOptions {
        MapOptions {
            size,
            views: Views::Cascades(c),
            ..MapOptions::default()
        }
    }

    /// The default map pass warped by `kind` (with the warp's default parameters).
    pub fn warped(kind: super::warp::WarpKind) -> MapOptions {
        MapOptions {
            views: Views::Warp(Warp {
                kind,
                ..Warp::default()
            }),
            ..MapOptions::default()
        }
    }

    /// The declaration of the map pass's fields (size, format, polygon offset, fitting,
    /// snapping); a technique's options that hold a `MapOptions` declare them with
    /// [`crate::shadow::options::within`].
    pub fn fields() -> Vec<Field<MapOptions>> {
        vec![
            Field::size("map side in texels (a cube map has six faces of this size)", |m: &mut MapOptions| &mut m.size),
            Field::new("format", "depth storage: f32, u24 or u16", |m: &mut MapOptions| {
                &mut m.format
            }),
            Field::range(
                "units",
                "constant polygon offset, in units of the format's resolvable depth step",
                -1e6,
                1e6,
                |m: &mut MapOptions| &mut m.units,
            ),
            Field::range(
                "slope",
                "slope-scaled polygon offset factor",
                -1e3,
                1e3,
                |m: &mut MapOptions| &mut m.slope,
            ),
            Field::new(
                "fit",
                "directional lights: scene bounds, or receivers (casters that shadow visible receivers)",
                |m: &mut MapOptions| &mut m.fit,
            ),
            Field::new(
                "snap",
                "snap the fitted frustum to whole texels (against shimmering); cascades: each fitted to its slice's bounding sphere on whole texels",
                |m: &mut MapOptions| &mut m.snap,
            ),
        ]
    }
}

/// Where a world point falls in a light's maps ([`locate`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MapPoint {
    /// The light view that sees the point (a cube face's index for cube maps).
    pub view: usize,
    /// Texture coordinate in that view (origin top-left; inside the map in `[0, 1)²`).
    pub uv: Vec2,
    /// Depth in the view (the light's clip depth, `[0, 1]` between its planes).
    pub depth: f32,
}

impl MapPoint {
    /// Whether the point lies on the map: the one edge rule, [`inside`].
    #[inline(always)]
    pub fn inside(&self) -> bool {
        inside(self.uv)
    }

    /// The texel holding the point in a `width x height` map (`floor(uv * size)`), clamped to
    /// the map (points off the map take its edge texel).
    #[inline(always)]
    pub fn texel(&self, width: u32, height: u32) -> (u32, u32) {
        texel(self.uv, width, height)
    }
}

/// The edge rule of every lookup, the pipeline's samplers' own
/// ([`crate::pipeline::sampler::on_map`]): `uv` lies on a map when it is in `[0, 1)²`, where
/// its texel `floor(uv * size)` exists (so a coordinate of exactly 1 is off the map, as a
/// texel index of `size` would be).
#[inline(always)]
pub fn inside(uv: Vec2) -> bool {
    crate::pipeline::sampler::on_map(uv)
}

/// [`inside`] of four coordinates `(u[l], v[l])`, one per lane.
#[inline(always)]
pub fn inside4(u: Vec4, v: Vec4) -> BVec4A {
    crate::pipeline::sampler::on_map4(u, v)
}

/// The texel of `uv` in a `width x height` map, clamped to the map.
#[inline(always)]
pub fn texel(uv: Vec2, width: u32, height: u32) -> (u32, u32) {
    let clamp = |t: f32, n: u32| (t.floor().max(0.0) as u32).min(n - 1);
    (clamp(uv.x * width as f32, width), clamp(uv.y * height as f32, height))
}

/// Something with a light view: a [`LightView`] itself, or a map paired with its view, so
/// that [`locate`] serves every technique's per-view data.
pub trait OnView {
    /// The light view.
    fn light_view(&self) -> &LightView;
}

impl OnView for LightView {
    #[inline(always)]
    fn light_view(&self) -> &LightView {
        self
    }
}

impl<T> OnView for (T, LightView) {
    #[inline(always)]
    fn light_view(&self) -> &LightView {
        &self.1
    }
}

/// Which of `views` sees world point `p`: a cascade by its [`Slice`](super::cascades::Slice)
/// ([`cascade_of`]), a cube face by the direction from the light for six views
/// ([`CubeFace::ALL`] order), the one view otherwise.
#[inline(always)]
pub fn view_of(views: &[impl OnView], light: &Light, p: Vec3) -> usize {
    match views.first().and_then(|v| v.light_view().slice()) {
        Some(first) => cascade_of(views, &first, p),
        None if views.len() == 6 => CubeFace::from_direction(p - light.position).map_or(0, |f| f.0 as usize),
        None => 0,
    }
}

/// Where world point `p` falls in `views`: the view that sees it ([`view_of`]), its texture
/// coordinate and depth there; `None` behind a perspective view's eye. The point is on the
/// map when [`MapPoint::inside`].
#[inline(always)]
pub fn locate(views: &[impl OnView], light: &Light, p: Vec3) -> Option<MapPoint> {
    locate_on(views, view_of(views, light, p), p)
}

/// [`locate`] in a given view `view` (a technique that moves the lookup point, as the
/// normal offset does, keeps the view its surface point chose).
#[inline(always)]
pub fn locate_on(views: &[impl OnView], view: usize, p: Vec3) -> Option<MapPoint> {
    let (uv, depth) = views[view].light_view().lookup(p)?;
    Some(MapPoint { view, uv, depth })
}

/// The light's maps of one frame: one depth map per light view, and what the pass found.
#[derive(Default)]
pub struct LightMaps {
    maps: ViewMaps<Surface<f32>>,
    /// With [`Layer::Id`]: object id + 1 per texel (0: empty), per view.
    ids: Vec<Surface<f32>>,
    culled: usize,
    fitted: Option<LightView>,
    /// Cascades: triangles drawn into each cascade's map.
    casters: Vec<usize>,
    /// The warp of the last pass, if one was asked for.
    warp: Option<WarpInfo>,
    /// SDSM: the depth samples of the last frame reduced (the next pass's with latency 1).
    last_samples: Option<DepthSamples>,
    /// SDSM: the samples the last pass's cascades used, and the reduction's milliseconds.
    samples: Option<(DepthSamples, f64)>,
}

impl LightMaps {
    /// The map pass: the maps of `frame`'s light with options `o`, storing `layer`. The maps
    /// of the last call are reused where their size allows; the memory the pass adds is
    /// checked against the budget before anything is drawn.
    pub fn render(&mut self, p: &Pipeline, frame: &Frame, o: &MapOptions, layer: Layer) -> Result<(), Error> {
        self.warp = None;
        self.samples = None;
        let fit = match &o.views {
            Views::Cascades(c) => {
                if frame.light.kind != crate::scene::LightKind::Directional {
                    return Err(Error::option(
                        "cascades",
                        c.count,
                        format!(
                            "split a directional light's map; the scene's light is {} (shadow-map covers every light)",
                            frame.light.kind.describe()
                        ),
                    ));
                }
                if c.partition == Partition::View {
                    cascade_fit(frame, o.size, c, o.snap, None)
                } else {
                    // SDSM: reduce this frame's depths; use them, or with latency the last frame's.
                    let start = std::time::Instant::now();
                    let now = sdsm::reduce(p, frame, c.partition == Partition::Histogram)?;
                    let ms = start.elapsed().as_secs_f64() * 1e3;
                    let used = match c.latency {
                        0 => now.clone(),
                        _ => self.last_samples.take().or_else(|| now.clone()),
                    };
                    self.last_samples = now;
                    let fit = cascade_fit(frame, o.size, c, o.snap, used.as_ref());
                    self.samples = used.map(|u| (u, ms));
                    fit
                }
            }
            Views::Warp(w) => {
                if frame.light.kind != crate::scene::LightKind::Directional {
                    return Err(Error::technique(format!(
                        "{} warps a directional light's map; the scene's light is {} (shadow-map covers every light)",
                        w.kind.as_str(),
                        frame.light.kind.describe()
                    )));
                }
                if w.kind == super::warp::WarpKind::Logpsm && matches!(layer, Layer::Midpoint | Layer::Id) {
                    return Err(Error::option(
                        "layer",
                        layer.as_str(),
                        "logpsm draws its logarithmic rows one depth layer at a time: first or second",
                    ));
                }
                // PSM and LogPSM cover the depths seen: this frame's reduction.
                let start = std::time::Instant::now();
                let seen = match w.kind {
                    super::warp::WarpKind::Psm | super::warp::WarpKind::Logpsm => sdsm::reduce(p, frame, false)?,
                    _ => None,
                };
                let ms = start.elapsed().as_secs_f64() * 1e3;
                let (fit, mut info) = warp_fit(frame, o.size, w, seen.as_ref());
                if seen.is_some() {
                    info.reduce_ms = Some(ms);
                }
                self.warp = Some(info);
                fit
            }
            Views::Whole => fit(frame, o.size, o.fit == FitTo::Receivers, o.snap),
        };
        self.culled = fit.culled;
        self.fitted = fit.fitted;
        // Cascades merge their own casters per view (a cascade with the last one's set reuses
        // its merge).
        let casters = if fit.per_view.is_empty() {
            merged_casters(frame, &fit.casters)?
        } else {
            Casters::default()
        };
        let mut layers = Layers {
            frame,
            pass: DepthPass {
                size: o.size,
                format: o.format,
                offset: PolygonOffset {
                    units: o.units,
                    factor: o.slope,
                },
            },
            layer,
            objects: &fit.casters,
            per_view: &fit.per_view,
            casters,
            drawn: Vec::new(),
            ids: Vec::new(),
        };
        self.maps.render(p, fit.views, o.size, &mut layers)?;
        self.casters = layers.drawn;
        self.ids = layers.ids;
        Ok(())
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

    /// Whether the pass has not run (or found no view).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.maps.is_empty()
    }

    /// The map and view of view `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> &(Surface<f32>, LightView) {
        self.maps.get(i)
    }

    /// With [`Layer::Id`]: view `i`'s object ids (+1; 0 where empty).
    #[inline(always)]
    pub fn ids(&self, i: usize) -> Option<&Surface<f32>> {
        self.ids.get(i)
    }

    /// Where world point `p` falls in the maps ([`locate`]).
    #[inline(always)]
    pub fn locate(&self, light: &Light, p: Vec3) -> Option<MapPoint> {
        self.maps.locate(light, p)
    }

    /// Texels of the last pass's maps, all views.
    pub fn texels(&self) -> usize {
        self.maps().iter().map(|(m, _)| m.data().len()).sum()
    }

    /// Casters culled by fitting in the last pass.
    pub fn culled(&self) -> usize {
        self.culled
    }

    /// Cascades: the caster triangles each cascade's map drew in the last pass (empty
    /// without cascades).
    pub fn cascade_casters(&self) -> &[usize] {
        &self.casters
    }

    /// SDSM: the depth samples the last pass's cascades used (this frame's, or the previous
    /// one's with latency) and the milliseconds this frame's reduction took.
    pub fn depth_samples(&self) -> Option<&(DepthSamples, f64)> {
        self.samples.as_ref()
    }

    /// The warp the last pass fitted (its parameters and any fall-back), if it was warped.
    pub fn warp(&self) -> Option<&WarpInfo> {
        self.warp.as_ref()
    }

    /// Milliseconds each view's pass took in the last pass (its casters and its draw).
    pub fn view_times(&self) -> &[f64] {
        self.maps.view_times()
    }

    /// The fitted view of the last pass (directional lights fitted to receivers).
    pub fn fitted(&self) -> Option<&LightView> {
        self.fitted.as_ref()
    }

    /// Per view: the nearest caster's distance from the light (the map's least depth, at
    /// most the far plane's; [`LightView::distance`]), from a parallel reduction.
    pub fn nearest_casters(&self, p: &Pipeline) -> Vec<f32> {
        self.maps()
            .iter()
            .map(|(m, v)| v.distance(compute::least(p, m, 1.0)))
            .collect()
    }

    /// The pass's buffers for `dump`: each depth map, the fitted frustum over the whole
    /// scene's map (RTR fig. 7.11) and the id maps.
    pub fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v: Vec<Stage> = self
            .maps()
            .iter()
            .enumerate()
            .map(|(i, (m, _))| Stage::unit(format!("depth_map{i}"), m.clone()))
            .collect();
        if let Some(fitted) = &self.fitted {
            v.push(Stage::Color {
                name: "fitted_frustum".into(),
                data: super::fitted_overview(p, frame, fitted)?,
            });
        }
        if !self.maps.is_empty() {
            // Texels per camera pixel: where the map is magnified (above 1) or wasted.
            v.push(Stage::pixels(
                frame,
                "texel_footprint",
                super::texel_footprint(frame, self.maps()),
                0.0,
                4.0,
            )?);
        }
        if self.maps().first().is_some_and(|(_, v)| v.slice().is_some()) {
            v.push(Stage::Color {
                name: "cascades".into(),
                data: cascade_image(frame, self.maps())?,
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

/// The map pass's payload: the [`Layer`] of the casters each view draws (a cascade its own
/// set), with the object ids beside the depth for [`Layer::Id`].
struct Layers<'a> {
    frame: &'a Frame<'a>,
    pass: DepthPass,
    layer: Layer,
    /// Per scene object: whether it casts (the fit's culling).
    objects: &'a [bool],
    /// Cascades: per view, the objects it draws (empty: every view draws `casters`).
    per_view: &'a [Vec<bool>],
    /// The casters of the view being drawn.
    casters: Casters,
    /// Cascades: triangles drawn into each view.
    drawn: Vec<usize>,
    /// [`Layer::Id`]: each view's ids.
    ids: Vec<Surface<f32>>,
}

impl Payload for Layers<'_> {
    type Map = Surface<f32>;

    fn what(&self) -> &'static str {
        "the light's maps"
    }

    /// Every map the pass allocates (views × layers) less the maps of the last run it draws
    /// into again.
    fn bytes(&self, size: u32, views: usize, reused: usize) -> u64 {
        let layers: u64 = match self.layer {
            Layer::First | Layer::Second => 1,
            Layer::Midpoint => 3,
            Layer::Id => 2,
        };
        let new_maps = (views as u64 * layers).saturating_sub(reused as u64);
        (size as u64 * size as u64 * 4).saturating_mul(new_maps)
    }

    fn reusable(&self, old: &Surface<f32>, size: u32) -> bool {
        old.width() == size
    }

    fn draw(
        &mut self,
        p: &Pipeline,
        i: usize,
        view: &LightView,
        reuse: Option<Surface<f32>>,
    ) -> Result<Surface<f32>, Error> {
        let (frame, pass, casters) = (self.frame, self.pass, &mut self.casters);
        if let Some(keep) = self.per_view.get(i) {
            // Cascades: each draws the casters that can shadow its slice.
            if i == 0 || self.per_view[i - 1] != *keep {
                *casters = merged_casters(frame, keep)?;
            }
            self.drawn.push(casters.indices.len() / 3);
        }
        let size = pass.size;
        Ok(match self.layer {
            Layer::First => pass.render(p, casters, view, CullMode::None, None, reuse)?,
            Layer::Second => pass.render(p, casters, view, CullMode::Front, None, reuse)?,
            Layer::Midpoint => {
                let d1 = pass.render(p, casters, view, CullMode::None, None, reuse)?;
                let d2 = pass.render(p, casters, view, CullMode::None, Some(&d1), None)?;
                let mid: Vec<f32> = d1.data().iter().zip(d2.data()).map(|(a, b)| 0.5 * (a + b)).collect();
                Surface::from_vec(size, size, mid)?
            }
            Layer::Id => {
                // Object ids (+1; 0 = empty) of the nearest surface; its depth is the map
                // `dump` shows.
                let mut ids = Surface::new(size, size, 0.0f32)?;
                let mut depth = Surface::new(size, size, 1.0f32)?;
                for (oi, ob) in frame.scene.objects.iter().enumerate().filter(|(i, _)| self.objects[*i]) {
                    let id = oi as f32 + 1.0;
                    let fs = Shader(move |_: &Fragment<()>| Vec4::splat(id));
                    p.draw(
                        &mut Targets::color(&mut ids).with_depth(&mut depth),
                        &RenderState::default(),
                        &ob.mesh.positions,
                        &ob.mesh.indices,
                        &TransformPositions(view.matrix),
                        &fs,
                    )?;
                }
                self.ids.push(ids);
                depth
            }
        })
    }
}

/// Which cascade each camera pixel of `frame` reads, one colour per cascade shaded by the
/// light's angle (RTR fig. 7.20); black where there is no geometry.
fn cascade_image(frame: &Frame, views: &[(Surface<f32>, LightView)]) -> Result<Surface<Rgba8>, Error> {
    const PALETTE: [[f32; 3]; 8] = [
        [230.0, 80.0, 80.0],
        [80.0, 200.0, 80.0],
        [80.0, 120.0, 240.0],
        [230.0, 200.0, 60.0],
        [200.0, 90.0, 220.0],
        [60.0, 210.0, 210.0],
        [240.0, 150.0, 60.0],
        [170.0, 170.0, 170.0],
    ];
    let data = frame
        .points()
        .iter()
        .map(|s| match s {
            None => [0, 0, 0, 255],
            Some(s) => {
                let c = PALETTE[view_of(views, &frame.light, s.position) % 8];
                let k = 0.35 + 0.65 * s.normal.dot(frame.light.to_light(s.position)).max(0.0);
                [(c[0] * k) as u8, (c[1] * k) as u8, (c[2] * k) as u8, 255]
            }
        })
        .collect();
    Ok(Surface::from_vec(frame.width(), frame.height(), data)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::LightKind;

    fn light(kind: LightKind) -> Light {
        Light {
            kind,
            position: Vec3::new(0.5, 3.0, -0.25),
            direction: Vec3::new(0.0, -1.0, 0.0),
            intensity: 1.0,
        }
    }

    #[test]
    fn the_edge_rule_is_half_open() {
        for (uv, on) in [
            (Vec2::new(0.0, 0.0), true),
            (Vec2::new(0.999_999_9, 0.5), true),
            (Vec2::new(1.0, 0.5), false),
            (Vec2::new(0.5, 1.0), false),
            (Vec2::new(-1e-9, 0.5), false),
            (Vec2::new(f32::NAN, 0.5), false),
        ] {
            assert_eq!(inside(uv), on, "{uv}");
            if on {
                let (x, y) = texel(uv, 64, 32);
                assert!(x < 64 && y < 32);
                assert_eq!((x, y), ((uv.x * 64.0) as u32, (uv.y * 32.0) as u32));
            }
        }
        // Off the map, the texel is the edge's.
        assert_eq!(texel(Vec2::new(1.0, -0.5), 64, 32), (63, 0));
    }

    #[test]
    fn cube_faces_meet_without_a_gap() {
        // Points on a sphere around a point light: each falls inside the face that sees it,
        // including on the faces' seams and corners.
        let l = light(LightKind::Point);
        let views: Vec<LightView> = (0..6)
            .map(|i| {
                let (fwd, u, v) = CubeFace::ALL[i].basis();
                let e = l.position;
                let view = glam::Mat4::from_cols(
                    Vec4::new(u.x, -v.x, -fwd.x, 0.0),
                    Vec4::new(u.y, -v.y, -fwd.y, 0.0),
                    Vec4::new(u.z, -v.z, -fwd.z, 0.0),
                    Vec4::new(-u.dot(e), v.dot(e), fwd.dot(e), 1.0),
                );
                LightView {
                    matrix: glam::Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, 0.01, 50.0) * view,
                    texel: 2.0 / 64.0,
                    kind: crate::shadow::light::ViewKind::Perspective,
                }
            })
            .collect();
        let mut n = 0;
        for i in 0..40 {
            for j in 0..80 {
                let th = std::f32::consts::PI * (i as f32 + 0.5) / 40.0;
                let ph = std::f32::consts::TAU * j as f32 / 80.0;
                let d = Vec3::new(
                    crate::math::sin(th) * crate::math::cos(ph),
                    crate::math::cos(th),
                    crate::math::sin(th) * crate::math::sin(ph),
                );
                for dir in [d, d.signum() * Vec3::ONE.normalize(), Vec3::new(d.x.signum(), 0.0, 1.0)] {
                    let m = locate(&views, &l, l.position + dir * 2.0).expect("in front of its face");
                    assert!(m.uv.x >= -1e-6 && m.uv.x <= 1.0 + 1e-6, "{dir} {m:?}");
                    assert!(m.uv.y >= -1e-6 && m.uv.y <= 1.0 + 1e-6, "{dir} {m:?}");
                    let (x, y) = m.texel(64, 64);
                    assert!(x < 64 && y < 64);
                    n += 1;
                }
            }
        }
        assert_eq!(n, 40 * 80 * 3);
        // One view: always view 0.
        assert_eq!(view_of(&views[..1], &l, Vec3::new(9.0, -3.0, 2.0)), 0);
    }
}
