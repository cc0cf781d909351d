//! Running techniques against the reference, and reporting: reference caching, timing,
//! images, the sweep's CSV, the speed/accuracy charts (SVG, time on a log axis, RMSE up, the
//! Pareto front drawn) and the report page (Markdown and HTML).

use crate::frame::{self, Frame};
use crate::hash::{fnv1a, FNV_OFFSET};
use crate::image_io::write_png;
use crate::metrics::{self, Errors};
use crate::pipeline::{Pipeline, Rgba8, Surface};
use crate::reference::{Reference, ReferenceOptions};
use crate::scene::Scene;
use crate::shadow;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Bump when the reference's algorithm changes, so caches made before do not match.
const REFERENCE_REVISION: u32 = 1;

/// Key of a cached reference: the scene file's bytes, the geometry and the shading points
/// actually built from it (so a change to a mesh generator or to the G-buffer cannot reuse a
/// stale file), the frame, the light and the options.
pub fn reference_key(scene_text: &str, frame: &Frame, light: usize, opts: &ReferenceOptions) -> u64 {
    let mut h = fnv1a(FNV_OFFSET, scene_text.as_bytes());
    let words = |h: u64, it: &mut dyn Iterator<Item = u32>| it.fold(h, |h, w| fnv1a(h, &w.to_le_bytes()));
    for o in &frame.scene.objects {
        h = words(
            h,
            &mut o.mesh.positions.iter().flat_map(|p| p.to_array().map(f32::to_bits)),
        );
        h = words(h, &mut o.mesh.indices.iter().copied());
    }
    h = words(
        h,
        &mut frame
            .gbuffer
            .position
            .data()
            .iter()
            .zip(frame.gbuffer.normal.data())
            .flat_map(|(p, n)| [p.to_array(), n.to_array()].concat().into_iter().map(f32::to_bits)),
    );
    h = fnv1a(
        h,
        format!(
            "{light}/{}/{opts:?}/{}/{REFERENCE_REVISION}",
            frame.index,
            env!("CARGO_PKG_VERSION")
        )
        .as_bytes(),
    );
    h
}

/// Reference visibility of a frame, read from `cache` when present (`None`: no caching).
/// Returns the visibility and the seconds spent computing it (0 when cached).
pub fn reference(p: &Pipeline, frame: &Frame, key: u64, cache: Option<&Path>) -> Result<(Vec<f32>, f64, u64), String> {
    let n = (frame.width() * frame.height()) as usize;
    let file = cache.map(|d| d.join(format!("reference-{key:016x}.f32")));
    if let Some(f) = &file {
        if let Ok(bytes) = std::fs::read(f) {
            if bytes.len() == 4 * n {
                return Ok((
                    bytes
                        .chunks_exact(4)
                        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                    0.0,
                    0,
                ));
            }
        }
    }
    let t = Instant::now();
    let r = Reference::new(frame.scene);
    let pts = frame.points();
    let v = p.install(|| r.visibility(pts, frame.width() as usize, &frame.light, &ReferenceOptions::default()));
    let secs = t.elapsed().as_secs_f64();
    if let Some(f) = &file {
        if let Some(d) = f.parent() {
            std::fs::create_dir_all(d).map_err(|e| format!("cannot create cache folder {}: {e}", d.display()))?;
        }
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(f, bytes).map_err(|e| format!("cannot write {}: {e}", f.display()))?;
    }
    Ok((v, secs, r.rays_traced()))
}

