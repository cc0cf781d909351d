//! The stencil shadow-volume pass (Crow 1977; Heidmann z-pass; Carmack's reverse z-fail;
//! RTR 7.3, CS300, Cournia 3.2), shared by the `shadow-volume` technique and the multi-sample
//! light's `volumes` method: silhouette edges from edge adjacency ([`super::silhouette`])
//! extruded away from the light to infinity, capped, and counted in the pipeline's two-sided
//! stencil with wrapping increments (z-pass from the eye's count, or z-fail with depth clamp
//! or an infinite far plane, per [`Mode`]). Count 0: lit.

use super::silhouette::{self, Volume};
use crate::frame::Frame;
use crate::pipeline::*;
use crate::scene::LightKind;
use crate::shadow::inspect::{NoTrace, Step, Steps, Trace};
use crate::shadow::light::{homogeneous_position, scene_depth};
use crate::shadow::overview::{backdrop, draw_world_segment};
use crate::shadow::pass::Pass;
use crate::shadow::technique::Stage;
use crate::shadow::timing::Passes;
use crate::Error;
use glam::{Mat4, Vec3, Vec4};

crate::choice_enum! {
    /// How the stencil counts volumes.
    pub enum Mode {
        /// z-pass unless a caster may put the near plane in shadow, z-fail otherwise.
        Auto = "auto",
        /// Capped z-fail with the pipeline's depth clamp (Carmack's reverse).
        Zfail = "zfail",
        /// Capped z-fail with an infinite far plane projection and its own depth pre-pass.
        ZfailInfinite = "zfail-infinite",
        /// z-pass (Heidmann), the stencil starting at the eye's count.
        Zpass = "zpass",
        /// z-pass starting at 0 (wrong whenever the eye is inside a volume).
        ZpassNaive = "zpass-naive",
        /// z-fail without depth clamp (wrong where the far plane cuts a volume).
        ZfailNoclamp = "zfail-noclamp",
    }
}

/// The stencil shadow-volume pass: the volumes of a frame's casters counted in the stencil
/// (see the module docs), with what `inspect`, `dump` and the counters report of it.
#[derive(Default)]
pub struct StencilVolumes {
    mode: &'static str,
    /// The last run's stencil.
    stencil: Option<Surface<u8>>,
    /// The last run's volumes, one per object.
    volumes: Vec<Volume>,
    /// Mesh defects of the last run: (object name, description) of each irregular object.
    irregular: Vec<(String, String)>,
    chose_zpass: bool,
    /// The eye's volume count (z-pass).
    eye: u32,
    /// Stencil fragments (volume fill) of the last run.
    fill: u64,
}

impl StencilVolumes {
    /// The pass counting with `mode`.
    pub fn new(mode: Mode) -> StencilVolumes {
        StencilVolumes {
            mode: mode.as_str(),
            ..Default::default()
        }
    }

    /// Whether the last run counted z-pass (auto mode chooses).
    pub fn chose_zpass(&self) -> bool {
        self.chose_zpass
    }
}

impl Pass for StencilVolumes {
    type Output = Vec<f32>;

