//! Adaptive volumetric shadow maps (Salvi, Vidimce, Lauritzen and Lefohn 2010; RTR 7.8):
//! each light texel keeps a fixed number of nodes `(depth, transmittance)`, a compressed
//! transmittance curve along its light ray, built as the casters' fragments stream in.
//!
//! - **Light pass**: every caster (opaque ones transmit 0, semi-transparent ones their
//!   material's transmittance per channel) is drawn from the light (views of
//!   [`crate::shadow::light`]: one, or six cube faces) through the pipeline's raster-ordered
//!   storage ([`Pipeline::draw_ordered`]): each fragment, in submission order per texel,
//!   inserts a node at its depth and multiplies the transmittance of every node behind it by
//!   its own. When the texel's nodes overflow, the node whose removal changes the curve's
//!   area least is removed, never the first: the streaming lossy compression of the paper. On
//!   a GPU this needs pixel-order interlock (D3D's rasterizer-ordered views); here the
//!   pipeline's tile ownership gives the same per-texel order for free, so the result does
//!   not depend on the thread count (a test checks it).
//! - **The curve.** Our casters are thin surfaces, so each fragment is a step of the curve
//!   (the paper's particles are segments with linear falloff inside): a node stores the
//!   transmittance *behind* its depth, `T(z)` is the transmittance of the last node in front
//!   of `z` (1 in front of every node). Removing node `i` extends node `i - 1`'s value over
//!   `[d_i, d_{i+1})`, which changes the area under the curve by
//!   `|T_{i-1} - T_i| (d_{i+1} - d_i)` (summed over the channels); the paper's metric is the
//!   same area for its piecewise-linear reconstruction.
//! - **Lookup**: the receiver's light-space depth, with the shadow map's polygon offset in
//!   the light pass so that a surface does not shadow itself, against its texel's curve.
//!
//! Known failure: order dependence. The compression is greedy and streaming, so the same
//! fragments in another order give another curve: `order=reverse` inserts every texel's
//! fragments in reverse submission order, and the difference is measured on `smoke`. With too
//! few nodes for the layers of a texel, far layers merge and light leaks.

pub use super::PassOptions;
use super::{LightPass, PointLookup, Texel, Volumetric};
use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::*;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::light::{light_views, merged_casters, LightView, Payload, ViewMaps};
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Field, Stage};
use crate::Error;
use glam::Vec3;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "avsm",
    summary: "adaptive volumetric shadow maps (Salvi et al. 2010; RTR 7.8): a fixed number of (depth, transmittance) nodes per texel, compressed as fragments stream in; order-dependent",
    sweep: &[&[], &[("nodes", "4")], &[("nodes", "16")], &[("order", "reverse")]],
    ..super::BASE
};

/// Most nodes a texel may keep.
pub const MAX_NODES: usize = 64;

/// Options of the adaptive volumetric shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Nodes per texel, 1 to 64. Default: 8 (the paper's common setting).
    pub nodes: u32,
    /// Insertion order. Default: forward.
    pub order: Order,
    /// The light pass: map side, polygon offset. Default: 512 texels, the shadow map's
    /// offset (4 units, slope 1.1).
    pub pass: PassOptions,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            pass: PassOptions::sized(512),
            nodes: 8,
            order: Order::Forward,
        }
    }
}

choice_enum! {
    /// The order in which each texel's fragments are inserted.
    pub enum Order {
        /// Submission order (scene order, then triangle order).
        Forward = "forward",
        /// Reverse submission order (to show the method's order dependence).
        Reverse = "reverse",
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    super::declaration(
        "avsm",
        |o: &mut Options| &mut o.pass,
        vec![
            Field::range(
                "nodes",
                "nodes per texel (the compressed curve's size)",
                1,
                MAX_NODES as u32,
                |o: &mut Options| &mut o.nodes,
            ),
            Field::new(
                "order",
                "forward (submission order) or reverse (each texel's fragments backwards: order dependence)",
                |o: &mut Options| &mut o.order,
            ),
        ],
    )
}

/// One node of a texel's curve: the transmittance per channel behind `depth`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Node {
    /// Light-space depth in [0, 1].
    pub depth: f32,
    /// Transmittance behind it, per channel.
    pub t: Vec3,
}

