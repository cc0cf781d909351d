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
//! and texel snapping so camera motion does not move the sampling grid.
//!
//! Known failures: acne without bias, Peter Panning with too much, aliasing where the map is
//! magnified, shimmering of fitted maps without snapping, light leaks of second-depth maps on
//! open (two-sided) geometry, self-shadowing lost by id maps.

use super::*;
use crate::pipeline::sampler::CompareSampler;
use crate::pipeline::*;
use crate::scene::LightKind;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;

const OPTIONS: &[OptionInfo] = &[
    OptionInfo {
        key: "size",
        default: "2048",
        doc: "map side in texels (a cube map has six faces of this size)",
    },
    OptionInfo {
        key: "format",
        default: "f32",
        doc: "depth storage: f32, u24 or u16",
    },
    OptionInfo {
        key: "units",
        default: "4",
        doc: "constant polygon offset, in units of the format's resolvable depth step",
    },
    OptionInfo {
        key: "slope",
        default: "1.1",
        doc: "slope-scaled polygon offset factor",
    },
    OptionInfo {
        key: "normal",
        default: "0",
        doc: "normal-offset bias: texels along the normal, times sin(angle to the light)",
    },
    OptionInfo {
        key: "receiver",
        default: "false",
        doc: "receiver-plane depth bias (one texel of the receiver's depth slope)",
    },
    OptionInfo {
        key: "layer",
        default: "first",
        doc: "first, second (back faces), midpoint (two nearest layers) or id (object ids)",
    },
    OptionInfo {
        key: "fit",
        default: "scene",
        doc: "directional lights: scene bounds, or receivers (casters that shadow visible receivers)",
    },
    OptionInfo {
        key: "snap",
        default: "false",
        doc: "snap the fitted frustum to whole texels (against shimmering)",
    },
    OptionInfo {
        key: "filter",
        default: "none",
        doc: "none (one comparison) or pcf2 (2x2 hardware PCF)",
    },
];

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "shadow-map",
        summary:
            "depth map from the light, one comparison per pixel (RTR 7.4): acne, Peter Panning, aliasing, shimmering",
        options: OPTIONS,
        sweep: &[
            &[("size", "256")],
            &[("size", "512")],
            &[("size", "1024")],
            &[("size", "2048")],
            &[("size", "4096")],
            &[("format", "u16")],
            &[("format", "u24")],
            &[("units", "0"), ("slope", "0")],
            &[("units", "100000")],
            &[("units", "0"), ("slope", "0"), ("normal", "1.5")],
            &[("units", "0"), ("slope", "0"), ("receiver", "true")],
            &[("layer", "second"), ("units", "0"), ("slope", "0")],
            &[("layer", "midpoint"), ("units", "0"), ("slope", "0")],
            &[("layer", "id")],
            &[("fit", "receivers")],
            &[("fit", "receivers"), ("snap", "true")],
            &[("filter", "pcf2")],
        ],
        create: |s| {
            let format = match s.choice("format", &["f32", "u24", "u16"])? {
                "u24" => DepthFormat::Unorm24,
                "u16" => DepthFormat::Unorm16,
                _ => DepthFormat::F32,
            };
            let layer = match s.choice("layer", &["first", "second", "midpoint", "id"])? {
                "second" => Layer::Second,
                "midpoint" => Layer::Midpoint,
                "id" => Layer::Id,
                _ => Layer::First,
            };
            Ok(Box::new(ShadowMap {
                size: s.num("size", 16u32, MAX_DIMENSION)?,
                format,
                offset: PolygonOffset {
                    units: s.num("units", -1e6f32, 1e6)?,
                    factor: s.num("slope", -1e3f32, 1e3)?,
                },
                normal: s.num("normal", 0.0f32, 100.0)?,
                receiver: s.choice("receiver", &["false", "true"])? == "true",
                layer,
                fit_receivers: s.choice("fit", &["scene", "receivers"])? == "receivers",
                snap: s.choice("snap", &["false", "true"])? == "true",
                pcf: s.choice("filter", &["none", "pcf2"])? == "pcf2",
                maps: Vec::new(),
                ids: Vec::new(),
                culled: 0,
                fitted: None,
                times: Vec::new(),
            }))
        },
    }
}

