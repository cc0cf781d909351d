//! `penumbra sweep` (and the default `cargo run`): every technique's sweep sets on every
//! scene against the reference; CSV, charts, the summary table and the report page. A run
//! list can be split into deterministic shards (`--shard I/N`) whose folders `--merge`
//! combines into what one run would have written.

use super::scene::{check_techniques, load, pipeline, FIXTURES};
use crate::error::CliError;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use penumbra::error::for_terminal;
use penumbra::report::files::{read_sweep_data, write_sweep, write_sweep_data, Manifest};
use penumbra::report::{self, DirCache, SceneInfo};
use penumbra::run::{self, RunResult};
use penumbra::scene::Scene;
use penumbra::shadow;
use std::path::{Path, PathBuf};
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
    /// Run only shard `I` of `N` (`(0, 1)`: everything).
    pub shard: (usize, usize),
}

/// Parses `I/N` with 0 <= I < N.
pub fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("--shard '{s}': expected I/N with 0 <= I < N (for example 0/4)");
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n) = (
        i.trim().parse::<usize>().map_err(|_| bad())?,
        n.trim().parse::<usize>().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

/// The run list's slice of shard `i` of `n`: contiguous, so that each scene's reference is
/// built by as few shards as possible, and sized within one run of the others.
pub fn shard_range(total: usize, (i, n): (usize, usize)) -> std::ops::Range<usize> {
    (total * i / n)..(total * (i + 1) / n)
}

/// Progress of a long command: indicatif's bar on a terminal; where stderr is not one (CI
/// logs, batch jobs), a plain line when it starts and then every 10 seconds
/// (`PENUMBRA_PROGRESS_SECS` sets the interval): done/total, elapsed, the time left at the
/// pace so far, what is at work and, inside a run, the library's stage
/// ([`penumbra::progress`]: the reference's BVH build and rows), so that it moves during a
/// long reference too.
pub struct Progress {
    bar: Option<ProgressBar>,
    state: std::sync::Arc<std::sync::Mutex<(u64, String)>>,
    stop: Option<(std::sync::mpsc::Sender<()>, std::thread::JoinHandle<()>)>,
}

/// What is at work: the command's message and the library's stage, if any.
fn at_work(what: &str) -> String {
    match (what.is_empty(), penumbra::progress::current()) {
        (true, None) => String::new(),
        (false, None) => what.to_string(),
        (true, Some(stage)) => stage,
        (false, Some(stage)) => format!("{what} ({stage})"),
    }
}

impl Progress {
    /// Progress of `total` steps of the command `label`.
    pub fn new(label: &'static str, total: usize) -> Progress {
        use std::io::IsTerminal;
        let state = std::sync::Arc::new(std::sync::Mutex::new((0u64, String::new())));
        let shared = state.clone();
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template("[{bar:30}] {pos}/{len} {elapsed} (eta {eta}) {msg}")
                    .expect("a valid template")
                    .progress_chars("#>."),
            );
            // The message (with the library's stage) and the clock move between steps too.
            let shown = bar.clone();
            let thread = std::thread::spawn(move || {
                while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                    rx.recv_timeout(std::time::Duration::from_millis(250))
                {
                    let what = shared.lock().map(|g| g.1.clone()).unwrap_or_default();
                    shown.set_message(for_terminal(&at_work(&what)).into_owned());
                    shown.tick();
                }
            });
            return Progress {
                bar: Some(bar),
                state,
                stop: Some((tx, thread)),
            };
        }
        let every = std::env::var("PENUMBRA_PROGRESS_SECS")
            .ok()
            .and_then(|v| v.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v > 0.0)
            .unwrap_or(10.0)
            .min(3600.0);
        let t0 = Instant::now();
        let line = move || {
            let (done, what) = shared.lock().map(|g| g.clone()).unwrap_or_default();
            let elapsed = t0.elapsed().as_secs_f64();
            let left = if done > 0 && (done as usize) < total {
                format!(
                    ", about {:.0} s left",
                    elapsed / done as f64 * (total as u64 - done) as f64
                )
            } else {
                String::new()
            };
            let what = at_work(&what);
            eprintln!(
                "{label}: {done}/{total} runs, {elapsed:.0} s{left}{}",
                if what.is_empty() {
                    String::new()
                } else {
                    format!(", at {}", for_terminal(&what))
                }
            );
        };
        line();
        let thread = std::thread::spawn(move || {
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                rx.recv_timeout(std::time::Duration::from_secs_f64(every))
            {
                line();
            }
        });
        Progress {
            bar: None,
            state,
            stop: Some((tx, thread)),
        }
    }

    /// One more step done.
    pub fn inc(&self) {
        if let Some(b) = &self.bar {
            b.inc(1);
        }
        if let Ok(mut g) = self.state.lock() {
            g.0 += 1;
        }
    }

    /// What is at work now.
    pub fn set_message(&self, msg: String) {
        let msg = for_terminal(&msg).into_owned();
        if let Some(b) = &self.bar {
            b.set_message(at_work(&msg));
        }
        if let Ok(mut g) = self.state.lock() {
            g.1 = msg;
        }
    }

    /// Clears the bar, or stops the lines.
    pub fn finish(mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
        if let Some((tx, thread)) = self.stop.take() {
            drop(tx);
            let _ = thread.join();
        }
    }
}

