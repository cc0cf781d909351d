//! Projective shadow textures (light cookies, drop shadows; RTR 7.2 "Projection shadows";
//! Cournia section 3.1's projective texturing; Segal et al. 1992): the occluders' silhouette
//! is drawn from the light into a mask texture, which is projected onto the receivers like a
//! slide projector, darkening them where the mask is covered. No depth is stored, so:
//!
//! - occluders never shadow themselves or each other (they are not receivers);
//! - a receiver between the light and the occluders is darkened all the same ("shadows cast
//!   backward": the projection cannot tell in front from behind).
//!
//! Both failures are measured on the `cookie` fixture. The light views are the shadow map's
//! (orthographic for directional lights, the spot's cone, six cube faces for point lights, the
//! face picked by direction so no seams). Occluders: every non-planar object unless named.

use super::shadow_map::{light_views, project};
use super::*;
use crate::pipeline::sampler::{sample_bilinear, sample_nearest, Address};
use crate::pipeline::*;
use glam::{Vec2, Vec4};
use rayon::prelude::*;

const OPTIONS: &[OptionInfo] = &[
    OptionInfo {
        key: "occluders",
        default: "auto",
        doc: "comma-separated names of the objects drawn into the texture, or auto: every non-planar object; all others receive",
    },
    OptionInfo {
        key: "size",
        default: "1024",
        doc: "texture side in texels (per cube face for point lights), 16 to 16384",
    },
    OptionInfo {
        key: "filter",
        default: "nearest",
        doc: "nearest (hard edge) or bilinear (a one-texel soft edge, as cookies are usually sampled)",
    },
];

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "cookie",
        summary: "projective shadow texture (RTR 7.2): occluder mask projected from the light; no self-shadowing, shadows cast backward",
        options: OPTIONS,
        sweep: &[&[], &[("filter", "bilinear")]],
        create: |s| {
            Ok(Box::new(Cookie {
                occluders: s.get("occluders").to_string(),
                size: s.num("size", 16, MAX_DIMENSION)?,
                bilinear: s.choice("filter", &["nearest", "bilinear"])? == "bilinear",
                ..Default::default()
            }))
        },
    }
}

#[derive(Default)]
struct Cookie {
    occluders: String,
    size: u32,
    bilinear: bool,
    /// Last run: one mask per light view, and which objects occluded.
    masks: Vec<Surface<f32>>,
    occluding: Vec<bool>,
    times: Vec<(&'static str, f64)>,
}

impl Cookie {
    /// Which objects are occluders.
    fn pick(&self, frame: &Frame) -> Result<Vec<bool>, String> {
        let objs = &frame.scene.objects;
        if self.occluders == "auto" {
            return Ok(objs
                .iter()
                .map(|o| super::planar::plane_of(&o.mesh).is_none())
                .collect());
        }
        let mut pick = vec![false; objs.len()];
        for name in self.occluders.split(',').map(str::trim) {
            let i = object_named(frame, "cookie", "occluders", name)?;
            pick[i] = true;
        }
        Ok(pick)
    }
}

impl ShadowTechnique for Cookie {
    fn name(&self) -> &'static str {
        "cookie"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Vec<f32>, String> {
        let t0 = std::time::Instant::now();
        self.occluding = self.pick(frame)?;
        let views = light_views(frame, self.size);
        // Pass 1: the occluders' silhouette, 1 where covered (no depth).
        self.masks.clear();
        for view in &views {
            let mut mask = Surface::new(self.size, self.size, 0.0f32).map_err(|e| e.to_string())?;
            for (o, _) in frame.scene.objects.iter().zip(&self.occluding).filter(|(_, k)| **k) {
                p.draw(
                    &mut Targets::color(&mut mask),
                    &RenderState {
                        depth: DepthState {
                            func: CompareFunc::Always,
                            write: false,
                            ..Default::default()
                        },
                        ..Default::default()
                    },
                    &o.mesh.positions,
                    &o.mesh.indices,
                    &TransformPositions(view.matrix),
                    &Shader(|_: &Fragment<()>| Vec4::ONE),
                )
                .map_err(|e| e.to_string())?;
            }
            self.masks.push(mask);
        }
        let t1 = std::time::Instant::now();
        // Pass 2: project the mask onto every receiver pixel.
        let light = frame.light;
        let (w, pts, objs) = (frame.width() as usize, frame.points(), frame.gbuffer.object.data());
        let (masks, occluding, bilinear) = (&self.masks, &self.occluding, self.bilinear);
        let mut out = vec![f32::NAN; pts.len()];
        p.install(|| {
            out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let Some(s) = pts[y * w + x] else { continue };
                    *o = 1.0;
                    if occluding[objs[y * w + x] as usize] {
                        continue; // occluders receive nothing
                    }
                    let face = light_face(views.len(), &light, s.position);
                    let Some((uv, _)) = project(&views[face].matrix, s.position) else {
                        continue;
                    };
                    if uv.cmplt(Vec2::ZERO).any() || uv.cmpgt(Vec2::ONE).any() {
                        continue;
                    }
                    let m = &masks[face];
                    let covered = if bilinear {
                        sample_bilinear(m, uv, Address::Clamp)
                    } else {
                        sample_nearest(m, uv, Address::Clamp)
                    };
                    *o = 1.0 - covered;
                }
            })
        });
        self.times = vec![
            ("mask pass", (t1 - t0).as_secs_f64() * 1e3),
            ("projection pass", t1.elapsed().as_secs_f64() * 1e3),
        ];
        Ok(out)
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![("occluders", self.occluding.iter().filter(|k| **k).count() as f64)]
    }

    fn stages(&self, _: &Pipeline, _: &Frame) -> Result<Vec<Stage>, String> {
        Ok(self
            .masks
            .iter()
            .enumerate()
            .map(|(i, m)| Stage::Scalar {
                name: format!("cookie{i}"),
                data: m.clone(),
                lo: 0.0,
                hi: 1.0,
            })
            .collect())
    }
}
