//! The fuzz harness: random and mutated input to every parser and every technique's
//! settings, extreme numbers in every scene field, hostile names through every writer. Each
//! case must end in a value that is sound or in an error that names the file or the field;
//! never a panic. Case counts are bounded so that `cargo test --release` stays quick; the
//! `--ignored` tests run many more (`cargo test --release --test fuzz -- --ignored`).
//! Failures proptest finds are kept as literal cases below. The glTF target runs on a fixed
//! corpus (the small scene as `.gltf` text and as `.glb`) with fixed seeds, so CI replays the
//! same cases every run; `--ignored` runs many more from fresh seeds.

use crate::common;

use penumbra::pipeline::Pipeline;
use penumbra::report;
use penumbra::scene::file::{parse, MAX_COORDINATE};
use penumbra::scene::Scene;
use penumbra::shadow;
use proptest::prelude::*;
use std::path::Path;

const SCENE: &str = "# fuzz\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\nfov = 45\nnear = 0.1\nfar = 100\nresolution = [16, 12]\n\n[[light]]\ntype = \"spot\"\nposition = [1, 4, 1]\ntarget = [0, 0, 0]\nangle = 60\nintensity = 1\n\n[[material]]\nname = \"m\"\nalbedo = [0.5, 0.5, 0.5]\nopacity = 0.5\n\n[[object]]\nmesh = \"plane\"\nsize = [4, 4]\nsubdivisions = 2\n\n[[object]]\nmesh = \"sphere\"\nradius = 0.5\nstacks = 6\nslices = 8\ntranslate = [0, 0.5, 0]\nrotate = [10, 20, 30]\nscale = 1\nmaterial = \"m\"\n";

/// Numbers a hostile user writes.
const EXTREMES: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e38",
    "-1e38",
    "3.4e38",
    "1e39",
    "0",
    "-0",
    "1e-45",
    "-1",
    "99999999999",
    "0.0000001",
    "18446744073709551616",
    "\"x\"",
    "[]",
    "[1, 2, 3, 4, 5]",
    "true",
];

/// A parsed scene must be sound: finite coordinates within the scene's range, unit light
/// directions, a camera that sees something.
fn assert_sound(s: &Scene) {
    for o in &s.objects {
        for p in &o.mesh.positions {
            assert!(
                p.is_finite() && p.abs().max_element() <= MAX_COORDINATE,
                "{} vertex {p}",
                o.name
            );
        }
        assert!(o.mesh.indices.iter().all(|&i| (i as usize) < o.mesh.positions.len()));
    }
    for l in &s.lights {
        assert!(
            l.position.is_finite() && (l.direction.length() - 1.0).abs() < 1e-3,
            "{l:?}"
        );
    }
    let c = &s.camera;
    assert!(c.position.is_finite() && c.target.is_finite() && c.position != c.target);
    assert!(c.width >= 1 && c.height >= 1 && c.fov_deg > 0.0 && c.fov_deg < 180.0);
}

/// Parses `text`: a sound scene, or an error that names the file and a line.
fn check_parse(text: &str) -> Option<Scene> {
    match parse(text, Path::new("fuzz.toml")) {
        Ok(s) => {
            assert_sound(&s);
            Some(s)
        }
        Err(e) => {
            assert!(e.to_string().starts_with("fuzz.toml"), "error without the file: {e}");
            None
        }
    }
}

/// Renders a sound scene with shadow volumes and a shadow map at its small resolution: no
/// panic, no non-finite visibility where there is geometry.
fn check_render(s: &Scene) {
    if s.camera.width as u64 * s.camera.height as u64 > 64 * 64 {
        return;
    }
    let p = Pipeline::new(1).unwrap();
    let Ok(f) = penumbra::frame::frame(&p, s, 0, 0) else {
        return;
    };
    for name in ["shadow-volume", "shadow-map"] {
        let mut t = shadow::registry::create(
            name,
            &[("size".into(), "64".into())]
                .into_iter()
                .filter(|_| name == "shadow-map")
                .collect::<Vec<_>>(),
        )
        .unwrap();
        if let Ok(v) = t.visibility(&p, &f) {
            for (i, pt) in f.points().iter().enumerate() {
                if pt.is_some() {
                    let x = v.rgb(i);
                    assert!(x.is_finite(), "{name}: pixel {i} is {x}");
                }
            }
        }
    }
}