/// `penumbra sweep`.
pub fn sweep(o: SweepOpts) -> Result<(), CliError> {
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
    let reg = shadow::registry::registry();
    let names: Vec<&str> = if o.techniques == "all" {
        reg.iter().map(|t| t.name).collect()
    } else {
        let want: Vec<&str> = o.techniques.split(',').map(str::trim).collect();
        check_techniques(&o.techniques, &want)?;
        want
    };
    let mut jobs: Vec<(&str, Vec<(String, String)>)> = Vec::new();
    for t in reg.iter().filter(|t| names.contains(&t.name)) {
        let extended: &[&[(&str, &str)]] = if o.all { t.extended } else { &[] };
        for set in t.sweep.iter().chain(extended) {
            jobs.push((t.name, shadow::registry::owned_sets(set)));
        }
    }
    let p = pipeline(o.threads)?;
    let loaded: Vec<(Scene, String)> = scenes.iter().map(|s| load(s)).collect::<Result<_, _>>()?;
    // One name, one scene: rows, images and charts are keyed by it.
    for (i, (s, _)) in loaded.iter().enumerate() {
        if let Some(j) = loaded[..i].iter().position(|(t, _)| t.name == s.name) {
            return Err(format!(
                "{} and {} are both scene '{}': rows, images and charts would share a name (rename one file)",
                scenes[j].display(),
                scenes[i].display(),
                s.name
            )
            .into());
        }
    }
    // Runs whose technique does not work on their scene (terrain occlusion height without a
    // heightfield): left out, and listed as such.
    let mut skipped = Vec::new();
    for (si, (s, _)) in loaded.iter().enumerate() {
        for (ji, (name, _)) in jobs.iter().enumerate() {
            if reg.iter().any(|t| t.name == *name && !t.applies_to(s)) {
                skipped.push(si * jobs.len() + ji);
            }
        }
    }
    let total = loaded.len() * jobs.len();
    let mine = shard_range(total, o.shard);
    let thumbs_dir = o.out.join("images");
    let cache = DirCache(o.out.join("cache"));
    let mut results: Vec<RunResult> = Vec::new();
    let t0 = Instant::now();
    let bar = Progress::new("sweep", mine.len());
    for (si, (s, text)) in loaded.iter().enumerate() {
        let runs = si * jobs.len()..(si + 1) * jobs.len();
        if runs.end <= mine.start || runs.start >= mine.end {
            continue;
        }
        let prepared = run::Prepared::new(&p, s, text, Some(&cache))?;
        for (ji, (name, sets)) in jobs.iter().enumerate() {
            let index = si * jobs.len() + ji;
            if !mine.contains(&index) {
                continue;
            }
            if skipped.contains(&index) {
                bar.inc();
                continue;
            }
            bar.set_message(format!("{} / {name}", s.name));
            let reps = if *name == "reference" { 0 } else { o.reps };
            let r = run::render_prepared(&p, &prepared, name, sets, reps)?;
            report::files::write_run(&thumbs_dir, &r)?;
            results.push(RunResult { index, ..r.result });
            bar.inc();
        }
    }
    bar.finish();
    let manifest = Manifest {
        settings: jobs
            .iter()
            .map(|(name, sets)| run::label(name, &run::settings_text(sets)))
            .collect(),
        shard: format!("{}/{}", o.shard.0, o.shard.1),
        scenes: loaded
            .iter()
            .zip(scenes)
            .map(|((s, _), path)| SceneInfo {
                name: s.name.clone(),
                description: s.description.clone(),
                class: s.class(),
                file: path.display().to_string(),
            })
            .collect(),
        skipped,
    };
    if o.shard.1 > 1 {
        write_sweep_data(&o.out, &results, &manifest)?;
        println!(
            "sweep shard {}: runs {}..{} of {total} in {:.1} s, {} threads; merge the shards' folders with `penumbra sweep --merge DIR...`",
            manifest.shard,
            mine.start,
            mine.end,
            t0.elapsed().as_secs_f64(),
            p.threads()
        );
        println!("data:   {}", o.out.join("results.csv").display());
        return Ok(());
    }
    write_sweep(&o.out, &results, &manifest, &explore_command)?;
    println!(
        "sweep: {} runs on {} scene{} in {:.1} s, {} threads",
        results.len(),
        loaded.len(),
        if loaded.len() == 1 { "" } else { "s" },
        t0.elapsed().as_secs_f64(),
        p.threads()
    );
    print_outputs(&o.out);
    Ok(())
}