/// A texel's curve as stored: `nodes` slots of [`Node`]s in depth order (unused slots at
/// depth infinity), then one header slot whose depth counts the fragments inserted and whose
/// first channel counts the nodes removed by compression (both exact below 2^24).
#[derive(Copy, Clone, Debug)]
pub struct Curve<'a>(pub &'a [Node]);

/// An unused node slot.
pub const UNUSED: Node = Node {
    depth: f32::INFINITY,
    t: Vec3::ONE,
};

/// A cleared header slot.
pub const HEADER: Node = Node {
    depth: 0.0,
    t: Vec3::ZERO,
};

impl Curve<'_> {
    /// The nodes in use.
    pub fn nodes(&self) -> &[Node] {
        let slots = &self.0[..self.0.len() - 1];
        &slots[..slots.partition_point(|n| n.depth.is_finite())]
    }

    /// Fragments inserted into the texel.
    pub fn inserted(&self) -> u32 {
        self.0[self.0.len() - 1].depth as u32
    }

    /// Nodes removed by compression.
    pub fn removed(&self) -> u32 {
        self.0[self.0.len() - 1].t.x as u32
    }

    /// Transmittance at depth `z`: the last node strictly in front of it (1 if none).
    pub fn at(&self, z: f32) -> Vec3 {
        let n = self.nodes();
        let k = n.partition_point(|nd| nd.depth < z);
        if k == 0 {
            Vec3::ONE
        } else {
            n[k - 1].t
        }
    }
}

/// Inserts a fragment at `depth` transmitting `t` (per channel) into a texel's slots (see
/// [`Curve`]) (Salvi et al.: insert, then, past the slot count, remove the node whose
/// removal changes the area under the curve least, never the first).
pub fn insert(slots: &mut [Node], depth: f32, t: Vec3) {
    let max = slots.len() - 1;
    let header = slots[max];
    let len = Curve(slots).nodes().len();
    // Work on a copy with room for one more node.
    let mut buf = [UNUSED; MAX_NODES + 1];
    buf[..len].copy_from_slice(&slots[..len]);
    let k = buf[..len].partition_point(|nd| nd.depth <= depth);
    let before = if k == 0 { Vec3::ONE } else { buf[k - 1].t };
    // Everything behind the fragment is attenuated by it.
    for nd in &mut buf[k..len] {
        nd.t *= t;
    }
    buf.copy_within(k..len, k + 1);
    buf[k] = Node { depth, t: before * t };
    let mut n = len + 1;
    let mut removed = header.t.x;
    while n > max {
        remove_least(&mut buf, n);
        n -= 1;
        removed += 1.0;
    }
    slots[..n].copy_from_slice(&buf[..n]);
    slots[max] = Node {
        depth: header.depth + 1.0,
        t: Vec3::new(removed, 0.0, 0.0),
    };
}

/// Removes the node (never the first) of `buf[..n]` whose removal changes the area under the
/// curve least: node `i` going extends `T_{i-1}` over `[d_i, d_{i+1})`, an area of
/// `|T_{i-1} - T_i| (d_{i+1} - d_i)` summed over the channels. With one node, nothing goes
/// but the new one's information is lost: the first node stays.
fn remove_least(buf: &mut [Node], n: usize) {
    if n <= 1 {
        return;
    }
    let area = |i: usize| {
        let next = if i + 1 < n { buf[i + 1].depth } else { 1.0 };
        let d = (buf[i - 1].t - buf[i].t).abs();
        (d.x + d.y + d.z) * (next - buf[i].depth).max(0.0)
    };
    let mut best = 1;
    let mut best_area = area(1);
    for i in 2..n {
        let a = area(i);
        if a < best_area {
            best = i;
            best_area = a;
        }
    }
    buf.copy_within(best + 1..n, best);
    buf[n - 1] = UNUSED;
}

/// The light pass of the adaptive volumetric shadow map: a store of curves per light view.
pub struct AvsmPass {
    opts: Options,
    /// Last run: one store of curves (`nodes + 1` slots per texel) and view per light view.
    maps: ViewMaps<PixelStore<Node>>,
    fragments: u64,
}

/// The adaptive volumetric shadow map (see the module docs).
pub type Avsm = PassTechnique<Volumetric<AvsmPass>>;

impl Avsm {
    /// An AVSM with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Avsm, Error> {
        declaration().check(&opts)?;
        Ok(Volumetric::technique(
            "avsm",
            AvsmPass {
                opts,
                maps: ViewMaps::default(),
                fragments: 0,
            },
        ))
    }
}

