//! Screen-space shadows, the shadow map with contact shadows and terrain occlusion height:
//! their accuracy against the reference, the failures they are known for (each on its
//! fixture), and their bad input.

use penumbra::frame::{self, Frame};
use penumbra::pipeline::Pipeline;
use penumbra::reference::Reference;
use penumbra::scene::file::load;
use penumbra::scene::Scene;
use penumbra::shadow::{self, Stage};
use std::path::Path;

fn scene(name: &str) -> Scene {
    load(Path::new(&format!("fixtures/scenes/{name}.toml"))).unwrap()
}

/// The technique's visibility on `frame`.
fn run(p: &Pipeline, f: &Frame, technique: &str, sets: &[(&str, &str)]) -> Vec<f32> {
    let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let mut t = shadow::registry::create(technique, &sets).unwrap();
    let v = t.visibility(p, f).unwrap();
    assert!(!t.stages(p, f).unwrap().is_empty(), "{technique} lists its stages");
    (0..v.len()).map(|i| v.value(i)).collect()
}

/// Hard visibility from the light's centre of every pixel of `f`, against `scene` (which may
/// lack some of the frame's objects).
fn hard(p: &Pipeline, f: &Frame, scene: &Scene) -> Vec<f32> {
    let r = Reference::new(scene);
    p.install(|| {
        use rayon::prelude::*;
        f.points()
            .par_iter()
            .map(|s| s.map_or(f32::NAN, |s| r.hard(&s, &f.light)))
            .collect()
    })
}

/// `s` without the objects named in `names`.
fn without(s: &Scene, names: &[&str]) -> Scene {
    let mut t = s.clone();
    t.objects.retain(|o| !names.contains(&o.name.as_str()));
    t
}

/// Fraction of the pixels of `region` where `v` is lit (above one half).
fn lit_in(v: &[f32], region: &[bool]) -> f64 {
    let n = region.iter().filter(|&&r| r).count();
    assert!(n > 0, "an empty region");
    let lit = v.iter().zip(region).filter(|(&v, &r)| r && v > 0.5).count();
    lit as f64 / n as f64
}

/// The pixels (of the metric mask) that only the objects `names` shadow: shadowed in the
/// whole scene, lit without them.
fn shadow_of(p: &Pipeline, f: &Frame, s: &Scene, names: &[&str]) -> Vec<bool> {
    let all = hard(p, f, s);
    let rest = hard(p, f, &without(s, names));
    let mask = f.metric_mask();
    (0..all.len())
        .map(|i| mask[i] && all[i] == 0.0 && rest[i] == 1.0)
        .collect()
}

/// On fixture `name`, the shadow that only `object` casts (more than `pixels` pixels): the
/// fraction screen-space shadows light (must be above `lost`) and the fraction the map with
/// contact shadows lights (must be below `kept`).
fn lost_by_the_march(name: &str, object: &str, pixels: usize, lost: f64, kept: f64) {
    let p = Pipeline::new(2).unwrap();
    let s = scene(name);
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let region = shadow_of(&p, &f, &s, &[object]);
    assert!(
        region.iter().filter(|&&t| t).count() > pixels,
        "{object}'s shadow is in view"
    );
    let ss = lit_in(&run(&p, &f, "screen-space", &[]), &region);
    let cm = lit_in(&run(&p, &f, "contact-map", &[]), &region);
    eprintln!("{name}: {object}'s shadow lit: screen-space {ss:.4}, contact-map {cm:.4}");
    assert!(ss > lost, "screen-space lights {ss} of {object}'s shadow");
    // The map holds the caster: the contact term keeps its shadow.
    assert!(cm < kept, "contact-map lights {cm} of it");
}

#[test]
fn screen_space_loses_casters_outside_the_view_and_the_map_keeps_them() {
    // The march sees no tower: all of its shadow is lost.
    lost_by_the_march("offscreen", "tower", 2000, 0.99, 0.01);
}

#[test]
fn screen_space_loses_casters_hidden_from_the_camera() {
    // The depth buffer holds the slab, not the box under it.
    lost_by_the_march("hidden_caster", "box", 100, 0.95, 0.05);
}