fn print_outputs(out: &Path) {
    println!("report: {}", out.join("report.html").display());
    println!("        {}", out.join("report.md").display());
    println!("data:   {}", out.join("results.csv").display());
}

/// Checks one shard's rows against its manifest: every technique of the manifest is known,
/// every row is a run of the shard's own range with the scene, setting and class the run list
/// has there, no run is in it twice or was skipped, and none of its range is missing. Errors
/// name the folder, the file and the row.
fn check_shard(dir: &Path, rows: &[RunResult], m: &Manifest) -> Result<(), CliError> {
    let csv = dir.join("results.csv");
    let json = dir.join("sweep.json");
    let known: Vec<&str> = shadow::registry::registry()
        .iter()
        .map(|t| t.name)
        .chain(["reference"])
        .collect();
    for (k, setting) in m.settings.iter().enumerate() {
        let name = setting.split(" [").next().unwrap_or("");
        if !known.contains(&name) {
            return Err(format!(
                "{}: setting {} is of technique '{name}', which penumbra does not have",
                json.display(),
                k + 1
            )
            .into());
        }
    }
    let (i, n) = parse_shard(&m.shard).map_err(|e| format!("{}: shard: {e}", json.display()))?;
    let runs = m.runs();
    let range = shard_range(runs, (i, n));
    let mut seen: Vec<Option<usize>> = vec![None; range.len()];
    for (k, r) in rows.iter().enumerate() {
        let row = k + 1;
        let at =
            |what: String| -> CliError { format!("{}: row {row} (run {}): {what}", csv.display(), r.index).into() };
        if !range.contains(&r.index) {
            return Err(at(format!(
                "the run is not in this folder's shard {} (runs {}..{} of {runs})",
                m.shard, range.start, range.end
            )));
        }
        let (scene, setting) = (
            &m.scenes[r.index / m.settings.len()],
            &m.settings[r.index % m.settings.len()],
        );
        if r.scene != scene.name || r.label() != *setting || r.class != scene.class {
            return Err(at(format!(
                "is '{}' on scene '{}' ({}), but the sweep's run {} is '{setting}' on scene '{}' ({})",
                r.label(),
                r.scene,
                r.class.key(),
                r.index,
                scene.name,
                scene.class.key()
            )));
        }
        if m.skipped.contains(&r.index) {
            return Err(at(
                "the sweep skips this run (its technique does not apply to the scene)".into(),
            ));
        }
        match seen[r.index - range.start] {
            Some(first) => return Err(at(format!("the same run as row {first} of the same file"))),
            None => seen[r.index - range.start] = Some(row),
        }
    }
    if let Some(k) = seen
        .iter()
        .enumerate()
        .position(|(k, s)| s.is_none() && !m.skipped.contains(&(range.start + k)))
    {
        return Err(format!(
            "{}: shard {} should hold runs {}..{} of {runs}, and run {} is not in its results.csv ({} rows)",
            dir.display(),
            m.shard,
            range.start,
            range.end,
            range.start + k,
            rows.len()
        )
        .into());
    }
    Ok(())
}

