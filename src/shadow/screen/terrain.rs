//! Terrain occlusion height (Gollent 2014, "Landscape creation and rendering in REDengine 3";
//! RTR 7.10 and fig. 7.32): for each location of a grid over the terrain, the height above
//! which the sun is visible. A location the sun's shadow map of the terrain shadows is marched
//! up in fixed steps until the sun is visible, then the height where it first is is refined by
//! binary search; a lit location stores its surface height. Any point (the terrain and every
//! object standing on it) is then shadowed below the occlusion height interpolated bilinearly
//! from its four nearest locations, with a linear transition over a height band centred on it
//! (the soft terrain shadows of fig. 7.32):
//!
//! `v = clamp((y - H(x, z)) / band + 1/2, 0, 1)`.
//!
//! A lit location stores a height below its surface (half the band, and its largest surface
//! step to a neighbour, which bounds how far the bilinear interpolation cuts below a concave
//! surface), so that lit ground stays lit between locations.
//!
//! The grid's surface heights come from a top-down orthographic depth pass of the terrain
//! through the pipeline, the sun's map from the light's depth pass of `light/` (terrain only).
//! Above a heightfield the occlusion height is exact in the limit: a point higher than a lit
//! one sees the sun along a parallel ray raised above it, so visibility is monotone in height
//! and the search converges to the true height, up to the map's resolution and the grid's.
//!
//! Known failure: occluders that are not terrain (the trees on it, overhangs) are not in the
//! heights, so they shadow nothing; `objects=true` adds a shadow map of the other objects.

use crate::frame::Frame;
use crate::pipeline::{DepthFormat, Pipeline};
use crate::pipeline::{PolygonOffset, Reservation, Surface};
use crate::reference::bvh::{Bvh, Tri};
use crate::scene::{Light, LightKind, Scene};
use crate::shadow::inspect::{explain, Trace};
use crate::shadow::light::pass::Depth;
use crate::shadow::light::{corners, directional_view, locate_on, merged_casters, scene_depth, DepthPass, ViewMaps};
use crate::shadow::technique::{Declaration, Entry, Family, Field, ShadowTechnique, Stage, Step, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;
use glam::{Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "terrain-height",
    family: Family::Screen,
    summary: "per terrain-grid location, the height above which the sun is visible (Gollent 2014; RTR 7.10): soft terrain shadows on everything above it; objects that are not terrain shadow nothing",
    sweep: &[
        &[],
        &[("objects", "true")],
        &[("grid", "128")],
        &[("band", "0")],
        &[("step", "1"), ("iterations", "2")],
    ],
    extended: &[&[("grid", "1024"), ("size", "4096")], &[("iterations", "0")]],
    applies: Some(applies),
    ..Entry::BASE
};

/// Options of terrain occlusion height.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Grid locations per side over the terrain's extent. Default: 512.
    pub grid: u32,
    /// Height of each step of the march up, world units. Default: 0.25.
    pub step: f32,
    /// Binary-search iterations after the march (each halves the height's uncertainty).
    /// Default: 8.
    pub iterations: u32,
    /// Height of the transition below the occlusion height, world units (0: a hard edge).
    /// Default: 0.05.
    pub band: f32,
    /// Side of the sun's shadow maps, texels. Default: 2048.
    pub size: u32,
    /// Also shadow by a shadow map of the objects that are not terrain. Default: false.
    pub objects: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            grid: 512,
            step: 0.25,
            iterations: 8,
            band: 0.05,
            size: 2048,
            objects: false,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new(
        "terrain-height",
        vec![
            Field::range("grid", "grid locations per side", 2, 8192, |o: &mut Options| {
                &mut o.grid
            }),
            Field::range("step", "march-up step, world units", 1e-4, 1e6, |o: &mut Options| {
                &mut o.step
            }),
            Field::range(
                "iterations",
                "binary-search iterations after the march",
                0,
                40,
                |o: &mut Options| &mut o.iterations,
            ),
            Field::range(
                "band",
                "soft transition below the occlusion height, world units (0: hard)",
                0.0,
                1e6,
                |o: &mut Options| &mut o.band,
            ),
            Field::size("sun shadow-map side, texels", |o: &mut Options| &mut o.size),
            Field::new(
                "objects",
                "also shadow by a shadow map of the objects that are not terrain",
                |o: &mut Options| &mut o.objects,
            ),
        ],
    )
}

/// Whether terrain occlusion height works on `scene`: a heightfield under a directional
/// first light.
pub fn applies(scene: &Scene, light: &Light) -> bool {
    scene.objects.iter().any(|o| o.heightfield) && light.kind == LightKind::Directional
}

