//! An 8-wide bounding volume hierarchy over triangles for shadow rays.
//!
//! - **Build**: binned SAH (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//!   Hierarchies": all three axes binned in one pass over the node's primitives; 4 to 32
//!   bins per axis, more for more primitives, as Embree's builder chooses them), in parallel
//!   with `rayon::join` below the top levels and over chunks of the primitives for the
//!   largest nodes' bins. The partition gathers each part's centre bounds, so the bins hold
//!   only boxes and counts. Every split depends on the primitives alone, and subtrees are
//!   laid out depth first with relative child offsets, so the tree is the same bytes for any
//!   thread count ([`Bvh::digest`], tested). The binary
//!   tree is then collapsed into 8-wide nodes (each node adopts the children of its largest
//!   inner child until it has eight), whose boxes are stored as structure of arrays, and
//!   whose leaves are packets of up to 4 triangles, also as structure of arrays. Eight lanes
//!   measured faster than four on the benchmark's shadow rays (fewer, fuller nodes per ray:
//!   8.1 visits instead of 11.7), whether tested as two halves of four or at once.
//! - **Traversal**: the eight slab tests of a node with AVX where the machine has it
//!   (detected at run time), otherwise as two groups of four (SSE on x86-64, where it is part
//!   of the base instruction set; plain lanes elsewhere): the same operations either way, so
//!   the same bits (tested). The near and far planes are chosen by the ray's direction signs;
//!   `min` and `max` are exact, and the far distance is widened by `1 + 2 gamma(3)` (Ize
//!   2013, "Robust BVH Ray Traversal"), so a box is never missed by rounding and the answer
//!   does not depend on the tree's shape. A node with one inner child hit goes straight on
//!   to it; with more, the nearest is next and the others wait on the stack, farthest first,
//!   so occlusion rays stop early. No fused multiply-add anywhere.
//! - **Triangles**: the watertight test (Woop, Benthin and Wald 2013, "Watertight
//!   Ray/Triangle Intersection") on four triangles at once, with exactly the scalar test's
//!   operations in its order (no fused multiply-add), and the scalar test's double-precision
//!   fall-back on any lane where an edge function is zero: every lane's answer is the
//!   scalar test's, bit for bit.
//! - **Queries**: any-hit, all hits in `(0, tmax)` reported to a callback that may stop the
//!   ray (the reference multiplies translucent surfaces and stops at opaque ones).
//! - **Packets** ([`Bvh::traverse_packet`]): up to eight rays with the same direction signs
//!   walk the tree together, each child's box tested against all of them at once (each lane
//!   the ray's own slab test), so each ray meets exactly the triangles it meets alone.

use glam::{Vec3, Vec3A};

/// A triangle with its user tag (object index).
#[derive(Copy, Clone, Debug)]
pub struct Tri {
    /// Vertices.
    pub v: [Vec3; 3],
    /// Tag returned by hits (e.g. object index).
    pub tag: u32,
}

/// A node of the binary build: bounds, and either a leaf of `count` primitives from `first`
/// or (`count == 0`) an inner node whose left child follows it and whose right child is
/// `first` nodes after it (relative offsets: subtrees built apart concatenate unchanged).
#[derive(Copy, Clone, Debug)]
struct BNode {
    lo: Vec3,
    hi: Vec3,
    first: u32,
    count: u32,
}

/// A primitive during the build: its bounds, the centre of its bounds and its triangle.
#[derive(Copy, Clone, Debug)]
struct Prim {
    lo: Vec3A,
    hi: Vec3A,
    c: Vec3A,
    tri: u32,
}

/// A [`W`]-wide node: the children's boxes as structure of arrays (`planes[side][lane]`), and
/// per lane an inner node's index or, on the lanes of the `leaves` mask, a leaf (packet
/// count - 1 << [`PACKETS_SHIFT`] | first packet).
#[derive(Copy, Clone, Debug)]
#[repr(C, align(64))]
struct Node {
    /// The children's box planes: low x, y, z, then high x, y, z.
    planes: [[f32; W]; 6],
    child: [u32; W],
    /// A bit per lane in use (2 to [`W`] lanes; the root of a tree of one leaf uses 1).
    valid: u32,
    /// A bit per lane that is a leaf.
    leaves: u32,
}

/// Up to four triangles as structure of arrays (`v[vertex][axis][lane]`), and their tags.
#[derive(Copy, Clone, Debug)]
#[repr(C, align(16))]
struct Tri4 {
    v: [[[f32; 4]; 3]; 3],
    tag: [u32; 4],
    /// Lanes in use (1 to 4).
    n: u32,
}

const PACKETS_SHIFT: u32 = 27;
const FIRST_MASK: u32 = (1 << PACKETS_SHIFT) - 1;
/// The most SAH bins per axis ([`split`]).
const MAX_BINS: usize = 32;
/// Children per node.
const W: usize = 8;
const LEAF_MAX: usize = 4;
/// The SAH may keep up to this many triangles in a leaf (4 packets).
const LEAF_LIMIT: usize = 4 * LEAF_MAX;
/// Subtrees of at least this many primitives are built in parallel.
const PARALLEL: usize = 4096;
/// Sets of at least this many primitives are binned in parallel.
const PARALLEL_BINNING: usize = 32768;

/// The hierarchy.
pub struct Bvh {
    /// Whether traversal uses the AVX box test (found on the machine at build).
    #[cfg(target_arch = "x86_64")]
    avx: bool,
    nodes: Vec<Node>,
    packets: Vec<Tri4>,
    tris: usize,
}

fn area(lo: Vec3, hi: Vec3) -> f32 {
    let d = (hi - lo).max(Vec3::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// The bin of a centre coordinate `c` among `B` bins from `c0` (`scale` bins per unit).
#[inline(always)]
fn bin_of<const B: usize>(c: f32, c0: f32, scale: f32) -> usize {
    bin_at::<B>((c - c0) * scale)
}

/// [`bin_of`] on the three axes of `c` at once: the same IEEE operations lane by lane.
#[inline(always)]
fn bin_lanes<const B: usize>(c: Vec3A, c0: Vec3A, scale: Vec3A) -> [usize; 3] {
    ((c - c0) * scale).to_array().map(bin_at::<B>)
}

/// The bin at `at` bins from the first, clamped to the `B` bins. `f32::max` and `min` return
/// their operand that is not NaN (NaN comes from a denormal extent's infinite scale), so the
/// value converted is always in `[0, B - 1]`.
#[inline(always)]
fn bin_at<const B: usize>(at: f32) -> usize {
    let at = at.max(0.0).min((B - 1) as f32);
    // SAFETY: `at` is finite and in [0, B - 1] (above), which a `u32` holds.
    unsafe { at.to_int_unchecked::<u32>() as usize }
}

/// Bounds of a set of primitives and of their centres.
#[derive(Copy, Clone)]
struct Bounds {
    lo: Vec3A,
    hi: Vec3A,
    clo: Vec3A,
    chi: Vec3A,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        lo: Vec3A::splat(f32::MAX),
        hi: Vec3A::splat(f32::MIN),
        clo: Vec3A::splat(f32::MAX),
        chi: Vec3A::splat(f32::MIN),
    };

    #[inline(always)]
    fn grow(&mut self, p: &Prim) {
        self.lo = self.lo.min(p.lo);
        self.hi = self.hi.max(p.hi);
        self.clo = self.clo.min(p.c);
        self.chi = self.chi.max(p.c);
    }

    fn of(prims: &[Prim]) -> Bounds {
        let mut b = Bounds::EMPTY;
        for p in prims {
            b.grow(p);
        }
        b
    }

    fn area(&self) -> f32 {
        area(self.lo.into(), self.hi.into())
    }
}

/// Builds the subtree of `prims` (whose first is primitive `offset` of the whole array, and
/// whose bounds are `bounds`) into `out`, depth first.
fn build_into(prims: &mut [Prim], bounds: Bounds, offset: u32, out: &mut Vec<BNode>) {
    let me = out.len();
    let count = prims.len();
    out.push(BNode {
        lo: bounds.lo.into(),
        hi: bounds.hi.into(),
        first: offset,
        count: count as u32,
    });
    let Some((mid, lb, rb)) = split(prims, &bounds) else {
        return;
    };
    let (l, r) = prims.split_at_mut(mid);
    out[me].count = 0;
    if count >= PARALLEL {
        let (a, b) = rayon::join(
            || {
                let mut v = Vec::with_capacity(2 * l.len());
                build_into(l, lb, offset, &mut v);
                v
            },
            || {
                let mut v = Vec::with_capacity(2 * r.len());
                build_into(r, rb, offset + mid as u32, &mut v);
                v
            },
        );
        out[me].first = 1 + a.len() as u32;
        out.extend_from_slice(&a);
        out.extend_from_slice(&b);
    } else {
        build_into(l, lb, offset, out);
        out[me].first = (out.len() - me) as u32;
        build_into(r, rb, offset + mid as u32, out);
    }
}

/// A bin of the SAH: the bounds of its primitives' boxes and how many there are.
#[derive(Copy, Clone)]
struct Bin {
    lo: Vec3A,
    hi: Vec3A,
    n: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        lo: Vec3A::splat(f32::MAX),
        hi: Vec3A::splat(f32::MIN),
        n: 0,
    };

    #[inline(always)]
    fn merge(self, b: &Bin) -> Bin {
        Bin {
            lo: self.lo.min(b.lo),
            hi: self.hi.max(b.hi),
            n: self.n + b.n,
        }
    }

    fn area(&self) -> f32 {
        area(self.lo.into(), self.hi.into())
    }
}