/// Every numeric position of the template (the offsets of its numbers).
fn number_spans() -> Vec<(usize, usize)> {
    let b = SCENE.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if (b[i].is_ascii_digit() || b[i] == b'-') && i > 0 && matches!(b[i - 1], b' ' | b'[') {
            let start = i;
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.' || b[i] == b'-') {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

fn extreme_case(span: usize, value: usize) {
    let spans = number_spans();
    let (a, b) = spans[span % spans.len()];
    let text = format!("{}{}{}", &SCENE[..a], EXTREMES[value % EXTREMES.len()], &SCENE[b..]);
    if let Some(s) = check_parse(&text) {
        check_render(&s);
    }
}

fn mutate(seed: &[(u8, u16, u8)]) -> String {
    let mut bytes = SCENE.as_bytes().to_vec();
    for &(op, at, byte) in seed {
        if bytes.is_empty() {
            break;
        }
        let at = at as usize % bytes.len();
        match op % 3 {
            0 => bytes[at] = byte,
            1 => {
                bytes.remove(at);
            }
            _ => bytes.insert(at, byte),
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

fn option_case(technique: usize, key: &str, value: &str) {
    let reg = shadow::registry::registry();
    let t = &reg[technique % reg.len()];
    let keys: Vec<&str> = t.options.iter().map(|o| o.key).collect();
    let key = if key.is_empty() || keys.is_empty() {
        key.to_string()
    } else {
        keys[key.len() % keys.len()].to_string()
    };
    match shadow::registry::create(t.name, &[(key.clone(), value.to_string())]) {
        Ok(_) => {}
        Err(e) => {
            let e = e.to_string();
            assert!(e.contains(t.name) || e.contains(&key), "{}: {key}={value}: {e}", t.name)
        }
    }
}

fn obj_case(bytes: &[u8]) {
    let dir = std::env::temp_dir().join(format!("penumbra-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!(
        "m{}.obj",
        penumbra::hash::fnv1a(penumbra::hash::FNV_OFFSET, bytes)
    ));
    std::fs::write(&p, bytes).unwrap();
    match penumbra::scene::mesh::load_obj(&p) {
        Ok(m) => {
            assert!(m.positions.iter().all(|p| p.is_finite()));
            assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()) && m.indices.len() % 3 == 0);
        }
        Err(e) => assert!(e.to_string().contains(&p.display().to_string()), "{e}"),
    }
    let _ = std::fs::remove_file(&p);
}

fn obj_text() -> impl Strategy<Value = Vec<u8>> {
    let line = prop_oneof![
        (any::<f32>(), any::<f32>(), any::<f32>()).prop_map(|(a, b, c)| format!("v {a} {b} {c}")),
        (-3i64..6, -3i64..6, -3i64..6).prop_map(|(a, b, c)| format!("f {a} {b} {c}")),
        (0i64..5).prop_map(|a| format!("f {a}")),
        "[a-z#/ 0-9.-]{0,12}".prop_map(|s| s),
        Just("vn 0 1 0".to_string()),
        Just("f 1//1 2//1 3//1".to_string()),
        Just("l 1 2".to_string()),
    ];
    prop::collection::vec(line, 0..12).prop_map(|ls| ls.join("\n").into_bytes())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn random_text_is_a_scene_or_an_error_naming_the_file(text in ".{0,300}") {
        check_parse(&text);
    }

    #[test]
    fn mutated_scenes_are_sound_or_errors(seed in prop::collection::vec((any::<u8>(), any::<u16>(), any::<u8>()), 1..6)) {
        check_parse(&mutate(&seed));
    }

    #[test]
    fn extreme_numbers_in_every_field(span in 0usize..64, value in 0usize..64) {
        extreme_case(span, value);
    }

    #[test]
    fn random_obj_files_load_soundly_or_name_the_file(bytes in obj_text()) {
        obj_case(&bytes);
    }

    #[test]
    fn random_option_values_for_every_technique(technique in 0usize..64, key in "[a-z]{0,6}", value in prop_oneof![
        Just("nan".to_string()), Just("1e39".to_string()), Just("-1".to_string()), Just("".to_string()),
        Just("99999999999999999999".to_string()), "\\PC{0,10}"
    ]) {
        option_case(technique, &key, &value);
    }

    #[test]
    fn hostile_names_survive_every_writer(scene in "\\PC{1,20}", settings in "\\PC{0,20}") {
        let r = penumbra::run::RunResult {
            scene: scene.clone(), technique: "shadow-map".into(), family: shadow::Family::Map,
            settings: settings.clone(), ms: 1.0, threads: 1, counted_path: true, ..Default::default()
        };
        // CSV: read back equal, one record per run.
        let text = report::csv(std::slice::from_ref(&r));
        let back = report::read_csv(&text, "x.csv").unwrap();
        prop_assert_eq!(&back[0].scene, &scene);
        prop_assert_eq!(&back[0].settings, &settings);
        // HTML: the names appear only escaped: the page has the markup of the same page
        // with a plain name, no more.
        prop_assert!(html_markup_is_the_plain_pages(&r, &scene));
        // Markdown: no image or link syntax survives.
        let md = report::markdown::md(&scene);
        prop_assert!(!md.contains("!["));
    }
}

/// Values a hostile glTF writes where the corpus has a number or a string: indices past the
/// end, component types and accessor types of the wrong kind, huge and non-finite numbers,
/// URIs that leave the folder.
const GLTF_VALUES: &[&str] = &[
    "-1",
    "0",
    "1",
    "2",
    "3",
    "4",
    "7",
    "65535",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "1e308",
    "-1e308",
    "1e-45",
    "0.5",
    "null",
    "\"x\"",
    "[]",
    "{}",
    "[0, 0, 0, 0]",
    "5120",
    "5121",
    "5122",
    "5125",
    "5126",
    "\"VEC2\"",
    "\"MAT4\"",
    "\"SCALAR\"",
    "\"../x.bin\"",
    "\"/dev/zero\"",
    "\"data:,\"",
    "\"data:application/octet-stream;base64,AAAA\"",
];

/// The glTF corpus: the small scene as `.gltf` text (its buffer a `data:` URI) and as `.glb`
/// (its buffer the BIN chunk).
fn gltf_corpus(glb: bool) -> (Vec<u8>, Vec<u8>) {
    if glb {
        let (json, bin) = common::glb_parts(&[0, 2, 1, 0, 3, 2], 4);
        (json.into_bytes(), bin)
    } else {
        (common::gltf_text(&[0, 2, 1, 0, 3, 2], 4).into_bytes(), Vec::new())
    }
}

/// The spans of the JSON's number and string tokens.
fn json_tokens(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'"' {
            let start = i;
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += 1;
            }
            i += 1;
            out.push((start, i.min(b.len())));
        } else if b[i].is_ascii_digit() || b[i] == b'-' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || matches!(b[i], b'.' | b'-' | b'+')) {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

/// One mutation of a glTF file: a token of the JSON replaced by a hostile value, bytes of the
/// JSON or of the binary chunk replaced, removed or repeated, or (GLB) a header or chunk
/// length rewritten.
type GltfEdit = (u8, u16, u16);

fn mutate_gltf(glb: bool, edits: &[GltfEdit]) -> Vec<u8> {
    let (mut json, mut bin) = gltf_corpus(glb);
    let mut lengths: Vec<(usize, u32)> = Vec::new();
    for &(op, at, v) in edits {
        let (at, v) = (at as usize, v as usize);
        match op % 6 {
            0 | 1 => {
                let tokens = json_tokens(&json);
                if tokens.is_empty() {
                    continue;
                }
                let (a, b) = tokens[at % tokens.len()];
                let value = GLTF_VALUES[v % GLTF_VALUES.len()].as_bytes();
                json.splice(a..b, value.iter().copied());
            }
            2 if !json.is_empty() => {
                let i = at % json.len();
                json[i] = v as u8;
            }
            3 if !json.is_empty() => {
                let i = at % json.len();
                let end = (i + v % 24).min(json.len());
                if op & 8 == 0 {
                    json.drain(i..end);
                } else {
                    let copy: Vec<u8> = json[i..end].to_vec();
                    json.splice(i..i, copy);
                }
            }
            4 if !bin.is_empty() => {
                let i = at % bin.len();
                if op & 8 == 0 {
                    bin[i] = v as u8;
                } else {
                    bin.truncate(i);
                }
            }
            5 if glb => lengths.push((at % 3, [0, 1, 12, 84, v as u32, u32::MAX][v % 6])),
            _ => {}
        }
    }
    if !glb {
        return json;
    }
    let mut file = common::glb(&json, &bin);
    let json_len = u32::from_le_bytes(file[12..16].try_into().unwrap()) as usize;
    for (field, value) in lengths {
        // The file's total length, the JSON chunk's length, the BIN chunk's length.
        let at = [8, 12, 20 + json_len][field];
        file[at..at + 4].copy_from_slice(&value.to_le_bytes());
    }
    file
}

/// Loads a mutated glTF: a sound scene, or an error that names the file; never a panic.
fn gltf_case(glb: bool, edits: &[GltfEdit]) {
    let bytes = mutate_gltf(glb, edits);
    let dir = std::env::temp_dir().join(format!("penumbra-fuzz-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let name = format!(
        "g{:016x}.{}",
        penumbra::hash::fnv1a(penumbra::hash::FNV_OFFSET, &bytes),
        if glb { "glb" } else { "gltf" }
    );
    let p = dir.join(&name);
    std::fs::write(&p, &bytes).unwrap();
    match penumbra::scene::file::load(&p) {
        Ok(s) => assert_sound(&s),
        Err(e) => assert!(e.to_string().contains(&name), "{e}"),
    }
    let _ = std::fs::remove_file(&p);
}

fn gltf_edits(n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<GltfEdit>> {
    prop::collection::vec((any::<u8>(), any::<u16>(), any::<u16>()), n)
}

proptest! {
    // Fixed seeds: CI replays the same cases every run.
    #![proptest_config(ProptestConfig {
        cases: 400,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x9e37_79b9),
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_gltf_text_is_sound_or_an_error_naming_the_file(edits in gltf_edits(1..5)) {
        gltf_case(false, &edits);
    }

    #[test]
    fn mutated_glb_files_are_sound_or_an_error_naming_the_file(edits in gltf_edits(1..5)) {
        gltf_case(true, &edits);
    }
}

/// The corpus itself loads, and each hostile value in each token of it is sound or an error
/// naming the file.
#[test]
fn every_hostile_value_in_every_gltf_token() {
    for glb in [false, true] {
        gltf_case(glb, &[]);
        let tokens = json_tokens(&gltf_corpus(glb).0).len();
        for t in 0..tokens {
            for v in 0..GLTF_VALUES.len() {
                gltf_case(glb, &[(0, t as u16, v as u16)]);
            }
        }
    }
}

/// Whether the report page for `r` with the scene (and its description) called `name` has
/// exactly the markup characters of the page for a plain name: names add only escaped text.
fn html_markup_is_the_plain_pages(r: &penumbra::run::RunResult, name: &str) -> bool {
    let page = |n: &str| {
        let r = penumbra::run::RunResult {
            scene: n.to_string(),
            ..r.clone()
        };
        let info = report::SceneInfo {
            name: n.to_string(),
            description: n.to_string(),
            class: r.class,
            file: n.to_string(),
        };
        report::report_html(&[r], &[info], &|_| None, &|_| None, &|_, _| None)
    };
    let (hostile, plain) = (page(name), page("plain"));
    ['<', '>', '"']
        .iter()
        .all(|&c| hostile.matches(c).count() == plain.matches(c).count())
}

/// Regression: a scene called `<` (proptest's minimal case for a check that was too naive).
#[test]
fn a_scene_called_lt_is_escaped() {
    let r = penumbra::run::RunResult {
        scene: "<".into(),
        technique: "shadow-map".into(),
        family: shadow::Family::Map,
        ms: 1.0,
        ..Default::default()
    };
    assert!(html_markup_is_the_plain_pages(&r, "<"));
    assert!(html_markup_is_the_plain_pages(&r, "<script>alert(1)</script>\"'&"));
}

/// The same properties over many more cases (minutes): `cargo test --release --test fuzz -- --ignored`.
#[test]
#[ignore]
fn long_fuzz_run() {
    // A fresh runner per target: a runner counts its successes across runs, so one runner
    // would run the first target's cases and none of the others'.
    let runner = || {
        proptest::test_runner::TestRunner::new(ProptestConfig {
            cases: 20_000,
            ..ProptestConfig::default()
        })
    };
    runner()
        .run(&".{0,400}", |t| {
            check_parse(&t);
            Ok(())
        })
        .unwrap();
    runner()
        .run(
            &prop::collection::vec((any::<u8>(), any::<u16>(), any::<u8>()), 1..12),
            |seed| {
                check_parse(&mutate(&seed));
                Ok(())
            },
        )
        .unwrap();
    runner()
        .run(&(0usize..64, 0usize..64), |(a, b)| {
            extreme_case(a, b);
            Ok(())
        })
        .unwrap();
    runner()
        .run(&obj_text(), |b| {
            obj_case(&b);
            Ok(())
        })
        .unwrap();
    runner()
        .run(&(any::<bool>(), gltf_edits(1..10)), |(glb, e)| {
            gltf_case(glb, &e);
            Ok(())
        })
        .unwrap();
}

/// Every extreme value in every numeric field of the template, exhaustively.
#[test]
fn every_extreme_value_in_every_numeric_field() {
    for span in 0..number_spans().len() {
        for value in 0..EXTREMES.len() {
            extreme_case(span, value);
        }
    }
}