/// What the map stores.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Layer {
    First,
    Second,
    Midpoint,
    Id,
}

/// One light view: world to light clip, and the world size of one texel at unit distance
/// (orthographic: everywhere; perspective: times the distance to the light).
#[derive(Copy, Clone, Debug)]
pub struct LightView {
    /// World to light clip space.
    pub matrix: Mat4,
    /// Texel size in world units (perspective views: per unit of distance from the light).
    pub texel: f32,
    /// True for perspective views (texel size grows with distance).
    pub perspective: bool,
}

fn corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Light views fitted to the whole scene: one (directional, spot) or six (cube faces in
/// [`CubeFace::ALL`] order). `size` is the map side in texels.
pub fn light_views(frame: &Frame, size: u32) -> Vec<LightView> {
    let l = &frame.light;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let cs = corners(lo, hi);
    let far_from = |p: Vec3| cs.iter().map(|c| (*c - p).length()).fold(0.0f32, f32::max) * 1.01 + 1e-3;
    match l.kind {
        LightKind::Directional => vec![directional_view(frame, &cs, &cs, size, false)],
        LightKind::Spot { angle_deg } => {
            let view = Mat4::look_at_rh(l.position, l.position + l.direction, up_for(l.direction));
            let far = far_from(l.position);
            let half = (angle_deg.to_radians() * 0.5).tan();
            vec![LightView {
                matrix: Mat4::perspective_rh(angle_deg.to_radians(), 1.0, (far * 1e-4).max(1e-3), far) * view,
                texel: 2.0 * half / size as f32,
                perspective: true,
            }]
        }
        LightKind::Point | LightKind::Area(_) => {
            let far = far_from(l.position);
            let proj = Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, (far * 1e-4).max(1e-3), far);
            CubeFace::ALL
                .iter()
                .map(|f| {
                    // Rows: x = u, y = -v (texture v points down), z = -forward (looking down -z).
                    let (fwd, u, v) = f.basis();
                    let e = l.position;
                    let view = Mat4::from_cols(
                        Vec4::new(u.x, -v.x, -fwd.x, 0.0),
                        Vec4::new(u.y, -v.y, -fwd.y, 0.0),
                        Vec4::new(u.z, -v.z, -fwd.z, 0.0),
                        Vec4::new(-u.dot(e), v.dot(e), fwd.dot(e), 1.0),
                    );
                    LightView {
                        matrix: proj * view,
                        texel: 2.0 / size as f32,
                        perspective: true,
                    }
                })
                .collect()
        }
    }
}

fn up_for(d: Vec3) -> Vec3 {
    if d.y.abs() < 0.99 {
        Vec3::Y
    } else {
        Vec3::Z
    }
}

/// An orthographic view along a directional light: x/y fitted to `receivers`, depth range
/// covering `receivers` and `casters` (RTR fig. 7.11). With `snap`, the extent is quantized and
/// the origin moved to whole texels, so small camera motions keep the sampling grid in place.
fn directional_view(frame: &Frame, receivers: &[Vec3], casters: &[Vec3], size: u32, snap: bool) -> LightView {
    let l = &frame.light;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let view = Mat4::look_at_rh(center - l.direction * radius * 2.0, center, up_for(l.direction));
    let bounds = |pts: &[Vec3]| {
        pts.iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| {
                let q = view.transform_point3(*p);
                (a.min(q), b.max(q))
            })
    };
    let (rlo, rhi) = bounds(receivers);
    let (_, chi) = bounds(casters);
    let m = radius * 0.01;
    let (mut x0, mut x1, mut y0, mut y1) = (rlo.x - m, rhi.x + m, rlo.y - m, rhi.y + m);
    if snap {
        // A stable extent (rounded up to 1/16 of the scene's diameter) and an origin on whole
        // texels of it: a sub-texel camera move changes neither.
        let q = radius / 8.0;
        let ext = ((x1 - x0).max(y1 - y0) / q).ceil() * q;
        let texel = ext / size as f32;
        x0 = (x0 / texel).floor() * texel;
        y0 = (y0 / texel).floor() * texel;
        x1 = x0 + ext;
        y1 = y0 + ext;
    }
    // Near: the caster closest to the light; far: the farthest receiver.
    let near = -(chi.z.max(rhi.z)) - m;
    let far = -rlo.z + m;
    LightView {
        matrix: Mat4::orthographic_rh(x0, x1, y0, y1, near, far) * view,
        texel: (x1 - x0).max(y1 - y0) / size as f32,
        perspective: false,
    }
}

