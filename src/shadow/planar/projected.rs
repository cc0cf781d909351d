//! Planar projected shadows (Blinn 1988, "Me and my (fake) shadow"; RTR 7.2, equations 7.1
//! and 7.2 generalised to homogeneous lights; CS300): every caster is flattened onto a
//! receiving plane by the projection matrix
//!
//! `M = (π·L) I − L πᵀ`, with the plane `π = (n, d)` (`n·x + d = 0`) and the homogeneous light
//! `L` (`(l, 1)` for a point, `(−direction, 0)` for a directional light),
//!
//! which sends a point `p` to where the light's ray through `p` meets the plane, and drawn
//! into the camera view as a darkening. Only planes receive, so other surfaces stay lit.
//!
//! Pass by pass, for each receiving plane:
//! 1. the receiver is drawn with the G-buffer's depth (`Equal`), writing stencil 1 where it is
//!    the visible surface;
//! 2. casters, clipped in world space to the slab between the plane and the light (what lies
//!    beyond the light would project through it as an "anti-shadow", what lies behind the
//!    plane cannot shadow it), are drawn flattened with the stencil test `Equal 1` and op
//!    `Zero`: each pixel darkens once, however many flattened triangles cover it (no double
//!    blending), and only on the receiver (no shadow hanging over the plane's edge).
//!
//! Options show each failure the stencil and the clipping remove: `stencil=off` (depth test
//! with polygon offset instead: double blending where flattened triangles overlap, shadows
//! beyond the plane's edge) and `clip=off` (naive division by w: anti-shadows from casters
//! beyond the light).

use crate::frame::Frame;
use crate::pipeline::*;
use crate::scene::Mesh;
use crate::shadow::inspect::{self, NoTrace, Step, Steps, Trace};
use crate::shadow::light::homogeneous_position;
use crate::shadow::technique::{object_named, Declaration, Entry, Family, Field, ShadowTechnique, Stage, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;
use glam::{DVec3, Mat4, Vec3, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "planar",
    family: Family::Planar,
    summary: "planar projected shadows with stencil (Blinn; RTR 7.2): exact on planes, nothing on other surfaces",
    sweep: &[&[], &[("stencil", "off"), ("darkness", "0.5")]],
    ..Entry::BASE
};

/// Options of planar projected shadows.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The receiving object's name, or `auto`: every planar object receives. Default: auto.
    pub receiver: String,
    /// How much a shadow darkens, in [0, 1]: visibility in shadow is `1 - darkness` (below 1,
    /// double blending shows without the stencil). Default: 1.
    pub darkness: f32,
    /// Darken each receiver pixel once and only on the receiver (false: depth test only,
    /// double blending and overhang). Default: true (`on`).
    pub stencil: bool,
    /// Clip casters to the slab between plane and light (false: project every vertex and
    /// divide by w, anti-shadows). Default: true (`on`).
    pub clip: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            receiver: "auto".into(),
            darkness: 1.0,
            stencil: true,
            clip: true,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new(
        "planar",
        vec![
            Field::new(
                "receiver",
                "the receiving object's name, or auto: every planar object receives",
                |o: &mut Options| &mut o.receiver,
            ),
            Field::range(
                "darkness",
                "how much a shadow darkens: visibility in shadow is 1 - darkness (below 1, double blending shows)",
                0.0,
                1.0,
                |o: &mut Options| &mut o.darkness,
            ),
            Field::new(
                "stencil",
                "on: darken each receiver pixel once and only on the receiver; off: depth test only (double blending, overhang)",
                |o: &mut Options| &mut o.stencil,
            ),
            Field::new(
                "clip",
                "on: clip casters to the slab between plane and light; off: project every vertex and divide by w (anti-shadows)",
                |o: &mut Options| &mut o.clip,
            ),
        ],
    )
}

/// Planar projected shadows (see the module docs).
pub struct Planar {
    opts: Options,
    /// Last run: the receivers' stencil masks (object index, mask) and the result.
    masks: Vec<(usize, Surface<u8>)>,
    shadow: Option<Surface<f32>>,
    times: Vec<(&'static str, f64)>,
    fragments: u64,
}

impl Planar {
    /// Planar shadows with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Planar, Error> {
        declaration().check(&opts)?;
        Ok(Planar {
            opts,
            masks: Vec::new(),
            shadow: None,
            times: Vec::new(),
            fragments: 0,
        })
    }
}

