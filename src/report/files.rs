//! A run's files in a folder: the shaded image, visibility, error and reference (PNG) and,
//! for camera paths, the path's CSV and chart.

use super::{chart, csv, file_safe, images};
use crate::image_io::write_png;
use crate::run::RenderOutput;
use std::path::{Path, PathBuf};

/// The file stem of a run: `scene_label`, file-safe.
pub fn stem(scene: &str, label: &str) -> String {
    format!("{scene}_{}", file_safe(label))
}

/// Writes the images of `r` (and its path's CSV and chart) into `dir`; returns the files.
pub fn write_run(dir: &Path, r: &RenderOutput) -> Result<Vec<PathBuf>, String> {
    let stem = stem(&r.result.scene, &r.result.label());
    let f = &r.first;
    let (w, h) = (f.width, f.height);
    let mut files = Vec::new();
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
        write_png(&path, &img)?;
        files.push(path);
    }
    if r.path.len() > 1 {
        let title = format!("{}: {} along the camera path", r.result.scene, r.result.label());
        for (suffix, body) in [
            ("_path.csv", csv::path_csv(&r.path)),
            ("_path.svg", chart::path_chart_svg(&title, &r.path)),
        ] {
            let file = dir.join(format!("{stem}{suffix}"));
            std::fs::write(&file, body).map_err(|e| format!("cannot write {}: {e}", file.display()))?;
            files.push(file);
        }
    }
    Ok(files)
}
