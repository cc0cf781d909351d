//! Draws triangles with the software GPU into a depth buffer and reads the depth back: the
//! pipeline alone, without scenes or shadows.
//!
//! `cargo run --release --example draw_triangles -- out/depth.png`

use glam::{Mat4, Vec3};
use penumbra::image_io;
use penumbra::pipeline::*;
use penumbra::Error;
use std::path::Path;

fn main() -> Result<(), Error> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "out/draw_triangles.png".into());
    let p = Pipeline::new(0)?;
    let mut depth = Surface::new(256, 256, 1.0f32)?;
    // Two overlapping triangles at different heights, seen from above.
    let positions = [
        Vec3::new(-1.5, 0.0, -1.5),
        Vec3::new(1.5, 0.0, -1.5),
        Vec3::new(0.0, 0.0, 1.5),
        Vec3::new(-1.0, 1.0, 1.0),
        Vec3::new(0.0, 1.0, -1.0),
        Vec3::new(1.0, 1.0, 1.0),
    ];
    let indices = [0, 1, 2, 3, 4, 5];
    let view_proj = Mat4::orthographic_rh(-2.0, 2.0, -2.0, 2.0, 0.1, 10.0)
        * Mat4::look_at_rh(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, Vec3::Z);
    let state = RenderState::default(); // depth test Less, no culling
    let stats = p.draw(
        &mut Targets::depth_only(&mut depth),
        &state,
        &positions,
        &indices,
        &TransformPositions(view_proj),
        &DepthOnly,
    )?;
    // Read back: the centre pixel sees the upper triangle (nearer the eye, smaller depth).
    let centre = depth.get(128, 128).unwrap_or(f32::NAN);
    let covered = depth.data().iter().filter(|&&d| d < 1.0).count();
    println!(
        "{} fragments rasterized, {} of {} pixels covered, depth at the centre {centre:.4}",
        stats.fragments_rasterized,
        covered,
        depth.data().len()
    );
    image_io::write_png(Path::new(&out), &image_io::grey(&depth, 0.0, 1.0))?;
    println!("wrote {out}");
    Ok(())
}
