//! Hostile but realistic input through the CLI: each case gets a clear error naming what was
//! wrong (or a documented, correct behaviour), never a panic, never garbage.

use crate::common;
use common::cli;

fn scene(name: &str, body: &str) -> String {
    common::temp_file("hostile", name, body)
}

const POINT: &str = "# a point light over a box\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\nresolution = [48, 32]\n[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\n[[object]]\nmesh = \"plane\"\nsize = 4\n[[object]]\nmesh = \"box\"\ntranslate = [0, 0.5, 0]\n";

#[test]
fn maps_past_the_memory_budget_are_refused_before_they_are_allocated() {
    let s = scene("point.toml", POINT);
    let out = std::env::temp_dir().join(format!("penumbra-hostile-out-{}", std::process::id()));
    let out = out.to_str().unwrap();
    // Six faces of 16384² (6 GiB; 18 GiB with the midpoint's layers): refused at once, for
    // render and dump alike, with the sizes and the way to raise the limit.
    for cmd in ["render", "dump"] {
        for layer in ["first", "midpoint"] {
            let (ok, text) = cli(&[
                cmd,
                &s,
                "--technique",
                "shadow-map",
                "--set",
                "size=16384",
                "--set",
                &format!("layer={layer}"),
                "--out",
                out,
            ]);
            assert!(!ok, "{text}");
            assert!(
                text.contains("6 views, option size=16384")
                    && text.contains("beyond the memory limit of 4096 MiB")
                    && text.contains("--max-memory"),
                "{text}"
            );
        }
    }
    // A lower limit applies to every surface (here the camera's G-buffer).
    let (ok, text) = cli(&["render", &s, "--max-memory", "4K", "--out", out]);
    assert!(!ok && text.contains("beyond the memory limit of 4.0 KiB"), "{text}");
    // Within the limit it renders.
    let (ok, text) = cli(&[
        "render",
        &s,
        "--technique",
        "shadow-map",
        "--set",
        "size=512",
        "--max-memory",
        "1G",
        "--out",
        out,
    ]);
    assert!(ok, "{text}");
    for bad in ["-1", "0", "4X", "1e9", "99999999999G"] {
        let (ok, text) = cli(&["render", &s, "--max-memory", bad]);
        assert!(
            !ok && text.contains("--max-memory") && !text.contains("panicked"),
            "{bad}: {text}"
        );
    }
}

#[test]
fn scene_errors_blame_the_field_the_user_wrote() {
    let cases: &[(&str, &str, &str)] = &[
        // A point light exactly at the centre of the scene's bounds is valid.
        ("position = [0, 2, 0]", "position = [0, 0.5, 0]", ""),
        (
            "position = [0, 2, 0]\n",
            "",
            "field `position`: a point light needs a position",
        ),
        (
            "position = [0, 3, 5]",
            "position = [0, 3e38, 5]",
            "[camera], field `position`",
        ),
        (
            "translate = [0, 0.5, 0]",
            "translate = [0, 0.5, 0]\nscale = 3e38",
            "field `scale`",
        ),
        (
            "size = 4",
            "size = 999999\nscale = 1e34",
            "[[object]] #1 (plane), field `scale`: a vertex lands at",
        ),
        (
            "resolution = [48, 32]",
            "resolution = [48, 32, 99999]",
            "field `resolution`: expected a list of 2 values, got 3",
        ),
    ];
    for (i, (from, to, want)) in cases.iter().enumerate() {
        assert!(POINT.contains(from), "{from}");
        let s = scene(&format!("case{i}.toml"), &POINT.replacen(from, to, 1));
        let (ok, text) = cli(&[
            "render",
            &s,
            "--technique",
            "shadow-volume",
            "--reps",
            "1",
            "--out",
            &std::env::temp_dir().join("penumbra-hostile-o").to_string_lossy(),
        ]);
        if want.is_empty() {
            assert!(ok, "{to}: {text}");
        } else {
            assert!(!ok && text.contains(want), "{to}:\n{text}");
        }
    }
}