/// Bins `prims` by their centres on `B` bins per axis (as [`bin_of`] places them): in
/// parallel over chunks for large sets. Bounds merge by `min` and `max` and counts add, so the
/// bins are the same whatever the chunks.
fn bin<const B: usize>(prims: &[Prim], clo: Vec3A, scale: Vec3A) -> [[Bin; B]; 3] {
    if prims.len() >= PARALLEL_BINNING {
        use rayon::prelude::*;
        let merge = |a: [[Bin; B]; 3], b: [[Bin; B]; 3]| -> [[Bin; B]; 3] {
            std::array::from_fn(|x| std::array::from_fn(|i| a[x][i].merge(&b[x][i])))
        };
        return prims
            .par_chunks(PARALLEL_BINNING / 2)
            .map(|c| bin::<B>(c, clo, scale))
            .reduce(|| [[Bin::EMPTY; B]; 3], merge);
    }
    let mut bins = [[Bin::EMPTY; B]; 3];
    for p in prims {
        let at = bin_lanes::<B>(p.c, clo, scale);
        for (axis, bins) in bins.iter_mut().enumerate() {
            let b = &mut bins[at[axis]];
            b.lo = b.lo.min(p.lo);
            b.hi = b.hi.max(p.hi);
            b.n += 1;
        }
    }
    bins
}

/// The binned SAH split of `prims` (partitioned in place): where the right part starts and
/// the two parts' bounds (boxes from the bins, centres from the partition), or None for a
/// leaf. The bins per axis grow with the count, as Embree's builder sets them (about
/// `4 + count / 20`, at most 32): a few bins cost little where a split moves few triangles.
fn split(prims: &mut [Prim], bounds: &Bounds) -> Option<(usize, Bounds, Bounds)> {
    let n = prims.len();
    if n <= LEAF_MAX {
        None
    } else if n < 80 {
        split_on::<4>(prims, bounds)
    } else if n < 240 {
        split_on::<8>(prims, bounds)
    } else if n < 560 {
        split_on::<16>(prims, bounds)
    } else {
        split_on::<MAX_BINS>(prims, bounds)
    }
}

/// [`split`] on `B` bins per axis.
fn split_on<const B: usize>(prims: &mut [Prim], bounds: &Bounds) -> Option<(usize, Bounds, Bounds)> {
    let count = prims.len();
    let (clo, chi) = (bounds.clo, bounds.chi);
    let ext = chi - clo;
    let scale = Vec3A::select(ext.cmpgt(Vec3A::ZERO), Vec3A::splat(B as f32) / ext, Vec3A::ZERO);
    let bins = bin::<B>(prims, clo, scale);
    let mut best = (f32::MAX, 0usize, 0usize);
    for (axis, bins) in bins.iter().enumerate() {
        if ext[axis] <= 0.0 {
            continue;
        }
        // The cost of each split: the left part's area times its count, from a sweep left to
        // right, then the right part's from a sweep back.
        let mut left = [(0.0f32, 0u32); B];
        let mut acc = Bin::EMPTY;
        for (i, b) in bins.iter().enumerate() {
            acc = acc.merge(b);
            left[i] = (if acc.n > 0 { acc.area() } else { 0.0 }, acc.n);
        }
        let mut acc = Bin::EMPTY;
        for i in (1..B).rev() {
            acc = acc.merge(&bins[i]);
            let (la, ln) = left[i - 1];
            if ln == 0 || acc.n == 0 {
                continue;
            }
            let cost = la * ln as f32 + acc.area() * acc.n as f32;
            if cost < best.0 {
                best = (cost, axis, i);
            }
        }
    }
    let (cost, axis, at) = best;
    if cost < bounds.area() * count as f32 && cost < f32::MAX {
        // The partition (from both ends, swapping only what lies on the wrong side),
        // gathering each part's centre bounds on the way.
        let empty = (Vec3A::splat(f32::MAX), Vec3A::splat(f32::MIN));
        let (mut lc, mut rc) = (empty, empty);
        let grow = |b: &mut (Vec3A, Vec3A), c: Vec3A| *b = (b.0.min(c), b.1.max(c));
        let left = |p: &Prim| bin_of::<B>(p.c[axis], clo[axis], scale[axis]) < at;
        let (mut i, mut j) = (0, count);
        loop {
            while i < j && left(&prims[i]) {
                grow(&mut lc, prims[i].c);
                i += 1;
            }
            while i < j && !left(&prims[j - 1]) {
                grow(&mut rc, prims[j - 1].c);
                j -= 1;
            }
            if i == j {
                break;
            }
            // `prims[i]` belongs right and `prims[j - 1]` left.
            prims.swap(i, j - 1);
            grow(&mut lc, prims[i].c);
            grow(&mut rc, prims[j - 1].c);
            i += 1;
            j -= 1;
        }
        let part = |r: std::ops::Range<usize>, (clo, chi): (Vec3A, Vec3A)| {
            let b = bins[axis][r].iter().fold(Bin::EMPTY, |a, b| a.merge(b));
            Bounds {
                lo: b.lo,
                hi: b.hi,
                clo,
                chi,
            }
        };
        (i > 0 && i < count).then(|| (i, part(0..at, lc), part(at..B, rc)))
    } else if count > LEAF_LIMIT {
        // No useful SAH split (e.g. identical centroids): split in the middle.
        let mid = count / 2;
        Some((mid, Bounds::of(&prims[..mid]), Bounds::of(&prims[mid..])))
    } else {
        None
    }
}