/// A depth map of some casters from the sun, with its view.
struct SunMap {
    maps: ViewMaps<Surface<f32>>,
}

impl SunMap {
    /// The sun's map of the objects `keep` selects, fitted to `receivers`.
    fn render(p: &Pipeline, frame: &Frame, keep: &[bool], receivers: &[Vec3], size: u32) -> Result<SunMap, Error> {
        let casters = merged_casters(frame, keep)?;
        let view = directional_view(frame, receivers, &casters.positions, size, false);
        let mut depth = Depth {
            pass: DepthPass {
                size,
                format: DepthFormat::F32,
                // The light pass's default polygon offset (`MapOptions`): no acne on the terrain.
                offset: PolygonOffset {
                    units: 4.0,
                    factor: 1.1,
                },
            },
            casters: &casters,
        };
        let mut maps = ViewMaps::default();
        maps.render(p, vec![view], size, &mut depth)?;
        Ok(SunMap { maps })
    }

    /// The depth map.
    fn map(&self) -> &Surface<f32> {
        &self.maps.get(0).0
    }

    /// Whether the map shadows world point `q` (one comparison of the nearest texel; outside
    /// the map: lit).
    #[inline]
    fn shadows(&self, q: Vec3) -> bool {
        match locate_on(self.maps.maps(), 0, q) {
            Some(at) if at.inside() => {
                let map = self.map();
                let (x, y) = at.texel(map.width(), map.height());
                at.depth > map.at(x, y)
            }
            _ => false,
        }
    }
}

/// The grid over the terrain: its extent and the world point of each location.
#[derive(Copy, Clone, Debug)]
struct Grid {
    lo: Vec3,
    hi: Vec3,
    n: u32,
}

impl Grid {
    fn cell(&self) -> Vec2 {
        Vec2::new(self.hi.x - self.lo.x, self.hi.z - self.lo.z) / self.n as f32
    }

    /// The (x, z) of location (i, j): the centre of its cell.
    fn at(&self, i: u32, j: u32) -> Vec2 {
        Vec2::new(self.lo.x, self.lo.z) + (Vec2::new(i as f32, j as f32) + 0.5) * self.cell()
    }

    /// The top-down orthographic view whose pixel centres are the locations: x across, z down
    /// the rows, depth 0 at `hi.y`, 1 at `lo.y`.
    fn view(&self) -> Mat4 {
        let d = self.hi - self.lo;
        Mat4::from_cols(
            Vec4::new(2.0 / d.x, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 0.0, -1.0 / d.y, 0.0),
            Vec4::new(0.0, -2.0 / d.z, 0.0, 0.0),
            Vec4::new(
                -2.0 * self.lo.x / d.x - 1.0,
                1.0 + 2.0 * self.lo.z / d.z,
                self.hi.y / d.y,
                1.0,
            ),
        )
    }

    /// The height of depth `z` of [`Grid::view`].
    fn height(&self, z: f32) -> f32 {
        self.hi.y - z * (self.hi.y - self.lo.y)
    }
}

/// What the build found at one location.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
struct Location {
    /// Surface height (NaN where the terrain does not cover the location).
    surface: f32,
    /// Occlusion height.
    height: f32,
    /// Map lookups of the march up and of the search.
    marched: u32,
    searched: u32,
}

/// Terrain occlusion height (see the module docs).
pub struct TerrainHeight {
    opts: Options,
    /// Last run: the grid, its locations (row-major), the sun's maps, the sun below the
    /// horizon.
    grid: Option<Grid>,
    locations: Vec<Location>,
    /// `locations` in the memory budget.
    reserved: Reservation,
    terrain_map: Option<SunMap>,
    objects_map: Option<SunMap>,
    night: bool,
    times: Vec<(&'static str, f64)>,
}

impl TerrainHeight {
    /// The technique with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<TerrainHeight, Error> {
        declaration().check(&opts)?;
        Ok(TerrainHeight {
            opts,
            grid: None,
            locations: Vec::new(),
            reserved: Reservation::default(),
            terrain_map: None,
            objects_map: None,
            night: false,
            times: Vec::new(),
        })
    }

