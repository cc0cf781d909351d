//! `penumbra bench ...`: the spheres frame, random triangles, the reference's rays and a
//! technique on the spheres scene (or a scene file), with per-stage times, counters and a JSON
//! line.

use super::{FrameArgs, RasterArgs, RaysArgs, TechniqueArgs};
use crate::error::CliError;
use penumbra::bench::*;
use penumbra::hash::{hash_f32, hash_rgba8};
use penumbra::image_io::{grey, write_png};
use penumbra::pipeline::*;
use serde_json::json;
use std::time::Instant;

/// Largest `--triangles` of the benchmarks: a workload a 2-core machine builds and draws in
/// seconds and a few GB.
/// (Checked as `--triangles` is parsed.)
pub const MAX_BENCH_TRIANGLES: usize = 10_000_000;

pub fn frame(a: FrameArgs) -> Result<(), CliError> {
    let p = Pipeline::new(a.common.threads)?;
    let mesh = spheres_scene(a.triangles);
    let setup = FrameSetup {
        shading: a.shading,
        camera_cull: a.cull,
        ..frame_setup(&mesh, a.width, a.height)
    };
    let mut t = FrameTargets::new(a.map, a.width, a.height)?;
    if let Some(dir) = &a.export {
        export_frame(dir, &mesh, &setup, a.mode, a.map, (a.width, a.height))?;
        println!("wrote the workload into {}", dir.display());
    }
    let (stacks, slices) = sphere_tessellation(a.triangles);
    println!(
        "spheres frame: {} triangles (spheres {stacks} stacks x {slices} slices), map {}x{}, image {}x{}, mode {:?}, {} threads",
        mesh.triangles(),
        a.map,
        a.map,
        a.width,
        a.height,
        a.mode,
        p.threads()
    );
    for _ in 0..2 {
        render_frame(&p, &mesh, &setup, a.mode, &mut t)?;
    }
    let mut depth = Vec::new();
    let mut main = Vec::new();
    let mut prefilter = Vec::new();
    let mut frame = Vec::new();
    let mut last = FrameTimes::default();
    let (mut depth_st, mut main_st) = (StageTimes::default(), StageTimes::default());
    for _ in 0..a.common.reps.max(1) {
        let t0 = Instant::now();
        last = render_frame(&p, &mesh, &setup, a.mode, &mut t)?;
        frame.push(t0.elapsed().as_secs_f64() * 1e3);
        depth.push(last.ms_depth);
        main.push(last.ms_main);
        prefilter.push(last.ms_prefilter);
        depth_st += last.depth_stages;
        main_st += last.main_stages;
    }
    let (md, mm, mf) = (median(&mut depth), median(&mut main), median(&mut frame));
    let mp = median(&mut prefilter);
    let hash = frame_hash(&t, a.mode);
    let tris = mesh.triangles() as f64;
    println!(
        "depth pass: {md:8.2} ms  {:7.2} Mtri/s  {:6.3} Gpix/s  ({} fragments, {} bin entries)",
        tris / md / 1e3,
        last.depth_stats.fragments_rasterized as f64 / md / 1e6,
        last.depth_stats.fragments_rasterized,
        last.depth_stats.bin_entries
    );
    if a.mode == FrameMode::Vsm {
        let texels = (a.map as f64) * (a.map as f64);
        println!(
            "prefilter:  {mp:8.2} ms  {:6.3} Gtexel/s  (moments and a 5x5 box blur of {}x{} texels)",
            texels / mp / 1e6,
            a.map,
            a.map
        );
    }
    if a.mode != FrameMode::Depth {
        println!(
            "main pass:  {mm:8.2} ms  {:7.2} Mtri/s  {:6.3} Gpix/s  ({} fragments, {} early-z killed, {} hidden before shading, {} shaded)",
            tris / mm / 1e3,
            last.main_stats.fragments_rasterized as f64 / mm / 1e6,
            last.main_stats.fragments_rasterized,
            last.main_stats.early_z_killed,
            last.main_stats.fragments_hidden,
            last.main_stats.fragments_shaded
        );
    }
    println!("frame:      {mf:8.2} ms (median of {})", frame.len());
    print!("depth pass ");
    print_stage_times(&depth_st);
    if a.mode != FrameMode::Depth {
        print!("main pass  ");
        print_stage_times(&main_st);
    }
    println!("hash:       {hash:016x}");
    if let Some(dir) = &a.out {
        if a.mode != FrameMode::Depth {
            write_png(&dir.join("spheres.png"), &t.color)?;
        }
        write_png(&dir.join("spheres_shadow_map.png"), &grey(&t.shadow, 0.0, 1.0))?;
        println!("wrote {}", dir.join("spheres.png").display());
    }
    if a.common.json {
        let j = json!({
            "triangles": mesh.triangles(),
            "threads": p.threads(),
            "mode": format!("{:?}", a.mode),
            "ms_depth_pass": md,
            "ms_main_pass": mm,
            "ms_prefilter": mp,
            "ms_frame": mf,
            "mtri_per_s_depth": tris / md / 1e3,
            "hash": format!("{hash:016x}"),
        });
        println!("{j}");
    }
    Ok(())
}