/// Copies a shard's `images/` into `out/images`: regular files only, read and written
/// without following links (a shard's link could name any file; a linked `out/images` would
/// write outside the output folder).
fn copy_images(dir: &Path, out: &Path) -> Result<(), CliError> {
    let images = dir.join("images");
    match std::fs::symlink_metadata(&images) {
        Ok(m) if m.file_type().is_dir() => {}
        Ok(_) => {
            return Err(format!(
                "{}: a symbolic link or a file, not a folder: links are not followed",
                images.display()
            )
            .into())
        }
        Err(_) => return Ok(()),
    }
    let to = out.join("images");
    report::files::create_folder(&to)?;
    if std::fs::canonicalize(&images).ok() == std::fs::canonicalize(&to).ok() {
        return Ok(());
    }
    let rd = std::fs::read_dir(&images).map_err(|e| format!("{}: cannot list: {e}", images.display()))?;
    for e in rd {
        let e = e.map_err(|e| format!("{}: cannot list: {e}", images.display()))?;
        let bytes = report::files::read_plain(&e.path(), "a shard's image", report::files::MAX_SHARD_FILE)?;
        report::files::write_plain(&to.join(e.file_name()), &bytes)?;
    }
    Ok(())
}

/// `penumbra sweep --merge DIR...`: the shards' rows in run order, their images, and every
/// chart and report page, as one unsharded run writes them. Errors name the folder that is
/// missing, inconsistent or duplicated, and the file and row that no sweep wrote.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<(), CliError> {
    if dirs.is_empty() {
        return Err("--merge needs the shards' output folders".into());
    }
    let mut all: Vec<(RunResult, usize)> = Vec::new();
    let mut manifest: Option<(Manifest, &PathBuf)> = None;
    for (k, d) in dirs.iter().enumerate() {
        let (rs, m) = read_sweep_data(d)?;
        if let Some((first, fd)) = &manifest {
            if first.scenes != m.scenes || first.settings != m.settings || first.skipped != m.skipped {
                return Err(format!(
                    "{} and {} are shards of different sweeps (their scenes, technique settings or skipped runs differ)",
                    fd.display(),
                    d.display()
                )
                .into());
            }
        }
        check_shard(d, &rs, &m)?;
        if manifest.is_none() {
            manifest = Some((m, d));
        }
        all.extend(rs.into_iter().map(|r| (r, k)));
        copy_images(d, out)?;
    }
    let (mut m, _) = manifest.expect("at least one folder");
    all.sort_by_key(|(r, _)| r.index);
    for w in all.windows(2) {
        if w[0].0.index == w[1].0.index {
            return Err(format!(
                "run {} is in two shards, {} and {} (a folder was given twice?)",
                w[0].0.index,
                dirs[w[0].1].display(),
                dirs[w[1].1].display()
            )
            .into());
        }
    }
    let all: Vec<RunResult> = all.into_iter().map(|(r, _)| r).collect();
    let missing: Vec<usize> = (0..m.runs())
        .filter(|i| all.binary_search_by_key(i, |r| r.index).is_err() && !m.skipped.contains(i))
        .collect();
    if !missing.is_empty() {
        return Err(format!(
            "{} of {} runs are in none of the folders (first missing: run {}): merge every shard",
            missing.len(),
            m.runs(),
            missing[0]
        )
        .into());
    }
    m.shard = "0/1".into();
    write_sweep(out, &all, &m, &explore_command)?;
    println!("merged {} runs from {} folders", all.len(), dirs.len());
    print_outputs(out);
    Ok(())
}

/// The command line that opens run `r` of scene file `file` in `penumbra explore` (the
/// report's fold-out under each run).
fn explore_command(file: &str, r: &RunResult) -> Option<String> {
    let sets: String = r
        .settings
        .split(';')
        .filter(|kv| !kv.is_empty())
        .map(|kv| format!(" --set {kv}"))
        .collect();
    Some(format!("penumbra explore {file} --technique {}{sets}", r.technique))
}
