//! Helpers shared by the integration tests that run the CLI (each test binary uses some).
#![allow(dead_code)]

use std::process::Command;

/// Runs the CLI; returns (success, stdout + stderr). A panic is a test failure whatever the
/// exit status.
pub fn cli(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!text.contains("panicked"), "the CLI panicked on {args:?}:\n{text}");
    (out.status.success(), text)
}

/// Writes `body` to `name` in this test process's folder `tag` under the temp dir; returns
/// its path.
pub fn temp_file(tag: &str, name: &str, body: &str) -> String {
    let dir = std::env::temp_dir().join(format!("penumbra-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_string_lossy().into_owned()
}

/// A small glTF 2.0 file: a ground quad under a floating, half-transparent triangle (placed
/// by a parent node's translation and a child's scale), a camera and a sun.
pub fn gltf_text(indices: &[u16], mode: u32) -> String {
    let (json, bytes) = gltf_parts(indices, mode);
    let uri = format!(r#""uri": "data:application/octet-stream;base64,{}""#, base64(&bytes));
    json.replacen(
        r#""byteLength": BUFFER"#,
        &format!(r#""byteLength": {}, {uri}"#, bytes.len()),
        1,
    )
}

/// The same scene as a binary glTF: the JSON with its buffer in the GLB's BIN chunk.
pub fn glb_file(indices: &[u16], mode: u32) -> Vec<u8> {
    let (json, bytes) = glb_parts(indices, mode);
    glb(json.as_bytes(), &bytes)
}

/// The JSON and the BIN chunk of [`glb_file`] before they are put in the container.
pub fn glb_parts(indices: &[u16], mode: u32) -> (String, Vec<u8>) {
    let (json, bytes) = gltf_parts(indices, mode);
    let json = json.replacen(
        r#""byteLength": BUFFER"#,
        &format!(r#""byteLength": {}"#, bytes.len()),
        1,
    );
    (json, bytes)
}

/// A GLB container (version 2) around a JSON chunk and a BIN chunk, each padded to 4 bytes.
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |b: &[u8], with: u8| {
        let mut v = b.to_vec();
        while !v.len().is_multiple_of(4) {
            v.push(with);
        }
        v
    };
    let (json, bin) = (pad(json, b' '), pad(bin, 0));
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// The JSON of `gltf_text` with its one buffer's `"byteLength": BUFFER` left to fill in, and
/// the buffer's bytes.
pub fn gltf_parts(indices: &[u16], mode: u32) -> (String, Vec<u8>) {
    let positions: [[f32; 3]; 7] = [
        [-2.0, 0.0, -2.0],
        [2.0, 0.0, -2.0],
        [2.0, 0.0, 2.0],
        [-2.0, 0.0, 2.0],
        [-0.5, 0.0, -0.5],
        [0.5, 0.0, -0.5],
        [0.0, 0.0, 0.5],
    ];
    let mut bytes: Vec<u8> = positions.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
    let index_offset = bytes.len();
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    while !bytes.len().is_multiple_of(4) {
        bytes.push(0);
    }
    let n = indices.len();
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [{{"type": "directional"}}]}}}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 2, 3]}}],
  "nodes": [
    {{"name": "lift", "translation": [0, 1, 0], "children": [1]}},
    {{"name": "leaf", "mesh": 1, "scale": [2, 1, 2]}},
    {{"name": "ground", "mesh": 0}},
    {{"name": "rig", "children": [4, 5]}},
    {{"name": "cam", "camera": 0, "translation": [0, 3, 6], "rotation": [-0.2297529, 0, 0, 0.9732489]}},
    {{"name": "sun", "rotation": [-0.7071068, 0, 0, 0.7071068], "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.8, "znear": 0.1, "zfar": 50, "aspectRatio": 1.3333334}}}}],
  "materials": [
    {{"name": "floor", "pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.6, 0.7, 1]}}}},
    {{"name": "veil", "alphaMode": "BLEND", "doubleSided": true, "pbrMetallicRoughness": {{"baseColorFactor": [1, 1, 1, 0.25]}}}}
  ],
  "meshes": [
    {{"name": "quad", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0, "mode": {mode}}}]}},
    {{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 2}}, "material": 1}}]}}
  ],
  "buffers": [{{"byteLength": BUFFER}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 84}},
    {{"buffer": 0, "byteOffset": {index_offset}, "byteLength": {ilen}}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-2, 0, -2], "max": [2, 0, 2]}},
    {{"bufferView": 1, "componentType": 5123, "count": {n}, "type": "SCALAR"}},
    {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 3, "type": "VEC3", "min": [-0.5, 0, -0.5], "max": [0.5, 0, 0.5]}}
  ]
}}"#,
        ilen = n * 2,
    );
    (json, bytes)
}

pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let v = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(v >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// `key=value` pairs as the technique constructors take them.
pub fn owned(sets: &[(&str, &str)]) -> Vec<(String, String)> {
    sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
}

/// `technique` with `sets` on fixture `scene` against its reference (every path frame), on 2
/// threads.
pub fn fixture_result(scene: &str, technique: &str, sets: &[(&str, &str)]) -> penumbra::run::RunResult {
    let p = penumbra::pipeline::Pipeline::new(2).unwrap();
    let path = format!("fixtures/scenes/{scene}.toml");
    let s = penumbra::scene::file::load(std::path::Path::new(&path)).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    penumbra::run::render(&p, &s, &text, technique, &owned(sets), 0, None)
        .unwrap()
        .result
}

/// A window-space triangle of the raster tests (fixed point, 1/256 pixel).
pub type WinTri = [(i64, i64); 3];

/// Exact orientation of (b - a) x (c - a), in i128.
pub fn orient(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> i128 {
    (b.0 - a.0) as i128 * (c.1 - a.1) as i128 - (b.1 - a.1) as i128 * (c.0 - a.0) as i128
}

/// A grid of `nx` x `ny` quads over `[x0, x1] x [y0, y1]`, two triangles each on a random
/// diagonal; interior vertices jittered by up to 2 pixels, so the union stays the rectangle.
pub fn jittered_grid(
    rng: &mut penumbra::bench::SplitMix,
    nx: usize,
    ny: usize,
    (x0, y0): (i64, i64),
    (x1, y1): (i64, i64),
) -> Vec<WinTri> {
    let mut g = vec![vec![(0i64, 0i64); nx + 1]; ny + 1];
    for (j, row) in g.iter_mut().enumerate() {
        for (i, v) in row.iter_mut().enumerate() {
            let mut x = x0 + (x1 - x0) * i as i64 / nx as i64;
            let mut y = y0 + (y1 - y0) * j as i64 / ny as i64;
            if i > 0 && i < nx {
                x += (rng.next_u64() % 1024) as i64 - 512;
            }
            if j > 0 && j < ny {
                y += (rng.next_u64() % 1024) as i64 - 512;
            }
            *v = (x, y);
        }
    }
    quads(rng, &g)
}

/// Two triangles per quad of the vertex grid `g` (rows of vertices), each on a random
/// diagonal.
pub fn quads(rng: &mut penumbra::bench::SplitMix, g: &[Vec<(i64, i64)>]) -> Vec<WinTri> {
    let mut tris = Vec::new();
    for j in 0..g.len() - 1 {
        for i in 0..g[j].len() - 1 {
            let (a, b, c, d) = (g[j][i], g[j][i + 1], g[j + 1][i + 1], g[j + 1][i]);
            if rng.next_u64() & 1 == 0 {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    tris
}

/// A fan of `n` triangles around `c` (rim radii 2000 to 62000 units, angular gaps below pi,
/// so slivers but no overlaps), the degenerate ones left out; and its rim.
pub fn fan(rng: &mut penumbra::bench::SplitMix, n: usize, c: (i64, i64)) -> (Vec<WinTri>, Vec<(i64, i64)>) {
    let steps: Vec<f64> = (0..n).map(|_| 1.0 + 0.9 * rng.next_f32() as f64).collect();
    let total: f64 = steps.iter().sum();
    let start = rng.next_f32() as f64 * std::f64::consts::TAU;
    let angles: Vec<f64> = (0..n)
        .map(|i| start + steps[..i].iter().sum::<f64>() / total * std::f64::consts::TAU)
        .collect();
    let rim: Vec<(i64, i64)> = angles
        .iter()
        .map(|a| {
            let r = 2000.0 + rng.next_f32() as f64 * 60000.0;
            (c.0 + (r * a.cos()) as i64, c.1 + (r * a.sin()) as i64)
        })
        .collect();
    let tris = (0..n)
        .map(|i| [c, rim[i], rim[(i + 1) % n]])
        .filter(|t| orient(t[0], t[1], t[2]) != 0)
        .collect();
    (tris, rim)
}

/// Whether a sample at `p` must be covered by the fan (`tris`, `rim` around `c`): strictly
/// inside one of its triangles, or on a spoke (an edge shared by two triangles) strictly
/// between the centre and the rim vertex.
pub fn fan_covers(tris: &[WinTri], rim: &[(i64, i64)], c: (i64, i64), p: (i64, i64)) -> bool {
    let strictly = tris.iter().any(|t| {
        let d = [orient(t[0], t[1], p), orient(t[1], t[2], p), orient(t[2], t[0], p)];
        d.iter().all(|&x| x > 0) || d.iter().all(|&x| x < 0)
    });
    let on_spoke = rim.iter().any(|&r| {
        orient(c, r, p) == 0
            && p != c
            && p != r
            && p.0 >= c.0.min(r.0)
            && p.0 <= c.0.max(r.0)
            && p.1 >= c.1.min(r.1)
            && p.1 <= c.1.max(r.1)
    });
    strictly || on_spoke
}

/// A window position in 1/256 pixels of a `w` x `h` target to clip space (`w = 1`); with a
/// power-of-two size the trip through NDC is exact.
pub fn window_to_clip(x: i64, y: i64, z: f32, (w, h): (u32, u32)) -> glam::Vec4 {
    glam::Vec4::new(
        x as f32 / (128.0 * w as f32) - 1.0,
        1.0 - y as f32 / (128.0 * h as f32),
        z,
        1.0,
    )
}
