//! Random scenes, seeded and reproducible, for claims that must hold on scenes nobody picked:
//! a ground (a plane or a heightfield), 1 to 12 casters of every kind the scene format has
//! (boxes, spheres, cylinders, cones, pleated sheets, small heightfields), low-tessellated
//! ellipsoids (random convex polyhedra) and torus-knot tubes (closed, curved meshes that
//! shadow themselves, written as OBJ), with random transforms (thin and elongated casters,
//! casters on the ground, casters above the camera), mostly opaque materials (some
//! translucent and coloured, when asked), one light of a random kind (directional, spot,
//! point, disk, sphere, rectangle) and a camera that sees the ground.
//!
//! A scene is generated as the text of a scene file and the OBJ files it names
//! ([`RandomScene`]): [`RandomScene::scene`] parses them from memory, and `penumbra random`
//! writes them, so a failing case opens, renders and inspects like any fixture. The numbers
//! come from SplitMix64 (Steele et al. 2014) of the seed alone, so a seed is the same scene on
//! every machine.

use super::Scene;
use crate::Error;
use std::fmt::Write;
use std::path::Path;

/// What [`generate`] may put in a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// The camera's resolution.
    pub width: u32,
    /// The camera's resolution.
    pub height: u32,
    /// Fewest and most casters (1 to 12 by default).
    pub casters: (usize, usize),
    /// Translucent and coloured materials on some casters (off: every material is opaque).
    pub translucent: bool,
    /// The light kinds to draw from (`directional`, `spot`, `point`, `disk`, `sphere`,
    /// `rectangle`; all by default).
    pub lights: Vec<&'static str>,
}

/// Every light kind of the scene format.
pub const LIGHT_KINDS: [&str; 6] = ["directional", "spot", "point", "disk", "sphere", "rectangle"];

impl Default for Params {
    fn default() -> Self {
        Params {
            width: 160,
            height: 90,
            casters: (1, 12),
            translucent: true,
            lights: LIGHT_KINDS.to_vec(),
        }
    }
}

/// A generated scene: the scene file's text and the OBJ files (name, text) it names.
#[derive(Clone, Debug, PartialEq)]
pub struct RandomScene {
    /// The seed it came from.
    pub seed: u64,
    /// The scene file (TOML).
    pub text: String,
    /// The OBJ files the scene names, beside it.
    pub meshes: Vec<(String, String)>,
}

impl RandomScene {
    /// The scene file's name: `random_<seed>.toml`.
    pub fn file_name(&self) -> String {
        format!("random_{}.toml", self.seed)
    }

    /// The scene, parsed from the text and the OBJ files in memory.
    pub fn scene(&self) -> Result<Scene, Error> {
        super::file::parse_with_files(&self.text, Path::new(&self.file_name()), &self.meshes)
    }

    /// Writes the scene file and its OBJ files into `dir`; returns the scene file's path.
    pub fn write(&self, dir: &Path) -> Result<std::path::PathBuf, Error> {
        crate::output::create_folder(dir)?;
        for (name, text) in &self.meshes {
            crate::output::write_plain(&dir.join(name), text.as_bytes())?;
        }
        let p = dir.join(self.file_name());
        crate::output::write_plain(&p, self.text.as_bytes())?;
        Ok(p)
    }
}

/// The scene of `seed` ([`generate`], parsed).
pub fn random(seed: u64, params: &Params) -> Result<Scene, Error> {
    generate(seed, params).scene()
}

/// SplitMix64: the generator's only source of numbers.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi), rounded to 3 decimals (the scene file's numbers read back exactly
    /// as written).
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next() >> 40) as f32 / (1u64 << 24) as f32;
        ((lo + (hi - lo) * u) * 1000.0).round() / 1000.0
    }

    /// Uniform in lo..=hi.
    fn int(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next() % (hi - lo + 1) as u64) as usize
    }

    /// True with probability `p`.
    fn chance(&mut self, p: f32) -> bool {
        self.range(0.0, 1.0) < p
    }

    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.int(0, v.len() - 1)]
    }
}

fn v3(v: [f32; 3]) -> String {
    format!("[{}, {}, {}]", v[0], v[1], v[2])
}

