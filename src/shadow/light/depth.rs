//! The light's depth pass: casters merged into one draw, rendered through the pipeline into a
//! depth map of any format with polygon offset (constant + slope-scaled bias), face culling
//! and optional depth peeling (for second-depth and midpoint maps).

use super::LightView;
use crate::frame::Frame;
use crate::pipeline::*;
use crate::Error;
use glam::{Vec3, Vec4};

/// The casters' triangles as one mesh, in scene order.
#[derive(Clone, Debug, Default)]
pub struct Casters {
    /// World positions.
    pub positions: Vec<Vec3>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// Per triangle: the index of its scene object.
    pub object: Vec<u32>,
    /// Per triangle: its scene-wide id ([`crate::scene::Scene::triangle_bases`] + its index
    /// in its object), the id the G-buffer reports for the surface it is.
    pub triangle: Vec<u32>,
}

/// The kept objects' triangles as one mesh, in scene order (one draw instead of one per
/// object). An object whose indices reach past its own vertices is an error, as its own draw
/// would be.
pub fn merged_casters(frame: &Frame, keep: &[bool]) -> Result<Casters, Error> {
    let kept = || {
        frame
            .scene
            .objects
            .iter()
            .enumerate()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(o, _)| o)
    };
    let mut c = Casters {
        positions: Vec::with_capacity(kept().map(|(_, o)| o.mesh.positions.len()).sum()),
        indices: Vec::with_capacity(kept().map(|(_, o)| o.mesh.indices.len()).sum()),
        object: Vec::new(),
        triangle: Vec::new(),
    };
    let bases = frame.scene.triangle_bases();
    for (oi, o) in kept() {
        let m = &o.mesh;
        if let Some(bad) = m.indices.iter().find(|&&i| i as usize >= m.positions.len()) {
            return Err(Error::Scene {
                file: frame.scene.name.clone().into(),
                line: None,
                section: Some(format!("object '{}'", o.name)),
                field: Some("indices".into()),
                message: format!("index {bad} beyond its {} vertices", m.positions.len()),
            });
        }
        let base = c.positions.len() as u32;
        c.positions.extend_from_slice(&m.positions);
        c.indices.extend(m.indices.iter().map(|i| i + base));
        c.object.extend(std::iter::repeat_n(oi as u32, m.indices.len() / 3));
        c.triangle.extend(bases[oi]..bases[oi] + (m.indices.len() / 3) as u32);
    }
    Ok(c)
}

/// A depth pass's settings: map side, depth format and polygon offset.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DepthPass {
    /// Map side in texels.
    pub size: u32,
    /// Depth storage format.
    pub format: DepthFormat,
    /// Polygon offset of the (first) layer; peeled layers use none.
    pub offset: PolygonOffset,
}

impl DepthPass {
    /// Renders one depth layer of `casters` for `view`: `cull` selects faces (swapped for
    /// mirrored views); `peel` (if any) keeps only fragments clearly behind the given layer.
    /// `reuse` is a previous map of the right size to draw into (the draw clears it).
    pub fn render(
        &self,
        p: &Pipeline,
        casters: &Casters,
        view: &LightView,
        cull: CullMode,
        peel: Option<&Surface<f32>>,
        reuse: Option<Surface<f32>>,
    ) -> Result<Surface<f32>, Error> {
        let mut map = match reuse {
            Some(m) if m.width() == self.size && m.height() == self.size => m,
            _ => Surface::new(self.size, self.size, 1.0f32)?,
        };
        let cull = match (cull, view.mirrored()) {
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
        if let Some(rows) = view.log() {
            // LogPSM: the perspective warp's space drawn at the logarithmic rows' samples.
            if peel.is_some() {
                return Err(Error::technique(
                    "a logarithmic map draws one depth layer (first or second), not peeled ones",
                ));
            }
            let grid = samples::SampleGrid::rows(self.size, &rows.table(self.size))?;
            let m = view.matrix;
            let clip: Vec<Vec4> = casters.positions.iter().map(|q| m * q.extend(1.0)).collect();
            p.draw_depth_at(&mut map, Some(1.0), &state, &clip, &casters.indices, &grid)?;
            return Ok(map);
        }
        // All kept casters in one draw (in scene order): one pass over the tiles, not one per
        // object.
        let vs = TransformPositions(view.matrix);
        let targets = &mut Targets::depth_only(&mut map).clearing_depth(1.0);
        let r = match peel {
            None => p.draw(targets, &state, &casters.positions, &casters.indices, &vs, &DepthOnly),
            Some(first) => {
                // Depth peeling: only fragments clearly behind the first layer.
                let eps = 2.0 * self.format.resolvable(1.0).max(1e-6);
                let fs =
                    DiscardingShader(move |f: &Fragment<()>| (f.z > first.at(f.x, f.y) + eps).then_some(Vec4::ZERO));
                p.draw(targets, &state, &casters.positions, &casters.indices, &vs, &fs)
            }
        };
        r?;
        Ok(map)
    }
}

/// Depth of every object of `frame`'s scene for which `keep(object index)` holds, seen
/// through `matrix`, into a fresh `w` x `h` target (1 = empty).
pub fn scene_depth(
    p: &Pipeline,
    frame: &Frame,
    matrix: glam::Mat4,
    w: u32,
    h: u32,
    keep: impl Fn(usize) -> bool,
) -> Result<Surface<f32>, Error> {
    let mut d = Surface::new(w, h, 1.0f32)?;
    for (_, o) in frame.scene.objects.iter().enumerate().filter(|(i, _)| keep(*i)) {
        p.draw(
            &mut Targets::depth_only(&mut d),
            &RenderState::default(),
            &o.mesh.positions,
            &o.mesh.indices,
            &TransformPositions(matrix),
            &DepthOnly,
        )?;
    }
    Ok(d)
}