#[test]
fn thickness_trades_shadows_too_long_for_leaks() {
    // On `thin_sheet`: a thick assumption makes the thin sheet cast shadow wherever a step
    // passes behind it (too long, too wide); a thin one lets the box's shadow leak where the
    // march passes behind the box's front faces.
    let p = Pipeline::new(2).unwrap();
    let s = scene("thin_sheet");
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let r = hard(&p, &f, &s);
    let mask = f.metric_mask();
    let count = |v: &[f32], want_lit: bool| {
        (0..v.len())
            .filter(|&i| mask[i] && (v[i] > 0.5) != want_lit && (r[i] > 0.5) == want_lit)
            .count()
    };
    let thick = run(&p, &f, "screen-space", &[("thickness", "5")]);
    let thin = run(&p, &f, "screen-space", &[("thickness", "0.02")]);
    let (over_thick, over_thin) = (count(&thick, true), count(&thin, true));
    let (leak_thick, leak_thin) = (count(&thick, false), count(&thin, false));
    eprintln!("thin_sheet: too dark thick {over_thick} thin {over_thin}; leaks thick {leak_thick} thin {leak_thin}");
    assert!(over_thick > 2 * over_thin + 200, "thick occluders overshadow");
    assert!(leak_thin > 2 * leak_thick + 200, "thin occluders leak");
}

/// Ground pixels within `d` of the contact fixture's box footprint (the box is 1 wide,
/// turned 25 degrees about y).
fn contact_region(f: &Frame, d: f32) -> Vec<bool> {
    let a = 25f32.to_radians();
    let (s, c) = (penumbra::math::sin(a), penumbra::math::cos(a));
    let mask = f.metric_mask();
    let ground = f.scene.objects.iter().position(|o| o.name == "ground").unwrap() as u32;
    f.points()
        .iter()
        .enumerate()
        .map(|(i, pt)| {
            let Some(pt) = pt else { return false };
            if !mask[i] || f.gbuffer.object.data()[i] != ground {
                return false;
            }
            let q = pt.position;
            // Into the box's frame.
            let (x, z) = (c * q.x - s * q.z, s * q.x + c * q.z);
            let out = glam::Vec2::new(x.abs() - 0.5, z.abs() - 0.5)
                .max(glam::Vec2::ZERO)
                .length();
            out > 0.0 && out < d
        })
        .collect()
}

#[test]
fn contact_shadows_fix_the_maps_contact_region() {
    // The map with a bias that keeps it free of acne (here: a large constant one) loses the
    // shadow next to the box (Peter Panning); the contact march gives it back.
    let p = Pipeline::new(2).unwrap();
    let s = scene("contact");
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let r = hard(&p, &f, &s);
    // Within the short march's reach of the box.
    let region = contact_region(&f, 0.06);
    let n = region.iter().filter(|&&x| x).count();
    assert!(n > 200, "{n} contact pixels");
    let wrong = |v: &[f32]| {
        let w = (0..v.len()).filter(|&i| region[i] && (v[i] - r[i]).abs() > 0.5).count();
        100.0 * w as f64 / n as f64
    };
    for units in ["4", "2000"] {
        let map = wrong(&run(&p, &f, "shadow-map", &[("units", units)]));
        let both = wrong(&run(&p, &f, "contact-map", &[("units", units)]));
        eprintln!("contact region (units={units}): shadow-map {map:.3} %, contact-map {both:.3} %");
        assert!(
            both <= map,
            "units={units}: contact shadows {both} % vs the map's {map} %"
        );
        if units != "4" {
            assert!(
                both < 0.5 * map,
                "units={units}: contact shadows {both} % vs the map's {map} %"
            );
        }
    }
}

#[test]
fn screen_techniques_against_the_hard_reference() {
    // Bounds: the measured wrong % (hard reference from the light's centre) with margin.
    let p = Pipeline::new(2).unwrap();
    for (name, technique, bound) in [
        ("contact", "screen-space", 2.0),
        ("contact", "contact-map", 0.5),
        ("thin_sheet", "contact-map", 0.5),
        ("terrain", "terrain-height", 1.0),
    ] {
        let s = scene(name);
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let r = hard(&p, &f, &s);
        let v = run(&p, &f, technique, &[]);
        let e = penumbra::metrics::compare_scalar(&v, &r, &f.metric_mask());
        eprintln!("{technique} on {name}: wrong {:.3} %, rmse {:.4}", e.wrong_pct, e.rmse);
        assert!(e.wrong_pct < bound, "{technique} on {name}: {} %", e.wrong_pct);
    }
}

