//! The scene commands of the CLI: render, dump, inspect, reference. (Only the CLI and the
//! report know about files on disk beyond scene loading and image writing.)

use crate::error::CliError;
use penumbra::error::for_terminal;
use penumbra::frame;
use penumbra::image_io::{write_exr, write_pfm, write_png};
use penumbra::pipeline::{Pipeline, Rgba8, Surface};
use penumbra::reference::{Reference, ReferenceOptions};
use penumbra::report::{self, DirCache};
use penumbra::run;
use penumbra::scene::{file, Scene};
use penumbra::shadow::{self, Stage, Step};
use penumbra::visibility::Visibility;
use std::path::Path;

/// The built-in scenes folder.
pub const FIXTURES: &str = "fixtures/scenes";

/// Checks the names of a `--techniques` list (`given` as written; `names` split at its
/// commas): an empty name (a comma at an end, two in a row, or nothing) and an unknown one are
/// errors that name the flag and what was written.
pub fn check_techniques<S: AsRef<str>>(given: &str, names: &[S]) -> Result<(), CliError> {
    let reg = shadow::registry::registry();
    for w in names.iter().map(|w| w.as_ref().trim()) {
        if w.is_empty() {
            return Err(format!(
                "--techniques '{given}': an empty technique name (a comma at an end, two commas in a row, or nothing at all)"
            )
            .into());
        }
        if !reg.iter().any(|t| t.name == w) {
            return Err(format!(
                "--techniques: unknown technique {} (known: {})",
                penumbra::error::quoted(w),
                reg.iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
            )
            .into());
        }
    }
    Ok(())
}

/// Loads a scene file, printing what loading chose on the user's behalf (`Scene::notes`).
pub fn load(path: &Path) -> Result<(Scene, String), CliError> {
    let (s, text) = file::load_with_text(path)?;
    for n in &s.notes {
        eprintln!("note: {}", for_terminal(&format!("{}: {n}", path.display())));
    }
    Ok((s, text))
}

/// The most rays the reference traces for one frame of `s` at `width` x `height`: a ray a
/// pixel, and under an area light up to its samples and the rim test's 32 more.
pub fn reference_rays(s: &Scene, width: u32, height: u32) -> u64 {
    let pixels = width as u64 * height as u64;
    let per_pixel = if s
        .lights
        .iter()
        .any(|l| matches!(l.kind, penumbra::scene::LightKind::Area(_)))
    {
        1 + 32 + ReferenceOptions::default().area_samples as u64
    } else {
        1
    };
    pixels * per_pixel
}

/// A count for a person: `12,345,678`.
pub fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

pub fn pipeline(threads: usize) -> Result<Pipeline, CliError> {
    Pipeline::new(threads).map_err(CliError::from)
}

pub fn cache(out: &Path) -> DirCache {
    DirCache(out.join("cache"))
}

