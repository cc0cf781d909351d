//! Cascaded shadow maps' light side (RTR 7.4.1; Zhang et al. 2006, parallel-split shadow
//! maps; Dimitrov 2007): the camera's view range cut into slices, one orthographic light view
//! fitted to each slice, and the rule that sends a world point to its slice's view.
//!
//! - Splits ([`split_distances`]): uniform, logarithmic (RTR eq. 7.5,
//!   `z_i = n (f / n)^(i / c)`), or the practical blend of the two,
//!   `lambda * log + (1 - lambda) * uniform` (Zhang et al. use 0.5, the Cesium slides 0.9).
//! - Fitting ([`cascade_fit`]): each slice's eight frustum corners taken into a light space
//!   anchored at the world origin. Stable (`snap`): the slice's bounding sphere, its radius
//!   rounded up to a sixteenth of an octave and its centre moved to whole texels, so neither
//!   camera rotation (the sphere does not turn) nor sub-texel translation moves the sampling
//!   grid (MJP's "stable cascades"). Tight: the corners' box clipped to the scene's. Each
//!   cascade draws only the casters whose light-space box overlaps its own and that are not
//!   wholly beyond its receivers from the light.
//! - Selection ([`Slice`], read by [`super::view_of`], so the same [`super::locate`] serves
//!   cascades): by view depth (the first cascade whose far split lies beyond the point) or by
//!   map bounds (the first cascade whose map holds the point).
//! - Blending ([`next_weight`]): in a band at the end of each cascade the lookup mixes in the
//!   next one, linearly or by an ordered dither (one lookup per pixel), against seams.

use super::sdsm::{DepthSamples, Partition};
use super::{corners, up_for, Fit, LightView, OnView, ViewKind};
use crate::choice_enum;
use crate::frame::Frame;
use crate::shadow::options::Field;
use glam::{Mat4, Vec2, Vec3, Vec4};

choice_enum! {
    /// How the view range is split between cascades.
    pub enum Split {
        /// Equal depth ranges.
        Uniform = "uniform",
        /// Logarithmic: equal ratios of far to near (RTR eq. 7.5).
        Log = "log",
        /// `lambda * log + (1 - lambda) * uniform` (Zhang et al. 2006).
        Practical = "practical",
    }
}

choice_enum! {
    /// How a point picks its cascade.
    pub enum Select {
        /// By view depth against the split distances.
        Depth = "depth",
        /// The first cascade whose map holds the point.
        Bounds = "bounds",
    }
}

choice_enum! {
    /// How the band at a cascade's end mixes in the next cascade.
    pub enum Blend {
        /// Both lookups, weighted by the position across the band.
        Linear = "linear",
        /// One lookup: the next cascade where the weight passes a 4x4 ordered-dither
        /// threshold of the pixel.
        Dither = "dither",
    }
}

/// Most cascades of one light.
pub const MAX_CASCADES: u32 = 8;

/// Settings of the cascades (count, splits, selection, blending); their fitting's stability
/// is the map pass's `snap` ([`super::MapOptions::snap`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Cascades {
    /// Number of cascades, 1 to 8 (1: one map fitted to the whole view range). Default: 4.
    pub count: u32,
    /// Split scheme. Default: practical.
    pub split: Split,
    /// Practical splits: weight of the logarithmic split (Zhang et al. 0.5, Cesium 0.9).
    /// Default: 0.5.
    pub lambda: f32,
    /// Cascade selection. Default: depth.
    pub select: Select,
    /// Blend band: the fraction of a cascade's depth range (selection by depth) or of half
    /// its map (by bounds) at its end where the next cascade is mixed in; 0: none.
    /// Default: 0.1.
    pub band: f32,
    /// How the band mixes. Default: linear.
    pub blend: Blend,
    /// Where the range and splits come from: the camera's planes, or the depths it sees
    /// (SDSM, [`super::sdsm`]). Default: view.
    pub partition: Partition,
    /// SDSM: frames between the depth reduction and its use (0: this frame's depths; 1: the
    /// previous frame's, as engines that read the reduction back late). Default: 0.
    pub latency: u32,
}

impl Default for Cascades {
    fn default() -> Self {
        Cascades {
            count: 4,
            split: Split::Practical,
            lambda: 0.5,
            select: Select::Depth,
            band: 0.1,
            blend: Blend::Linear,
            partition: Partition::View,
            latency: 0,
        }
    }
}

