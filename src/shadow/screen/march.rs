//! The screen-space ray march (Sousa et al. 2013, "Rendering technologies of Crysis 3"; RTR
//! 7.10): from a camera pixel's surface point towards the light, a fixed number of steps over a
//! fixed length, each step projected into the camera's depth buffer, which is read as a
//! heightfield: a step is blocked where it lies behind the buffer's surface by more than the
//! buffer's own slope across a pixel and less than `thickness` (every occluder is assumed to be
//! `thickness` deep behind the surface the camera sees).
//!
//! The depth buffer is the G-buffer's hardware depth `z` in [0, 1], linearised once per frame
//! as an engine does (`d = f n / (f - z (f - n))` for the `[0, 1]` perspective projection), so
//! its precision is the technique's.
//!
//! What the march cannot see is what the camera does not: occluders outside the view, the
//! back of a surface (an occluder is only `thickness` deep) and surfaces hidden behind others
//! cast nothing.

use crate::frame::{Frame, NO_OBJECT};
use crate::pipeline::{Pipeline, Surface};
use crate::scene::LightKind;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::pixels::per_pixel_map;
use crate::shadow::sample::kernel::interleaved_gradient_noise;
use crate::shadow::technique::{Field, Stage};
use crate::Error;
use glam::{Mat4, Vec2, Vec3};

/// Most steps a march takes.
pub const MAX_STEPS: u32 = 1024;

/// The march's options (nested in both screen-space techniques' options).
#[derive(Clone, Debug, PartialEq)]
pub struct March {
    /// Steps per pixel (1 to [`MAX_STEPS`]). Default: 16.
    pub steps: u32,
    /// Length of the march towards the light, world units. Default: the technique's.
    pub length: f32,
    /// How deep behind the depth buffer's surface an occluder is assumed to be, world
    /// units. Default: the technique's.
    pub thickness: f32,
    /// Start each pixel's march at an offset hashed from the pixel (interleaved gradient
    /// noise, Jimenez 2014), which turns banding into noise. Default: true.
    pub jitter: bool,
}

impl Default for March {
    /// Screen-space shadows' march: 16 steps over 2 world units, 0.5 thick, jittered (a
    /// technique nesting a march sets its own defaults, which its option list shows).
    fn default() -> Self {
        March::new(16, 2.0, 0.5)
    }
}

impl March {
    /// The march of `steps` steps over `length` with `thickness`, jittered.
    pub const fn new(steps: u32, length: f32, thickness: f32) -> March {
        March {
            steps,
            length,
            thickness,
            jitter: true,
        }
    }

    /// The fields of the march (`steps`, `length`, `thickness`, `jitter`), for
    /// [`crate::shadow::options::within`].
    pub fn fields() -> Vec<Field<March>> {
        vec![
            Field::range("steps", "march steps per pixel", 1, MAX_STEPS, |o: &mut March| {
                &mut o.steps
            }),
            Field::range(
                "length",
                "march length towards the light, world units",
                1e-6,
                1e6,
                |o: &mut March| &mut o.length,
            ),
            Field::range(
                "thickness",
                "assumed depth of every occluder behind the surface the camera sees, world units",
                0.0,
                1e6,
                |o: &mut March| &mut o.thickness,
            ),
            Field::new(
                "jitter",
                "start each pixel's march at a hashed offset (noise instead of banding)",
                |o: &mut March| &mut o.jitter,
            ),
        ]
    }
}

/// The camera's depth buffer as a heightfield, and the march through it.
pub struct DepthField {
    /// Linear view depth per pixel (the camera's far distance where no geometry).
    pub linear: Surface<f32>,
    /// Per pixel, row-major: the linear depth and the buffer's tolerance
    /// ([`DepthField::slope`]), side by side so that a step reads one place.
    texels: Vec<[f32; 2]>,
    width: usize,
    view: Mat4,
    view_projection: Mat4,
    size: Vec2,
}