impl Bvh {
    /// Builds over `tris` (degenerate and non-finite triangles are dropped), in parallel on
    /// the current rayon pool; the tree does not depend on the thread count.
    pub fn build(mut tris: Vec<Tri>) -> Bvh {
        tris.retain(|t| {
            t.v.iter().all(|p| p.is_finite()) && (t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]).length_squared() > 0.0
        });
        let n = tris.len();
        assert!(
            n.div_ceil(LEAF_MAX) < FIRST_MASK as usize,
            "BVH: {n} triangles are more than the node layout addresses"
        );
        let mut bvh = Bvh {
            #[cfg(target_arch = "x86_64")]
            avx: std::arch::is_x86_feature_detected!("avx"),
            nodes: Vec::new(),
            packets: Vec::new(),
            tris: n,
        };
        if n == 0 {
            return bvh;
        }
        let _stage = crate::progress::stage("building the reference's BVH", 0);
        use rayon::prelude::*;
        let mut prims: Vec<Prim> = tris
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let lo = Vec3A::from(t.v[0].min(t.v[1]).min(t.v[2]));
                let hi = Vec3A::from(t.v[0].max(t.v[1]).max(t.v[2]));
                Prim {
                    lo,
                    hi,
                    c: (lo + hi) * 0.5,
                    tri: i as u32,
                }
            })
            .collect();
        let mut bin = Vec::with_capacity(2 * n);
        let all = Bounds::of(&prims);
        build_into(&mut prims, all, 0, &mut bin);
        bvh.nodes.reserve(bin.len() / 3 + 1);
        bvh.packets.reserve(n.div_ceil(LEAF_MAX) + bin.len() / 8);
        bvh.collapse(&bin, &prims, &tris);
        bvh
    }

    /// The wide nodes from the binary tree `bin` (root 0), depth first.
    fn collapse(&mut self, bin: &[BNode], prims: &[Prim], tris: &[Tri]) {
        let kids = |b: usize| [b + 1, b + bin[b].first as usize];
        // (binary inner node whose subtree to make, wide node to fill in, lane); the root's
        // parent is `usize::MAX`.
        let mut todo = vec![(0usize, usize::MAX, 0usize)];
        while let Some((of, parent, lane)) = todo.pop() {
            let mut children = [0usize; W];
            let mut n = if bin[of].count > 0 {
                // A tree of one leaf: its root holds it.
                children[0] = of;
                1
            } else {
                children[..2].copy_from_slice(&kids(of));
                2
            };
            // Adopt the children of the largest inner child until there are W.
            while n < W {
                let Some((k, _)) = children[..n]
                    .iter()
                    .enumerate()
                    .filter(|(_, &c)| bin[c].count == 0)
                    .map(|(k, &c)| (k, area(bin[c].lo, bin[c].hi)))
                    .fold(None, |best: Option<(usize, f32)>, (k, a)| match best {
                        Some((_, ba)) if ba >= a => best,
                        _ => Some((k, a)),
                    })
                else {
                    break;
                };
                let [l, r] = kids(children[k]);
                children.copy_within(k + 1..n, k + 2);
                children[k] = l;
                children[k + 1] = r;
                n += 1;
            }
            let children = &children[..n];
            let me = self.nodes.len();
            if parent != usize::MAX {
                self.nodes[parent].child[lane] = me as u32;
            }
            let mut node = Node {
                planes: [
                    [f32::MAX; W],
                    [f32::MAX; W],
                    [f32::MAX; W],
                    [f32::MIN; W],
                    [f32::MIN; W],
                    [f32::MIN; W],
                ],
                child: [0; W],
                valid: (1 << children.len()) - 1,
                leaves: 0,
            };
            for (lane, &c) in children.iter().enumerate() {
                let b = &bin[c];
                for axis in 0..3 {
                    node.planes[axis][lane] = b.lo[axis];
                    node.planes[3 + axis][lane] = b.hi[axis];
                }
                if b.count > 0 {
                    node.leaves |= 1 << lane;
                    node.child[lane] = self.pack(&prims[b.first as usize..(b.first + b.count) as usize], tris);
                }
            }
            self.nodes.push(node);
            // Inner children, made in lane order (pushed in reverse).
            for (lane, &c) in children.iter().enumerate().rev() {
                if bin[c].count == 0 {
                    todo.push((c, me, lane));
                }
            }
        }
    }

    /// Packets of the leaf `prims`; its child word.
    fn pack(&mut self, prims: &[Prim], tris: &[Tri]) -> u32 {
        let first = self.packets.len() as u32;
        for group in prims.chunks(LEAF_MAX) {
            let mut p = Tri4 {
                v: [[[f32::NAN; 4]; 3]; 3],
                tag: [u32::MAX; 4],
                n: group.len() as u32,
            };
            for (lane, pr) in group.iter().enumerate() {
                let t = &tris[pr.tri as usize];
                for (vertex, v) in t.v.iter().enumerate() {
                    for axis in 0..3 {
                        p.v[vertex][axis][lane] = v[axis];
                    }
                }
                p.tag[lane] = t.tag;
            }
            self.packets.push(p);
        }
        let count = prims.len().div_ceil(LEAF_MAX) as u32;
        ((count - 1) << PACKETS_SHIFT) | first
    }

    /// Triangles held.
    pub fn len(&self) -> usize {
        self.tris
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.tris == 0
    }

    /// Bytes of nodes and triangle packets.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>() + self.packets.len() * std::mem::size_of::<Tri4>()
    }

    /// A hash of the tree's every byte (nodes and packets): the same for any thread count.
    pub fn digest(&self) -> u64 {
        let mut h = crate::hash::fnv1a(crate::hash::FNV_OFFSET, b"bvh8");
        for n in &self.nodes {
            for w in n.planes.iter().flatten() {
                h = crate::hash::fnv1a(h, &w.to_bits().to_le_bytes());
            }
            for w in n.child.iter().chain([&n.valid, &n.leaves]) {
                h = crate::hash::fnv1a(h, &w.to_le_bytes());
            }
        }
        for p in &self.packets {
            for w in p.v.iter().flatten().flatten() {
                h = crate::hash::fnv1a(h, &w.to_bits().to_le_bytes());
            }
            for w in p.tag.iter().chain([&p.n]) {
                h = crate::hash::fnv1a(h, &w.to_le_bytes());
            }
        }
        h
    }

    /// Calls `hit(tag, t)` for triangles hit by the ray `o + t d` with `t` in `(0, tmax)`, in
    /// traversal order; stops when `hit` returns true. Returns whether it was stopped.
    pub fn traverse(&self, o: Vec3, d: Vec3, tmax: f32, hit: impl FnMut(u32, f32) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: the build found AVX on this machine.
            return unsafe { self.traverse_avx(o, d, tmax, hit) };
        }
        self.walk(o, d, tmax, hit, Ray4::boxes)
    }

    /// [`Bvh::traverse`] compiled for AVX, with the eight-lane box test.
    ///
    /// # Safety
    /// The machine must have AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn traverse_avx(&self, o: Vec3, d: Vec3, tmax: f32, hit: impl FnMut(u32, f32) -> bool) -> bool {
        // SAFETY: this function runs only with AVX.
        self.walk(o, d, tmax, hit, |r, n| unsafe { avx::boxes(r, n) })
    }

    /// The traversal, with `boxes` as the node's box test.
    #[inline(always)]
    fn walk(
        &self,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        mut hit: impl FnMut(u32, f32) -> bool,
        boxes: impl Fn(&Ray4, &Node) -> (u32, [f32; W]),
    ) -> bool {
        let ray = WatertightRay::new(o, d);
        let r = Ray4::new(o, d, tmax, &ray);
        let mut stack = Stack::<u32>::new();
        let mut ni = 0u32;
        loop {
            let node = &self.nodes[ni as usize];
            let (mask, tn) = boxes(&r, node);
            // Leaves now; then the nearest inner child next and the others onto the stack,
            // farthest first.
            let mut leaves = mask & node.leaves;
            while leaves != 0 {
                let lane = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                let c = node.child[lane];
                let first = (c & FIRST_MASK) as usize;
                let count = (c >> PACKETS_SHIFT) as usize + 1;
                for p in &self.packets[first..first + count] {
                    let (hits, th) = r.triangles(p, &ray, tmax);
                    let mut h = hits;
                    while h != 0 {
                        let k = h.trailing_zeros() as usize;
                        h &= h - 1;
                        if hit(p.tag[k], th[k]) {
                            return true;
                        }
                    }
                }
            }
            let inner = mask & !node.leaves;
            if inner & (inner.wrapping_sub(1)) == 0 {
                if inner != 0 {
                    // One inner child hit: no stack.
                    ni = node.child[inner.trailing_zeros() as usize];
                    continue;
                }
            } else {
                let mut near = [(0.0f32, 0u32); W];
                let mut k = 0;
                let mut lanes = inner;
                while lanes != 0 {
                    let lane = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    near[k] = (tn[lane], node.child[lane]);
                    k += 1;
                }
                ni = push_farthest_first(&mut near[..k], &mut stack).expect("two or more");
                continue;
            }
            let Some(next) = stack.pop() else {
                return false;
            };
            ni = next;
        }
    }

    /// True if anything is hit in `(0, tmax)`.
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.traverse(o, d, tmax, |_, _| true)
    }

    /// [`Bvh::traverse`] for a packet of up to [`PACKET`] rays `(o, d, tmax)` at once (Wald,
    /// Slusallek, Benthin and Wagner 2001, "Interactive Rendering with Coherent Ray
    /// Tracing"): the packet walks the tree together, each node fetched once for all its rays,
    /// and each stack entry carries the rays that entered the node. Every ray's box and
    /// triangle tests are the single ray's, so each ray meets exactly the triangles, at
    /// exactly the distances, that [`Bvh::traverse`] reports for it (tested); only the order
    /// of its hits may differ. Calls `hit(ray, tag, t)`; a ray stops when it returns true.
    /// Returns a bit per ray that was stopped.
    pub fn traverse_packet(&self, rays: &[(Vec3, Vec3, f32)], hit: impl FnMut(usize, u32, f32) -> bool) -> u32 {
        assert!(rays.len() <= PACKET, "a packet holds at most {PACKET} rays");
        if self.nodes.is_empty() || rays.is_empty() {
            return 0;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: the build found AVX on this machine.
            return unsafe { self.traverse_packet_avx(rays, hit) };
        }
        self.walk_packet(rays, hit, Ray4::boxes, Soa::child)
    }

    /// [`Bvh::traverse_packet`] compiled for AVX, with the eight-lane box test.
    ///
    /// # Safety
    /// The machine must have AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn traverse_packet_avx(&self, rays: &[(Vec3, Vec3, f32)], hit: impl FnMut(usize, u32, f32) -> bool) -> u32 {
        // SAFETY: this function runs only with AVX.
        self.walk_packet(
            rays,
            hit,
            |r, n| unsafe { avx::boxes(r, n) },
            |s, n, lane| unsafe { avx::soa_child(s, n, lane) },
        )
    }

    /// The packet's traversal, with `boxes` as the node's box test.
    #[inline(always)]
    fn walk_packet(
        &self,
        rays: &[(Vec3, Vec3, f32)],
        mut hit: impl FnMut(usize, u32, f32) -> bool,
        boxes: impl Fn(&Ray4, &Node) -> (u32, [f32; W]),
        child: impl Fn(&Soa, &Node, usize) -> (u32, [f32; PACKET]),
    ) -> u32 {
        let n = rays.len();
        let Some(soa) = Soa::new(rays) else {
            // Direction signs differ: each ray alone.
            let mut done = 0;
            for (i, &(o, d, tmax)) in rays.iter().enumerate() {
                if self.walk(o, d, tmax, |tag, t| hit(i, tag, t), &boxes) {
                    done |= 1 << i;
                }
            }
            return done;
        };
        // Lanes past the packet's rays repeat its first ray and are never active.
        let ray = |i: usize| rays[if i < n { i } else { 0 }];
        let wt: [WatertightRay; PACKET] = std::array::from_fn(|i| WatertightRay::new(ray(i).0, ray(i).1));
        let r4: [Ray4; PACKET] = std::array::from_fn(|i| Ray4::new(ray(i).0, ray(i).1, ray(i).2, &wt[i]));
        self.walk_soa(rays, &soa, &wt, &r4, hit, child)
    }
}

