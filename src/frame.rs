//! The camera pass: a G-buffer drawn through the pipeline (depth, world position, normal,
//! object id, material), and the final shading `ambient + v * (Lambert + Blinn-Phong)`.
//!
//! Two draws per object share the same geometry and depth formula: the first writes
//! position and object id with a `Less` depth test, the second writes normals where the
//! depth is `Equal` (bit-identical depths, so exactly the visible surface).
//!
//! Shading: `ambient + v * (Lambert + Blinn-Phong)` with `v` per colour channel.

use crate::math;
use crate::pipeline::*;
use crate::reference::SamplePoint;
use crate::scene::{Camera, Light, Scene};
use crate::visibility::Visibility;
use crate::Error;
use glam::{Vec3, Vec4};

/// Marks "no object" in [`GBuffer::object`].
pub const NO_OBJECT: u32 = u32::MAX;

/// Per-pixel surface data of the camera view.
#[derive(Clone, Debug)]
pub struct GBuffer {
    /// Camera depth in [0, 1] (1: background).
    pub depth: Surface<f32>,
    /// World position.
    pub position: Surface<Vec3>,
    /// Unit normal, turned towards the camera for two-sided materials.
    pub normal: Surface<Vec3>,
    /// Object index, or [`NO_OBJECT`].
    pub object: Surface<u32>,
    /// Index of the visible triangle within its object's mesh (undefined where there is no
    /// object): with [`crate::scene::Scene::triangle_bases`], a scene-wide triangle id.
    pub prim: Surface<u32>,
}

/// Everything a technique gets: the scene, the light, the camera and its G-buffer.
#[derive(Clone)]
pub struct Frame<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// The light whose visibility is computed.
    pub light: Light,
    /// The camera of this frame.
    pub camera: Camera,
    /// The camera's G-buffer.
    pub gbuffer: GBuffer,
    /// Index of the frame on the camera path (0 for a still camera).
    pub index: usize,
    /// The shading point of every pixel, row-major (built once with the G-buffer).
    points: Vec<Option<SamplePoint>>,
}

impl Frame<'_> {
    /// The same camera and G-buffer lit by `light` instead (techniques that sample an area
    /// light with many point lights run their hard passes on these).
    pub fn with_light(&self, light: Light) -> Self {
        Frame { light, ..self.clone() }
    }

    /// Image width.
    pub fn width(&self) -> u32 {
        self.camera.width
    }

    /// Image height.
    pub fn height(&self) -> u32 {
        self.camera.height
    }

    /// The shading point at pixel (x, y), if geometry covers it.
    pub fn point(&self, x: u32, y: u32) -> Option<SamplePoint> {
        if x >= self.width() || y >= self.height() {
            return None;
        }
        self.points[(y * self.width() + x) as usize]
    }

    /// The scene-wide id of the triangle visible at pixel index `i` (row-major), if any:
    /// `bases[object] + prim`, with `bases` from [`crate::scene::Scene::triangle_bases`].
    pub fn triangle_at(&self, i: usize, bases: &[u32]) -> Option<u32> {
        let o = self.gbuffer.object.data()[i];
        (o != NO_OBJECT).then(|| bases[o as usize] + self.gbuffer.prim.data()[i])
    }

    /// All shading points, row-major.
    pub fn points(&self) -> &[Option<SamplePoint>] {
        &self.points
    }

    /// Pixels the metrics count: covered by geometry and facing the light.
    pub fn metric_mask(&self) -> Vec<bool> {
        self.points()
            .iter()
            .map(|p| p.is_some_and(|s| s.normal.dot(self.light.to_light(s.position)) > 0.0))
            .collect()
    }

    /// The pixels of [`Frame::metric_mask`] on a smooth surface's terminator: the interpolated
    /// normal faces the light, the visible triangle itself does not
    /// ([`SamplePoint::face`]). Whether such a point is lit is a matter of convention: the
    /// triangle is in its own shadow, the smooth surface it stands for is not. Shadow volumes
    /// count it shadowed (the triangle is behind its own silhouette); the reference's ray,
    /// leaving from under the triangle, may pass its edge and see the light. The exact
    /// techniques' claims are stated without these pixels (`tests/random.rs`).
    pub fn terminator_mask(&self) -> Vec<bool> {
        self.points
            .iter()
            .map(|p| {
                p.is_some_and(|s| {
                    let l = self.light.to_light(s.position);
                    s.normal.dot(l) > 0.0 && s.face.dot(l) <= 0.0
                })
            })
            .collect()
    }

    /// The pixels of [`Frame::metric_mask`] whose visible surface is transparent (its material
    /// has a transmittance): where a technique's shadow of transparent objects on themselves
    /// and on each other is measured.
    pub fn transparent_mask(&self) -> Vec<bool> {
        let transparent: Vec<bool> = self
            .scene
            .objects
            .iter()
            .map(|o| self.scene.materials[o.material].is_transparent())
            .collect();
        self.metric_mask()
            .into_iter()
            .zip(self.gbuffer.object.data())
            .map(|(m, &o)| m && o != NO_OBJECT && transparent[o as usize])
            .collect()
    }
}

