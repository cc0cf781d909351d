//! Perspective warping of a directional light's map (RTR 7.4.1, fig. 7.15): a perspective
//! transform that spends more texels near the eye, shared by LiSPSM (Wimmer et al. 2004),
//! TSM (Martin and Tan 2004), PSM (Stamminger and Drettakis 2002; see
//! [Perspective shadow maps](#perspective-shadow-maps) below) and LogPSM (Lloyd et al. 2008:
//! LiSPSM's space with logarithmic rows, [`LogRows`]).
//!
//! Light space: `y` points to the light, `z` along the view direction projected onto the
//! plane perpendicular to the light (the warp axis), `x = light direction × z`. A
//! perspective frustum looks down `z` from a centre of projection `P` at distance `n` before
//! the body it covers (the camera's view range, clipped to the scene); after its divide the
//! light's rays (constant `x`, `z`) stay parallel, so an orthographic map of that space along
//! `y` is a shadow map whose texels shrink towards `P`, i.e. towards the eye. The map's `u`
//! is the post-perspective `x`, its `v` the post-perspective `z`, its depth the
//! post-perspective `y` (Wimmer et al. 2004, section 4). Along one light ray the divide is
//! the same, so depth comparisons within a texel are exact; across texels the depth scale
//! changes, so no technique that unprojects depths takes a warp.
//!
//! The light-space warps differ only in `P` and `n` (and LogPSM's rows):
//! - LiSPSM: `P` under the eye, `n_opt = (z_n + sqrt(z_n z_f)) / sin(gamma)` (Wimmer et al.
//!   2004, section 5: the `n` that spreads the error evenly over the view range `z_n .. z_f`;
//!   `gamma` the angle between the view and light directions, so the warp fades as the view
//!   turns towards the light), times an option `n_scale`.
//! - TSM: `P` on the centre line through the near plane's centre; `n` the trapezoid's `eta`
//!   that maps the focus point (`focus` of the view range past the near plane) to the 80 %
//!   line `xi = -0.6` of the map (Martin and Tan 2004, section 4):
//!   `eta = (lambda delta' + lambda delta' xi) / (lambda - 2 delta' - lambda xi)`, with
//!   `lambda` the trapezoid's height and `delta'` the focus point's distance from its top.
//! - LogPSM: `P` under the eye, `n = z_n / sin(gamma)` over the depths seen (LiSPSM's
//!   `n_opt` without the `sqrt(z_n z_f)` term: the logarithmic rows spread the error along
//!   the view instead), or `P` at the eye where the body lies wholly ahead of it and nearer;
//!   the map's `v` is `1 - ln(w / n) / ln(f / n)` ([`LogRows`]), drawn at a sample table.
//!
//! Falls back to the orthographic map of the same body ([`WarpInfo::fallback`] says why)
//! where the parameterization degenerates: the light along the view direction (no warp
//! axis), a focus region already past the 80 % line, or a camera frustum that misses the
//! scene (the map then covers the scene).
//!
//! # Perspective shadow maps
//! PSM renders the map in the camera's post-perspective space (Stamminger and Drettakis 2002,
//! section 3): after the camera's projection `C` the view frustum is the unit cube, and the
//! directional light, the point at infinity `(-d, 0)`, becomes the point `l = C (-d, 0)`. With
//! `l.w > 0` (the light ahead of the viewer) it is a point light at `L = l.xyz / l.w`, on the
//! plane that the camera's infinity maps to; with `l.w < 0` (the light behind the viewer) the
//! rays towards it cross the camera's eye plane and come back from the far side, so seen from
//! `L` an occluder lies *beyond* what it shadows: the light is inverted and the stored depth
//! reversed (section 4); with `l.w = 0` (the light across the view) it stays directional and
//! the map is orthographic along `-l.xyz`. The map is the perspective from `L` fitted to the
//! view's body in that space (the frustum between the nearest and farthest depths seen, by
//! the depth reduction: a distant near plane is what keeps `L` away from the body), and one
//! matrix `M_light C` takes a world point to it, so the lookup is the plain map's.
//!
//! Casters behind the eye have `w < 0` in that space: they are clipped, and their shadows
//! lost. Kozlov's fix (GPU Gems, ch. 14) moves the virtual camera back along the view by
//! `shift` until every caster that can shadow the view lies at least half the new near
//! distance in front of it (`shift = max(0, z_n - 2 z_min)`, `z_min` the casters' least view
//! depth), the near and far planes moved with it. Its price: a farther near plane weakens
//! the warp (the ratio `far / near` falls), so the texels near the eye grow. Where the light's
//! position in that space comes too close to the body for one frustum (measured: the light
//! ahead of the viewer within about the field of view; behind it, the inverted frustum still
//! held on the fixtures; Stamminger and Drettakis use a cube map there), the map falls back
//! to the orthographic one and says so.

use super::cascades::{convex_hull, depth_plane, slice_corners, view_range};
use super::sdsm::DepthSamples;
use super::{corners, up_for, Fit, LightView, ViewKind};
use crate::choice_enum;
use crate::error::Reason;
use crate::frame::Frame;
use crate::shadow::options::Field;
use glam::{Mat4, Vec2, Vec3, Vec4};

choice_enum! {
    /// Which warp sets the centre of projection and `n`.
    pub enum WarpKind {
        /// Light space perspective shadow maps (Wimmer et al. 2004), `n_opt`.
        Lispsm = "lispsm",
        /// Trapezoidal shadow maps (Martin and Tan 2004), the 80 % rule.
        Tsm = "tsm",
        /// Perspective shadow maps (Stamminger and Drettakis 2002): the map of the camera's
        /// post-perspective space.
        Psm = "psm",
        /// Logarithmic perspective shadow maps (Lloyd et al. 2008): LiSPSM's light space with
        /// logarithmic rows, drawn by logarithmic rasterization.
        Logpsm = "logpsm",
    }
}

/// TSM's 80 % line: the focus point's post-perspective coordinate (Martin and Tan 2004).
pub const TSM_XI: f32 = -0.6;

/// Below this sine of the angle between view and light directions the warp axis is
/// undefined and the map falls back to the orthographic one (about 0.57 degrees).
pub const MIN_SIN_GAMMA: f32 = 0.01;

/// PSM: the widest half-angle (its tangent) of the light's frustum in post-perspective space
/// before the map falls back (about 72 degrees: past it a single map's texels stretch
/// too unevenly, and at 90 it cannot hold the body).
pub const PSM_MAX_TAN: f32 = 3.0;

