//! Stencil shadow volumes (Crow 1977; Heidmann z-pass; Carmack's reverse z-fail; RTR 7.3,
//! CS300, Cournia 3.2): silhouette edges from edge adjacency are extruded away from the light
//! to infinity (homogeneous w = 0), capped in front by the light-facing triangles and at
//! infinity by the same triangles projected away; the camera depth is the G-buffer's; the
//! pipeline's two-sided stencil counts volume entries and exits, with depth clamp so the far
//! plane never cuts a volume. Count 0: lit.
//!
//! Open edges (one triangle) count as silhouette edges when their triangle faces the light
//! (CS300). Meshes with an edge shared by more than two triangles are non-manifold: they are
//! reported in `stages` and drawn as per-triangle volumes (every light-facing triangle's own
//! three edges), which is exact for any mesh, only slower.
//!
//! Mode `auto` uses z-pass when no caster can shadow the camera's near-plane rectangle
//! (a conservative bounding-box test) and z-fail otherwise (Everitt and Kilgard 2002).
//!
//! Known failure: z-pass with the eye inside a volume (mode `zpass`), and with z-fail the
//! far plane cutting volumes when clamping is off (mode `zfail-noclamp`).

use super::*;
use crate::pipeline::*;
use crate::scene::{LightKind, Mesh};
use glam::{Mat4, Vec3, Vec4};
use std::collections::{BTreeMap, HashMap};

const OPTIONS: &[OptionInfo] = &[OptionInfo {
    key: "mode",
    default: "auto",
    doc: "auto (z-pass unless a caster may put the near plane in shadow), zfail (capped, depth clamp), zpass (Heidmann), or zfail-noclamp",
}];

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "shadow-volume",
        summary: "stencil shadow volumes, silhouettes by adjacency (RTR 7.3): exact; z-pass fails with the eye inside a volume",
        options: OPTIONS,
        sweep: &[&[], &[("mode", "zfail")], &[("mode", "zpass")]],
        create: |s| {
            let mode = s.choice("mode", &["auto", "zfail", "zpass", "zfail-noclamp"])?;
            Ok(Box::new(ShadowVolume { mode, stencil: None, silhouettes: 0, nonmanifold: 0, chose_zpass: false }))
        },
    }
}

struct ShadowVolume {
    mode: &'static str,
    stencil: Option<Surface<u8>>,
    silhouettes: usize,
    nonmanifold: usize,
    chose_zpass: bool,
}