/// The unit normal of triangle `prim` of `mesh`, turned to `normal`'s side; `normal` where the
/// triangle has no area (or no such triangle exists).
pub fn face_normal(mesh: &crate::scene::Mesh, prim: usize, normal: Vec3) -> Vec3 {
    let Some(t) = mesh.indices.get(3 * prim..3 * prim + 3) else {
        return normal;
    };
    let v = |k: usize| mesh.positions.get(t[k] as usize).copied().unwrap_or(Vec3::ZERO);
    let n = (v(1) - v(0)).cross(v(2) - v(0)).normalize_or_zero();
    if n == Vec3::ZERO || !n.is_finite() {
        normal
    } else if n.dot(normal) < 0.0 {
        -n
    } else {
        n
    }
}

struct GVs {
    vp: glam::Mat4,
}
impl VertexProgram for GVs {
    type In = (Vec3, Vec3);
    type Out = (Vec3, Vec3);
    fn run(&self, v: &(Vec3, Vec3)) -> (Vec4, (Vec3, Vec3)) {
        (self.vp * v.0.extend(1.0), (v.0, v.1))
    }
}

/// Draws the G-buffer of `scene` seen by `camera`.
pub fn gbuffer(p: &Pipeline, scene: &Scene, camera: &Camera) -> Result<GBuffer, PipelineError> {
    let (w, h) = (camera.width, camera.height);
    let mut depth = Surface::new(w, h, 1.0f32)?;
    let mut pos_id = Surface::new(w, h, Vec4::new(0.0, 0.0, 0.0, -1.0))?;
    let mut nrm = Surface::new(w, h, Vec4::ZERO)?;
    let vs = GVs {
        vp: camera.view_projection(),
    };
    let verts: Vec<Vec<(Vec3, Vec3)>> = scene
        .objects
        .iter()
        .map(|o| {
            o.mesh
                .positions
                .iter()
                .copied()
                .zip(o.mesh.normals.iter().copied())
                .collect()
        })
        .collect();
    for (oi, o) in scene.objects.iter().enumerate() {
        let id = oi as f32;
        let fs = Shader(move |f: &Fragment<(Vec3, Vec3)>| f.var.0.extend(id));
        p.draw(
            &mut Targets::color(&mut pos_id).with_depth(&mut depth),
            &RenderState::default(),
            &verts[oi],
            &o.mesh.indices,
            &vs,
            &fs,
        )?;
    }
    let eq = RenderState {
        depth: DepthState {
            func: CompareFunc::Equal,
            write: false,
            ..Default::default()
        },
        ..Default::default()
    };
    // Where two objects reach a pixel at exactly the same depth (coplanar surfaces), the
    // first pass kept the first one drawn (`Less`), and every one passes `Equal`: only the
    // object the first pass kept writes here, so that a pixel's triangle is always one of its
    // object's.
    let ids = pos_id.data();
    for (oi, o) in scene.objects.iter().enumerate() {
        let two_sided = scene.materials[o.material].two_sided;
        let eye = camera.position;
        let id = oi as f32;
        let fs = DiscardingShader(move |f: &Fragment<(Vec3, Vec3)>| {
            if ids[f.y as usize * w as usize + f.x as usize].w != id {
                return None;
            }
            let mut n = f.var.1.normalize_or_zero();
            // Face the viewer: back faces of two-sided sheets, and any normal pointing away.
            if (two_sided || !f.front) && n.dot(eye - f.var.0) < 0.0 {
                n = -n;
            }
            // The triangle's index rides in the unused w, by bit pattern (exact for any count).
            Some(n.extend(f32::from_bits(f.prim)))
        });
        p.draw(
            &mut Targets::color(&mut nrm).with_depth(&mut depth),
            &eq,
            &verts[oi],
            &o.mesh.indices,
            &vs,
            &fs,
        )?;
    }
    Ok(GBuffer {
        position: pos_id.map(|v| v.truncate()),
        object: pos_id.map(|v| if v.w < 0.0 { NO_OBJECT } else { v.w as u32 }),
        normal: nrm.map(|v| v.truncate()),
        prim: nrm.map(|v| v.w.to_bits()),
        depth,
    })
}