/// Whether the view's handedness is mirrored (cube faces): winding flips.
fn mirrored(m: &Mat4) -> bool {
    Mat3::from_mat4(*m).determinant() > 0.0
}

struct ShadowMap {
    size: u32,
    format: DepthFormat,
    offset: PolygonOffset,
    normal: f32,
    receiver: bool,
    layer: Layer,
    fit_receivers: bool,
    snap: bool,
    pcf: bool,
    maps: Vec<(Surface<f32>, LightView)>,
    ids: Vec<Surface<f32>>,
    culled: usize,
    /// The fitted view of the last run (directional lights fitted to receivers), for `stages`.
    fitted: Option<LightView>,
    times: Vec<(&'static str, f64)>,
}

impl ShadowMap {
    /// The views of this frame (fitted to receivers if asked and the light is directional),
    /// and the objects that can cast into them.
    fn views(&mut self, frame: &Frame) -> (Vec<LightView>, Vec<bool>) {
        let all = vec![true; frame.scene.objects.len()];
        if !(self.fit_receivers && frame.light.kind == LightKind::Directional) {
            self.culled = 0;
            return (light_views(frame, self.size), all);
        }
        // Visible receivers: the G-buffer's points.
        let pts: Vec<Vec3> = frame.points().iter().flatten().map(|s| s.position).collect();
        if pts.is_empty() {
            return (light_views(frame, self.size), all);
        }
        // Casters: objects whose light-space x/y box overlaps the receivers' (and so can
        // shadow them); the rest are culled.
        let probe = directional_view(frame, &pts, &pts, self.size, false);
        let ndc_box = |ps: &[Vec3]| {
            ps.iter()
                .fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(a, b), p| {
                    let q = probe.matrix.project_point3(*p).truncate();
                    (a.min(q), b.max(q))
                })
        };
        let (rlo, rhi) = ndc_box(&pts);
        let mut casters = Vec::new();
        let keep: Vec<bool> = frame
            .scene
            .objects
            .iter()
            .map(|o| {
                let Some((lo, hi)) = o.mesh.bounds() else { return false };
                let cs = corners(lo, hi);
                let (a, b) = ndc_box(&cs);
                let k = a.x <= rhi.x && b.x >= rlo.x && a.y <= rhi.y && b.y >= rlo.y;
                if k {
                    casters.extend_from_slice(&cs);
                }
                k
            })
            .collect();
        self.culled = keep.iter().filter(|k| !**k).count();
        (
            vec![directional_view(frame, &pts, &casters, self.size, self.snap)],
            keep,
        )
    }

