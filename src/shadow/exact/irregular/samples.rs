//! Pass 1's samples: one per pixel (the G-buffer's point) or `k` per pixel at stratified
//! sub-pixel positions on the pixel's visible triangle, and which of them face the light.

use super::*;

/// A camera sample: the pixel it belongs to, its surface point and triangle.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CameraSample {
    /// Row-major pixel index.
    pub pixel: u32,
    /// The point on the pixel's visible triangle, and the pixel's normal.
    pub point: SamplePoint,
    /// Scene-wide id of the triangle visible at the pixel.
    pub triangle: u32,
}

/// The camera samples of `frame`, `k` per covered pixel (pixel-major, strata row by row):
/// with one sample, the G-buffer's point; with more, stratified sub-pixel camera rays
/// intersected with the triangle visible at the pixel (falling back to the G-buffer's point
/// where the ray passes beside that triangle or sees it edge-on).
pub fn camera_samples(frame: &Frame, k: SamplesPerPixel) -> Vec<CameraSample> {
    camera_samples_grid(frame, k.grid())
}

/// [`camera_samples`] on any `(columns, rows)` grid of sub-pixel strata (for supersampled
/// references: `(8, 8)` is 64 rays per pixel).
pub fn camera_samples_grid(frame: &Frame, grid: (usize, usize)) -> Vec<CameraSample> {
    let filler = SampleFiller {
        grid,
        ..SampleFiller::new(frame, SamplesPerPixel::One)
    };
    let w = frame.width() as usize;
    let mut out = Vec::new();
    for (y, row) in frame.points().chunks(w).enumerate() {
        let n = row.iter().filter(|p| p.is_some()).count() * grid.0 * grid.1;
        let start = out.len();
        out.resize(start + n, CameraSample::default());
        filler.row(y, &mut out[start..]);
    }
    out
}

/// Makes the samples of one row at a time (see [`camera_samples`]).
pub(super) struct SampleFiller<'a> {
    frame: &'a Frame<'a>,
    bases: Vec<u32>,
    grid: (usize, usize),
    inv: Mat4,
    eye: Vec3,
}

impl<'a> SampleFiller<'a> {
    pub(super) fn new(frame: &'a Frame<'a>, k: SamplesPerPixel) -> Self {
        SampleFiller {
            frame,
            bases: frame.scene.triangle_bases(),
            grid: k.grid(),
            inv: crate::math::inverse(&frame.camera.view_projection()),
            eye: frame.camera.position,
        }
    }

    /// The scene-wide id of the triangle visible at pixel `i`, or `u32::MAX`.
    #[inline]
    pub(super) fn triangle(&self, i: usize) -> u32 {
        self.frame.triangle_at(i, &self.bases).unwrap_or(u32::MAX)
    }

    /// The samples of row `y` into `out` (exactly as many as the row's covered pixels times k).
    pub(super) fn row(&self, y: usize, out: &mut [CameraSample]) {
        let f = self.frame;
        let (w, h) = (f.width() as usize, f.height() as usize);
        let (cols, rows) = self.grid;
        let pts = &f.points()[y * w..(y + 1) * w];
        let mut o = 0;
        for (x, p) in pts.iter().enumerate() {
            let Some(s) = *p else { continue };
            let i = y * w + x;
            let triangle = self.triangle(i);
            if cols * rows == 1 {
                out[o] = CameraSample {
                    pixel: i as u32,
                    point: s,
                    triangle,
                };
                o += 1;
                continue;
            }
            let ray = |px: f32, py: f32| {
                let ndc = Vec2::new(px / w as f32 * 2.0 - 1.0, 1.0 - py / h as f32 * 2.0);
                (self.inv.project_point3(ndc.extend(1.0)) - self.eye).normalize()
            };
            // The visible triangle itself: a sub-sample is where its camera ray meets that
            // triangle. (On the pixel's tangent plane, the plane of its interpolated normal, a
            // sub-sample of a smooth-shaded heightfield lay below the neighbouring facets,
            // which then shadowed it: dark speckle over lit terrain.)
            let tri = {
                let obj = f.gbuffer.object.data()[i] as usize;
                let prim = f.gbuffer.prim.data()[i] as usize;
                let m = &f.scene.objects[obj].mesh;
                let v = |k: usize| m.positions[m.indices[3 * prim + k] as usize];
                [v(0), v(1), v(2)]
            };
            let ng = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            for r in 0..rows {
                for c in 0..cols {
                    let d = ray(
                        x as f32 + (c as f32 + 0.5) / cols as f32,
                        y as f32 + (r as f32 + 0.5) / rows as f32,
                    );
                    let p = on_triangle(self.eye, d, &tri, ng).unwrap_or(s.position);
                    out[o] = CameraSample {
                        pixel: i as u32,
                        point: SamplePoint { position: p, ..s },
                        triangle,
                    };
                    o += 1;
                }
            }
        }
        debug_assert_eq!(o, out.len());
    }
}

