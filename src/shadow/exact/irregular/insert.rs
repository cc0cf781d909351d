//! Passes 1-3 of the irregular z-buffer: the camera samples, the light views cropped to
//! them, and the lists by a parallel counting sort that gives the serial sort's result.

use super::samples::{sample_uv, triangle_facing, CameraSample, SampleFiller};
use super::*;
use crate::pipeline::compute::Scatter;
use crate::pipeline::Reservation;
use crate::shadow::light::Payload;

/// A sample's record from pass 1: where its ray starts and the triangle it never tests
/// ([`NO_TRIANGLE`]: none).
#[derive(Copy, Clone, Debug, Default)]
pub(super) struct Rec {
    origin: Vec3,
    triangle: u32,
}

/// A sample on its way through the counting sort: its record, its index and its texel's
/// column (the whole record travels, so the last step reads it in order instead of
/// gathering it from the samples).
#[derive(Copy, Clone, Debug, Default)]
pub(super) struct Entry {
    rec: Rec,
    sample: u32,
    column: u32,
}

/// A view of the grid before its lists: the cropped view, its base view, and the crop in
/// the base view's uv.
type Cropped = (LightView, LightView, Grid);

/// Per chunk of samples: its count per (view, texel row), and its samples that test their
/// own triangle.
type ChunkCounts = Vec<(Vec<u32>, usize)>;

impl IrregularZBuffer {
    pub(super) fn insert(&mut self, p: &Pipeline, frame: &Frame) -> Result<(), Error> {
        let size = self.opts.size;
        // A list sample keeps a triangle id in 31 bits (see `ListSample`).
        let triangles = frame.scene.triangles();
        if triangles >= NO_TRIANGLE as usize {
            return Err(Error::budget(
                "the lists' triangle ids (31 bits): the scene's triangles",
                triangles as u64,
                NO_TRIANGLE as u64 - 1,
                Resource::Entries,
            ));
        }
        let row_counts = self.count_rows(frame)?;
        let light = frame.light;
        // A spot light's samples may lie outside its cone (the reference gives spot lights no
        // cone): like point lights, it gets six cube faces, each cropped to its samples.
        let base = match light.kind {
            LightKind::Spot { .. } => light::cube_views(frame, size),
            _ => light_views(frame, size),
        };
        let row_bounds = self.sample_pass(frame, &base, &row_counts);
        let (view_of, views) = crop_views(&base, &row_bounds, size);
        let (counts, chunk) = self.key_pass(&view_of, &views);
        let (row_at, starts) = row_starts(&counts, views.len() * size as usize);
        let inserted = row_at[row_at.len() - 1] as usize;
        self.scatter_pass(starts, chunk, inserted);
        let mut lists = Lists {
            size,
            crops: views.iter().map(|(_, base, grid)| (*base, *grid)).collect(),
            by_row: &self.by_row,
            row_at: &row_at,
        };
        let views = views.into_iter().map(|(view, _, _)| view).collect();
        self.views.render(p, views, size, &mut lists)?;
        self.inserted = inserted;
        Ok(())
    }

    /// The samples per image row, and the lists' capacity checked before anything is
    /// allocated: `row_start` and `total`.
    fn count_rows(&mut self, frame: &Frame) -> Result<Vec<u32>, Error> {
        let k = self.opts.samples.count();
        let w = frame.width() as usize;
        let row_counts: Vec<u32> = frame
            .gbuffer
            .object
            .data()
            .par_chunks(w)
            .map(|r| (r.iter().filter(|&&o| o != NO_OBJECT).count() * k) as u32)
            .collect();
        self.row_start.clear();
        self.row_start.push(0);
        let mut total = 0usize;
        for c in &row_counts {
            total += *c as usize;
            self.row_start.push(total as u32);
        }
        if total > self.opts.capacity as usize {
            return Err(Error::budget(
                format!(
                    "the lists' samples ({}x{} pixels, {k} per covered pixel; option capacity, at most {})",
                    frame.width(),
                    frame.height(),
                    1u32 << 28
                ),
                total as u64,
                self.opts.capacity as u64,
                Resource::Entries,
            ));
        }
        self.total = total;
        Ok(row_counts)
    }