/// `penumbra render`.
pub fn render(
    scene: &Path,
    technique: &str,
    sets: &[String],
    threads: usize,
    reps: usize,
    out: &Path,
) -> Result<(), CliError> {
    let sets = shadow::registry::parse_sets(sets)?;
    shadow::registry::create(technique, &sets)?;
    let (s, text) = load(scene)?;
    let p = pipeline(threads)?;
    let dir_cache = cache(out);
    // Along a camera path, a progress bar (hidden when stderr is not a terminal).
    let bar = (s.frame_count() > 1).then(|| {
        let b = indicatif::ProgressBar::new(s.frame_count() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("[{bar:30}] {pos}/{len} frames {elapsed} {msg}")
                .expect("a valid template")
                .progress_chars("#>."),
        );
        b
    });
    let tell = |what: &str, i: usize, _n: usize| {
        if let Some(b) = &bar {
            b.set_message(what.to_string());
            b.set_position(i as u64);
        }
    };
    let prepared = run::Prepared::new_with_progress(&p, &s, &text, Some(&dir_cache), &tell)?;
    let r = run::render_prepared_with_progress(&p, &prepared, technique, &sets, reps, &tell)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut files = report::files::write_run(out, &r)?;
    // The float data beside the pictures, for image tools (NaN where no geometry).
    let stem = report::files::stem(&r.result.scene, &r.result.label());
    for (what, v) in [("visibility", &r.first.visibility), ("reference", &r.first.reference)] {
        let path = out.join(format!("{stem}_{what}.exr"));
        write_visibility_exr(&path, v, r.first.width, r.first.height)?;
        files.push(path);
    }
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
    if r.result.errors.penumbra_pixels > 0 {
        println!(
            "jumps     {:.5} (penumbra discontinuity beyond the reference's)",
            r.result.discontinuity
        );
        println!(
            "bands     {:.4} (penumbra neighbours on one partial-visibility plateau)",
            r.result.banding
        );
    }
    if r.result.texel_px.is_finite() {
        println!(
            "texels    {:.3} px median, {:.3} px 99th percentile (a map texel's footprint in camera pixels; 1 is ideal, above it the map is magnified)",
            r.result.texel_px, r.result.texel_px_p99
        );
    }
    if r.result.transparent.pixels > 0 {
        let t = &r.result.transparent;
        println!(
            "on transparent surfaces: rmse {:.5}, wrong {:.3} % over {} pixels",
            t.rmse, t.wrong_pct, t.pixels
        );
    }
    if s.frame_count() > 1 {
        println!("flicker   {:.5} over {} frames", r.result.flicker, s.frame_count());
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
        println!("note: {}", for_terminal(note));
    }
    let st = p.take_times();
    println!(
        "pipeline stages (all draws): vertex {:.2} ms, clip+setup+bin {:.2} ms, raster+fragment {:.2} ms",
        st.vertex * 1e3,
        st.setup_bin * 1e3,
        st.raster_fragment * 1e3
    );
    for f in &files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// False colour (blue -> green -> yellow -> red) of a scalar in [lo, hi]; NaN grey.
pub fn false_color(s: &Surface<f32>, lo: f32, hi: f32) -> Surface<Rgba8> {
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

/// Writes a visibility image as OpenEXR (one channel, or RGB transmittance).
fn write_visibility_exr(path: &Path, v: &penumbra::visibility::Visibility, w: u32, h: u32) -> Result<(), CliError> {
    Ok(write_exr(path, w, h, if v.is_rgb() { 3 } else { 1 }, &v.to_flat())?)
}

/// The float formats `dump` writes every float buffer in: PFM (simple, any tool) and OpenEXR
/// (what image tools open).
type FloatWriter = fn(&Path, u32, u32, usize, &[f32]) -> Result<(), penumbra::Error>;
const FLOAT_FORMATS: [(&str, FloatWriter); 2] = [("pfm", write_pfm), ("exr", write_exr)];

/// `penumbra dump`.
pub fn dump(scene: &Path, technique: &str, sets: &[String], threads: usize, out: &Path) -> Result<(), CliError> {
    let sets = shadow::registry::parse_sets(sets)?;
    let mut t = shadow::registry::create(technique, &sets)?;
    let (s, _) = load(scene)?;
    let p = pipeline(threads)?;
    let f = frame::frame(&p, &s, 0, 0)?;
    let v = t.visibility(&p, &f)?;
    let dir = out.join(format!("{}_{}", s.name, technique));
    penumbra::output::create_folder(&dir)?;
    let (w, h) = (f.width(), f.height());
    let mut written = Vec::new();
    for note in t.notes() {
        eprintln!("note: {}", for_terminal(&note));
    }
    for st in t.stages(&p, &f)? {
        let name = report::file_safe(st.name());
        let path = dir.join(format!("{name}.png"));
        match &st {
            Stage::Scalar { data, lo, hi, .. } => {
                write_png(&path, &false_color(data, *lo, *hi))?;
                for (ext, write) in FLOAT_FORMATS {
                    let pf = dir.join(format!("{name}.{ext}"));
                    write(&pf, data.width(), data.height(), 1, data.data())?;
                    written.push(pf);
                }
            }
            Stage::Color { data, .. } => write_png(&path, data)?,
        }
        written.push(path);
    }
    let gb = &f.gbuffer;
    let pos: Vec<f32> = gb.position.data().iter().flat_map(|v| v.to_array()).collect();
    let nrm: Vec<f32> = gb.normal.data().iter().flat_map(|v| v.to_array()).collect();
    let vis = v.to_flat();
    for (name, ch, data) in [
        ("position", 3, &pos),
        ("normal", 3, &nrm),
        ("visibility", if v.is_rgb() { 3 } else { 1 }, &vis),
        ("depth", 1, &gb.depth.data().to_vec()),
    ] {
        for (ext, write) in FLOAT_FORMATS {
            let path = dir.join(format!("{name}.{ext}"));
            write(&path, w, h, ch, data)?;
            written.push(path);
        }
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
pub fn reference(scene: &Path, threads: usize, out: &Path) -> Result<(), CliError> {
    let (s, text) = load(scene)?;
    let p = pipeline(threads)?;
    let f = frame::frame(&p, &s, 0, 0)?;
    let key = run::reference_key(&text, &f, 0, &ReferenceOptions::default());
    let (v, secs, rays) = run::reference(&p, &f, key, Some(&cache(out)))?;
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
    let path = out.join(format!("{}_reference.exr", s.name));
    write_visibility_exr(&path, &v, f.width(), f.height())?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Parses `X,Y`.
pub fn parse_pixel(s: &str) -> Result<(u32, u32), CliError> {
    let bad = || format!("--pixel '{s}' is not X,Y (two whole numbers, e.g. 120,80)");
    let (x, y) = s.split_once(',').ok_or_else(bad)?;
    Ok((
        x.trim().parse().map_err(|_| bad())?,
        y.trim().parse().map_err(|_| bad())?,
    ))
}

/// The error for a pixel outside the frame (the CLI's words, also `explore`'s).
pub fn check_pixel(f: &frame::Frame, x: u32, y: u32) -> Result<(), CliError> {
    if x >= f.width() || y >= f.height() {
        return Err(format!(
            "--pixel {x},{y} is outside the {}x{} image of scene '{}'",
            f.width(),
            f.height(),
            f.scene.name
        )
        .into());
    }
    Ok(())
}

/// One pixel's steps after technique `t` drew visibility `v` of frame `f`: the surface point,
/// the technique's own steps (the per-pixel function its image came from) and the reference
/// there. The pixel must be inside the frame ([`check_pixel`]).
pub fn pixel_steps(f: &frame::Frame, t: &dyn shadow::ShadowTechnique, v: &Visibility, x: u32, y: u32) -> Vec<Step> {
    let s = f.scene;
    let i = (y * f.width() + x) as usize;
    let mut steps = Vec::new();
    match f.point(x, y) {
        None => steps.push(Step::new(
            "pixel",
            "no geometry covers this pixel: outside every metric",
        )),
        Some(pt) => {
            let obj = f.gbuffer.object.at(x, y) as usize;
            let l = f.light.to_light(pt.position);
            steps.push(
                Step::new("surface", "the G-buffer's point at the pixel centre")
                    .text("object", s.objects[obj].name.clone())
                    .vec3("position", pt.position)
                    .vec3("normal", pt.normal)
                    .vec3("to light", l)
                    .num("cos to light", pt.normal.dot(l))
                    .flag("faces the light", pt.normal.dot(l) > 0.0),
            );
            steps.extend(t.inspect(f, x, y));
            let r = Reference::new(s);
            let hard = r.hard(&pt, &f.light);
            let opts = ReferenceOptions::default();
            let area = r.area_rgb(&pt, &f.light, i as u64, &opts);
            let mut st = Step::new(
                "reference",
                "the ray tracer at the same point: hard (one ray to the light's centre) and, for area lights, the fraction of light samples that reach it (per channel)",
            )
            .num("hard", hard)
            .vec3("area per channel", area)
            .num("technique", v.value(i))
            .num("difference", v.value(i) - area.dot(penumbra::visibility::LUMINANCE));
            if !matches!(f.light.kind, penumbra::scene::LightKind::Area(_)) {
                st = st.text("light", "not an area light: area = hard");
            }
            steps.push(st);
        }
    }
    steps
}

/// `inspect --json`'s document of one pixel's steps.
pub fn pixel_json(
    scene: &str,
    technique: &str,
    sets: &[(String, String)],
    x: u32,
    y: u32,
    steps: &[Step],
) -> serde_json::Value {
    serde_json::json!({
        "scene": scene,
        "technique": technique,
        "settings": sets.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>(),
        "pixel": [x, y],
        "steps": steps,
    })
}

/// `penumbra inspect`: one pixel, step by step: the surface point, the technique's steps,
/// and the reference's hard and area visibility there.
pub fn inspect(
    scene: &Path,
    technique: &str,
    sets: &[String],
    pixel: &str,
    threads: usize,
    json: bool,
) -> Result<(), CliError> {
    let sets = shadow::registry::parse_sets(sets)?;
    let mut t = shadow::registry::create(technique, &sets)?;
    let (x, y) = parse_pixel(pixel)?;
    let (s, _) = load(scene)?;
    let p = pipeline(threads)?;
    let f = frame::frame(&p, &s, 0, 0)?;
    check_pixel(&f, x, y)?;
    let v = t.visibility(&p, &f)?;
    let steps = pixel_steps(&f, t.as_ref(), &v, x, y);
    if json {
        let doc = pixel_json(&s.name, technique, &sets, x, y, &steps);
        println!("{}", serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?);
        return Ok(());
    }
    println!(
        "scene {}, technique {} [{}], pixel ({x}, {y})",
        s.name,
        technique,
        sets.iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    for (k, st) in steps.iter().enumerate() {
        println!(
            "{:>2}. {}{}",
            k + 1,
            st.name,
            if st.what.is_empty() {
                String::new()
            } else {
                format!(": {}", st.what)
            }
        );
        for (key, val) in &st.values {
            println!("      {key:<28} {val}");
        }
    }
    Ok(())
}