impl Bvh {
    /// The packet's traversal when its rays share their direction signs ([`Soa`]): at each
    /// node, each child's box against all the packet's rays at once, a bit per ray that enters
    /// it (each bit the single ray's own test); leaves then test their triangles with each ray
    /// that entered them, inner children go onto one stack with the rays that entered them.
    #[inline(always)]
    fn walk_soa(
        &self,
        rays: &[(Vec3, Vec3, f32)],
        soa: &Soa,
        wt: &[WatertightRay; PACKET],
        r4: &[Ray4; PACKET],
        mut hit: impl FnMut(usize, u32, f32) -> bool,
        child: impl Fn(&Soa, &Node, usize) -> (u32, [f32; PACKET]),
    ) -> u32 {
        let all = (1u32 << rays.len()) - 1;
        let mut done = 0u32;
        let mut stack = Stack::<(u32, u32)>::new();
        let (mut ni, mut active) = (0u32, all);
        loop {
            active &= !done;
            if active != 0 {
                let node = &self.nodes[ni as usize];
                let mut next = [(0.0f32, (0u32, 0u32)); W];
                let mut k = 0;
                let mut lanes = node.valid;
                while lanes != 0 {
                    let lane = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    let (entered, tn) = child(soa, node, lane);
                    let rs = entered & active & !done;
                    if rs == 0 {
                        continue;
                    }
                    let c = node.child[lane];
                    if node.leaves & (1 << lane) == 0 {
                        next[k] = (tn[rs.trailing_zeros() as usize], (c, rs));
                        k += 1;
                        continue;
                    }
                    let first = (c & FIRST_MASK) as usize;
                    let count = (c >> PACKETS_SHIFT) as usize + 1;
                    let mut r = rs;
                    while r != 0 {
                        let i = r.trailing_zeros() as usize;
                        r &= r - 1;
                        'packets: for p in &self.packets[first..first + count] {
                            let (hits, th) = r4[i].triangles(p, &wt[i], rays[i].2);
                            let mut h = hits;
                            while h != 0 {
                                let b = h.trailing_zeros() as usize;
                                h &= h - 1;
                                if hit(i, p.tag[b], th[b]) {
                                    done |= 1 << i;
                                    break 'packets;
                                }
                            }
                        }
                    }
                    if done == all {
                        return done;
                    }
                }
                // The nearest inner child next (by its first ray's entry), the others onto
                // the stack, farthest first.
                if let Some(e) = push_farthest_first(&mut next[..k], &mut stack) {
                    (ni, active) = e;
                    continue;
                }
            }
            let Some(e) = stack.pop() else {
                return done;
            };
            (ni, active) = e;
        }
    }
}

/// A packet's rays as structure of arrays, a lane per ray (Wald et al. 2001), when they share
/// their direction signs (so one near and one far plane per axis for all): a child's slab
/// test on all rays at once, with each lane's operations those of the ray's own
/// [`Ray4::boxes`] in its order (`max` and `min` with the same operands first), so the same
/// bit per ray.
struct Soa {
    o: [[F4; 2]; 3],
    inv: [[F4; 2]; 3],
    tmax: [F4; 2],
    near: [usize; 3],
    far: [usize; 3],
    /// The same lanes as plain rows (for the eight-lane AVX test).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    raw: SoaRows,
}

/// A packet's rays as rows of eight lanes: origin, reciprocal direction, `tmax`.
#[derive(Copy, Clone)]
#[repr(C, align(32))]
struct SoaRows {
    o: [[f32; PACKET]; 3],
    inv: [[f32; PACKET]; 3],
    tmax: [f32; PACKET],
}

impl Soa {
    /// `None` when the rays' direction signs differ on some axis.
    fn new(rays: &[(Vec3, Vec3, f32)]) -> Option<Soa> {
        let inv = |d: Vec3| Vec3::from(Vec3A::from(d).recip());
        let first = inv(rays[0].1);
        let mut o = [[0.0f32; PACKET]; 3];
        let mut iv = [[0.0f32; PACKET]; 3];
        let mut tmax = [0.0f32; PACKET];
        for k in 0..PACKET {
            let (ro, rd, rt) = rays[if k < rays.len() { k } else { 0 }];
            let v = inv(rd);
            for a in 0..3 {
                if v[a].is_sign_negative() != first[a].is_sign_negative() {
                    return None;
                }
                o[a][k] = ro[a];
                iv[a][k] = v[a];
            }
            tmax[k] = rt;
        }
        let halves = |x: &[f32; PACKET]| -> [F4; 2] {
            [
                F4::load(x[..4].try_into().expect("four")),
                F4::load(x[4..].try_into().expect("four")),
            ]
        };
        Some(Soa {
            o: [halves(&o[0]), halves(&o[1]), halves(&o[2])],
            inv: [halves(&iv[0]), halves(&iv[1]), halves(&iv[2])],
            tmax: halves(&tmax),
            near: std::array::from_fn(|a| if first[a].is_sign_negative() { 3 + a } else { a }),
            far: std::array::from_fn(|a| if first[a].is_sign_negative() { a } else { 3 + a }),
            raw: SoaRows { o, inv: iv, tmax },
        })
    }

