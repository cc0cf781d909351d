//! Per-pixel fragment lists: a head (and tail) index per pixel plus one node pool, as GPUs
//! build order-independent transparency and irregular z-buffer lists with atomics.
//!
//! Unlike an atomic counter, the pool here is filled deterministically: during a draw every
//! tile appends to its own local pool; afterwards the local pools are merged in tile order and
//! linked behind each pixel's existing list. Each pixel's list is therefore in submission
//! order, and node indices never depend on the thread count.

use super::error::PipelineError;
use super::surface::Surface;
use glam::Vec4;

/// Marks "no node".
pub const NONE: u32 = u32::MAX;

/// One stored fragment.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ListNode {
    /// Fragment depth (after offset and clamp).
    pub depth: f32,
    /// The fragment program's output.
    pub value: Vec4,
    /// Index of the source triangle in its draw.
    pub prim: u32,
    /// Index of the draw call that produced it (counted per [`FragmentLists`]).
    pub draw: u32,
    /// Next node of the same pixel, or [`NONE`].
    pub next: u32,
}

/// Per-pixel linked lists of fragments.
#[derive(Clone, Debug)]
pub struct FragmentLists {
    head: Surface<u32>,
    tail: Surface<u32>,
    nodes: Vec<ListNode>,
    capacity: usize,
    draws: u32,
}

impl FragmentLists {
    /// Empty lists for a `width` x `height` target holding at most `capacity` nodes.
    pub fn new(width: u32, height: u32, capacity: usize) -> Result<Self, PipelineError> {
        Ok(FragmentLists {
            head: Surface::new(width, height, NONE)?,
            tail: Surface::new(width, height, NONE)?,
            nodes: Vec::new(),
            capacity,
            draws: 0,
        })
    }

    /// Width of the target.
    pub fn width(&self) -> u32 {
        self.head.width()
    }

    /// Height of the target.
    pub fn height(&self) -> u32 {
        self.head.height()
    }

    /// Node capacity.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Nodes stored so far.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when no fragment is stored.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Removes every node (capacity unchanged).
    pub fn clear(&mut self) {
        self.head.fill(NONE);
        self.tail.fill(NONE);
        self.nodes.clear();
        self.draws = 0;
    }

    /// The node pool.
    pub fn nodes(&self) -> &[ListNode] {
        &self.nodes
    }

    /// Head index per pixel.
    pub fn heads(&self) -> &Surface<u32> {
        &self.head
    }

    /// Iterates the list of pixel (x, y) in submission order.
    pub fn iter(&self, x: u32, y: u32) -> ListIter<'_> {
        ListIter {
            nodes: &self.nodes,
            cur: self.head.at(x, y),
        }
    }

    /// Length of each pixel's list (for dumps and tests).
    pub fn lengths(&self) -> Surface<u32> {
        let mut s = Surface::from_vec_derived(
            self.width(),
            self.height(),
            vec![0u32; self.width() as usize * self.height() as usize],
        )
        .expect("same size as lists");
        for y in 0..self.height() {
            for x in 0..self.width() {
                s.set(x, y, self.iter(x, y).count() as u32);
            }
        }
        s
    }

    /// Merges one tile's local pool (`nodes` with local `next` links; `local_head`/`local_tail`
    /// over the tile rectangle, row-major, `rect` inclusive) behind the existing lists.
    pub(crate) fn merge_tile(&mut self, rect: [i32; 4], nodes: &[ListNode], local_head: &[u32], local_tail: &[u32]) {
        let base = self.nodes.len() as u32;
        let draw = self.draws;
        self.nodes.extend(nodes.iter().map(|n| ListNode {
            next: if n.next == NONE { NONE } else { n.next + base },
            draw,
            ..*n
        }));
        let w = (rect[2] - rect[0] + 1) as usize;
        for (i, (&h, &t)) in local_head.iter().zip(local_tail).enumerate() {
            if h == NONE {
                continue;
            }
            let x = rect[0] as u32 + (i % w) as u32;
            let y = rect[1] as u32 + (i / w) as u32;
            let old_tail = self.tail.at(x, y);
            if old_tail == NONE {
                self.head.set(x, y, h + base);
            } else {
                self.nodes[old_tail as usize].next = h + base;
            }
            self.tail.set(x, y, t + base);
        }
    }

    pub(crate) fn end_draw(&mut self) {
        self.draws += 1;
    }
}

/// Iterator over one pixel's list.
pub struct ListIter<'a> {
    nodes: &'a [ListNode],
    cur: u32,
}

impl<'a> Iterator for ListIter<'a> {
    type Item = &'a ListNode;
    fn next(&mut self) -> Option<&'a ListNode> {
        if self.cur == NONE {
            return None;
        }
        let n = &self.nodes[self.cur as usize];
        self.cur = n.next;
        Some(n)
    }
}