/// A point at `dist` from the origin, `elev` degrees above the ground, `az` degrees around.
fn spherical(dist: f32, elev: f32, az: f32) -> [f32; 3] {
    let (e, a) = (elev.to_radians(), az.to_radians());
    let r = |x: f32| (x * 1000.0).round() / 1000.0;
    [
        r(dist * crate::math::cos(e) * crate::math::cos(a)),
        r(dist * crate::math::sin(e)),
        r(dist * crate::math::cos(e) * crate::math::sin(a)),
    ]
}

/// Generates the scene of `seed` under `params`.
pub fn generate(seed: u64, params: &Params) -> RandomScene {
    let mut g = Rng(seed ^ 0x5eed_0f5c_e7e5);
    let mut t = String::new();
    let mut meshes = Vec::new();
    let _ = writeln!(t, "# Random scene of seed {seed}.");

    // Camera: it looks down at the ground from 10 to 18 units away.
    let eye = spherical(g.range(10.0, 18.0), g.range(15.0, 60.0), g.range(0.0, 360.0));
    let target = [g.range(-2.0, 2.0), 0.0, g.range(-2.0, 2.0)];
    let _ = writeln!(
        t,
        "[camera]\nposition = {}\ntarget = {}\nfov = {}\nresolution = [{}, {}]\n",
        v3(eye),
        v3(target),
        g.range(40.0, 60.0),
        params.width,
        params.height
    );

    // Light.
    light(&mut g, &mut t, params);
    t.push('\n');

    // Materials: grey ground, a few opaque colours, and translucent ones when asked.
    let _ = writeln!(t, "[[material]]\nname = \"ground\"\nalbedo = [0.6, 0.6, 0.55]\n");
    let _ = writeln!(t, "[[material]]\nname = \"opaque\"\nalbedo = [0.7, 0.5, 0.4]\n");
    if params.translucent {
        let _ = writeln!(
            t,
            "[[material]]\nname = \"veil\"\nalbedo = [0.9, 0.9, 0.9]\nopacity = {}\ntwo_sided = true\n",
            g.range(0.2, 0.8)
        );
        let _ = writeln!(
            t,
            "[[material]]\nname = \"glass\"\nalbedo = [0.9, 0.9, 0.9]\nopacity = {}\ntransmittance = {}\n",
            g.range(0.3, 0.7),
            v3([g.range(0.1, 0.9), g.range(0.1, 0.9), g.range(0.1, 0.9)])
        );
    }

    // Ground.
    if g.chance(0.35) {
        let _ = writeln!(
            t,
            "[[object]]\nname = \"ground\"\nmesh = \"heightfield\"\nsize = [24, 24]\nsubdivisions = {}\namplitude = {}\nseed = {}\nmaterial = \"ground\"\n",
            g.int(24, 64),
            g.range(0.2, 1.5),
            g.int(1, 1000)
        );
    } else {
        let _ = writeln!(
            t,
            "[[object]]\nname = \"ground\"\nmesh = \"plane\"\nsize = 24\nmaterial = \"ground\"\n"
        );
    }

    // Casters.
    let (lo, hi) = params.casters;
    let n = g.int(lo.max(1), hi.max(lo.max(1)));
    for k in 0..n {
        let kind = *g.pick(&[
            "box",
            "sphere",
            "cylinder",
            "cone",
            "pleated",
            "heightfield",
            "hull",
            "knot",
        ]);
        let _ = writeln!(t, "[[object]]\nname = \"c{k}_{kind}\"");
        // Its half height, for resting it on the ground.
        let half = caster_shape(&mut g, &mut t, kind, (seed, k), &mut meshes);
        let (x, z) = (g.range(-6.0, 6.0), g.range(-6.0, 6.0));
        let y = if g.chance(0.05) {
            eye[1] + g.range(0.5, 2.0) // above the camera
        } else if g.chance(0.4) {
            half // on the ground
        } else {
            half + g.range(0.2, 3.0)
        };
        let _ = writeln!(t, "translate = {}", v3([x, y, z]));
        if g.chance(0.6) {
            let _ = writeln!(
                t,
                "rotate = {}",
                v3([g.range(0.0, 360.0), g.range(0.0, 360.0), g.range(0.0, 360.0)])
            );
        } else {
            let _ = writeln!(t, "rotate = [0, {}, 0]", g.range(0.0, 360.0));
        }
        let material = if params.translucent && g.chance(0.2) {
            *g.pick(&["veil", "glass"])
        } else {
            "opaque"
        };
        let _ = writeln!(t, "material = \"{material}\"\n");
    }
    RandomScene { seed, text: t, meshes }
}

