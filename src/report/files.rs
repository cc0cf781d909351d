//! A run's files in a folder: the shaded image, visibility, error and reference (PNG) and,
//! for camera paths, the path's CSV and chart.

use super::{chart, csv, file_safe, images, markdown, SceneInfo};
use crate::image_io::encode_png;
use crate::run::{RenderOutput, RunResult};
use crate::scene::SceneClass;
use crate::Error;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What a sweep folder holds beside its CSV (`sweep.json`): every scene and technique setting
/// of the run (in run order, whichever shard this is), so that merged shards can be checked
/// to come from one sweep and to be complete.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// The technique settings run on each scene, in order (`technique [settings]`): shards of
    /// one sweep share it.
    pub settings: Vec<String>,
    /// This folder's shard, `I/N` (`0/1`: the whole run).
    pub shard: String,
    /// The scenes.
    pub scenes: Vec<SceneInfo>,
    /// The runs (by index) whose technique does not work on their scene
    /// ([`crate::shadow::TechniqueInfo::applies`]): left out, not missing.
    #[serde(default)]
    pub skipped: Vec<usize>,
}

fn write(dir: &Path, name: &str, body: &str, files: &mut Vec<PathBuf>) -> Result<(), Error> {
    let path = dir.join(name);
    write_plain(&path, body.as_bytes())?;
    files.push(path);
    Ok(())
}

/// Largest file read from a shard's folder: a whole sweep's results.csv is about 1 MB, an
/// image a few MB.
pub const MAX_SHARD_FILE: u64 = 256 << 20;

/// Reads a file of a sweep's folder: a regular file of at most `limit` bytes, never through a
/// symbolic link (a shard's link could name any file on the machine), and never a FIFO or
/// device (refused before it is opened: a read would hang or never end).
pub fn read_plain(path: &Path, what: &str, limit: u64) -> Result<Vec<u8>, Error> {
    crate::scene::file::read_unlinked(path, what, limit)
}

pub use crate::output::{create_folder, write_plain};

impl Manifest {
    /// The run list's length (all shards together): every setting on every scene.
    pub fn runs(&self) -> usize {
        self.scenes.len() * self.settings.len()
    }
}

/// Writes a sweep's data (`results.csv`, `sweep.json`): what a shard writes and a merge reads.
pub fn write_sweep_data(dir: &Path, results: &[RunResult], manifest: &Manifest) -> Result<Vec<PathBuf>, Error> {
    create_folder(dir)?;
    let mut files = Vec::new();
    write(dir, "results.csv", &csv::csv(results), &mut files)?;
    let json = serde_json::to_string_pretty(manifest).map_err(|e| Error::input(e.to_string()))?;
    write(dir, "sweep.json", &json, &mut files)?;
    Ok(files)
}

/// Reads what [`write_sweep_data`] wrote in `dir` (regular files only, never through links:
/// [`read_plain`]).
pub fn read_sweep_data(dir: &Path) -> Result<(Vec<RunResult>, Manifest), Error> {
    let read = |name: &str| -> Result<(String, String), Error> {
        let path = dir.join(name);
        let shown = path.display().to_string();
        let bytes = read_plain(&path, &format!("a sweep's {name}"), MAX_SHARD_FILE).map_err(|e| {
            let hint = format!(" (is {} a sweep's output folder?)", dir.display());
            match e {
                Error::Io { path, message } => Error::Io {
                    path,
                    message: message + &hint,
                },
                e => e,
            }
        })?;
        String::from_utf8(bytes)
            .map(|t| (t, shown.clone()))
            .map_err(|_| Error::input(format!("{shown}: not UTF-8 text")))
    };
    let (text, shown) = read("results.csv")?;
    let results = csv::read_csv(&text, &shown)?;
    let (text, shown) = read("sweep.json")?;
    let manifest: Manifest =
        serde_json::from_str(&text).map_err(|e| Error::input(format!("{shown}:{}: {e}", e.line())))?;
    Ok((results, manifest))
}