/// Bytes per pixel a frame and a run's buffers for it take, measured: 9.3 GB peak for a
/// 8192 x 8192 render with a camera path (`/usr/bin/time penumbra render`), about 140 per
/// pixel.
pub const FRAME_BYTES_PER_PIXEL: u64 = 140;

/// Builds the frame of camera-path index `index` (0 and no path: the scene camera) for light
/// `light`.
pub fn frame<'a>(p: &Pipeline, scene: &'a Scene, light: usize, index: usize) -> Result<Frame<'a>, Error> {
    let l = scene.light_at(light, index).ok_or_else(|| {
        Error::input(format!(
            "scene '{}' has no light #{light} (it has {})",
            scene.name,
            scene.lights.len()
        ))
    })?;
    let camera = scene.camera_at(index);
    // A frame and what a run keeps of it (G-buffer, sample points, the technique's visibility
    // and the reference, masks, the shaded image, the previous frame's for flicker) take
    // about FRAME_BYTES_PER_PIXEL: checked against the memory budget before any is built.
    crate::pipeline::check_room(camera.width, camera.height, FRAME_BYTES_PER_PIXEL as usize, 1).map_err(|e| {
        Error::from(e).within(&format!(
            "a {}x{} frame ({FRAME_BYTES_PER_PIXEL} bytes per pixel: G-buffer, sample points, visibility and reference)",
            camera.width, camera.height
        ))
    })?;
    let gbuffer = gbuffer(p, scene, &camera)?;
    let points = gbuffer
        .object
        .data()
        .iter()
        .zip(gbuffer.prim.data())
        .zip(gbuffer.position.data().iter().zip(gbuffer.normal.data()))
        .map(|((&o, &prim), (&position, &normal))| {
            let mesh = &scene.objects.get(o as usize)?.mesh;
            Some(SamplePoint {
                position,
                normal,
                face: face_normal(mesh, prim as usize, normal),
            })
        })
        .collect();
    Ok(Frame {
        scene,
        light: l,
        camera,
        gbuffer,
        index,
        points,
    })
}

/// The sRGB transfer function of a linear value clamped to [0, 1] (IEC 61966-2-1).
fn srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * math::powf(c, 1.0 / 2.4) - 0.055
    }
}