    /// Pass 1, row by row in parallel: the samples; for each, the base view it falls in
    /// (none: it faces away from the light), its uv there, and its record (ray origin, and
    /// the triangle it skips). A sample skips its own triangle only where that triangle faces
    /// the light (its geometric normal turned to the side of the shading normal, for
    /// two-sided sheets). Where it faces away (the terminator of a tessellated sphere, the
    /// far side of a heightfield's ridge), the sample's ray leaves through the back of its
    /// own surface and the triangle is tested like any other. Returns each row's uv bounds
    /// per view (min and max: exact in any order).
    fn sample_pass(&mut self, frame: &Frame, base: &[LightView], row_counts: &[u32]) -> Vec<Vec<(Vec2, Vec2)>> {
        let k = self.opts.samples.count();
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let total = self.total;
        let light = frame.light;
        let nb = base.len();
        let facing = triangle_facing(frame);
        let filler = SampleFiller::new(frame, self.opts.samples);
        // (Every element is written below: the kept buffers are only resized.)
        self.uv.resize(total, Vec2::ZERO);
        self.rec.resize(total, Rec::default());
        self.meta.resize(total, META_NONE);
        let mut rows: Vec<(&mut [Vec2], &mut [Rec], &mut [u8])> = Vec::with_capacity(h);
        let (mut ru, mut rr, mut rm) = (
            self.uv.as_mut_slice(),
            self.rec.as_mut_slice(),
            self.meta.as_mut_slice(),
        );
        for c in row_counts {
            let c = *c as usize;
            let (au, bu) = std::mem::take(&mut ru).split_at_mut(c);
            let (ar, br) = std::mem::take(&mut rr).split_at_mut(c);
            let (am, bm) = std::mem::take(&mut rm).split_at_mut(c);
            rows.push((au, ar, am));
            (ru, rr, rm) = (bu, br, bm);
        }
        let empty = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        let points = frame.points();
        rows.into_par_iter()
            .enumerate()
            .map_init(Vec::new, |buf: &mut Vec<CameraSample>, (y, (uvs, rec, meta))| {
                let mut b = vec![empty; nb];
                let count = uvs.len();
                // The bounds of the view the last sample fell in, kept in registers (a row's
                // samples mostly fall in one view; min and max are exact in any order).
                let mut cur = (usize::MAX, empty);
                {
                    let mut one = |j: usize, s: &SamplePoint, triangle: u32| {
                        let Some((f, uv)) = sample_uv(base, &light, s) else {
                            meta[j] = META_NONE;
                            rec[j] = Rec {
                                origin: Vec3::ZERO,
                                triangle: NO_TRIANGLE,
                            };
                            return;
                        };
                        if f != cur.0 {
                            if cur.0 != usize::MAX {
                                b[cur.0] = cur.1;
                            }
                            cur = (f, b[f]);
                        }
                        cur.1 = (cur.1 .0.min(uv), cur.1 .1.max(uv));
                        uvs[j] = uv;
                        let skip_own = facing.get(triangle as usize).is_some_and(|&(n, lit)| {
                            let flip = n.dot(s.normal) < 0.0;
                            lit != flip
                        });
                        meta[j] = f as u8 | if skip_own { META_SKIP_OWN } else { 0 };
                        rec[j] = Rec {
                            // The ray starts where the reference's does: the point moved a few
                            // ULPs along its triangle's normal (Wächter and Binder 2019), a
                            // property of float numbers, not a bias that depends on the scene or
                            // the light.
                            origin: offset_origin(s.position, s.face),
                            triangle: if skip_own { triangle } else { NO_TRIANGLE },
                        };
                    };
                    if k == 1 {
                        let mut j = 0;
                        for x in 0..w {
                            let i = y * w + x;
                            if let Some(s) = &points[i] {
                                one(j, s, filler.triangle(i));
                                j += 1;
                            }
                        }
                    } else {
                        buf.clear();
                        buf.resize(count, CameraSample::default());
                        filler.row(y, buf);
                        for (j, c) in buf.iter().enumerate() {
                            one(j, &c.point, c.triangle);
                        }
                    }
                }
                if cur.0 != usize::MAX {
                    b[cur.0] = cur.1;
                }
                b
            })
            .collect()
    }

    /// Pass 3a, by chunks in parallel: each sample's key (view and texel in its cropped
    /// view, or none), and each chunk's count per texel row of every view. Returns the
    /// counts and the chunk length.
    fn key_pass(&mut self, view_of: &[u8], views: &[Cropped]) -> (ChunkCounts, usize) {
        let size = self.opts.size;
        let total = self.total;
        let n = (size * size) as usize;
        let s = size as usize;
        let buckets = views.len() * s;
        let chunk = total.div_ceil(MAX_CHUNKS).max(MIN_CHUNK);
        self.keys.resize(total, u32::MAX);
        let per_chunk: ChunkCounts = self
            .keys
            .par_chunks_mut(chunk)
            .zip(self.uv.par_chunks(chunk))
            .zip(self.meta.par_chunks(chunk))
            .map(|((keys, uvs), meta)| {
                let mut hist = vec![0u32; buckets];
                let mut own_tested = 0;
                for ((key, uv), &m) in keys.iter_mut().zip(uvs).zip(meta) {
                    *key = u32::MAX;
                    if m == META_NONE {
                        continue;
                    }
                    let v = view_of[(m & !META_SKIP_OWN) as usize] as usize;
                    let (tx, ty) = views[v].2.texel(*uv);
                    *key = (v * n + ty * s + tx) as u32;
                    hist[v * s + ty] += 1;
                    own_tested += (m & META_SKIP_OWN == 0) as usize;
                }
                (hist, own_tested)
            })
            .collect();
        self.own_tested = per_chunk.iter().map(|c| c.1).sum();
        (per_chunk, chunk)
    }