impl Cascades {
    /// The declaration of the cascades' fields (`cascades`, `split`, `lambda`, `select`,
    /// `band`, `blend`) for options that hold a `Cascades`.
    pub fn fields() -> Vec<Field<Cascades>> {
        vec![
            Field::range(
                "cascades",
                "cascades over the view range (directional lights)",
                1,
                MAX_CASCADES,
                |c: &mut Cascades| &mut c.count,
            ),
            Field::new(
                "split",
                "split scheme: uniform, log (RTR eq. 7.5) or practical (lambda blend of the two)",
                |c: &mut Cascades| &mut c.split,
            ),
            Field::range(
                "lambda",
                "practical splits: weight of the logarithmic split (PSSM 0.5, Cesium 0.9)",
                0.0,
                1.0,
                |c: &mut Cascades| &mut c.lambda,
            ),
            Field::new(
                "select",
                "cascade selection: depth (split distances) or bounds (the first map that holds the point)",
                |c: &mut Cascades| &mut c.select,
            ),
            Field::range(
                "band",
                "blend band at each cascade's end: fraction of its depth range (or of half its map, by bounds); 0: none",
                0.0,
                0.5,
                |c: &mut Cascades| &mut c.band,
            ),
            Field::new(
                "blend",
                "blend across the band: linear (two lookups) or dither (one, by a 4x4 ordered dither)",
                |c: &mut Cascades| &mut c.blend,
            ),
        ]
    }

    /// SDSM's fields (`partition`, `latency`), for the techniques that reduce the camera's
    /// depths.
    pub fn sdsm_fields() -> Vec<Field<Cascades>> {
        vec![
            Field::new(
                "partition",
                "range and splits from: view (camera planes), minmax (the depths seen) or histogram (each cascade fitted to where samples are)",
                |c: &mut Cascades| &mut c.partition,
            ),
            Field::range(
                "latency",
                "frames between the depth reduction and its use (0: this frame's; 1: the previous frame's)",
                0,
                1,
                |c: &mut Cascades| &mut c.latency,
            ),
        ]
    }
}

/// One cascade's place in its set: the view depths it covers and how points pick it
/// ([`super::view_of`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Slice {
    /// The camera's view-depth plane: `depth(p) = dot(plane.xyz, p) + plane.w`.
    pub plane: Vec4,
    /// View depth where the cascade starts.
    pub near: f32,
    /// View depth where it ends (the next one's start).
    pub far: f32,
    /// Selection by map bounds instead of depth.
    pub by_bounds: bool,
}

impl Slice {
    /// View depth of world point `p`.
    #[inline(always)]
    pub fn depth(&self, p: Vec3) -> f32 {
        crate::math::dot4(self.plane, p.extend(1.0))
    }
}

/// The cascade of `views` (each with its [`Slice`]) that sees world point `p`: the first
/// whose far split lies beyond the point's view depth (or, by bounds, whose map holds it:
/// on the map and between its depth planes); the last one for points beyond every cascade.
#[inline(always)]
pub fn cascade_of(views: &[impl OnView], first: &Slice, p: Vec3) -> usize {
    let last = views.len() - 1;
    if first.by_bounds {
        return (0..last)
            .find(|&i| {
                views[i]
                    .light_view()
                    .lookup(p)
                    .is_some_and(|(uv, z)| super::inside(uv) && (0.0..=1.0).contains(&z))
            })
            .unwrap_or(last);
    }
    let d = first.depth(p);
    (0..last)
        .find(|&i| views[i].light_view().slice().is_some_and(|s| d < s.far))
        .unwrap_or(last)
}

/// The weight of the next cascade at world point `p` seen in cascade `i` of `views` at map
/// coordinate `uv`, with a blend band of `band`: 0 outside the band (and in the last
/// cascade), rising to 1 at the cascade's end.
#[inline(always)]
pub fn next_weight(views: &[impl OnView], i: usize, p: Vec3, uv: Vec2, band: f32) -> f32 {
    let Some(s) = views[i].light_view().slice() else {
        return 0.0;
    };
    if band <= 0.0 || i + 1 >= views.len() {
        return 0.0;
    }
    if s.by_bounds {
        // Distance to the map's nearest edge, in map widths; the band is a fraction of half.
        let e = uv.x.min(1.0 - uv.x).min(uv.y).min(1.0 - uv.y);
        let w = band * 0.5;
        return if e >= w { 0.0 } else { (1.0 - e / w).clamp(0.0, 1.0) };
    }
    let width = band * (s.far - s.near);
    let start = s.far - width;
    let d = s.depth(p);
    if d <= start || width <= 0.0 {
        0.0
    } else {
        ((d - start) / width).min(1.0)
    }
}

