//! Techniques against the reference on the fixture scenes, their known failures, and the
//! registry's and the CLI's handling of bad input.

use crate::common;
use common::cli;
use penumbra::frame;
use penumbra::metrics::{compare, compare_scalar};
use penumbra::pipeline::Pipeline;
use penumbra::run;
use penumbra::scene::file::load;
use penumbra::shadow;
use std::path::Path;

/// `technique` on `scene` and the scene's reference, handed to `then` with the frame.
fn with_reference<T>(
    scene: &str,
    technique: &str,
    sets: &[(&str, &str)],
    then: impl FnOnce(&penumbra::visibility::Visibility, &penumbra::visibility::Visibility, &frame::Frame) -> T,
) -> T {
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let text = std::fs::read_to_string(format!("fixtures/scenes/{scene}.toml")).unwrap();
    let key = run::reference_key(&text, &f, 0, &Default::default());
    let (r, _, _) = run::reference(&p, &f, key, None).unwrap();
    let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let mut t = shadow::registry::create(technique, &sets).unwrap();
    let v = t.visibility(&p, &f).unwrap();
    assert!(!t.stages(&p, &f).unwrap().is_empty(), "{technique} lists its stages");
    then(&v, &r, &f)
}

fn errors(scene: &str, technique: &str, sets: &[(&str, &str)]) -> penumbra::metrics::Errors {
    with_reference(scene, technique, sets, |v, r, f| compare(v, r, &f.metric_mask()))
}

#[test]
fn reference_technique_is_the_reference() {
    let e = errors("contact", "reference", &[]);
    assert_eq!((e.rmse, e.wrong_pct), (0.0, 0.0));
    assert!(e.penumbra_pixels > 100, "the contact scene has a penumbra");
}

#[test]
fn shadow_map_matches_hard_reference_on_hard_light_fixtures() {
    // Bounds: the measured wrong % of the default 2048 map (see README) with margin.
    for (scene, bound) in [
        ("grazing", 0.1),
        ("eye_in_volume", 0.1),
        ("facing_light", 0.4),
        ("long_view", 0.2),
        ("point_casters", 0.1),
        ("thin_sheet", 0.1),
        ("terrain", 1.0),
        ("spheres", 0.6),
    ] {
        let e = errors(scene, "shadow-map", &[]);
        assert!(
            e.wrong_pct < bound,
            "{scene}: wrong {} % (bound {bound} %)",
            e.wrong_pct
        );
        assert!(e.pixels > 10_000, "{scene}: measured {} pixels", e.pixels);
    }
}

#[test]
fn acne_without_bias_and_resolution_helps() {
    let biased = errors("grazing", "shadow-map", &[]);
    let acne = errors("grazing", "shadow-map", &[("units", "0"), ("slope", "0")]);
    assert!(
        acne.wrong_pct > 20.0,
        "zero bias on a grazing plane must show acne: {} %",
        acne.wrong_pct
    );
    assert!(
        biased.wrong_pct * 50.0 < acne.wrong_pct,
        "bias fixes it: {} vs {} %",
        biased.wrong_pct,
        acne.wrong_pct
    );
    let small = errors("long_view", "shadow-map", &[("size", "256")]);
    let large = errors("long_view", "shadow-map", &[("size", "4096")]);
    assert!(
        large.rmse < small.rmse,
        "a larger map aliases less: {} vs {}",
        large.rmse,
        small.rmse
    );
}

#[test]
fn hard_techniques_miss_the_penumbra_and_translucency() {
    let e = errors("overlap", "shadow-map", &[]);
    assert!(
        e.penumbra_rmse > 0.2,
        "a hard shadow map cannot produce soft shadows: {}",
        e.penumbra_rmse
    );
    let e = errors("layers", "shadow-map", &[]);
    assert!(
        e.wrong_pct > 5.0,
        "an opaque depth map blocks semi-transparent layers: {} %",
        e.wrong_pct
    );
}

#[test]
fn registry_rejects_unknown_names_and_bad_values() {
    let bad = |name: &str, sets: &[(&str, &str)]| {
        let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        shadow::registry::create(name, &sets)
            .err()
            .expect("must be an error")
            .to_string()
    };
    assert!(bad("shadow-mop", &[]).contains("unknown technique 'shadow-mop' (known: reference, shadow-map"));
    assert!(bad("shadow-map", &[("sise", "1")]).contains("option sise=1 is unknown (options: size, format"));
    assert!(bad("shadow-map", &[("size", "big")]).contains("size=big is not a number (an integer is expected)"));
    assert!(bad("shadow-map", &[("size", "0")]).contains("outside [16, 16384]"));
    assert!(bad("shadow-map", &[("filter", "gauss")]).contains("not one of none, pcf2"));
    // Callers match on what went wrong: the technique and the key are fields.
    let sets = [("size".to_string(), "0".to_string())];
    match shadow::registry::create("pcss", &sets).err() {
        Some(penumbra::Error::Option {
            technique, key, value, ..
        }) => {
            assert_eq!(
                (technique.as_deref(), key.as_str(), value.as_str()),
                (Some("pcss"), "size", "0")
            )
        }
        e => panic!("not an option error: {e:?}"),
    }
    assert!(matches!(
        shadow::registry::create("nope", &[]),
        Err(penumbra::Error::Technique { .. })
    ));
    assert!(shadow::registry::parse_sets(&["size".into()]).is_err());
    for t in shadow::registry::registry() {
        assert!(!t.sweep.is_empty(), "{} declares sweep sets", t.name);
        for set in t.sweep.iter().chain(t.extended) {
            let sets: Vec<(String, String)> = set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            assert!(
                shadow::registry::create(t.name, &sets).is_ok(),
                "{} sweep set {set:?} is valid",
                t.name
            );
        }
    }
}

fn temp_scene(name: &str, body: &str) -> String {
    common::temp_file("test", name, body)
}

const GOOD: &str = "# ok\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\nresolution = [32, 24]\n\n[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\n\n[[object]]\nmesh = \"plane\"\nsize = 4\n";

#[test]
fn cli_reports_bad_input_with_what_and_where() {
    let out = std::env::temp_dir().join(format!("penumbra-test-out-{}", std::process::id()));
    let out = out.to_str().unwrap();
    let good = temp_scene("good.toml", GOOD);
    let (ok, text) = cli(&[
        "render",
        &good,
        "--technique",
        "shadow-map",
        "--out",
        out,
        "--reps",
        "1",
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("rmse"), "{text}");
    // `render GOOD FLAG VALUE`.
    let render =
        |flag: &str, value: &str| -> Vec<String> { vec!["render".into(), good.clone(), flag.into(), value.into()] };
    let cases: Vec<(Vec<String>, &str)> = vec![
        (render("--technique", "nope"), "unknown technique 'nope'"),
        (render("--set", "sise=3"), "option sise=3 is unknown"),
        (render("--set", "size=-4"), "size=-4"),
        (render("--set", "size"), "is not key=value"),
        // Regression: clap called `-1` an unexpected argument, and `size=-1` "not a number".
        (
            render("--threads", "-1"),
            "-1 is negative: 0 (all cores) or a number of threads",
        ),
        (render("--set", "size=-1"), "size=-1 is outside [16, 16384]"),
        (render("--set", "size=1e3"), "write 1000 in digits"),
        (render("--set", "units=nan"), "units=nan is not finite"),
        (
            vec!["render".into(), "does/not/exist.toml".into()],
            "does/not/exist.toml: cannot read scene file",
        ),
        (
            vec![
                "render".into(),
                temp_scene("syntax.toml", &GOOD.replace("[camera]", "[camera")),
            ],
            "syntax.toml:2:",
        ),
        (
            vec![
                "render".into(),
                temp_scene("nan.toml", &GOOD.replace("[0, 3, 5]", "[0, nan, 5]")),
            ],
            "field `position`: [0, NaN, 5] is not finite",
        ),
        (
            vec![
                "render".into(),
                temp_scene("zero.toml", &GOOD.replace("[32, 24]", "[0, 24]")),
            ],
            "field `resolution`",
        ),
        (
            vec![
                "render".into(),
                temp_scene("obj.toml", &GOOD.replace("\"plane\"", "\"missing.obj\"")),
            ],
            "missing.obj",
        ),
        (
            vec![
                "render".into(),
                temp_scene("bad_obj.toml", &GOOD.replace("\"plane\"", "\"broken.obj\"")),
            ],
            "broken.obj",
        ),
        (
            vec![
                "sweep".into(),
                good.clone(),
                "--techniques".into(),
                "shadow-map,nope".into(),
            ],
            "unknown technique 'nope'",
        ),
        (
            vec!["bench".into(), "frame".into(), "--triangles".into(), "1".into()],
            "'--triangles <TRIANGLES>': 1 is outside 2..=10000000",
        ),
        (
            vec!["bench".into(), "raster".into(), "--mode".into(), "paint".into()],
            "unknown raster mode 'paint'",
        ),
    ];
    let _ = std::fs::write(
        std::path::Path::new(&good).with_file_name("broken.obj"),
        "v 0 0 0\nv 1 0 0\nf 1 2 9\n",
    );
    for (args, expect) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (ok, text) = cli(&args);
        assert!(!ok, "{args:?} must fail:\n{text}");
        assert!(text.contains(expect), "{args:?}: expected '{expect}' in:\n{text}");
    }
}