pub fn raster(a: RasterArgs) -> Result<(), CliError> {
    // A triangle covers at most the 1920x1080 target; the total fill is bounded too, so that
    // one repetition takes seconds, not hours.
    if !(a.area.is_finite() && a.area > 0.0 && a.area <= 2.1e6) {
        return Err(format!(
            "--area {} is out of range (0, 2.1e6]: the target has 2,073,600 pixels",
            a.area
        )
        .into());
    }
    if a.area as f64 * a.triangles as f64 > 2e10 {
        return Err(format!(
            "--triangles {} of --area {} fill {:.1e} pixels per repetition, beyond 2e10 (minutes on two cores): lower one",
            a.triangles,
            a.area,
            a.area as f64 * a.triangles as f64
        ).into());
    }
    let color_mode = match a.mode.as_str() {
        "color" => true,
        "depth" => false,
        m => return Err(format!("unknown raster mode '{m}' (expected depth or color)").into()),
    };
    let p = Pipeline::new(a.common.threads)?;
    let (w, h) = (1920, 1080);
    let (verts, idx) = random_triangles(a.triangles, a.area, w, h, 1);
    if let Some(dir) = &a.export {
        export_raster(dir, &verts, &idx, color_mode, (w, h))?;
        println!("wrote the workload into {}", dir.display());
    }
    let mut color = Surface::new(w, h, [0u8; 4])?;
    let mut depth = Surface::new(w, h, 1.0f32)?;
    let state = RenderState {
        shading: a.shading,
        ..Default::default()
    };
    let run = |color: &mut Surface<Rgba8>, depth: &mut Surface<f32>| -> Result<DrawStats, CliError> {
        // The clears ride along with the draw (load-op clears, tile by tile, still timed).
        draw_random(&p, color_mode.then_some(color), depth, &state, &verts, &idx).map_err(CliError::from)
    };
    for _ in 0..2 {
        run(&mut color, &mut depth)?;
    }
    let mut times = Vec::new();
    let mut stats = DrawStats::default();
    for _ in 0..a.common.reps.max(1) {
        let t0 = Instant::now();
        stats = run(&mut color, &mut depth)?;
        times.push(t0.elapsed().as_secs_f64());
    }
    let st = p.take_times();
    let s = median(&mut times);
    let mtri = a.triangles as f64 / s / 1e6;
    let gpix = stats.fragments_rasterized as f64 / s / 1e9;
    let hash = if color_mode {
        hash_rgba8(color.data())
    } else {
        hash_f32(depth.data())
    };
    println!(
        "raster {}: {} triangles of ~{} px, {} threads: {:.3} ms, {mtri:.2} Mtri/s, {gpix:.3} Gpix/s ({} fragments), hash {hash:016x}",
        a.mode,
        a.triangles,
        a.area,
        p.threads(),
        s * 1e3,
        stats.fragments_rasterized
    );
    print_stage_times(&st);
    if a.common.json {
        let j = json!({
            "triangles": a.triangles,
            "area": a.area,
            "mode": a.mode.to_string(),
            "threads": p.threads(),
            "ms": s * 1e3,
            "mtri_per_s": mtri,
            "gpix_per_s": gpix,
            "hash": format!("{hash:016x}"),
        });
        println!("{j}");
    }
    Ok(())
}

