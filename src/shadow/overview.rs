//! Drawing helpers for the overview stages of `dump` (frusta, silhouettes, lists over the
//! camera view): segments in 2D and in world space, and a grey backdrop of the view.

use crate::frame::Frame;
use crate::pipeline::{Rgba8, Surface};

/// Draws the 2D segment `a`-`b` (pixel coordinates) into `img`, clipped to its bounds: for
/// overview stages (frusta, silhouettes).
pub fn draw_segment(img: &mut Surface<Rgba8>, a: glam::Vec2, b: glam::Vec2, color: Rgba8) {
    let (w, h) = (img.width() as f32, img.height() as f32);
    // Clip the parameter range to the image (Liang-Barsky), so huge segments cost nothing.
    let d = b - a;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for (p, q) in [(-d.x, a.x), (d.x, w - a.x), (-d.y, a.y), (d.y, h - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    // Also rejects NaN ends.
    if t0.partial_cmp(&t1).is_none_or(|o| o.is_gt()) {
        return;
    }
    let (a, b) = (a + d * t0, a + d * t1);
    let steps = ((b - a).abs().max_element().ceil() as u32).max(1) * 2;
    for k in 0..=steps {
        let q = a + (b - a) * (k as f32 / steps as f32);
        if q.x >= 0.0 && q.y >= 0.0 && q.x < w && q.y < h {
            img.set(q.x as u32, q.y as u32, color);
        }
    }
}

/// Draws the world segment `a`-`b` as the camera of `frame` sees it, clipped to the near
/// plane.
pub fn draw_world_segment(img: &mut Surface<Rgba8>, frame: &Frame, a: glam::Vec3, b: glam::Vec3, color: Rgba8) {
    let vp = frame.camera.view_projection();
    let (mut ca, mut cb) = (vp * a.extend(1.0), vp * b.extend(1.0));
    // Clip to z >= 0 (the near plane of a [0, 1] depth range).
    let (da, db) = (ca.z, cb.z);
    if da < 0.0 && db < 0.0 {
        return;
    }
    if da < 0.0 {
        ca = ca + (cb - ca) * (da / (da - db));
    } else if db < 0.0 {
        cb = cb + (ca - cb) * (db / (db - da));
    }
    let (w, h) = (img.width() as f32, img.height() as f32);
    let to_px = |c: glam::Vec4| {
        let n = c.truncate() / c.w.max(1e-12);
        glam::Vec2::new((n.x * 0.5 + 0.5) * w, (0.5 - n.y * 0.5) * h)
    };
    draw_segment(img, to_px(ca), to_px(cb), color);
}

/// A grey, light-independent picture of the camera view (normals facing the camera bright),
/// the backdrop that overview stages draw on.
pub fn backdrop(frame: &Frame) -> Surface<Rgba8> {
    let eye = frame.camera.position;
    let mut img = frame.gbuffer.normal.map(|_| [30, 30, 40, 255]);
    for (o, px) in frame.points().iter().zip(img.data_mut()) {
        if let Some(s) = o {
            let g = (40.0 + 120.0 * s.normal.dot((eye - s.position).normalize_or_zero()).abs()) as u8;
            *px = [g, g, g, 255];
        }
    }
    img
}
