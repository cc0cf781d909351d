//! Penumbra volumes (Cournia 2005, chapters 4 and 5): silhouettes from the light's centre
//! extruded into volumes that enclose the penumbrae, rendered from the light into maps that
//! the camera pass reads.
//!
//! - [`pvm`]: penumbra volume maps (ch. 4): per-vertex extrusion vectors clipped against the
//!   neighbouring edges' planes, a map of the nearest volume's silhouette edge, and the
//!   light's visibility from the cutting plane through the pixel and that edge (eq. 4.1, 4.2).
//! - [`pvmf`]: penumbra volume mask filtering (ch. 5): overestimated volumes edge by edge as a
//!   mask with each edge's distance from the light, a PCF as wide as the penumbra only inside
//!   the mask, and an object-aware blur.
//!
//! Shared here: the light-space silhouettes of every object, from the shadow volumes' edge
//! adjacency ([`crate::shadow::volume::silhouette`]) chained into loops; the rendering of
//! volume quadrilaterals into a depth map plus a texel per volume through the pipeline; and
//! the disk visibility of a cutting plane.

pub mod pvm;
pub mod pvmf;

use crate::frame::Frame;
use crate::math;
use crate::pipeline::*;
use crate::scene::LightKind;
use crate::shadow::inspect::Step;
use crate::shadow::light::soft::light_width;
use crate::shadow::light::{homogeneous_position, LightView};
use crate::shadow::sample::lookup::MapLookup;
use crate::shadow::technique::{Effect, Entry, Family, Field, Stage};
use crate::shadow::timing::Passes;
use crate::shadow::volume::silhouette;
use crate::Error;
use glam::{Vec3, Vec4};
use std::collections::HashMap;

/// The light's radius for penumbra volumes: half the scene's area light width (the soft
/// techniques' light width, [`light_width`]) times `scale`; 0 for point, spot and directional lights (no
/// extent, or no centre to extrude from).
pub fn light_radius(frame: &Frame, scale: f32) -> f32 {
    match frame.light.kind {
        LightKind::Area(_) => 0.5 * light_width(frame, scale, 0.0),
        _ => 0.0,
    }
}

/// The `light` option both methods declare: the radius as a multiple of half the area light's
/// width.
pub fn light_field<O: Clone + Default + 'static>(access: fn(&mut O) -> &mut f32) -> Field<O> {
    Field::range(
        "light",
        "the light's radius as a multiple of half the scene's area light width (0: hard shadow)",
        0.0,
        1e3,
        access,
    )
}

/// One silhouette edge seen from the light's centre, oriented as its light-facing triangle
/// winds (the occluder lies on the positive side of its hard shadow plane
/// `(b - a) x (a - l)`).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Edge {
    /// First end point (world).
    pub a: Vec3,
    /// Second end point (world).
    pub b: Vec3,
    /// The scene object it belongs to.
    pub object: u32,
}

/// The light-space silhouettes of a frame's objects, chained into loops.
#[derive(Clone, Debug, Default)]
pub struct Silhouettes {
    /// Every silhouette edge, objects in scene order.
    pub edges: Vec<Edge>,
    /// Per edge: the edge of the same loop ending where it starts (`None`: an open loop).
    pub prev: Vec<Option<u32>>,
    /// Per edge: the edge of the same loop starting where it ends.
    pub next: Vec<Option<u32>>,
    /// Objects whose mesh is not a closed manifold, with the shadow volumes' description.
    pub irregular: Vec<(String, String)>,
}

/// The silhouettes of every object of `frame` from the light's centre (Cournia 4.1.1: an
/// edge whose two faces face the light and away from it; the adjacency and the open,
/// non-manifold handling are the shadow volumes'), with each edge's neighbours in its loop.
pub fn silhouettes(p: &Pipeline, frame: &Frame) -> Silhouettes {
    let light = homogeneous_position(&frame.light);
    let (volumes, irregular) = silhouette::scene_volumes(p, frame, light);
    let mut s = Silhouettes {
        irregular,
        ..Default::default()
    };
    for (i, v) in volumes.into_iter().enumerate() {
        s.edges
            .extend(v.silhouette.into_iter().map(|(a, b)| Edge { a, b, object: i as u32 }));
    }
    // Loops: edges meet at welded positions (bit patterns, as the adjacency welds). Where
    // several edges leave one vertex (two loops touching), the first in order is taken.
    let key = |v: Vec3, o: u32| (o, (v.x + 0.0).to_bits(), (v.y + 0.0).to_bits(), (v.z + 0.0).to_bits());
    let mut starts: HashMap<(u32, u32, u32, u32), u32> = HashMap::with_capacity(s.edges.len());
    let mut ends: HashMap<(u32, u32, u32, u32), u32> = HashMap::with_capacity(s.edges.len());
    for (i, e) in s.edges.iter().enumerate().rev() {
        starts.insert(key(e.a, e.object), i as u32);
        ends.insert(key(e.b, e.object), i as u32);
    }
    s.prev = s.edges.iter().map(|e| ends.get(&key(e.a, e.object)).copied()).collect();
    s.next = s
        .edges
        .iter()
        .map(|e| starts.get(&key(e.b, e.object)).copied())
        .collect();
    s
}

