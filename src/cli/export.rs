//! `penumbra export` (a scene in world space for other renderers) and `penumbra list`.

use super::scene::{load, FIXTURES};
use crate::error::CliError;
use glam::Vec3;
use penumbra::scene::{AreaShape, Light, LightKind};
use penumbra::shadow;
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// An OBJ/MTL name: one line, no spaces or control characters (they would start new
/// statements or shift the file's numbering).
fn obj_name(s: &str) -> String {
    let n: String = s
        .chars()
        .map(|c| {
            if c.is_whitespace() || c.is_control() || c == '#' {
                '_'
            } else {
                c
            }
        })
        .collect();
    if n.is_empty() {
        "unnamed".into()
    } else {
        n
    }
}

/// An `f32` as the JSON number it reads as (0.1, not 0.10000000149011612).
fn f(x: f32) -> serde_json::Value {
    x.to_string()
        .parse::<f64>()
        .map_or(serde_json::Value::Null, |v| json!(v))
}

fn v3(v: Vec3) -> serde_json::Value {
    json!([f(v.x), f(v.y), f(v.z)])
}

/// A light as structured JSON: its type, its shape's fields and the placement every type has.
fn light_json(l: &Light) -> serde_json::Value {
    let mut j = match l.kind {
        LightKind::Directional => json!({"type": "directional"}),
        LightKind::Spot { angle_deg } => json!({"type": "spot", "angle_deg": f(angle_deg)}),
        LightKind::Point => json!({"type": "point"}),
        LightKind::Area(AreaShape::Disk { radius }) => json!({"type": "disk", "radius": f(radius)}),
        LightKind::Area(AreaShape::Sphere { radius }) => json!({"type": "sphere", "radius": f(radius)}),
        LightKind::Area(AreaShape::Rectangle { width, height }) => {
            let (t1, t2) = l.tangents();
            json!({"type": "rectangle", "width": f(width), "height": f(height), "width_axis": v3(t1), "height_axis": v3(t2)})
        }
    };
    j["position"] = v3(l.position);
    j["direction"] = v3(l.direction);
    j["intensity"] = f(l.intensity);
    j
}

/// How the reference samples lights and averages visibility, for another renderer to
/// reproduce the ground truth (src/reference/mod.rs).
const SAMPLING: &str = "Visibility of a shading point is the transmittance along shadow rays from the point, offset along its geometric normal (Wachter and Binder, Ray Tracing Gems ch. 6), to the light. Opaque surfaces (opacity 1) stop a ray; a surface with opacity below 1 multiplies it by its transmittance (Tf in the MTL, 1 - d where Tf is absent), per channel, front to back; a mesh is seen from both sides. Hard shadows: one ray to the light's position (directional lights: along -direction, unbounded). Area lights: the fraction of the light seen, by stratified jittered sampling; a pilot of 8 x 8 strata and 32 rim points, and if the pilot rays disagree, 32 x 32 fresh strata (1024 rays), averaged with equal weights. Disk: points by the concentric map (Shirley and Chiu) of the strata over the disk around position, spanned by the light's tangents. Rectangle: uniform over width_axis x height_axis around position. Sphere: uniform directions within the cone the sphere subtends, ending at its near surface. The jitter is a hash of (pixel, sample, pass), so the reference is deterministic; matching it to within sampling noise needs the same strata, not the same jitter.";