/// The plane `(n, d)` of a mesh whose vertices all lie on one plane (within 1e-5 of its
/// extent), `n` unit and along the first non-degenerate triangle's winding.
pub fn plane_of(mesh: &Mesh) -> Option<(Vec3, f32)> {
    let pos = |i: u32| mesh.positions[i as usize].as_dvec3();
    let (lo, hi) = mesh.bounds()?;
    let extent = (hi - lo).length() as f64;
    let n = mesh
        .indices
        .chunks_exact(3)
        .map(|t| (pos(t[1]) - pos(t[0])).cross(pos(t[2]) - pos(t[0])))
        .find(|n| n.length() > 1e-12 * extent * extent)?
        .normalize();
    let d = -n.dot(pos(mesh.indices[0]));
    let flat = mesh
        .positions
        .iter()
        .all(|p| (n.dot(p.as_dvec3()) + d).abs() <= 1e-5 * extent.max(1e-30));
    flat.then(|| (n.as_vec3(), d as f32))
}

/// RTR eq. 7.1/7.2, homogeneous: `M = (π·L) I − L πᵀ` projects onto plane `π` from light `L`.
pub fn projection_matrix(plane: Vec4, light: Vec4) -> Mat4 {
    let k = crate::math::dot4(plane, light);
    let cols = [Vec4::X, Vec4::Y, Vec4::Z, Vec4::W].map(|e| e * k - light * crate::math::dot4(plane, e));
    Mat4::from_cols(cols[0], cols[1], cols[2], cols[3])
}

/// Clips polygon `poly` to `f(p) >= 0` for an affine `f` (Sutherland-Hodgman, in f64), into
/// `out` (cleared first; reused across triangles).
fn clip_polygon(poly: &[DVec3], f: impl Fn(DVec3) -> f64, out: &mut Vec<DVec3>) {
    out.clear();
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (fa, fb) = (f(a), f(b));
        if fa >= 0.0 {
            out.push(a);
        }
        if (fa >= 0.0) != (fb >= 0.0) {
            out.push(a + (b - a) * (fa / (fa - fb)));
        }
    }
}

impl Planar {
    /// The flattened casters for receiver `r` with plane `plane` (light side positive):
    /// homogeneous positions (`M p`) and indices.
    fn flattened(&self, frame: &Frame, r: usize, plane: Vec4, light: Vec4) -> (Vec<Vec4>, Vec<u32>) {
        let m = projection_matrix(plane, light);
        let (pd, ld) = (plane.as_dvec4(), light.as_dvec4());
        let dist = |p: DVec3| pd.truncate().dot(p) + pd.w;
        // Light's height over the plane (directional: unbounded).
        let dl = if light.w == 0.0 {
            f64::INFINITY
        } else {
            dist(ld.truncate())
        };
        let (mut verts, mut idx) = (Vec::new(), Vec::new());
        let (mut poly, mut tmp) = (Vec::with_capacity(5), Vec::with_capacity(5));
        for (oi, o) in frame.scene.objects.iter().enumerate() {
            if oi == r {
                continue;
            }
            let pos = |i: u32| o.mesh.positions[i as usize].as_dvec3();
            for t in o.mesh.indices.chunks_exact(3) {
                let tri = [pos(t[0]), pos(t[1]), pos(t[2])];
                if self.opts.clip {
                    // Keep 0 <= dist <= dl (1 - 1e-6): on the plane's light side, short of
                    // the light's own plane, where the projection would reach infinity.
                    clip_polygon(&tri, dist, &mut poly);
                    if dl.is_finite() {
                        clip_polygon(&poly, |q| dl * (1.0 - 1e-6) - dist(q), &mut tmp);
                        std::mem::swap(&mut poly, &mut tmp);
                    }
                } else {
                    poly.clear();
                    poly.extend_from_slice(&tri);
                }
                if poly.len() < 3 || poly.iter().all(|q| dist(*q) <= 1e-9 * dl.min(1e9)) {
                    continue;
                }
                let base = verts.len() as u32;
                for q in &poly {
                    let h = m * q.as_vec3().extend(1.0);
                    // clip=off: the naive divide, which turns points beyond the light into
                    // points on the plane on the wrong side (anti-shadows).
                    verts.push(if self.opts.clip { h } else { h / h.w });
                }
                for k in 1..poly.len() as u32 - 1 {
                    idx.extend_from_slice(&[base, base + k, base + k + 1]);
                }
            }
        }
        (verts, idx)
    }
}