#[test]
fn large_frames_and_benchmarks_past_their_limits_are_refused_at_once() {
    // An 8192² frame along a 5-keyframe path: each frame is about 9 GB of buffers.
    let mut big = POINT.replace("resolution = [48, 32]", "resolution = [8192, 8192]");
    for i in 0..5 {
        big.push_str(&format!(
            "[[camera_path]]\nposition = [{i}, 3, 5]\ntarget = [0, 0, 0]\n"
        ));
    }
    let s = scene("big.toml", &big);
    let (ok, text) = cli(&["render", &s, "--technique", "planar"]);
    assert!(
        !ok && text.contains("a 8192x8192 frame (140 bytes per pixel")
            && text.contains("buffers of 8960 MiB")
            && text.contains("--max-memory"),
        "{text}"
    );
    // Benchmarks at their documented limits finish on two cores; past them, an error.
    for (args, want) in [
        (
            &["bench", "technique", "--triangles", "50000000"][..],
            "'--triangles <TRIANGLES>': 50000000 is outside 2..=10000000",
        ),
        (
            &["bench", "rays", "--rays", "1000000000"][..],
            "'--rays <RAYS>': 1000000000 is outside 1000..=100000000",
        ),
        (
            &["bench", "raster", "--triangles", "1000", "--area", "1e7"][..],
            "--area 10000000 is out of range",
        ),
        (
            &["bench", "raster", "--triangles", "10000000", "--area", "2e6"][..],
            "beyond 2e10",
        ),
        (
            &["bench", "frame", "--reps", "1000"][..],
            "'--reps <REPS>': 1000 is outside 0..=100",
        ),
        (&["render", "x.toml", "--reps", "101"][..], "101 is outside 0..=100"),
        // Counts: a negative or fractional value gets the option's name and range (clap alone
        // called `-1` an unexpected argument); sizes name the option, not a surface.
        (
            &["bench", "frame", "--reps", "-1"][..],
            "'--reps <REPS>': -1 is outside 0..=100",
        ),
        (
            &["bench", "raster", "--triangles", "-1"][..],
            "'--triangles <TRIANGLES>': -1 is outside",
        ),
        (
            &["bench", "raster", "--triangles", "1.5"][..],
            "'1.5' is not a whole number in 2..=10000000",
        ),
        (
            &["bench", "frame", "--width", "0"][..],
            "'--width <WIDTH>': 0 is outside 1..=16384",
        ),
        (
            &["bench", "frame", "--map", "0"][..],
            "'--map <MAP>': 0 is outside 1..=16384",
        ),
        (
            &["bench", "frame", "--map", "65536"][..],
            "'--map <MAP>': 65536 is outside 1..=16384",
        ),
        (
            &["bench", "frame", "--height", "-1080"][..],
            "'--height <HEIGHT>': -1080 is outside",
        ),
        // Negative numbers and -inf are values (clap called them unexpected arguments or
        // `-i` flags): each refused with its option's name.
        (&["bench", "raster", "--area", "-1"][..], "--area -1 is out of range"),
        (
            &["bench", "raster", "--area", "-inf"][..],
            "--area -inf is out of range",
        ),
        (
            &["inspect", "x.toml", "--pixel", "-1,0"][..],
            "--pixel '-1,0' is not X,Y",
        ),
        (&["sweep", "--shard", "-1/4"][..], "--shard '-1/4': expected I/N"),
        (&["choose", "x.toml", "--budget-ms", "-inf"][..], "--budget-ms -inf"),
        (&["choose", "x.toml", "--max-error", "-inf"][..], "--max-error -inf"),
        // A thousand workers on a small frame ran for minutes: refused, with the limit.
        (&["render", "x.toml", "--threads", "1000"][..], "1000 is more than"),
        (&["bench", "frame", "--threads", "1024"][..], "(4x this machine's"),
    ] {
        let (ok, text) = cli(args);
        assert!(!ok && text.contains(want), "{args:?}: {text}");
    }
}

/// The small glTF of `common::gltf_text` with `from` replaced by `to` (which must occur).
fn gltf_with(from: &str, to: &str) -> String {
    let t = common::gltf_text(&[0, 2, 1, 0, 3, 2], 4);
    assert!(t.contains(from), "{from} is not in the glTF text");
    t.replacen(from, to, 1)
}

/// Loads `body` as `name` in a fresh folder and returns the error text (a load that
/// succeeds is a test failure).
fn gltf_error(name: &str, body: &str) -> String {
    let p = common::temp_file("hostile-gltf", name, body);
    match penumbra::scene::file::load(std::path::Path::new(&p)) {
        Ok(_) => panic!("{name} loaded"),
        Err(e) => e.to_string(),
    }
}