    /// The terrain objects of `frame`'s scene (made as heightfields); an error names the
    /// objects it looked at when there is none.
    fn terrain(frame: &Frame) -> Result<Vec<bool>, Error> {
        let keep: Vec<bool> = frame.scene.objects.iter().map(|o| o.heightfield).collect();
        if !keep.iter().any(|&k| k) {
            return Err(Error::technique(format!(
                "terrain occlusion height needs a heightfield (mesh = \"heightfield\"), and scene '{}' has none (objects: {})",
                frame.scene.name,
                frame.scene.objects.iter().map(|o| o.name.as_str()).collect::<Vec<_>>().join(", ")
            )));
        }
        Ok(keep)
    }

    /// The occlusion heights of every location (the march up, then the search).
    fn build(&self, p: &Pipeline, grid: &Grid, surface: &Surface<f32>, sun: &SunMap) -> Vec<Location> {
        let n = grid.n as usize;
        let (step, iterations) = (self.opts.step, self.opts.iterations);
        let mut out = vec![Location::default(); n * n];
        p.install(|| {
            out.par_chunks_mut(n).enumerate().for_each(|(j, row)| {
                for (i, loc) in row.iter_mut().enumerate() {
                    let xz = grid.at(i as u32, j as u32);
                    let z = surface.at(i as u32, j as u32);
                    *loc = if z >= 1.0 {
                        Location {
                            surface: f32::NAN,
                            height: f32::NEG_INFINITY,
                            ..Default::default()
                        }
                    } else {
                        occlusion_height(sun, xz, grid.height(z), grid.hi.y, step, iterations)
                    };
                }
            })
        });
        // A lit location stores a height below its surface: half the band (so that the band
        // is centred on the shadow's edge) and its largest surface step to a neighbour (so
        // that the bilinear interpolation between lit locations, which cuts below a concave
        // surface by less than that, keeps the surface lit).
        let surface = |i: usize, j: usize| out[j * n + i].surface;
        let lowered: Vec<f32> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let l = out[k];
                if l.surface.is_nan() || l.height > l.surface {
                    return l.height;
                }
                let mut slack = 0.0f32;
                for (di, dj) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                    let (a, b) = (i as i64 + di, j as i64 + dj);
                    if a >= 0 && b >= 0 && (a as usize) < n && (b as usize) < n {
                        let d = (surface(a as usize, b as usize) - l.surface).abs();
                        if d.is_finite() {
                            slack = slack.max(d);
                        }
                    }
                }
                l.surface - 0.5 * self.opts.band - slack
            })
            .collect();
        for (l, h) in out.iter_mut().zip(lowered) {
            l.height = h;
        }
        out
    }

    /// The occlusion height interpolated at `(x, z)` (bilinear over the four nearest
    /// locations; outside the grid: none), each step reported to `t`.
    fn height_at(&self, grid: &Grid, q: Vec3, t: &mut impl Trace) -> f32 {
        let c = grid.cell();
        let g = (Vec2::new(q.x - grid.lo.x, q.z - grid.lo.z)) / c - 0.5;
        let n = grid.n as i64;
        if !(q.x >= grid.lo.x && q.x <= grid.hi.x && q.z >= grid.lo.z && q.z <= grid.hi.z) {
            t.step(|| Step::new("grid", "outside the terrain's grid: no occlusion height").vec3("point", q));
            return f32::NEG_INFINITY;
        }
        let (i0, j0) = (g.x.floor() as i64, g.y.floor() as i64);
        let f = g - Vec2::new(i0 as f32, j0 as f32);
        let h = |i: i64, j: i64| self.locations[(j.clamp(0, n - 1) * n + i.clamp(0, n - 1)) as usize].height;
        let (h00, h10, h01, h11) = (h(i0, j0), h(i0 + 1, j0), h(i0, j0 + 1), h(i0 + 1, j0 + 1));
        let top = h00 + (h10 - h00) * f.x;
        let bottom = h01 + (h11 - h01) * f.x;
        let v = top + (bottom - top) * f.y;
        t.step(|| {
            Step::new("occlusion height", "bilinear over the four nearest grid locations")
                .int("location x", i0)
                .int("location z", j0)
                .vec2("weights", f)
                .num("h00", h00)
                .num("h10", h10)
                .num("h01", h01)
                .num("h11", h11)
                .num("height", v)
        });
        v
    }

    /// Pixel `(x, y)`'s visibility, each step reported to `t`.
    fn pixel(&self, frame: &Frame, x: u32, y: u32, t: &mut impl Trace) -> f32 {
        let Some(s) = frame.point(x, y) else {
            return f32::NAN;
        };
        if self.night {
            t.step(|| Step::new("sun", "below the horizon: everything is shadowed"));
            return 0.0;
        }
        let Some(grid) = &self.grid else {
            return f32::NAN;
        };
        let q = s.position;
        let h = self.height_at(grid, q, t);
        let band = self.opts.band;
        let v = if band > 0.0 {
            ((q.y - h) / band + 0.5).clamp(0.0, 1.0)
        } else if q.y >= h {
            1.0
        } else {
            0.0
        };
        t.step(|| {
            Step::new(
                "band",
                "lit above the occlusion height, shadowed below it, linear over a band centred on it",
            )
            .num("point height", q.y)
            .num("band", band)
            .num("terrain visibility", v)
        });
        match &self.objects_map {
            Some(m) if v > 0.0 => {
                let shadowed = m.shadows(q);
                t.step(|| {
                    Step::new("objects", "the shadow map of the objects that are not terrain")
                        .flag("shadowed", shadowed)
                });
                if shadowed {
                    0.0
                } else {
                    v
                }
            }
            _ => v,
        }
    }

    /// The exact occlusion height of every location of the last run (ray casting against the
    /// terrain's triangles with the reference's BVH), for the error stage.
    fn exact(&self, p: &Pipeline, frame: &Frame, grid: &Grid) -> Vec<f32> {
        let tris: Vec<Tri> = frame
            .scene
            .objects
            .iter()
            .filter(|o| o.heightfield)
            .flat_map(|o| {
                o.mesh.indices.chunks_exact(3).map(|t| Tri {
                    v: [0, 1, 2].map(|k| o.mesh.positions[t[k] as usize]),
                    tag: 0,
                })
            })
            .collect();
        let bvh = Bvh::build(tris);
        let to_sun = -frame.light.direction;
        let n = grid.n as usize;
        let top = grid.hi.y + 1.0;
        let mut out = vec![f32::NAN; n * n];
        p.install(|| {
            out.par_chunks_mut(n).enumerate().for_each(|(j, row)| {
                for (i, o) in row.iter_mut().enumerate() {
                    let xz = grid.at(i as u32, j as u32);
                    // The surface: the first hit straight down.
                    let mut down = f32::INFINITY;
                    bvh.traverse(Vec3::new(xz.x, top, xz.y), -Vec3::Y, f32::INFINITY, |_, t| {
                        down = down.min(t);
                        false
                    });
                    if !down.is_finite() {
                        continue;
                    }
                    let lit = |y: f32| !bvh.occluded(Vec3::new(xz.x, y, xz.y), to_sun, f32::INFINITY);
                    let (mut lo, mut hi) = (top - down, top);
                    let eps = 1e-4 * (1.0 + top.abs());
                    if lit(lo + eps) {
                        *o = lo;
                        continue;
                    }
                    for _ in 0..32 {
                        let mid = 0.5 * (lo + hi);
                        if lit(mid) {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    *o = hi;
                }
            })
        });
        out
    }
}

/// The occlusion height at grid location `xz` of surface height `surface`: the march up in
/// steps of `step` from the surface while `sun` shadows the point (never past `top`, above
/// which nothing of the terrain is), then `iterations` halvings of the last step.
fn occlusion_height(sun: &SunMap, xz: Vec2, surface: f32, top: f32, step: f32, iterations: u32) -> Location {
    let at = |y: f32| Vec3::new(xz.x, y, xz.y);
    let mut loc = Location {
        surface,
        height: surface,
        marched: 1,
        searched: 0,
    };
    if !sun.shadows(at(surface)) {
        return loc;
    }
    // March up until the sun is visible.
    let mut k = 1u32;
    let mut y = surface + step;
    while y <= top && sun.shadows(at(y)) {
        k += 1;
        y = surface + k as f32 * step;
    }
    loc.marched = k;
    // Binary search between the last shadowed height and the first lit one.
    let (mut lo, mut hi) = (surface + (k - 1) as f32 * step, y);
    for _ in 0..iterations {
        let mid = 0.5 * (lo + hi);
        if sun.shadows(at(mid)) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    loc.searched = iterations;
    loc.height = hi;
    loc
}

impl ShadowTechnique for TerrainHeight {
    fn name(&self) -> &'static str {
        "terrain-height"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        let keep = Self::terrain(frame)?;
        if frame.light.kind != LightKind::Directional {
            return Err(Error::technique(format!(
                "terrain occlusion height needs a directional light (the sun), and the light of scene '{}' is {:?}",
                frame.scene.name, frame.light.kind
            )));
        }
        (self.grid, self.terrain_map, self.objects_map) = (None, None, None);
        self.locations = Vec::new();
        self.reserved = Reservation::default();
        // A sun at or below the horizon lights nothing.
        self.night = frame.light.direction.y >= 0.0;
        if !self.night {
            // The grid over the terrain's extent, its surface heights from above.
            let (lo, hi) = frame
                .scene
                .objects
                .iter()
                .filter(|o| o.heightfield)
                .filter_map(|o| o.mesh.bounds())
                .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
                .ok_or_else(|| Error::technique("the scene's heightfields have no vertices"))?;
            let margin = 0.01 * (hi - lo).max_element().max(1e-3);
            let grid = Grid {
                lo: lo - Vec3::Y * margin,
                hi: hi + Vec3::Y * margin,
                n: self.opts.grid,
            };
            // The locations, in the memory budget before any pass.
            let n = grid.n as u64;
            self.reserved = Reservation::new(grid.n, grid.n, n * n * std::mem::size_of::<Location>() as u64)
                .map_err(|e| Error::from(e).within(&format!("the occlusion heights (option grid={})", grid.n)))?;
            let surface = scene_depth(p, frame, grid.view(), grid.n, grid.n, |i| keep[i])?;
            passes.end("surface heights");
            // The sun's map of the terrain, fitted to the grid's box.
            let receivers = corners(grid.lo, grid.hi);
            let sun = SunMap::render(p, frame, &keep, &receivers, self.opts.size)?;
            passes.end("sun map");
            self.locations = self.build(p, &grid, &surface, &sun);
            passes.end("occlusion heights");
            if self.opts.objects {
                let others: Vec<bool> = keep.iter().map(|k| !k).collect();
                let (slo, shi) = frame.scene.bounds().unwrap_or((grid.lo, grid.hi));
                self.objects_map = Some(SunMap::render(p, frame, &others, &corners(slo, shi), self.opts.size)?);
                passes.end("objects map");
            }
            self.grid = Some(grid);
            self.terrain_map = Some(sun);
        }
        let this = &*self;
        let out = crate::shadow::pixels::per_pixel(p, frame, |x, y| {
            this.pixel(frame, x as u32, y as u32, &mut crate::shadow::inspect::NoTrace)
        });
        passes.end("lookup pass");
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        explain(|t| self.pixel(frame, x, y, t))
    }

    fn stages(&self, p: &Pipeline, frame: &Frame) -> Result<Vec<Stage>, Error> {
        let Some(grid) = &self.grid else {
            return Ok(Vec::new());
        };
        let n = grid.n;
        let (lo, hi) = (grid.lo.y, grid.hi.y);
        let scalar = |name: &str, data: Vec<f32>, lo: f32, hi: f32| -> Result<Stage, Error> {
            Ok(Stage::Scalar {
                name: name.into(),
                data: Surface::from_vec(n, n, data)?,
                lo,
                hi,
            })
        };
        let exact = self.exact(p, frame, grid);
        let error: Vec<f32> = self
            .locations
            .iter()
            .zip(&exact)
            .map(|(l, e)| (l.height.max(l.surface) - e).abs())
            .collect();
        let mut v = vec![
            scalar(
                "surface_height",
                self.locations.iter().map(|l| l.surface).collect(),
                lo,
                hi,
            )?,
            scalar(
                "occlusion_height",
                self.locations.iter().map(|l| l.height).collect(),
                lo,
                hi,
            )?,
            scalar(
                "occlusion_above_surface",
                self.locations.iter().map(|l| (l.height - l.surface).max(0.0)).collect(),
                0.0,
                hi - lo,
            )?,
            scalar("exact_occlusion_height", exact, lo, hi)?,
            scalar("occlusion_height_error", error, 0.0, self.opts.step)?,
        ];
        for (name, m) in [
            ("terrain_sun_map", &self.terrain_map),
            ("objects_sun_map", &self.objects_map),
        ] {
            if let Some(m) = m {
                v.push(Stage::unit(name, m.map().clone()));
            }
        }
        Ok(v)
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let shadowed = self.locations.iter().filter(|l| l.height > l.surface).count();
        let marched: u64 = self.locations.iter().map(|l| l.marched as u64).sum();
        let searched: u64 = self.locations.iter().map(|l| l.searched as u64).sum();
        vec![
            ("grid locations", self.locations.len() as f64),
            ("locations shadowed", shadowed as f64),
            ("march lookups", marched as f64),
            ("search lookups", searched as f64),
        ]
    }

    fn notes(&self) -> Vec<String> {
        if self.night {
            vec!["the sun is at or below the horizon: everything is shadowed".into()]
        } else {
            Vec::new()
        }
    }
}