/// `penumbra export`: the scene in world space as OBJ + MTL (every material: albedo `Kd`,
/// opacity `d`, transmittance colour `Tf`, two-sidedness as a comment and in the JSON) and a
/// JSON of the camera, its path, structured lights and the reference's light-sample
/// convention, so that another renderer can reproduce the ground truth.
pub fn export(scene: &Path, out: &Path) -> Result<(), CliError> {
    let (s, _) = load(scene)?;
    // Non-finite geometry would make files other tools cannot read (and that say nothing).
    for o in &s.objects {
        if let Some(p) = o.mesh.positions.iter().find(|p| !p.is_finite()) {
            return Err(format!(
                "{}: object '{}' has a vertex at {p} after its transform: not finite, so not exported (lower its scale or translate)",
                scene.display(),
                o.name
            ).into());
        }
    }
    penumbra::output::create_folder(out)?;
    let stem = match penumbra::report::file_safe(&s.name) {
        n if n.is_empty() => "scene".to_string(),
        n => n,
    };
    let mut mtl = format!("# {} materials, exported by penumbra\n", obj_name(&s.name));
    let names = unique_names(s.materials.iter().map(|m| obj_name(&m.name)));
    let material_name = |i: usize| names.get(i).cloned().unwrap_or_else(|| "default".into());
    for (m, name) in s.materials.iter().zip(&names) {
        let tf = m.transmittance_rgb();
        let _ = writeln!(
            mtl,
            "\nnewmtl {}\nKd {} {} {}\nd {}\nTf {} {} {}\n# two_sided {}",
            name, m.albedo.x, m.albedo.y, m.albedo.z, m.opacity, tf.x, tf.y, tf.z, m.two_sided
        );
    }
    let mut obj = format!(
        "# {} exported by penumbra (world space)\nmtllib {stem}.mtl\n",
        obj_name(&s.name)
    );
    let mut base = 1;
    for o in &s.objects {
        let mat = material_name(o.material);
        let _ = writeln!(obj, "o {}\nusemtl {mat}", obj_name(&o.name));
        for p in &o.mesh.positions {
            let _ = writeln!(obj, "v {} {} {}", p.x, p.y, p.z);
        }
        for n in &o.mesh.normals {
            let _ = writeln!(obj, "vn {} {} {}", n.x, n.y, n.z);
        }
        for t in o.mesh.indices.chunks_exact(3) {
            let (a, b, c) = (t[0] as usize + base, t[1] as usize + base, t[2] as usize + base);
            let _ = writeln!(obj, "f {a}//{a} {b}//{b} {c}//{c}");
        }
        base += o.mesh.positions.len();
    }
    let c = &s.camera;
    let doc = json!({
        "scene": s.name,
        "description": s.description,
        "files": {"obj": format!("{stem}.obj"), "mtl": format!("{stem}.mtl")},
        "camera": {
            "position": v3(c.position), "target": v3(c.target), "up": v3(c.up),
            "fov_y_deg": f(c.fov_deg), "near": f(c.near), "far": f(c.far),
            "width": c.width, "height": c.height,
        },
        "camera_path": s.camera_path.iter().map(|k| json!({"position": v3(k.position), "target": v3(k.target)})).collect::<Vec<_>>(),
        "lights": s.lights.iter().map(light_json).collect::<Vec<_>>(),
        "materials": s.materials.iter().zip(&names).map(|(m, name)| json!({
            "name": name, "albedo": v3(m.albedo), "opacity": f(m.opacity),
            "transmittance": v3(m.transmittance_rgb()), "two_sided": m.two_sided,
        })).collect::<Vec<_>>(),
        "objects": s.objects.iter().map(|o| json!({
            "name": obj_name(&o.name),
            "material": material_name(o.material),
            "triangles": o.mesh.triangles(),
        })).collect::<Vec<_>>(),
        "reference_sampling": SAMPLING,
    });
    let json = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    let files = [
        (out.join(format!("{stem}.obj")), obj),
        (out.join(format!("{stem}.mtl")), mtl),
        (out.join(format!("{stem}.json")), json),
    ];
    for (path, body) in &files {
        penumbra::output::write_plain(path, body.as_bytes())?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// `penumbra list`.
pub fn list() -> Result<(), CliError> {
    println!("techniques:");
    for t in shadow::registry::registry() {
        println!("  {:<12} {}", t.name, t.summary);
        for o in &t.options {
            let kv = format!("{}={}", o.key, o.default);
            println!("      --set {kv:<22} {} [{}]", o.doc, o.ty);
            for (name, meaning) in &o.choices {
                println!("            {name:<22} {meaning}");
            }
        }
    }
    println!("scenes ({FIXTURES}):");
    if let Ok(rd) = std::fs::read_dir(FIXTURES) {
        let mut v: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        v.sort();
        for p in v {
            match load(&p) {
                Ok((s, _)) => println!("  {:<16} {}", s.name, s.description),
                Err(e) => println!("  {:<16} (error: {e})", p.display()),
            }
        }
    }
    Ok(())
}

/// `names` made unique in order: a name met before gets `_2`, `_3`, ... (materials "a b" and
/// "a_b" sanitize to the same OBJ name).
fn unique_names(names: impl Iterator<Item = String>) -> Vec<String> {
    let mut seen = std::collections::HashSet::new();
    names
        .map(|n| {
            let mut name = n.clone();
            let mut k = 2;
            while !seen.insert(name.clone()) {
                name = format!("{n}_{k}");
                k += 1;
            }
            name
        })
        .collect()
}