fn print_stage_times(st: &StageTimes) {
    let per = 1e3 / st.draws.max(1) as f64;
    // Draws that share no vertices run the vertex program inside set-up.
    let vertex = if st.vertex > 0.0 {
        format!("{:.2} ms", st.vertex * per)
    } else {
        "(in set-up)".to_string()
    };
    println!(
        "stages (mean per draw): vertex {vertex}, clip+setup+bin {:.2} ms, raster+fragment {:.2} ms, list merge {:.2} ms",
        st.setup_bin * per,
        st.raster_fragment * per,
        st.list_merge * per
    );
}

/// Writes the triangles and rays of `bench rays` for another tracer (see `--export`).
fn export_rays(
    dir: &std::path::Path,
    scene: &penumbra::scene::Scene,
    rays: &[(glam::Vec3, glam::Vec3, f32)],
    traced: usize,
    occluded: u64,
) -> Result<(), CliError> {
    penumbra::output::create_folder(dir)?;
    let mut tri = Vec::with_capacity(scene.triangles() * 36);
    for o in &scene.objects {
        for t in o.mesh.indices.chunks_exact(3) {
            for &i in t {
                for c in o.mesh.positions[i as usize].to_array() {
                    tri.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
    }
    let mut ray = Vec::with_capacity(rays.len() * 28);
    for (o, d, t) in rays {
        for c in o.to_array().into_iter().chain(d.to_array()).chain([*t]) {
            ray.extend_from_slice(&c.to_le_bytes());
        }
    }
    penumbra::output::write_plain(&dir.join("triangles.f32"), &tri)?;
    penumbra::output::write_plain(&dir.join("rays.f32"), &ray)?;
    let counts = format!(
        "triangles {}\nrays {}\ntraced {traced}\noccluded {occluded}\n",
        scene.triangles(),
        rays.len()
    );
    penumbra::output::write_plain(&dir.join("rays.txt"), counts.as_bytes())?;
    Ok(())
}

pub fn rays(a: RaysArgs) -> Result<(), CliError> {
    use penumbra::reference::{offset_origin, Reference};
    let p = Pipeline::new(a.common.threads)?;
    let scene = spheres_as_scene(a.triangles);
    // The build runs on the benchmark's threads (it is parallel, and the tree is the same for
    // any count); the median of three.
    let mut builds = Vec::new();
    let mut r = None;
    for _ in 0..3 {
        let t0 = Instant::now();
        r = Some(p.install(|| Reference::new(&scene)));
        builds.push(t0.elapsed().as_secs_f64());
    }
    let r = r.expect("built");
    let build = median(&mut builds);
    // The reference's real workload: one shadow ray from every pixel of the camera view (the
    // G-buffer at 1920x1080) towards the light, in pixel order, repeated to `--rays` rays; or,
    // with --random, incoherent rays.
    let light = scene.lights[0];
    let rays: Vec<(glam::Vec3, glam::Vec3, f32)> = if a.random {
        let (lo, hi) = scene.bounds().ok_or("the scene has no geometry")?;
        let mut h = penumbra::hash::SplitMix(1);
        (0..1_000_000)
            .map(|_| {
                let mut u = || h.next_f32();
                let o = lo + (hi - lo) * glam::Vec3::new(u(), u(), u());
                let z = 2.0 * u() - 1.0;
                let phi = std::f32::consts::TAU * u();
                let s = (1.0 - z * z).max(0.0).sqrt();
                (
                    o,
                    glam::Vec3::new(s * penumbra::math::cos(phi), s * penumbra::math::sin(phi), z),
                    f32::INFINITY,
                )
            })
            .collect()
    } else {
        let gb = penumbra::frame::gbuffer(&p, &scene, &scene.camera)?;
        gb.position
            .data()
            .iter()
            .zip(gb.normal.data())
            .zip(gb.object.data())
            .filter(|(_, &o)| o != penumbra::frame::NO_OBJECT)
            .map(|((&p, &n), _)| (offset_origin(p, n), -light.direction, f32::INFINITY))
            .collect()
    };
    if rays.is_empty() {
        return Err("the camera sees no geometry".into());
    }
    let run = || {
        use rayon::prelude::*;
        p.install(|| {
            if a.packets {
                // Consecutive rays (neighbouring pixels) in packets.
                const N: usize = penumbra::reference::bvh::PACKET;
                (0..a.rays.div_ceil(N))
                    .into_par_iter()
                    .with_min_len(4096 / N)
                    .map(|c| {
                        let m = (a.rays - c * N).min(N);
                        let packet: [penumbra::reference::Ray; N] =
                            std::array::from_fn(|k| rays[(c * N + k) % rays.len()]);
                        let mut out = [0.0f32; N];
                        r.transmittance_packet(&packet[..m], &mut out[..m]);
                        out[..m].iter().filter(|&&v| v < 1.0).count() as u64
                    })
                    .sum::<u64>()
            } else {
                (0..a.rays)
                    .into_par_iter()
                    .with_min_len(4096)
                    .map(|i| {
                        let (o, d, t) = rays[i % rays.len()];
                        (r.transmittance(o, d, t) < 1.0) as u64
                    })
                    .sum::<u64>()
            }
        })
    };
    let occluded = run();
    let mut times = Vec::new();
    for _ in 0..a.common.reps.max(1) {
        let t = Instant::now();
        run();
        times.push(t.elapsed().as_secs_f64());
    }
    let s = median(&mut times);
    let mrays = a.rays as f64 / s / 1e6;
    if let Some(dir) = &a.export {
        export_rays(dir, &scene, &rays, a.rays, occluded)?;
    }
    println!(
        "rays: {} triangles (BVH built in {:.1} ms, {:.1} MB), {} {} rays{} in {:.1} ms: {mrays:.2} Mrays/s, {} threads ({:.1} % occluded)",
        scene.triangles(),
        build * 1e3,
        r.bytes() as f64 / 1e6,
        a.rays,
        if a.random { "random" } else { "shadow" },
        if a.packets { " in packets" } else { "" },
        s * 1e3,
        p.threads(),
        100.0 * occluded as f64 / a.rays as f64
    );
    if a.common.json {
        let j = json!({
            "triangles": scene.triangles(),
            "rays": a.rays,
            "threads": p.threads(),
            "mrays_per_s": mrays,
            "packets": a.packets,
            "occluded": occluded,
            "ms_build": build * 1e3,
        });
        println!("{j}");
    }
    Ok(())
}

/// `WIDTHxHEIGHT`, each side in 1..=MAX_RESOLUTION.
fn parse_resolution(s: &str) -> Result<(u32, u32), CliError> {
    let max = penumbra::scene::file::MAX_RESOLUTION;
    let bad = || format!("--resolution '{s}': expected WIDTHxHEIGHT, each side in 1..={max}");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let side = |v: &str| v.trim().parse::<u32>().ok().filter(|v| (1..=max).contains(v));
    Ok((side(w).ok_or_else(bad)?, side(h).ok_or_else(bad)?))
}

pub fn technique(a: TechniqueArgs) -> Result<(), CliError> {
    let sets = penumbra::shadow::registry::parse_sets(&a.sets)?;
    let mut t = penumbra::shadow::registry::create(&a.technique, &sets)?;
    let resolution = a.resolution.as_deref().map(parse_resolution).transpose()?;
    let p = Pipeline::new(a.common.threads)?;
    let mut scene = match &a.scene {
        Some(path) => super::scene::load(path)?.0,
        None => spheres_as_scene(a.triangles),
    };
    if let Some((w, h)) = resolution {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    if let Some(radius) = a.disk {
        if !(radius.is_finite() && radius > 0.0 && radius < 1e6) {
            return Err(format!("--disk {radius}: the radius must be in (0, 1e6)").into());
        }
        let light = scene.lights.first_mut().ok_or("the scene has no light to replace")?;
        light.kind = penumbra::scene::LightKind::Area(penumbra::scene::AreaShape::Disk { radius });
    }
    let f = penumbra::frame::frame(&p, &scene, 0, 0)?;
    let tris = scene.triangles();
    println!(
        "technique {} [{}] on {}: {tris} triangles, {}x{}, {} threads",
        a.technique,
        a.sets.join(" "),
        scene.name,
        f.width(),
        f.height(),
        p.threads()
    );
    let mut v = t.visibility(&p, &f)?;
    let mut total = Vec::new();
    let mut passes: Vec<(&'static str, Vec<f64>)> = Vec::new();
    for _ in 0..a.common.reps.max(1) {
        let t0 = Instant::now();
        v = t.visibility(&p, &f)?;
        total.push(t0.elapsed().as_secs_f64() * 1e3);
        for (name, ms) in t.timings() {
            match passes.iter_mut().find(|(n, _)| *n == name) {
                Some((_, list)) => list.push(ms),
                None => passes.push((name, vec![ms])),
            }
        }
    }
    let ms = penumbra::metrics::median(total);
    let hash = v.hash();
    println!("total     {ms:.3} ms (median of {})", a.common.reps.max(1));
    let mut json = serde_json::Map::new();
    json.insert("technique".into(), json!(a.technique));
    json.insert("threads".into(), json!(p.threads()));
    json.insert("triangles".into(), json!(tris));
    json.insert("ms".into(), json!(ms));
    json.insert("mtri_per_s".into(), json!(tris as f64 / ms / 1e3));
    // The light-space passes (all but the lookup), for the fragments' insertion rate.
    let mut light_ms = 0.0;
    let mut prefilter_ms = None;
    for (name, list) in passes {
        let m = penumbra::metrics::median(list);
        if name == "prefilter" {
            prefilter_ms = Some(m);
        }
        println!("  {name:<18} {m:.3} ms");
        json.insert(format!("ms_{}", name.replace(' ', "_")), json!(m));
        if !name.starts_with("lookup") {
            light_ms += m;
        }
    }
    let counters = t.counters();
    for (name, c) in &counters {
        println!("  {name:<18} {c}");
        json.insert(name.replace(' ', "_"), json!(c));
    }
    if let Some((_, frags)) = counters.iter().find(|(n, _)| n.starts_with("fragments")) {
        if light_ms > 0.0 {
            let rate = frags / light_ms / 1e3;
            println!("fragments {rate:.2} M/s through the light pass");
            json.insert("mfragments_per_s".into(), json!(rate));
        }
    }
    // The filtered family's prefilter: texels read per second.
    if let (Some(m), Some((_, reads))) = (
        prefilter_ms,
        counters.iter().find(|(n, _)| *n == "prefilter texel reads"),
    ) {
        if m > 0.0 {
            let rate = reads / m / 1e6;
            println!("prefilter {rate:.3} Gtexel/s read");
            json.insert("gtexel_per_s_prefilter".into(), json!(rate));
        }
    }
    println!("throughput {:.2} Mtri/s", tris as f64 / ms / 1e3);
    println!("hash      {hash:016x}");
    json.insert("hash".into(), json!(format!("{hash:016x}")));
    if a.common.json {
        println!("{}", serde_json::Value::Object(json));
    }
    Ok(())
}
