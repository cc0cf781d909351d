//! Procedural meshes (plane, box, sphere, cylinder, heightfield, pleated sheet) and OBJ loading
//! (tobj). All are centred on the origin (the box and sphere around it, the plane, heightfield
//! and pleated sheet around y = 0, the cylinder from y = 0 to its height) with outward, counter-clockwise faces.

use super::Mesh;
use crate::math;
#[cfg(feature = "files")]
use crate::Error;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};
#[cfg(feature = "files")]
use std::path::Path;

/// A plane in y = 0 of `size` (x, z), facing +y, split into `n` x `n` quads.
pub fn plane(size: Vec2, n: u32) -> Mesh {
    let n = n.max(1);
    let mut m = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let x = (i as f32 / n as f32 - 0.5) * size.x;
            let z = (j as f32 / n as f32 - 0.5) * size.y;
            m.positions.push(Vec3::new(x, 0.0, z));
            m.normals.push(Vec3::Y);
        }
    }
    grid_indices(&mut m, n, n);
    m
}

/// Indices of an `nx` x `nz` grid of quads whose rows run along +x and step along +z, facing +y.
fn grid_indices(m: &mut Mesh, nx: u32, nz: u32) {
    let row = nx + 1;
    for j in 0..nz {
        for i in 0..nx {
            let a = j * row + i;
            let (b, c, d) = (a + 1, a + row, a + row + 1);
            // Counter-clockwise seen from +y.
            m.indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
}

/// An axis-aligned box of `size`, centred on the origin (24 vertices, flat normals).
pub fn cuboid(size: Vec3) -> Mesh {
    let h = size * 0.5;
    let mut m = Mesh::default();
    let faces = [
        (Vec3::X, Vec3::Z, Vec3::Y),
        (-Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::Y, Vec3::X, Vec3::Z),
        (-Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::Z, Vec3::Y, Vec3::X),
        (-Vec3::Z, Vec3::X, Vec3::Y),
    ];
    for (n, u, v) in faces {
        // u x v = n, so (0, u, u+v, v) is counter-clockwise seen from outside.
        let u = if u.cross(v).dot(n) > 0.0 { u } else { -u };
        let b = m.positions.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push((n + u * su + v * sv) * h);
            m.normals.push(n);
        }
        m.indices.extend_from_slice(&[b, b + 1, b + 2, b, b + 2, b + 3]);
    }
    m
}

/// `(cos, sin)` of the `k`-th of `n` equal steps around a circle, with the last step bitwise
/// equal to the first, so seams weld and meshes close (shadow volumes need that).
fn circle(k: u32, n: u32) -> (f32, f32) {
    let a = TAU * (k % n) as f32 / n as f32;
    (math::cos(a), math::sin(a))
}

/// The unit-sphere point of ring `s` of `stacks` (0: north pole) and segment `k` of `slices`
/// of a UV sphere. The seam (`k = slices`) and the poles give bitwise equal positions for all
/// their copies, so the mesh welds closed (sin(pi) is not 0 in floating point).
pub fn sphere_point(s: u32, stacks: u32, k: u32, slices: u32) -> Vec3 {
    let theta = PI * s as f32 / (stacks - 1) as f32;
    let (st, ct) = match s {
        0 => (0.0, 1.0),
        _ if s == stacks - 1 => (0.0, -1.0),
        _ => (math::sin(theta), math::cos(theta)),
    };
    let (c, sn) = circle(k, slices);
    Vec3::new(st * c, ct, -st * sn)
}

/// A UV sphere of `radius` with `stacks` rings of vertices (poles included) and `slices` segments.
/// The seam and the poles repeat vertices at bitwise equal positions (the mesh is closed).
pub fn sphere(radius: f32, stacks: u32, slices: u32) -> Mesh {
    let (stacks, slices) = (stacks.max(3), slices.max(3));
    let mut m = Mesh::default();
    for s in 0..stacks {
        for k in 0..=slices {
            let n = sphere_point(s, stacks, k, slices);
            m.positions.push(n * radius);
            m.normals.push(n);
        }
    }
    let row = slices + 1;
    for s in 0..stacks - 1 {
        for k in 0..slices {
            let a = s * row + k;
            let b = a + row;
            if s > 0 {
                m.indices.extend_from_slice(&[a, b, a + 1]);
            }
            if s < stacks - 2 {
                m.indices.extend_from_slice(&[a + 1, b, b + 1]);
            }
        }
    }
    m
}

/// A closed cylinder of `radius` from y = 0 to y = `height` with `segments` sides.
pub fn cylinder(radius: f32, height: f32, segments: u32) -> Mesh {
    let n = segments.max(3);
    let mut m = Mesh::default();
    for k in 0..=n {
        let (c, sn) = circle(k, n);
        let d = Vec3::new(c, 0.0, -sn);
        m.positions.push(d * radius);
        m.normals.push(d);
        m.positions.push(d * radius + Vec3::Y * height);
        m.normals.push(d);
    }
    for k in 0..n {
        let (a, b) = (2 * k, 2 * k + 2);
        m.indices.extend_from_slice(&[a, b, a + 1, a + 1, b, b + 1]);
    }
    for (y, normal) in [(0.0, -Vec3::Y), (height, Vec3::Y)] {
        let c = m.positions.len() as u32;
        m.positions.push(Vec3::Y * y);
        m.normals.push(normal);
        for k in 0..=n {
            let (c, sn) = circle(k, n);
            m.positions.push(Vec3::new(c * radius, y, -sn * radius));
            m.normals.push(normal);
        }
        for k in 0..n {
            let (p, q) = (c + 1 + k, c + 2 + k);
            if normal.y > 0.0 {
                m.indices.extend_from_slice(&[c, p, q]);
            } else {
                m.indices.extend_from_slice(&[c, q, p]);
            }
        }
    }
    m
}

/// A closed cone of base `radius` from y = 0 to its apex at y = `height` with `segments`
/// sides (a tree's crown in the `forest_floor` fixture); side normals are the surface's.
pub fn cone(radius: f32, height: f32, segments: u32) -> Mesh {
    let n = segments.max(3);
    let mut m = Mesh::default();
    // The side: one triangle per segment, the apex repeated with each segment's normal.
    let slope = Vec3::new(height, radius, height);
    for k in 0..n {
        let (c0, s0) = circle(k, n);
        let (c1, s1) = circle(k + 1, n);
        let (cm, sm) = circle(2 * k + 1, 2 * n);
        let b = m.positions.len() as u32;
        m.positions.extend_from_slice(&[
            Vec3::new(c0 * radius, 0.0, -s0 * radius),
            Vec3::new(c1 * radius, 0.0, -s1 * radius),
            Vec3::Y * height,
        ]);
        for (c, sn) in [(c0, s0), (c1, s1), (cm, sm)] {
            m.normals.push((Vec3::new(c, 1.0, -sn) * slope).normalize());
        }
        m.indices.extend_from_slice(&[b, b + 1, b + 2]);
    }
    // The base.
    let c = m.positions.len() as u32;
    m.positions.push(Vec3::ZERO);
    m.normals.push(-Vec3::Y);
    for k in 0..=n {
        let (co, sn) = circle(k, n);
        m.positions.push(Vec3::new(co * radius, 0.0, -sn * radius));
        m.normals.push(-Vec3::Y);
    }
    for k in 0..n {
        m.indices.extend_from_slice(&[c, c + 2 + k, c + 1 + k]);
    }
    m
}

/// A heightfield over `size` (x, z) in `n` x `n` quads: a sum of seeded sine waves of peak
/// amplitude `amplitude` (deterministic for a seed), normals from central differences.
pub fn heightfield(size: Vec2, n: u32, amplitude: f32, seed: u64) -> Mesh {
    let n = n.max(1);
    let mut rng = crate::hash::SplitMix(seed);
    let waves: Vec<(Vec2, f32, f32)> = (0..6)
        .map(|i| {
            let a = rng.next_f32() * TAU;
            let f = (1.0 + i as f32) * (0.6 + rng.next_f32()) * TAU / size.max_element();
            (
                Vec2::new(math::cos(a), math::sin(a)) * f,
                rng.next_f32() * TAU,
                1.0 / (1.0 + i as f32),
            )
        })
        .collect();
    let norm: f32 = waves.iter().map(|w| w.2).sum();
    let h = |x: f32, z: f32| {
        amplitude / norm
            * waves
                .iter()
                .map(|(k, ph, w)| w * math::sin(k.x * x + k.y * z + ph))
                .sum::<f32>()
    };
    let mut m = plane(size, n);
    let e = size.max_element() / n as f32 * 0.5;
    for (p, nrm) in m.positions.iter_mut().zip(m.normals.iter_mut()) {
        p.y = h(p.x, p.z);
        *nrm = Vec3::new(
            h(p.x - e, p.z) - h(p.x + e, p.z),
            2.0 * e,
            h(p.x, p.z - e) - h(p.x, p.z + e),
        )
        .normalize();
    }
    m
}

/// A pleated sheet: the plane of `size` (x, z) folded along x into `pleats` sine waves of
/// height `amplitude`, `y = amplitude sin(2 pi pleats (x / size.x + 1/2))`, with `n` quads
/// along x and `n / 4` (at least 1) along z; normals are the surface's exact ones.
pub fn pleated(size: Vec2, n: u32, amplitude: f32, pleats: u32) -> Mesh {
    let (nx, nz) = (n.max(1), (n / 4).max(1));
    let k = TAU * pleats as f32 / size.x;
    let mut m = Mesh::default();
    for j in 0..=nz {
        for i in 0..=nx {
            let x = (i as f32 / nx as f32 - 0.5) * size.x;
            let z = (j as f32 / nz as f32 - 0.5) * size.y;
            let phase = k * (x + 0.5 * size.x);
            m.positions.push(Vec3::new(x, amplitude * math::sin(phase), z));
            m.normals
                .push(Vec3::new(-amplitude * k * math::cos(phase), 1.0, 0.0).normalize());
        }
    }
    grid_indices(&mut m, nx, nz);
    m
}

/// Largest OBJ file read (bytes).
#[cfg(feature = "files")]
pub const MAX_OBJ_BYTES: u64 = 1 << 30;

/// Checks an OBJ's element lines before parsing, so that errors carry line numbers: every
/// vertex (`v`) and normal (`vn`) is finite (a normal also non-zero), used or not; every
/// face (`f`) has three or more vertices whose position indices are integers naming a vertex
/// defined so far (1-based, or negative: relative). Points and polylines (`p`, `l`) have no
/// area: they are dropped (and counted). Returns the text to parse and the dropped count.
#[cfg(feature = "files")]
fn check_obj(text: &str, path: &Path) -> Result<(String, usize), Error> {
    let mut out = String::with_capacity(text.len());
    let (mut vertices, mut dropped) = (0i64, 0usize);
    for (i, line) in text.lines().enumerate() {
        let at = |msg: String| Error::Scene {
            file: path.into(),
            line: Some(i + 1),
            section: None,
            field: None,
            message: msg,
        };
        let mut words = line.split_whitespace();
        match words.next() {
            Some(kw @ ("v" | "vn")) => {
                let nums: Vec<&str> = words.collect();
                if nums.len() < 3 {
                    return Err(at(format!("`{kw}` needs 3 numbers, this line has {}", nums.len())));
                }
                if let Some(bad) = nums.iter().take(3).find(|w| w.parse::<f32>().is_err()) {
                    return Err(at(format!("`{kw}`: `{bad}` is not a number")));
                }
                // Every vertex and normal, used by a face or not: NaN and infinity never pass
                // (nor a zero normal, which has no direction).
                if let Some(bad) = nums
                    .iter()
                    .take(3)
                    .find(|w| !w.parse::<f32>().is_ok_and(f32::is_finite))
                {
                    return Err(at(format!("`{kw}`: `{bad}` is not finite")));
                }
                if kw == "vn" && nums.iter().take(3).all(|w| w.parse::<f32>() == Ok(0.0)) {
                    return Err(at("`vn 0 0 0`: a normal of length zero has no direction".into()));
                }
                if kw == "v" {
                    vertices += 1;
                }
            }
            Some("l" | "p") => {
                dropped += 1;
                continue;
            }
            Some("f") => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return Err(at(format!(
                        "a face needs 3 or more vertices, this one has {} (`{}`)",
                        refs.len(),
                        line.trim()
                    )));
                }
                for r in refs {
                    let first = r.split('/').next().unwrap_or("");
                    let k: i64 = first
                        .parse()
                        .map_err(|_| at(format!("face vertex `{r}`: `{first}` is not a vertex number")))?;
                    let ok = if k > 0 { k <= vertices } else { k < 0 && -k <= vertices };
                    if !ok {
                        return Err(at(format!(
                            "face vertex `{r}` names vertex {k}, but {vertices} are defined before this line"
                        )));
                    }
                }
            }
            _ => {}
        }
        out.push_str(line);
        out.push('\n');
    }
    Ok((out, dropped))
}