/// Settings of a warp.
#[derive(Clone, Debug, PartialEq)]
pub struct Warp {
    /// The warp. Default: LiSPSM.
    pub kind: WarpKind,
    /// LiSPSM: factor on `n_opt` (1: the paper's; larger: a weaker warp, towards the
    /// orthographic map; smaller: more texels near the eye, fewer far away). LogPSM: factor
    /// on its `n` (`z_n / sin(gamma)`, or the eye's distance before the body where nearer).
    /// Default: 1.
    pub n_scale: f32,
    /// TSM: the focus point's distance past the near plane, as a fraction of the view range;
    /// the region up to it takes 80 % of the map. Default: 0.5.
    pub focus: f32,
    /// PSM: move the virtual camera back until the casters behind the eye are in front of it
    /// (Kozlov's fix). Default: true.
    pub shift: bool,
}

impl Default for Warp {
    fn default() -> Self {
        Warp {
            kind: WarpKind::Lispsm,
            n_scale: 1.0,
            focus: 0.5,
            shift: true,
        }
    }
}

impl Warp {
    /// LiSPSM's field (`n_scale`).
    pub fn lispsm_fields() -> Vec<Field<Warp>> {
        vec![Field::range(
            "n_scale",
            "factor on LiSPSM's n_opt (1: the paper's; larger: weaker warp, towards the uniform map)",
            0.01,
            100.0,
            |w: &mut Warp| &mut w.n_scale,
        )]
    }

    /// LogPSM's field (`n_scale`).
    pub fn logpsm_fields() -> Vec<Field<Warp>> {
        vec![Field::range(
            "n_scale",
            "factor on LogPSM's n (z_n / sin(gamma), or the centre of projection at the eye; larger: weaker perspective, fewer texels near the eye, more far away)",
            0.01,
            100.0,
            |w: &mut Warp| &mut w.n_scale,
        )]
    }

    /// TSM's field (`focus`).
    pub fn tsm_fields() -> Vec<Field<Warp>> {
        vec![Field::range(
            "focus",
            "TSM: focus distance past the near plane, as a fraction of the view range; it takes 80 % of the map",
            0.01,
            0.99,
            |w: &mut Warp| &mut w.focus,
        )]
    }

    /// PSM's field (`shift`).
    pub fn psm_fields() -> Vec<Field<Warp>> {
        vec![Field::new(
            "shift",
            "PSM: move the virtual camera back so casters behind the eye are in front of it (Kozlov); false: their shadows are lost",
            |w: &mut Warp| &mut w.shift,
        )]
    }
}

/// What the last warp fitted: its parameters, for `counters`, `inspect` and `notes`.
#[derive(Clone, Debug, PartialEq)]
pub struct WarpInfo {
    /// The warp asked for.
    pub kind: WarpKind,
    /// Angle between the view and light directions, in degrees.
    pub gamma_deg: f32,
    /// Distance from the centre of projection to the body's near side (infinite: no warp).
    pub n: f32,
    /// The body's extent along the warp axis (the frustum's depth).
    pub depth: f32,
    /// Why the map fell back to the orthographic one, if it did.
    pub fallback: Option<String>,
    /// PSM: its post-perspective space (also where it fell back: the range and shift).
    pub psm: Option<PsmInfo>,
    /// PSM and LogPSM: milliseconds of the depth reduction that found the depths seen.
    pub reduce_ms: Option<f64>,
    /// LogPSM: its rows (`None` where it fell back to the orthographic map).
    pub log: Option<LogRows>,
    /// LogPSM: `n` was raised to keep the farthest rows [`LOG_MIN_ROW_GAP`] apart (a view
    /// range too deep for the rasterizer's precision), from this value.
    pub log_limited: Option<f32>,
}

/// What PSM fitted in the camera's post-perspective space.
#[derive(Clone, Debug, PartialEq)]
pub struct PsmInfo {
    /// Least view depth the map covers (the nearest depth seen).
    pub near: f32,
    /// Greatest view depth the map covers.
    pub far: f32,
    /// How far the virtual camera moved back along the view (world units; 0: not moved).
    pub shift: f32,
    /// The light behind the viewer: beyond the plane at infinity, depths reversed.
    pub inverted: bool,
    /// The light across the view: directional in that space too, the map orthographic.
    pub parallel: bool,
    /// Casters that reach behind the virtual camera's eye plane (clipped: their shadows lost).
    pub behind: usize,
}

/// The light space of a warp: unit axes `x`, `y` (to the light) and `z` (the warp axis).
#[derive(Copy, Clone, Debug)]
struct Basis {
    x: Vec3,
    y: Vec3,
    z: Vec3,
}

impl Basis {
    fn of(&self, p: Vec3) -> Vec3 {
        Vec3::new(self.x.dot(p), self.y.dot(p), self.z.dot(p))
    }
}

/// The angle between the view direction and the light's.
struct Angle {
    /// Its sine.
    sin_g: f32,
    /// In degrees.
    gamma_deg: f32,
}

/// A warp's light space for `frame`'s directional light and the view's `forward` direction:
/// `z` the view direction projected across the light (the warp axis), `y` towards the light.
/// With the light along the view's line there is no warp axis: a fall-back axis, and why.
fn warp_basis(frame: &Frame, forward: Vec3) -> (Basis, Angle, Option<String>) {
    let d = frame.light.direction.normalize_or_zero();
    let cos_g = forward.dot(d).clamp(-1.0, 1.0);
    let sin_g = (1.0 - cos_g * cos_g).max(0.0).sqrt();
    let gamma_deg = crate::math::acos(cos_g).to_degrees();
    let mut fallback = None;
    let axis = forward - d * cos_g;
    let z = if sin_g >= MIN_SIN_GAMMA {
        axis.normalize()
    } else {
        fallback = Some(format!(
            "the light is {:.2} degrees off the view direction's line: no warp axis, so the orthographic map of the view",
            gamma_deg.min(180.0 - gamma_deg)
        ));
        let u = up_for(d);
        (u - d * u.dot(d)).normalize()
    };
    let basis = Basis {
        x: d.cross(z),
        y: -d,
        z,
    };
    (basis, Angle { sin_g, gamma_deg }, fallback)
}