/// The scene's `[[light]]`: a kind from `params`, placed high over the scene.
fn light(g: &mut Rng, t: &mut String, params: &Params) {
    let kind = *g.pick(&params.lights);
    let _ = writeln!(t, "[[light]]\ntype = \"{kind}\"");
    let high = spherical(g.range(9.0, 14.0), g.range(35.0, 80.0), g.range(0.0, 360.0));
    match kind {
        "directional" => {
            let d = spherical(1.0, g.range(20.0, 80.0), g.range(0.0, 360.0));
            let _ = writeln!(t, "direction = {}", v3(d.map(|x| -x)));
        }
        "point" | "sphere" => {
            let _ = writeln!(t, "position = {}", v3(high));
            if kind == "sphere" {
                let _ = writeln!(t, "radius = {}", g.range(0.1, 1.0));
            }
        }
        _ => {
            let _ = writeln!(t, "position = {}\ntarget = [0, 0, 0]", v3(high));
            match kind {
                "spot" => {
                    let _ = writeln!(t, "angle = {}", g.range(50.0, 100.0));
                }
                "disk" => {
                    let _ = writeln!(t, "radius = {}", g.range(0.1, 1.0));
                }
                _ => {
                    let _ = writeln!(t, "size = [{}, {}]", g.range(0.2, 1.5), g.range(0.2, 1.5));
                }
            }
        }
    }
}

/// Caster number `k` of the scene of `seed` as a `kind` mesh (its keys written into `t`, an
/// OBJ file into `meshes` for a knot); returns its half height, for resting it on the ground.
fn caster_shape(
    g: &mut Rng,
    t: &mut String,
    kind: &str,
    (seed, k): (u64, usize),
    meshes: &mut Vec<(String, String)>,
) -> f32 {
    match kind {
        "box" => {
            let mut s = [g.range(0.3, 2.0), g.range(0.3, 2.0), g.range(0.3, 2.0)];
            if g.chance(0.2) {
                let i = g.int(0, 2);
                s[i] = g.range(0.02, 0.06); // thin
            } else if g.chance(0.15) {
                let i = g.int(0, 2);
                s[i] = g.range(3.0, 6.0); // elongated
            }
            let _ = writeln!(t, "mesh = \"box\"\nsize = {}", v3(s));
            s[1] / 2.0
        }
        "sphere" => {
            let r = g.range(0.2, 1.2);
            let _ = writeln!(t, "mesh = \"sphere\"\nradius = {r}\nstacks = 12\nslices = 24");
            r
        }
        "cylinder" | "cone" => {
            let (r, h) = (g.range(0.05, 0.8), g.range(0.5, 4.0));
            let _ = writeln!(t, "mesh = \"{kind}\"\nradius = {r}\nheight = {h}\nsegments = 24");
            h / 2.0
        }
        "pleated" | "heightfield" => {
            // Both a sheet over `size`: pleats of an amplitude, or a seeded noise surface.
            let pleated = kind == "pleated";
            let size = [g.range(1.0, if pleated { 4.0 } else { 3.0 }), g.range(1.0, 3.0)];
            let amplitude = if pleated { g.range(0.05, 0.4) } else { g.range(0.1, 0.6) };
            let (detail, last) = if pleated {
                ("", format!("pleats = {}", g.int(2, 8)))
            } else {
                ("\nsubdivisions = 16", format!("seed = {}", g.int(1, 1000)))
            };
            let _ = writeln!(
                t,
                "mesh = \"{kind}\"\nsize = [{}, {}]{detail}\namplitude = {amplitude}\n{last}",
                size[0], size[1]
            );
            0.5
        }
        "hull" => {
            // A low-tessellated ellipsoid: a random convex polyhedron.
            let _ = writeln!(
                t,
                "mesh = \"sphere\"\nradius = 1\nstacks = {}\nslices = {}\nscale = {}",
                g.int(3, 7),
                g.int(4, 9),
                v3([g.range(0.2, 1.2), g.range(0.2, 1.2), g.range(0.2, 1.2)])
            );
            0.6
        }
        _ => {
            let name = format!("random_{seed}_knot{k}.obj");
            let (p, q) = *g.pick(&[(2, 3), (3, 2), (2, 5), (3, 4)]);
            let tube = g.range(0.12, 0.3);
            meshes.push((name.clone(), torus_knot(p, q, tube, 96, 8)));
            let _ = writeln!(t, "mesh = \"{name}\"\nscale = {}", g.range(0.3, 0.6));
            0.8
        }
    }
}