    fn run(&mut self, p: &Pipeline, frame: &Frame, passes: &mut Passes) -> Result<Vec<f32>, Error> {
        let light = homogeneous_position(&frame.light);
        (self.volumes, self.irregular) = silhouette::scene_volumes(p, frame, light);
        passes.end("silhouettes");
        self.chose_zpass = match self.mode {
            "auto" => zpass_is_safe(frame),
            m => m.starts_with("zpass"),
        };
        self.eye = if self.mode == "zpass-naive" || !self.chose_zpass {
            0
        } else {
            silhouette::eye_count(&self.volumes, frame.camera.position, light)
        };
        passes.end("eye count");
        // Camera transform and depth: the G-buffer's, or for `zfail-infinite` a projection with
        // the far plane at infinity (Everitt and Kilgard 2002) and a depth pre-pass with it.
        let infinite = self.mode == "zfail-infinite";
        let cam = &frame.camera;
        let vp = if infinite {
            Mat4::perspective_infinite_rh(cam.fov_deg.to_radians(), cam.width as f32 / cam.height as f32, cam.near)
                * cam.view()
        } else {
            cam.view_projection()
        };
        let mut depth = if infinite {
            scene_depth(p, frame, vp, frame.width(), frame.height(), |_| true)?
        } else {
            frame.gbuffer.depth.clone()
        };
        let mut stencil = Surface::new(frame.width(), frame.height(), self.eye as u8)?;
        let (front, back) = if self.chose_zpass {
            (
                StencilFace {
                    pass: StencilOp::IncrWrap,
                    ..Default::default()
                },
                StencilFace {
                    pass: StencilOp::DecrWrap,
                    ..Default::default()
                },
            )
        } else {
            (
                StencilFace {
                    depth_fail: StencilOp::DecrWrap,
                    ..Default::default()
                },
                StencilFace {
                    depth_fail: StencilOp::IncrWrap,
                    ..Default::default()
                },
            )
        };
        let state = RenderState {
            depth: DepthState {
                func: CompareFunc::Less,
                write: false,
                clamp: !matches!(self.mode, "zfail-noclamp" | "zfail-infinite"),
                ..Default::default()
            },
            stencil: StencilState {
                enabled: true,
                front,
                back,
                ..Default::default()
            },
            ..Default::default()
        };
        let vs = TransformHomogeneous(vp);
        self.fill = 0;
        for v in &self.volumes {
            let st = p.draw(
                &mut Targets::none().with_depth(&mut depth).with_stencil(&mut stencil),
                &state,
                &v.vertices,
                &v.indices,
                &vs,
                &DepthOnly,
            )?;
            self.fill += st.fragments_rasterized;
        }
        let out: Vec<f32> = frame
            .points()
            .iter()
            .zip(stencil.data())
            .map(|(pt, &s)| {
                if pt.is_none() {
                    f32::NAN
                } else {
                    resolve(s, &mut NoTrace)
                }
            })
            .collect();
        self.stencil = Some(stencil);
        passes.end("stencil pass");
        Ok(out)
    }

    fn explain(&self, frame: &Frame, x: u32, y: u32, t: &mut Steps) -> Option<f32> {
        let stencil = self.stencil.as_ref()?;
        let s = frame.point(x, y)?;
        let light = homogeneous_position(&frame.light);
        t.0.push(
            Step::new(
                "counting",
                if self.chose_zpass {
                    "z-pass: the stencil starts at the eye's count; front faces in front of the point add 1, back faces subtract 1"
                } else {
                    "z-fail: back faces behind the point add 1, front faces behind it subtract 1 (the caps close each volume)"
                },
            )
            .text("mode", self.mode)
            .flag("z-pass", self.chose_zpass)
            .int("eye count", self.eye),
        );
        // Which volumes contain the point: a segment test from the point to the light
        // against each volume's caps (independent of the stencil pass).
        let p = s.position + s.normal * 1e-4;
        let inside: Vec<String> = self
            .volumes
            .iter()
            .zip(&frame.scene.objects)
            .filter(|(v, _)| silhouette::eye_count(std::slice::from_ref(*v), p, light) > 0)
            .map(|(_, o)| o.name.clone())
            .collect();
        t.0.push(
            Step::new(
                "volumes containing the point",
                "objects whose shadow volume holds the point, by a segment test towards the light (a check of the count)",
            )
            .int("count", inside.len())
            .text("objects", inside.join(", ")),
        );
        Some(resolve(stencil.at(x, y), t))
    }