    /// A bit per ray that enters child `lane` of `n`, and the rays' entry distances.
    #[inline(always)]
    fn child(&self, n: &Node, lane: usize) -> (u32, [f32; PACKET]) {
        let mut mask = 0;
        let mut dist = [0.0f32; PACKET];
        for h in 0..2 {
            let slab = |axis: usize, side: usize| {
                F4::splat(n.planes[side][lane])
                    .sub(self.o[axis][h])
                    .mul(self.inv[axis][h])
            };
            let (near, far) = (&self.near, &self.far);
            let tn = slab(0, near[0]).max(slab(1, near[1]).max(slab(2, near[2]).max(F4::splat(0.0))));
            let tf = slab(0, far[0]).min(slab(1, far[1]).min(slab(2, far[2]).min(self.tmax[h])));
            let tf = tf.mul(F4::splat(ROBUST));
            mask |= tn.le(tf) << (4 * h);
            dist[4 * h..4 * h + 4].copy_from_slice(&tn.to_array());
        }
        (mask, dist)
    }
}

/// The traversal stack: 64 entries in place (left uninitialised: a ray rarely needs more
/// than a few), and the rest, if ever, on the heap.
struct Stack<T: Copy> {
    items: [std::mem::MaybeUninit<T>; 64],
    len: usize,
    overflow: Vec<T>,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    fn new() -> Self {
        Stack {
            items: [const { std::mem::MaybeUninit::uninit() }; 64],
            len: 0,
            overflow: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, v: T) {
        if self.len < self.items.len() {
            self.items[self.len].write(v);
            self.len += 1;
        } else {
            self.overflow.push(v);
        }
    }

    /// The last pushed (the overflow holds the latest pushes once the array is full).
    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        if let Some(v) = self.overflow.pop() {
            return Some(v);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: the entries below `len` were written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

/// Sorts `next` (entry distance, what to visit; at most [`W`]) farthest first by insertion,
/// pushes all but the nearest onto the stack and returns the nearest, which is visited next.
#[inline(always)]
fn push_farthest_first<T: Copy>(next: &mut [(f32, T)], stack: &mut Stack<T>) -> Option<T> {
    for i in 1..next.len() {
        let mut j = i;
        while j > 0 && next[j - 1].0 < next[j].0 {
            next.swap(j - 1, j);
            j -= 1;
        }
    }
    let (last, rest) = next.split_last()?;
    for &(_, c) in rest {
        stack.push(c);
    }
    Some(last.1)
}

/// Rays in a packet at most ([`Bvh::traverse_packet`]).
pub const PACKET: usize = 8;
// `Soa` holds a packet as two halves of four lanes, or one row of eight.
const _: () = assert!(PACKET == 8);

/// `1 + 2 gamma(3)` (Ize 2013): the far slab distance widened by the bound of its rounding.
const ROBUST: f32 = 1.0 + 3.0 * f32::EPSILON;

/// Four f32 lanes: SSE on x86-64 (part of its base instruction set), plain arrays elsewhere;
/// the same IEEE operations either way.
mod lanes {
    #[cfg(target_arch = "x86_64")]
    use std::arch::x86_64::*;

    /// An SSE or SSE2 intrinsic.
    #[cfg(target_arch = "x86_64")]
    macro_rules! sse {
        ($e:expr) => {
            // SAFETY: SSE and SSE2 are part of x86-64's base instruction set.
            unsafe { $e }
        };
    }

    /// Four lanes.
    #[cfg(target_arch = "x86_64")]
    #[derive(Copy, Clone)]
    pub struct F4(__m128);
    /// Four lanes.
    #[cfg(not(target_arch = "x86_64"))]
    #[derive(Copy, Clone)]
    pub struct F4([f32; 4]);

    #[cfg(target_arch = "x86_64")]
    impl F4 {
        /// The SSE register.
        #[inline(always)]
        pub fn raw(self) -> __m128 {
            self.0
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            // SAFETY: reads four floats from a reference to four floats.
            F4(unsafe { _mm_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            F4(sse!(_mm_set1_ps(x)))
        }
        #[inline(always)]
        pub fn add(self, b: F4) -> F4 {
            F4(sse!(_mm_add_ps(self.0, b.0)))
        }
        #[inline(always)]
        pub fn sub(self, b: F4) -> F4 {
            F4(sse!(_mm_sub_ps(self.0, b.0)))
        }
        #[inline(always)]
        pub fn mul(self, b: F4) -> F4 {
            F4(sse!(_mm_mul_ps(self.0, b.0)))
        }
        #[inline(always)]
        pub fn div(self, b: F4) -> F4 {
            F4(sse!(_mm_div_ps(self.0, b.0)))
        }
        /// Per lane `if a > b { a } else { b }` (so `b` where either is NaN).
        #[inline(always)]
        pub fn max(self, b: F4) -> F4 {
            F4(sse!(_mm_max_ps(self.0, b.0)))
        }
        /// Per lane `if a < b { a } else { b }` (so `b` where either is NaN).
        #[inline(always)]
        pub fn min(self, b: F4) -> F4 {
            F4(sse!(_mm_min_ps(self.0, b.0)))
        }
        /// Bit `i` set where lane `i` of `a <= b`.
        #[inline(always)]
        pub fn le(self, b: F4) -> u32 {
            sse!(_mm_movemask_ps(_mm_cmple_ps(self.0, b.0))) as u32
        }
        #[inline(always)]
        pub fn lt(self, b: F4) -> u32 {
            sse!(_mm_movemask_ps(_mm_cmplt_ps(self.0, b.0))) as u32
        }
        #[inline(always)]
        pub fn eq(self, b: F4) -> u32 {
            sse!(_mm_movemask_ps(_mm_cmpeq_ps(self.0, b.0))) as u32
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            let mut a = [0.0f32; 4];
            // SAFETY: writes four floats into an array of four floats.
            unsafe { _mm_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
    }

    #[cfg(not(target_arch = "x86_64"))]
    impl F4 {
        #[inline(always)]
        fn zip(self, b: F4, f: impl Fn(f32, f32) -> f32) -> F4 {
            F4(std::array::from_fn(|i| f(self.0[i], b.0[i])))
        }
        #[inline(always)]
        fn bits(self, b: F4, f: impl Fn(f32, f32) -> bool) -> u32 {
            (0..4).fold(0, |m, i| m | ((f(self.0[i], b.0[i]) as u32) << i))
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            F4(*a)
        }
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            F4([x; 4])
        }
        #[inline(always)]
        pub fn add(self, b: F4) -> F4 {
            self.zip(b, |x, y| x + y)
        }
        #[inline(always)]
        pub fn sub(self, b: F4) -> F4 {
            self.zip(b, |x, y| x - y)
        }
        #[inline(always)]
        pub fn mul(self, b: F4) -> F4 {
            self.zip(b, |x, y| x * y)
        }
        #[inline(always)]
        pub fn div(self, b: F4) -> F4 {
            self.zip(b, |x, y| x / y)
        }
        #[inline(always)]
        pub fn max(self, b: F4) -> F4 {
            self.zip(b, |x, y| if x > y { x } else { y })
        }
        #[inline(always)]
        pub fn min(self, b: F4) -> F4 {
            self.zip(b, |x, y| if x < y { x } else { y })
        }
        #[inline(always)]
        pub fn le(self, b: F4) -> u32 {
            self.bits(b, |x, y| x <= y)
        }
        #[inline(always)]
        pub fn lt(self, b: F4) -> u32 {
            self.bits(b, |x, y| x < y)
        }
        #[inline(always)]
        pub fn eq(self, b: F4) -> u32 {
            self.bits(b, |x, y| x == y)
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }
    }
}

use lanes::F4;

/// The eight-lane box test with AVX.
#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{Node, Ray4, ROBUST, W};
    use std::arch::x86_64::*;

    // The aligned loads below: every row of planes starts on a 32-byte boundary.
    const _: () = assert!(std::mem::align_of::<Node>().is_multiple_of(32) && std::mem::offset_of!(Node, planes) == 0);
    const _: () = assert!(std::mem::size_of::<[f32; W]>() == 32);

    /// [`Ray4::boxes`] on all eight lanes at once: the same IEEE operations in the same order
    /// (`vmaxps` and `vminps` return their second operand on NaN as `maxps` and `minps` do;
    /// `<=` is the ordered compare of `cmpleps`), so the same bits.
    ///
    /// Inlined into [`super::Bvh::traverse_avx`], where the intrinsics are inlined in turn
    /// (a `target_feature` function could not be inlined always).
    ///
    /// # Safety
    /// The machine must have AVX.
    #[inline(always)]
    pub unsafe fn boxes(r: &Ray4, n: &Node) -> (u32, [f32; W]) {
        // SAFETY: the caller guarantees AVX; every load reads a 32-byte-aligned row of eight floats inside the node or the packet, and the store writes an array of eight.
        unsafe {
            // The ray's four-lane splats as eight lanes.
            let wide = |x: super::F4| _mm256_set_m128(x.raw(), x.raw());
            let slab = |axis: usize, side: usize| {
                // A row of eight floats, 32-byte aligned (the node is 64-byte aligned and its rows
                // are 32 bytes).
                let p = _mm256_load_ps(n.planes[side].as_ptr());
                _mm256_mul_ps(_mm256_sub_ps(p, wide(r.o[axis])), wide(r.inv[axis]))
            };
            let (near, far) = (&r.near, &r.far);
            let tn = _mm256_max_ps(
                slab(0, near[0]),
                _mm256_max_ps(slab(1, near[1]), _mm256_max_ps(slab(2, near[2]), _mm256_setzero_ps())),
            );
            let tf = _mm256_min_ps(
                slab(0, far[0]),
                _mm256_min_ps(slab(1, far[1]), _mm256_min_ps(slab(2, far[2]), wide(r.tmax))),
            );
            let tf = _mm256_mul_ps(tf, _mm256_set1_ps(ROBUST));
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tn, tf)) as u32;
            let mut dist = [0.0f32; W];
            // Writes eight floats into an array of eight.
            _mm256_storeu_ps(dist.as_mut_ptr(), tn);
            (mask & n.valid, dist)
        }
    }

    /// [`super::Soa::child`] on all eight rays at once: the same operations, lane by lane.
    ///
    /// # Safety
    /// The machine must have AVX.
    #[inline(always)]
    pub unsafe fn soa_child(s: &super::Soa, n: &Node, lane: usize) -> (u32, [f32; super::PACKET]) {
        // SAFETY: the caller guarantees AVX; every load reads a 32-byte-aligned row of eight floats inside the node or the packet, and the store writes an array of eight.
        unsafe {
            let r = &s.raw;
            // Rows of eight floats, 32-byte aligned (`SoaRows` is).
            let slab = |axis: usize, side: usize| {
                _mm256_mul_ps(
                    _mm256_sub_ps(_mm256_set1_ps(n.planes[side][lane]), _mm256_load_ps(r.o[axis].as_ptr())),
                    _mm256_load_ps(r.inv[axis].as_ptr()),
                )
            };
            let (near, far) = (&s.near, &s.far);
            let tn = _mm256_max_ps(
                slab(0, near[0]),
                _mm256_max_ps(slab(1, near[1]), _mm256_max_ps(slab(2, near[2]), _mm256_setzero_ps())),
            );
            let tf = _mm256_min_ps(
                slab(0, far[0]),
                _mm256_min_ps(
                    slab(1, far[1]),
                    _mm256_min_ps(slab(2, far[2]), _mm256_load_ps(r.tmax.as_ptr())),
                ),
            );
            let tf = _mm256_mul_ps(tf, _mm256_set1_ps(ROBUST));
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tn, tf)) as u32;
            let mut dist = [0.0f32; super::PACKET];
            _mm256_storeu_ps(dist.as_mut_ptr(), tn);
            (mask, dist)
        }
    }
}

/// A ray prepared for a node's boxes (four or eight lanes at a time) and for four triangles
/// at a time.
struct Ray4 {
    o: [F4; 3],
    inv: [F4; 3],
    /// Per axis, the node's near and far planes (the low side for a positive direction).
    near: [usize; 3],
    far: [usize; 3],
    tmax: F4,
    /// The origin's components in the shear's order (kx, ky, kz), and the shear.
    ok: [F4; 3],
    s: [F4; 3],
}

impl Ray4 {
    fn new(o: Vec3, d: Vec3, tmax: f32, ray: &WatertightRay) -> Ray4 {
        // Lane by lane the IEEE reciprocal, in one vector division.
        let inv = Vec3::from(Vec3A::from(d).recip());
        let [kx, ky, kz] = ray.k;
        let oa = o.to_array();
        Ray4 {
            o: [F4::splat(o.x), F4::splat(o.y), F4::splat(o.z)],
            inv: [F4::splat(inv.x), F4::splat(inv.y), F4::splat(inv.z)],
            near: std::array::from_fn(|a| if inv[a].is_sign_negative() { 3 + a } else { a }),
            far: std::array::from_fn(|a| if inv[a].is_sign_negative() { a } else { 3 + a }),
            tmax: F4::splat(tmax),
            ok: [F4::splat(oa[kx]), F4::splat(oa[ky]), F4::splat(oa[kz])],
            s: [F4::splat(ray.s.x), F4::splat(ray.s.y), F4::splat(ray.s.z)],
        }
    }

