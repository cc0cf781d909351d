//! Renders a scene file with one shadow technique into a PNG and compares it with the
//! ray-traced reference.
//!
//! `cargo run --release --example render_scene -- fixtures/scenes/contact.toml pcss out/contact_pcss.png`

use penumbra::pipeline::Pipeline;
use penumbra::reference::{Reference, ReferenceOptions};
use penumbra::Error;
use penumbra::{frame, image_io, metrics, scene, shadow};
use std::path::Path;

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().collect();
    let scene_path = args.get(1).map_or("fixtures/scenes/contact.toml", String::as_str);
    let technique = args.get(2).map_or("shadow-map", String::as_str);
    let out = args.get(3).map_or("out/render_scene.png", String::as_str);

    // Scene -> camera G-buffer (the frame) -> the technique's visibility -> shaded image.
    let scene = scene::file::load(Path::new(scene_path))?;
    let p = Pipeline::new(0)?;
    let f = frame::frame(&p, &scene, 0, 0)?;
    let mut t = shadow::registry::create(technique, &[])?;
    let v = t.visibility(&p, &f)?;
    image_io::write_png(Path::new(out), &frame::shade(&f, &v))?;

    // The same pixels by the ray tracer, and the errors against it.
    let r = p.install(|| Reference::new(&scene));
    let reference = p.install(|| r.visibility(f.points(), f.width() as usize, &f.light, &ReferenceOptions::default()));
    let e = metrics::compare(&v, &reference, &f.metric_mask());
    println!(
        "{technique} on {}: RMSE {:.4}, wrong {:.3} %, penumbra RMSE {:.4}; wrote {out}",
        scene.name, e.rmse, e.wrong_pct, e.penumbra_rmse
    );
    Ok(())
}