/// Where the ray from `eye` along `d` meets the triangle `tri` (geometric normal `ng`), if it
/// meets it in front of the eye and inside its edges; `None` where it passes beside it or the
/// triangle is seen edge-on (the sample is then the pixel's own G-buffer point).
fn on_triangle(eye: Vec3, d: Vec3, tri: &[Vec3; 3], ng: Vec3) -> Option<Vec3> {
    let denom = ng.dot(d);
    if denom.is_nan() || denom.abs() <= 1e-7 * ng.length() {
        return None;
    }
    let t = ng.dot(tri[0] - eye) / denom;
    let q = eye + d * t;
    let inside = (0..3).all(|k| {
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        (b - a).cross(q - a).dot(ng) >= 0.0
    });
    (t > 0.0 && inside).then_some(q)
}

impl Default for CameraSample {
    fn default() -> Self {
        CameraSample {
            pixel: u32::MAX,
            point: SamplePoint::flat(Vec3::ZERO, Vec3::ZERO),
            triangle: u32::MAX,
        }
    }
}

/// Per scene triangle (scene-wide ids): its geometric normal (unnormalised) and whether it
/// faces the light (at its centroid).
pub(super) fn triangle_facing(frame: &Frame) -> Vec<(Vec3, bool)> {
    let light = frame.light;
    let per: Vec<Vec<(Vec3, bool)>> = frame
        .scene
        .objects
        .par_iter()
        .map(|o| {
            let m = &o.mesh;
            m.indices
                .chunks_exact(3)
                .map(|t| {
                    let [a, b, c] =
                        [t[0], t[1], t[2]].map(|i| m.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO));
                    let n = (b - a).cross(c - a);
                    (n, n.dot(to_light(&light, (a + b + c) / 3.0)) > 0.0)
                })
                .collect()
        })
        .collect();
    per.concat()
}

/// From `p` towards the light: the light's position minus `p`, or against a directional
/// light's direction.
pub(super) fn to_light(light: &Light, p: Vec3) -> Vec3 {
    match light.kind {
        LightKind::Directional => -light.direction,
        _ => light.position - p,
    }
}

/// Whether a sample's surface faces the light (the others are unlit and never inserted).
pub(super) fn faces_light(light: &Light, s: &SamplePoint) -> bool {
    s.normal.dot(light.to_light(s.position)) > 0.0
}

/// Where camera sample `s` falls in the `base` views: the view that sees it and its uv there
/// ([`crate::shadow::light::locate`]); `None` where it faces away from the light or lies
/// behind the view's eye. The one way from a sample to its texel, for the insertion and for
/// `inspect`.
#[inline(always)]
pub(super) fn sample_uv(base: &[LightView], light: &Light, s: &SamplePoint) -> Option<(usize, Vec2)> {
    if !faces_light(light, s) {
        return None;
    }
    crate::shadow::light::locate(base, light, s.position).map(|m| (m.view, m.uv))
}