    /// The node's slab tests: a bit per lane whose box the ray enters in `[0, tmax]`, and the
    /// entry distances. A NaN slab distance (`0 * inf`: the ray in a box face's plane) leaves
    /// its axis unconstrained (`max` and `min` return their second operand on NaN, and the NaN
    /// is always the first). Four lanes at a time; [`avx::boxes`] does all eight at once with
    /// the same operations.
    #[inline(always)]
    fn boxes(&self, n: &Node) -> (u32, [f32; W]) {
        let (near, far) = (&self.near, &self.far);
        let mut mask = 0;
        let mut dist = [0.0f32; W];
        for half in 0..W / 4 {
            let plane =
                |side: usize| -> &[f32; 4] { n.planes[side][4 * half..4 * half + 4].try_into().expect("four lanes") };
            let slab = |axis: usize, side: usize| F4::load(plane(side)).sub(self.o[axis]).mul(self.inv[axis]);
            let tn = slab(0, near[0]).max(slab(1, near[1]).max(slab(2, near[2]).max(F4::splat(0.0))));
            let tf = slab(0, far[0]).min(slab(1, far[1]).min(slab(2, far[2]).min(self.tmax)));
            let tf = tf.mul(F4::splat(ROBUST));
            mask |= tn.le(tf) << (4 * half);
            dist[4 * half..4 * half + 4].copy_from_slice(&tn.to_array());
        }
        (mask & n.valid, dist)
    }