impl PointLookup for AvsmPass {
    /// The transmittance at world point `p` (the per-pixel pass, and `inspect` with a
    /// recording trace): the curve of the texel the point falls in, read at its depth, every
    /// step reported to `t`.
    fn transmittance(&self, frame: &Frame, p: Vec3, t: &mut impl Trace) -> Vec3 {
        let Some((store, at)) = Texel::of(&self.maps, frame, p, self.opts.pass.size, t) else {
            return Vec3::ONE;
        };
        let (z, c) = (at.depth, Curve(store.pixel(at.x, at.y)));
        t.step(|| at.step("the texel whose curve the point reads, and its depth there", z));
        t.step(|| {
            let mut st = Step::new(
                "curve",
                "the texel's nodes (depth: transmittance behind it, per channel), after streaming compression",
            )
            .int("nodes", c.nodes().len())
            .int("fragments inserted", c.inserted())
            .int("nodes removed", c.removed());
            for (i, n) in c.nodes().iter().enumerate() {
                st = st
                    .num(&format!("node {i} depth"), n.depth)
                    .vec3(&format!("node {i} T"), n.t);
            }
            st
        });
        let v = c.at(z.clamp(0.0, 1.0));
        t.step(|| {
            Step::new(
                "lookup",
                "the transmittance of the last node in front of the point (1 if none)",
            )
            .int("nodes in front", c.nodes().partition_point(|n| n.depth < z))
            .vec3("transmittance", v)
        });
        v
    }
}

/// The light pass's payload: per view, every texel's nodes, each fragment inserted in
/// primitive order by `program`.
struct Nodes<'a, F> {
    size: u32,
    /// Nodes per texel, and the header.
    slots: usize,
    positions: &'a [Vec3],
    indices: &'a [u32],
    state: RenderState,
    program: F,
    /// Fragments inserted, every view.
    fragments: u64,
}

impl<F: Fn(&Fragment<()>, &mut [Node]) + Sync> Payload for Nodes<'_, F> {
    type Map = PixelStore<Node>;

    fn what(&self) -> &'static str {
        "the AVSM node maps"
    }

    fn draw(
        &mut self,
        p: &Pipeline,
        _: usize,
        view: &LightView,
        reuse: Option<PixelStore<Node>>,
    ) -> Result<PixelStore<Node>, Error> {
        let (size, slots) = (self.size, self.slots);
        let mut store = match reuse {
            Some(s) if s.width() == size && s.pixel(0, 0).len() == slots => s,
            _ => PixelStore::fixed(size, size, slots, UNUSED)?,
        };
        p.install(|| {
            use rayon::prelude::*;
            store.data_mut().par_chunks_mut(slots).for_each(|px| {
                px.fill(UNUSED);
                px[slots - 1] = HEADER;
            })
        });
        let st = p.draw_ordered(
            &mut Targets::none(),
            &self.state,
            self.positions,
            self.indices,
            &TransformPositions(view.matrix),
            &self.program,
            &mut store,
        )?;
        self.fragments += st.fragments_shaded;
        Ok(store)
    }
}

