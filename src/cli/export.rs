//! `penumbra export` (a scene in world space for other renderers) and `penumbra list`.

use super::scene::{load, FIXTURES};
use penumbra::scene::LightKind;
use penumbra::shadow;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `penumbra export`.
pub fn export(scene: &Path, out: &Path) -> Result<(), String> {
    let (s, _) = load(scene)?;
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let mut obj = format!("# {} exported by penumbra (world space)\n", s.name);
    let mut base = 1;
    for o in &s.objects {
        let _ = writeln!(obj, "o {}", o.name);
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
    let v3 = |v: glam::Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
    let mut json = format!(
        "{{\n  \"scene\": \"{}\",\n  \"camera\": {{\"position\": {}, \"target\": {}, \"up\": {}, \"fov_deg\": {}, \"near\": {}, \"far\": {}, \"width\": {}, \"height\": {}}},\n  \"lights\": [\n",
        s.name,
        v3(c.position),
        v3(c.target),
        v3(c.up),
        c.fov_deg,
        c.near,
        c.far,
        c.width,
        c.height
    );
    for (i, l) in s.lights.iter().enumerate() {
        let kind = match l.kind {
            LightKind::Directional => "\"type\": \"directional\"".to_string(),
            LightKind::Spot { angle_deg } => format!("\"type\": \"spot\", \"angle_deg\": {angle_deg}"),
            LightKind::Point => "\"type\": \"point\"".to_string(),
            LightKind::Area(a) => format!("\"type\": \"area\", \"shape\": \"{a:?}\""),
        };
        let _ = writeln!(
            json,
            "    {{{kind}, \"position\": {}, \"direction\": {}, \"intensity\": {}}}{}",
            v3(l.position),
            v3(l.direction),
            l.intensity,
            if i + 1 < s.lights.len() { "," } else { "" }
        );
    }
    json.push_str("  ]\n}\n");
    let (po, pj) = (
        out.join(format!("{}.obj", s.name)),
        out.join(format!("{}.json", s.name)),
    );
    std::fs::write(&po, obj).map_err(|e| format!("cannot write {}: {e}", po.display()))?;
    std::fs::write(&pj, json).map_err(|e| format!("cannot write {}: {e}", pj.display()))?;
    println!("wrote {}\nwrote {}", po.display(), pj.display());
    Ok(())
}

/// `penumbra list`.
pub fn list() -> Result<(), String> {
    println!("techniques:");
    for t in shadow::registry() {
        println!("  {:<12} {}", t.name, t.summary);
        for o in &t.options {
            let kv = format!("{}={}", o.key, o.default);
            println!("      --set {kv:<22} {} [{}]", o.doc, o.ty);
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