    /// The whole scene seen from the light (256 x 256, grey depth) with the fitted frustum's
    /// footprint drawn over it in red and culled casters' depth left out: RTR fig. 7.11.
    fn fitted_overview(&self, p: &Pipeline, frame: &Frame, fitted: &LightView) -> Result<Surface<Rgba8>, String> {
        const N: u32 = 256;
        let all = light_views(frame, N)[0];
        let d = scene_depth(p, frame, all.matrix, N, N, |_| true)?;
        let mut img = d.map(|z| {
            let g = ((1.0 - z) * 220.0 + 20.0) as u8;
            [g, g, g, 255]
        });
        // The fitted frustum's x/y outline, taken to world at mid depth and into the overview.
        let inv = fitted.matrix.inverse();
        let c = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(x, y)| {
            let w = inv.project_point3(Vec3::new(x, y, 0.5));
            let q = all.matrix.project_point3(w);
            Vec2::new((q.x * 0.5 + 0.5) * N as f32, (0.5 - q.y * 0.5) * N as f32)
        });
        for i in 0..4 {
            draw_segment(&mut img, c[i], c[(i + 1) % 4], [230, 40, 40, 255]);
        }
        Ok(img)
    }

    /// Renders one depth layer of `objects` for `view`: `cull` selects faces; `peel` (if any)
    /// keeps only fragments behind the given layer.
    #[allow(clippy::too_many_arguments)]
    fn depth_layer(
        &self,
        p: &Pipeline,
        casters: &(Vec<Vec3>, Vec<u32>),
        view: &LightView,
        cull: CullMode,
        peel: Option<&Surface<f32>>,
        reuse: Option<Surface<f32>>,
    ) -> Result<Surface<f32>, String> {
        // A previous run's map of the right size is reused; the draw clears it as it goes.
        let mut map = match reuse {
            Some(m) if m.width() == self.size && m.height() == self.size => m,
            _ => Surface::new(self.size, self.size, 1.0f32).map_err(|e| e.to_string())?,
        };
        let cull = match (cull, mirrored(&view.matrix)) {
            (CullMode::Back, true) => CullMode::Front,
            (CullMode::Front, true) => CullMode::Back,
            (c, _) => c,
        };
        let offset = if peel.is_some() {
            PolygonOffset::default()
        } else {
            self.offset
        };
        let state = RenderState {
            offset,
            cull,
            depth: DepthState {
                format: self.format,
                ..Default::default()
            },
            ..Default::default()
        };
        // All kept casters in one draw (in scene order): one pass over the tiles, not one per
        // object.
        let (positions, indices) = casters;
        let vs = TransformPositions(view.matrix);
        let r = match peel {
            None => p.draw(
                &mut Targets::depth_only(&mut map).clearing_depth(1.0),
                &state,
                positions,
                indices,
                &vs,
                &DepthOnly,
            ),
            Some(first) => {
                // Depth peeling: only fragments clearly behind the first layer.
                let eps = 2.0 * self.format.resolvable(1.0).max(1e-6);
                let fs =
                    DiscardingShader(move |f: &Fragment<()>| (f.z > first.at(f.x, f.y) + eps).then_some(Vec4::ZERO));
                p.draw(
                    &mut Targets::depth_only(&mut map).clearing_depth(1.0),
                    &state,
                    positions,
                    indices,
                    &vs,
                    &fs,
                )
            }
        };
        r.map_err(|e| e.to_string())?;
        Ok(map)
    }
}

