//! Hostile but realistic input through the CLI: each case gets a clear error naming what was
//! wrong (or a documented, correct behaviour), never a panic, never garbage.

mod common;
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
    assert!(!ok && text.contains("beyond the memory limit of 0 MiB"), "{text}");
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
            "--triangles 50000000 is out of range",
        ),
        (
            &["bench", "rays", "--rays", "1000000000"][..],
            "--rays 1000000000 is out of range",
        ),
        (
            &["bench", "raster", "--triangles", "1000", "--area", "1e7"][..],
            "--area 10000000 is out of range",
        ),
        (
            &["bench", "raster", "--triangles", "10000000", "--area", "2e6"][..],
            "beyond 2e10",
        ),
        (&["bench", "frame", "--reps", "1000"][..], "from 0 to 100"),
        (&["render", "x.toml", "--reps", "101"][..], "from 0 to 100"),
    ] {
        let (ok, text) = cli(args);
        assert!(!ok && text.contains(want), "{args:?}: {text}");
    }
}