#[test]
fn terrain_height_misses_what_is_not_terrain_and_the_map_adds_it() {
    let p = Pipeline::new(2).unwrap();
    let s = scene("forest_floor");
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let trees: Vec<&str> = s
        .objects
        .iter()
        .filter(|o| !o.heightfield)
        .map(|o| o.name.as_str())
        .collect();
    let of_trees = shadow_of(&p, &f, &s, &trees);
    let alone = lit_in(&run(&p, &f, "terrain-height", &[]), &of_trees);
    let with_map = lit_in(&run(&p, &f, "terrain-height", &[("objects", "true")]), &of_trees);
    eprintln!("trees' shadows lit: terrain-height {alone:.4}, with objects map {with_map:.4}");
    assert!(alone > 0.95, "occlusion height lights {alone} of the trees' shadows");
    assert!(with_map < 0.05, "with the objects' map: {with_map}");
    // The trees themselves are shadowed by the terrain where it shadows them: on tree pixels
    // the terrain's shadow (reference without other trees) matches.
    let terrain_only = hard(&p, &f, &without(&s, &trees));
    let v = run(&p, &f, "terrain-height", &[]);
    let mask = f.metric_mask();
    let on_trees: Vec<usize> = (0..v.len())
        .filter(|&i| {
            mask[i] && {
                let o = f.gbuffer.object.data()[i];
                o != frame::NO_OBJECT && !s.objects[o as usize].heightfield
            }
        })
        .collect();
    let shaded = on_trees.iter().filter(|&&i| terrain_only[i] < 0.5).count();
    let wrong = on_trees
        .iter()
        .filter(|&&i| (v[i] - terrain_only[i]).abs() > 0.5)
        .count();
    eprintln!(
        "tree pixels: {} ({} in the terrain's shadow), wrong {wrong}",
        on_trees.len(),
        shaded
    );
    let wrong_shaded = on_trees
        .iter()
        .filter(|&&i| terrain_only[i] < 0.5 && v[i] > 0.5)
        .count();
    assert!(shaded > 100, "trees stand in the terrain's shadow");
    assert!(
        wrong_shaded * 10 < shaded,
        "{wrong_shaded} of {shaded} shadowed tree pixels lit"
    );
    assert!(
        (wrong as f64) < 0.03 * on_trees.len() as f64,
        "{wrong} tree pixels wrong"
    );
}

#[test]
fn occlusion_heights_match_exact_ray_casting() {
    let p = Pipeline::new(2).unwrap();
    let s = scene("terrain");
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let sets = vec![("grid".to_string(), "128".to_string())];
    let mut t = shadow::registry::create("terrain-height", &sets).unwrap();
    t.visibility(&p, &f).unwrap();
    let stages = t.stages(&p, &f).unwrap();
    let get = |name: &str| match stages.iter().find(|s| s.name() == name) {
        Some(Stage::Scalar { data, .. }) => data.data().to_vec(),
        _ => panic!("no stage {name}"),
    };
    let (err, above) = (get("occlusion_height_error"), get("occlusion_above_surface"));
    // Over the locations the terrain shadows: the mean and the 99th percentile of the error.
    let mut e: Vec<f32> = err
        .iter()
        .zip(&above)
        .filter(|(e, a)| e.is_finite() && **a > 0.0)
        .map(|(e, _)| *e)
        .collect();
    assert!(e.len() > 200, "{} shadowed locations", e.len());
    e.sort_by(f32::total_cmp);
    let mean = e.iter().sum::<f32>() / e.len() as f32;
    let p99 = e[e.len() * 99 / 100];
    eprintln!(
        "occlusion height error over {} locations: mean {mean:.4}, p99 {p99:.4}",
        e.len()
    );
    assert!(mean < 0.05 && p99 < 0.3, "mean {mean}, p99 {p99}");
}

#[test]
fn a_sun_below_the_horizon_shadows_everything() {
    let p = Pipeline::new(2).unwrap();
    let mut s = scene("terrain");
    s.lights[0].direction = glam::Vec3::new(-1.0, 0.2, -0.3).normalize();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("terrain-height", &[]).unwrap();
    let v = t.visibility(&p, &f).unwrap();
    let covered: Vec<f32> = (0..v.len()).map(|i| v.value(i)).filter(|v| !v.is_nan()).collect();
    assert!(!covered.is_empty() && covered.iter().all(|&v| v == 0.0));
    assert!(t.notes().iter().any(|n| n.contains("horizon")), "{:?}", t.notes());
}