/// Whether z-pass is safe: no caster can put any point of the camera's near-plane rectangle
/// in shadow. Conservative: true only when no caster's bounding box meets the bounding box of
/// the near rectangle swept towards the light (to the light's position, or across the scene
/// for directional lights). Z-fail (with clamp) is always correct; z-pass is cheaper to reason
/// about and needs no caps.
pub fn zpass_is_safe(frame: &Frame) -> bool {
    let cam = &frame.camera;
    let inv = cam.view_projection().inverse();
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

/// Clip-space transform of homogeneous world positions (w = 0: points at infinity).
struct Homogeneous(Mat4);
impl VertexProgram for Homogeneous {
    type In = Vec4;
    type Out = ();
    fn run(&self, v: &Vec4) -> (Vec4, ()) {
        (self.0 * *v, ())
    }
}

/// One use of an edge: (triangle, first vertex, second vertex) in the triangle's winding.
type EdgeUse = (usize, u32, u32);

/// Volume geometry of one mesh for one light: homogeneous vertices and triangle indices,
/// outward-facing. Returns also the number of silhouette edges and whether the mesh was
/// non-manifold (then per-triangle volumes were built).
pub fn volume_geometry(mesh: &Mesh, light_pos: Vec4) -> (Vec<Vec4>, Vec<u32>, usize, bool) {
    // Weld positions so faces that share corners (flat-shaded boxes) share edges.
    let mut weld: HashMap<[u32; 3], u32> = HashMap::new();
    let ids: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let n = weld.len() as u32;
            *weld.entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]).or_insert(n)
        })
        .collect();
    let tris: Vec<[u32; 3]> = mesh
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .filter(|t| {
            ids[t[0] as usize] != ids[t[1] as usize]
                && ids[t[1] as usize] != ids[t[2] as usize]
                && ids[t[0] as usize] != ids[t[2] as usize]
        })
        .collect();
    // Light-facing: the light is on the front (counter-clockwise) side of the triangle.
    let facing: Vec<bool> = tris
        .iter()
        .map(|t| {
            let (a, b, c) = (
                mesh.positions[t[0] as usize],
                mesh.positions[t[1] as usize],
                mesh.positions[t[2] as usize],
            );
            let n = (b - a).cross(c - a);
            let to_light = light_pos.truncate() - a * light_pos.w;
            n.dot(to_light) > 0.0
        })
        .collect();
    // Edge adjacency over welded ids: (min, max) -> triangles using it (ordered: the volume's
    // geometry, and so its dump, is the same on every run).
    let mut edges: BTreeMap<(u32, u32), Vec<EdgeUse>> = BTreeMap::new();
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (ia, ib) = (ids[a as usize], ids[b as usize]);
            edges.entry((ia.min(ib), ia.max(ib))).or_default().push((ti, a, b));
        }
    }
    let nonmanifold = edges.values().any(|v| v.len() > 2);
    let mut verts: Vec<Vec4> = Vec::new();
    let mut idx: Vec<u32> = Vec::new();
    let far = |p: Vec3| -> Vec4 {
        // Away from the light, at infinity (w = 0).
        if light_pos.w == 0.0 {
            (-light_pos.truncate()).extend(0.0)
        } else {
            (p - light_pos.truncate()).extend(0.0)
        }
    };
    let quad = |a: Vec3, b: Vec3, verts: &mut Vec<Vec4>, idx: &mut Vec<u32>| {
        // Edge a -> b of a light-facing, counter-clockwise triangle: the side quad
        // (b, a, a_inf, b_inf) faces outward.
        let base = verts.len() as u32;
        verts.extend_from_slice(&[b.extend(1.0), a.extend(1.0), far(a), far(b)]);
        idx.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    };
    let mut silhouettes = 0;
    if nonmanifold {
        for (t, _) in tris.iter().zip(&facing).filter(|(_, f)| **f) {
            for k in 0..3 {
                let (a, b) = (mesh.positions[t[k] as usize], mesh.positions[t[(k + 1) % 3] as usize]);
                quad(a, b, &mut verts, &mut idx);
                silhouettes += 1;
            }
        }
    } else {
        for list in edges.values() {
            // The silhouette edge in the winding of its light-facing triangle, if any.
            let edge = match list.as_slice() {
                [(t, a, b)] if facing[*t] => Some((a, b)),
                [(t0, a0, b0), (t1, a1, b1)] if facing[*t0] != facing[*t1] => {
                    Some(if facing[*t0] { (a0, b0) } else { (a1, b1) })
                }
                _ => None,
            };
            if let Some((a, b)) = edge {
                quad(
                    mesh.positions[*a as usize],
                    mesh.positions[*b as usize],
                    &mut verts,
                    &mut idx,
                );
                silhouettes += 1;
            }
        }
    }
    // Caps: light-facing triangles (front), and the same projected to infinity, reversed (back).
    for (t, _) in tris.iter().zip(&facing).filter(|(_, f)| **f) {
        let p = [
            mesh.positions[t[0] as usize],
            mesh.positions[t[1] as usize],
            mesh.positions[t[2] as usize],
        ];
        let base = verts.len() as u32;
        verts.extend_from_slice(&[
            p[0].extend(1.0),
            p[1].extend(1.0),
            p[2].extend(1.0),
            far(p[0]),
            far(p[1]),
            far(p[2]),
        ]);
        idx.extend_from_slice(&[base, base + 1, base + 2, base + 3, base + 5, base + 4]);
    }
    (verts, idx, silhouettes, nonmanifold)
}

impl ShadowTechnique for ShadowVolume {
    fn name(&self) -> &'static str {
        "shadow-volume"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Vec<f32>, String> {
        let light_pos = match frame.light.kind {
            LightKind::Directional => (-frame.light.direction).extend(0.0),
            _ => frame.light.position.extend(1.0),
        };
        let mut depth = frame.gbuffer.depth.clone();
        let mut stencil = Surface::new(frame.width(), frame.height(), 0u8).map_err(|e| e.to_string())?;
        self.chose_zpass = match self.mode {
            "auto" => zpass_is_safe(frame),
            m => m == "zpass",
        };
        let zfail = !self.chose_zpass;
        let (front, back) = if zfail {
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
        } else {
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
        };
        let state = RenderState {
            depth: DepthState {
                func: CompareFunc::Less,
                write: false,
                clamp: self.mode != "zfail-noclamp",
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
        let vs = Homogeneous(frame.camera.view_projection());
        self.silhouettes = 0;
        self.nonmanifold = 0;
        for o in &frame.scene.objects {
            let (verts, idx, sil, nm) = volume_geometry(&o.mesh, light_pos);
            self.silhouettes += sil;
            self.nonmanifold += nm as usize;
            p.draw(
                &mut Targets::none().with_depth(&mut depth).with_stencil(&mut stencil),
                &state,
                &verts,
                &idx,
                &vs,
                &DepthOnly,
            )
            .map_err(|e| e.to_string())?;
        }
        let v = frame
            .points()
            .iter()
            .zip(stencil.data())
            .map(|(pt, &s)| {
                if pt.is_none() {
                    f32::NAN
                } else if s == 0 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        self.stencil = Some(stencil);
        Ok(v)
    }

    fn stages(&self) -> Vec<Stage> {
        self.stencil
            .iter()
            .map(|s| Stage::Scalar {
                // The name records which counting the pass used (auto mode chooses).
                name: if self.chose_zpass {
                    "stencil_counts_zpass"
                } else {
                    "stencil_counts_zfail"
                }
                .into(),
                data: s.map(|v| v as i8 as f32),
                lo: -2.0,
                hi: 2.0,
            })
            .collect()
    }
}
