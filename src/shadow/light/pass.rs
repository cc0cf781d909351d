//! The one light pass: every view of a light drawn in turn through the pipeline, each
//! storing what its technique keeps per texel.
//!
//! A technique says *which* views ([`super::light_views`], [`super::cube_views`], a fitted,
//! cascaded or warped set from [`super::LightMaps`]) and *what a texel stores* (a
//! [`Payload`]: depth, moments, opacity slices, deep-shadow functions, AVSM nodes, IZB lists,
//! a cookie's coverage, a height); [`ViewMaps::render`] does the rest the same way for all
//! of them: the memory budget checked before the first view, last run's maps handed back to
//! be drawn into again, each view's time, and the views kept beside their maps so that
//! [`super::locate`] finds a world point's texel in any of them.

use super::{Casters, DepthPass, LightView, MapPoint};
use crate::pipeline::{check_bytes, CullMode, Pipeline, Surface};
use crate::scene::Light;
use crate::Error;
use glam::Vec3;

/// What a light pass stores per texel of a view, and how it draws one view: the hook of
/// [`ViewMaps::render`].
pub trait Payload {
    /// One view's stored texels.
    type Map;

    /// What a memory-budget error calls the maps ("the deep shadow maps").
    fn what(&self) -> &'static str;

    /// Bytes the pass allocates for `views` views of `size`² texels of which `reused` draw
    /// into last run's maps; checked against the memory budget before the first view is
    /// drawn. Default: 0 (a payload whose views allocate through checked surfaces).
    fn bytes(&self, _size: u32, _views: usize, _reused: usize) -> u64 {
        0
    }

    /// Whether last run's map `old` can be drawn into again at `size`. Default: no.
    fn reusable(&self, _old: &Self::Map, _size: u32) -> bool {
        false
    }

    /// Draws view `i`, `view`; `reuse` is one of last run's maps to draw into, if any
    /// (the payload clears it, or drops it when [`Payload::reusable`] says no).
    fn draw(&mut self, p: &Pipeline, i: usize, view: &LightView, reuse: Option<Self::Map>) -> Result<Self::Map, Error>;
}

/// One light pass's maps: each view's payload beside its view, and each view's time.
pub struct ViewMaps<M> {
    maps: Vec<(M, LightView)>,
    times: Vec<f64>,
}

impl<M> Default for ViewMaps<M> {
    fn default() -> Self {
        ViewMaps {
            maps: Vec::new(),
            times: Vec::new(),
        }
    }
}

impl<M> ViewMaps<M> {
    /// The light pass: `payload` drawn for each of `views` at `size`² texels, in order. The
    /// memory the pass adds ([`Payload::bytes`]) is checked before anything is drawn; last
    /// run's maps are handed back to the payload to draw into.
    pub fn render<P: Payload<Map = M>>(
        &mut self,
        p: &Pipeline,
        views: Vec<LightView>,
        size: u32,
        payload: &mut P,
    ) -> Result<(), Error> {
        let mut old: Vec<M> = self.maps.drain(..).map(|(m, _)| m).collect();
        self.times.clear();
        let reused = old
            .iter()
            .filter(|m| payload.reusable(m, size))
            .count()
            .min(views.len());
        let bytes = payload.bytes(size, views.len(), reused);
        if bytes > 0 {
            check_bytes(size, size, bytes).map_err(|e| {
                Error::from(e).within(&format!(
                    "{} ({} views, option size={size})",
                    payload.what(),
                    views.len()
                ))
            })?;
        }
        for (i, view) in views.into_iter().enumerate() {
            let start = std::time::Instant::now();
            let map = payload.draw(p, i, &view, old.pop())?;
            self.maps.push((map, view));
            self.times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }

    /// Each view's map beside its view, in view order (six for cube maps).
    #[inline(always)]
    pub fn maps(&self) -> &[(M, LightView)] {
        &self.maps
    }

    /// Each view's map beside its view, in view order.
    pub fn iter(&self) -> std::slice::Iter<'_, (M, LightView)> {
        self.maps.iter()
    }

    /// Each view's map beside its view, to be changed in place.
    pub fn maps_mut(&mut self) -> &mut [(M, LightView)] {
        &mut self.maps
    }

    /// The light views of the last pass.
    pub fn views(&self) -> Vec<LightView> {
        self.maps.iter().map(|(_, v)| *v).collect()
    }

    /// Whether the pass has not run (or found no view).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.maps.is_empty()
    }

    /// The number of views of the last pass.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.maps.len()
    }

    /// The map and view of view `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> &(M, LightView) {
        &self.maps[i]
    }

    /// Milliseconds each view of the last pass took (its payload's draw).
    pub fn view_times(&self) -> &[f64] {
        &self.times
    }

    /// Where world point `q` falls in the maps ([`super::locate`]).
    #[inline(always)]
    pub fn locate(&self, light: &Light, q: Vec3) -> Option<MapPoint> {
        super::locate(&self.maps, light, q)
    }

    /// Forgets the maps (a technique that ran and then found nothing to draw).
    pub fn clear(&mut self) {
        self.maps.clear();
        self.times.clear();
    }
}

/// The plainest payload: the nearest depth of `casters` ([`DepthPass`], culling nothing).
pub struct Depth<'c> {
    /// The depth pass's settings.
    pub pass: DepthPass,
    /// The casters drawn.
    pub casters: &'c Casters,
}

impl Payload for Depth<'_> {
    type Map = Surface<f32>;

    fn what(&self) -> &'static str {
        "the depth maps"
    }

    fn bytes(&self, size: u32, views: usize, reused: usize) -> u64 {
        (size as u64 * size as u64 * 4).saturating_mul(views.saturating_sub(reused) as u64)
    }

    fn reusable(&self, old: &Surface<f32>, size: u32) -> bool {
        old.width() == size && old.height() == size
    }

    fn draw(
        &mut self,
        p: &Pipeline,
        _: usize,
        view: &LightView,
        reuse: Option<Surface<f32>>,
    ) -> Result<Surface<f32>, Error> {
        self.pass.render(p, self.casters, view, CullMode::None, None, reuse)
    }
}