impl ShadowTechnique for ShadowMap {
    fn name(&self) -> &'static str {
        "shadow-map"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Vec<f32>, String> {
        // Pass 1: the light's map(s).
        let t0 = std::time::Instant::now();
        let (views, keep) = self.views(frame);
        self.fitted = (self.fit_receivers && frame.light.kind == LightKind::Directional).then_some(views[0]);
        let mut old: Vec<Surface<f32>> = self.maps.drain(..).map(|(m, _)| m).collect();
        self.ids.clear();
        let casters = merged_casters(frame, &keep)?;
        for view in views {
            let reuse = old.pop();
            let map = match self.layer {
                Layer::First => self.depth_layer(p, &casters, &view, CullMode::None, None, reuse)?,
                Layer::Second => self.depth_layer(p, &casters, &view, CullMode::Front, None, reuse)?,
                Layer::Midpoint => {
                    let d1 = self.depth_layer(p, &casters, &view, CullMode::None, None, reuse)?;
                    let d2 = self.depth_layer(p, &casters, &view, CullMode::None, Some(&d1), None)?;
                    let mid: Vec<f32> = d1.data().iter().zip(d2.data()).map(|(a, b)| 0.5 * (a + b)).collect();
                    Surface::from_vec(self.size, self.size, mid).map_err(|e| e.to_string())?
                }
                Layer::Id => {
                    // Object ids (+1; 0 = empty) of the nearest surface; its depth is the map
                    // `dump` shows.
                    let mut ids = Surface::new(self.size, self.size, 0.0f32).map_err(|e| e.to_string())?;
                    let mut depth = Surface::new(self.size, self.size, 1.0f32).map_err(|e| e.to_string())?;
                    for (oi, o) in frame.scene.objects.iter().enumerate().filter(|(i, _)| keep[*i]) {
                        let id = oi as f32 + 1.0;
                        let fs = Shader(move |_: &Fragment<()>| Vec4::splat(id));
                        let vs = TransformPositions(view.matrix);
                        p.draw(
                            &mut Targets::color(&mut ids).with_depth(&mut depth),
                            &RenderState::default(),
                            &o.mesh.positions,
                            &o.mesh.indices,
                            &vs,
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

        let t1 = std::time::Instant::now();
        // Pass 2: one lookup per camera pixel.
        let sampler = CompareSampler::default();
        let (w, h, light) = (frame.width() as usize, frame.height() as usize, frame.light);
        let pts = frame.points();
        let objs = frame.gbuffer.object.data();
        let mut out = vec![f32::NAN; pts.len()];
        let this = &*self;
        p.install(|| {
            out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let Some(s) = pts[y * w + x] else { continue };
                    let face = light_face(this.maps.len(), &light, s.position);
                    let (map, view) = &this.maps[face];
                    // Normal offset: move the lookup point along the normal (Holbert 2011).
                    let mut pos = s.position;
                    if this.normal > 0.0 {
                        let l = light.to_light(s.position);
                        let sin = (1.0 - s.normal.dot(l).clamp(-1.0, 1.0).powi(2)).sqrt();
                        let texel = if view.perspective {
                            view.texel * (s.position - light.position).length()
                        } else {
                            view.texel
                        };
                        pos += s.normal * (this.normal * texel * sin);
                    }
                    let Some((uv, z)) = project(&view.matrix, pos) else {
                        *o = 1.0;
                        continue;
                    };
                    if this.layer == Layer::Id {
                        let id = crate::pipeline::sampler::sample_nearest(
                            &this.ids[face],
                            uv,
                            crate::pipeline::sampler::Address::Clamp,
                        );
                        let inside = uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all();
                        *o = if !inside || id == 0.0 || id as u32 == objs[y * w + x] + 1 {
                            1.0
                        } else {
                            0.0
                        };
                        continue;
                    }
                    let mut z = z;
                    if this.receiver {
                        z -= receiver_plane_bias(pts, objs, w, h, x, y, &view.matrix, map.width());
                    }
                    let z = this.format.quantize(z.clamp(0.0, 1.0));
                    *o = if this.pcf {
                        sampler.pcf2x2(map, uv, z)
                    } else {
                        sampler.nearest(map, uv, z)
                    };
                }
            })
        });
        self.times = vec![
            ("light pass", (t1 - t0).as_secs_f64() * 1e3),
            ("lookup pass", t1.elapsed().as_secs_f64() * 1e3),
        ];
        Ok(out)
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
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
                data: self.fitted_overview(p, frame, fitted)?,
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

/// The kept objects' triangles as one mesh, in scene order (one draw instead of one per
/// object). An object whose indices reach past its own vertices is an error, as its own draw
/// would be.
fn merged_casters(frame: &Frame, keep: &[bool]) -> Result<(Vec<Vec3>, Vec<u32>), String> {
    let kept = || {
        frame
            .scene
            .objects
            .iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(o, _)| o)
    };
    let mut positions = Vec::with_capacity(kept().map(|o| o.mesh.positions.len()).sum());
    let mut indices = Vec::with_capacity(kept().map(|o| o.mesh.indices.len()).sum());
    for o in kept() {
        let m = &o.mesh;
        if let Some(bad) = m.indices.iter().find(|&&i| i as usize >= m.positions.len()) {
            return Err(format!(
                "object '{}': index {bad} beyond its {} vertices",
                o.name,
                m.positions.len()
            ));
        }
        let base = positions.len() as u32;
        positions.extend_from_slice(&m.positions);
        indices.extend(m.indices.iter().map(|i| i + base));
    }
    Ok((positions, indices))
}

/// Light-space texture coordinate and depth of a world point, if in front of the light.
#[inline]
pub(crate) fn project(m: &Mat4, p: Vec3) -> Option<(Vec2, f32)> {
    let c = *m * p.extend(1.0);
    if c.w <= 0.0 {
        return None;
    }
    let ndc = c.truncate() / c.w;
    Some((Vec2::new(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5), ndc.z))
}

/// Receiver-plane depth bias (Isidoro 2006): from the light-space (u, v, z) of this pixel and
/// its right and lower neighbours (same surface), solve for dz/du and dz/dv and return the
/// depth change across one texel, `(|dz/du| + |dz/dv|) / size`. Zero where the neighbours are
/// missing or the Jacobian is singular.
#[allow(clippy::too_many_arguments)]
fn receiver_plane_bias(
    pts: &[Option<crate::reference::SamplePoint>],
    objs: &[u32],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    m: &Mat4,
    size: u32,
) -> f32 {
    let own = objs[y * w + x];
    let at = |xx: usize, yy: usize| {
        if objs[yy * w + xx] == own {
            pts[yy * w + xx].and_then(|s| project(m, s.position))
        } else {
            None
        }
    };
    let Some((uv0, z0)) = at(x, y) else { return 0.0 };
    let nx = if x + 1 < w {
        at(x + 1, y)
    } else if x > 0 {
        at(x - 1, y)
    } else {
        None
    };
    let ny = if y + 1 < h {
        at(x, y + 1)
    } else if y > 0 {
        at(x, y - 1)
    } else {
        None
    };
    let (Some((uvx, zx)), Some((uvy, zy))) = (nx, ny) else {
        return 0.0;
    };
    let (du1, dz1) = (uvx - uv0, zx - z0);
    let (du2, dz2) = (uvy - uv0, zy - z0);
    let det = du1.x * du2.y - du2.x * du1.y;
    if det.abs() < 1e-20 {
        return 0.0;
    }
    let dzdu = (dz1 * du2.y - dz2 * du1.y) / det;
    let dzdv = (du1.x * dz2 - du2.x * dz1) / det;
    let b = (dzdu.abs() + dzdv.abs()) / size as f32;
    if b.is_finite() {
        b.min(0.05)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Pipeline;

    #[test]
    fn fitting_culls_casters_that_cannot_shadow_visible_receivers() {
        // A box far to the side of the view casts nowhere the camera looks: culled.
        let text = "[camera]\nposition = [0, 3, 6]\ntarget = [0, 0, 0]\nresolution = [64, 48]\n\n[[light]]\ntype = \"directional\"\ndirection = [0.2, -1, 0.1]\n\n[[object]]\nmesh = \"plane\"\nsize = 8\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [0, 0.5, 0]\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [60, 0.5, 0]\n";
        let scene = crate::scene::file::parse(text, std::path::Path::new("t.toml")).unwrap();
        let p = Pipeline::new(2).unwrap();
        let f = crate::frame::frame(&p, &scene, 0, 0).unwrap();
        let mut sm = ShadowMap {
            size: 256,
            format: DepthFormat::F32,
            offset: PolygonOffset {
                factor: 1.1,
                units: 4.0,
            },
            normal: 0.0,
            receiver: false,
            layer: Layer::First,
            fit_receivers: true,
            snap: false,
            pcf: false,
            maps: Vec::new(),
            ids: Vec::new(),
            culled: 0,
            fitted: None,
            times: Vec::new(),
        };
        sm.visibility(&p, &f).unwrap();
        assert_eq!(sm.culled, 1);
    }
}