/// The objects that can shadow the warp's body: their light-space box meets the body's
/// rectangle `x` (across) by `z` (along the warp axis) and reaches above its bottom `y0`
/// (shadows fall along y).
fn casters_over(frame: &Frame, basis: &Basis, (lo, hi): (Vec2, Vec2), (z0, z1): (f32, f32), y0: f32) -> Vec<bool> {
    frame
        .scene
        .objects
        .iter()
        .map(|o| {
            o.mesh.bounds().is_some_and(|(a, b)| {
                let (ca, cb) = corners(a, b)
                    .iter()
                    .map(|c| basis.of(*c))
                    .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(p, q), c| {
                        (p.min(c), q.max(c))
                    });
                ca.x <= hi.x && cb.x >= lo.x && ca.z <= z1 && cb.z >= z0 && cb.y >= y0
            })
        })
        .collect()
}

/// A warped view of `frame`'s directional light at `size` texels ([`Warp`]; see the module
/// docs), with the casters that can shadow the body. PSM covers the view depths of
/// `samples` (the depth reduction's) where given.
pub fn warp_fit(frame: &Frame, size: u32, w: &Warp, samples: Option<&DepthSamples>) -> (Fit, WarpInfo) {
    let forward = depth_plane(frame).truncate().normalize_or_zero();
    let (basis, Angle { sin_g, gamma_deg }, mut fallback) = warp_basis(frame, forward);
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let scene: Vec<Vec3> = corners(lo, hi).iter().map(|c| basis.of(*c)).collect();
    let (slo, shi) = scene
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), q| {
            (a.min(*q), b.max(*q))
        });
    let (near, far) = view_range(frame);
    // LogPSM covers the depths seen (the reduction's, padded by a hundredth), where given.
    let (near, far) = match (w.kind, samples) {
        (WarpKind::Logpsm, Some(s)) if s.far > s.near => ((s.near * 0.99).max(near), (s.far * 1.01).min(far)),
        _ => (near, far),
    };
    let frustum = slice_corners(frame, near, far).map(|c| basis.of(c));
    // The body seen from the light: the frustum's outline clipped to the scene's.
    let outline = convex_hull(&frustum.map(|q| Vec2::new(q.x, q.z)));
    let mut body = clip_to_rect(&outline, Vec2::new(slo.x, slo.z), Vec2::new(shi.x, shi.z));
    let mut y0 = frustum.iter().map(|q| q.y).fold(f32::MAX, f32::min).max(slo.y);
    if body.len() < 3 {
        fallback = Some("the camera frustum misses the scene: the map covers the scene".into());
        body = vec![
            Vec2::new(slo.x, slo.z),
            Vec2::new(shi.x, slo.z),
            Vec2::new(shi.x, shi.z),
            Vec2::new(slo.x, shi.z),
        ];
        y0 = slo.y;
    }
    let (blo, bhi) = body
        .iter()
        .fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(a, b), q| {
            (a.min(*q), b.max(*q))
        });
    let diameter = (hi - lo).length().max(1e-3);
    let margin = diameter * 1e-3;
    let (z0, z1) = (blo.y - margin, bhi.y + margin);
    let lambda = z1 - z0;
    // Casters up to the scene's top; receivers down to the body's bottom.
    let (y0, y1) = (y0.min(shi.y) - margin, shi.y + margin);
    let eye = basis.of(frame.camera.position);
    // Casters: objects whose light-space box meets the body's rectangle and reaches above its
    // bottom (shadows fall along y).
    let mut keep = casters_over(
        frame,
        &basis,
        (blo - Vec2::splat(margin), bhi + Vec2::splat(margin)),
        (z0, z1),
        y0,
    );
    // PSM has no light-space `n`: its matrix comes from `psm_matrix` below.
    let (n, px) = if fallback.is_some() {
        (f32::INFINITY, eye.x)
    } else {
        match w.kind {
            WarpKind::Lispsm => ((near + (near * far).sqrt()) / sin_g * w.n_scale, eye.x),
            // LiSPSM's n_opt without its sqrt(z_n z_f) term (the logarithm spreads the rows
            // along the view instead), or the centre of projection at the eye where the body
            // lies ahead of the eye and nearer than that.
            WarpKind::Logpsm => {
                let base = near / sin_g;
                let at_eye = z0 - eye.z;
                ((if at_eye > 0.0 { base.min(at_eye) } else { base }) * w.n_scale, eye.x)
            }
            WarpKind::Tsm => {
                let top = basis.of(frame.camera.position + forward * near);
                let focus = basis.of(frame.camera.position + forward * (near + w.focus * (far - near)));
                let dp = (focus.z - z0).clamp(lambda * 1e-4, lambda);
                let den = lambda - 2.0 * dp - lambda * TSM_XI;
                if den <= lambda * 1e-4 {
                    fallback = Some(format!(
                        "the focus point lies {:.0} % of the way down the trapezoid, past the 80 % line: no warp",
                        100.0 * dp / lambda
                    ));
                    (f32::INFINITY, top.x)
                } else {
                    ((lambda * dp + lambda * dp * TSM_XI) / den, top.x)
                }
            }
            WarpKind::Psm => (f32::INFINITY, eye.x),
        }
    };
    let n = if n.is_finite() && n < lambda * 1e5 {
        n
    } else {
        f32::INFINITY
    };
    // LogPSM: rows far enough apart for the rasterizer's precision.
    let mut log_limited = None;
    let n = if w.kind == WarpKind::Logpsm && n.is_finite() {
        let least = LogRows::least_n(lambda);
        if n < least {
            log_limited = Some(n);
        }
        n.max(least)
    } else {
        n
    };
    let orthographic = || orthographic_matrix(&basis, (blo.x - margin, bhi.x + margin), (z0, z1), (y0, y1));
    let mut psm = None;
    let (matrix, n) = if w.kind == WarpKind::Psm {
        // The depths seen (padded by a hundredth), else the view range.
        let range = samples.map_or((near, far), |s| (s.near * 0.99, s.far * 1.01));
        let fit = psm_matrix(frame, w, range, &basis);
        keep = fit.casters;
        psm = Some(fit.info);
        match (fallback.is_none(), fit.matrix) {
            (true, Ok((m, n))) => (m, n),
            (_, Err(why)) if fallback.is_none() => {
                fallback = Some(why.0);
                (orthographic(), f32::INFINITY)
            }
            _ => (orthographic(), f32::INFINITY),
        }
    } else if n.is_finite() {
        (
            perspective_matrix(&basis, &body, Vec3::new(px, 0.0, z0 - n), n, lambda, (y0, y1), margin),
            n,
        )
    } else {
        (orthographic(), n)
    };
    let log = (w.kind == WarpKind::Logpsm && n.is_finite()).then(|| LogRows::new(n, n + lambda));
    let view = LightView {
        matrix,
        texel: 1.0 / size as f32,
        kind: ViewKind::Warped { log },
    };
    let fit = Fit {
        views: vec![view],
        culled: keep.iter().filter(|k| !**k).count(),
        casters: keep,
        fitted: Some(view),
        per_view: Vec::new(),
    };
    let info = WarpInfo {
        kind: w.kind,
        gamma_deg,
        n,
        depth: lambda,
        fallback,
        psm,
        reduce_ms: None,
        log,
        log_limited: log_limited.filter(|_| log.is_some()),
    };
    (fit, info)
}