/// Loads an OBJ file (all its models, triangulated). Missing normals are generated from the
/// faces (area-weighted). The file must be a regular file of at most [`MAX_OBJ_BYTES`]; bytes
/// that are not UTF-8 (in comments, say) are replaced; faces are checked line by line
/// (with line numbers). Errors name the path, and the line where there is one.
#[cfg(feature = "files")]
pub fn load_obj(path: &Path) -> Result<Mesh, Error> {
    let bytes = super::read::read_regular(path, "OBJ file", MAX_OBJ_BYTES)?;
    obj_from_bytes(&bytes, path)
}

/// [`load_obj`] of an OBJ file's bytes already in memory; `path` names it in errors.
#[cfg(feature = "files")]
pub fn obj_from_bytes(bytes: &[u8], path: &Path) -> Result<Mesh, Error> {
    let text = String::from_utf8_lossy(bytes);
    let (text, _dropped) = check_obj(&text, path)?;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // Materials (`mtllib`) are not read: a scene file gives materials.
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(text.as_bytes()), &opts, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| Error::scene(path, format!("cannot parse OBJ: {e}")))?;
    let mut out = Mesh::default();
    for model in models {
        let mm = &model.mesh;
        let positions: Vec<Vec3> = mm
            .positions
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(Error::scene(
                path,
                format!(
                    "model {} has a non-finite vertex position",
                    crate::error::quoted(&model.name)
                ),
            ));
        }
        if let Some(&bad) = mm.indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(Error::scene(
                path,
                format!(
                    "model {} has face index {bad} beyond its {} vertices",
                    crate::error::quoted(&model.name),
                    positions.len()
                ),
            ));
        }
        let normals = if mm.normals.len() == mm.positions.len() {
            mm.normals
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero())
                .collect()
        } else {
            face_normals(&positions, &mm.indices)
        };
        out.append(&Mesh {
            positions,
            normals,
            indices: mm.indices.clone(),
        });
    }
    if out.indices.is_empty() {
        return Err(Error::scene(path, "no triangles in the file (no `f` lines)"));
    }
    Ok(out)
}