impl Planar {
    /// The per-pixel resolve of the passes (the image's, and `inspect`'s with a recording
    /// trace): the shadow buffer's value, the product of the darkening at the pixel.
    #[inline(always)]
    fn resolve(&self, shadow: f32, t: &mut impl Trace) -> f32 {
        t.step(|| {
            Step::new("shadow buffer", "the product of the darkening at this pixel (1: none)")
                .num("value", shadow)
                .num("darkness", self.opts.darkness)
        });
        shadow
    }
}

impl ShadowTechnique for Planar {
    fn name(&self) -> &'static str {
        "planar"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        passes.add("flatten casters", 0.0);
        let scene = frame.scene;
        let receivers: Vec<usize> = if self.opts.receiver == "auto" {
            (0..scene.objects.len()).collect()
        } else {
            let i = object_named(frame, "planar", "receiver", &self.opts.receiver)?;
            if plane_of(&scene.objects[i].mesh).is_none() {
                return Err(declaration().error("receiver", &self.opts.receiver, "names an object that is not planar"));
            }
            vec![i]
        };
        let light = homogeneous_position(&frame.light);
        let vp = frame.camera.view_projection();
        let (w, h) = (frame.width(), frame.height());
        let mut shadow = Surface::new(w, h, 1.0f32)?;
        self.masks.clear();
        self.fragments = 0;
        for r in receivers {
            let Some((n, d)) = plane_of(&scene.objects[r].mesh) else {
                continue;
            };
            // Orient the plane so the light is on its positive side; a light in the plane
            // casts nothing onto it.
            let mut plane = n.extend(d);
            let side = crate::math::dot4(plane, light);
            if side == 0.0 {
                continue;
            }
            if side < 0.0 {
                plane = -plane;
            }
            passes.end("stencil passes");
            let (verts, idx) = self.flattened(frame, r, plane, light);
            passes.end("flatten casters");
            // Pass 1: stencil 1 where the receiver is the visible surface.
            let mut depth = frame.gbuffer.depth.clone();
            let mut mask = Surface::new(w, h, 0u8)?;
            let mark = StencilFace {
                pass: StencilOp::Replace,
                ..Default::default()
            };
            p.draw(
                &mut Targets::none().with_depth(&mut depth).with_stencil(&mut mask),
                &RenderState {
                    depth: DepthState {
                        func: CompareFunc::Equal,
                        write: false,
                        ..Default::default()
                    },
                    stencil: StencilState {
                        enabled: true,
                        front: mark,
                        back: mark,
                        reference: 1,
                        ..Default::default()
                    },
                    ..Default::default()
                },
                &scene.objects[r].mesh.positions,
                &scene.objects[r].mesh.indices,
                &TransformPositions(vp),
                &DepthOnly,
            )?;
            // Pass 2: the flattened casters darken, once per pixel, on the receiver only.
            let once = StencilFace {
                func: CompareFunc::Equal,
                pass: StencilOp::Zero,
                ..Default::default()
            };
            let state = if self.opts.stencil {
                RenderState {
                    depth: DepthState {
                        func: CompareFunc::Always,
                        write: false,
                        ..Default::default()
                    },
                    stencil: StencilState {
                        enabled: true,
                        front: once,
                        back: once,
                        reference: 1,
                        ..Default::default()
                    },
                    blend: BlendMode::Multiply,
                    ..Default::default()
                }
            } else {
                // Without the stencil: a depth test pulled towards the camera so the
                // flattened shadow wins against its own plane (and everything behind it).
                RenderState {
                    depth: DepthState {
                        func: CompareFunc::LessEqual,
                        write: false,
                        ..Default::default()
                    },
                    offset: PolygonOffset {
                        factor: -1.0,
                        units: -64.0,
                    },
                    blend: BlendMode::Multiply,
                    ..Default::default()
                }
            };
            let keep = 1.0 - self.opts.darkness;
            let mut targets = if self.opts.stencil {
                Targets::color(&mut shadow).with_stencil(&mut mask)
            } else {
                Targets::color(&mut shadow).with_depth(&mut depth)
            };
            let st = p.draw(
                &mut targets,
                &state,
                &verts,
                &idx,
                &TransformHomogeneous(vp),
                &Shader(move |_: &Fragment<()>| Vec4::splat(keep)),
            )?;
            self.fragments += st.fragments_rasterized;
            self.masks.push((r, mask));
        }
        let out: Vec<f32> = frame
            .points()
            .iter()
            .zip(shadow.data())
            .map(|(pt, &s)| {
                if pt.is_some() {
                    self.resolve(s, &mut NoTrace)
                } else {
                    f32::NAN
                }
            })
            .collect();
        self.shadow = Some(shadow);
        passes.end("stencil passes");
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let mut steps = Vec::new();
        let Some(shadow) = &self.shadow else { return steps };
        let Some(s) = frame.point(x, y) else { return steps };
        let obj = frame.gbuffer.object.at(x, y) as usize;
        let plane = plane_of(&frame.scene.objects[obj].mesh);
        let mut st = Step::new(
            "receiver",
            "only planar objects receive: the casters are flattened onto each plane (RTR eq. 7.1/7.2)",
        )
        .text("object", frame.scene.objects[obj].name.clone())
        .flag("planar", plane.is_some());
        if let Some((n, d)) = plane {
            st = st
                .vec3("plane normal", n)
                .num("plane offset", d)
                .num("point's distance to the plane", n.dot(s.position) + d);
        }
        steps.push(st);
        if let Some((_, m)) = self.masks.iter().find(|(r, _)| *r == obj) {
            let left = m.at(x, y);
            steps.push(
                Step::new(
                    "stencil",
                    "pass 1 marks the receiver's visible pixels with 1; a flattened caster darkens a marked pixel and zeroes it (once)",
                )
                .int("stencil after the shadow pass", left)
                .flag("darkened", self.opts.stencil && left == 0),
            );
        }
        let mut t = Steps(steps);
        let v = self.resolve(shadow.at(x, y), &mut t);
        t.0.push(inspect::result(v));
        t.0
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("receivers", self.masks.len() as f64),
            ("shadow fragments", self.fragments as f64),
        ]
    }

    fn stages(&self, _: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let mut v: Vec<Stage> = self
            .masks
            .iter()
            .map(|(r, m)| {
                Stage::unit(
                    format!("receiver_stencil_{}", frame.scene.objects[*r].name),
                    m.map(|x| x as f32),
                )
            })
            .collect();
        if let Some(s) = &self.shadow {
            v.push(Stage::unit("flattened_shadows", s.clone()));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_projection_lands_on_the_plane_along_the_light_ray() {
        let plane = Vec4::new(0.0, 1.0, 0.0, 0.0); // y = 0
        let light = Vec4::new(1.0, 4.0, 0.0, 1.0);
        let m = projection_matrix(plane, light);
        let p = Vec3::new(1.0, 2.0, 0.5);
        let q = m.project_point3(p);
        assert!(q.y.abs() < 1e-6, "{q}");
        // On the line from the light through p, twice as far (p is halfway down).
        assert!((q - Vec3::new(1.0, 0.0, 1.0)).length() < 1e-5, "{q}");
        // Directional: along the direction.
        let m = projection_matrix(plane, Vec4::new(0.0, 1.0, 1.0, 0.0));
        let q = m.project_point3(p);
        assert!((q - Vec3::new(1.0, 0.0, -1.5)).length() < 1e-5, "{q}");
    }

    #[test]
    fn only_flat_meshes_have_a_plane() {
        let m = crate::scene::mesh::plane(glam::Vec2::splat(2.0), 3);
        let (n, d) = plane_of(&m).unwrap();
        assert!((n.y.abs() - 1.0).abs() < 1e-6 && d.abs() < 1e-6);
        assert!(plane_of(&crate::scene::mesh::cuboid(Vec3::ONE)).is_none());
    }

    #[test]
    fn clipping_keeps_the_inside() {
        let tri = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 2.0, 0.0)];
        let mut p = Vec::new();
        clip_polygon(&tri, |q| 1.0 - q.x, &mut p);
        assert_eq!(p.len(), 4);
        assert!(p.iter().all(|q| q.x <= 1.0 + 1e-12));
    }
}