/// PSM's matrix, or why it cannot be fitted, and what it found.
struct PsmFit {
    /// World to map, and the virtual near distance (the warp's `n`).
    matrix: Result<(Mat4, f32), Reason>,
    info: PsmInfo,
    /// Per object: whether part of it can shadow the view.
    casters: Vec<bool>,
}

/// A linear form on homogeneous points `h`: `e . (h.xyz - origin h.w)`.
fn form(e: Vec3, origin: Vec3) -> Vec4 {
    e.extend(-e.dot(origin))
}

/// The vertices of the convex body `frustum ∩ box`, for the frustum slice with corners `f`
/// ([`slice_corners`] order: bit 0 x, bit 1 y, bit 2 depth) and the box `lo .. hi`: the
/// corners of each inside the other and where the edges of each cross the faces of the
/// other.
pub fn frustum_box(f: &[Vec3; 8], lo: Vec3, hi: Vec3) -> Vec<Vec3> {
    let centre = f.iter().copied().sum::<Vec3>() / 8.0;
    let eps = (hi - lo).length().max(1e-3) * 1e-5;
    // The frustum's faces as planes (normal, offset), inside where n . p <= o.
    let planes: Vec<(Vec3, f32)> = [[0, 2, 4], [1, 3, 5], [0, 1, 4], [2, 3, 6], [0, 1, 2], [4, 5, 6]]
        .iter()
        .map(|[a, b, c]| {
            let n = (f[*b] - f[*a]).cross(f[*c] - f[*a]).normalize_or_zero();
            let n = if n.dot(centre - f[*a]) > 0.0 { -n } else { n };
            (n, n.dot(f[*a]))
        })
        .collect();
    let in_frustum = |p: Vec3| planes.iter().all(|(n, o)| n.dot(p) <= o + eps);
    let in_box = |p: Vec3| p.cmpge(lo - eps).all() && p.cmple(hi + eps).all();
    let boxed = corners(lo, hi);
    // Edges: corner pairs differing in one bit.
    let edges = |c: &[Vec3; 8]| {
        (0..8usize)
            .flat_map(|i| {
                [1usize, 2, 4]
                    .into_iter()
                    .filter(move |b| i & b == 0)
                    .map(move |b| (i, i | b))
            })
            .map(|(i, j)| (c[i], c[j]))
            .collect::<Vec<_>>()
    };
    let mut out: Vec<Vec3> = f.iter().copied().filter(|p| in_box(*p)).collect();
    out.extend(boxed.iter().copied().filter(|p| in_frustum(*p)));
    for (a, b) in edges(f) {
        for k in 0..3 {
            for bound in [lo[k], hi[k]] {
                let t = (bound - a[k]) / (b[k] - a[k]);
                let p = a + (b - a) * t;
                if (0.0..=1.0).contains(&t) && in_box(p) {
                    out.push(p);
                }
            }
        }
    }
    for (a, b) in edges(&boxed) {
        for (n, o) in &planes {
            let t = (o - n.dot(a)) / n.dot(b - a);
            let p = a + (b - a) * t;
            if (0.0..=1.0).contains(&t) && in_frustum(p) {
                out.push(p);
            }
        }
    }
    out
}

/// The sides of the prism over the convex polygon `hull` of light-space `(x, z)`
/// (counter-clockwise, grown by `margin`) above `y0`: planes `(n, o)`, inside where
/// `n . p + o >= 0`.
fn prism_sides(hull: &[Vec2], margin: f32, y0: f32) -> Vec<(Vec3, f32)> {
    let mut sides: Vec<(Vec3, f32)> = (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            let n = (b - a).perp().normalize_or_zero();
            (Vec3::new(n.x, 0.0, n.y), margin - n.dot(a))
        })
        .collect();
    sides.push((Vec3::Y, -y0));
    sides
}

/// The part of triangle `tri` inside the planes `sides` (Sutherland-Hodgman).
fn clip_to_prism(tri: [Vec3; 3], sides: &[(Vec3, f32)]) -> Vec<Vec3> {
    let mut out = tri.to_vec();
    for (n, o) in sides {
        if out.is_empty() {
            break;
        }
        let d = |q: Vec3| n.dot(q) + o;
        let input = std::mem::take(&mut out);
        for i in 0..input.len() {
            let (a, c) = (input[i], input[(i + 1) % input.len()]);
            let (da, dc) = (d(a), d(c));
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (dc >= 0.0) {
                out.push(a + (c - a) * (da / (da - dc)));
            }
        }
    }
    out
}

