//! The ground truth against closed forms: a box's hard shadow is its analytic projection; the
//! visible fraction of a disk light behind a straight occluder edge is the circular-segment
//! area (Cournia eq. 4.1); sphere lights fully visible or hidden; transmittance of layers.

use glam::Vec3;
use penumbra::reference::{Reference, ReferenceOptions, SamplePoint};
use penumbra::scene::file::parse;
use std::path::Path;

fn scene(objects: &str, light: &str) -> penumbra::scene::Scene {
    let text = format!("[camera]\nposition = [0, 5, 9]\ntarget = [0, 0, 0]\nresolution = [8, 8]\n\n{light}\n\n[[material]]\nname = \"veil\"\nopacity = 0.35\n\n{objects}");
    parse(&text, Path::new("test.toml")).unwrap()
}

fn ground_point(x: f32, z: f32) -> SamplePoint {
    SamplePoint::flat(Vec3::new(x, 0.0, z), Vec3::Y)
}

/// Exact slab test in f64: does the ray o + t d (t > 0) hit the box?
fn ray_hits_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> (bool, f64) {
    let (mut t0, mut t1) = (1e-9f64, f64::INFINITY);
    let mut margin = f64::INFINITY;
    for a in 0..3 {
        let (oa, da) = (o[a] as f64, d[a] as f64);
        let (l, h) = (lo[a] as f64, hi[a] as f64);
        if da.abs() < 1e-12 {
            if oa < l || oa > h {
                return (false, (l - oa).abs().min((oa - h).abs()));
            }
            continue;
        }
        let (ta, tb) = ((l - oa) / da, (h - oa) / da);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    margin = margin.min((t1 - t0).abs());
    (t0 <= t1, margin)
}

#[test]
fn box_shadow_is_its_analytic_projection() {
    let s = scene(
        "[[object]]\nmesh = \"plane\"\nsize = [12, 12]\n\n[[object]]\nmesh = \"box\"\nsize = [1, 1, 1]\ntranslate = [0, 0.7, 0]\n",
        "[[light]]\ntype = \"directional\"\ndirection = [0.3, -1, 0.2]\n",
    );
    let r = Reference::new(&s);
    let light = s.lights[0];
    let (lo, hi) = (Vec3::new(-0.5, 0.2, -0.5), Vec3::new(0.5, 1.2, 0.5));
    let (mut shadowed, mut checked) = (0, 0);
    for i in 0..120 {
        for j in 0..120 {
            let (x, z) = (-3.0 + i as f32 * 0.05 + 0.013, -3.0 + j as f32 * 0.05 + 0.007);
            let p = ground_point(x, z);
            let (hit, margin) = ray_hits_box(p.position, -light.direction, lo, hi);
            if margin < 1e-3 {
                continue; // the ray grazes the box: either answer is right
            }
            let v = r.hard(&p, &light);
            assert_eq!(v, if hit { 0.0 } else { 1.0 }, "ground point ({x}, {z})");
            shadowed += hit as u32;
            checked += 1;
        }
    }
    assert!(shadowed > 300 && checked > 14000, "{shadowed} of {checked}");
}

/// Area of the part of a disk of radius `r` with x > c (the circular segment).
fn segment_fraction(c: f64, r: f64) -> f64 {
    if c >= r {
        return 0.0;
    }
    if c <= -r {
        return 1.0;
    }
    (r * r * (c / r).acos() - c * (r * r - c * c).sqrt()) / (std::f64::consts::PI * r * r)
}

#[test]
fn disk_light_behind_a_straight_edge_matches_the_circular_segment() {
    // Disk light of radius R at height H facing down; an occluder covering x < 0 at height h.
    let (rl, hl, ho) = (0.5f64, 4.0f64, 1.0f64);
    let s = scene(
        "[[object]]\nmesh = \"box\"\nsize = [20, 0.002, 20]\ntranslate = [-10, 1.0, 0]\n",
        "[[light]]\ntype = \"disk\"\nposition = [0, 4, 0]\ndirection = [0, -1, 0]\nradius = 0.5\n",
    );
    let r = Reference::new(&s);
    let opts = ReferenceOptions::default();
    let mut worst = 0.0f64;
    for k in 0..=40 {
        let x = -0.25 + k as f64 * 0.0125;
        // The edge seen from (x, 0, 0) cuts the light plane at lx = x (h - H) / h; visible: lx > c.
        let c = x * (ho - hl) / ho;
        let expect = segment_fraction(c, rl);
        let v = r.area(&ground_point(x as f32, 0.0), &s.lights[0], 1000 + k, &opts) as f64;
        worst = worst.max((v - expect).abs());
        assert!(
            (v - expect).abs() < 0.01,
            "x = {x}: visible {v}, circular segment gives {expect}"
        );
    }
    assert!(worst > 0.0, "the test crossed the penumbra");
}

#[test]
fn sphere_light_fully_visible_or_hidden() {
    let light = "[[light]]\ntype = \"sphere\"\nposition = [0, 5, 0]\nradius = 0.5\n";
    let open = scene(
        "[[object]]\nmesh = \"box\"\nsize = 0.2\ntranslate = [5, 0.1, 5]\n",
        light,
    );
    let r = Reference::new(&open);
    assert_eq!(
        r.area(
            &ground_point(0.0, 0.0),
            &open.lights[0],
            1,
            &ReferenceOptions::default()
        ),
        1.0
    );
    let covered = scene(
        "[[object]]\nmesh = \"box\"\nsize = [4, 0.1, 4]\ntranslate = [0, 2, 0]\n",
        light,
    );
    let r = Reference::new(&covered);
    assert_eq!(
        r.area(
            &ground_point(0.0, 0.0),
            &covered.lights[0],
            1,
            &ReferenceOptions::default()
        ),
        0.0
    );
}

/// Float products are not associative: the layers multiply front to back, whatever order the
/// hierarchy meets them in (here 24 layers of different opacities, stacked in a shuffled
/// object order, over every permutation the BVH's split might produce).
#[test]
fn transmittance_multiplies_layers_front_to_back() {
    let mut objects = String::new();
    let mut mats = String::new();
    let heights: Vec<u32> = (0..24).map(|i| (i * 7) % 24).collect();
    for (i, h) in heights.iter().enumerate() {
        mats.push_str(&format!(
            "[[material]]\nname = \"m{i}\"\nopacity = {}\n\n",
            0.013 + 0.031 * i as f32
        ));
        objects.push_str(&format!(
            "[[object]]\nmesh = \"plane\"\nsize = 2\ntranslate = [0, {}, 0]\nmaterial = \"m{i}\"\n\n",
            0.1 + 0.15 * *h as f32
        ));
    }
    let s = scene(
        &format!("{mats}{objects}"),
        "[[light]]\ntype = \"point\"\nposition = [0, 9, 0]\n",
    );
    let r = Reference::new(&s);
    let v = r.hard(&ground_point(0.1, 0.1), &s.lights[0]);
    let mut order: Vec<usize> = (0..24).collect();
    order.sort_by_key(|&i| heights[i]);
    let want = order
        .iter()
        .fold(1.0f32, |acc, &i| acc * (1.0 - (0.013 + 0.031 * i as f32)));
    assert_eq!(v.to_bits(), want.to_bits(), "{v} against {want}");
}

#[test]
fn semi_transparent_layers_attenuate_multiplicatively() {
    let layers = "[[object]]\nmesh = \"plane\"\nsize = 2\ntranslate = [0, 1, 0]\nmaterial = \"veil\"\n\n[[object]]\nmesh = \"plane\"\nsize = 2\ntranslate = [0, 2, 0]\nmaterial = \"veil\"\n";
    let s = scene(layers, "[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\n");
    let r = Reference::new(&s);
    let v = r.hard(&ground_point(0.1, 0.1), &s.lights[0]);
    assert!((v - 0.65 * 0.65).abs() < 1e-6, "{v}");
    assert_eq!(r.hard(&ground_point(3.0, 3.0), &s.lights[0]), 1.0);
}

#[test]
fn reference_is_deterministic_across_threads() {
    let s = scene(
        "[[object]]\nmesh = \"plane\"\nsize = [6, 6]\n\n[[object]]\nmesh = \"sphere\"\nradius = 0.5\ntranslate = [0, 1, 0]\n",
        "[[light]]\ntype = \"rectangle\"\nposition = [0.5, 4, 0.5]\ndirection = [0, -1, 0]\nsize = [1, 0.6]\n",
    );
    let r = Reference::new(&s);
    let pts: Vec<Option<SamplePoint>> = (0..64 * 64)
        .map(|i| Some(ground_point((i % 64) as f32 / 16.0 - 2.0, (i / 64) as f32 / 16.0 - 2.0)))
        .collect();
    let run = |t: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap();
        pool.install(|| r.visibility(&pts, 64, &s.lights[0], &ReferenceOptions::default()))
    };
    let one = run(1);
    assert!(one.to_scalar().iter().any(|&v| v > 0.0 && v < 1.0), "has a penumbra");
    assert_eq!(one, run(2));
    assert_eq!(one, run(4));
}