    /// The watertight test on a packet: a bit per lane hit in `(0, tmax)`, and the distances.
    /// Every operation is the scalar [`WatertightRay::intersect`]'s, in its order; a lane with
    /// a zero edge function takes the scalar test (its double-precision fall-back).
    #[inline(always)]
    fn triangles(&self, p: &Tri4, ray: &WatertightRay, tmax: f32) -> (u32, [f32; 4]) {
        let [kx, ky, kz] = ray.k;
        let [sx, sy, sz] = self.s;
        let rel = |vertex: usize, k: usize, lane: usize| F4::load(&p.v[vertex][k]).sub(self.ok[lane]);
        let (akx, aky, akz) = (rel(0, kx, 0), rel(0, ky, 1), rel(0, kz, 2));
        let (bkx, bky, bkz) = (rel(1, kx, 0), rel(1, ky, 1), rel(1, kz, 2));
        let (ckx, cky, ckz) = (rel(2, kx, 0), rel(2, ky, 1), rel(2, kz, 2));
        let (ax, ay) = (akx.sub(sx.mul(akz)), aky.sub(sy.mul(akz)));
        let (bx, by) = (bkx.sub(sx.mul(bkz)), bky.sub(sy.mul(bkz)));
        let (cx, cy) = (ckx.sub(sx.mul(ckz)), cky.sub(sy.mul(ckz)));
        let u = cx.mul(by).sub(cy.mul(bx));
        let v = ax.mul(cy).sub(ay.mul(cx));
        let w = bx.mul(ay).sub(by.mul(ax));
        let zero = F4::splat(0.0);
        let valid = (1u32 << p.n) - 1;
        let edge_zero = (u.eq(zero) | v.eq(zero) | w.eq(zero)) & valid;
        let negative = u.lt(zero) | v.lt(zero) | w.lt(zero);
        let positive = zero.lt(u) | zero.lt(v) | zero.lt(w);
        let det = u.add(v).add(w);
        let t = u.mul(sz.mul(akz)).add(v.mul(sz.mul(bkz))).add(w.mul(sz.mul(ckz)));
        let th = t.div(det);
        let hit = !(negative & positive) & !det.eq(zero) & zero.lt(th) & th.lt(F4::splat(tmax));
        let mut mask = hit & valid & !edge_zero;
        let mut th = th.to_array();
        if edge_zero != 0 {
            let mut lanes = edge_zero;
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let vert = |i: usize| Vec3::new(p.v[i][0][lane], p.v[i][1][lane], p.v[i][2][lane]);
                if let Some(t) = ray.intersect(&[vert(0), vert(1), vert(2)], tmax) {
                    mask |= 1 << lane;
                    th[lane] = t;
                }
            }
        }
        (mask, th)
    }
}

/// Precomputed shear of Woop et al. 2013.
struct WatertightRay {
    o: Vec3,
    k: [usize; 3],
    s: Vec3,
}

impl WatertightRay {
    fn new(o: Vec3, d: Vec3) -> Self {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        // The next two axes after `kz`, swapped when `d[kz]` is negative (the winding).
        const NEXT: [usize; 3] = [1, 2, 0];
        const AFTER: [usize; 3] = [2, 0, 1];
        let d = d.to_array();
        let (kx, ky) = if d[kz] < 0.0 {
            (AFTER[kz], NEXT[kz])
        } else {
            (NEXT[kz], AFTER[kz])
        };
        // `d[kx] / d[kz]`, `d[ky] / d[kz]` and `1 / d[kz]` as one vector division (each lane
        // is the IEEE quotient, as three scalar divisions would give).
        let s = Vec3A::new(d[kx], d[ky], 1.0) / Vec3A::splat(d[kz]);
        WatertightRay {
            o,
            k: [kx, ky, kz],
            s: s.into(),
        }
    }

    /// Distance to the triangle, if hit with `t` in `(0, tmax)`.
    #[inline(always)]
    fn intersect(&self, v: &[Vec3; 3], tmax: f32) -> Option<f32> {
        let [kx, ky, kz] = self.k;
        let (a, b, c) = (v[0] - self.o, v[1] - self.o, v[2] - self.o);
        let ax = a[kx] - self.s.x * a[kz];
        let ay = a[ky] - self.s.y * a[kz];
        let bx = b[kx] - self.s.x * b[kz];
        let by = b[ky] - self.s.y * b[kz];
        let cx = c[kx] - self.s.x * c[kz];
        let cy = c[ky] - self.s.y * c[kz];
        let mut u = cx * by - cy * bx;
        let mut vv = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            // Edge cases in double precision, as the paper prescribes.
            u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            vv = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        let t = u * (self.s.z * a[kz]) + vv * (self.s.z * b[kz]) + w * (self.s.z * c[kz]);
        let th = t / det;
        (th > 0.0 && th < tmax).then_some(th)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash::SplitMix;

    /// Triangles around `n` centres from `p`, their other corners within `spread` of it.
    fn clustered(p: &mut impl FnMut() -> Vec3, n: u32, spread: f32, first_tag: u32) -> Vec<Tri> {
        (0..n)
            .map(|i| {
                let c = p();
                Tri {
                    v: [c, c + p() * spread, c + p() * spread],
                    tag: first_tag + i,
                }
            })
            .collect()
    }

    /// The box tests this machine can run: `false` the four-lane one, `true` AVX.
    fn box_paths(_bvh: &Bvh) -> Vec<bool> {
        #[cfg(target_arch = "x86_64")]
        if _bvh.avx {
            return vec![false, true];
        }
        vec![false]
    }

    fn use_path(_bvh: &mut Bvh, _avx: bool) {
        #[cfg(target_arch = "x86_64")]
        {
            _bvh.avx = _avx;
        }
    }

    /// Asserts that the tree reports exactly the scalar test's hits of the ray, distances bit
    /// for bit, and that `occluded` agrees; returns how many there were.
    fn assert_brute_force(bvh: &Bvh, tris: &[Tri], o: Vec3, d: Vec3, tmax: f32) -> usize {
        let ray = WatertightRay::new(o, d);
        let mut brute: Vec<(u32, u32)> = tris
            .iter()
            .filter_map(|t| ray.intersect(&t.v, tmax).map(|h| (t.tag, h.to_bits())))
            .collect();
        let mut got = Vec::new();
        bvh.traverse(o, d, tmax, |tag, t| {
            got.push((tag, t.to_bits()));
            false
        });
        brute.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, brute, "ray {o} {d}");
        assert_eq!(bvh.occluded(o, d, tmax), !brute.is_empty(), "ray {o} {d}");
        got.len()
    }

    /// Every hit of the tree is the scalar test's hit, with the same distance to the bit, and
    /// none is missed (the packets' lanes and the boxes' robust slabs change nothing), with
    /// the four-lane box test and, where the machine has it, the eight-lane AVX one. Rays
    /// along the axes (zero direction components: NaN slabs) and triangles in axis planes
    /// (flat boxes) are among them.
    /// Every ray of a packet meets exactly the triangles its single traversal meets, at the
    /// same distances to the bit, and stops where it would (`stop` decides per hit): packets
    /// of coherent rays (one direction, nearby origins: the hull of signs holds) and of
    /// incoherent ones (mixed signs: the per-ray path), partial packets, axis-aligned
    /// directions, with the four-lane and (where the machine has it) the AVX box tests.
    #[test]
    fn packets_meet_what_single_rays_meet() {
        let mut r = SplitMix(11);
        let mut p = || Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 10.0 - 5.0;
        let mut tris = clustered(&mut p, 400, 0.8, 0);
        tris.extend(clustered(&mut p, 200, 3.0, 1000));
        let mut bvh = Bvh::build(tris);
        let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        let mut packets: Vec<Vec<(Vec3, Vec3, f32)>> = Vec::new();
        for k in 0..300 {
            let n = 1 + k % PACKET;
            let base = p();
            let shared = if k % 7 == 0 {
                axes[k / 7 % 6]
            } else {
                (p() - p()).normalize()
            };
            let coherent = k % 3 != 0;
            packets.push(
                (0..n)
                    .map(|_| {
                        let o = if coherent { base + p() * 0.02 } else { p() };
                        let d = if coherent { shared } else { (p() - p()).normalize() };
                        let tmax = if k % 4 == 0 {
                            f32::INFINITY
                        } else {
                            2.0 + 6.0 * (p().x + 5.0) / 10.0
                        };
                        (o, d, tmax)
                    })
                    .collect(),
            );
        }
        // Stop at a tag divisible by 5 (as an opaque surface), go on through the others.
        let stop = |tag: u32| tag.is_multiple_of(5);
        let mut compared = 0;
        for avx in box_paths(&bvh) {
            use_path(&mut bvh, avx);
            for rays in &packets {
                let mut got: Vec<Vec<(u32, u32)>> = vec![Vec::new(); rays.len()];
                let stopped = bvh.traverse_packet(rays, |i, tag, t| {
                    got[i].push((tag, t.to_bits()));
                    stop(tag)
                });
                for (i, &(o, d, tmax)) in rays.iter().enumerate() {
                    let mut want = Vec::new();
                    let s = bvh.traverse(o, d, tmax, |tag, t| {
                        want.push((tag, t.to_bits()));
                        stop(tag)
                    });
                    assert_eq!(stopped & (1 << i) != 0, s, "ray {i} of a packet of {}", rays.len());
                    if !s {
                        // Not stopped: every hit, the same set.
                        got[i].sort_unstable();
                        want.sort_unstable();
                        assert_eq!(got[i], want);
                    }
                    compared += want.len();
                }
            }
        }
        assert!(compared > 500, "{compared} hits: the packets must hit something");
    }