/// A closed tube of radius `tube` around the (p, q) torus knot (major radius 2, minor 1):
/// `rings` rings of `sides` vertices along the curve, each ring in the plane normal to the
/// curve, framed by parallel transport (rotated at the end so that the tube closes without a
/// twist). OBJ text with outward faces.
fn torus_knot(p: u32, q: u32, tube: f32, rings: usize, sides: usize) -> String {
    use glam::Vec3;
    use std::f32::consts::TAU;
    let curve = |t: f32| {
        let r = 2.0 + crate::math::cos(q as f32 * t);
        Vec3::new(
            r * crate::math::cos(p as f32 * t),
            crate::math::sin(q as f32 * t),
            r * crate::math::sin(p as f32 * t),
        )
    };
    let pts: Vec<Vec3> = (0..rings).map(|i| curve(TAU * i as f32 / rings as f32)).collect();
    let tangent = |i: usize| (pts[(i + 1) % rings] - pts[(i + rings - 1) % rings]).normalize();
    // Parallel transport of a normal along the ring centres.
    let mut normals = Vec::with_capacity(rings);
    let t0 = tangent(0);
    let seed = if t0.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let mut n = (seed - t0 * seed.dot(t0)).normalize();
    for i in 0..rings {
        let t = tangent(i);
        n = (n - t * n.dot(t)).normalize();
        normals.push(n);
    }
    // The twist left at the end, spread over the rings.
    let (t0, nl) = (tangent(0), normals[rings - 1]);
    let back = (nl - t0 * nl.dot(t0)).normalize();
    let twist = libm::atan2f(t0.cross(normals[0]).dot(back), normals[0].dot(back));
    let mut out = String::from("# torus knot tube\n");
    for i in 0..rings {
        let t = tangent(i);
        let a = -twist * i as f32 / rings as f32;
        let (n0, b0) = (normals[i], t.cross(normals[i]));
        let (n, b) = (
            n0 * crate::math::cos(a) + b0 * crate::math::sin(a),
            b0 * crate::math::cos(a) - n0 * crate::math::sin(a),
        );
        for j in 0..sides {
            let phi = TAU * j as f32 / sides as f32;
            let v = pts[i] + (n * crate::math::cos(phi) + b * crate::math::sin(phi)) * tube;
            let _ = writeln!(out, "v {} {} {}", v.x, v.y, v.z);
        }
    }
    for i in 0..rings {
        let i2 = (i + 1) % rings;
        for j in 0..sides {
            let j2 = (j + 1) % sides;
            let (a, b, c, d) = (
                i * sides + j + 1,
                i2 * sides + j + 1,
                i2 * sides + j2 + 1,
                i * sides + j2 + 1,
            );
            let _ = writeln!(out, "f {a} {d} {c}\nf {a} {c} {b}");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_give_the_same_scene_and_every_scene_parses() {
        let p = Params::default();
        assert_eq!(generate(7, &p), generate(7, &p));
        assert_ne!(generate(7, &p).text, generate(8, &p).text);
        for seed in 0..64 {
            let r = generate(seed, &p);
            let s = r.scene().unwrap_or_else(|e| panic!("seed {seed}: {e}\n{}", r.text));
            assert!(s.objects.len() >= 2 && s.lights.len() == 1, "seed {seed}");
        }
    }

    /// The knot's tube is closed (every edge in exactly two faces, in opposite directions)
    /// and its faces point outward (positive volume).
    #[test]
    fn the_knot_tube_is_closed_and_outward() {
        let text = torus_knot(2, 3, 0.2, 96, 8);
        let m = crate::scene::mesh::obj_from_bytes(text.as_bytes(), Path::new("k.obj")).unwrap();
        let mut edges = std::collections::HashMap::new();
        for t in m.indices.chunks_exact(3) {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        assert!(edges
            .iter()
            .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1)));
        let volume: f32 = m
            .indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!(volume > 0.0, "{volume}");
    }
}