impl LightPass for AvsmPass {
    fn render(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error> {
        let o = self.opts.clone();
        let scene = frame.scene;
        // Casters in scene order, each triangle with its material's transmittance.
        let casters = merged_casters(frame, &vec![true; scene.objects.len()])?;
        let transmit = super::transmittances(scene, &casters);
        let mut indices = casters.indices.clone();
        if o.order == Order::Reverse {
            // Every texel then sees its fragments backwards (triangles reversed; a triangle
            // covers a texel once).
            let tris: Vec<[u32; 3]> = indices.chunks_exact(3).rev().map(|t| [t[0], t[1], t[2]]).collect();
            indices = tris.concat();
        }
        let ntri = transmit.len() as u32;
        let reverse = o.order == Order::Reverse;
        let program = |f: &Fragment<()>, px: &mut [Node]| {
            let tri = if reverse { ntri - 1 - f.prim } else { f.prim };
            insert(px, f.z, transmit[tri as usize]);
        };
        let state = RenderState {
            offset: o.pass.offset(),
            depth: DepthState {
                func: CompareFunc::Always,
                write: false,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut payload = Nodes {
            size: o.pass.size,
            slots: o.nodes as usize + 1,
            positions: &casters.positions,
            indices: &indices,
            state,
            program,
            fragments: 0,
        };
        self.maps
            .render(p, light_views(frame, o.pass.size), o.pass.size, &mut payload)?;
        self.fragments = payload.fragments;
        Ok(())
    }

    fn ran(&self) -> bool {
        !self.maps.is_empty()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let slots = self.opts.nodes as usize + 1;
        let curves = || {
            self.maps
                .iter()
                .flat_map(move |(s, _)| s.data().chunks_exact(slots).map(Curve))
        };
        let removed: u64 = curves().map(|c| c.removed() as u64).sum();
        let max_in = curves().map(|c| c.inserted()).max().unwrap_or(0);
        let texels = curves().count();
        vec![
            ("fragments inserted", self.fragments as f64),
            ("nodes removed", removed as f64),
            ("max fragments in a texel", max_in as f64),
            (
                "light-space bytes",
                (texels * slots * std::mem::size_of::<Node>()) as f64,
            ),
        ]
    }

    fn stages(&self) -> Result<Vec<Stage>, Error> {
        let mut v = Vec::new();
        for (i, (s, _)) in self.maps.iter().enumerate() {
            let (w, h) = (s.width(), s.height());
            let slots = self.opts.nodes as usize + 1;
            let of = |f: &dyn Fn(Curve) -> f32| -> Result<Surface<f32>, Error> {
                Surface::from_vec(w, h, s.data().chunks_exact(slots).map(|c| f(Curve(c))).collect())
                    .map_err(Error::from)
            };
            let most = s
                .data()
                .chunks_exact(slots)
                .map(|c| Curve(c).inserted())
                .max()
                .unwrap_or(1)
                .max(1);
            v.push(Stage::Scalar {
                name: format!("nodes_used{i}"),
                data: of(&|c| c.nodes().len() as f32)?,
                lo: 0.0,
                hi: self.opts.nodes as f32,
            });
            v.push(Stage::Scalar {
                name: format!("fragments_per_texel{i}"),
                data: of(&|c| c.inserted() as f32)?,
                lo: 0.0,
                hi: most as f32,
            });
            v.push(Stage::unit(
                format!("transmittance_behind_all{i}"),
                of(&|c| c.at(1.0).dot(crate::visibility::LUMINANCE))?,
            ));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texel(nodes: usize) -> Vec<Node> {
        let mut v = vec![UNUSED; nodes + 1];
        v[nodes] = HEADER;
        v
    }

    #[test]
    fn a_curve_multiplies_what_lies_behind_and_compresses_least_area_first() {
        let mut px = texel(8);
        insert(&mut px, 0.5, Vec3::splat(0.5));
        insert(&mut px, 0.2, Vec3::splat(0.5));
        let c = Curve(&px);
        assert_eq!(c.at(0.1), Vec3::ONE);
        assert_eq!(c.at(0.3), Vec3::splat(0.5));
        assert_eq!(c.at(0.6), Vec3::splat(0.25));
        assert_eq!((c.inserted(), c.removed()), (2, 0));
        // Three nodes into two slots: the node whose step covers the least area goes (never
        // the first): the one at 0.9 (0.25 -> 0.2 over [0.9, 1)) rather than 0.5's.
        let mut two = texel(2);
        for (d, t) in [(0.5, 0.5), (0.2, 0.5), (0.9, 0.8)] {
            insert(&mut two, d, Vec3::splat(t));
        }
        let c = Curve(&two);
        assert_eq!(c.nodes().len(), 2);
        assert_eq!((c.inserted(), c.removed()), (3, 1));
        assert_eq!((c.nodes()[0].depth, c.nodes()[1].depth), (0.2, 0.5));
        assert_eq!(c.at(0.95), Vec3::splat(0.25));
        // One slot: only the first node is ever kept.
        let mut one = texel(1);
        for k in 0..10 {
            insert(&mut one, 0.9 - 0.1 * k as f32, Vec3::splat(0.9));
        }
        assert_eq!(Curve(&one).nodes().len(), 1);
        // Per channel: a red filter behind a green one leaves nothing of either.
        let mut rgb = texel(4);
        insert(&mut rgb, 0.3, Vec3::new(1.0, 0.1, 0.1));
        insert(&mut rgb, 0.6, Vec3::new(0.1, 1.0, 0.1));
        assert_eq!(Curve(&rgb).at(0.7), Vec3::new(0.1, 0.1, 0.010000001));
    }
}