/// The 4x4 ordered-dither threshold of pixel `(x, y)`, in `(0, 1)` (Bayer).
#[inline(always)]
pub fn dither_threshold(x: usize, y: usize) -> f32 {
    const BAYER: [[u8; 4]; 4] = [[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]];
    (BAYER[y & 3][x & 3] as f32 + 0.5) / 16.0
}

/// `count + 1` split distances from `near` to `far` (the first `near`, the last `far`) by
/// `split`; practical splits weigh the logarithmic one by `lambda`.
pub fn split_distances(near: f32, far: f32, count: u32, split: Split, lambda: f32) -> Vec<f32> {
    let c = count.max(1) as f32;
    (0..=count.max(1))
        .map(|i| {
            let t = i as f32 / c;
            // RTR eq. 7.5: the logarithmic split.
            let log = near * crate::math::powf(far / near, t);
            let uniform = near + (far - near) * t;
            match split {
                Split::Uniform => uniform,
                Split::Log => log,
                Split::Practical => lambda * log + (1.0 - lambda) * uniform,
            }
        })
        .enumerate()
        // The ends exactly (powf need not return them bit for bit).
        .map(|(i, d)| {
            if i == 0 {
                near
            } else if i as u32 == count.max(1) {
                far
            } else {
                d
            }
        })
        .collect()
}

/// The view range the cascades cover: the camera's near and far planes clamped to the view
/// depths of the scene's bounding box (no cascade spends its texels in front of the nearest
/// corner or beyond the farthest).
pub fn view_range(frame: &Frame) -> (f32, f32) {
    let cam = &frame.camera;
    let plane = depth_plane(frame);
    let (near, far) = match frame.scene.bounds() {
        Some((lo, hi)) => {
            let d = corners(lo, hi).map(|c| crate::math::dot4(plane, c.extend(1.0)));
            let (a, b) = d.iter().fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(*x), b.max(*x)));
            (a.max(cam.near).min(cam.far), b.min(cam.far))
        }
        None => (cam.near, cam.far),
    };
    (near, far.max(near * 1.001))
}

/// The camera's view-depth plane of `frame` ([`Slice::plane`]).
pub fn depth_plane(frame: &Frame) -> Vec4 {
    // View space looks down -z: the depth is minus the view matrix's third row.
    -frame.camera.view().row(2)
}

/// The eight world corners of the camera frustum between view depths `d0` and `d1`.
pub fn slice_corners(frame: &Frame, d0: f32, d1: f32) -> [Vec3; 8] {
    let cam = &frame.camera;
    let inv = crate::math::inverse(&cam.view());
    let ty = crate::math::tan(cam.fov_deg.to_radians() * 0.5);
    let tx = ty * cam.width as f32 / cam.height.max(1) as f32;
    std::array::from_fn(|i| {
        let d = if i & 4 == 0 { d0 } else { d1 };
        let x = if i & 1 == 0 { -tx } else { tx } * d;
        let y = if i & 2 == 0 { -ty } else { ty } * d;
        inv.transform_point3(Vec3::new(x, y, -d))
    })
}