    /// Pass 3c, by chunks in parallel: each sample's entry (record, index and column) behind
    /// the ones before it in its row's run (every position has one writer).
    fn scatter_pass(&mut self, mut starts: Vec<Vec<u32>>, chunk: usize, inserted: usize) {
        let size = self.opts.size;
        let s = size as usize;
        self.by_row.resize(inserted, Entry::default());
        {
            let out = Scatter::new(&mut self.by_row[..inserted]);
            self.keys
                .par_chunks(chunk)
                .zip(self.rec.par_chunks(chunk))
                .zip(starts.par_iter_mut())
                .enumerate()
                .for_each(|(c, ((keys, rec), cursor))| {
                    for (j, (&key, r)) in keys.iter().zip(rec).enumerate() {
                        if key == u32::MAX {
                            continue;
                        }
                        let b = key as usize / s;
                        let e = Entry {
                            rec: *r,
                            sample: (c * chunk + j) as u32,
                            column: key % size,
                        };
                        // SAFETY: the prefix sum gives each (row, chunk) run its own positions,
                        // and this chunk alone advances its cursors through them.
                        unsafe { out.write(cursor[b] as usize, e) };
                        cursor[b] += 1;
                    }
                });
        }
    }
}

/// Pass 3d, by texel rows in parallel, as the light pass's payload: each row counts its
/// records per texel, and puts them behind the ones before them in their texel's list (a
/// stable sort by column) into the row's part of the store; the occluder pass's masks. Every
/// buffer of the last run's views is reused.
struct Lists<'a> {
    size: u32,
    /// Per cropped view: its base view and the crop.
    crops: Vec<(LightView, Grid)>,
    /// The records sorted by (view, texel row).
    by_row: &'a [Entry],
    /// Per (view, texel row): where its records start in `by_row`.
    row_at: &'a [u32],
}

impl Payload for Lists<'_> {
    type Map = View;

    fn what(&self) -> &'static str {
        "the irregular z-buffer's lists"
    }

    fn draw(&mut self, _: &Pipeline, v: usize, view: &LightView, old: Option<View>) -> Result<View, Error> {
        let size = self.size;
        let n = (size * size) as usize;
        let s = size as usize;
        let by_row = self.by_row;
        let (base, grid) = self.crops[v];
        let (mut store, mut order, mask, mut texels, mut reserved) = match old {
            Some(o) => (o.store, o.order, o.mask, o.texels, o.reserved),
            None => (
                PixelStore::default(),
                Vec::new(),
                None,
                Vec::new(),
                Reservation::default(),
            ),
        };
        let axis = axis_depth(view);
        let runs = &self.row_at[v * s..=(v + 1) * s];
        let listed = (runs[s] - runs[0]) as usize;
        // The texels' records and the lists' order, in the memory budget before they grow
        // (what they hold stays reserved: the buffers are kept from run to run).
        let need = (n * std::mem::size_of::<Texel>() + listed * 4) as u64;
        reserved.resize(size, size, need.max(reserved.bytes()))?;
        texels.resize(n, Texel { far: 0.0, tests: 0 });
        let texel_rows = Scatter::new(&mut texels);
        let row_totals: Vec<u32> = runs.windows(2).map(|r| r[1] - r[0]).collect();
        order.resize(listed, 0);
        let ord = Scatter::new(&mut order);
        store.rebuild_rows(size, size, &row_totals, ListSample::EMPTY, |ty, starts, part| {
            let run = &by_row[runs[ty] as usize..runs[ty + 1] as usize];
            let first = (runs[ty] - runs[0]) as usize;
            starts.fill(0);
            for e in run {
                starts[e.column as usize] += 1;
            }
            let mut acc = 0;
            for st in starts.iter_mut() {
                let c = *st;
                *st = acc;
                acc += c;
            }
            let mut cursor = starts.to_vec();
            let mut row_far = vec![f32::NEG_INFINITY; s];
            for e in run {
                let f = &mut row_far[e.column as usize];
                *f = f.max(axis_at(axis, e.rec.origin));
                let at = &mut cursor[e.column as usize];
                part[*at as usize] = ListSample {
                    position: e.rec.origin,
                    state: e.rec.triangle,
                };
                // SAFETY: every record of the view is in one row's run once.
                unsafe { ord.write(first + *at as usize, e.sample) };
                *at += 1;
            }
            for (x, far) in row_far.into_iter().enumerate() {
                // SAFETY: row `ty` alone writes texels `ty * s .. (ty + 1) * s`.
                unsafe { texel_rows.write(ty * s + x, Texel { far, tests: 0 }) };
            }
        })?;
        let mut mask = match mask {
            Some(m) if m.width() == size => m,
            _ => Surface::new(size, size, 0.0f32)?,
        };
        let offsets = store.offsets();
        mask.data_mut()
            .par_iter_mut()
            .zip(offsets.par_windows(2))
            .for_each(|(m, o)| *m = if o[1] > o[0] { 1.0 } else { -1.0 });
        Ok(View {
            base,
            grid,
            store,
            order,
            mask: Some(mask),
            texels,
            reserved,
            fragments: 0,
            rasterized: 0,
        })
    }
}