/// Accessors are checked before the gltf crate's readers see them (a FLOAT index accessor
/// reached an `unreachable!` inside the crate), and every silent fix-up is an error naming the
/// node, accessor or field.
#[test]
fn gltf_accessors_and_silent_numbers_are_errors_naming_the_part() {
    let positions = r#""componentType": 5126, "count": 4, "type": "VEC3", "min": [-2, 0, -2], "max": [2, 0, 2]"#;
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "float_indices.gltf",
            gltf_with(r#""componentType": 5123"#, r#""componentType": 5126"#),
            "accessor 1 (indices): is F32 Scalar",
        ),
        (
            "vec2_positions.gltf",
            gltf_with(
                positions,
                r#""componentType": 5126, "count": 4, "type": "VEC2", "min": [-2, 0], "max": [2, 0]"#,
            ),
            // The crate's validation refuses it (its min and max are not those of a VEC3).
            r#"invalid glTF 2.0: meshes[0].primitives[0].attributes["POSITION"]"#,
        ),
        (
            "overrun.gltf",
            gltf_with(
                positions,
                r#""componentType": 5126, "count": 40, "type": "VEC3", "min": [-2, 0, -2], "max": [2, 0, 2]"#,
            ),
            "run past bufferView 0's 84 bytes",
        ),
        (
            "view_past_buffer.gltf",
            gltf_with(
                r#""byteOffset": 0, "byteLength": 84"#,
                r#""byteOffset": 0, "byteLength": 8400"#,
            ),
            "runs past buffer 0's",
        ),
        (
            "zero_quaternion.gltf",
            gltf_with(
                r#""mesh": 1, "scale": [2, 1, 2]"#,
                r#""mesh": 1, "rotation": [0, 0, 0, 0]"#,
            ),
            "node 1 'leaf': rotation [0.0, 0.0, 0.0, 0.0] is not a unit quaternion",
        ),
        (
            "version.gltf",
            gltf_with(r#""version": "2.0""#, r#""version": "3.0""#),
            "only glTF 2.x",
        ),
        (
            "colour.gltf",
            gltf_with("[0.5, 0.6, 0.7, 1]", "[2, 0.6, 0.7, 1]"),
            "material 0 'floor': baseColorFactor [2.0, 0.6, 0.7, 1.0] has 2, outside [0, 1]",
        ),
        (
            "aspect.gltf",
            gltf_with(r#""aspectRatio": 1.3333334"#, r#""aspectRatio": -1"#),
            "aspectRatio -1 is not positive",
        ),
        (
            "far.gltf",
            gltf_with(r#""zfar": 50"#, r#""zfar": 0.01"#),
            "zfar 0.01 is not beyond znear 0.1",
        ),
        (
            "spot.gltf",
            gltf_with(
                r#"{"type": "directional"}"#,
                r#"{"type": "spot", "spot": {"innerConeAngle": 0.6, "outerConeAngle": 0.5}}"#,
            ),
            "innerConeAngle 0.6 is not in [0, outerConeAngle = 0.5)",
        ),
        (
            "intensity.gltf",
            gltf_with(
                r#"{"type": "directional"}"#,
                r#"{"type": "directional", "intensity": -1}"#,
            ),
            "intensity -1 is not a finite number >= 0",
        ),
        (
            "colour_light.gltf",
            gltf_with(
                r#"{"type": "directional"}"#,
                r#"{"type": "directional", "color": [1, -1, 1]}"#,
            ),
            "has a negative or non-finite component",
        ),
        (
            // Regression: the gltf crate's validation indexed this accessor (a panic).
            "position_index.gltf",
            gltf_with(r#""POSITION": 0"#, r#""POSITION": 7"#),
            "mesh 0, primitive 0: attribute POSITION names accessor 7, but the file has 3",
        ),
        (
            "junk.glb",
            "glTF\u{2}\0\0\0junk".into(),
            "not a valid binary glTF (GLB) container",
        ),
        (
            // glTF 2.0: a loader refuses what a file requires and it cannot do.
            "required.gltf",
            gltf_with(
                r#""scenes": ["#,
                r#""extensionsRequired": ["KHR_materials_transmission"], "scenes": ["#,
            ),
            "requires the extension 'KHR_materials_transmission'",
        ),
        (
            "projective.gltf",
            gltf_with(
                r#""translation": [0, 1, 0], "children""#,
                r#""matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 2], "children""#,
            ),
            "node 0 'lift': its matrix's bottom row is [0.0, 0.0, 0.0, 2.0]",
        ),
        (
            "both.gltf",
            gltf_with(
                r#""translation": [0, 1, 0], "children""#,
                r#""translation": [0, 1, 0], "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1], "children""#,
            ),
            "node 0 'lift' has both a matrix and translation, rotation or scale",
        ),
    ];
    for (name, body, want) in cases {
        let e = gltf_error(name, &body);
        assert!(e.contains(name) && e.contains(want), "{name}: {e}");
        // The CLI says the same and does not panic.
        let p = common::temp_file("hostile-gltf", name, &body);
        let (ok, text) = cli(&["render", &p, "--technique", "shadow-map"]);
        assert!(!ok && text.contains(want), "{name}: {text}");
    }
}

/// A glTF file loaded alone is built without scene text: its errors name the glTF file and
/// the part of it, never a line or field of a scene file it does not have.
#[test]
fn a_gltf_alone_has_errors_about_itself() {
    let far = (r#""translation": [0, 1, 0]"#, r#""translation": [1e8, 1, 0]"#);
    let dark = (r#", "extensions": {"KHR_lights_punctual": {"light": 0}}"#, "");
    for (name, (from, to), want) in [
        ("far.gltf", far, "'leaf/tri/0' has a vertex at"),
        ("dark.gltf", dark, "the glTF file has no KHR_lights_punctual light"),
    ] {
        let e = gltf_error(name, &gltf_with(from, to));
        assert!(e.contains(name) && e.contains(want), "{name}: {e}");
        assert!(
            !e.contains(&format!("{name}:2")) && !e.contains("top level"),
            "{name}: {e}"
        );
        // The same file as a GLB.
        let (json, bin) = common::glb_parts(&[0, 2, 1, 0, 3, 2], 4);
        let json = json.replacen(from, to, 1);
        let p = std::path::PathBuf::from(common::temp_file("hostile-gltf", "x", ""))
            .with_file_name(name.replace(".gltf", ".glb"));
        std::fs::write(&p, common::glb(json.as_bytes(), &bin)).unwrap();
        let e = penumbra::scene::file::load(&p).err().unwrap().to_string();
        assert!(e.contains(&p.display().to_string()) && e.contains(want), "{e}");
        assert!(!e.contains("glb:2") && !e.contains("top level"), "{e}");
    }
}

/// A GLB whose header gives a length other than the file's is refused (it was once read as
/// far as the header said).
#[test]
fn a_glb_whose_header_length_is_wrong_is_refused() {
    let mut bytes = common::glb_file(&[0, 2, 1, 0, 3, 2], 4);
    let n = bytes.len();
    bytes[8..12].copy_from_slice(&20u32.to_le_bytes());
    let p = std::path::PathBuf::from(common::temp_file("hostile-gltf", "x", "")).with_file_name("short.glb");
    std::fs::write(&p, &bytes).unwrap();
    let e = penumbra::scene::file::load(&p).err().unwrap().to_string();
    assert!(
        e.contains("short.glb") && e.contains(&format!("its header gives a length of 20 bytes, the file has {n}")),
        "{e}"
    );
}

/// Buffer URIs are files too: only relative paths to regular files inside the glTF file's
/// folder (and bounded base64 `data:` URIs) are read. Devices, FIFOs, absolute paths, `..`,
/// `file://`, percent-encoded `..` and links out of the folder are refused by name, before
/// anything is read (a FIFO or `/dev/zero` would hang or fill the memory).
#[test]
fn gltf_buffer_uris_stay_inside_the_scene_folder() {
    let uri = |u: &str| {
        let t = common::gltf_text(&[0, 2, 1, 0, 3, 2], 4);
        let start = t.find("data:application").unwrap();
        let end = start + t[start..].find('"').unwrap();
        format!("{}{u}{}", &t[..start], &t[end..])
    };
    let dir = std::env::temp_dir().join(format!("penumbra-hostile-uri-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let outside = std::env::temp_dir().join(format!("penumbra-hostile-outside-{}.bin", std::process::id()));
    std::fs::write(&outside, vec![0u8; 256]).unwrap();
    let link = dir.join("link.bin");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&outside, &link).unwrap();
    let fifo = dir.join("fifo.bin");
    if !fifo.exists() {
        assert!(std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success());
    }
    let cases = [
        ("/dev/zero", "an absolute path"),
        ("/etc/passwd", "an absolute path"),
        ("../outside.bin", "'..' climbs out"),
        ("sub/../../outside.bin", "'..' climbs out"),
        ("%2e%2e/outside.bin", "'..' climbs out"),
        ("%2Fetc%2Fpasswd", "an absolute path"),
        ("file:///etc/passwd", "the scheme 'file:' is not read"),
        ("http://example.com/x.bin", "the scheme 'http:' is not read"),
        ("link.bin", "leads out of the glTF file's folder"),
        ("fifo.bin", "not a regular file"),
        ("sub", "it is a folder"),
        ("nothere.bin", "nothere.bin"),
        (
            "data:application/octet-stream;base64,@@@@",
            "base64 has the character '@' at 0",
        ),
        ("data:application/octet-stream,plain", "only base64 data URIs"),
        ("%zz.bin", "a bad percent escape at byte 0"),
    ];
    for (u, want) in cases {
        let p = dir.join("scene.gltf");
        std::fs::write(&p, uri(u)).unwrap();
        let e = match penumbra::scene::file::load(&p) {
            Ok(_) => panic!("uri {u} loaded"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains("buffer 0: uri") && e.contains(want), "uri {u}: {e}");
    }
    // A buffer file inside the folder (and a subfolder, percent-encoded) is read.
    let t = common::gltf_text(&[0, 2, 1, 0, 3, 2], 4);
    let start = t.find("base64,").unwrap() + 7;
    let b64 = &t[start..start + t[start..].find('"').unwrap()];
    std::fs::write(dir.join("sub").join("my data.bin"), decode64(b64)).unwrap();
    let p = dir.join("scene.gltf");
    std::fs::write(&p, uri("sub/my%20data.bin")).unwrap();
    let s = penumbra::scene::file::load(&p).unwrap();
    assert_eq!(s.triangles(), 3);
    std::fs::remove_file(&outside).unwrap();
}

/// The plain decoder of the test's own base64.
fn decode64(s: &str) -> Vec<u8> {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let v: Vec<u32> = s
        .bytes()
        .filter(|&c| c != b'=')
        .map(|c| A.iter().position(|&a| a == c).unwrap() as u32)
        .collect();
    let mut out = Vec::new();
    for c in v.chunks(4) {
        let n = c.iter().enumerate().fold(0u32, |a, (i, &x)| a | x << (18 - 6 * i));
        out.extend_from_slice(&n.to_be_bytes()[1..c.len()]);
    }
    out
}

/// Budgets before expansion: a node graph that instances a mesh through a DAG (a few KB
/// making millions of instances), a cycle and an absurd depth are refused by counting the
/// graph before any mesh is built.
#[test]
fn gltf_node_graphs_are_counted_before_they_are_built() {
    let t = common::gltf_text(&[0, 2, 1, 0, 3, 2], 4);
    let nodes_at = t.find("\"nodes\": [\n").unwrap();
    let nodes_end = nodes_at + t[nodes_at..].find("\n  ],").unwrap() + 4;
    let with_nodes = |scene_nodes: &str, nodes: &[String]| {
        let s = t.replacen(
            r#""scenes": [{"nodes": [0, 2, 3]}]"#,
            &format!(r#""scenes": [{{"nodes": [{scene_nodes}]}}]"#),
            1,
        );
        let (a, b) = s.split_at(s.find("\"nodes\": [\n").unwrap());
        let rest = &b[nodes_end - nodes_at..];
        format!("{a}\"nodes\": [\n    {}\n  ]{rest}", nodes.join(",\n    "))
    };
    // 40 nodes, each with the next two as children: about 1.6e8 instances of the last.
    let mut dag: Vec<String> = (0..38)
        .map(|i| format!(r#"{{"children": [{}, {}]}}"#, i + 1, i + 2))
        .collect();
    dag.push(r#"{"mesh": 0}"#.into());
    dag.push(r#"{"mesh": 0}"#.into());
    let e = gltf_error("dag.gltf", &with_nodes("0", &dag));
    assert!(
        e.contains("dag.gltf") && e.contains("node instances, more than 1000000"),
        "{e}"
    );
    // Few instances but too many triangles for the budget: counted, not built.
    let mut wide: Vec<String> = vec![format!(
        r#"{{"children": [{}]}}"#,
        (1..=8).map(|i| i.to_string()).collect::<Vec<_>>().join(", ")
    )];
    wide.extend((1..=8).map(|_| r#"{"mesh": 0}"#.to_string()));
    let p = common::temp_file("hostile-gltf", "wide.gltf", &with_nodes("0", &wide));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["render", &p, "--technique", "shadow-map"])
        .env("PENUMBRA_MAX_TRIANGLES", "10")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && text.contains("the node graph makes 16 triangles (instances included), beyond the budget of 10"),
        "{text}"
    );
    // A cycle names its node.
    let cycle = vec![
        r#"{"children": [1]}"#.to_string(),
        r#"{"children": [0], "mesh": 0}"#.to_string(),
    ];
    let e = gltf_error("cycle.gltf", &with_nodes("0", &cycle));
    assert!(e.contains("cycle.gltf") && e.contains("node"), "{e}");
    // 2^18 = 262,144 instances of one named node (a few KB): within the instance budget,
    // and loaded in time linear in the objects (each instance's name made unique by a
    // suffix, not by comparing it with every name so far).
    let mut doubling: Vec<String> = (0..18)
        .map(|i| format!(r#"{{"children": [{}, {}]}}"#, i + 1, i + 1))
        .collect();
    doubling.push(r#"{"mesh": 0, "name": "leaf"}"#.into());
    doubling.push(r#"{"camera": 0, "translation": [0, 3, 6]}"#.into());
    doubling.push(
        r#"{"rotation": [-0.7071068, 0, 0, 0.7071068], "extensions": {"KHR_lights_punctual": {"light": 0}}}"#.into(),
    );
    let p = common::temp_file("hostile-gltf", "doubling.gltf", &with_nodes("0, 19, 20", &doubling));
    let start = std::time::Instant::now();
    let s = penumbra::scene::file::load(std::path::Path::new(&p)).unwrap();
    assert_eq!(s.objects.len(), 1 << 18);
    let names: std::collections::HashSet<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names.len(), 1 << 18, "every object's name is its own");
    assert!(
        s.objects.iter().all(|o| o.name.len() < 64),
        "suffixes, not ever longer names"
    );
    assert!(start.elapsed().as_secs() < 20, "{:?}", start.elapsed());
    // A chain 300 deep.
    let mut chain: Vec<String> = (0..299).map(|i| format!(r#"{{"children": [{}]}}"#, i + 1)).collect();
    chain.push(r#"{"mesh": 0}"#.into());
    let e = gltf_error("deep.gltf", &with_nodes("0", &chain));
    assert!(e.contains("deep.gltf") && e.contains("levels deep"), "{e}");
}

/// A glTF file whose name holds a newline loads like any other (the one-line scene that
/// stands for it shows the newline as '?').
#[test]
fn a_gltf_file_name_with_a_newline_loads() {
    let p = common::temp_file(
        "hostile-gltf",
        "two\nlines.gltf",
        &common::gltf_text(&[0, 2, 1, 0, 3, 2], 4),
    );
    let (s, text) = penumbra::scene::file::load_with_text(std::path::Path::new(&p)).unwrap();
    assert_eq!(s.triangles(), 3);
    assert!(text.starts_with("# two?lines.gltf (glTF)\n"), "{text}");
}

/// Material names that sanitize to the same OBJ name ("a b" and "a_b") stay distinct in the
/// export: the second gets a suffix, and the objects and the JSON use the names the MTL has.
#[test]
fn exported_material_names_stay_unique_after_sanitizing() {
    let body = "# two materials, one OBJ name\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\nresolution = [48, 32]\n[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\n[[material]]\nname = \"a b\"\nalbedo = [1, 0, 0]\n[[material]]\nname = \"a_b\"\nalbedo = [0, 1, 0]\n[[object]]\nmesh = \"plane\"\nsize = 4\nmaterial = \"a b\"\n[[object]]\nmesh = \"box\"\ntranslate = [0, 0.5, 0]\nmaterial = \"a_b\"\n";
    let s = scene("names.toml", body);
    let out = std::env::temp_dir().join(format!("penumbra-hostile-export-{}", std::process::id()));
    let (ok, text) = cli(&["export", &s, "--out", out.to_str().unwrap()]);
    assert!(ok, "{text}");
    let mtl = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "mtl"))
        .map(|p| std::fs::read_to_string(p).unwrap())
        .unwrap();
    let names: Vec<&str> = mtl.lines().filter_map(|l| l.strip_prefix("newmtl ")).collect();
    assert!(names.contains(&"a_b") && names.contains(&"a_b_2"), "{names:?}");
    let unique: std::collections::HashSet<&&str> = names.iter().collect();
    assert_eq!(unique.len(), names.len(), "{names:?}");
}

/// Numbers that cannot make an image are refused naming the field; an `up` of any finite,
/// non-zero length is the unit vector it points along; the fields of one kind of light are
/// errors on another; one light per scene.
#[test]
fn the_last_silent_numbers_are_errors_naming_the_field() {
    let parse = |body: &str| penumbra::scene::file::parse(body, std::path::Path::new("n.toml"));
    let with = |from: &str, to: &str| {
        assert!(POINT.contains(from), "{from}");
        POINT.replacen(from, to, 1)
    };
    // An up of 1e38, 3e38 or 1e-45 is the unit y axis (it overflowed or vanished in the view
    // matrix: a flat image).
    for up in ["1e38", "3e38", "1e-45"] {
        let s = parse(&with(
            "target = [0, 0, 0]\n",
            &format!("target = [0, 0, 0]\nup = [0, {up}, 0]\n"),
        ))
        .unwrap();
        assert_eq!(s.camera.up, glam::Vec3::Y, "{up}");
    }
    let cases: Vec<(String, &str)> = vec![
        (
            with("target = [0, 0, 0]\n", "target = [0, 0, 0]\nnear = 1e-38\n"),
            "field `near`: 1e-38 is too close for far = 100",
        ),
        (
            with("target = [0, 0, 0]\n", "target = [0, 0, 0]\nfov = 1e-30\n"),
            "field `fov`: 1e-30 is outside [0.01, 179.9]",
        ),
        (
            with("target = [0, 0, 0]\n", "target = [0, 0, 0]\nfov = 179.95\n"),
            "field `fov`",
        ),
        (
            with("type = \"point\"", "type = \"sphere\"\nradius = 1e38"),
            "field `radius`: 1e38 must be positive and at most 1e7",
        ),
        (
            with("type = \"point\"", "type = \"rectangle\"\nsize = [1e38, 1]"),
            "field `size`",
        ),
        (
            with("type = \"point\"", "type = \"rectangle\"\nsize = [nan, nan]"),
            "field `size`",
        ),
        (
            with("type = \"point\"", "type = \"spot\"\nangle = 1e-30"),
            "field `angle`",
        ),
        (
            with("type = \"point\"", "type = \"point\"\nradius = -5"),
            "field `radius`: does not apply to a point light",
        ),
        (
            with("type = \"point\"", "type = \"point\"\nangle = nan"),
            "field `angle`: does not apply to a point light",
        ),
        (
            with("type = \"point\"", "type = \"point\"\nsize = [nan, nan]"),
            "field `size`: does not apply to a point light",
        ),
        (
            with("type = \"point\"", "type = \"disk\"\nsize = [1, 1]"),
            "field `size`: does not apply to a disk light",
        ),
        (
            with("type = \"point\"", "type = \"directional\"\nradius = 1"),
            "field `radius`: does not apply to a directional light",
        ),
        (
            format!("{POINT}[[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\n"),
            "[[light]] #2 (spot), field `type`: a scene has one light, and its first [[light]] is at line 6",
        ),
    ];
    for (body, want) in cases {
        let e = parse(&body)
            .err()
            .unwrap_or_else(|| panic!("accepted: {body}"))
            .to_string();
        assert!(e.contains(want) && e.starts_with("n.toml:"), "{want}: {e}");
    }
    // 2,000 lights: the same error, at the second.
    let many = format!(
        "{POINT}{}",
        "[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\n".repeat(2000)
    );
    assert!(parse(&many).err().unwrap().to_string().contains("[[light]] #2"));
    // OBJ: NaN or infinity in a vertex no face uses, or in a normal; a zero normal.
    for (obj, want) in [
        (
            "v 0 0 0\nv 1 0 0\nv 0 0 1\nv nan 0 0\nf 1 2 3\n",
            "tri.obj:4: `v`: `nan` is not finite",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn 0 inf 0\nf 1//1 2//1 3//1\n",
            "tri.obj:4: `vn`: `inf` is not finite",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn 0 0 0\nf 1//1 2//1 3//1\n",
            "tri.obj:4: `vn 0 0 0`",
        ),
    ] {
        let p = common::temp_file("hostile-obj", "tri.obj", obj);
        let e = penumbra::scene::mesh::load_obj(std::path::Path::new(&p))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(want), "{want}: {e}");
    }
}

/// Every command that writes files writes none through a symbolic link planted where its
/// output goes (it was `random --out`'s scene and OBJ files): each command runs once, each
/// file it wrote is replaced by a link to a file outside, and the second run refuses, naming
/// the link, and leaves the outside file as it was.
#[test]
fn outputs_are_never_written_through_links() {
    use std::path::{Path, PathBuf};
    fn files(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                files(&p, out);
            } else {
                out.push(p);
            }
        }
    }
    let root = std::env::temp_dir().join(format!("penumbra-hostile-links-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let outside = root.join("outside.txt");
    std::fs::write(&outside, "not yours").unwrap();
    let s = scene("links.toml", POINT);
    for (i, args) in [
        vec!["random", "--seed", "7", "--width", "32", "--height", "24"],
        vec!["render", &s, "--technique", "shadow-map", "--reps", "1"],
        vec!["dump", &s, "--technique", "pcss"],
        vec!["reference", &s],
        vec!["export", &s],
        vec!["choose", &s, "--reps", "1"],
        vec!["sweep", &s, "--techniques", "shadow-map,pcss"],
        vec![
            "defaults",
            "--scenes",
            "1",
            "--width",
            "16",
            "--height",
            "12",
            "--techniques",
            "pvm",
            "--reps",
            "1",
        ],
    ]
    .into_iter()
    .enumerate()
    {
        let out = root.join(format!("out{i}"));
        let out_s = out.display().to_string();
        let mut args = args;
        args.extend(["--out", &out_s]);
        let (ok, text) = cli(&args);
        assert!(ok, "{args:?}: {text}");
        let mut written = Vec::new();
        files(&out, &mut written);
        assert!(!written.is_empty(), "{args:?} wrote nothing");
        for f in &written {
            std::fs::remove_file(f).unwrap();
            std::os::unix::fs::symlink(&outside, f).unwrap();
        }
        let (ok, text) = cli(&args);
        assert!(!ok && text.contains("not written through"), "{args:?}: {text}");
        assert_eq!(std::fs::read_to_string(&outside).unwrap(), "not yours", "{args:?}");
    }
    // An output folder that is itself a link is refused too.
    let elsewhere = root.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let linked = root.join("linked");
    std::os::unix::fs::symlink(&elsewhere, &linked).unwrap();
    let (ok, text) = cli(&["random", "--seed", "7", "--out", &linked.display().to_string()]);
    assert!(!ok && text.contains("not a folder"), "{text}");
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0);
    let _ = std::fs::remove_dir_all(&root);
}

/// Two objects holding the same triangles tie in depth at every pixel of them: the G-buffer's
/// triangle was the last object's while its object was the first's, and a technique that
/// read the triangle of a pixel's object indexed past it (`choose --scale 0.5` on a glTF file
/// whose meshes shared a quad panicked in the IZB's sample setup). Every pixel's triangle is
/// now one of its own object's, at any resolution.
#[test]
fn coplanar_objects_keep_their_own_triangles_in_the_gbuffer() {
    let quad = "v -4 0 -4\nv 4 0 -4\nv 4 0 4\nv -4 0 4\nf 1 3 2\nf 1 4 3\n";
    // Ten small triangles elsewhere, then the same quad: its triangles are 10 and 11.
    let mut more = String::new();
    for i in 0..10 {
        let x = 20 + 2 * i;
        more += &format!("v {x} 0 20\nv {} 0 20\nv {x} 0 21\n", x + 1);
    }
    more += "v -4 0 -4\nv 4 0 -4\nv 4 0 4\nv -4 0 4\n";
    for i in 0..10 {
        let b = 3 * i + 1;
        more += &format!("f {b} {} {}\n", b + 2, b + 1);
    }
    more += "f 31 33 32\nf 31 34 33\n";
    common::temp_file("hostile-ties", "a.obj", quad);
    common::temp_file("hostile-ties", "b.obj", &more);
    let scene = common::temp_file(
        "hostile-ties",
        "ties.toml",
        r#"
[camera]
position = [3.5, 2.6, 4.5]
target = [0, 0, 0]
fov = 40
resolution = [96, 54]

[[light]]
type = "directional"
direction = [-0.3, -1, -0.2]

[[material]]
name = "m"
albedo = [0.7, 0.7, 0.7]

[[object]]
name = "a"
mesh = "a.obj"
material = "m"

[[object]]
name = "b"
mesh = "b.obj"
material = "m"

[[object]]
name = "box"
mesh = "box"
size = [1, 1, 1]
translate = [0, 0.5, 0]
material = "m"
"#,
    );
    let s = penumbra::scene::file::load(std::path::Path::new(&scene)).unwrap();
    let p = penumbra::pipeline::Pipeline::new(2).unwrap();
    for (w, h) in [(96, 54), (48, 27), (163, 91)] {
        let mut s = s.clone();
        (s.camera.width, s.camera.height) = (w, h);
        let f = penumbra::frame::frame(&p, &s, 0, 0).unwrap();
        let (objs, prims) = (f.gbuffer.object.data(), f.gbuffer.prim.data());
        let mut quad_pixels = 0;
        for (&o, &t) in objs.iter().zip(prims) {
            if o == penumbra::frame::NO_OBJECT {
                continue;
            }
            let tris = s.objects[o as usize].mesh.indices.len() / 3;
            assert!(
                (t as usize) < tris,
                "{w}x{h}: object {o} has {tris} triangles, the pixel names {t}"
            );
            quad_pixels += (o == 0) as usize;
        }
        assert!(
            quad_pixels > w as usize * h as usize / 4,
            "{w}x{h}: the quad is in view"
        );
    }
    let out = std::env::temp_dir().join(format!("penumbra-hostile-ties-out-{}", std::process::id()));
    let (ok, text) = common::cli(&[
        "render",
        &scene,
        "--technique",
        "izb",
        "--set",
        "samples=4",
        "--out",
        &out.to_string_lossy(),
    ]);
    assert!(ok, "{text}");
}

/// Messages that said too little: an empty or unknown `--techniques` name names the flag; an
/// integer option set to a number its type cannot hold gives the option's own range; a
/// `defaults` list without a soft or volumetric technique says which those are; a single
/// table where a scene takes a list of them says to write `[[...]]`.
#[test]
fn refusals_name_the_flag_the_range_and_the_fix() {
    let scene = "fixtures/scenes/contact.toml";
    for (args, want) in [
        (
            &["sweep", scene, "--techniques", ""][..],
            "--techniques '': an empty technique name",
        ),
        (
            &["sweep", scene, "--techniques", "pcss,"][..],
            "--techniques 'pcss,': an empty technique name",
        ),
        (
            &["sweep", scene, "--techniques", "pcss,,vsm"][..],
            "an empty technique name",
        ),
        (
            &["sweep", scene, "--techniques", "nope"][..],
            "--techniques: unknown technique 'nope'",
        ),
        (
            &["defaults", "--techniques", "nope"][..],
            "--techniques: unknown technique 'nope'",
        ),
        (
            &["defaults", "--techniques", "shadow-map"][..],
            "--techniques shadow-map: none of them models",
        ),
        (
            &["render", scene, "--technique", "shadow-map", "--set", "size=inf"][..],
            "size=inf is outside [16, 16384]",
        ),
        (
            &["render", scene, "--technique", "shadow-map", "--set", "size=1e30"][..],
            "size=1e30 is outside [16, 16384]",
        ),
        (
            &["render", scene, "--technique", "shadow-map", "--set", "size=-1"][..],
            "size=-1 is outside [16, 16384]",
        ),
        (
            &["render", scene, "--technique", "pcss", "--set", "light=1e40"][..],
            "light=1e40 is outside",
        ),
    ] {
        let (ok, text) = common::cli(args);
        assert!(!ok && text.contains(want), "{args:?}: {text}");
    }
    // A number that is no number keeps its own reason.
    let (ok, text) = common::cli(&["render", scene, "--technique", "shadow-map", "--set", "units=nan"]);
    assert!(!ok && text.contains("units=nan is not finite"), "{text}");
    for (table, body) in [
        ("object", "[object]\nname = \"a\"\nmesh = \"box\"\n"),
        (
            "light_path",
            "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\n[light_path]\ndirection = [0, -1, 0]\n",
        ),
    ] {
        let p = common::temp_file("hostile-tables", &format!("{table}.toml"), body);
        let e = penumbra::scene::file::load(std::path::Path::new(&p))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("write [[{table}]]")), "{table}: {e}");
    }
}

/// Names and values from input reach the terminal without acting on it: an object's and a
/// material's names with an ANSI clear-screen and a right-to-left override, and the same in
/// an option's value, come out escaped in the printed error, whichever message carries them.
#[test]
fn names_reach_the_terminal_escaped() {
    let evil = "x\u{1b}[2J\u{1b}]0;title\u{7}\u{202e}y";
    // TOML's escapes: `\uXXXX` for every character.
    let toml: String = evil.chars().map(|c| format!("\\u{:04X}", c as u32)).collect();
    let body = format!(
        "[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\n[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\n[[object]]\nname = \"{toml}\"\nmesh = \"box\"\nmaterial = \"{toml}\"\n"
    );
    let scene = common::temp_file("hostile-names", "evil.toml", &body);
    let set = format!("size={evil}");
    for args in [
        vec!["render", scene.as_str(), "--technique", "shadow-map"],
        vec![
            "render",
            "fixtures/scenes/contact.toml",
            "--technique",
            "shadow-map",
            "--set",
            set.as_str(),
        ],
        vec!["render", "fixtures/scenes/contact.toml", "--technique", evil],
    ] {
        let (ok, text) = common::cli(&args);
        assert!(!ok, "{args:?}: {text}");
        assert!(
            !text.contains('\u{1b}') && !text.contains('\u{202e}') && !text.contains('\u{7}'),
            "{text:?}"
        );
        assert!(text.contains("\\u{1b}[2J"), "{args:?}: {text:?}");
    }
}

#[test]
fn long_jobs_say_what_they_will_do_and_move_while_they_do_it() {
    // Past the stated limit: refused, naming it and how to ask.
    let (ok, text) = cli(&["defaults", "--scenes", "100000", "--out", "/nonexistent/never"]);
    assert!(!ok);
    assert!(
        text.contains("past the limit of 1000 scenes a class") && text.contains("--long"),
        "{text}"
    );
    // Before the runs: what it will do. During the reference (no cache in a fresh folder),
    // the progress line says which stage is at work and how far it is.
    let out = std::env::temp_dir().join(format!("penumbra-long-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args([
            "choose",
            "fixtures/scenes/contact.toml",
            "--scale",
            "1.5",
            "--threads",
            "2",
            "--out",
        ])
        .arg(&out)
        .env("PENUMBRA_PROGRESS_SECS", "0.05")
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr),
    );
    assert!(run.status.success(), "{stderr}");
    assert!(
        stdout.contains("choose: ") && stdout.contains(" runs of ") && stdout.contains("rays a frame first"),
        "{stdout}"
    );
    assert!(
        stderr
            .lines()
            .any(|l| l.contains("at contact / reference (tracing the reference (rows): ")),
        "{stderr}"
    );
    assert!(stderr.contains("s left"), "{stderr}");
    let _ = std::fs::remove_dir_all(&out);
}