/// Volume quadrilaterals to render from the light: homogeneous vertices (`w = 0`: extruded
/// to infinity, beyond the far plane), two triangles per quad, and one texel value per quad.
#[derive(Clone, Debug, Default)]
pub struct Quads {
    /// Homogeneous world positions, four per quad.
    pub vertices: Vec<Vec4>,
    /// Six indices per quad.
    pub indices: Vec<u32>,
    /// The value each quad writes into the texel map.
    pub texels: Vec<f32>,
}

impl Quads {
    /// Adds the quad `p0, p1, p2, p3` (homogeneous) writing `texel`.
    pub fn push(&mut self, p: [Vec4; 4], texel: f32) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&p);
        self.indices
            .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        self.texels.push(texel);
    }

    /// Number of quads.
    pub fn len(&self) -> usize {
        self.texels.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.texels.is_empty()
    }
}

/// One light view's volume map: the nearest volume's depth and its texel (Cournia 4.1.3: the
/// penumbra volume depth map and, in one texel, what identifies the volume).
#[derive(Clone, Debug)]
pub struct VolumeMap {
    /// Light-space depth of the nearest volume surface (1: none).
    pub depth: Surface<f32>,
    /// The nearest volume's texel value (-1: none).
    pub texel: Surface<f32>,
    /// Fragments the volumes rasterized.
    pub fragments: u64,
}

/// Renders `quads` from `view` into a `size` x `size` volume map in one pass (both faces, depth
/// test `Less` with the pipeline's depth clamp so that the far ends at infinity are not
/// clipped): the depth target is the volume depth map, the colour target (one `f32` per
/// texel) holds the nearest quad's value, which the program reads by primitive id.
pub fn render(p: &Pipeline, quads: &Quads, view: &LightView, size: u32) -> Result<VolumeMap, Error> {
    let mut depth = Surface::new(size, size, 1.0f32)?;
    let mut texel = Surface::new(size, size, -1.0f32)?;
    if quads.is_empty() {
        return Ok(VolumeMap {
            depth,
            texel,
            fragments: 0,
        });
    }
    let state = RenderState {
        depth: DepthState {
            clamp: true,
            ..Default::default()
        },
        ..Default::default()
    };
    let texels = &quads.texels;
    let fs = Shader(move |f: &Fragment<()>| Vec4::splat(texels[(f.prim / 2) as usize]));
    let stats = p.draw(
        &mut Targets::color(&mut texel).with_depth(&mut depth),
        &state,
        &quads.vertices,
        &quads.indices,
        &TransformHomogeneous(view.matrix),
        &fs,
    )?;
    Ok(VolumeMap {
        depth,
        texel,
        fragments: stats.fragments_rasterized,
    })
}

impl VolumeMap {
    /// The map's depth for `dump` as stage `name` (from the nearest depth to 1); `None` when
    /// no volume reached the map.
    pub fn depth_stage(&self, name: String) -> Option<Stage> {
        (self.fragments > 0).then(|| Stage::Scalar {
            name,
            data: self.depth.clone(),
            lo: self.depth.data().iter().copied().fold(1.0f32, f32::min),
            hi: 1.0,
        })
    }
}

/// [`render`] in every view of `lookup`'s maps, at the maps' size.
pub fn render_views(p: &Pipeline, quads: &Quads, lookup: &MapLookup, size: u32) -> Result<Vec<VolumeMap>, Error> {
    lookup
        .maps()
        .iter()
        .map(|(_, view)| render(p, quads, view, size))
        .collect()
}

/// The passes both techniques begin with, timed into `passes`: the depth maps ("light
/// pass"), the light's radius scaled by `light` ([`light_radius`]) and, for a light with a
/// size, the silhouettes ("silhouettes"; none for a point light).
pub fn light_and_silhouettes(
    p: &Pipeline,
    frame: &Frame,
    lookup: &mut MapLookup,
    light: f32,
    passes: &mut Passes,
) -> Result<(f32, Silhouettes), Error> {
    lookup.light_pass(p, frame)?;
    let radius = light_radius(frame, light);
    passes.end("light pass");
    let sil = if radius > 0.0 {
        silhouettes(p, frame)
    } else {
        Silhouettes::default()
    };
    passes.end("silhouettes");
    Ok((radius, sil))
}

/// What every penumbra-volume technique's registry entry shares: the family, and the area
/// light among the effects it models.
pub const BASE: Entry = Entry {
    family: Family::Penumbra,
    models: &[Effect::AreaLight],
    ..Entry::BASE
};

/// The first step of `inspect` for a technique over silhouette volumes: its map pass, the
/// light's radius and the silhouette edges.
pub fn volume_step(lookup: &MapLookup, radius: f32, sil: &Silhouettes) -> Step {
    lookup
        .pass_step()
        .num("light radius", radius)
        .int("silhouette edges", sil.edges.len())
}

