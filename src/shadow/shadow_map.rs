//! The basic shadow map (Williams 1978; RTR 7.4, Cournia 3.1): depth from the light through
//! the pipeline, then one depth comparison per camera pixel. Directional lights get an
//! orthographic map fitted to the scene bounds, spot lights a perspective map of their cone,
//! point and area lights (their centre) a cube map of six 90-degree faces.
//!
//! Known failures: acne without bias, Peter Panning with too much, aliasing where the map is
//! magnified (perspective aliasing) and along grazing receivers (projective aliasing).

use super::*;
use crate::pipeline::sampler::CompareSampler;
use crate::pipeline::*;
use crate::scene::LightKind;
use glam::{Mat4, Vec2, Vec3, Vec4};
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
        key: "filter",
        default: "none",
        doc: "none (one comparison) or pcf2 (2x2 hardware PCF)",
    },
];

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "shadow-map",
        summary: "depth map from the light, one comparison per pixel (RTR 7.4): acne, Peter Panning, aliasing",
        options: OPTIONS,
        sweep: &[
            &[("size", "512")],
            &[("size", "1024")],
            &[("size", "2048")],
            &[("size", "4096")],
            &[("size", "2048"), ("filter", "pcf2")],
            &[("size", "2048"), ("units", "0"), ("slope", "0")],
        ],
        create: |s| {
            let format = match s.choice("format", &["f32", "u24", "u16"])? {
                "u24" => DepthFormat::Unorm24,
                "u16" => DepthFormat::Unorm16,
                _ => DepthFormat::F32,
            };
            Ok(Box::new(ShadowMap {
                size: s.num("size", 16u32, MAX_DIMENSION)?,
                format,
                offset: PolygonOffset {
                    units: s.num("units", -1e6f32, 1e6)?,
                    factor: s.num("slope", -1e3f32, 1e3)?,
                },
                pcf: s.choice("filter", &["none", "pcf2"])? == "pcf2",
                maps: Vec::new(),
            }))
        },
    }
}

/// The light's views: one matrix (directional, spot) or six (cube faces, in [`CubeFace::ALL`]
/// order).
pub fn light_views(frame: &Frame) -> Vec<Mat4> {
    let l = &frame.light;
    let (lo, hi) = frame.scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let corners: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        })
        .collect();
    let up_for = |d: Vec3| if d.y.abs() < 0.99 { Vec3::Y } else { Vec3::Z };
    let far_from = |p: Vec3| corners.iter().map(|c| (*c - p).length()).fold(0.0f32, f32::max) * 1.01 + 1e-3;
    match l.kind {
        LightKind::Directional => {
            let view = Mat4::look_at_rh(center - l.direction * radius * 2.0, center, up_for(l.direction));
            let (mut vlo, mut vhi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for c in &corners {
                let q = view.transform_point3(*c);
                vlo = vlo.min(q);
                vhi = vhi.max(q);
            }
            let m = radius * 0.01;
            vec![Mat4::orthographic_rh(vlo.x - m, vhi.x + m, vlo.y - m, vhi.y + m, -vhi.z - m, -vlo.z + m) * view]
        }
        LightKind::Spot { angle_deg } => {
            let view = Mat4::look_at_rh(l.position, l.position + l.direction, up_for(l.direction));
            let far = far_from(l.position);
            vec![Mat4::perspective_rh(angle_deg.to_radians(), 1.0, (far * 1e-4).max(1e-3), far) * view]
        }
        LightKind::Point | LightKind::Area(_) => {
            let far = far_from(l.position);
            let proj = Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, (far * 1e-4).max(1e-3), far);
            CubeFace::ALL
                .iter()
                .map(|f| {
                    // Rows: x = u, y = -v (texture v points down), z = -forward (the view looks down -z).
                    let (fwd, u, v) = f.basis();
                    let e = l.position;
                    let view = Mat4::from_cols(
                        Vec4::new(u.x, -v.x, -fwd.x, 0.0),
                        Vec4::new(u.y, -v.y, -fwd.y, 0.0),
                        Vec4::new(u.z, -v.z, -fwd.z, 0.0),
                        Vec4::new(-u.dot(e), v.dot(e), fwd.dot(e), 1.0),
                    );
                    proj * view
                })
                .collect()
        }
    }
}

struct ShadowMap {
    size: u32,
    format: DepthFormat,
    offset: PolygonOffset,
    pcf: bool,
    maps: Vec<(Surface<f32>, Mat4)>,
}

impl ShadowTechnique for ShadowMap {
    fn name(&self) -> &'static str {
        "shadow-map"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Vec<f32>, String> {
        // Pass 1: depth from the light (one map, or six cube faces), no culling.
        let state = RenderState {
            offset: self.offset,
            depth: DepthState {
                format: self.format,
                ..Default::default()
            },
            ..Default::default()
        };
        self.maps.clear();
        for m in light_views(frame) {
            let mut map = Surface::new(self.size, self.size, 1.0f32).map_err(|e| e.to_string())?;
            for o in &frame.scene.objects {
                p.draw(
                    &mut Targets::depth_only(&mut map),
                    &state,
                    &o.mesh.positions,
                    &o.mesh.indices,
                    &TransformPositions(m),
                    &DepthOnly,
                )
                .map_err(|e| e.to_string())?;
            }
            self.maps.push((map, m));
        }
        // Pass 2: one comparison per camera pixel.
        let cube = self.maps.len() == 6;
        let sampler = CompareSampler::default();
        let (w, light) = (frame.width() as usize, frame.light);
        let pts = frame.points();
        let mut out = vec![f32::NAN; pts.len()];
        let maps = &self.maps;
        let pcf = self.pcf;
        let fmt = self.format;
        p.install(|| {
            out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let Some(s) = pts[y * w + x] else { continue };
                    let face = if cube {
                        CubeFace::from_direction(s.position - light.position).map_or(0, |f| f.0 as usize)
                    } else {
                        0
                    };
                    let (map, m) = &maps[face];
                    let c = *m * s.position.extend(1.0);
                    if c.w <= 0.0 {
                        *o = 1.0;
                        continue;
                    }
                    let ndc = c.truncate() / c.w;
                    let uv = Vec2::new(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
                    let z = fmt.quantize(ndc.z.clamp(0.0, 1.0));
                    *o = if pcf {
                        sampler.pcf2x2(map, uv, z)
                    } else {
                        sampler.nearest(map, uv, z)
                    };
                }
            })
        });
        Ok(out)
    }

    fn stages(&self) -> Vec<Stage> {
        self.maps
            .iter()
            .enumerate()
            .map(|(i, (m, _))| Stage::Scalar {
                name: format!("depth_map{i}"),
                data: m.clone(),
                lo: 0.0,
                hi: 1.0,
            })
            .collect()
    }
}