/// The views of `count` cascades of `frame`'s directional light at `size` texels
/// ([`Cascades`]; stable fitting with `snap`), with per-cascade casters.
/// With `samples` (SDSM, [`Cascades::partition`] other than view) the range is the depths
/// the camera sees, and with a histogram each cascade is fitted to the occupied part of its
/// slice.
pub fn cascade_fit(frame: &Frame, size: u32, c: &Cascades, snap: bool, samples: Option<&DepthSamples>) -> Fit {
    let light = &frame.light;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let diameter = (hi - lo).length().max(1e-3);
    // A light space anchored at the world origin, so that snapping has a fixed grid.
    let lv = Mat4::look_at_rh(Vec3::ZERO, light.direction, up_for(light.direction));
    let boxed = |pts: &[Vec3]| {
        pts.iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| {
                let q = lv.transform_point3(*p);
                (a.min(q), b.max(q))
            })
    };
    let (slo, shi) = boxed(&corners(lo, hi));
    let objects: Vec<Option<(Vec3, Vec3)>> = frame
        .scene
        .objects
        .iter()
        .map(|o| o.mesh.bounds().map(|(a, b)| boxed(&corners(a, b))))
        .collect();
    let samples = samples.filter(|_| c.partition != Partition::View);
    let (near, far) = match samples {
        // The depths seen, within the camera's planes (a margin of a thousandth for the
        // rounding of the reduction).
        Some(s) => {
            let cam = &frame.camera;
            let near = (s.near * 0.999).max(cam.near).min(cam.far);
            (near, (s.far * 1.001).min(cam.far).max(near * 1.001))
        }
        None => view_range(frame),
    };
    let splits = split_distances(near, far, c.count, c.split, c.lambda);
    let plane = depth_plane(frame);
    let margin = diameter * 1e-3;
    let mut views = Vec::with_capacity(c.count as usize);
    let mut per_view = Vec::with_capacity(c.count as usize);
    for i in 0..c.count as usize {
        // The slice's corners; with a histogram, of the part of it where samples are.
        let (d0, d1) = samples
            .and_then(|s| s.occupied(splits[i], splits[i + 1]))
            .unwrap_or((splits[i], splits[i + 1]));
        let cs = slice_corners(frame, d0, d1);
        let (clo, chi) = boxed(&cs);
        // Receivers: the slice within the scene's depth range from the light.
        let (mut rz0, mut rz1) = (clo.z.max(slo.z), chi.z.min(shi.z));
        let (x0, x1, y0, y1) = if snap {
            // The slice's bounding sphere: its radius does not change as the camera turns;
            // rounded up to 1/16 of an octave against rounding noise, and its centre on whole
            // texels of the fixed light space.
            let center = cs.iter().copied().sum::<Vec3>() / 8.0;
            let r = cs
                .iter()
                .map(|p| (*p - center).length())
                .fold(0.0f32, f32::max)
                .max(1e-4);
            let r = crate::math::powf(2.0, (crate::math::log2(r) * 16.0).ceil() / 16.0);
            let texel = 2.0 * r / size as f32;
            let q = lv.transform_point3(center);
            let (cx, cy) = ((q.x / texel).floor() * texel, (q.y / texel).floor() * texel);
            // The depth range from the sphere too, on whole texels: a turning camera changes
            // neither the grid nor the depths stored.
            let cz = (q.z / texel).floor() * texel;
            (rz0, rz1) = ((cz - r).max(slo.z), (cz + r).min(shi.z));
            (cx - r, cx + r, cy - r, cy + r)
        } else {
            // The corners' box, clipped to the scene's.
            let x0 = clo.x.max(slo.x) - margin;
            let x1 = chi.x.min(shi.x) + margin;
            let y0 = clo.y.max(slo.y) - margin;
            let y1 = chi.y.min(shi.y) + margin;
            if x1 > x0 && y1 > y0 {
                (x0, x1, y0, y1)
            } else {
                (clo.x, chi.x, clo.y, chi.y)
            }
        };
        if rz0 > rz1 {
            (rz0, rz1) = (slo.z, shi.z);
        }
        // Casters: objects whose light-space box meets the slice's outline seen from the light
        // (the convex hull of its corners, within the cascade's rectangle) and that are not
        // wholly beyond its receivers (light space looks down -z: larger z is nearer the
        // light). Shadows fall along the light's axis, so an object outside that outline
        // shadows nothing of the slice.
        let hull = convex_hull(&cs.map(|c| {
            let q = lv.transform_point3(c);
            Vec2::new(q.x, q.y)
        }));
        let keep: Vec<bool> = objects
            .iter()
            .map(|b| {
                b.is_some_and(|(a, b)| {
                    a.x <= x1
                        && b.x >= x0
                        && a.y <= y1
                        && b.y >= y0
                        && b.z >= rz0
                        && rect_meets_polygon(Vec2::new(a.x, a.y), Vec2::new(b.x, b.y), &hull)
                })
            })
            .collect();
        let top = objects
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .filter_map(|(b, _)| b.map(|(_, b)| b.z))
            .fold(rz1, f32::max);
        let (zn, zf) = (-top - margin, -rz0 + margin);
        views.push(LightView {
            matrix: Mat4::orthographic_rh(x0, x1, y0, y1, zn, zf) * lv,
            texel: (x1 - x0).max(y1 - y0) / size as f32,
            kind: ViewKind::Cascade(Slice {
                plane,
                near: splits[i],
                far: splits[i + 1],
                by_bounds: c.select == Select::Bounds,
            }),
        });
        per_view.push(keep);
    }
    let casters: Vec<bool> = (0..objects.len()).map(|o| per_view.iter().any(|k| k[o])).collect();
    let culled = per_view.iter().map(|k| k.iter().filter(|k| !**k).count()).sum();
    Fit {
        views,
        casters,
        culled,
        fitted: None,
        per_view,
    }
}