/// The input warnings of silhouettes `sil`: each object that is not a closed manifold, with
/// `then`, what the technique does there.
pub fn silhouette_notes(sil: &Silhouettes, then: &str) -> Vec<String> {
    sil.irregular
        .iter()
        .map(|(o, d)| format!("object '{o}': {d}; {then}"))
        .collect()
}

/// The light's visibility through a cutting plane (Cournia 4.2): the plane through the edge
/// `h0 -> h1` and the point `p`, `n = (h1 - h0) x (p - h0) / |...|`, `d = -n . h0`; the
/// light centre's distance `s = n . l + d`; the area of a disk of radius `r` perpendicular to
/// the plane beyond it, eq. 4.1, `a = acos(s / r) r^2 / 2 - s sqrt(r^2 - s^2) / 2`; and
/// eq. 4.2, `k = 2 a / (pi r^2)`. With the edge oriented as [`Edge`], the occluder lies on
/// the positive side, so `k` is the fraction of the disk on the negative (unblocked) side.
/// Returns `(k, s)`; a degenerate plane (`p` on the edge's line) gives `k = 0.5`.
pub fn disk_visibility(h0: Vec3, h1: Vec3, p: Vec3, l: Vec3, r: f32) -> (f32, f32) {
    let n = (h1 - h0).cross(p - h0);
    let len = n.length();
    if len.is_nan() || len <= 0.0 || r.is_nan() || r <= 0.0 {
        return (0.5, 0.0);
    }
    let n = n / len;
    let s = n.dot(l) - n.dot(h0);
    let x = s / r;
    // A disk wholly on one side is wholly lit or blocked, exactly (acos(-1) is not exactly
    // the float pi in every libm).
    if x <= -1.0 {
        return (1.0, s);
    }
    if x >= 1.0 {
        return (0.0, s);
    }
    // 2a / (pi r^2) with a from eq. 4.1, r factored out.
    let k = (math::acos(x) - x * (1.0 - x * x).max(0.0).sqrt()) / std::f32::consts::PI;
    (k.clamp(0.0, 1.0), s)
}

/// Parker et al.'s smoothing of a straight edge's linear fall-off for a spherical light, the
/// Bernstein interpolant `3 k^2 - 2 k^3` (Cournia 4.2).
#[inline]
pub fn bernstein(k: f32) -> f32 {
    k * k * (3.0 - 2.0 * k)
}

/// Per silhouette edge: the outer and inner extrusion vectors at its two ends (PVM's
/// penumbra volume, PVMF's mask volume).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Extrusion {
    /// Outer vector at the edge's first and second end.
    pub outer: [Vec3; 2],
    /// Inner vector at the edge's first and second end.
    pub inner: [Vec3; 2],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_visibility_is_half_on_the_hard_shadow_plane_and_monotonic() {
        // Edge along x at height 1, light above at height 5; the occluder lies at z > 0 (the
        // positive side of (b - a) x (a - l)).
        let (a, b, l) = (
            Vec3::new(-1.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 5.0, 0.0),
        );
        let m = (b - a).cross(a - l);
        let side = m.z.signum();
        assert!(side != 0.0, "{m}");
        let (k, s) = disk_visibility(a, b, Vec3::new(0.0, -1.0, 0.0), l, 0.5);
        assert!((k - 0.5).abs() < 1e-6 && s.abs() < 1e-6, "{k} {s}");
        // Moving into the umbra side (z > 0) darkens, out of it brightens, within [0, 1].
        let mut last = 1.0;
        for z in [-2.0f32, -0.5, -0.2, 0.0, 0.2, 0.5, 2.0] {
            let (k, _) = disk_visibility(a, b, Vec3::new(0.0, -1.0, z * side), l, 0.5);
            assert!(k <= last + 1e-6 && (0.0..=1.0).contains(&k), "{z}: {k}");
            last = k;
        }
        assert_eq!(disk_visibility(a, b, Vec3::new(0.0, -1.0, -2.0 * side), l, 0.5).0, 1.0);
        assert_eq!(disk_visibility(a, b, Vec3::new(0.0, -1.0, 2.0 * side), l, 0.5).0, 0.0);
        // Eq. 4.1 against the circular segment's area: the vertical plane z = 1/4 has normal
        // -z (from the edge's direction), so s = 1/4 and the disk of radius 1/2 is cut at half
        // its radius.
        let c = 0.25;
        let (k, s) = disk_visibility(
            Vec3::new(-1.0, 1.0, c),
            Vec3::new(1.0, 1.0, c),
            Vec3::new(0.0, -1.0, c),
            l,
            0.5,
        );
        let x: f32 = 0.5;
        let seg = (math::acos(x) - x * (1.0 - x * x).sqrt()) / std::f32::consts::PI;
        assert!((s - c).abs() < 1e-6 && (k - seg).abs() < 1e-6, "{k} {s} {seg}");
        assert_eq!(bernstein(0.0), 0.0);
        assert_eq!(bernstein(1.0), 1.0);
        assert_eq!(bernstein(0.5), 0.5);
    }
}