/// The byte of [`srgb`] as an 8-bit channel stores it ([`ColorFormat::from_vec4`]'s clamp,
/// scale and rounding; NaN and below zero: 0), by the 255 thresholds where the byte steps:
/// each the least `f32` whose byte reaches the step, found once by bisection over the bit
/// patterns of [0, 1] (ordered as their values) with that same function, so a channel costs
/// eight comparisons instead of a `powf` and gets the function's byte.
fn srgb_byte(c: f32) -> u8 {
    static STEPS: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    let byte = |c: f32| <Rgba8 as ColorFormat>::from_vec4(Vec4::new(srgb(c), 0.0, 0.0, 0.0))[0];
    let steps = STEPS.get_or_init(|| {
        (1..=255u8)
            .map(|k| {
                let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
                while lo < hi {
                    let mid = lo + (hi - lo) / 2;
                    if byte(f32::from_bits(mid)) >= k {
                        hi = mid;
                    } else {
                        lo = mid + 1;
                    }
                }
                f32::from_bits(lo)
            })
            .collect()
    });
    if c > 0.0 {
        steps.partition_point(|t| *t <= c) as u8
    } else {
        0
    }
}

/// Final image: `ambient + v * (Lambert + Blinn-Phong)` from the light's centre, in sRGB,
/// where `v` is the visibility per channel (light through coloured glass is tinted).
/// Background pixels get a dark sky colour.
pub fn shade(frame: &Frame, visibility: &Visibility) -> Surface<Rgba8> {
    let (w, h) = (frame.width(), frame.height());
    let mut out =
        Surface::from_vec_derived(w, h, vec![[18, 20, 28, 255]; w as usize * h as usize]).expect("frame size is valid");
    // Rows in parallel: each pixel's colour is its own, so any split gives the same image.
    use rayon::prelude::*;
    out.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            let y = y as u32;
            for (x, px) in (0..w).zip(row.iter_mut()) {
                let Some(s) = frame.point(x, y) else { continue };
                let obj = frame.gbuffer.object.at(x, y) as usize;
                let albedo = frame.scene.materials[frame.scene.objects[obj].material].albedo;
                let l = frame.light.to_light(s.position);
                let v = (frame.camera.position - s.position).normalize_or_zero();
                let ndl = s.normal.dot(l).max(0.0);
                let hv = (l + v).normalize_or_zero();
                let spec = if ndl > 0.0 {
                    // (n . h)^48 by squaring: ((x^3)^2)^2^2^2, exact IEEE products everywhere.
                    let x = s.normal.dot(hv).max(0.0);
                    let x6 = (x * x * x) * (x * x * x);
                    let x24 = (x6 * x6) * (x6 * x6);
                    0.25 * (x24 * x24)
                } else {
                    0.0
                };
                let vis = visibility.rgb((y * w + x) as usize);
                let vis = if vis.is_finite() { vis } else { Vec3::ONE };
                let c = albedo * 0.12 + (albedo * ndl + Vec3::splat(spec)) * vis * frame.light.intensity;
                *px = [srgb_byte(c.x), srgb_byte(c.y), srgb_byte(c.z), 255];
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thresholds give the transfer function's byte: on every 251st `f32` of [0, 1]
    /// (about 4 million values, each step's neighbourhood included), at the steps themselves
    /// and one ulp below, and outside [0, 1].
    #[test]
    fn srgb_bytes_by_threshold_equal_the_function() {
        let byte = |c: f32| <Rgba8 as ColorFormat>::from_vec4(Vec4::new(srgb(c), 0.0, 0.0, 0.0))[0];
        let mut bits = 0u32;
        while bits <= 1.0f32.to_bits() {
            let c = f32::from_bits(bits);
            assert_eq!(srgb_byte(c), byte(c), "{c:e}");
            bits += 251;
        }
        let mut seen = 0;
        for k in 1..=255u8 {
            // The least value reaching step k, and the value just below it.
            let mut c = 1.0f32;
            let mut step = 0.5f32;
            for _ in 0..40 {
                if byte(c - step) >= k {
                    c -= step;
                }
                step *= 0.5;
            }
            for v in [c, f32::from_bits(c.to_bits() - 1)] {
                assert_eq!(srgb_byte(v), byte(v), "step {k} at {v:e}");
                seen += 1;
            }
        }
        assert_eq!(seen, 510);
        for c in [-1.0, -0.0, 1.5, f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            assert_eq!(srgb_byte(c), byte(c), "{c}");
        }
    }
}