/// One technique run on one scene.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// Scene name.
    pub scene: String,
    /// Technique name.
    pub technique: String,
    /// Its settings, `k=v;k=v` (empty: defaults).
    pub settings: String,
    /// Errors against the reference.
    pub errors: Errors,
    /// Median milliseconds of the technique's visibility call.
    pub ms: f64,
    /// Worker threads.
    pub threads: usize,
    /// Flicker along the camera path (0 without a path).
    pub flicker: f64,
    /// Whether the technique reported work counters on the path's frames (their chart is
    /// worth showing).
    pub counted_path: bool,
    /// The technique's own pass times (ms) of its last run on the first frame.
    pub passes: Vec<(&'static str, f64)>,
    /// The technique's work counters on the first frame.
    pub counters: Vec<(&'static str, f64)>,
}

impl RunResult {
    /// Label for charts and tables.
    pub fn label(&self) -> String {
        if self.settings.is_empty() {
            self.technique.clone()
        } else {
            format!("{} [{}]", self.technique, self.settings)
        }
    }
}

/// A technique's visibility, its median time (ms) and the technique (for its stages).
pub type Timed = (Vec<f32>, f64, Box<dyn shadow::ShadowTechnique>);

/// Runs technique `name` with `sets` on `frame` `reps` times after one warm-up; returns the
/// last visibility and the median time in milliseconds.
pub fn time_technique(
    p: &Pipeline,
    frame: &Frame,
    name: &str,
    sets: &[(String, String)],
    reps: usize,
) -> Result<Timed, String> {
    let mut t = shadow::create(name, sets)?;
    let mut v = t.visibility(p, frame)?;
    let mut times = Vec::new();
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        v = t.visibility(p, frame)?;
        times.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    if v.len() != (frame.width() * frame.height()) as usize {
        return Err(format!(
            "technique '{name}' returned {} values for a {}x{} frame",
            v.len(),
            frame.width(),
            frame.height()
        ));
    }
    Ok((v, metrics::median(times), t))
}

/// Grey image of a visibility (NaN: background colour).
pub fn visibility_image(v: &[f32], w: u32, h: u32) -> Surface<Rgba8> {
    let s = Surface::from_vec(w, h, v.to_vec()).expect("frame size");
    s.map(|x| {
        if x.is_finite() {
            let g = (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
            [g, g, g, 255]
        } else {
            [40, 20, 60, 255]
        }
    })
}

/// Error image: red where the technique is darker than the truth, blue where brighter,
/// black where equal, grey outside the metric mask.
pub fn error_image(v: &[f32], r: &[f32], mask: &[bool], w: u32, h: u32) -> Surface<Rgba8> {
    let data = v
        .iter()
        .zip(r)
        .zip(mask)
        .map(|((&a, &b), &m)| {
            if !m || !b.is_finite() {
                return [60, 60, 60, 255];
            }
            let d = if a.is_finite() { a - b } else { -1.0 };
            let k = (d.abs().min(1.0) * 255.0) as u8;
            if d < 0.0 {
                [k, 0, 0, 255]
            } else {
                [0, 0, k, 255]
            }
        })
        .collect();
    Surface::from_vec(w, h, data).expect("frame size")
}

/// Everything one `render` produces.
pub struct RenderOutput {
    /// Metrics and time.
    pub result: RunResult,
    /// Seconds the reference took (0 when cached).
    pub reference_secs: f64,
    /// Shadow rays the reference traced (0 when cached).
    pub reference_rays: u64,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// The technique's own pass times of its last run on the first frame (ms).
    pub pass_times: Vec<(&'static str, f64)>,
    /// The technique's counters on the first frame.
    pub counters: Vec<(&'static str, f64)>,
    /// The technique's notes on the first frame (irregular input and how it was handled).
    pub notes: Vec<String>,
    /// Time and counters of every frame of the camera path (one entry without a path).
    pub path: Vec<PathFrame>,
}

/// Renders `scene` with a technique: final image, visibility, error image, metrics; camera
/// paths are run frame by frame for the flicker metric (images of the first frame).
#[allow(clippy::too_many_arguments)]
pub fn render(
    p: &Pipeline,
    scene: &Scene,
    scene_text: &str,
    name: &str,
    sets: &[(String, String)],
    reps: usize,
    out: Option<&Path>,
    cache: Option<&Path>,
) -> Result<RenderOutput, String> {
    let frames = scene.camera_path.len().max(1);
    let mut seq = Vec::new();
    let mut first = None;
    let mut pass_times = Vec::new();
    let mut notes = Vec::new();
    let mut path = Vec::new();
    let (mut ref_secs, mut ref_rays) = (0.0, 0);
    for i in 0..frames {
        let f = frame::frame(p, scene, 0, i)?;
        let (r, secs, rays) = reference(
            p,
            &f,
            reference_key(scene_text, &f, 0, &ReferenceOptions::default()),
            cache,
        )?;
        ref_secs += secs;
        ref_rays += rays;
        let (v, ms, t) = time_technique(p, &f, name, sets, if i == 0 { reps } else { 0 })?;
        if i == 0 {
            pass_times = t.timings();
            notes = t.notes();
        }
        path.push(PathFrame {
            ms,
            counters: t.counters(),
        });
        let mask = f.metric_mask();
        if i == 0 {
            first = Some((
                metrics::compare(&v, &r, &mask),
                ms,
                v.clone(),
                r.clone(),
                mask.clone(),
                f,
            ));
        }
        seq.push((v, r, mask));
    }
    let (errors, ms, v, r, mask, f) = first.expect("at least one frame");
    let settings = sets
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(";");
    let result = RunResult {
        scene: scene.name.clone(),
        technique: name.into(),
        settings,
        errors,
        ms,
        threads: p.threads(),
        flicker: metrics::flicker(&seq),
        counted_path: path.len() > 1 && path.iter().any(|f| !f.counters.is_empty()),
        passes: pass_times.clone(),
        counters: path.first().map(|f| f.counters.clone()).unwrap_or_default(),
    };
    let mut files = Vec::new();
    if let Some(dir) = out {
        let stem = format!("{}_{}", scene.name, file_safe(&result.label()));
        let (w, h) = (f.width(), f.height());
        for (suffix, img) in [
            ("", frame::shade(&f, &v)),
            ("_visibility", visibility_image(&v, w, h)),
            ("_error", error_image(&v, &r, &mask, w, h)),
            ("_reference", visibility_image(&r, w, h)),
        ] {
            let path = dir.join(format!("{stem}{suffix}.png"));
            write_png(&path, &img)?;
            files.push(path);
        }
        if path.len() > 1 {
            for (suffix, body) in [
                ("_path.csv", path_csv(&path)),
                (
                    "_path.svg",
                    path_chart_svg(
                        &format!("{}: {} along the camera path", scene.name, result.label()),
                        &path,
                    ),
                ),
            ] {
                let file = dir.join(format!("{stem}{suffix}"));
                std::fs::write(&file, body).map_err(|e| format!("cannot write {}: {e}", file.display()))?;
                files.push(file);
            }
        }
    }
    Ok(RenderOutput {
        result,
        reference_secs: ref_secs,
        reference_rays: ref_rays,
        files,
        pass_times,
        counters: path.first().map(|f| f.counters.clone()).unwrap_or_default(),
        notes,
        path,
    })
}

/// A file-name-safe version of a label.
pub fn file_safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect::<String>()
        .trim_matches('_')
        .to_string()
}

/// The sweep's CSV (one row per technique setting and scene).
pub fn csv(results: &[RunResult]) -> String {
    let mut s = String::from(
        "scene,technique,settings,ms,threads,rmse,mae,wrong_pct,penumbra_rmse,flicker,pixels,penumbra_pixels,passes_ms,counters\n",
    );
    for r in results {
        let e = &r.errors;
        let _ = writeln!(
            s,
            "{},{},\"{}\",{:.4},{},{:.6},{:.6},{:.4},{:.6},{:.6},{},{},\"{}\",\"{}\"",
            r.scene,
            r.technique,
            r.settings,
            r.ms,
            r.threads,
            e.rmse,
            e.mae,
            e.wrong_pct,
            e.penumbra_rmse,
            r.flicker,
            e.pixels,
            e.penumbra_pixels,
            r.passes
                .iter()
                .map(|(k, v)| format!("{k}={v:.3}"))
                .collect::<Vec<_>>()
                .join(";"),
            r.counters
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(";")
        );
    }
    s
}

/// Indices of the Pareto-optimal points (no other point both faster and more accurate).
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// A speed/accuracy chart as SVG: x = milliseconds (log scale), y = RMSE, one labelled point
/// per result, the Pareto front as a line.
pub fn chart_svg(title: &str, results: &[RunResult]) -> String {
    let (w, h, ml, mr, mt, mb) = (760.0, 480.0, 70.0, 30.0, 40.0, 60.0);
    let pts: Vec<(f64, f64)> = results.iter().map(|r| (r.ms.max(1e-3), r.errors.rmse)).collect();
    let (xmin, xmax) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let ymax = pts.iter().map(|p| p.1).fold(0.0, f64::max).max(1e-3) * 1.1;
    let (lx0, lx1) = (
        (xmin.max(1e-3)).log10().floor(),
        (xmax.max(1e-3))
            .log10()
            .ceil()
            .max(xmin.max(1e-3).log10().floor() + 1.0),
    );
    let px = |x: f64| ml + (x.log10() - lx0) / (lx1 - lx0) * (w - ml - mr);
    let py = |y: f64| h - mb - y / ymax * (h - mt - mb);
    let mut s = format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"22\" font-size=\"15\" text-anchor=\"middle\">{}</text>",
        w / 2.0,
        xml(title)
    );
    let _ = writeln!(
        s,
        "<line x1=\"{ml}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/>",
        h - mb,
        w - mr,
        h - mb
    );
    let _ = writeln!(
        s,
        "<line x1=\"{ml}\" y1=\"{mt}\" x2=\"{ml}\" y2=\"{}\" stroke=\"black\"/>",
        h - mb
    );
    let mut d = lx0;
    while d <= lx1 + 1e-9 {
        let x = px(10f64.powf(d));
        let _ = writeln!(s, "<line x1=\"{x}\" y1=\"{mt}\" x2=\"{x}\" y2=\"{}\" stroke=\"#ddd\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">{} ms</text>", h - mb, h - mb + 16.0, 10f64.powf(d));
        d += 1.0;
    }
    for k in 0..=4 {
        let y = ymax * k as f64 / 4.0;
        let _ = writeln!(s, "<line x1=\"{ml}\" y1=\"{py}\" x2=\"{}\" y2=\"{py}\" stroke=\"#eee\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">{y:.3}</text>", w - mr, ml - 6.0, py(y) + 4.0, py = py(y));
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">time per frame (ms, log scale)</text>",
        w / 2.0,
        h - 18.0
    );
    let _ = writeln!(
        s,
        "<text x=\"16\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {})\">RMSE of visibility</text>",
        h / 2.0,
        h / 2.0
    );
    let front = pareto(&pts);
    let line: Vec<String> = front
        .iter()
        .map(|&i| format!("{:.1},{:.1}", px(pts[i].0), py(pts[i].1)))
        .collect();
    if line.len() > 1 {
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#c33\" stroke-width=\"1.5\" stroke-dasharray=\"4 3\"/>",
            line.join(" ")
        );
    }
    for (i, r) in results.iter().enumerate() {
        let (x, y) = (px(pts[i].0), py(pts[i].1));
        let fill = if front.contains(&i) { "#c33" } else { "#369" };
        let _ = writeln!(
            s,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"4\" fill=\"{fill}\"/><text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
            x + 6.0,
            y - 4.0,
            xml(&r.label())
        );
    }
    s.push_str("</svg>\n");
    s
}

/// One frame of a camera path: the technique's time and its work counters.
#[derive(Clone, Debug)]
pub struct PathFrame {
    /// Milliseconds of the technique's visibility call.
    pub ms: f64,
    /// The technique's counters (name, value).
    pub counters: Vec<(&'static str, f64)>,
}

/// CSV of a camera path: frame, ms, then one column per counter.
pub fn path_csv(frames: &[PathFrame]) -> String {
    let mut s = String::from("frame,ms");
    for (name, _) in frames.first().map(|f| f.counters.as_slice()).unwrap_or_default() {
        let _ = write!(s, ",{}", name.replace(' ', "_"));
    }
    s.push('\n');
    for (i, f) in frames.iter().enumerate() {
        let _ = write!(s, "{i},{:.4}", f.ms);
        for (_, v) in &f.counters {
            let _ = write!(s, ",{v}");
        }
        s.push('\n');
    }
    s
}

/// Time and counters along a camera path as SVG: one panel per series (time first, then each
/// counter that is not zero on every frame), frame index on x. RTR 7.3 calls the cost of
/// shadow volumes unpredictable: this is where users see it.
pub fn path_chart_svg(title: &str, frames: &[PathFrame]) -> String {
    let mut series: Vec<(String, Vec<f64>)> = vec![("time (ms)".into(), frames.iter().map(|f| f.ms).collect())];
    if let Some(f0) = frames.first() {
        for (k, (name, _)) in f0.counters.iter().enumerate() {
            let v: Vec<f64> = frames.iter().map(|f| f.counters.get(k).map_or(0.0, |c| c.1)).collect();
            if v.iter().any(|&x| x != 0.0) {
                series.push((name.to_string(), v));
            }
        }
    }
    let (w, ph, ml, mr, mt) = (760.0, 150.0, 90.0, 30.0, 40.0);
    let h = mt + ph * series.len() as f64 + 40.0;
    let n = frames.len().max(2) - 1;
    let px = |i: usize| ml + i as f64 / n as f64 * (w - ml - mr);
    let mut s = format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"22\" font-size=\"15\" text-anchor=\"middle\">{}</text>",
        w / 2.0,
        xml(title)
    );
    for (k, (name, v)) in series.iter().enumerate() {
        let top = mt + ph * k as f64;
        let bottom = top + ph - 30.0;
        let hi = v.iter().copied().fold(0.0, f64::max).max(1e-9) * 1.1;
        let py = |y: f64| bottom - y / hi * (bottom - top);
        let _ = writeln!(
            s,
            "<line x1=\"{ml}\" y1=\"{bottom}\" x2=\"{}\" y2=\"{bottom}\" stroke=\"black\"/><line x1=\"{ml}\" y1=\"{top}\" x2=\"{ml}\" y2=\"{bottom}\" stroke=\"black\"/>",
            w - mr
        );
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text><text x=\"{}\" y=\"{}\" text-anchor=\"end\">0</text><text x=\"{}\" y=\"{}\" font-weight=\"bold\">{}</text>",
            ml - 6.0,
            top + 10.0,
            fmt_si(hi),
            ml - 6.0,
            bottom,
            ml + 6.0,
            top + 10.0,
            xml(name)
        );
        let line: Vec<String> = v
            .iter()
            .enumerate()
            .map(|(i, &y)| format!("{:.1},{:.1}", px(i), py(y)))
            .collect();
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#369\" stroke-width=\"1.5\"/>",
            line.join(" ")
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">frame of the camera path (0 to {n})</text>",
        w / 2.0,
        h - 14.0
    );
    s.push_str("</svg>\n");
    s
}

/// A number with an SI suffix (1.2k, 3.4M) for axis labels.
fn fmt_si(x: f64) -> String {
    match x.abs() {
        a if a >= 1e9 => format!("{:.1}G", x / 1e9),
        a if a >= 1e6 => format!("{:.1}M", x / 1e6),
        a if a >= 1e3 => format!("{:.1}k", x / 1e3),
        _ => format!("{x:.2}"),
    }
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// One row per technique and settings across all scenes: median time, mean RMSE, mean and
/// worst wrong % (with the scene), mean penumbra RMSE. The README's technique table.
pub fn summary_markdown(results: &[RunResult]) -> String {
    let mut labels: Vec<String> = Vec::new();
    for r in results {
        if !labels.contains(&r.label()) {
            labels.push(r.label());
        }
    }
    let mut s = String::from(
        "| technique [settings] | median ms | mean RMSE | mean wrong % | worst wrong % (scene) | mean penumbra RMSE |\n| --- | --- | --- | --- | --- | --- |\n",
    );
    for label in labels {
        let rs: Vec<&RunResult> = results.iter().filter(|r| r.label() == label).collect();
        let n = rs.len() as f64;
        let mean = |f: &dyn Fn(&RunResult) -> f64| rs.iter().map(|r| f(r)).sum::<f64>() / n;
        let worst = rs
            .iter()
            .max_by(|a, b| a.errors.wrong_pct.total_cmp(&b.errors.wrong_pct))
            .expect("at least one run");
        let _ = writeln!(
            s,
            "| {label} | {:.1} | {:.4} | {:.2} | {:.2} ({}) | {:.3} |",
            metrics::median(rs.iter().map(|r| r.ms).collect()),
            mean(&|r| r.errors.rmse),
            mean(&|r| r.errors.wrong_pct),
            worst.errors.wrong_pct,
            worst.scene,
            {
                // Over the scenes that have a penumbra (area lights) only.
                let soft: Vec<f64> = rs
                    .iter()
                    .filter(|r| r.errors.penumbra_pixels > 0)
                    .map(|r| r.errors.penumbra_rmse)
                    .collect();
                soft.iter().sum::<f64>() / soft.len().max(1) as f64
            },
        );
    }
    s
}

/// The report page in Markdown: per scene a chart and a table with thumbnails.
pub fn report_markdown(
    results: &[RunResult],
    scenes: &[(String, String)],
    thumbs: &dyn Fn(&RunResult) -> Option<String>,
    paths: &dyn Fn(&RunResult) -> Option<String>,
) -> String {
    let mut s = String::from("# penumbra sweep\n\nEvery technique on every scene against the ray-traced reference. Time is the median of the technique's visibility pass; errors are over pixels covered by geometry and facing the light.\n\n![all scenes](chart_all.svg)\n\n");
    for (name, desc) in scenes {
        let _ = write!(s, "## {name}\n\n{desc}\n\n![{name}](chart_{name}.svg)\n\n| technique | ms | RMSE | MAE | wrong % | penumbra RMSE | flicker | image |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n");
        for r in results.iter().filter(|r| &r.scene == name) {
            let e = &r.errors;
            let img = thumbs(r).map(|t| format!("![]({t})")).unwrap_or_default();
            let _ = writeln!(
                s,
                "| {} | {:.2} | {:.4} | {:.4} | {:.3} | {:.4} | {:.4} | {img} |",
                r.label(),
                r.ms,
                e.rmse,
                e.mae,
                e.wrong_pct,
                e.penumbra_rmse,
                r.flicker
            );
        }
        s.push('\n');
        // Time and work counters along the camera path, for techniques with counters to show.
        let charts: Vec<(String, String)> = results
            .iter()
            .filter(|r| &r.scene == name)
            .filter_map(|r| paths(r).map(|p| (r.label(), p)))
            .collect();
        if !charts.is_empty() {
            let _ = writeln!(
                s,
                "### {name}: along the camera path
"
            );
            for (label, p) in charts {
                let _ = writeln!(
                    s,
                    "![{label}]({p})
"
                );
            }
        }
    }
    s
}

/// The same report as a standalone HTML page (tables and images, no scripts).
pub fn report_html(markdown: &str) -> String {
    let mut html = String::from("<!doctype html><html><head><meta charset=\"utf-8\"><title>penumbra sweep</title><style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 6px}img{max-width:100%}td img{width:160px}</style></head><body>\n");
    let mut in_table = false;
    for line in markdown.lines() {
        let img = |t: &str| -> String {
            // ![alt](src) -> <img>
            let mut out = String::new();
            let mut rest = t;
            while let Some(a) = rest.find("![") {
                out.push_str(&xml(&rest[..a]));
                let after = &rest[a + 2..];
                let (Some(b), Some(c)) = (after.find("]("), after.find(')')) else {
                    out.push_str(&xml(&rest[a..]));
                    return out;
                };
                out.push_str(&format!(
                    "<img alt=\"{}\" src=\"{}\">",
                    xml(&after[..b]),
                    xml(&after[b + 2..c])
                ));
                rest = &after[c + 1..];
            }
            out.push_str(&xml(rest));
            out
        };
        if line.starts_with('|') {
            if line.contains("---") {
                continue;
            }
            let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
            if !in_table {
                html.push_str("<table><tr>");
                for c in &cells {
                    let _ = write!(html, "<th>{}</th>", img(c));
                }
                html.push_str("</tr>\n");
                in_table = true;
                continue;
            }
            html.push_str("<tr>");
            for c in &cells {
                let _ = write!(html, "<td>{}</td>", img(c));
            }
            html.push_str("</tr>\n");
            continue;
        }
        if in_table {
            html.push_str("</table>\n");
            in_table = false;
        }
        if let Some(t) = line.strip_prefix("## ") {
            let _ = writeln!(html, "<h2>{}</h2>", xml(t));
        } else if let Some(t) = line.strip_prefix("# ") {
            let _ = writeln!(html, "<h1>{}</h1>", xml(t));
        } else if !line.trim().is_empty() {
            let _ = writeln!(html, "<p>{}</p>", img(line));
        }
    }
    if in_table {
        html.push_str("</table>\n");
    }
    html.push_str("</body></html>\n");
    html
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let pts = [(1.0, 0.5), (2.0, 0.2), (3.0, 0.3), (0.5, 0.9), (4.0, 0.1), (2.5, 0.2)];
        assert_eq!(pareto(&pts), vec![3, 0, 1, 4]);
    }

    #[test]
    fn html_report_converts_tables_and_images() {
        let md = "# t\n\n| a | b |\n| --- | --- |\n| x | ![](p.png) |\n";
        let h = report_html(md);
        assert!(
            h.contains("<th>a</th>") && h.contains("<img alt=\"\" src=\"p.png\">"),
            "{h}"
        );
    }
}
