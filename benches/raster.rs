//! Criterion benchmarks of the pipeline: the spheres frame per mode and triangle count, and
//! random triangles per size, depth-only and colour + depth; shadow techniques on the spheres
//! scene; the volumetric techniques on the smoke scene; the screen-space family on spheres and
//! terrain. Throughput is reported in triangles (elements) per second; pixels/s are printed by
//! `penumbra bench raster`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use penumbra::bench::*;
use penumbra::pipeline::*;

/// Worker threads from `PENUMBRA_THREADS` (0: all cores). Every group starts here, so this is
/// also where the CLI's allocation policy is set: without it the large per-call buffers are
/// returned to the kernel and page-faulted back in on every iteration.
fn threads() -> usize {
    penumbra::alloc::keep_freed_memory();
    std::env::var("PENUMBRA_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

fn spheres(c: &mut Criterion) {
    let p = Pipeline::new(threads()).unwrap();
    let mut g = c.benchmark_group(format!("spheres_frame_{}t", p.threads()));
    g.sample_size(10);
    for t in [10_000usize, 100_000] {
        let mesh = spheres_scene(t);
        let setup = frame_setup(&mesh, 1920, 1080);
        let mut targets = FrameTargets::new(2048, 1920, 1080).unwrap();
        g.throughput(Throughput::Elements(mesh.triangles() as u64));
        for mode in [FrameMode::Depth, FrameMode::Pcf2, FrameMode::Pcf5] {
            g.bench_with_input(BenchmarkId::new(format!("{mode:?}"), t), &t, |b, _| {
                b.iter(|| render_frame(&p, &mesh, &setup, mode, &mut targets).unwrap())
            });
        }
        // The camera pass without hidden surface removal before shading, for comparison.
        let immediate = FrameSetup {
            shading: Shading::Immediate,
            ..setup
        };
        g.bench_with_input(BenchmarkId::new("Pcf2_immediate", t), &t, |b, _| {
            b.iter(|| render_frame(&p, &mesh, &immediate, FrameMode::Pcf2, &mut targets).unwrap())
        });
    }
    g.finish();
}

fn random(c: &mut Criterion) {
    let p = Pipeline::new(threads()).unwrap();
    let mut g = c.benchmark_group(format!("random_triangles_{}t", p.threads()));
    g.sample_size(10);
    let mut color = Surface::new(1920, 1080, [0u8; 4]).unwrap();
    let mut depth = Surface::new(1920, 1080, 1.0f32).unwrap();
    for (n, area) in [(100_000usize, 50.0f32), (20_000, 1000.0), (2_000, 20_000.0)] {
        let (verts, idx) = random_triangles(n, area, 1920, 1080, 1);
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::new("depth", area), &area, |b, _| {
            b.iter(|| draw_random(&p, None, &mut depth, &RenderState::default(), &verts, &idx).unwrap())
        });
        for (name, shading) in [("color", Shading::Deferred), ("color_immediate", Shading::Immediate)] {
            let state = RenderState {
                shading,
                ..Default::default()
            };
            g.bench_with_input(BenchmarkId::new(name, area), &area, |b, _| {
                b.iter(|| draw_random(&p, Some(&mut color), &mut depth, &state, &verts, &idx).unwrap())
            });
        }
    }
    g.finish();
}

/// Shadow techniques on the spheres scene (100k triangles, 1920x1080): shadow volumes whole
/// and their silhouette extraction alone, the shadow map, the irregular z-buffer (1 and 4
/// samples per pixel), the volumetric techniques (opaque casters only here: their light
/// passes and lookups at full size) and the reference's hard visibility.
fn techniques(c: &mut Criterion) {
    use penumbra::shadow::{self, volume::silhouette};
    let p = Pipeline::new(threads()).unwrap();
    let mut g = c.benchmark_group(format!("spheres_techniques_{}t", p.threads()));
    g.sample_size(10);
    let scene = spheres_as_scene(100_000);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    g.throughput(Throughput::Elements(scene.triangles() as u64));
    let light = (-f.light.direction).extend(0.0);
    g.bench_function("silhouettes", |b| {
        b.iter(|| {
            scene
                .objects
                .iter()
                .map(|o| {
                    silhouette::volume(&o.mesh, &silhouette::Adjacency::new(&o.mesh), light)
                        .indices
                        .len()
                })
                .sum::<usize>()
        })
    });
    let izb4 = vec![("samples".to_string(), "4".to_string())];
    for (id, name, sets) in [
        ("shadow-volume", "shadow-volume", vec![]),
        ("shadow-map", "shadow-map", vec![]),
        ("csm", "csm", vec![]),
        ("sdsm", "sdsm", vec![]),
        ("lispsm", "lispsm", vec![]),
        ("tsm", "tsm", vec![]),
        ("psm", "psm", vec![]),
        ("logpsm", "logpsm", vec![]),
        ("izb", "izb", vec![]),
        ("izb-4spp", "izb", izb4),
        ("avsm", "avsm", vec![]),
        ("transparency-map", "transparency-map", vec![]),
        ("opacity-maps", "opacity-maps", vec![]),
        ("deep-shadow-map", "deep-shadow-map", vec![]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    // The reference's hard visibility of the same pixels (the third way to exact hard shadows).
    let mut r = shadow::registry::create("reference", &[("area".into(), "false".into())]).unwrap();
    g.bench_function("reference-hard", |b| b.iter(|| r.visibility(&p, &f).unwrap()));
    g.finish();
}

/// The volumetric techniques on `smoke` (300 semi-transparent billboards) at 1920x1080 with
/// 1024² light maps: AVSM with 8 nodes, opacity maps with 16 slices, the deep shadow map and
/// the coloured transparency map. Throughput in fragments through the light pass.
fn volumetric(c: &mut Criterion) {
    use penumbra::shadow;
    let p = Pipeline::new(threads()).unwrap();
    let mut g = c.benchmark_group(format!("smoke_techniques_{}t", p.threads()));
    g.sample_size(10);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes/smoke.toml");
    let mut scene = penumbra::scene::file::load(&path).unwrap();
    (scene.camera.width, scene.camera.height) = (1920, 1080);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    let size = || ("size".to_string(), "1024".to_string());
    for (id, name, sets) in [
        ("avsm-8", "avsm", vec![size()]),
        ("opacity-maps-16", "opacity-maps", vec![size()]),
        ("deep-shadow-map", "deep-shadow-map", vec![size()]),
        ("transparency-map", "transparency-map", vec![size()]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        t.visibility(&p, &f).unwrap();
        let frags = t
            .counters()
            .iter()
            .find(|(n, _)| n.starts_with("fragments"))
            .map_or(0, |c| c.1 as u64);
        g.throughput(Throughput::Elements(frags.max(1)));
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    g.finish();
}

/// Soft shadows from one map on the spheres scene (a 2-degree sun for PCSS and CHS; 2048²
/// maps), against the 2x2 and 5x5 PCF maps; and on `pergola` at 1920x1080 under its
/// rectangle light, with the multi-sample area light as the baseline, the IZB/PCSS hybrid and
/// the penumbra volumes; and the penumbra volumes on `contact` at 1920x1080.
fn soft(c: &mut Criterion) {
    use penumbra::shadow;
    let p = Pipeline::new(threads()).unwrap();
    let kv = |k: &str, v: &str| (k.to_string(), v.to_string());
    let mut g = c.benchmark_group(format!("spheres_soft_{}t", p.threads()));
    g.sample_size(10);
    let scene = spheres_as_scene(100_000);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    for (id, name, sets) in [
        ("pcf2", "shadow-map", vec![kv("filter", "pcf2")]),
        ("pcf-grid-5", "shadow-map", vec![kv("filter", "grid")]),
        ("pcss", "pcss", vec![kv("angle", "2")]),
        (
            "pcss-hierarchy",
            "pcss",
            vec![kv("angle", "2"), kv("hierarchy", "true")],
        ),
        ("chs", "chs", vec![kv("angle", "2")]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    g.finish();
    let mut g = c.benchmark_group(format!("pergola_soft_{}t", p.threads()));
    g.sample_size(10);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes/pergola.toml");
    let mut scene = penumbra::scene::file::load(&path).unwrap();
    (scene.camera.width, scene.camera.height) = (1920, 1080);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    for (id, name, sets) in [
        ("pcf2", "shadow-map", vec![kv("filter", "pcf2")]),
        ("pcss", "pcss", vec![]),
        ("chs", "chs", vec![]),
        ("multi-sample-16", "multi-sample", vec![kv("size", "512")]),
        ("multi-sample-16-volumes", "multi-sample", vec![kv("method", "volumes")]),
        ("hybrid", "hybrid", vec![]),
        ("pvm", "pvm", vec![]),
        ("pvmf", "pvmf", vec![]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    g.finish();
    // Penumbra volumes where most pixels are outside every penumbra: contact at 1920x1080,
    // against PCSS with PVMF's 49 filter taps.
    let mut g = c.benchmark_group(format!("contact_soft_{}t", p.threads()));
    g.sample_size(10);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes/contact.toml");
    let mut scene = penumbra::scene::file::load(&path).unwrap();
    (scene.camera.width, scene.camera.height) = (1920, 1080);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    for (id, name, sets) in [
        ("pcss-49", "pcss", vec![kv("taps", "49")]),
        ("pvm", "pvm", vec![]),
        ("pvmf", "pvmf", vec![]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    g.finish();
}

/// Screen-space shadows on the spheres scene at 1920x1080 (16 and 32 steps, and the shadow
/// map with the contact march, against the plain map), and terrain occlusion height on
/// `terrain` at 1920x1080 with a 512² grid (build and lookup).
fn screen(c: &mut Criterion) {
    use penumbra::shadow;
    let p = Pipeline::new(threads()).unwrap();
    let kv = |k: &str, v: &str| (k.to_string(), v.to_string());
    let mut g = c.benchmark_group(format!("spheres_screen_{}t", p.threads()));
    g.sample_size(10);
    let scene = spheres_as_scene(100_000);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    g.throughput(Throughput::Elements(u64::from(f.width() * f.height())));
    for (id, name, sets) in [
        ("shadow-map", "shadow-map", vec![]),
        ("screen-space-16", "screen-space", vec![]),
        ("screen-space-32", "screen-space", vec![kv("steps", "32")]),
        ("contact-map", "contact-map", vec![]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    g.finish();
    let mut g = c.benchmark_group(format!("terrain_screen_{}t", p.threads()));
    g.sample_size(10);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes/terrain.toml");
    let mut scene = penumbra::scene::file::load(&path).unwrap();
    (scene.camera.width, scene.camera.height) = (1920, 1080);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    for (id, name, sets) in [
        ("shadow-map", "shadow-map", vec![]),
        ("terrain-height-512", "terrain-height", vec![]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    g.finish();
}

/// Filtered shadow maps on the spheres scene at 1920x1080 with a 2048² map (the issue's
/// speed setting): VSM with its 9x9 Gaussian, the summed-area VSM, ESM, EVSM, MSM and the
/// convolution map, against the plain map; and the prefilter alone (a 9x9 separable
/// Gaussian of a 2048² two-moment map, and its summed-area table).
fn filtered(c: &mut Criterion) {
    use penumbra::pipeline::compute::{gaussian_weights, separable_blur, summed_area_table};
    use penumbra::shadow;
    let p = Pipeline::new(threads()).unwrap();
    let kv = |k: &str, v: &str| (k.to_string(), v.to_string());
    let mut g = c.benchmark_group(format!("spheres_filtered_{}t", p.threads()));
    g.sample_size(10);
    let scene = spheres_as_scene(100_000);
    let f = penumbra::frame::frame(&p, &scene, 0, 0).unwrap();
    g.throughput(Throughput::Elements(u64::from(f.width() * f.height())));
    let size = || kv("size", "2048");
    for (id, name, sets) in [
        ("shadow-map", "shadow-map", vec![]),
        ("vsm-gaussian9", "vsm", vec![size()]),
        ("vsm-sat", "vsm", vec![size(), kv("prefilter", "sat")]),
        ("esm", "esm", vec![size()]),
        ("evsm", "evsm", vec![size()]),
        ("msm", "msm", vec![size()]),
        ("convolution-8", "convolution", vec![size()]),
    ] {
        let mut t = shadow::registry::create(name, &sets).unwrap();
        g.bench_function(id, |b| b.iter(|| t.visibility(&p, &f).unwrap()));
    }
    g.finish();
    let mut g = c.benchmark_group(format!("prefilter_2048_{}t", p.threads()));
    g.sample_size(10);
    let map = Surface::new(2048, 2048, glam::Vec4::new(0.5, 0.25, 0.0, 0.0)).unwrap();
    g.throughput(Throughput::Elements(2048 * 2048));
    let w = gaussian_weights(4);
    g.bench_function("gaussian9", |b| b.iter(|| separable_blur(&p, &map, &w).unwrap()));
    g.bench_function("sat-f64", |b| b.iter(|| summed_area_table(&p, &map)));
    g.finish();
}

/// The spheres frame's light pass (100k triangles, a 2048² map): the standard raster mode
/// against draws at sample tables (pixel centres; rows on a logarithm, LogPSM's table).
fn samples(c: &mut Criterion) {
    use penumbra::pipeline::samples::SampleGrid;
    let p = Pipeline::new(threads()).unwrap();
    let mut g = c.benchmark_group(format!("samples_{}t", p.threads()));
    g.sample_size(10);
    let mesh = spheres_scene(100_000);
    let setup = frame_setup(&mesh, 1920, 1080);
    let mut targets = FrameTargets::new(2048, 1920, 1080).unwrap();
    g.bench_function("standard", |b| {
        b.iter(|| render_frame(&p, &mesh, &setup, FrameMode::Depth, &mut targets).unwrap())
    });
    let mut depth = Surface::new(2048, 2048, 1.0f32).unwrap();
    let uniform = SampleGrid::uniform(2048, 2048).unwrap();
    g.bench_function("uniform_table", |b| {
        b.iter(|| depth_pass_at(&p, &mesh, &setup, &uniform, &mut depth).unwrap())
    });
    let rows: Vec<f64> = (0..2048)
        .map(|j| 2048.0 * ((1.0f64 + 255.0).powf((j as f64 + 0.5) / 2048.0) - 1.0) / 255.0)
        .collect();
    let log = SampleGrid::rows(2048, &rows).unwrap();
    g.bench_function("log_rows", |b| {
        b.iter(|| depth_pass_at(&p, &mesh, &setup, &log, &mut depth).unwrap())
    });
    g.finish();
}

criterion_group!(benches, spheres, random, techniques, volumetric, soft, screen, filtered, samples);
criterion_main!(benches);