    #[test]
    fn matches_brute_force_on_random_triangles() {
        let mut r = SplitMix(5);
        let mut p = || Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 10.0 - 5.0;
        let mut tris: Vec<Tri> = (0..500)
            .map(|i| Tri {
                v: [p(), p(), p()],
                tag: i,
            })
            .collect();
        for i in 0..100 {
            let (a, b, c) = (p(), p(), p());
            let z = (i % 5) as f32 - 2.0;
            tris.push(Tri {
                v: [a.with_z(z), b.with_z(z), c.with_z(z)],
                tag: 1000 + i,
            });
        }
        let mut bvh = Bvh::build(tris.clone());
        let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        let rays: Vec<(Vec3, Vec3)> = (0..600)
            .map(|i| {
                let o = p();
                let d = if i % 5 == 0 {
                    axes[i / 5 % 6]
                } else {
                    (p() - p()).normalize()
                };
                (o, d)
            })
            .collect();
        let mut hits = 0;
        for avx in box_paths(&bvh) {
            use_path(&mut bvh, avx);
            hits += rays
                .iter()
                .map(|&(o, d)| assert_brute_force(&bvh, &tris, o, d, f32::MAX))
                .sum::<usize>();
        }
        assert!(hits > 1000, "{hits} hits: the rays must hit something");
    }

    /// Trees of 1 to 40 triangles (a root that is one leaf, nodes of every lane count) find
    /// exactly the brute-force hits, on every box test.
    #[test]
    fn small_trees_match_brute_force() {
        let mut r = SplitMix(17);
        let mut p = || Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 4.0 - 2.0;
        for n in 1..=40u32 {
            let tris = clustered(&mut p, n, 0.5, 0);
            let mut bvh = Bvh::build(tris.clone());
            assert_eq!(bvh.len(), n as usize);
            let rays: Vec<(Vec3, Vec3)> = (0..200).map(|_| (p() * 2.0, (p() - p()).normalize())).collect();
            for avx in box_paths(&bvh) {
                use_path(&mut bvh, avx);
                for &(o, d) in &rays {
                    assert_brute_force(&bvh, &tris, o, d, 10.0);
                }
            }
        }
    }

    /// Centres that differ by denormal amounts (an extent whose bin scale is infinite, so
    /// `0 * inf` bin positions) and by huge ones still give a tree that finds every hit: the
    /// bins and the partition place each primitive alike.
    #[test]
    fn denormal_and_huge_extents_match_brute_force() {
        // Triangles in the planes x = 0, x = tiny and x = 2 tiny: their centres' extent on x
        // is denormal, its bin scale infinite.
        let tiny = f32::from_bits(1);
        let mut tris: Vec<Tri> = (0..120u32)
            .map(|i| {
                let x = (i % 3) as f32 * tiny;
                let s = 0.01 * (i / 3) as f32;
                Tri {
                    v: [Vec3::new(x, s, s), Vec3::new(x, 1.0 + s, s), Vec3::new(x, s, 1.0 + s)],
                    tag: i,
                }
            })
            .collect();
        tris.extend((0..40u32).map(|i| {
            let c = Vec3::new(if i % 2 == 0 { 3e38 } else { -3e38 }, i as f32, 0.0);
            Tri {
                v: [c, c + Vec3::Y, c + Vec3::Z],
                tag: 1000 + i,
            }
        }));
        let bvh = Bvh::build(tris.clone());
        assert_eq!(bvh.len(), tris.len());
        for (o, d) in [
            (Vec3::new(-1.0, 0.3, 0.3), Vec3::X),
            (Vec3::new(1.0, 0.45, 0.2), -Vec3::X),
            (Vec3::new(0.0, 0.5, 5.0), -Vec3::Z),
            (Vec3::new(0.0, 0.5, 0.5), Vec3::X),
            (Vec3::new(0.0, 0.5, 0.5), Vec3::new(1.0, 0.0, 0.0001).normalize()),
        ] {
            assert_brute_force(&bvh, &tris, o, d, f32::INFINITY);
        }
        // The ray along x through (0.3, 0.3) crosses the three planes of every shift up to 0.3
        // (the last on its edge).
        assert!(assert_brute_force(&bvh, &tris, Vec3::new(-1.0, 0.3, 0.3), Vec3::X, 10.0) >= 90);
    }

    /// The stack gives back what was pushed, last first, past its 64 places too.
    #[test]
    fn the_stack_is_last_in_first_out_past_its_array() {
        let mut s = Stack::<u32>::new();
        assert_eq!(s.pop(), None);
        for round in 0..2 {
            for v in 0..150 {
                s.push(v + round);
            }
            for v in (0..150).rev() {
                assert_eq!(s.pop(), Some(v + round));
            }
            assert_eq!(s.pop(), None);
        }
        // Interleaved around the array's end.
        for v in 0..64 {
            s.push(v);
        }
        s.push(100);
        assert_eq!(s.pop(), Some(100));
        s.push(101);
        s.push(102);
        assert_eq!((s.pop(), s.pop(), s.pop()), (Some(102), Some(101), Some(63)));
    }

    #[test]
    fn the_tree_is_the_same_for_1_2_and_4_threads() {
        let mut r = SplitMix(9);
        let mut p = || Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 10.0 - 5.0;
        // Enough triangles for the parallel levels and the parallel binning, with shared
        // centroids for the fall-back.
        let mut tris = clustered(&mut p, 2 * PARALLEL_BINNING as u32, 0.05, 0);
        tris.extend((0..64).map(|i| Tri {
            v: [Vec3::ZERO, Vec3::X, Vec3::Y],
            tag: 40_000 + i,
        }));
        let digest = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| Bvh::build(tris.clone()).digest())
        };
        let one = digest(1);
        assert_eq!(one, digest(2));
        assert_eq!(one, digest(4));
    }

    #[test]
    fn empty_degenerate_and_non_finite_input_gives_an_empty_tree() {
        let empty = Bvh::build(Vec::new());
        assert!(empty.is_empty() && !empty.occluded(Vec3::ZERO, Vec3::X, f32::INFINITY));
        let bad = vec![
            Tri {
                v: [Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
                tag: 0,
            },
            Tri {
                v: [Vec3::ZERO, Vec3::ZERO, Vec3::Y],
                tag: 1,
            },
            Tri {
                v: [Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X, Vec3::Y],
                tag: 2,
            },
            Tri {
                v: [Vec3::ZERO, Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::Y],
                tag: 3,
            },
        ];
        let b = Bvh::build(bad);
        assert_eq!(b.len(), 0);
        assert!(!b.occluded(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 10.0));
        // One good triangle: a tree of one leaf.
        let one = Bvh::build(vec![Tri {
            v: [Vec3::ZERO, Vec3::X, Vec3::Y],
            tag: 7,
        }]);
        let mut tags = Vec::new();
        one.traverse(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 10.0, |t, _| {
            tags.push(t);
            false
        });
        assert_eq!(tags, [7]);
    }

    #[test]
    fn shared_edges_are_watertight() {
        // A fan of triangles around the z axis: rays down the shared edges hit at least once.
        let n = 7;
        let tris: Vec<Tri> = (0..n)
            .map(|i| {
                let a = |k: u32| {
                    let t = k as f32 / n as f32 * std::f32::consts::TAU;
                    Vec3::new(crate::math::cos(t), crate::math::sin(t), 0.0)
                };
                Tri {
                    v: [Vec3::ZERO, a(i), a(i + 1)],
                    tag: i,
                }
            })
            .collect();
        let bvh = Bvh::build(tris);
        for i in 0..n {
            let t = i as f32 / n as f32 * std::f32::consts::TAU;
            for s in [0.0f32, 0.25, 0.5, 0.999] {
                let o = Vec3::new(crate::math::cos(t) * s, crate::math::sin(t) * s, 1.0);
                assert!(bvh.occluded(o, -Vec3::Z, 10.0), "ray down edge {i} at {s} leaked");
            }
        }
    }
}