/// The PSM map (see the module docs) of view depths `near .. far`, in the light space
/// `basis`. Its receivers: the view frustum between those depths, clipped to the scene's
/// box. Its casters: each triangle's part above the receivers' bottom (towards the light)
/// and inside their outline seen from the light, so a ground plane behind the eye whose
/// shadows cannot reach the view moves nothing.
fn psm_matrix(frame: &Frame, w: &Warp, (near, far): (f32, f32), basis: &Basis) -> PsmFit {
    let cam = &frame.camera;
    let view = cam.view();
    let depth = |p: Vec3| -view.transform_point3(p).z;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let mut body = frustum_box(&slice_corners(frame, near, far), lo, hi);
    if body.len() < 4 {
        body = slice_corners(frame, near, far).to_vec();
    }
    let lit: Vec<Vec3> = body.iter().map(|p| basis.of(*p)).collect();
    // The body's bottom (its least height towards the light).
    let bottom = lit.iter().map(|q| q.y).fold(f32::MAX, f32::min);
    let margin = (hi - lo).length().max(1e-3) * 1e-3;
    let hull = convex_hull(&lit.iter().map(|q| Vec2::new(q.x, q.z)).collect::<Vec<_>>());
    // Each object's part that can shadow the body, in world space.
    let floor = bottom - margin;
    let sides = prism_sides(&hull, margin, floor);
    let parts = caster_parts(frame, basis, &sides);
    let z_min = parts.iter().flatten().map(|p| depth(*p)).fold(f32::MAX, f32::min);
    // Kozlov's shift: the nearest caster at least half the virtual near distance in front.
    let shift = if w.shift { (near - 2.0 * z_min).max(0.0) } else { 0.0 };
    let (vn, vf) = (near + shift, far + shift);
    let aspect = cam.width as f32 / cam.height.max(1) as f32;
    let c = Mat4::perspective_rh_gl(cam.fov_deg.to_radians(), aspect, vn, vf)
        * Mat4::from_translation(Vec3::new(0.0, 0.0, -shift))
        * view;
    // Post-perspective positions of points in front of the virtual eye.
    let pps = |p: Vec3| {
        let h = c * p.extend(1.0);
        (h.w > vn * 1e-4).then(|| h.truncate() / h.w)
    };
    let casters: Vec<bool> = parts.iter().map(|p| !p.is_empty()).collect();
    let behind = parts.iter().filter(|p| p.iter().any(|q| pps(*q).is_none())).count();
    let receivers: Vec<Vec3> = body.iter().filter_map(|p| pps(*p)).collect();
    let occluders: Vec<Vec3> = parts.iter().flatten().filter_map(|p| pps(*p)).collect();
    let l = c * (-frame.light.direction.normalize_or_zero()).extend(0.0);
    let centre = receivers.iter().copied().sum::<Vec3>() / receivers.len().max(1) as f32;
    let radius = receivers.iter().map(|r| (*r - centre).length()).fold(0.0, f32::max);
    let lxyz = l.truncate();
    let parallel = l.w.abs() * 1e3 * radius <= lxyz.length();
    let info = PsmInfo {
        near,
        far,
        shift,
        inverted: !parallel && l.w < 0.0,
        parallel,
        behind,
    };
    if receivers.len() < 4 || !radius.is_finite() || radius <= 0.0 || lxyz.length() == 0.0 {
        return PsmFit {
            matrix: Err("the view's body has no extent in post-perspective space".into()),
            info,
            casters,
        };
    }
    // Rows on the virtual camera's homogeneous clip coordinates.
    let rows = if parallel {
        parallel_rows(lxyz, radius, &receivers, &occluders)
    } else {
        let at = lxyz / l.w;
        let a = (centre - at).normalize();
        let s = |p: &Vec3| a.dot(*p - at);
        let s_min = receivers.iter().map(s).fold(f32::MAX, f32::min);
        let e1 = a.cross(up_for(a)).normalize();
        let e2 = a.cross(e1);
        let (mut ua, mut ub, mut va, mut vb) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        for r in &receivers {
            let q = *r - at;
            let (u, v) = (e1.dot(q) / s(r), e2.dot(q) / s(r));
            (ua, ub, va, vb) = (ua.min(u), ub.max(u), va.min(v), vb.max(v));
        }
        let widest = [ua, ub, va, vb].iter().fold(0.0f32, |m, x| m.max(x.abs()));
        if s_min <= radius * 1e-3 || widest > PSM_MAX_TAN {
            let angle = crate::math::atan(widest).to_degrees();
            return PsmFit {
                matrix: Err(format!(
                    "the light lies {} the view so near its axis that one frustum in post-perspective space would span {:.0} degrees: the orthographic map of the view",
                    if l.w < 0.0 { "behind" } else { "ahead of" },
                    if s_min <= radius * 1e-3 { 180.0 } else { 2.0 * angle }
                ).into()),
                info,
                casters,
            };
        }
        // Depths from the light: receivers, and casters on the side shadows come from
        // (nearer the light; farther from it when inverted).
        let mut s0 = s_min;
        let mut s1 = receivers.iter().map(s).fold(0.0, f32::max);
        for o in &occluders {
            let d = s(o);
            if d > 0.0 {
                (s0, s1) = (s0.min(d), s1.max(d));
            }
        }
        s0 = s0.max(s_min * 0.05);
        let (s0, s1) = (s0 * (1.0 - 1e-3), s1 * (1.0 + 1e-3));
        let pad_u = (ub - ua) * 1e-3;
        let pad_v = (vb - va) * 1e-3;
        let (ua, ub, va, vb) = (ua - pad_u, ub + pad_u, va - pad_v, vb + pad_v);
        let fa = form(a, at);
        // depth = A + B / s over [s0, s1] to [0, 1]; inverted: 1 - that.
        let (big_a, big_b) = (s1 / (s1 - s0), -s0 * s1 / (s1 - s0));
        let z = fa * big_a + Vec4::W * big_b;
        [
            form(e1, at) * (2.0 / (ub - ua)) - fa * ((ua + ub) / (ub - ua)),
            form(e2, at) * (2.0 / (vb - va)) - fa * ((va + vb) / (vb - va)),
            if l.w < 0.0 { fa - z } else { z },
            fa,
        ]
    };
    let m = Mat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose() * c;
    PsmFit {
        matrix: Ok((m, vn)),
        info,
        casters,
    }
}

/// Each object's part that can shadow PSM's body, in world space: a box wholly inside the
/// prism over the body's outline (`sides`, above its bottom) or wholly outside one of its
/// sides decides for the object; otherwise each triangle is clipped. Empty: no part.
fn caster_parts(frame: &Frame, basis: &Basis, sides: &[(Vec3, f32)]) -> Vec<Vec<Vec3>> {
    let to_world = |q: Vec3| basis.x * q.x + basis.y * q.y + basis.z * q.z;
    let outside = |q: &[Vec3]| sides.iter().any(|(n, o)| q.iter().all(|p| n.dot(*p) + o < 0.0));
    let inside = |q: &[Vec3]| sides.iter().all(|(n, o)| q.iter().all(|p| n.dot(*p) + o >= 0.0));
    frame
        .scene
        .objects
        .iter()
        .map(|o| {
            let m = &o.mesh;
            let Some((a, b)) = m.bounds() else {
                return Vec::new();
            };
            let boxed = corners(a, b).map(|c| basis.of(c));
            if outside(&boxed) {
                return Vec::new();
            }
            if inside(&boxed) {
                return corners(a, b).to_vec();
            }
            let mut part = Vec::new();
            for t in m.indices.chunks_exact(3) {
                let tri = [0, 1, 2].map(|k| basis.of(m.positions[t[k] as usize]));
                if outside(&tri) {
                    continue;
                }
                if inside(&tri) {
                    part.extend(tri.map(to_world));
                } else {
                    part.extend(clip_to_prism(tri, sides).into_iter().map(to_world));
                }
            }
            part
        })
        .collect()
}

