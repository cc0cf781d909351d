//! Runs one technique on a scene and saves every intermediate buffer it lists (its stages),
//! the way `penumbra dump` does: the shadow map, the IZB's list lengths, AVSM's nodes...
//!
//! `cargo run --release --example technique_stages -- fixtures/scenes/wires.toml izb out/stages`

use penumbra::pipeline::Pipeline;
use penumbra::shadow::Stage;
use penumbra::Error;
use penumbra::{frame, image_io, report, scene, shadow};
use std::path::Path;

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().collect();
    let scene_path = args.get(1).map_or("fixtures/scenes/wires.toml", String::as_str);
    let technique = args.get(2).map_or("izb", String::as_str);
    let out = Path::new(args.get(3).map_or("out/stages", String::as_str));

    let scene = scene::file::load(Path::new(scene_path))?;
    let p = Pipeline::new(0)?;
    let f = frame::frame(&p, &scene, 0, 0)?;
    let mut t = shadow::registry::create(technique, &[])?;
    t.visibility(&p, &f)?;
    for (pass, ms) in t.timings() {
        println!("pass {pass:<24} {ms:.3} ms");
    }
    for (name, value) in t.counters() {
        println!("counter {name:<21} {value}");
    }
    for stage in t.stages(&p, &f)? {
        let path = out.join(format!("{}.png", report::file_safe(stage.name())));
        match &stage {
            Stage::Scalar { data, lo, hi, .. } => image_io::write_png(&path, &image_io::grey(data, *lo, *hi))?,
            Stage::Color { data, .. } => image_io::write_png(&path, data)?,
        }
        println!("wrote {}", path.display());
    }
    Ok(())
}