/// What one pixel's march found.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Hit {
    /// Visibility: 0 where a step was blocked, else 1.
    pub v: f32,
    /// Steps taken.
    pub steps: u32,
    /// Distance along the ray of the blocked step (NaN where none was).
    pub at: f32,
}

impl DepthField {
    /// The linearised depth buffer of `frame`'s camera (an engine's "linearise depth" pass).
    pub fn new(p: &Pipeline, frame: &Frame) -> Result<DepthField, Error> {
        let cam = &frame.camera;
        let (n, f) = (cam.near, cam.far);
        let depth = &frame.gbuffer.depth;
        let object = &frame.gbuffer.object;
        let lin = per_pixel_map(p, frame, |x, y| {
            let (x, y) = (x as u32, y as u32);
            if object.at(x, y) == NO_OBJECT {
                return f;
            }
            f * n / (f - depth.at(x, y) * (f - n))
        });
        let linear = Surface::from_vec(frame.width(), frame.height(), lin)?;
        let texels = per_pixel_map(p, frame, |x, y| {
            [linear.at(x as u32, y as u32), Self::slope(&linear, x, y)]
        });
        Ok(DepthField {
            texels,
            width: frame.width() as usize,
            linear,
            view: cam.view(),
            view_projection: cam.view_projection(),
            size: Vec2::new(frame.width() as f32, frame.height() as f32),
        })
    }

    /// The buffer's tolerance at pixel `(x, y)`: its depth change to the next pixel, on the
    /// side of each axis that stays on the surface (the smaller one-sided difference), the
    /// larger of the two axes. A step closer behind the buffer than this is the surface itself
    /// seen at another point of its pixel, not an occluder.
    fn slope(linear: &Surface<f32>, x: usize, y: usize) -> f32 {
        let (w, h) = (linear.width() as usize, linear.height() as usize);
        let l = linear.data();
        let i = y * w + x;
        let d = l[i];
        // The smaller difference of the two sides of an axis; a side past the image's edge
        // does not count (the other one does), an axis of one pixel gives 0.
        let side = |a: Option<f32>, b: Option<f32>| match (a, b) {
            (Some(a), Some(b)) => (a - d).abs().min((b - d).abs()),
            (Some(a), None) | (None, Some(a)) => (a - d).abs(),
            (None, None) => 0.0,
        };
        let sx = side((x > 0).then(|| l[i - 1]), (x + 1 < w).then(|| l[i + 1]));
        let sy = side((y > 0).then(|| l[i - w]), (y + 1 < h).then(|| l[i + w]));
        sx.max(sy)
    }