/// Area-weighted vertex normals from faces.
pub fn face_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let (a, b, c) = (
            positions[t[0] as usize],
            positions[t[1] as usize],
            positions[t[2] as usize],
        );
        let f = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += f;
        }
    }
    n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume by the divergence theorem: positive and equal to the analytic volume when
    /// every face is outward and counter-clockwise.
    fn volume(m: &Mesh) -> f32 {
        m.indices
            .chunks_exact(3)
            .map(|t| m.positions[t[0] as usize].dot(m.positions[t[1] as usize].cross(m.positions[t[2] as usize])) / 6.0)
            .sum()
    }

    #[test]
    fn closed_meshes_are_outward_and_have_their_volume() {
        assert!((volume(&cuboid(Vec3::new(1.0, 2.0, 3.0))) - 6.0).abs() < 1e-4);
        let s = volume(&sphere(1.0, 40, 80));
        assert!((s - 4.0 / 3.0 * PI).abs() < 0.02, "{s}");
        let c = volume(&cylinder(1.0, 2.0, 96));
        assert!((c - 2.0 * PI).abs() < 0.01, "{c}");
        // A cone: a third of its cylinder, and vertex normals on the faces' side.
        let m = cone(1.0, 2.0, 96);
        let k = volume(&m);
        assert!((k - 2.0 * PI / 3.0).abs() < 0.01, "{k}");
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            let f = (b - a).cross(c - a);
            assert!(t.iter().all(|&i| m.normals[i as usize].dot(f) > 0.0));
        }
    }

    #[test]
    fn plane_faces_up() {
        let p = plane(Vec2::new(2.0, 2.0), 2);
        for t in p.indices.chunks_exact(3) {
            let (a, b, c) = (
                p.positions[t[0] as usize],
                p.positions[t[1] as usize],
                p.positions[t[2] as usize],
            );
            assert!((b - a).cross(c - a).y > 0.0);
        }
        let h = heightfield(Vec2::splat(10.0), 16, 1.0, 3);
        assert!(h.positions.iter().all(|p| p.y.abs() <= 1.0 + 1e-5));
        assert!(h.normals.iter().all(|n| n.y > 0.0));
    }
}