/// Pass 2: each view's tight bounds over its rows' bounds, then the views cropped to them
/// (a view without samples is left out). Returns, per base view, its index among the
/// cropped views (`u8::MAX`: none), and the cropped views.
fn crop_views(base: &[LightView], row_bounds: &[Vec<(Vec2, Vec2)>], size: u32) -> (Vec<u8>, Vec<Cropped>) {
    let nb = base.len();
    let empty = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
    let mut bounds = vec![empty; nb];
    for rb in row_bounds {
        for (e, r) in bounds.iter_mut().zip(rb) {
            *e = (e.0.min(r.0), e.1.max(r.1));
        }
    }
    let mut view_of = vec![u8::MAX; nb];
    // Per view: the cropped view, its base view, and the crop in the base view's uv.
    let mut views: Vec<Cropped> = Vec::new();
    for (f, (lo, hi)) in bounds.iter().enumerate() {
        if lo.x > hi.x {
            continue; // no samples in this view
        }
        view_of[f] = views.len() as u8;
        let (view, grid) = crop(&base[f], *lo, *hi, size);
        views.push((view, base[f], grid));
    }
    (view_of, views)
}

/// Pass 3b: where each chunk's run of each texel row starts (rows in order, chunks in order
/// within a row: the serial sort's order). Returns each row's start (and the end, the
/// number of samples in the lists) and each chunk's starts.
fn row_starts(counts: &ChunkCounts, buckets: usize) -> (Vec<u32>, Vec<Vec<u32>>) {
    let mut row_at = Vec::with_capacity(buckets + 1);
    let mut starts = vec![vec![0u32; buckets]; counts.len()];
    let mut at = 0u32;
    for b in 0..buckets {
        row_at.push(at);
        for (c, (hist, _)) in counts.iter().enumerate() {
            starts[c][b] = at;
            at += hist[b];
        }
    }
    row_at.push(at);
    (row_at, starts)
}

/// `base` cropped to its samples' uv bounds `lo`..`hi` (plus half a texel), so the grid's
/// texels cover only where samples are: a scale and offset of clip x and y.
pub(super) fn crop(base: &LightView, lo: Vec2, hi: Vec2, size: u32) -> (LightView, Grid) {
    let pad = 0.5 / size as f32;
    let (lo, hi) = (lo - pad, hi + pad);
    // uv -> ndc: x = 2u - 1, y = 1 - 2v.
    let (x0, x1) = (2.0 * lo.x - 1.0, 2.0 * hi.x - 1.0);
    let (y0, y1) = (1.0 - 2.0 * hi.y, 1.0 - 2.0 * lo.y);
    let (sx, sy) = (2.0 / (x1 - x0).max(1e-9), 2.0 / (y1 - y0).max(1e-9));
    let c = Mat4::from_cols(
        Vec4::new(sx, 0.0, 0.0, 0.0),
        Vec4::new(0.0, sy, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(-(x0 + x1) * 0.5 * sx, -(y0 + y1) * 0.5 * sy, 0.0, 1.0),
    );
    let view = LightView {
        matrix: c * base.matrix,
        texel: base.texel * (hi - lo).max_element(),
        kind: base.kind,
    };
    let grid = Grid {
        lo,
        scale: Vec2::splat(size as f32) / (hi - lo).max(Vec2::splat(1e-9)),
        size,
    };
    (view, grid)
}

/// A cropped view's texels in its base view's uv: the crop's scale and offset.
#[derive(Copy, Clone, Debug)]
pub(super) struct Grid {
    pub(super) lo: Vec2,
    pub(super) scale: Vec2,
    pub(super) size: u32,
}

impl Grid {
    /// The texel (column, row) of base-view uv `uv`.
    #[inline(always)]
    pub(super) fn texel(&self, uv: Vec2) -> (usize, usize) {
        let t = ((uv - self.lo) * self.scale).floor();
        let last = self.size as f32 - 1.0;
        (t.x.clamp(0.0, last) as usize, t.y.clamp(0.0, last) as usize)
    }
}