    /// The march from pixel `(x, y)`'s surface point `p` towards `frame`'s light, each step
    /// reported to `t`.
    pub fn march(&self, frame: &Frame, m: &March, x: u32, y: u32, p: Vec3, t: &mut impl Trace) -> Hit {
        let light = &frame.light;
        let dir = light.to_light(p);
        // A point or area light closer than the march length ends it.
        let length = match light.kind {
            LightKind::Directional => m.length,
            _ => m.length.min(light.position.distance(p)),
        };
        let jitter = if m.jitter {
            1.0 - interleaved_gradient_noise(x, y)
        } else {
            1.0
        };
        let step = length / m.steps as f32;
        t.step(|| {
            Step::new(
                "ray",
                "march from the surface point towards the light, through the linearised depth buffer",
            )
            .vec3("start", p)
            .vec3("direction", dir)
            .num("length", length)
            .int("steps", m.steps)
            .num("first step at", jitter * step)
            .num("thickness", m.thickness)
        });
        let mut hit = Hit {
            v: 1.0,
            steps: 0,
            at: f32::NAN,
        };
        // The ray is a line in clip space and in view depth: each step is the start plus `s`
        // times the direction's image, four multiply-adds instead of two matrix products.
        let (c0, cd) = (
            self.view_projection * p.extend(1.0),
            self.view_projection * dir.extend(0.0),
        );
        let (v0, vd) = (-(self.view * p.extend(1.0)).z, -(self.view * dir.extend(0.0)).z);
        for i in 0..m.steps {
            let s = (i as f32 + jitter) * step;
            hit.steps += 1;
            // The step on the screen: behind the eye or outside the image ends the march (lit).
            let c = c0 + cd * s;
            if c.w <= 0.0 {
                t.step(|| Step::new("step", "behind the camera: the march ends, lit").num("t", s));
                break;
            }
            let ndc = Vec2::new(c.x / c.w, c.y / c.w);
            let px = Vec2::new((ndc.x + 1.0) * 0.5 * self.size.x, (1.0 - ndc.y) * 0.5 * self.size.y);
            if !(px.x >= 0.0 && px.y >= 0.0 && px.x < self.size.x && px.y < self.size.y) {
                t.step(|| {
                    Step::new("step", "outside the image: the march ends, lit")
                        .num("t", s)
                        .vec2("pixel", px)
                });
                break;
            }
            let (sx, sy) = (px.x as i64, px.y as i64);
            let [buffer, tol] = self.texels[sy as usize * self.width + sx as usize];
            let depth = v0 + vd * s;
            let behind = depth - buffer;
            // One branch, taken once: both comparisons evaluated (no short circuit).
            let blocked = (behind > tol) & (behind < m.thickness);
            t.step(|| {
                Step::new(
                    "step",
                    "blocked where the step is behind the buffer by more than its slope and less than the thickness",
                )
                .num("t", s)
                .vec3("point", p + dir * s)
                .vec2("pixel", Vec2::new(sx as f32, sy as f32))
                .num("step depth", depth)
                .num("buffer depth", buffer)
                .num("slope", tol)
                .flag("blocked", blocked)
            });
            if blocked {
                hit.v = 0.0;
                hit.at = s;
                break;
            }
        }
        hit
    }

    /// The linear depth buffer as a stage (near black, far white).
    pub fn stage(&self, frame: &Frame) -> Stage {
        Stage::Scalar {
            name: "linear_depth".into(),
            data: self.linear.clone(),
            lo: frame.camera.near,
            hi: self.linear.data().iter().copied().fold(frame.camera.near, f32::max),
        }
    }
}

/// Every pixel's march ([`DepthField::march`]), rows in parallel; pixels without geometry
/// get `v = NaN`, and pixels `skip(x, y)` names are not marched (`v = 1`, no steps).
pub fn march_all(
    p: &Pipeline,
    frame: &Frame,
    field: &DepthField,
    m: &March,
    skip: impl Fn(usize, usize) -> bool + Sync,
) -> Vec<Hit> {
    per_pixel_map(p, frame, |x, y| match frame.point(x as u32, y as u32) {
        None => Hit {
            v: f32::NAN,
            steps: 0,
            at: f32::NAN,
        },
        Some(_) if skip(x, y) => Hit {
            v: 1.0,
            steps: 0,
            at: f32::NAN,
        },
        Some(s) => field.march(
            frame,
            m,
            x as u32,
            y as u32,
            s.position,
            &mut crate::shadow::inspect::NoTrace,
        ),
    })
}

/// The counters of a run's hits: steps taken and pixels blocked (summed in pixel order).
pub fn counters(hits: &[Hit]) -> Vec<(&'static str, f64)> {
    let steps: u64 = hits.iter().map(|h| h.steps as u64).sum();
    let blocked = hits.iter().filter(|h| h.v == 0.0).count();
    vec![("march steps", steps as f64), ("pixels blocked", blocked as f64)]
}

/// The distance along each pixel's ray at which its march was blocked, as a stage (0 black,
/// `length` white, NaN where nothing blocked it).
pub fn hit_stage(frame: &Frame, hits: &[Hit], length: f32) -> Result<Stage, Error> {
    Stage::pixels(
        frame,
        "march_blocked_at",
        hits.iter().map(|h| h.at).collect(),
        0.0,
        length,
    )
}