/// PSM's rows where the light is directional in post-perspective space too (`lxyz`, its
/// direction there): orthographic along its travel, `-lxyz`, over the `receivers` (within
/// `radius` of their centre) and, in depth, the `occluders`.
fn parallel_rows(lxyz: Vec3, radius: f32, receivers: &[Vec3], occluders: &[Vec3]) -> [Vec4; 4] {
    let t = -lxyz.normalize();
    let e1 = t.cross(up_for(t)).normalize();
    let e2 = t.cross(e1);
    let range = |e: Vec3, pts: &mut dyn Iterator<Item = &Vec3>| {
        pts.fold((f32::MAX, f32::MIN), |(a, b), p| (a.min(e.dot(*p)), b.max(e.dot(*p))))
    };
    let (u0, u1) = range(e1, &mut receivers.iter());
    let (v0, v1) = range(e2, &mut receivers.iter());
    let (d0, d1) = range(t, &mut receivers.iter().chain(occluders));
    let pad = radius * 1e-3;
    let axis = |e: Vec3, a: f32, b: f32| {
        let (a, b) = (a - pad, b + pad);
        form(e, Vec3::ZERO) * (2.0 / (b - a)) - Vec4::W * ((a + b) / (b - a))
    };
    let (d0, d1) = (d0 - pad, d1 + pad);
    [
        axis(e1, u0, u1),
        axis(e2, v0, v1),
        (form(t, Vec3::ZERO) - Vec4::W * d0) / (d1 - d0),
        Vec4::W,
    ]
}

/// World to light space relative to `origin` (rows: the basis' axes).
fn light_space(b: &Basis, origin: Vec3) -> Mat4 {
    Mat4::from_cols(
        Vec4::new(b.x.x, b.y.x, b.z.x, 0.0),
        Vec4::new(b.x.y, b.y.y, b.z.y, 0.0),
        Vec4::new(b.x.z, b.y.z, b.z.z, 0.0),
        Vec4::new(-origin.x, -origin.y, -origin.z, 1.0),
    )
}

/// The orthographic map of the body: `u` along `x`, `v` along `z`, depth down from the light.
fn orthographic_matrix(b: &Basis, (x0, x1): (f32, f32), (z0, z1): (f32, f32), (y0, y1): (f32, f32)) -> Mat4 {
    let sx = 2.0 / (x1 - x0);
    let sz = 2.0 / (z1 - z0);
    let sy = 1.0 / (y1 - y0);
    // Rows of the map on light-space coordinates (x, y, z, 1).
    let a = Mat4::from_cols(
        Vec4::new(sx, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, -sy, 0.0),
        Vec4::new(0.0, sz, 0.0, 0.0),
        Vec4::new(-(x0 + x1) / (x1 - x0), -(z0 + z1) / (z1 - z0), y1 * sy, 1.0),
    );
    a * light_space(b, Vec3::ZERO)
}

/// The warped map: the perspective from `p` (light-space coordinates) down `z` over the
/// body's near `n` to `n + lambda`, then the orthographic map of its post-perspective box
/// (`u`: `x / z`, `v`: the perspective depth, depth: `y / z`, Wimmer et al. 2004 fig. 4).
fn perspective_matrix(
    b: &Basis,
    body: &[Vec2],
    p: Vec3,
    n: f32,
    lambda: f32,
    (y0, y1): (f32, f32),
    margin: f32,
) -> Mat4 {
    let f = n + lambda;
    // Post-perspective x over the body (the x / z extremes lie at the outline's vertices).
    let (mut xa, mut xb) = body.iter().fold((f32::MAX, f32::MIN), |(a, c), q| {
        let x = (q.x - p.x) / (q.y - p.z);
        (a.min(x), c.max(x))
    });
    let pad = (xb - xa).max(margin / f) * 1e-3;
    (xa, xb) = (xa - pad, xb + pad);
    // Post-perspective y over the depth range's corners (y / z is monotone in each).
    let (mut ya, mut yb) = [(y0, n), (y0, f), (y1, n), (y1, f)]
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, c), (y, z)| {
            let v = (y - p.y) / z;
            (a.min(v), c.max(v))
        });
    let pad = (yb - ya) * 1e-3;
    (ya, yb) = (ya - pad, yb + pad);
    // Homogeneous rows on light coordinates relative to p: clip x = x, clip y = y,
    // clip z = z (f + n) / (f - n) - 2 f n / (f - n) (z / w in [-1, 1] over [n, f]), w = z.
    let (zz, zw) = ((f + n) / (f - n), -2.0 * f * n / (f - n));
    let sx = 2.0 / (xb - xa);
    let tx = -(xa + xb) / (xb - xa);
    let sy = 1.0 / (yb - ya);
    // u = sx X + tx, v = Z, depth = (yb - Y) sy, each times w.
    let m = Mat4::from_cols(
        Vec4::new(sx, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, -sy, 0.0),
        Vec4::new(tx, zz, yb * sy, 1.0),
        Vec4::new(0.0, zw, 0.0, 0.0),
    );
    m * light_space(b, p)
}

/// The part of convex polygon `poly` inside the rectangle `lo .. hi` (Sutherland-Hodgman
/// against its four sides).
pub fn clip_to_rect(poly: &[Vec2], lo: Vec2, hi: Vec2) -> Vec<Vec2> {
    let mut out: Vec<Vec2> = poly.to_vec();
    // Each side as (axis, bound, keep-below).
    for (axis, bound, below) in [(0, lo.x, false), (0, hi.x, true), (1, lo.y, false), (1, hi.y, true)] {
        if out.is_empty() {
            break;
        }
        let inside = |q: Vec2| if below { q[axis] <= bound } else { q[axis] >= bound };
        let input = std::mem::take(&mut out);
        for i in 0..input.len() {
            let (a, c) = (input[i], input[(i + 1) % input.len()]);
            if inside(a) {
                out.push(a);
            }
            if inside(a) != inside(c) {
                let t = (bound - a[axis]) / (c[axis] - a[axis]);
                out.push(a + (c - a) * t);
            }
        }
    }
    out
}