/// Writes everything a sweep shows from its results: the data ([`write_sweep_data`]), one
/// chart per scene class and per scene, `summary.md` (the README's technique table: one row
/// per technique), `summary_all.md` (every setting: docs/techniques.md's table),
/// `report.md` and `report.html`. Images are the runs' own ([`write_run`], in `images/`);
/// `explore(file, r)` is the command line the page offers for opening a run (the caller's).
pub fn write_sweep(
    dir: &Path,
    results: &[RunResult],
    manifest: &Manifest,
    explore: &dyn Fn(&str, &RunResult) -> Option<String>,
) -> Result<Vec<PathBuf>, Error> {
    let mut files = write_sweep_data(dir, results, manifest)?;
    for c in SceneClass::ALL {
        let rs: Vec<RunResult> = results.iter().filter(|r| r.class == c).cloned().collect();
        if !rs.is_empty() {
            let svg = chart::class_chart_svg(&format!("{}: time vs {}", c.title(), c.metric()), c, &rs);
            write(dir, &format!("chart_{}.svg", c.key()), &svg, &mut files)?;
        }
    }
    let charts = dir.join("charts");
    create_folder(&charts)?;
    for s in &manifest.scenes {
        let rs: Vec<RunResult> = results.iter().filter(|r| r.scene == s.name).cloned().collect();
        let svg = chart::class_chart_svg(&format!("{}: time vs {}", s.name, s.class.metric()), s.class, &rs);
        write(&charts, &format!("{}.svg", file_safe(&s.name)), &svg, &mut files)?;
    }
    let thumb = |r: &RunResult| format!("images/{}.png", stem(&r.scene, &r.label()));
    let path_chart = |r: &RunResult| {
        r.counted_path
            .then(|| format!("images/{}_path.svg", stem(&r.scene, &r.label())))
    };
    let scene_list: Vec<(String, String)> = manifest
        .scenes
        .iter()
        .map(|s| (s.name.clone(), s.description.clone()))
        .collect();
    let md = markdown::report_markdown(results, &scene_list, &|r| Some(thumb(r)), &path_chart);
    write(dir, "report.md", &md, &mut files)?;
    write(
        dir,
        "summary.md",
        &markdown::summary_markdown(results, markdown::Rows::PerTechnique),
        &mut files,
    )?;
    write(
        dir,
        "summary_all.md",
        &markdown::summary_markdown(results, markdown::Rows::PerSetting),
        &mut files,
    )?;
    let images = |r: &RunResult| {
        let s = stem(&r.scene, &r.label());
        Some(["_visibility", "_reference", "_error"].map(|k| format!("images/{s}{k}.png")))
    };
    let html = super::html::report_html(results, &manifest.scenes, &images, &path_chart, explore);
    write(dir, "report.html", &html, &mut files)?;
    Ok(files)
}

/// The file stem of a run: `scene_label`, both file-safe ([`file_safe`]): the stem names
/// files and stands in the reports' image links, so nothing of a scene's or a label's name
/// reaches either as written (a scene file named `<img src=x onerror=alert(1)>.toml`, a `|`
/// or a `javascript:` made live HTML, a link or a broken row of `report.md`).
pub fn stem(scene: &str, label: &str) -> String {
    format!("{}_{}", file_safe(scene), file_safe(label))
}

/// Writes the images of `r` (and its path's CSV and chart) into `dir`; returns the files.
pub fn write_run(dir: &Path, r: &RenderOutput) -> Result<Vec<PathBuf>, Error> {
    let stem = stem(&r.result.scene, &r.result.label());
    let f = &r.first;
    let (w, h) = (f.width, f.height);
    let mut files = Vec::new();
    create_folder(dir)?;
    for (suffix, img) in [
        ("", f.shaded.clone()),
        ("_visibility", images::visibility_image(&f.visibility, w, h)),
        (
            "_error",
            images::error_image(&f.visibility, &f.reference, &f.mask, w, h),
        ),
        ("_reference", images::visibility_image(&f.reference, w, h)),
    ] {
        let path = dir.join(format!("{stem}{suffix}.png"));
        let png = encode_png(&img).map_err(|e| Error::io(&path, "cannot write", e))?;
        write_plain(&path, &png)?;
        files.push(path);
    }
    if r.path.len() > 1 {
        let title = format!("{}: {} along the camera path", r.result.scene, r.result.label());
        for (suffix, body) in [
            ("_path.csv", csv::path_csv(&r.path)),
            ("_path.svg", chart::path_chart_svg(&title, &r.path)),
        ] {
            let file = dir.join(format!("{stem}{suffix}"));
            write_plain(&file, body.as_bytes())?;
            files.push(file);
        }
    }
    Ok(files)
}
