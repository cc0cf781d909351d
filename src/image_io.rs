//! Writing surfaces to image files (PNG).

use crate::pipeline::{Rgba8, Surface};
use std::path::Path;

/// Writes an RGBA8 surface as a PNG (row 0 at the top). Creates the parent folder.
pub fn write_png(path: &Path, s: &Surface<Rgba8>) -> Result<(), String> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).map_err(|e| format!("cannot create folder {}: {e}", dir.display()))?;
        }
    }
    let bytes: Vec<u8> = s.data().iter().flat_map(|p| p.iter().copied()).collect();
    image::save_buffer(path, &bytes, s.width(), s.height(), image::ColorType::Rgba8)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// A grey-scale view of a float surface mapped from `[lo, hi]` to black..white.
pub fn grey(s: &Surface<f32>, lo: f32, hi: f32) -> Surface<Rgba8> {
    let k = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
    s.map(|v| {
        let g = (((v - lo) * k).clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        [g, g, g, 255]
    })
}