/// World size of one texel of a warped view with matrix `m` (and LogPSM's `log` rows, if
/// any) at world point `p`, for a light along `dir` and texels of `uv_texel` in texture
/// coordinates: the texel's area on the plane perpendicular to the light is
/// `uv_texel² / |det J|`, `J` the Jacobian of the texture coordinate there, and its side the
/// square root (the geometric mean of the two axes).
pub fn texel_at(m: &Mat4, log: Option<&LogRows>, dir: Vec3, p: Vec3, uv_texel: f32) -> f32 {
    let c = *m * p.extend(1.0);
    let u = up_for(dir);
    let e1 = dir.cross(u).normalize_or_zero();
    let e2 = dir.normalize_or_zero().cross(e1);
    let derivative = |e: Vec3| {
        let dc = *m * e.extend(0.0);
        let d = Vec2::new(dc.x * c.w - c.x * dc.w, dc.y * c.w - c.y * dc.w) * (0.5 / (c.w * c.w));
        match log {
            // v = 1 - ln(w / n) / ln(f / n): dv = -(dw / w) / ln(f / n).
            Some(rows) => Vec2::new(d.x, -dc.w / c.w * rows.k),
            None => d,
        }
    };
    let (a, b) = (derivative(e1), derivative(e2));
    let det = (a.x * b.y - a.y * b.x).abs();
    let t = uv_texel / det.sqrt();
    if t.is_finite() && c.w > 0.0 {
        t
    } else {
        uv_texel
    }
}

/// LogPSM's rows (Lloyd et al. 2008): the map's `v` is `1 - ln(w / n) / ln(f / n)`, `w` the
/// distance along the warp axis from the centre of projection (the warped matrix's clip
/// `w`) over the body's `n .. f`, so each row covers the same ratio of distances, and the
/// texels' depth extent grows in proportion to the distance, as the camera's pixels do. The
/// map is drawn in the perspective warp's space (straight lines stay straight there) at a
/// sample table whose row `j` lies where that space puts the distance of row `j`'s centre
/// ([`LogRows::table`]): logarithmic rasterization, exact at the samples.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LogRows {
    /// Distance from the centre of projection to the body's near side.
    pub n: f32,
    /// Distance to the body's far side.
    pub f: f32,
    /// `1 / ln(f / n)`.
    pub k: f32,
}

/// LogPSM's rows must lie at least this far apart (window pixels) in the perspective space
/// they are drawn in (4 steps of the rasterizer's 1/256-pixel grid): the farthest rows are
/// the closest there, `n ln(f / n) / (f - n)` pixels apart, which bounds the ratio `f / n`
/// to about 380 ([`LogRows::least_n`]).
pub const LOG_MIN_ROW_GAP: f32 = 1.0 / 64.0;

impl LogRows {
    /// Rows over distances `n .. f` (`0 < n < f`).
    pub fn new(n: f32, f: f32) -> LogRows {
        LogRows {
            n,
            f,
            k: 1.0 / crate::math::ln(f / n),
        }
    }

    /// Texture `v` of a point at distance `w` (see the type's docs).
    #[inline(always)]
    pub fn v(&self, w: f32) -> f32 {
        1.0 - crate::math::ln(w / self.n) * self.k
    }

    /// Texture coordinate and depth of world point `p` through the warped matrix `m`: its
    /// `u` and depth as [`super::project`] gives them, its `v` from the logarithm of its
    /// clip `w`. `None` behind the centre of projection.
    #[inline]
    pub fn project(&self, m: &Mat4, p: Vec3) -> Option<(Vec2, f32)> {
        let c = *m * p.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let ndc = c / Vec4::splat(c.w);
        Some((Vec2::new(ndc.x * 0.5 + 0.5, self.v(c.w)), ndc.z))
    }

    /// The window y (pixels, y down, in the perspective warp's space of a `height`-row
    /// target) of each row's sample: row `j`'s centre `v_j = (j + 1/2) / height` lies at
    /// distance `w_j = n (f / n)^(1 - v_j)`, which the perspective puts at
    /// `y = (1 - ndc) height / 2`, `ndc = (f + n) / (f - n) - 2 f n / ((f - n) w_j)`.
    /// Increasing in `j`.
    pub fn table(&self, height: u32) -> Vec<f64> {
        let (n, f) = (self.n as f64, self.f as f64);
        let ratio = crate::math::ln_f64(f / n);
        (0..height)
            .map(|j| {
                let t = 1.0 - (j as f64 + 0.5) / height as f64;
                let w = n * crate::math::exp_f64(t * ratio);
                let ndc = (f + n) / (f - n) - 2.0 * f * n / ((f - n) * w);
                (1.0 - ndc) * 0.5 * height as f64
            })
            .collect()
    }