    fn notes(&self) -> Vec<String> {
        self.irregular
            .iter()
            .map(|(name, what)| format!("object '{name}': {what}; its volume uses every triangle, turned to the light"))
            .collect()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let sum = |f: fn(&Volume) -> usize| self.volumes.iter().map(f).sum::<usize>() as f64;
        vec![
            ("stencil fragments", self.fill as f64),
            ("silhouette edges", sum(|v| v.silhouette.len())),
            ("volume triangles", sum(|v| v.indices.len() / 3)),
            ("eye count", self.eye as f64),
            ("irregular meshes", self.irregular.len() as f64),
        ]
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let Some(stencil) = &self.stencil else {
            return Ok(Vec::new());
        };
        // Silhouette edges over a grey picture of the view; edges of meshes that use every
        // triangle (irregular meshes) in orange.
        let mut sil = backdrop(frame);
        for v in &self.volumes {
            let color = if v.all_triangles {
                [255, 150, 20, 255]
            } else {
                [255, 40, 40, 255]
            };
            for &(a, b) in &v.silhouette {
                draw_world_segment(&mut sil, frame, a, b, color);
            }
        }
        // The volumes from the camera: fragments per pixel, every volume triangle counted
        // (the stencil pass's fill, which the depth test does not reduce).
        let mut fill = Surface::new(frame.width(), frame.height(), 0.0f32)?;
        let state = RenderState::accumulate();
        let vs = TransformHomogeneous(frame.camera.view_projection());
        for v in &self.volumes {
            p.draw(
                &mut Targets::color(&mut fill),
                &state,
                &v.vertices,
                &v.indices,
                &vs,
                &Shader(|_: &Fragment<()>| Vec4::ONE),
            )?;
        }
        let hi = fill.data().iter().copied().fold(1.0f32, f32::max);
        Ok(vec![
            // The name records which counting the pass used (auto mode chooses).
            Stage::Scalar {
                name: if self.chose_zpass {
                    "stencil_counts_zpass"
                } else {
                    "stencil_counts_zfail"
                }
                .into(),
                data: stencil.map(|v| v as i8 as f32),
                lo: -2.0,
                hi: 2.0,
            },
            Stage::Color {
                name: "silhouettes".into(),
                data: sil,
            },
            Stage::Scalar {
                name: "volume_fill".into(),
                data: fill,
                lo: 0.0,
                hi,
            },
        ])
    }
}

/// Whether z-pass is safe: no caster can put any point of the camera's near-plane rectangle
/// in shadow. Conservative: true only when no caster's bounding box meets the bounding box of
/// the near rectangle swept towards the light (to the light's position, or across the scene
/// for directional lights). Z-fail (with clamp) is always correct; z-pass is cheaper to reason
/// about and needs no caps.
pub fn zpass_is_safe(frame: &Frame) -> bool {
    let cam = &frame.camera;
    let inv = crate::math::inverse(&cam.view_projection());
    let near: Vec<Vec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(x, y)| inv.project_point3(Vec3::new(x, y, 0.0)))
        .collect();
    let (slo, shi) = frame.scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let reach = (shi - slo).length() * 2.0 + (cam.position - slo).length();
    let mut pts = near.clone();
    match frame.light.kind {
        LightKind::Directional => pts.extend(near.iter().map(|p| *p - frame.light.direction * reach)),
        _ => pts.push(frame.light.position),
    }
    let (lo, hi) = pts
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    !frame
        .scene
        .objects
        .iter()
        .filter_map(|o| o.mesh.bounds())
        .any(|(a, b)| a.cmple(hi).all() && b.cmpge(lo).all())
}

/// The per-pixel resolve of the stencil pass (the image's, and `inspect`'s with a recording
/// trace): lit where the count is 0.
#[inline(always)]
fn resolve(count: u8, t: &mut impl Trace) -> f32 {
    t.step(|| {
        Step::new("stencil", "the count after the pass (wrapping 8-bit); 0 is lit")
            .int("stencil", count)
            .int("as signed", count as i8)
    });
    if count == 0 {
        1.0
    } else {
        0.0
    }
}