#[test]
fn bad_input_is_a_clear_error() {
    for (technique, key, value, says) in [
        ("screen-space", "steps", "0", "outside [1, 1024]"),
        ("screen-space", "steps", "100000", "outside [1, 1024]"),
        ("screen-space", "thickness", "-1", "outside [0,"),
        ("screen-space", "length", "0", "outside"),
        ("contact-map", "steps", "nan", "steps"),
        ("terrain-height", "grid", "0", "outside [2, 8192]"),
        ("terrain-height", "iterations", "1000", "outside [0, 40]"),
    ] {
        let e = shadow::registry::create(technique, &[(key.to_string(), value.to_string())])
            .err()
            .unwrap_or_else(|| panic!("{technique} {key}={value} accepted"))
            .to_string();
        assert!(e.contains(technique) && e.contains(key) && e.contains(says), "{e}");
    }
    // Terrain occlusion height on a scene without a heightfield names what it looked at.
    let p = Pipeline::new(2).unwrap();
    let s = scene("contact");
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("terrain-height", &[]).unwrap();
    let e = t.visibility(&p, &f).err().unwrap().to_string();
    assert!(
        e.contains("terrain-height") && e.contains("heightfield") && e.contains("ground, box"),
        "{e}"
    );
    assert!(!shadow::registry::registry()
        .iter()
        .find(|t| t.name == "terrain-height")
        .unwrap()
        .applies_to(&s));
    // ... and of a scene whose light is not the sun, names the light.
    let mut s = scene("terrain");
    s.lights[0].kind = penumbra::scene::LightKind::Point;
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let e = t.visibility(&p, &f).err().unwrap().to_string();
    assert!(e.contains("directional") && e.contains("Point"), "{e}");
}

#[test]
fn screen_techniques_are_the_same_for_any_thread_count() {
    for (name, technique) in [
        ("contact", "screen-space"),
        ("contact", "contact-map"),
        ("forest_floor", "terrain-height"),
    ] {
        let s = scene(name);
        let hashes: Vec<u64> = [1, 2, 4]
            .iter()
            .map(|&n| {
                let p = Pipeline::new(n).unwrap();
                let f = frame::frame(&p, &s, 0, 0).unwrap();
                let mut t = shadow::registry::create(technique, &[]).unwrap();
                t.visibility(&p, &f).unwrap().hash()
            })
            .collect();
        assert!(hashes.windows(2).all(|w| w[0] == w[1]), "{technique}: {hashes:x?}");
    }
}

#[test]
fn occlusion_heights_follow_the_sun() {
    // How far the heights move when the sun turns by half a degree (about its elevation):
    // the rate that says how often the grid must be rebuilt.
    let p = Pipeline::new(2).unwrap();
    let heights = |s: &Scene| {
        let f = frame::frame(&p, s, 0, 0).unwrap();
        let mut t = shadow::registry::create("terrain-height", &[("grid".to_string(), "256".to_string())]).unwrap();
        t.visibility(&p, &f).unwrap();
        let stages = t.stages(&p, &f).unwrap();
        match stages.iter().find(|s| s.name() == "occlusion_above_surface") {
            Some(Stage::Scalar { data, .. }) => data.data().to_vec(),
            _ => panic!("no occlusion heights"),
        }
    };
    let s = scene("forest_floor");
    let mut turned = s.clone();
    let d = s.lights[0].direction;
    // Half a degree lower: the direction turned about the horizontal axis across it.
    let axis = glam::Vec3::new(-d.z, 0.0, d.x).normalize();
    turned.lights[0].direction = glam::Quat::from_axis_angle(axis, 0.5f32.to_radians()) * d;
    let (a, b) = (heights(&s), heights(&turned));
    let moved: Vec<f32> = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| **x > 0.0 || **y > 0.0)
        .map(|(x, y)| (x - y).abs())
        .collect();
    let mean = moved.iter().sum::<f32>() / moved.len() as f32;
    let max = moved.iter().copied().fold(0.0, f32::max);
    eprintln!(
        "half a degree of sun: occlusion heights move by {mean:.4} on average, {max:.4} at most, over {} locations",
        moved.len()
    );
    // Measured 0.0105 and 0.31 (forest_floor, 256² grid, 2026-12-05).
    assert!(mean > 0.002 && mean < 0.05 && max < 1.0, "mean {mean}, max {max}");
}
