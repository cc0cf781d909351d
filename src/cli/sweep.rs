//! `penumbra sweep` (and the default `cargo run`): every technique's sweep sets on every
//! scene against the reference; CSV, charts, the summary table and the report page.

use super::scene::{load, pipeline, FIXTURES};
use penumbra::report::{self, DirCache};
use penumbra::run::{self, RunResult};
use penumbra::scene::Scene;
use penumbra::shadow;
use std::path::PathBuf;
use std::time::Instant;

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
    /// Also run every technique's extended option sets.
    pub all: bool,
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
        let extended: &[&[(&str, &str)]] = if o.all { t.extended } else { &[] };
        for set in t.sweep.iter().chain(extended) {
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
    let cache = DirCache(o.out.join("cache"));
    let mut results: Vec<RunResult> = Vec::new();
    let t0 = Instant::now();
    let mut k = 0;
    for (s, text) in &loaded {
        let prepared = run::Prepared::new(&p, s, text, Some(&cache))?;
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
            let r = run::render_prepared(&p, &prepared, name, sets, reps)?;
            report::files::write_run(&thumbs_dir, &r)?;
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
        &|r| Some(format!("images/{}.png", report::files::stem(&r.scene, &r.label()))),
        &|r| {
            r.counted_path
                .then(|| format!("images/{}_path.svg", report::files::stem(&r.scene, &r.label())))
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