/// Rays traced in packets give each ray's single answer bit for bit: transmittance through the
/// translucent layers of `layers` and the coloured panes of `stained_glass` (every surface
/// each ray crosses, multiplied in the same order), opaque stops, coherent packets (the
/// shadow rays of neighbouring pixels) and incoherent ones (random rays), partial packets.
#[test]
fn packets_give_each_rays_single_answer_bit_for_bit() {
    use penumbra::reference::bvh::PACKET;
    for name in ["layers", "stained_glass", "spheres"] {
        let path = format!("fixtures/scenes/{name}.toml");
        let s = penumbra::scene::file::load(Path::new(&path)).unwrap();
        let r = Reference::new(&s);
        let p = penumbra::pipeline::Pipeline::new(2).unwrap();
        let f = penumbra::frame::frame(&p, &s, 0, 0).unwrap();
        let light = &f.light;
        let mut rays: Vec<penumbra::reference::Ray> = f
            .points()
            .iter()
            .flatten()
            .step_by(3)
            .map(|pt| {
                let o = penumbra::reference::offset_origin(pt.position, pt.face);
                match light.kind {
                    penumbra::scene::LightKind::Directional => (o, -light.direction, f32::INFINITY),
                    _ => {
                        let to = light.position - o;
                        (o, to.normalize(), to.length())
                    }
                }
            })
            .collect();
        let (lo, hi) = s.bounds().unwrap();
        let mut h = penumbra::hash::SplitMix(7);
        for _ in 0..2000 {
            let mut u = || h.next_f32();
            let o = lo + (hi - lo) * Vec3::new(u(), u(), u());
            let d = (Vec3::new(u(), u(), u()) - 0.5).normalize();
            rays.push((o, d, if u() < 0.5 { f32::INFINITY } else { 5.0 * u() }));
        }
        let (mut k, mut n) = (0, 1);
        let mut shadowed = 0;
        while k < rays.len() {
            let m = n.min(rays.len() - k);
            let packet = &rays[k..k + m];
            let mut out = [0.0f32; PACKET];
            let mut rgb = [Vec3::ZERO; PACKET];
            r.transmittance_packet(packet, &mut out[..m]);
            r.transmittance_rgb_packet(packet, &mut rgb[..m]);
            for (i, &(o, d, t)) in packet.iter().enumerate() {
                assert_eq!(
                    out[i].to_bits(),
                    r.transmittance(o, d, t).to_bits(),
                    "{name}: ray {}",
                    k + i
                );
                let want = r.transmittance_rgb(o, d, t);
                assert_eq!(
                    rgb[i].to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "{name}: ray {}",
                    k + i
                );
                shadowed += (out[i] < 1.0) as usize;
            }
            k += m;
            n = n % PACKET + 1;
        }
        assert!(
            shadowed > 100,
            "{name}: {shadowed} rays shadowed: the rays must cross something"
        );
    }
}
