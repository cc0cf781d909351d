//! The scene commands of the CLI: render, dump, reference, sweep, export, list. (Only the CLI
//! and the report know about files on disk beyond scene loading and image writing.)

use penumbra::frame;
use penumbra::image_io::write_png;
use penumbra::pipeline::{Pipeline, Rgba8, Surface};
use penumbra::reference::ReferenceOptions;
use penumbra::report::{self, RunResult};
use penumbra::scene::{file, LightKind, Scene};
use penumbra::shadow::{self, Stage};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The built-in scenes folder.
pub const FIXTURES: &str = "fixtures/scenes";

fn load(path: &Path) -> Result<(Scene, String), String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read scene file: {e}", path.display()))?;
    Ok((file::parse(&text, path)?, text))
}

fn pipeline(threads: usize) -> Result<Pipeline, String> {
    Pipeline::new(threads).map_err(|e| e.to_string())
}

fn cache_dir(out: &Path) -> PathBuf {
    out.join("cache")
}

/// `penumbra render`.
pub fn render(
    scene: &Path,
    technique: &str,
    sets: &[String],
    threads: usize,
    reps: usize,
    out: &Path,
) -> Result<(), String> {
    let sets = shadow::parse_sets(sets)?;
    shadow::create(technique, &sets)?;
    let (s, text) = load(scene)?;
    let p = pipeline(threads)?;
    let r = report::render(&p, &s, &text, technique, &sets, reps, Some(out), Some(&cache_dir(out)))?;
    let e = &r.result.errors;
    println!(
        "scene {} ({} triangles, {}x{}), technique {}, {} threads",
        s.name,
        s.triangles(),
        s.camera.width,
        s.camera.height,
        r.result.label(),
        p.threads()
    );
    println!("time      {:.3} ms (median of {reps})", r.result.ms);
    println!(
        "rmse      {:.5}\nmae       {:.5}\nwrong     {:.3} %\npenumbra  {:.5} (rmse over {} pixels)",
        e.rmse, e.mae, e.wrong_pct, e.penumbra_rmse, e.penumbra_pixels
    );
    if !s.camera_path.is_empty() {
        println!("flicker   {:.5} over {} frames", r.result.flicker, s.camera_path.len());
    }
    if r.reference_rays > 0 {
        println!(
            "reference {:.2} s, {} rays, {:.1} Mrays/s",
            r.reference_secs,
            r.reference_rays,
            r.reference_rays as f64 / r.reference_secs / 1e6
        );
    }
    for (pass, ms) in &r.pass_times {
        println!("  {pass:<12} {ms:.3} ms (last run)");
    }
    for (name, v) in &r.counters {
        println!("  {name:<18} {v}");
    }
    for note in &r.notes {
        println!("note: {note}");
    }
    let st = p.take_times();
    println!(
        "pipeline stages (all draws): vertex {:.2} ms, clip+setup+bin {:.2} ms, raster+fragment {:.2} ms",
        st.vertex * 1e3,
        st.setup_bin * 1e3,
        st.raster_fragment * 1e3
    );
    for f in &r.files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// Writes a float image as PFM (grey, rows bottom-up as the format requires).
fn write_pfm(path: &Path, w: u32, h: u32, channels: usize, data: &[f32]) -> Result<(), String> {
    let mut bytes = format!("{}\n{w} {h}\n-1.0\n", if channels == 3 { "PF" } else { "Pf" }).into_bytes();
    for y in (0..h as usize).rev() {
        for v in &data[y * w as usize * channels..(y + 1) * w as usize * channels] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// False colour (blue -> green -> yellow -> red) of a scalar in [lo, hi]; NaN grey.
fn false_color(s: &Surface<f32>, lo: f32, hi: f32) -> Surface<Rgba8> {
    let k = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
    s.map(|v| {
        if !v.is_finite() {
            return [80, 80, 80, 255];
        }
        let t = ((v - lo) * k).clamp(0.0, 1.0);
        let c = [
            (1.5 - (4.0 * t - 3.0).abs()),
            (1.5 - (4.0 * t - 2.0).abs()),
            (1.5 - (4.0 * t - 1.0).abs()),
        ];
        let b = |x: f32| (x.clamp(0.0, 1.0) * 255.0) as u8;
        [b(c[0]), b(c[1]), b(c[2]), 255]
    })
}

/// `penumbra dump`.
pub fn dump(scene: &Path, technique: &str, sets: &[String], threads: usize, out: &Path) -> Result<(), String> {
    let sets = shadow::parse_sets(sets)?;
    let mut t = shadow::create(technique, &sets)?;
    let (s, _) = load(scene)?;
    let p = pipeline(threads)?;
    let f = frame::frame(&p, &s, 0, 0)?;
    let v = t.visibility(&p, &f)?;
    let dir = out.join(format!("{}_{}", s.name, technique));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let (w, h) = (f.width(), f.height());
    let mut written = Vec::new();
    for note in t.notes() {
        eprintln!("note: {note}");
    }
    for st in t.stages(&p, &f)? {
        let path = dir.join(format!("{}.png", st.name()));
        match &st {
            Stage::Scalar { data, lo, hi, .. } => {
                write_png(&path, &false_color(data, *lo, *hi))?;
                let pf = dir.join(format!("{}.pfm", st.name()));
                write_pfm(&pf, data.width(), data.height(), 1, data.data())?;
                written.push(pf);
            }
            Stage::Color { data, .. } => write_png(&path, data)?,
        }
        written.push(path);
    }
    let gb = &f.gbuffer;
    let pos: Vec<f32> = gb.position.data().iter().flat_map(|v| v.to_array()).collect();
    let nrm: Vec<f32> = gb.normal.data().iter().flat_map(|v| v.to_array()).collect();
    for (name, ch, data) in [
        ("position", 3, &pos),
        ("normal", 3, &nrm),
        ("visibility", 1, &v),
        ("depth", 1, &gb.depth.data().to_vec()),
    ] {
        let path = dir.join(format!("{name}.pfm"));
        write_pfm(&path, w, h, ch, data)?;
        written.push(path);
    }
    write_png(&dir.join("visibility.png"), &report::visibility_image(&v, w, h))?;
    write_png(
        &dir.join("normal.png"),
        &gb.normal.map(|n| {
            [
                ((n.x * 0.5 + 0.5) * 255.0) as u8,
                ((n.y * 0.5 + 0.5) * 255.0) as u8,
                ((n.z * 0.5 + 0.5) * 255.0) as u8,
                255,
            ]
        }),
    )?;
    println!(
        "wrote {} stage files and the G-buffer into {}",
        written.len(),
        dir.display()
    );
    Ok(())
}

/// `penumbra reference`.
pub fn reference(scene: &Path, threads: usize, out: &Path) -> Result<(), String> {
    let (s, text) = load(scene)?;
    let p = pipeline(threads)?;
    let f = frame::frame(&p, &s, 0, 0)?;
    let key = report::reference_key(&text, &f, 0, &ReferenceOptions::default());
    let (v, secs, rays) = report::reference(&p, &f, key, Some(&cache_dir(out)))?;
    if rays > 0 {
        println!(
            "reference of {}: {:.2} s, {rays} rays, {:.1} Mrays/s, {} threads",
            s.name,
            secs,
            rays as f64 / secs / 1e6,
            p.threads()
        );
    } else {
        println!("reference of {}: read from the cache (key {key:016x})", s.name);
    }
    let path = out.join(format!("{}_reference.png", s.name));
    write_png(&path, &report::visibility_image(&v, f.width(), f.height()))?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Options of `penumbra sweep`.
pub struct SweepOpts {
    /// Scene files (empty: the fixtures).
    pub scenes: Vec<PathBuf>,
    /// `all` or a comma list.
    pub techniques: String,
    /// Threads.
    pub threads: usize,
    /// Repetitions.
    pub reps: usize,
    /// Output folder.
    pub out: PathBuf,
}

/// `penumbra sweep`.
pub fn sweep(o: SweepOpts) -> Result<(), String> {
    let mut scenes = o.scenes.clone();
    if scenes.is_empty() {
        let rd = std::fs::read_dir(FIXTURES).map_err(|e| {
            format!("{FIXTURES}: cannot list scenes: {e} (run from the repository root, or name scene files)")
        })?;
        scenes = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        scenes.sort();
    }
    let reg = shadow::registry();
    let names: Vec<&str> = if o.techniques == "all" {
        reg.iter().map(|t| t.name).collect()
    } else {
        let want: Vec<&str> = o.techniques.split(',').map(str::trim).collect();
        for w in &want {
            if !reg.iter().any(|t| t.name == *w) {
                return Err(format!(
                    "unknown technique '{w}' (known: {})",
                    reg.iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
                ));
            }
        }
        want
    };
    let mut jobs: Vec<(&str, Vec<(String, String)>)> = Vec::new();
    for t in reg.iter().filter(|t| names.contains(&t.name)) {
        for set in t.sweep {
            jobs.push((
                t.name,
                set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            ));
        }
    }
    let p = pipeline(o.threads)?;
    let loaded: Vec<(Scene, String)> = scenes.iter().map(|s| load(s)).collect::<Result<_, _>>()?;
    let total = loaded.len() * jobs.len();
    let thumbs_dir = o.out.join("images");
    let mut results: Vec<RunResult> = Vec::new();
    let t0 = Instant::now();
    let mut k = 0;
    for (s, text) in &loaded {
        for (name, sets) in &jobs {
            k += 1;
            let reps = if *name == "reference" { 0 } else { o.reps };
            let bar = 30 * k / total.max(1);
            eprint!(
                "\r[{}{}] {k}/{total} {:.0} s  {} / {:<40}",
                "#".repeat(bar),
                ".".repeat(30 - bar),
                t0.elapsed().as_secs_f64(),
                s.name,
                name
            );
            let r = report::render(
                &p,
                s,
                text,
                name,
                sets,
                reps,
                Some(&thumbs_dir),
                Some(&o.out.join("cache")),
            )?;
            results.push(r.result);
        }
    }
    eprintln!();
    std::fs::create_dir_all(&o.out).map_err(|e| format!("cannot create {}: {e}", o.out.display()))?;
    let write = |name: &str, body: &str| -> Result<(), String> {
        let path = o.out.join(name);
        std::fs::write(&path, body).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    write("results.csv", &report::csv(&results))?;
    write(
        "chart_all.svg",
        &report::chart_svg("all scenes: time vs RMSE", &results),
    )?;
    let mut scene_list = Vec::new();
    for (s, _) in &loaded {
        let rs: Vec<RunResult> = results.iter().filter(|r| r.scene == s.name).cloned().collect();
        write(
            &format!("chart_{}.svg", s.name),
            &report::chart_svg(&format!("{}: time vs RMSE", s.name), &rs),
        )?;
        scene_list.push((s.name.clone(), s.description.clone()));
    }
    let md = report::report_markdown(
        &results,
        &scene_list,
        &|r| Some(format!("images/{}_{}.png", r.scene, report::file_safe(&r.label()))),
        &|r| {
            r.counted_path
                .then(|| format!("images/{}_{}_path.svg", r.scene, report::file_safe(&r.label())))
        },
    );
    write("report.md", &md)?;
    write("summary.md", &report::summary_markdown(&results))?;
    write("report.html", &report::report_html(&md))?;
    println!(
        "sweep: {} runs on {} scenes in {:.1} s, {} threads",
        results.len(),
        loaded.len(),
        t0.elapsed().as_secs_f64(),
        p.threads()
    );
    println!("report: {}", o.out.join("report.html").display());
    println!("        {}", o.out.join("report.md").display());
    println!("data:   {}", o.out.join("results.csv").display());
    Ok(())
}

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
        for o in t.options {
            println!("      --set {}={:<8} {}", o.key, o.default, o.doc);
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