    /// The least `n` for a body `depth` deep whose rows keep [`LOG_MIN_ROW_GAP`] apart: the
    /// root of `n ln((n + depth) / n) / depth = LOG_MIN_ROW_GAP` (the left side increases with
    /// `n`), by bisection.
    pub fn least_n(depth: f32) -> f32 {
        let gap = |n: f32| n * crate::math::ln((n + depth) / n) / depth;
        let (mut lo, mut hi) = (depth * 1e-6, depth);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if gap(mid) < LOG_MIN_ROW_GAP {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_the_inside() {
        let square = [
            Vec2::new(-1.0, -1.0),
            Vec2::new(1.0, -1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(-1.0, 1.0),
        ];
        let c = clip_to_rect(&square, Vec2::new(0.0, -0.5), Vec2::new(2.0, 2.0));
        let area: f32 = (0..c.len())
            .map(|i| {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                a.x * b.y - a.y * b.x
            })
            .sum::<f32>()
            * 0.5;
        assert!((area.abs() - 1.5).abs() < 1e-5, "{area}");
        assert!(clip_to_rect(&square, Vec2::new(2.0, 2.0), Vec2::new(3.0, 3.0)).is_empty());
    }

    /// A warped map of a trapezoid body (x from ±5 at z = 1 to ±20 at z = 30, the light
    /// straight down, the warp axis along world x), its centre of projection `n` before the
    /// near side.
    fn trapezoid(n: f32) -> Mat4 {
        let b = Basis {
            x: Vec3::Z,
            y: Vec3::Y,
            z: Vec3::X,
        };
        let body = [
            Vec2::new(-5.0, 1.0),
            Vec2::new(5.0, 1.0),
            Vec2::new(20.0, 30.0),
            Vec2::new(-20.0, 30.0),
        ];
        perspective_matrix(&b, &body, Vec3::new(0.0, 0.0, 1.0 - n), n, 29.0, (-1.0, 10.0), 0.01)
    }

    #[test]
    fn texel_at_is_the_side_of_a_texel_on_the_plane_across_the_light() {
        // A warped matrix: a world square of the returned side, across the light, covers
        // one texel's area of the map.
        let dir = -Vec3::Y;
        let m = trapezoid(3.0);
        let size = 1024.0f32;
        // With LogPSM's rows over the same body (distances 3 .. 32 from the centre) too.
        let rows = LogRows::new(3.0, 32.0);
        for log in [None, Some(&rows)] {
            for p in [
                Vec3::new(2.0, 0.5, 0.0),
                Vec3::new(25.0, 3.0, -10.0),
                Vec3::new(10.0, 0.0, 8.0),
            ] {
                let t = texel_at(&m, log, dir, p, 1.0 / size);
                let u = up_for(dir);
                let e1 = dir.cross(u).normalize();
                let e2 = dir.cross(e1);
                let uv = |q: Vec3| match log {
                    None => super::super::project(&m, q).unwrap().0,
                    Some(r) => r.project(&m, q).unwrap().0,
                };
                let (a, c) = ((uv(p + e1 * t) - uv(p)) * size, (uv(p + e2 * t) - uv(p)) * size);
                let area = (a.x * c.y - a.y * c.x).abs();
                assert!((area - 1.0).abs() < 0.02, "{p} ({log:?}): {area} texels");
            }
        }
    }

    #[test]
    fn log_rows_put_each_row_centre_at_its_sample() {
        // A point at row j's sample (window y in the perspective space) has v at row j's
        // centre; rows are increasing and the farthest keep the least gap after raising n.
        let (n, depth) = (LogRows::least_n(29.0).max(0.5), 29.0);
        let m = trapezoid(n);
        let rows = LogRows::new(n, n + depth);
        let h = 512u32;
        let table = rows.table(h);
        assert!(table.windows(2).all(|p| p[1] > p[0]), "increasing");
        let gap = table.windows(2).map(|p| p[1] - p[0]).fold(f64::MAX, f64::min);
        assert!(gap >= LOG_MIN_ROW_GAP as f64 * 0.99, "least gap {gap}");
        let inv = crate::math::inverse(&m);
        for j in [0usize, 7, 200, 511] {
            // Unproject the window point (u = 0.5) at row j's sample, depth 0.5.
            let ndc_y = 1.0 - 2.0 * table[j] / h as f64;
            let q = inv * Vec4::new(0.0, ndc_y as f32, 0.5, 1.0);
            let (uv, _) = rows.project(&m, q.truncate() / q.w).unwrap();
            let want = (j as f32 + 0.5) / h as f32;
            assert!(
                (uv.y - want).abs() * (h as f32) < 2e-3,
                "row {j}: v {} against {want}",
                uv.y
            );
        }
        let least = LogRows::least_n(100.0);
        assert!(least > 100.0 / 400.0 && least < 100.0 / 360.0, "{least}");
    }

    #[test]
    fn frustum_box_is_the_intersections_corners() {
        // A box-shaped "frustum" over [0, 2]³ and the box [1, 3]³: their common part is
        // [1, 2]³, whose eight corners are among the vertices, all inside both.
        let f: [Vec3; 8] = corners(Vec3::ZERO, Vec3::splat(2.0));
        let v = frustum_box(&f, Vec3::ONE, Vec3::splat(3.0));
        for c in corners(Vec3::ONE, Vec3::splat(2.0)) {
            assert!(v.iter().any(|p| (*p - c).length() < 1e-5), "{c} missing from {v:?}");
        }
        assert!(v
            .iter()
            .all(|p| p.cmpge(Vec3::splat(1.0 - 1e-4)).all() && p.cmple(Vec3::splat(2.0 + 1e-4)).all()));
        // A box far away: nothing.
        assert!(frustum_box(&f, Vec3::splat(5.0), Vec3::splat(6.0)).is_empty());
        // A box holding the frustum: its corners.
        let all = frustum_box(&f, Vec3::splat(-1.0), Vec3::splat(3.0));
        assert!(f.iter().all(|c| all.contains(c)));
    }

    #[test]
    fn clipping_a_triangle_to_the_prism_keeps_the_inside() {
        let square = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ];
        let tri = [
            Vec3::new(-1.0, 1.0, 0.5),
            Vec3::new(2.0, 1.0, 0.5),
            Vec3::new(0.5, -1.0, 0.5),
        ];
        let c = clip_to_prism(tri, &prism_sides(&square, 0.0, 0.0));
        assert!(!c.is_empty());
        assert!(c.iter().all(|p| p.x >= -1e-6 && p.x <= 1.0 + 1e-6 && p.y >= -1e-6));
        // Entirely below the floor: nothing.
        assert!(clip_to_prism(tri, &prism_sides(&square, 0.0, 2.0)).is_empty());
    }

    #[test]
    fn tsm_eta_puts_the_focus_on_the_80_percent_line() {
        // The projective map along the centre line, 1 at the top, -1 at the base.
        for (lambda, dp) in [(10.0f32, 2.0f32), (3.0, 0.5), (100.0, 70.0)] {
            let eta = (lambda * dp + lambda * dp * TSM_XI) / (lambda - 2.0 * dp - lambda * TSM_XI);
            let b = 2.0 * eta * (lambda + eta) / lambda;
            let a = -(lambda + 2.0 * eta) / lambda;
            let at = |t: f32| a + b / (t + eta);
            assert!((at(0.0) - 1.0).abs() < 1e-4);
            assert!((at(lambda) + 1.0).abs() < 1e-4);
            assert!((at(dp) - TSM_XI).abs() < 1e-4, "{}", at(dp));
        }
    }
}