/// The convex hull of `pts`, counter-clockwise (Andrew's monotone chain); collinear points
/// dropped.
pub fn convex_hull(pts: &[Vec2]) -> Vec<Vec2> {
    let mut p = pts.to_vec();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<Vec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        for k in 0..p.len() {
            let q = if pass == 0 { p[k] } else { p[p.len() - 1 - k] };
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// Whether the axis-aligned rectangle `lo..hi` meets the convex polygon `poly`
/// (counter-clockwise; separating axes: the rectangle's and the polygon's edge normals). A
/// polygon of fewer than three points is taken as meeting everything.
pub fn rect_meets_polygon(lo: Vec2, hi: Vec2, poly: &[Vec2]) -> bool {
    if poly.len() < 3 {
        return true;
    }
    let (plo, phi) = poly
        .iter()
        .fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    if plo.x > hi.x || phi.x < lo.x || plo.y > hi.y || phi.y < lo.y {
        return false;
    }
    let rect = [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)];
    (0..poly.len()).all(|i| {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        // Outward normal of a counter-clockwise edge: the rectangle is outside when every
        // corner lies beyond the edge.
        let n = Vec2::new(b.y - a.y, a.x - b.x);
        rect.iter().any(|c| (*c - a).dot(n) <= 0.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_follow_their_schemes() {
        let u = split_distances(1.0, 101.0, 4, Split::Uniform, 0.5);
        assert_eq!(u, vec![1.0, 26.0, 51.0, 76.0, 101.0]);
        let l = split_distances(1.0, 16.0, 4, Split::Log, 0.5);
        for (a, b) in l.iter().zip([1.0f32, 2.0, 4.0, 8.0, 16.0]) {
            assert!((a - b).abs() < 1e-4 * b, "{l:?}");
        }
        // Practical: the lambda blend, between the two, with exact ends.
        let p = split_distances(1.0, 16.0, 4, Split::Practical, 0.9);
        let u = split_distances(1.0, 16.0, 4, Split::Uniform, 0.0);
        for i in 0..5 {
            let want = 0.9 * l[i] + 0.1 * u[i];
            assert!((p[i] - want).abs() < 1e-4 * want, "{p:?}");
        }
        assert_eq!((p[0], p[4]), (1.0, 16.0));
        assert_eq!(split_distances(0.5, 9.0, 1, Split::Log, 0.5), vec![0.5, 9.0]);
        // Increasing for any lambda.
        for lambda in [0.0, 0.25, 1.0] {
            let s = split_distances(0.1, 200.0, 8, Split::Practical, lambda);
            assert!(s.windows(2).all(|w| w[0] < w[1]), "{s:?}");
        }
    }

    #[test]
    fn the_dither_thresholds_cover_the_unit_interval() {
        let mut t: Vec<f32> = (0..16).map(|i| dither_threshold(i % 4, i / 4)).collect();
        t.sort_by(f32::total_cmp);
        for (i, v) in t.iter().enumerate() {
            assert_eq!(*v, (i as f32 + 0.5) / 16.0);
        }
        assert_eq!(dither_threshold(5, 6), dither_threshold(1, 2));
    }

    #[test]
    fn rectangles_meet_the_hull_of_a_slice() {
        let pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(4.0, 0.0),
            Vec2::new(2.0, 1.0),
            Vec2::new(0.0, 4.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(2.0, 0.0),
        ];
        let hull = convex_hull(&pts);
        assert_eq!(
            hull,
            vec![Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0), Vec2::new(0.0, 4.0)]
        );
        // Inside, over an edge, containing the triangle; beyond the hypotenuse, beside.
        assert!(rect_meets_polygon(Vec2::new(0.5, 0.5), Vec2::new(1.0, 1.0), &hull));
        assert!(rect_meets_polygon(Vec2::new(1.5, 1.5), Vec2::new(3.0, 3.0), &hull));
        assert!(rect_meets_polygon(Vec2::new(-1.0, -1.0), Vec2::new(5.0, 5.0), &hull));
        assert!(!rect_meets_polygon(Vec2::new(2.5, 2.5), Vec2::new(3.0, 3.0), &hull));
        assert!(!rect_meets_polygon(Vec2::new(5.0, 0.0), Vec2::new(6.0, 1.0), &hull));
        // Touching a corner counts.
        assert!(rect_meets_polygon(Vec2::new(4.0, -1.0), Vec2::new(5.0, 0.0), &hull));
    }
}