#[test]
fn cli_export_and_list() {
    let out = std::env::temp_dir().join(format!("penumbra-test-export-{}", std::process::id()));
    let (ok, text) = cli(&["export", "fixtures/scenes/contact.toml", "--out", out.to_str().unwrap()]);
    assert!(ok, "{text}");
    let obj = std::fs::read_to_string(out.join("contact.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), 14);
    let json = std::fs::read_to_string(out.join("contact.json")).unwrap();
    assert!(json.contains("\"type\": \"disk\""), "{json}");
    let (ok, text) = cli(&["list"]);
    assert!(ok && text.contains("shadow-map") && text.contains("contact"), "{text}");
}

fn flicker(scene: &str, sets: &[(&str, &str)]) -> f64 {
    let p = Pipeline::new(2).unwrap();
    let path = format!("fixtures/scenes/{scene}.toml");
    let s = load(Path::new(&path)).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    run::render(&p, &s, &text, "shadow-map", &sets, 0, None)
        .unwrap()
        .result
        .flicker
}

/// Issue 4's failures, each where it must happen and its fix where it must not. Bounds are the
/// measured values (README) with a margin.
#[test]
fn shadow_map_failures_and_their_fixes() {
    // Peter Panning: a huge constant bias detaches the box's shadow (measured 4.07 % vs 0.03 %).
    let pp = errors("contact", "shadow-map", &[("units", "100000")]);
    let ok = errors("contact", "shadow-map", &[]);
    assert!(
        pp.wrong_pct > 2.0 && ok.wrong_pct < 0.1,
        "Peter Panning {} %, default {} %",
        pp.wrong_pct,
        ok.wrong_pct
    );
    // Normal offset and receiver-plane bias each fix acne alone (measured 0.17 % and 0.10 %).
    for (k, v) in [("normal", "1.5"), ("receiver", "true")] {
        let e = errors("grazing", "shadow-map", &[("units", "0"), ("slope", "0"), (k, v)]);
        assert!(e.wrong_pct < 0.5, "{k}={v}: {} %", e.wrong_pct);
    }
    // Second-depth fails on the open two-sided sheet (measured 2.37 %); midpoint handles the
    // sheet and the closed box without any bias (measured 0.02 %).
    let second = errors(
        "thin_sheet",
        "shadow-map",
        &[("layer", "second"), ("units", "0"), ("slope", "0")],
    );
    let mid = errors(
        "thin_sheet",
        "shadow-map",
        &[("layer", "midpoint"), ("units", "0"), ("slope", "0")],
    );
    assert!(
        second.wrong_pct > 1.0 && mid.wrong_pct < 0.1,
        "second {} %, midpoint {} %",
        second.wrong_pct,
        mid.wrong_pct
    );
    // Id maps lose self-shadowing of one object (terrain: measured 2.39 % vs 0.50 %).
    let id = errors("terrain", "shadow-map", &[("layer", "id")]);
    assert!(id.wrong_pct > 1.5, "id map on terrain {} %", id.wrong_pct);
    // 16-bit depth is too coarse for the contact scene's cube map (measured 4.07 %).
    let u16 = errors("contact", "shadow-map", &[("format", "u16")]);
    assert!(u16.wrong_pct > 1.0, "u16 {} %", u16.wrong_pct);
    // Point light among casters: no seam errors (measured 0.01 % wrong).
    let pc = errors("point_casters", "shadow-map", &[]);
    assert!(pc.wrong_pct < 0.1, "point light {} %", pc.wrong_pct);
}

#[test]
fn fitted_maps_shimmer_without_snapping() {
    // Measured at 1024 texels: 0.00117 fitted, 0.00034 fitted and snapped, 0.00027 unfitted.
    let fit = flicker("subtexel_path", &[("size", "1024"), ("fit", "receivers")]);
    let snapped = flicker(
        "subtexel_path",
        &[("size", "1024"), ("fit", "receivers"), ("snap", "true")],
    );
    assert!(fit > 2.0 * snapped, "fitted {fit}, snapped {snapped}");
}

#[test]
fn fitting_lists_the_fitted_frustum_and_improves_long_views() {
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new("fixtures/scenes/long_view.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("shadow-map", &[("fit".into(), "receivers".into())]).unwrap();
    t.visibility(&p, &f).unwrap();
    let names: Vec<String> = t.stages(&p, &f).unwrap().iter().map(|s| s.name().to_string()).collect();
    assert_eq!(names, ["depth_map0", "fitted_frustum", "texel_footprint"]);
    assert!(t.timings().iter().any(|(n, _)| *n == "lookup pass"));
    // Measured: 0.03 % wrong fitted, 0.05 % fitted to the whole scene.
    let fitted = errors("long_view", "shadow-map", &[("fit", "receivers")]);
    let whole = errors("long_view", "shadow-map", &[]);
    assert!(
        fitted.rmse < whole.rmse,
        "fitted {} vs whole scene {}",
        fitted.rmse,
        whole.rmse
    );
}

#[test]
fn point_light_inside_a_caster_shadows_everything_outside() {
    // Documented behaviour: the light sees only the caster's inside, so every receiver outside
    // is in shadow, as the reference says.
    let text = "[camera]\nposition = [0, 4, 6]\ntarget = [0, 0, 0]\nresolution = [64, 48]\n\n[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\n\n[[object]]\nmesh = \"plane\"\nsize = 8\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [0, 1, 0]\n";
    let s = penumbra::scene::file::parse(text, Path::new("inside.toml")).unwrap();
    let p = Pipeline::new(2).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("shadow-map", &[]).unwrap();
    let v = t.visibility(&p, &f).unwrap();
    let (r, _, _) = run::reference(&p, &f, 0, None).unwrap();
    let mask = f.metric_mask();
    let e = compare(&v, &r, &mask);
    assert!(
        e.pixels > 1000 && e.wrong_pct == 0.0,
        "{} % of {}",
        e.wrong_pct,
        e.pixels
    );
    assert!(v
        .to_scalar()
        .iter()
        .zip(&mask)
        .filter(|(_, m)| **m)
        .all(|(&x, _)| x == 0.0));
}

/// Errors against the *hard* reference (visibility of the light's centre), the ground truth of
/// exact hard-shadow techniques.
fn hard_errors(scene: &str, technique: &str, sets: &[(&str, &str)]) -> penumbra::metrics::Errors {
    let (v, r, mask, _) = run_hard(scene, technique, sets);
    compare_scalar(&v, &r, &mask)
}

#[test]
fn shadow_volumes_are_exact_and_z_pass_fails_with_the_eye_inside() {
    // Issue 5's bound: at most 0.05 % wrong against the hard reference on every opaque fixture.
    for scene in [
        "contact",
        "grazing",
        "overlap",
        "eye_in_volume",
        "facing_light",
        "long_view",
        "thin_sheet",
        "point_casters",
        "spheres",
        "subtexel_path",
    ] {
        let e = hard_errors(scene, "shadow-volume", &[]);
        assert!(e.wrong_pct <= 0.05, "{scene}: {} % wrong", e.wrong_pct);
    }
    // The terrain under a low sun is full of light-centre rays that graze silhouette edges,
    // which the bound excludes; measured 0.077 % there.
    let e = hard_errors("terrain", "shadow-volume", &[]);
    assert!(e.wrong_pct <= 0.1, "terrain: {} % wrong", e.wrong_pct);
    // z-pass without the eye's count, the eye inside a volume: the count is inverted
    // everywhere (measured 99.999 %); with the count (Heidmann), exact (0.001 %), because the
    // near-plane rectangle lies inside the same volume as the eye.
    let naive = hard_errors("eye_in_volume", "shadow-volume", &[("mode", "zpass-naive")]);
    assert!(naive.wrong_pct > 50.0, "naive z-pass: {} %", naive.wrong_pct);
    let counted = hard_errors("eye_in_volume", "shadow-volume", &[("mode", "zpass")]);
    assert!(
        counted.wrong_pct <= 0.05,
        "z-pass with the eye count: {} %",
        counted.wrong_pct
    );
}

#[test]
fn z_pass_fails_where_the_near_plane_cuts_a_volume() {
    // Measured: z-pass 37.7 % wrong (62.3 % without the eye count), z-fail and auto 0.003 %.
    let zpass = hard_errors("near_plane", "shadow-volume", &[("mode", "zpass")]);
    assert!(zpass.wrong_pct > 20.0, "z-pass: {} %", zpass.wrong_pct);
    for mode in ["zfail", "auto"] {
        let e = hard_errors("near_plane", "shadow-volume", &[("mode", mode)]);
        assert!(e.wrong_pct <= 0.05, "{mode}: {} %", e.wrong_pct);
    }
}

#[test]
fn broken_meshes_are_reported_and_still_shadow_exactly() {
    // A box OBJ with a missing face (a hole), a flipped face (inconsistent winding), duplicate
    // vertices and a zero-area triangle, plus a non-manifold fin: reported, no panic, and the
    // per-triangle fallback still matches the hard reference.
    // Flat normals: smooth normals generated for a faceted box would move its own
    // terminator, which is not what this test is about.
    let obj = "v -0.5 0 -0.5\nv 0.5 0 -0.5\nv 0.5 0 0.5\nv -0.5 0 0.5\nv -0.5 1 -0.5\nv 0.5 1 -0.5\nv 0.5 1 0.5\nv -0.5 1 0.5\nv 0.5 1 0.5\nv 0 2 0\nvn 0 -1 0\nvn 0 1 0\nvn 0 0 -1\nvn 1 0 0\nvn 0 0 1\nvn -1 0 0\nvn 0 -0.447 0.894\nf 1//1 2//1 3//1\nf 1//1 3//1 4//1\nf 5//2 8//2 7//2\nf 5//2 7//2 6//2\nf 1//3 5//3 6//3\nf 1//3 6//3 2//3\nf 2//4 6//4 9//4\nf 2//4 7//4 3//4\nf 3//5 8//5 7//5\nf 3//5 8//5 4//5\nf 4//6 8//6 5//6\nf 1//1 1//1 2//1\nf 5//7 6//7 10//7\n";
    // Own folder: other tests remove theirs when they finish.
    let dir = std::env::temp_dir().join(format!("penumbra-broken-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, body: &str| {
        let p = dir.join(name);
        std::fs::write(&p, body).unwrap();
        p.to_string_lossy().into_owned()
    };
    let obj_path = write("broken.obj", obj);
    let scene = write(
        "broken.toml",
        &format!(
            "# broken\n[camera]\nposition = [2, 4, 5]\ntarget = [0, 0, 0]\nresolution = [160, 90]\n\n\
             [[light]]\ntype = \"point\"\nposition = [1, 5, 1]\n\n\
             [[object]]\nname = \"ground\"\nmesh = \"plane\"\nsize = 8\n\n\
             [[object]]\nname = \"broken\"\nmesh = \"{}\"\ntranslate = [0, 0.3, 0]\n",
            obj_path.replace('\\', "/")
        ),
    );
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new(&scene)).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("shadow-volume", &[]).unwrap();
    let v = t.visibility(&p, &f).unwrap();
    let notes = t.notes().join("\n");
    for what in [
        "'broken'",
        "open edges",
        "inconsistent winding",
        "non-manifold",
        "degenerate",
    ] {
        assert!(notes.contains(what), "notes lack {what}: {notes}");
    }
    let r = penumbra::reference::Reference::new(&s);
    let opts = penumbra::reference::ReferenceOptions {
        area: false,
        ..Default::default()
    };
    let rv = p.install(|| r.visibility(f.points(), f.width() as usize, &f.light, &opts));
    let e = compare(&v, &rv, &f.metric_mask());
    assert!(e.wrong_pct <= 0.05, "{} % wrong", e.wrong_pct);
    // Stages: stencil counts, silhouettes, volume fill; the fill sums to the counter.
    let stages = t.stages(&p, &f).unwrap();
    let names: Vec<&str> = stages.iter().map(|s| s.name()).collect();
    assert_eq!(names, ["stencil_counts_zpass", "silhouettes", "volume_fill"]);
    let fill: f64 = match &stages[2] {
        shadow::Stage::Scalar { data, .. } => data.data().iter().map(|&x| x as f64).sum(),
        _ => unreachable!(),
    };
    let counted = t.counters().iter().find(|c| c.0 == "stencil fragments").unwrap().1;
    assert_eq!(fill, counted);
    // The CLI shows the notes.
    let (ok, text) = cli(&["render", &scene, "--technique", "shadow-volume", "--reps", "1"]);
    assert!(ok && text.contains("note: object 'broken'"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn auto_mode_picks_z_fail_only_when_the_near_plane_may_be_shadowed() {
    let p = Pipeline::new(2).unwrap();
    for (scene, zpass) in [("eye_in_volume", false), ("long_view", true)] {
        let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        assert_eq!(shadow::volume::shadow_volume::zpass_is_safe(&f), zpass, "{scene}");
        let mut t = shadow::registry::create("shadow-volume", &[]).unwrap();
        t.visibility(&p, &f).unwrap();
        let name = t.stages(&p, &f).unwrap()[0].name().to_string();
        assert_eq!(
            name,
            if zpass {
                "stencil_counts_zpass"
            } else {
                "stencil_counts_zfail"
            }
        );
    }
    // Auto is as exact as z-fail where z-pass would fail.
    let e = hard_errors("eye_in_volume", "shadow-volume", &[]);
    assert!(e.wrong_pct <= 0.05, "{} %", e.wrong_pct);
}

#[test]
fn z_fail_needs_depth_clamp_when_the_far_plane_cuts_volumes() {
    // Measured: 93.4 % wrong without clamp, 0.000 % with it (and with auto, which picks z-pass).
    let cut = hard_errors("far_plane", "shadow-volume", &[("mode", "zfail-noclamp")]);
    assert!(cut.wrong_pct > 10.0, "far plane cutting volumes: {} %", cut.wrong_pct);
    // Either fix: depth clamp, or the far plane at infinity.
    for mode in ["zfail", "zfail-infinite"] {
        let e = hard_errors("far_plane", "shadow-volume", &[("mode", mode)]);
        assert!(e.wrong_pct <= 0.05, "{mode}: {} %", e.wrong_pct);
    }
}

/// Visibility of `technique` and the hard reference on `scene`, with the frame.
fn run_hard(scene: &str, technique: &str, sets: &[(&str, &str)]) -> (Vec<f32>, Vec<f32>, Vec<bool>, Vec<u32>) {
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let r = penumbra::reference::Reference::new(&s);
    let opts = penumbra::reference::ReferenceOptions {
        area: false,
        ..Default::default()
    };
    let rv = p.install(|| r.visibility(f.points(), f.width() as usize, &f.light, &opts));
    let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let mut t = shadow::registry::create(technique, &sets).unwrap();
    let v = t.visibility(&p, &f).unwrap();
    (
        v.to_scalar(),
        rv.to_scalar(),
        f.metric_mask(),
        f.gbuffer.object.data().to_vec(),
    )
}

fn object_index(scene: &str, name: &str) -> u32 {
    let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
    s.objects.iter().position(|o| o.name == name).unwrap() as u32
}

#[test]
fn planar_shadows_match_the_reference_on_their_plane() {
    // Measured 0.000 % wrong on the ground of both scenes.
    for scene in ["planar", "contact"] {
        let g = object_index(scene, "ground");
        let (v, r, mask, obj) = run_hard(scene, "planar", &[]);
        let on_ground: Vec<bool> = mask.iter().zip(&obj).map(|(m, o)| *m && *o == g).collect();
        let e = compare_scalar(&v, &r, &on_ground);
        assert!(e.wrong_pct <= 0.05, "{scene}: {} % wrong on the ground", e.wrong_pct);
        assert!(on_ground.iter().filter(|m| **m).count() > 1000);
    }
    // Off planes nothing is shadowed: the terrain (no plane) loses all its shadows (2.39 %),
    // and in `overlap` the shadows on the casters themselves (1.38 %).
    for (scene, bound) in [("terrain", 2.0), ("overlap", 1.0)] {
        let e = hard_errors(scene, "planar", &[]);
        assert!(e.wrong_pct > bound, "{scene}: {} %", e.wrong_pct);
    }
}

#[test]
fn planar_stencil_removes_double_blending_and_overhang() {
    let g = object_index("planar", "ground");
    let floor = object_index("planar", "floor");
    // Half darkness: with the stencil every shadowed ground pixel is exactly 0.5; without,
    // overlapping flattened triangles (both slabs, and each slab's top and bottom) darken
    // twice or more.
    let (on, ..) = run_hard("planar", "planar", &[("darkness", "0.5")]);
    let (off, _, _, obj) = run_hard("planar", "planar", &[("darkness", "0.5"), ("stencil", "off")]);
    let ground = |v: &[f32]| -> Vec<f32> { v.iter().zip(&obj).filter(|(_, o)| **o == g).map(|(x, _)| *x).collect() };
    assert!(ground(&on).iter().all(|&x| x == 1.0 || x == 0.5));
    let doubled = ground(&off).iter().filter(|&&x| x < 0.5).count();
    assert!(doubled > 1000, "{doubled} doubly darkened pixels");
    // Overhang: the post's shadow runs past the ground's edge; without the stencil it lands on
    // the floor below, with the stencil only the receiver darkens.
    let on_floor = |v: &[f32]| v.iter().zip(&obj).filter(|(x, o)| **o == floor && **x < 1.0).count();
    let (on, ..) = run_hard("planar", "planar", &[("receiver", "ground")]);
    let (off, ..) = run_hard("planar", "planar", &[("receiver", "ground"), ("stencil", "off")]);
    assert_eq!(on_floor(&on), 0);
    assert!(on_floor(&off) > 100, "{} floor pixels", on_floor(&off));
}

#[test]
fn planar_casters_beyond_the_light_cast_nothing() {
    // The lamp shade above the light: clipped, nothing (0.000 %); dividing by w naively
    // draws its anti-shadow (measured 1.65 %).
    let clipped = hard_errors("planar", "planar", &[]);
    let naive = hard_errors("planar", "planar", &[("clip", "off")]);
    assert!(clipped.wrong_pct <= 0.05, "{} %", clipped.wrong_pct);
    assert!(naive.wrong_pct > 1.0, "{} %", naive.wrong_pct);
    // Bad receivers are errors that say what is wrong.
    let p = Pipeline::new(1).unwrap();
    let s = load(Path::new("fixtures/scenes/planar.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    for (r, what) in [
        ("nothing", "option receiver=nothing names no object of the scene"),
        ("post", "not planar"),
    ] {
        let mut t = shadow::registry::create("planar", &[("receiver".into(), r.into())]).unwrap();
        let e = t.visibility(&p, &f).err().unwrap().to_string();
        assert!(e.contains(what), "{e}");
    }
}

/// Wrong % of `technique` against the hard reference on the pixels of object `name` only.
fn wrong_on(scene: &str, technique: &str, sets: &[(&str, &str)], name: &str) -> f64 {
    let id = object_index(scene, name);
    let (v, r, mask, obj) = run_hard(scene, technique, sets);
    let only: Vec<bool> = mask.iter().zip(&obj).map(|(m, o)| *m && *o == id).collect();
    compare_scalar(&v, &r, &only).wrong_pct
}

#[test]
fn cookies_cannot_self_shadow_and_shadow_backwards() {
    // Measured on `cookie`: the shelf between light and boxes is 100 % wrong (darkened from
    // behind), the lower box 23.4 % (its top, shadowed by the upper box, stays lit); the
    // ground, where the projection is right, 0.009 % (bilinear 0.004 %).
    for filter in ["nearest", "bilinear"] {
        let sets = [("filter", filter)];
        let shelf = wrong_on("cookie", "cookie", &sets, "shelf");
        let lower = wrong_on("cookie", "cookie", &sets, "lower");
        let ground = wrong_on("cookie", "cookie", &sets, "ground");
        assert!(shelf > 90.0, "{filter}: shelf {shelf} %");
        assert!(lower > 15.0, "{filter}: lower box {lower} %");
        assert!(ground < 0.1, "{filter}: ground {ground} %");
    }
    // A shadow-volume on the same scene is exact, so the failures are the cookie's.
    let e = hard_errors("cookie", "shadow-volume", &[]);
    assert!(e.wrong_pct <= 0.05, "{} %", e.wrong_pct);
    // Naming an unknown occluder is an error that lists the objects.
    let p = Pipeline::new(1).unwrap();
    let s = load(Path::new("fixtures/scenes/cookie.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("cookie", &[("occluders".into(), "upper, nope".into())]).unwrap();
    let e = t.visibility(&p, &f).err().unwrap().to_string();
    assert!(
        e.contains("occluders=nope names no object") && e.contains("shelf"),
        "{e}"
    );
}

/// `bench frame --export` and `bench raster --export` write the workload another renderer
/// runs (tools/llvmpipe_bench.py): vertex and index files of the right sizes, and the layout,
/// matrices and targets in workload.json; an unwritable folder is a clear error.
#[test]
fn bench_export_writes_the_workload() {
    let dir = std::env::temp_dir().join(format!("penumbra-export-{}", std::process::id()));
    let frame = dir.join("frame");
    let (ok, text) = cli(&[
        "bench",
        "frame",
        "--triangles",
        "2000",
        "--map",
        "128",
        "--width",
        "96",
        "--height",
        "64",
        "--reps",
        "1",
        "--threads",
        "1",
        "--export",
        frame.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let mesh = penumbra::bench::spheres_scene(2000);
    let len = |name: &str| std::fs::metadata(frame.join(name)).unwrap().len() as usize;
    assert_eq!(len("vertices.f32"), mesh.vertices.len() * 9 * 4);
    assert_eq!(len("indices.u32"), mesh.indices.len() * 4);
    let json = std::fs::read_to_string(frame.join("workload.json")).unwrap();
    for key in [
        "\"kind\":\"frame\"",
        "\"floats_per_vertex\":9",
        "\"mode\":\"pcf2\"",
        "\"map\":128",
        "\"width\":96",
        "\"height\":64",
        "\"light_vp\":[",
        "\"camera_vp\":[",
        "\"to_light\":[",
        "\"camera_cull\":\"back\"",
    ] {
        assert!(json.contains(key), "{key} in {json}");
    }
    // The first vertex is the ground's first corner, as penumbra draws it.
    let bytes = std::fs::read(frame.join("vertices.f32")).unwrap();
    let x = f32::from_le_bytes(bytes[0..4].try_into().unwrap());
    assert_eq!(x, mesh.vertices[0].pos.x);

    let raster = dir.join("raster");
    let (ok, text) = cli(&[
        "bench",
        "raster",
        "--triangles",
        "300",
        "--mode",
        "depth",
        "--reps",
        "1",
        "--threads",
        "1",
        "--export",
        raster.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert_eq!(
        std::fs::metadata(raster.join("vertices.f32")).unwrap().len(),
        300 * 3 * 8 * 4
    );
    assert!(std::fs::read_to_string(raster.join("workload.json"))
        .unwrap()
        .contains("\"mode\":\"depth\""));

    // A folder that cannot be made: the error names the path.
    let file = dir.join("plain-file");
    std::fs::write(&file, b"x").unwrap();
    let bad = file.join("sub");
    let (ok, text) = cli(&[
        "bench",
        "raster",
        "--triangles",
        "10",
        "--reps",
        "1",
        "--export",
        bad.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("plain-file"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn coloured_glass_gives_a_colour_reference_that_no_scalar_technique_matches() {
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new("fixtures/scenes/stained_glass.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let (r, _, _) = run::reference(&p, &f, 0, None).unwrap();
    assert!(r.is_rgb(), "coloured materials make a colour reference");
    // Light through the red pane alone: red passes, green and blue do not.
    let red = (0..r.len()).filter(|&i| {
        let c = r.rgb(i);
        c.x > 0.8 && c.y < 0.2 && c.z < 0.2
    });
    assert!(red.count() > 500, "a red-tinted shadow on the ground");
    // Where panes overlap the tints multiply: some pixel is dark in every channel but not 0.
    assert!((0..r.len()).any(|i| {
        let c = r.rgb(i);
        c.max_element() > 0.0 && c.max_element() < 0.2
    }));
    // A scalar technique's best single value per pixel still misses the channels.
    let mut t = shadow::registry::create("shadow-volume", &[]).unwrap();
    let v = t.visibility(&p, &f).unwrap();
    assert!(!v.is_rgb());
    let e = compare(&v, &r, &f.metric_mask());
    assert!(e.rmse > 0.1, "scalar against colour: RMSE over channels {}", e.rmse);
    // Grey veils (layers) keep a scalar reference.
    let s = load(Path::new("fixtures/scenes/layers.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    assert!(!run::reference(&p, &f, 0, None).unwrap().0.is_rgb());
}

/// The per-pixel contract: every technique's `inspect` comes from the code that drew its image,
/// so at every 29th pixel of every fixture (every technique, its first sweep setting) the
/// explanation ends with one result, the image's value bit for bit. Techniques whose
/// explanation redraws light passes or walks whole lists (the multi-sample light, the IZB and
/// the hybrid) are checked at every 29th pixel of every 29th row.
#[test]
fn inspect_agrees_with_the_image_at_many_pixels() {
    let p = Pipeline::new(2).unwrap();
    let mut scenes: Vec<_> = std::fs::read_dir("fixtures/scenes")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    let mut checked = 0usize;
    for path in &scenes {
        let s = load(path).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let (w, h) = (f.width(), f.height());
        for info in shadow::registry::registry().into_iter().filter(|t| t.applies_to(&s)) {
            let sets: Vec<(String, String)> = info.sweep[0]
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            let mut t = shadow::registry::create(info.name, &sets).unwrap();
            let v = t.visibility(&p, &f).unwrap();
            let coarse = matches!(info.name, "multi-sample" | "izb" | "hybrid");
            let (dx, dy) = if coarse { (29, 29) } else { (1, 1) };
            let mut i = 0u32;
            while i < w * h {
                let (x, y) = (i % w, i / w);
                i += 29 * dx;
                if y % dy != 0 {
                    continue;
                }
                let steps = t.inspect(&f, x, y);
                let want = v.value((y * w + x) as usize);
                if f.point(x, y).is_none() {
                    continue;
                }
                let name = format!("{} on {} at ({x}, {y})", info.name, path.display());
                let results = steps.iter().filter(|s| s.name == "result").count();
                assert_eq!(results, 1, "{name}: one result step, the last");
                let last = steps.last().unwrap();
                assert_eq!(last.name, "result", "{name}");
                let got = match last.values[0].1 {
                    shadow::Value::Num(n) => n as f32,
                    _ => panic!("{name}: result is not a number"),
                };
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "{name}: inspect {got} vs image {want}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 100_000, "{checked} pixels checked");
}

#[test]
fn inspect_explains_a_pixel_for_every_technique() {
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new("fixtures/scenes/contact.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    // A pixel in the box's shadow on the ground: every technique's last step is its result,
    // equal to the image's value there.
    let (x, y) = (f.width() / 2, f.height() * 3 / 4);
    assert!(f.point(x, y).is_some());
    for info in shadow::registry::registry().into_iter().filter(|t| t.applies_to(&s)) {
        for set in info.sweep.iter().take(2) {
            let sets: Vec<(String, String)> = set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            let mut t = shadow::registry::create(info.name, &sets).unwrap();
            let v = t.visibility(&p, &f).unwrap();
            let steps = t.inspect(&f, x, y);
            let last = steps.last().unwrap_or_else(|| panic!("{} explains nothing", info.name));
            assert_eq!(last.name, "result", "{}", info.name);
            let got = match last.values[0].1 {
                shadow::Value::Num(n) => n as f32,
                _ => panic!("{}: result is not a number", info.name),
            };
            let want = v.value((y * f.width() + x) as usize);
            assert!(
                got == want || (got.is_nan() && want.is_nan()),
                "{}: inspect {got} vs image {want}",
                info.name
            );
            assert!(steps.len() >= 2, "{}: at least one step before the result", info.name);
        }
    }
    // The CLI: text and JSON.
    let (ok, out) = cli(&[
        "inspect",
        "fixtures/scenes/contact.toml",
        "--technique",
        "shadow-map",
        "--set",
        "filter=pcf2",
        "--pixel",
        &format!("{x},{y}"),
        "--json",
    ]);
    assert!(ok, "{out}");
    assert!(
        out.contains("\"steps\"") && out.contains("stored depth 0") && out.contains("\"reference\""),
        "{out}"
    );
    let (ok, out) = cli(&["inspect", "fixtures/scenes/contact.toml", "--pixel", "9999,1"]);
    assert!(!ok && out.contains("outside the"), "{out}");
    let (ok, out) = cli(&["inspect", "fixtures/scenes/contact.toml", "--pixel", "a,b"]);
    assert!(!ok && out.contains("is not X,Y"), "{out}");
}

/// Fixtures whose every caster is opaque.
const OPAQUE: &[&str] = &[
    "contact",
    "cookie",
    "eye_in_volume",
    "facing_light",
    "far_plane",
    "grazing",
    "long_view",
    "near_plane",
    "overlap",
    "planar",
    "point_casters",
    "spheres",
    "subtexel_path",
    "terrain",
    "thin_sheet",
    "wires",
];

#[test]
fn izb_is_exact_on_every_opaque_fixture_without_any_bias() {
    // Measured: 0.000 % everywhere but long_view (1 pixel of 71024, 0.0014 %). The issue's
    // bound: 0.02 %.
    for scene in OPAQUE {
        let e = hard_errors(scene, "izb", &[]);
        assert!(
            e.wrong_pct <= 0.02,
            "{scene}: izb wrong {} % (bound 0.02 %)",
            e.wrong_pct
        );
        assert!(e.pixels > 10_000, "{scene}");
    }
}

#[test]
fn izb_needs_conservative_rasterization_for_thin_occluders() {
    let exact = hard_errors("wires", "izb", &[]);
    let broken = hard_errors("wires", "izb", &[("raster", "standard")]);
    // Measured: 0.000 % conservative, 1.14 % standard (cables and slats thinner than a texel).
    assert!(exact.wrong_pct <= 0.02, "conservative: {} %", exact.wrong_pct);
    assert!(
        broken.wrong_pct > 0.8,
        "standard rasterization breaks thin shadows: {} %",
        broken.wrong_pct
    );
    // A coarser grid makes more occluders sub-texel: standard breaks more, conservative is
    // still exact.
    let coarse = hard_errors("wires", "izb", &[("raster", "standard"), ("size", "256")]);
    assert!(
        coarse.wrong_pct > broken.wrong_pct,
        "{} vs {}",
        coarse.wrong_pct,
        broken.wrong_pct
    );
    assert!(hard_errors("wires", "izb", &[("size", "256")]).wrong_pct <= 0.02);
}

/// The IZB with `k` samples per pixel on `scene`: its per-sample visibility against the hard
/// reference at the same sample points (fraction wrong), and its image.
fn izb_samples(scene: &str, k: &str) -> (f64, Vec<f32>, penumbra::frame::Frame<'static>) {
    let p = Pipeline::new(2).unwrap();
    let s: &'static _ = Box::leak(Box::new(
        load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap(),
    ));
    let f = frame::frame(&p, s, 0, 0).unwrap();
    let mut t = shadow::exact::izb::Izb::new(shadow::exact::izb::Options {
        samples: penumbra::shadow::options::OptionValue::parse(k).unwrap(),
        ..Default::default()
    })
    .unwrap();
    use penumbra::shadow::ShadowTechnique;
    let v = t.visibility(&p, &f).unwrap().to_scalar();
    let r = penumbra::reference::Reference::new(s);
    let sv = t.sample_visibility();
    let wrong = shadow::exact::izb::camera_samples(&f, t.options().samples)
        .iter()
        .zip(&sv)
        .filter(|(c, &lit)| {
            let faces = c.point.normal.dot(f.light.to_light(c.point.position)) > 0.0;
            faces && (r.hard(&c.point, &f.light) - lit).abs() > 0.5
        })
        .count();
    (wrong as f64 / sv.len() as f64 * 100.0, v, f)
}

/// Regression: sub-pixel samples on the pixel's tangent plane (the plane of its interpolated
/// normal) lay under the neighbouring facets of a smooth-shaded heightfield, which shadowed
/// them: `izb [samples=4]` was 1.88 % wrong on `terrain` (RMSE 0.23, dark speckle over the lit
/// ground) and 1.30 % on `forest_floor`, where one sample per pixel is exact. On the visible
/// triangle they are exact at their points and the image is as right as one sample's.
/// Measured: 0.000 % on terrain and 0.007 % on forest_floor at 4 samples, 0.000 % at the
/// samples themselves.
#[test]
fn izb_sub_pixel_samples_stay_on_a_heightfields_surface() {
    for scene in ["terrain", "forest_floor"] {
        let e = hard_errors(scene, "izb", &[("samples", "4")]);
        assert!(e.wrong_pct <= 0.02, "{scene}: izb [samples=4] wrong {} %", e.wrong_pct);
        let (at_samples, _, _) = izb_samples(scene, "4");
        assert!(
            at_samples <= 0.02,
            "{scene}: {at_samples} % of samples differ at their points"
        );
    }
}

#[test]
fn izb_with_sub_pixel_samples_is_exact_at_its_samples_and_anti_aliases_edges() {
    let (wrong1, v1, f) = izb_samples("contact", "1");
    let (wrong4, v4, _) = izb_samples("contact", "4");
    let (wrong16, v16, _) = izb_samples("contact", "16");
    for (k, w) in [(1, wrong1), (4, wrong4), (16, wrong16)] {
        assert!(
            w <= 0.02,
            "{k} samples: {w} % of samples differ from the reference at the same points"
        );
    }
    // Edge RMSE against a 64-ray-per-pixel supersampled hard reference, over its edge pixels.
    let s = f.scene;
    let r = penumbra::reference::Reference::new(s);
    let ss = shadow::exact::izb::camera_samples_grid(&f, (8, 8));
    let mut truth = vec![0.0f32; v1.len()];
    for c in &ss {
        let faces = c.point.normal.dot(f.light.to_light(c.point.position)) > 0.0;
        truth[c.pixel as usize] += if faces { r.hard(&c.point, &f.light) } else { 0.0 } / 64.0;
    }
    let mask = f.metric_mask();
    let edge_rmse = |v: &[f32]| {
        let (mut se, mut n) = (0.0f64, 0u64);
        for i in 0..v.len() {
            if mask[i] && truth[i] > 0.0 && truth[i] < 1.0 {
                se += ((v[i] - truth[i]) as f64).powi(2);
                n += 1;
            }
        }
        assert!(n > 100, "the scene has shadow edges: {n} pixels");
        (se / n as f64).sqrt()
    };
    let (e1, e4, e16) = (edge_rmse(&v1), edge_rmse(&v4), edge_rmse(&v16));
    eprintln!("edge RMSE: 1 sample {e1}, 4 {e4}, 16 {e16}; wrong at samples {wrong1} {wrong4} {wrong16}");
    assert!(e4 < e1 * 0.8 && e16 < e4, "edge RMSE: 1 sample {e1}, 4 {e4}, 16 {e16}");
}

#[test]
fn izb_input_errors_and_a_light_no_sample_faces() {
    let bad = |sets: &[(&str, &str)]| {
        let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        shadow::registry::create("izb", &sets)
            .err()
            .expect("must be an error")
            .to_string()
    };
    assert!(bad(&[("size", "0")]).contains("outside [16, 16384]"));
    assert!(bad(&[("size", "99999")]).contains("outside [16, 16384]"));
    assert!(bad(&[("samples", "3")]).contains("not one of 1, 4, 16, 32"));
    assert!(bad(&[("raster", "fast")]).contains("not one of conservative, standard"));
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new("fixtures/scenes/contact.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("izb", &[("capacity".into(), "1000".into())]).unwrap();
    let e = t.visibility(&p, &f).err().unwrap();
    assert!(
        matches!(e, penumbra::Error::Budget { resource: penumbra::Resource::Entries, limit: 1000, needed, .. } if needed > 1000),
        "{e:?}"
    );
    assert!(
        e.to_string().contains("the lists' samples") && e.to_string().contains("option capacity"),
        "{e}"
    );
    // A sun below the ground: no sample faces it, everything is dark, nothing is inserted.
    let text = "[camera]\nposition = [0, 3, 6]\ntarget = [0, 0, 0]\nresolution = [64, 48]\n\n[[light]]\ntype = \"directional\"\ndirection = [0.2, 1, 0.1]\n\n[[object]]\nmesh = \"plane\"\nsize = 8\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [0, 0.5, 0]\n";
    let s = penumbra::scene::file::parse(text, Path::new("below.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("izb", &[]).unwrap();
    let v = t.visibility(&p, &f).unwrap().to_scalar();
    let covered: Vec<f32> = v.iter().copied().filter(|x| !x.is_nan()).collect();
    assert!(covered.len() > 1000 && covered.iter().all(|&x| x == 0.0));
    let inserted = t.counters().iter().find(|c| c.0 == "samples inserted").unwrap().1;
    assert_eq!(inserted, 0.0);
}

#[test]
fn izb_is_identical_for_1_2_4_threads() {
    let s = load(Path::new("fixtures/scenes/point_casters.toml")).unwrap();
    let run = |threads: usize| {
        let p = Pipeline::new(threads).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let mut t = shadow::registry::create("izb", &[("samples".into(), "4".into())]).unwrap();
        let v = t.visibility(&p, &f).unwrap();
        (v.hash(), t.counters().iter().map(|c| c.1.to_bits()).collect::<Vec<_>>())
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(4));
}

#[test]
fn four_pixel_lookups_are_identical_for_1_2_4_threads() {
    // The shadow map's wide filters (flat and with a receiver plane), PCSS, CHS and the
    // hybrid run four pixels at a time.
    for (technique, sets) in [
        ("shadow-map", &[("filter", "grid"), ("kernel", "5")][..]),
        ("shadow-map", &[("filter", "rotated"), ("kernel", "4")][..]),
        (
            "shadow-map",
            &[("filter", "tent"), ("kernel", "5"), ("receiver", "true")][..],
        ),
        ("pcss", &[][..]),
        ("chs", &[][..]),
        ("hybrid", &[][..]),
    ] {
        let one = visibility_of("contact", technique, sets, 1).hash();
        assert_eq!(
            one,
            visibility_of("contact", technique, sets, 2).hash(),
            "{technique} {sets:?}"
        );
        assert_eq!(
            one,
            visibility_of("contact", technique, sets, 4).hash(),
            "{technique} {sets:?}"
        );
    }
}

fn visibility_of(
    scene: &str,
    technique: &str,
    sets: &[(&str, &str)],
    threads: usize,
) -> penumbra::visibility::Visibility {
    let p = Pipeline::new(threads).unwrap();
    let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    shadow::registry::create(technique, &sets)
        .unwrap()
        .visibility(&p, &f)
        .unwrap()
}

#[test]
fn avsm_error_falls_with_more_nodes_and_depends_on_order() {
    // Measured on smoke (17 layers in the busiest texel): RMSE 0.0394 (4 nodes), 0.02366 (8),
    // 0.02358 (16), 0.02358 (64: nothing removed, the uncompressed limit; what remains is the
    // 512² map's resolution).
    let e: Vec<f64> = ["4", "8", "16", "64"]
        .iter()
        .map(|n| errors("smoke", "avsm", &[("nodes", n)]).rmse)
        .collect();
    assert!(
        e[0] > e[1] && e[1] >= e[2] && e[2] >= e[3] - 1e-9,
        "RMSE by nodes 4, 8, 16, 64: {e:?}"
    );
    assert!(e[0] < 0.045 && e[3] < 0.026, "{e:?}");
    // The shadow map cannot see through the puffs at all.
    assert!(errors("smoke", "shadow-map", &[]).rmse > 0.25);
    // Order dependence: the same fragments backwards give another curve where texels overflow.
    let diff = |n: &str| {
        let a = visibility_of("smoke", "avsm", &[("nodes", n)], 2).to_scalar();
        let b = visibility_of("smoke", "avsm", &[("nodes", n), ("order", "reverse")], 2).to_scalar();
        let d: Vec<f64> = a
            .iter()
            .zip(&b)
            .filter(|(x, _)| x.is_finite())
            .map(|(x, y)| (x - y).abs() as f64)
            .collect();
        (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt()
    };
    let (d4, d64) = (diff("4"), diff("64"));
    eprintln!("forward against reverse: RMS difference {d4} with 4 nodes, {d64} with 64");
    assert!(d4 > 1e-3, "4 nodes: order changes the result ({d4})");
    assert!(d64 < 1e-6, "64 nodes (nothing removed): order cannot matter ({d64})");
}

#[test]
fn avsm_matches_the_reference_through_grey_and_coloured_layers() {
    // Measured: layers RMSE 0.0149, stained_glass 0.0250 (over channels) with the defaults;
    // the shadow map: 18.9 % wrong on layers.
    let l = errors("layers", "avsm", &[]);
    let g = errors("stained_glass", "avsm", &[]);
    assert!(l.rmse < 0.02 && l.wrong_pct < 0.05, "layers: {l:?}");
    assert!(g.rmse < 0.03 && g.wrong_pct < 0.15, "stained_glass: {g:?}");
    assert!(visibility_of("stained_glass", "avsm", &[], 2).is_rgb());
}

#[test]
fn avsm_without_transparent_casters_is_the_shadow_map() {
    for scene in ["contact", "point_casters", "grazing"] {
        let a = visibility_of(scene, "avsm", &[], 2);
        let m = visibility_of(scene, "shadow-map", &[("size", "512")], 2);
        assert_eq!(a.hash(), m.hash(), "{scene}: avsm and a 512² shadow map differ");
    }
}

#[test]
fn avsm_rejects_bad_node_counts_and_is_identical_for_any_thread_count() {
    for n in ["0", "65"] {
        let e = shadow::registry::create("avsm", &[("nodes".into(), n.into())])
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("outside [1, 64]"), "{e}");
    }
    let one = visibility_of("smoke", "avsm", &[("nodes", "4")], 1).hash();
    assert_eq!(one, visibility_of("smoke", "avsm", &[("nodes", "4")], 2).hash());
    assert_eq!(one, visibility_of("smoke", "avsm", &[("nodes", "4")], 4).hash());
}

/// RMSE over channels of `technique` against the reference on the pixels of the objects
/// `pick` selects (by name) in `scene`.
fn rmse_on(scene: &str, technique: &str, pick: &dyn Fn(&str) -> bool) -> f64 {
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let (r, _, _) = run::reference(&p, &f, 0, None).unwrap();
    let v = shadow::registry::create(technique, &[])
        .unwrap()
        .visibility(&p, &f)
        .unwrap();
    let objs = f.gbuffer.object.data();
    let mask: Vec<bool> = f
        .metric_mask()
        .iter()
        .zip(objs)
        .map(|(&m, &o)| m && pick(&s.objects[o as usize].name))
        .collect();
    compare(&v, &r, &mask).rmse
}

#[test]
fn the_transparent_surface_metric_counts_the_transparent_objects_only() {
    // The run's error on transparent surfaces is the error over the panes; a scene without
    // visible transparent surfaces measures none.
    let p = Pipeline::new(2).unwrap();
    let text = std::fs::read_to_string("fixtures/scenes/stained_glass.toml").unwrap();
    let s = load(Path::new("fixtures/scenes/stained_glass.toml")).unwrap();
    let out = run::render(&p, &s, &text, "avsm", &[], 0, None).unwrap();
    let panes = rmse_on("stained_glass", "avsm", &|n| n.ends_with("_pane"));
    assert!(out.result.transparent.pixels > 1000);
    assert!(
        (out.result.transparent.rmse - panes).abs() < 1e-9,
        "{} vs {panes}",
        out.result.transparent.rmse
    );
    assert!(out.result.transparent.pixels < out.result.errors.pixels);
    let text = std::fs::read_to_string("fixtures/scenes/contact.toml").unwrap();
    let s = load(Path::new("fixtures/scenes/contact.toml")).unwrap();
    let out = run::render(&p, &s, &text, "shadow-map", &[], 0, None).unwrap();
    assert_eq!(out.result.transparent.pixels, 0);
}

#[test]
fn transparency_maps_tint_the_ground_but_miss_overlaps_and_transparent_receivers() {
    let ground = rmse_on("stained_glass", "transparency-map", &|n| n == "ground");
    let panes = rmse_on("stained_glass", "transparency-map", &|n| n.ends_with("_pane"));
    let avsm_panes = rmse_on("stained_glass", "avsm", &|n| n.ends_with("_pane"));
    eprintln!("transparency map: ground {ground}, panes {panes}; avsm panes {avsm_panes}");
    // Measured: ground 0.0706 (overlaps take the nearer pane's colour), panes 0.1074; AVSM on
    // the panes 0.0332.
    assert!(ground < 0.08, "ground {ground}");
    assert!(
        panes > 0.09 && panes > 3.0 * avsm_panes,
        "panes {panes}, avsm {avsm_panes}"
    );
    // The curtain's folds shadow each other: one transparent layer in the map, so light that
    // crossed several folds is too bright, on the sheet itself and on what lies below.
    // Measured: sheet 0.152 against AVSM 0.099; whole image 0.136 against 0.045.
    let sheet = rmse_on("curtain", "transparency-map", &|n| n == "sheet");
    let avsm_sheet = rmse_on("curtain", "avsm", &|n| n == "sheet");
    assert!(sheet > 1.3 * avsm_sheet, "curtain sheet {sheet}, avsm {avsm_sheet}");
    let (all, avsm_all) = (
        errors("curtain", "transparency-map", &[]).rmse,
        errors("curtain", "avsm", &[]).rmse,
    );
    assert!(all > 2.0 * avsm_all, "curtain {all}, avsm {avsm_all}");
    // Grey layers: one layer only, so the light under several veils is too bright.
    let e = errors("layers", "transparency-map", &[]);
    assert!(e.rmse > 0.08, "layers {}", e.rmse);
    // Without transparent casters it is the shadow map of its size.
    for scene in ["contact", "point_casters", "grazing"] {
        let a = visibility_of(scene, "transparency-map", &[], 2);
        let m = visibility_of(scene, "shadow-map", &[("size", "1024")], 2);
        assert_eq!(a.hash(), m.hash(), "{scene}");
    }
}

#[test]
fn opacity_maps_band_between_slices_and_deep_opacity_maps_need_fewer() {
    let e = |scene: &str, sets: &[(&str, &str)]| errors(scene, "opacity-maps", sets).rmse;
    // Measured on smoke: uniform 4 slices 0.0503, 16 slices 0.0406; deep 4 slices 0.0345.
    let uniform = [("layout", "uniform"), ("slices", "16")];
    let (u4, u16, d4) = (
        e("smoke", &[("layout", "uniform"), ("slices", "4")]),
        e("smoke", &uniform),
        e("smoke", &[("layout", "deep"), ("slices", "4")]),
    );
    assert!(u4 > u16 * 1.1, "more slices, less banding: {u4} vs {u16}");
    assert!(
        d4 < u16,
        "deep opacity maps with 4 slices beat 16 uniform slices: {d4} vs {u16}"
    );
    // Layers and coloured panes: a transparent surface shadows itself by the part of its slice
    // in front of it; deep slices start on the first layer. Measured: layers 0.0537 / 0.0324,
    // stained_glass 0.147 / 0.051 (uniform 16 / deep 4).
    for (scene, uniform_above, deep_below) in [("layers", 0.045, 0.04), ("stained_glass", 0.12, 0.06)] {
        let (u, d) = (e(scene, &uniform), e(scene, &[("layout", "deep"), ("slices", "4")]));
        assert!(u > uniform_above && d < deep_below, "{scene}: uniform {u}, deep {d}");
    }
    // Regression: each view of a point light's cube slices its own depth range. When every
    // face used the last face's slice thickness, layers' uniform error was 0.186.
    let u = e("layers", &uniform);
    assert!(u < 0.07, "layers, uniform 16 slices under a point light: {u}");
    // The curtain: a thin sheet whose folds span a small part of the light's depth range.
    // Measured: uniform 16 slices 0.0815, 64 slices 0.0796; deep 4 slices 0.0474.
    let (u16, u64, d4) = (
        e("curtain", &uniform),
        e("curtain", &[("layout", "uniform"), ("slices", "64")]),
        e("curtain", &[("layout", "deep"), ("slices", "4")]),
    );
    assert!(
        d4 < 0.8 * u64 && d4 < 0.8 * u16,
        "curtain: deep 4 slices {d4}, uniform 16 {u16}, 64 {u64}"
    );
    // Without transparent casters: the 512² shadow map, bit for bit.
    for scene in ["contact", "point_casters"] {
        let a = visibility_of(scene, "opacity-maps", &[], 2);
        assert_eq!(
            a.hash(),
            visibility_of(scene, "shadow-map", &[("size", "512")], 2).hash(),
            "{scene}"
        );
    }
    for n in ["0", "65"] {
        let err = shadow::registry::create("opacity-maps", &[("slices".into(), n.into())])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("outside [1, 64]"), "{err}");
    }
}

#[test]
fn deep_shadow_maps_match_the_transmittance_and_bound_avsm() {
    // Resolution aside (a 2048² map, where its error is small): measured with the bilinear
    // filter layers 0.0059, stained_glass 0.0088, smoke 0.0098 (nearest: 0.0067, 0.0121,
    // 0.0126) with tolerance 0.01.
    for scene in ["layers", "stained_glass", "smoke"] {
        let e = errors(scene, "deep-shadow-map", &[("size", "2048")]);
        assert!(e.rmse < 0.015, "{scene}: RMSE {}", e.rmse);
        let n = errors(scene, "deep-shadow-map", &[("size", "2048"), ("filter", "nearest")]);
        assert!(n.rmse < 0.02, "{scene}: nearest RMSE {}", n.rmse);
    }
    // Filtering between texels lowers the error at the map size of AVSM (measured 512²:
    // smoke 0.0186 against 0.0236 nearest, curtain 0.0381 against 0.0454).
    for scene in ["smoke", "curtain"] {
        let b = errors(scene, "deep-shadow-map", &[]).rmse;
        let n = errors(scene, "deep-shadow-map", &[("filter", "nearest")]).rmse;
        assert!(b < n * 0.9, "{scene}: bilinear {b} against nearest {n}");
    }
    // Unfiltered, the deep shadow map is the limit AVSM's compression approaches: measured
    // smoke 0.02359 (DSM) against AVSM 0.0394 (4 nodes), 0.02358 (16).
    let dsm = errors("smoke", "deep-shadow-map", &[("filter", "nearest")]).rmse;
    let avsm4 = errors("smoke", "avsm", &[("nodes", "4")]).rmse;
    assert!(avsm4 > dsm * 1.3 && (errors("smoke", "avsm", &[("nodes", "16")]).rmse - dsm).abs() < 1e-3);
    // A coarser tolerance keeps fewer vertices and loses accuracy (measured 0.0352 at 0.1).
    assert!(
        errors(
            "smoke",
            "deep-shadow-map",
            &[("tolerance", "0.1"), ("filter", "nearest")]
        )
        .rmse
            > dsm
    );
    // Opaque casters only: the 512² shadow map bit for bit, unfiltered with its hard lookup and
    // filtered with its 2x2 hardware PCF.
    for scene in ["contact", "point_casters"] {
        let a = visibility_of(scene, "deep-shadow-map", &[("filter", "nearest")], 2);
        assert_eq!(
            a.hash(),
            visibility_of(scene, "shadow-map", &[("size", "512")], 2).hash(),
            "{scene}"
        );
        let a = visibility_of(scene, "deep-shadow-map", &[], 2);
        assert_eq!(
            a.hash(),
            visibility_of(scene, "shadow-map", &[("size", "512"), ("filter", "pcf2")], 2).hash(),
            "{scene} bilinear"
        );
    }
    // Bad input: a tolerance outside (0, 1), a pool too small (the error says how large).
    for t in ["0", "1"] {
        assert!(shadow::registry::create("deep-shadow-map", &[("tolerance".into(), t.into())]).is_err());
    }
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new("fixtures/scenes/smoke.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("deep-shadow-map", &[("capacity".into(), "1000".into())]).unwrap();
    let e = t.visibility(&p, &f).err().unwrap();
    assert!(e.to_string().contains("(option capacity): "), "{e}");
    // The number the error names is enough, and one fewer is not: the pool never holds more
    // than its stated capacity.
    let n = match e {
        penumbra::Error::Budget {
            resource: penumbra::Resource::Entries,
            limit: 1000,
            needed,
            ..
        } if needed > 1000 => needed,
        e => panic!("not the fragment budget: {e:?}"),
    };
    let needed = n.to_string();
    let mut t = shadow::registry::create("deep-shadow-map", &[("capacity".into(), needed.clone())]).unwrap();
    t.visibility(&p, &f).unwrap();
    let counter = |t: &dyn shadow::ShadowTechnique, name: &str| t.counters().iter().find(|c| c.0 == name).unwrap().1;
    assert_eq!(counter(&*t, "fragments") as u64, n);
    assert!(counter(&*t, "peak bytes") >= counter(&*t, "fragment-list bytes"));
    let mut t = shadow::registry::create("deep-shadow-map", &[("capacity".into(), (n - 1).to_string())]).unwrap();
    assert!(t.visibility(&p, &f).is_err());
}

/// Wide PCF kernels (RTR 7.5): acne where the kernel outgrows the slope bias and its two fixes,
/// the hierarchy's identical output with fewer taps, pattern noise along a camera path, and bad
/// kernel options.
#[test]
fn wide_pcf_kernels_need_bias_across_the_kernel() {
    // Grazing light: a 7x7 grid compares taps up to 3 texels away against the centre's depth,
    // so the receiver shadows itself. Measured: 2x2 0.0137; 7x7 0.330; with the receiver plane
    // 0.0239, with the bias cone (slope 2) 0.0201.
    let rmse = |sets: &[(&str, &str)]| errors("grazing", "shadow-map", sets).rmse;
    let (pcf2, wide) = (
        rmse(&[("filter", "pcf2")]),
        rmse(&[("filter", "grid"), ("kernel", "7")]),
    );
    assert!(wide > 0.2 && pcf2 < 0.02, "7x7 {wide}, 2x2 {pcf2}");
    let plane = rmse(&[("filter", "grid"), ("kernel", "7"), ("receiver", "true")]);
    let cone = rmse(&[("filter", "grid"), ("kernel", "7"), ("cone", "2")]);
    assert!(plane < 0.035 && cone < 0.03, "receiver plane {plane}, cone {cone}");
    // Filtering the depths before one comparison is still a hard test: no softer than none.
    let e = |sets: &[(&str, &str)]| errors("contact", "shadow-map", sets);
    let (depth_bilinear, grid) = (e(&[("filter", "depth-bilinear")]), e(&[("filter", "grid")]));
    assert!(
        depth_bilinear.penumbra_rmse > grid.penumbra_rmse + 0.03,
        "depth-bilinear {}, grid {}",
        depth_bilinear.penumbra_rmse,
        grid.penumbra_rmse
    );
}

#[test]
fn min_max_hierarchy_gives_the_same_image_with_fewer_taps() {
    let p = Pipeline::new(2).unwrap();
    for scene in ["contact", "overlap", "point_casters", "grazing"] {
        let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        // Across the kernel: the bias cone, and the receiver plane (a sloped reference, which
        // the plane-residual bounds classify).
        for (filter, bias) in [
            ("grid", "cone"),
            ("tent", "cone"),
            ("poisson", "cone"),
            ("rotated", "cone"),
            ("grid", "receiver"),
            ("poisson", "receiver"),
        ] {
            let run = |hierarchy: &str| {
                let across = if bias == "cone" {
                    ("cone", "2")
                } else {
                    ("receiver", "true")
                };
                let mut t = shadow::registry::create(
                    "shadow-map",
                    &[
                        ("filter".into(), filter.into()),
                        (across.0.into(), across.1.into()),
                        ("hierarchy".into(), hierarchy.into()),
                    ],
                )
                .unwrap();
                let v = t.visibility(&p, &f).unwrap();
                (v.hash(), counter(&*t, "taps"))
            };
            same_image_fewer_taps(&format!("{scene} {filter} {bias}"), run("false"), run("true"));
        }
    }
}

#[test]
fn sparse_disks_flicker_more_than_the_grid_along_a_camera_path() {
    // A 9-texel kernel, acne removed by the cone, the fitted map snapped: what changes from
    // frame to frame is the pattern's noise. Measured: grid 0.00020; poisson 0.00038, rotated
    // 0.00034, spiral 0.00035.
    let f = |filter: &str| {
        flicker(
            "subtexel_path",
            &[
                ("filter", filter),
                ("kernel", "9"),
                ("cone", "2"),
                ("fit", "receivers"),
                ("snap", "true"),
            ],
        )
    };
    let grid = f("grid");
    for disk in ["poisson", "rotated", "spiral"] {
        let d = f(disk);
        assert!(d > 1.3 * grid, "{disk} {d} against grid {grid}");
    }
}

#[test]
fn bad_kernel_options_are_errors() {
    for (k, v, says) in [
        ("taps", "0", "outside [1, 256]"),
        ("taps", "257", "outside [1, 256]"),
        ("kernel", "0", "outside"),
    ] {
        let e = shadow::registry::create(
            "shadow-map",
            &[("filter".into(), "poisson".into()), (k.into(), v.into())],
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains(says), "{k}={v}: {e}");
    }
    let e = shadow::registry::create(
        "shadow-map",
        &[
            ("filter".into(), "grid".into()),
            ("size".into(), "64".into()),
            ("kernel".into(), "65".into()),
        ],
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("wider than the map"), "{e}");
}

/// A scene, a technique and its option set.
type Case<'a> = (&'a str, &'a str, &'a [(&'a str, &'a str)]);

#[test]
fn wide_kernels_and_filtered_deep_maps_are_identical_for_1_2_4_threads() {
    let cases: &[Case] = &[
        ("contact", "shadow-map", &[("filter", "rotated")]),
        ("contact", "shadow-map", &[("filter", "spiral"), ("hierarchy", "true")]),
        (
            "grazing",
            "shadow-map",
            &[("filter", "tent"), ("receiver", "true"), ("cone", "2")],
        ),
        ("curtain", "deep-shadow-map", &[]),
        ("overlap", "pcss", &[("disk", "rotated"), ("hierarchy", "true")]),
        ("pergola", "chs", &[]),
        ("contact", "hybrid", &[]),
        ("pergola", "multi-sample", &[("samples", "8"), ("size", "256")]),
        ("forest", "pvm", &[]),
        ("forest", "pvmf", &[("blur", "12")]),
        (
            "overlap",
            "pvmf",
            &[("ids", "group"), ("layer", "midpoint"), ("blur", "12")],
        ),
    ];
    for (scene, technique, sets) in cases {
        let one = visibility_of(scene, technique, sets, 1).hash();
        for threads in [2, 4] {
            assert_eq!(
                one,
                visibility_of(scene, technique, sets, threads).hash(),
                "{scene} {technique} {sets:?}: 1 vs {threads} threads"
            );
        }
    }
}

/// `technique` on `scene`, its reference and the frame's points and metric mask.
fn soft_run(
    scene: &str,
    technique: &str,
    sets: &[(&str, &str)],
) -> (Vec<f32>, Vec<f32>, Vec<Option<glam::Vec3>>, Vec<bool>) {
    with_reference(scene, technique, sets, |v, r, f| {
        let pts = f.points().iter().map(|s| s.map(|s| s.position)).collect();
        (v.to_scalar(), r.to_scalar(), pts, f.metric_mask())
    })
}

fn rmse_where(v: &[f32], r: &[f32], pick: impl Fn(usize) -> bool) -> (f64, usize) {
    let (mut se, mut n) = (0.0f64, 0usize);
    for i in 0..v.len() {
        if pick(i) && r[i].is_finite() {
            let d = if v[i].is_finite() { (v[i] - r[i]) as f64 } else { 1.0 };
            se += d * d;
            n += 1;
        }
    }
    ((se / n.max(1) as f64).sqrt(), n)
}

/// PCSS (Fernando 2005) against the area-light reference: its penumbra follows the occluder
/// distance, a zero-width light is the hard map, the hierarchy changes nothing but the taps.
#[test]
fn pcss_is_the_hard_map_without_a_light_width_and_softens_with_one() {
    let p = Pipeline::new(2).unwrap();
    for scene in ["contact", "point_casters", "grazing"] {
        let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let hash = |t: &str, sets: &[(&str, &str)]| {
            let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            shadow::registry::create(t, &sets)
                .unwrap()
                .visibility(&p, &f)
                .unwrap()
                .hash()
        };
        // Light width 0 (contact), a point light (point_casters) and a directional light
        // without an angle (grazing) are all the 2x2-PCF shadow map.
        let hard = hash("shadow-map", &[("filter", "pcf2")]);
        let sets: &[(&str, &str)] = if scene == "contact" { &[("light", "0")] } else { &[] };
        assert_eq!(hash("pcss", sets), hard, "{scene}");
    }
    // Measured penumbra RMSE: contact 0.0512, overlap 0.0942, pergola 0.1457; the 2x2-PCF
    // map 0.253, 0.261, 0.371.
    for (scene, bound) in [("contact", 0.06), ("overlap", 0.11), ("pergola", 0.17)] {
        let pcss = errors(scene, "pcss", &[]);
        let hard = errors(scene, "shadow-map", &[("filter", "pcf2")]);
        assert!(pcss.penumbra_rmse < bound, "{scene}: {}", pcss.penumbra_rmse);
        assert!(
            pcss.penumbra_rmse < 0.6 * hard.penumbra_rmse,
            "{scene}: {} vs hard {}",
            pcss.penumbra_rmse,
            hard.penumbra_rmse
        );
    }
}

#[test]
fn pcss_hierarchy_gives_the_same_image_with_fewer_taps() {
    let p = Pipeline::new(2).unwrap();
    for scene in ["contact", "overlap", "pergola"] {
        let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        for (disk, receiver) in [("poisson", "false"), ("spiral", "false"), ("poisson", "true")] {
            let run = |h: &str| {
                let mut t = shadow::registry::create(
                    "pcss",
                    &[
                        ("disk".into(), disk.into()),
                        ("receiver".into(), receiver.into()),
                        ("hierarchy".into(), h.into()),
                    ],
                )
                .unwrap();
                let v = t.visibility(&p, &f).unwrap();
                (v.hash(), counter(&*t, "taps"), counter(&*t, "early outs"))
            };
            let (plain, with) = (run("false"), run("true"));
            let label = format!("{scene} {disk} receiver={receiver}");
            assert_eq!(plain.2, with.2, "{label}: same early outs");
            same_image_fewer_taps(&label, (plain.0, plain.1), (with.0, with.1));
        }
    }
}

#[test]
fn contact_hardening_beats_every_fixed_width_pcf() {
    // On contact the penumbra grows from nothing at the box's foot: a fixed kernel is too wide
    // there or too narrow far away. Measured: PCSS 0.0512; Poisson PCF 0.241 (2 texels),
    // 0.122 (16), 0.0612 (32, the best), 0.110 (48), 0.211 (96).
    let pcss = errors("contact", "pcss", &[]).penumbra_rmse;
    let chs = errors("contact", "chs", &[]).penumbra_rmse;
    let mut best = f64::MAX;
    for width in ["2", "4", "8", "16", "32", "48", "64", "96"] {
        let e = errors(
            "contact",
            "shadow-map",
            &[("filter", "poisson"), ("kernel", width), ("cone", "2")],
        )
        .penumbra_rmse;
        eprintln!("pcf {width}: {e}");
        best = best.min(e);
    }
    eprintln!("pcss {pcss} best fixed {best}");
    assert!(pcss < 0.92 * best, "pcss {pcss}, best fixed width {best}");
    // CHS measured 0.0392.
    assert!(chs < 0.75 * best, "chs {chs}, best fixed width {best}");
}

#[test]
fn pcss_averages_overlapping_blockers_and_many_samples_do_not() {
    // overlap: boxes at heights 2.5 (2 x 1.2 around x = -0.4) and 0.8 (1.2 x 2 around
    // (0.4, 0.3)) under a disk light of radius 0.5 at (0.5, 7, 0.5). Ground pixels whose cone
    // to the light meets both boxes are where one average blocker depth cannot be right.
    let light = glam::Vec3::new(0.5, 7.0, 0.5);
    let hits = |p: glam::Vec3, h: f32, c: glam::Vec2, half: glam::Vec2| {
        let t = (h - p.y) / (light.y - p.y);
        let q = p + (light - p) * t;
        let r = 0.5 * t;
        (q.x - c.x).abs() < half.x + r && (q.z - c.y).abs() < half.y + r
    };
    let both = |p: glam::Vec3| {
        p.y.abs() < 1e-3
            && hits(p, 2.5, glam::Vec2::new(-0.4, 0.0), glam::Vec2::new(1.0, 0.6))
            && hits(p, 0.8, glam::Vec2::new(0.4, 0.3), glam::Vec2::new(0.6, 1.0))
    };
    let region = |t: &str, sets: &[(&str, &str)]| {
        let (v, r, pts, mask) = soft_run("overlap", t, sets);
        rmse_where(&v, &r, |i| mask[i] && pts[i].is_some_and(both))
    };
    let (pcss, n) = region("pcss", &[]);
    let (ms, _) = region("multi-sample", &[("samples", "64"), ("size", "512")]);
    eprintln!("overlap region ({n} pixels): pcss {pcss} multi-sample 64 {ms}");
    // Measured: 980 pixels, PCSS 0.0431, 64 samples 0.0035.
    assert!(n > 500, "the overlap region has {n} pixels");
    assert!(pcss > 0.035 && ms < 0.15 * pcss, "pcss {pcss}, multi-sample {ms}");
}

#[test]
fn multi_sample_area_light_converges_to_the_reference() {
    // Measured on overlap: penumbra RMSE 0.1035 (4 samples), 0.0302 (16), 0.0131 (64 at
    // 512^2), 0.0060 (256 at 512^2); volumes at 16 samples 0.0300.
    let mut last = f64::MAX;
    for (n, bound) in [("4", 0.12), ("16", 0.035), ("64", 0.016)] {
        let e = errors("overlap", "multi-sample", &[("samples", n), ("size", "512")]).penumbra_rmse;
        eprintln!("{n}: {e}");
        assert!(
            e < bound && e < last,
            "{n} samples: {e} (bound {bound}, fewer samples {last})"
        );
        last = e;
    }
    let maps = errors("contact", "multi-sample", &[]).penumbra_rmse;
    let volumes = errors("contact", "multi-sample", &[("method", "volumes")]).penumbra_rmse;
    eprintln!("contact maps {maps} volumes {volumes}");
    assert!((maps - volumes).abs() < 0.01, "maps {maps}, volumes {volumes}");
    // Without an area, one sample: the hard map.
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new("fixtures/scenes/point_casters.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let mut t = shadow::registry::create("multi-sample", &[]).unwrap();
    let v = t.visibility(&p, &f).unwrap();
    assert_eq!(counter(&*t, "samples"), 1.0);
    let hard = shadow::registry::create(
        "shadow-map",
        &[("filter".into(), "pcf2".into()), ("size".into(), "1024".into())],
    )
    .unwrap()
    .visibility(&p, &f)
    .unwrap();
    assert_eq!(v.hash(), hard.hash());
}

#[test]
fn bad_soft_shadow_options_are_errors() {
    for (t, k, v, says) in [
        ("pcss", "blockers", "0", "outside [1, 256]"),
        ("pcss", "taps", "257", "outside [1, 256]"),
        ("pcss", "light", "-1", "outside"),
        ("pcss", "angle", "NaN", "not finite"),
        ("pcss", "disk", "grid", "not one of poisson, rotated, spiral"),
        ("multi-sample", "samples", "0", "outside [1, 1024]"),
        ("multi-sample", "method", "rays", "not one of maps, volumes"),
    ] {
        let e = shadow::registry::create(t, &[(k.into(), v.into())])
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(says) && e.contains(t), "{t} {k}={v}: {e}");
    }
}

fn counter(t: &dyn shadow::ShadowTechnique, name: &str) -> f64 {
    t.counters().iter().find(|c| c.0 == name).unwrap().1
}

/// A hierarchy's promise, from runs without and with it: (image hash, taps) each, the same
/// image from fewer taps.
fn same_image_fewer_taps<H: PartialEq + std::fmt::Debug>(label: &str, plain: (H, f64), with: (H, f64)) {
    assert_eq!(plain.0, with.0, "{label}: same image");
    assert!(with.1 < plain.1, "{label}: taps {} vs {}", with.1, plain.1);
}

/// Contact-hardening shadows: PCSS on a min/max mip chain, the filter's level from the
/// penumbra.
#[test]
fn chs_matches_the_area_light_better_than_pcss_and_is_the_hard_map_without_a_width() {
    // Measured penumbra RMSE: contact 0.0392 (PCSS 0.0512), overlap 0.0575 (0.0942),
    // pergola 0.1206 (0.1457).
    for (scene, bound) in [("contact", 0.045), ("overlap", 0.066), ("pergola", 0.135)] {
        let chs = errors(scene, "chs", &[]).penumbra_rmse;
        let pcss = errors(scene, "pcss", &[]).penumbra_rmse;
        assert!(
            chs < bound && chs < pcss,
            "{scene}: chs {chs} (bound {bound}), pcss {pcss}"
        );
    }
    let p = Pipeline::new(2).unwrap();
    let s = load(Path::new("fixtures/scenes/contact.toml")).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let hash = |t: &str, sets: &[(&str, &str)]| {
        let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        shadow::registry::create(t, &sets)
            .unwrap()
            .visibility(&p, &f)
            .unwrap()
            .hash()
    };
    assert_eq!(
        hash("chs", &[("light", "0")]),
        hash("shadow-map", &[("filter", "pcf2"), ("receiver", "true")])
    );
    for (k, v) in [("kernel", "0"), ("kernel", "16"), ("light", "-1")] {
        let e = shadow::registry::create("chs", &[(k.into(), v.into())])
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("technique 'chs'") && e.contains("outside"), "{k}={v}: {e}");
    }
}

#[test]
fn penumbra_error_over_map_sizes_512_to_4096() {
    // Both take their widths from world units, so neither penumbra follows the map's
    // resolution much. Measured on contact (512, 1024, 2048, 4096): PCSS 0.0501-0.0524, CHS
    // 0.0392-0.0478 (its 512 map's coarse levels blur).
    for (t, bound) in [("pcss", 0.005), ("chs", 0.012)] {
        let e: Vec<f64> = ["512", "1024", "2048", "4096"]
            .iter()
            .map(|n| errors("contact", t, &[("size", n)]).penumbra_rmse)
            .collect();
        let spread = e.iter().copied().fold(f64::MIN, f64::max) - e.iter().copied().fold(f64::MAX, f64::min);
        eprintln!("{t}: {e:?} spread {spread}");
        assert!(spread < bound, "{t}: {e:?}");
    }
}

/// The IZB/PCSS hybrid (Story and Wyman 2016): exact where the penumbra is narrow.
#[test]
fn hybrid_is_exact_near_contact_and_leaks_nowhere() {
    // contact: a unit box rotated 25 degrees about y at the origin. Ground pixels within 0.3
    // of its footprint are where its shadow starts: the penumbra is narrowest there.
    let near = |p: glam::Vec3| {
        let (s, c) = penumbra::math::sin_cos((-25f32).to_radians());
        let q = glam::Vec2::new(c * p.x + s * p.z, -s * p.x + c * p.z);
        let out = (q.abs() - glam::Vec2::splat(0.5)).max(glam::Vec2::ZERO).length();
        p.y.abs() < 1e-3 && out > 0.0 && out < 0.3
    };
    let region = |t: &str, sets: &[(&str, &str)]| {
        let (v, r, pts, mask) = soft_run("contact", t, sets);
        rmse_where(&v, &r, |i| mask[i] && pts[i].is_some_and(near))
    };
    let (pcss, n) = region("pcss", &[]);
    let (hybrid, _) = region("hybrid", &[]);
    // Measured: 1632 pixels, PCSS 0.0271, the hybrid 0.0223.
    assert!(
        n > 300 && hybrid < 0.9 * pcss,
        "{n} pixels: hybrid {hybrid}, pcss {pcss}"
    );
    // A bias that lifts PCSS's shadow off the box (Peter Panning: light leaks under it) does
    // not reach the hybrid's exact part. Measured: PCSS 4.07 % wrong, the hybrid 0.025 %.
    let leak = errors("contact", "pcss", &[("units", "100000")]).wrong_pct;
    let fixed = errors("contact", "hybrid", &[("units", "100000")]).wrong_pct;
    assert!(leak > 3.0 && fixed < 0.05, "pcss {leak} %, hybrid {fixed} %");
    let e = shadow::registry::create("hybrid", &[("from".into(), "5".into()), ("to".into(), "2".into())])
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("below from"), "{e}");
}

/// Penumbra RMSE on the ground (`y = 0`) and the penumbra discontinuity of `technique`.
fn penumbra_volume_errors(scene: &str, technique: &str, sets: &[(&str, &str)]) -> (f64, f64, f64) {
    with_reference(scene, technique, sets, |v, r, f| {
        let mask = f.metric_mask();
        let jumps = penumbra::metrics::discontinuity(v, r, &mask, f.gbuffer.object.data(), f.width() as usize);
        let (vs, rs) = (v.to_scalar(), r.to_scalar());
        let ground = |i: usize| {
            mask[i] && f.points()[i].is_some_and(|p| p.position.y.abs() < 1e-3) && rs[i] > 0.0 && rs[i] < 1.0
        };
        let (g, _) = rmse_where(&vs, &rs, ground);
        (compare(v, r, &mask).penumbra_rmse, g, jumps)
    })
}

/// Penumbra volume maps and penumbra volume mask filtering (Cournia 2005 ch. 4 and 5).
#[test]
fn penumbra_volumes_without_a_radius_are_the_hard_map() {
    let p = Pipeline::new(2).unwrap();
    for scene in ["contact", "point_casters"] {
        let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let hash = |t: &str, sets: &[(&str, &str)]| {
            let sets: Vec<(String, String)> = sets.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            shadow::registry::create(t, &sets)
                .unwrap()
                .visibility(&p, &f)
                .unwrap()
                .hash()
        };
        // contact has a disk light (radius 0 by `light=0`), point_casters a point light.
        let zero: &[(&str, &str)] = if scene == "contact" { &[("light", "0")] } else { &[] };
        assert_eq!(
            hash("pvm", zero),
            hash("shadow-map", &[("filter", "pcf2")]),
            "{scene} pvm"
        );
        assert_eq!(
            hash("pvmf", zero),
            hash(
                "shadow-map",
                &[("filter", "pcf2"), ("size", "512"), ("layer", "midpoint")]
            ),
            "{scene} pvmf"
        );
        // The text's second depth, as an option, is the map's second depth.
        let second: Vec<(&str, &str)> = zero.iter().copied().chain([("layer", "second")]).collect();
        assert_eq!(
            hash("pvmf", &second),
            hash(
                "shadow-map",
                &[("filter", "pcf2"), ("size", "512"), ("layer", "second")]
            ),
            "{scene} pvmf [layer=second]"
        );
    }
}

#[test]
fn pvm_jumps_where_volumes_overlap_and_pvmf_does_not() {
    // Measured (penumbra RMSE, ground penumbra RMSE, discontinuity):
    //   overlap: PVM 0.0878, 0.0915, 0.00955; PVMF 0.1128, 0.1165, 0.00217; PVMF without
    //   blur 0.0699, 0.0722, 0.01297.
    //   forest: PVM 0.0949, 0.0813, 0.01121; PVMF 0.1147, 0.0966, 0.00150; PVMF without blur
    //   0.1039, 0.0630, 0.01042 (PVMF's midpoint map; with the text's second depth 0.1265,
    //   0.0966, 0.00084).
    for (scene, pvm_bound, pvmf_bound) in [("overlap", 0.10, 0.13), ("forest", 0.11, 0.145)] {
        let pvm = penumbra_volume_errors(scene, "pvm", &[("smooth", "true")]);
        let pvmf = penumbra_volume_errors(scene, "pvmf", &[("blur", "12")]);
        let raw = penumbra_volume_errors(scene, "pvmf", &[]);
        eprintln!("{scene}: pvm {pvm:?} pvmf {pvmf:?} unblurred {raw:?}");
        assert!(
            pvm.0 < pvm_bound && pvmf.0 < pvmf_bound,
            "{scene}: pvm {pvm:?}, pvmf {pvmf:?}"
        );
        // The blurred estimate has no jumps between neighbouring edges' volumes.
        assert!(pvmf.2 < 0.35 * pvm.2, "{scene}: jumps pvmf {} pvm {}", pvmf.2, pvm.2);
        // Its filter, before the blur widens it, is nearer the truth on the ground than the
        // nearest volume's edge.
        assert!(
            raw.1 < 0.85 * pvm.1,
            "{scene}: ground pvmf unblurred {} pvm {}",
            raw.1,
            pvm.1
        );
    }
    // Overlapping volumes shade pixels from the wrong occluder: PVM 0.70 % wrong, PCSS 0.
    let pvm = errors("overlap", "pvm", &[("smooth", "true")]).wrong_pct;
    let pcss = errors("overlap", "pcss", &[]).wrong_pct;
    assert!(pvm > 0.4 && pcss < 0.1, "pvm {pvm} %, pcss {pcss} %");
}

#[test]
fn pvmf_min_max_chains_skip_taps_and_change_nothing() {
    let p = Pipeline::new(2).unwrap();
    for scene in ["contact", "forest"] {
        let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let run = |h: &str| {
            let mut t = shadow::registry::create("pvmf", &[("hierarchy".to_string(), h.to_string())]).unwrap();
            let v = t.visibility(&p, &f).unwrap();
            let taps = t.counters().iter().find(|(n, _)| *n == "taps").map(|c| c.1).unwrap();
            (v.hash(), taps)
        };
        let ((with, fewer), (without, all)) = (run("true"), run("false"));
        assert_eq!(with, without, "{scene}: the chains change the image");
        assert!(
            fewer < 0.9 * all,
            "{scene}: taps {fewer} with the chains, {all} without"
        );
    }
}

#[test]
fn pvmf_without_jitter_bands_where_edges_cross_its_grid() {
    // Cournia fig. 5.3: a regular n_pcf x n_pcf grid crosses a straight edge a row of taps at
    // a time, so its estimate stands on plateaus where the truth is a ramp; jitter breaks
    // them. Measured on the estimate before the blur (metrics::banding): overlap 0.3354
    // without jitter against 0.0009 with; pergola 0.3326 against 0.0081.
    let p = Pipeline::new(2).unwrap();
    for scene in ["overlap", "pergola"] {
        let path = format!("fixtures/scenes/{scene}.toml");
        let s = load(Path::new(&path)).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let (r, _, _) = run::reference(&p, &f, 0, None).unwrap();
        let mask = f.metric_mask();
        let bands = |jitter: &str| {
            let sets = [
                ("blur".to_string(), "0".to_string()),
                ("jitter".to_string(), jitter.to_string()),
            ];
            let v = shadow::registry::create("pvmf", &sets)
                .unwrap()
                .visibility(&p, &f)
                .unwrap();
            penumbra::metrics::banding(&v, &r, &mask, f.gbuffer.object.data(), f.width() as usize)
        };
        let (off, on) = (bands("false"), bands("true"));
        assert!(
            off > 0.25 && on < 0.02,
            "{scene}: banding without jitter {off}, with {on}"
        );
    }
}

#[test]
fn pvmf_blur_widens_contact_penumbrae_and_bleeds_without_ids() {
    // The text's n_blur = 12 screen pixels (`blur=12`; 0 by default) widens the penumbra
    // where it starts narrow: on contact, measured 0.1363 against 0.0593 unblurred.
    let (blurred, _, _) = penumbra_volume_errors("contact", "pvmf", &[("blur", "12")]);
    let (raw, _, _) = penumbra_volume_errors("contact", "pvmf", &[]);
    assert!(blurred > 1.8 * raw && raw < 0.07, "blurred {blurred}, unblurred {raw}");
    // Without B (one id for every surface) shadows bleed onto lit objects: lit pixels (in the
    // reference) within the blur's reach of another object. Measured on forest: 0.0094 with
    // object ids, 0.0363 without.
    let bleed = |ids: &str| {
        with_reference("forest", "pvmf", &[("ids", ids), ("blur", "12")], |v, r, f| {
            let (w, h) = (f.width() as i64, f.height() as i64);
            let obj = f.gbuffer.object.data();
            let (vs, rs, mask) = (v.to_scalar(), r.to_scalar(), f.metric_mask());
            let (mut sum, mut n) = (0.0f64, 0u32);
            for y in 0..h {
                for x in 0..w {
                    let i = (y * w + x) as usize;
                    if !mask[i] || rs[i] < 1.0 || !vs[i].is_finite() {
                        continue;
                    }
                    let border = (-6i64..=6).any(|d| {
                        let (a, b) = (x + d, y + d);
                        (a >= 0 && a < w && obj[(y * w + a) as usize] != obj[i])
                            || (b >= 0 && b < h && obj[(b * w + x) as usize] != obj[i])
                    });
                    if border {
                        sum += (1.0 - vs[i]) as f64;
                        n += 1;
                    }
                }
            }
            (sum / n.max(1) as f64, n)
        })
    };
    let ((with, n), (without, _)) = (bleed("object"), bleed("none"));
    eprintln!("bleeding on {n} lit border pixels: ids {with}, none {without}");
    assert!(n > 200 && without > 2.5 * with, "ids {with}, none {without}");
}

#[test]
fn one_silhouette_fails_under_a_large_near_light() {
    // big_light: a ball of radius 0.35 1.1 below a disk of radius 1.5. Measured penumbra
    // RMSE: PVM 0.1583 (0.0878 on overlap), PVMF 0.0604, 64 light samples 0.0412.
    let pvm = errors("big_light", "pvm", &[("smooth", "true")]).penumbra_rmse;
    let pvmf = errors("big_light", "pvmf", &[("blur", "12")]).penumbra_rmse;
    let ms = errors("big_light", "multi-sample", &[]).penumbra_rmse;
    let pvm_overlap = errors("overlap", "pvm", &[("smooth", "true")]).penumbra_rmse;
    eprintln!("big_light: pvm {pvm} pvmf {pvmf} multi-sample {ms}; pvm on overlap {pvm_overlap}");
    assert!(
        pvm > 1.5 * pvm_overlap && ms < 0.35 * pvm,
        "pvm {pvm}, overlap {pvm_overlap}, multi-sample {ms}"
    );
    assert!(ms < pvmf && pvmf < 0.075, "pvmf {pvmf}, multi-sample {ms}");
}

#[test]
fn bad_penumbra_volume_options_are_errors() {
    for (t, k, v, says) in [
        ("pvm", "light", "-1", "outside"),
        ("pvmf", "light", "NaN", "not finite"),
        ("pvmf", "spread", "0", "outside (0, 1]"),
        ("pvmf", "spread", "1.5", "outside (0, 1]"),
        ("pvmf", "pcf", "0", "outside [1, 32]"),
        ("pvmf", "blur", "1000", "outside [0, 64]"),
        ("pvmf", "layer", "id", "stores no depth"),
        ("pvmf", "ids", "bone", "not one of object, group, none"),
    ] {
        let e = shadow::registry::create(t, &[(k.into(), v.into())])
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(says) && e.contains(t), "{t} {k}={v}: {e}");
    } // `penumbra list` prints the interval that is checked (it printed [0, 1] for spread).
    let info = shadow::registry::registry()
        .into_iter()
        .find(|t| t.name == "pvmf")
        .unwrap();
    let spread = info.options.iter().find(|o| o.key == "spread").unwrap();
    assert!(spread.ty.ends_with("in (0, 1]"), "{}", spread.ty);
}
