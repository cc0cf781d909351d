//! What penumbra writes for users and other tools: the sweep's files (sharded and merged
//! equal to one run), the report page, exports, float images and glTF scenes.

use crate::common;
use common::cli;
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-report-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const HARD: &str = "# a plane and a box under the sun\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\nresolution = [40, 30]\n\n[[light]]\ntype = \"directional\"\ndirection = [0.3, -1, 0.2]\n\n[[object]]\nmesh = \"plane\"\nsize = 4\n\n[[object]]\nmesh = \"box\"\nsize = [1, 1, 1]\ntranslate = [0, 0.5, 0]\n";

/// The CSV's rows with the timing columns blanked (they differ run to run, and with the
/// thread count, which is a column too).
fn rows_without_timings(csv_path: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(csv_path).unwrap();
    let head = r.headers().unwrap().clone();
    let timing: Vec<usize> = head
        .iter()
        .enumerate()
        .filter(|(_, h)| ["ms", "passes_ms", "threads"].contains(h))
        .map(|(i, _)| i)
        .collect();
    assert_eq!(timing.len(), 3, "{head:?}");
    r.records()
        .map(|rec| {
            rec.unwrap()
                .iter()
                .enumerate()
                .map(|(i, f)| {
                    if timing.contains(&i) {
                        String::new()
                    } else {
                        f.to_string()
                    }
                })
                .collect()
        })
        .collect()
}

/// `sweep --merge` of the shard folders `parts` into `dir/merged`, which it returns.
fn merge_shards(dir: &Path, parts: &[String]) -> PathBuf {
    let merged = dir.join("merged");
    let mut args = vec!["sweep", "--out", merged.to_str().unwrap(), "--merge"];
    args.extend(parts.iter().map(String::as_str));
    let (ok, text) = cli(&args);
    assert!(ok, "{text}");
    merged
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = walk(dir)
        .into_iter()
        .map(|p| p.strip_prefix(dir).unwrap().to_string_lossy().into_owned())
        .filter(|p| !p.starts_with("cache"))
        .collect();
    v.sort();
    v
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        if e.path().is_dir() {
            out.extend(walk(&e.path()));
        } else {
            out.push(e.path());
        }
    }
    out
}

#[test]
fn sharded_and_merged_sweep_equals_one_run() {
    let dir = temp_dir("shards");
    // A comma in a scene's file name must not shift the CSV's columns.
    let a = dir.join("a,b.toml");
    let b = dir.join("second.toml");
    std::fs::write(&a, HARD).unwrap();
    std::fs::write(&b, HARD.replace("0.3, -1", "-0.4, -1")).unwrap();
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let techniques = "reference,shadow-map,shadow-volume,planar";
    // `sweep a b --techniques T --reps 1 --threads N [--shard I/3] --out DIR`.
    let sweep = |threads: &str, shard: Option<String>, out: &Path| {
        let mut args = vec![
            "sweep",
            a,
            b,
            "--techniques",
            techniques,
            "--reps",
            "1",
            "--threads",
            threads,
        ];
        if let Some(s) = &shard {
            args.extend(["--shard", s.as_str()]);
        }
        args.extend(["--out", out.to_str().unwrap()]);
        let (ok, text) = cli(&args);
        assert!(ok, "{text}");
    };
    let whole = dir.join("whole");
    sweep("2", None, &whole);
    let mut parts = Vec::new();
    for i in 0..3 {
        let out = dir.join(format!("part{i}"));
        sweep("1", Some(format!("{i}/3")), &out);
        parts.push(out.to_str().unwrap().to_string());
    }
    let merged = merge_shards(&dir, &parts);
    let rows = rows_without_timings(&whole.join("results.csv"));
    assert!(rows.len() > 8, "{rows:?}");
    let merged_rows = rows_without_timings(&merged.join("results.csv"));
    assert_eq!(rows.len(), merged_rows.len());
    for (a, b) in rows.iter().zip(&merged_rows) {
        assert_eq!(a, b);
    }
    assert_eq!(files(&whole), files(&merged));
    // The summaries: one row per technique (the README's), and one per setting.
    let table_rows = |name: &str| -> Vec<String> {
        std::fs::read_to_string(whole.join(name))
            .unwrap()
            .lines()
            .skip(2)
            .map(|l| l.split('|').nth(1).unwrap().trim().to_string())
            .collect()
    };
    let (one, all) = (table_rows("summary.md"), table_rows("summary_all.md"));
    let names: Vec<&str> = techniques.split(',').collect();
    assert_eq!(one.len(), names.len(), "{one:?}");
    for (row, name) in one.iter().zip(&names) {
        // Its defaults: shadow-map's sweep runs them as `size=2048`, after other sizes.
        let want = if *name == "shadow-map" {
            "shadow-map [size=2048]".to_string()
        } else {
            name.to_string()
        };
        assert_eq!(row, &want);
    }
    assert!(all.len() > one.len() && one.iter().all(|r| all.contains(r)), "{all:?}");
    // Missing and doubled shards are errors that say so.
    let merge = |dirs: &[&str]| {
        let mut args = vec!["sweep", "--out", merged.to_str().unwrap(), "--merge"];
        args.extend(dirs);
        cli(&args)
    };
    let (ok, text) = merge(&[&parts[0], &parts[2]]);
    assert!(!ok && text.contains("in none of the folders"), "{text}");
    let (ok, text) = merge(&[&parts[0], &parts[0], &parts[1], &parts[2]]);
    assert!(!ok && text.contains("in two shards"), "{text}");
    // A shard of another sweep (other settings, the same run count) is refused.
    let other_sweep = dir.join("other");
    let (ok, text) = cli(&[
        "sweep",
        a,
        b,
        "--techniques",
        "reference,shadow-volume,shadow-map,cookie",
        "--reps",
        "1",
        "--shard",
        "2/3",
        "--out",
        other_sweep.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let (ok, text) = cli(&[
        "sweep",
        "--out",
        merged.to_str().unwrap(),
        "--merge",
        &parts[0],
        &parts[1],
        other_sweep.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("shards of different sweeps"), "{text}");
    let (ok, text) = cli(&["sweep", a, "--shard", "3/3"]);
    assert!(!ok && text.contains("0 <= I < N"), "{text}");
    // Two scenes of one name in one sweep would overwrite each other's files.
    let other = dir.join("sub");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("second.toml"), HARD).unwrap();
    let (ok, text) = cli(&[
        "sweep",
        b,
        other.join("second.toml").to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("are both scene 'second'"), "{text}");
    // The report page: one per-class chart, the scenes' tables, no network resources.
    let html = std::fs::read_to_string(merged.join("report.html")).unwrap();
    assert!(
        html.contains("id=\"class-hard\"") && html.contains("<title>"),
        "chart tooltips"
    );
    assert!(!html.contains("https://") && !html.contains("src=\"http"));
    assert!(merged.join("chart_hard.svg").exists() && merged.join("charts").join("second.svg").exists());
}

#[test]
fn gltf_scenes_load_with_transforms_materials_camera_and_lights() {
    let dir = temp_dir("gltf");
    let path = dir.join("leaf.gltf");
    std::fs::write(&path, common::gltf_text(&[0, 2, 1, 0, 3, 2], 4)).unwrap();
    let s = penumbra::scene::file::load(&path).unwrap();
    assert_eq!(s.objects.len(), 2);
    assert_eq!(s.triangles(), 3);
    // The leaf: scaled by its node, lifted by its parent.
    let leaf = &s.objects[0];
    assert_eq!(leaf.name, "leaf/tri/0");
    assert!(leaf.mesh.positions.iter().all(|p| (p.y - 1.0).abs() < 1e-6));
    assert!(
        (leaf.mesh.positions[0].x + 1.0).abs() < 1e-6,
        "{:?}",
        leaf.mesh.positions
    );
    let veil = &s.materials[leaf.material];
    assert_eq!((veil.name.as_str(), veil.opacity, veil.two_sided), ("veil", 0.25, true));
    let floor = &s.materials[s.objects[1].material];
    assert!((floor.albedo.y - 0.6).abs() < 1e-6 && floor.opacity == 1.0);
    // The camera at its node, looking down its -z; the aspect ratio sets the resolution.
    assert!((s.camera.position - glam::Vec3::new(0.0, 3.0, 6.0)).length() < 1e-5);
    assert!((s.camera.fov_deg - 0.8f32.to_degrees()).abs() < 1e-3);
    assert_eq!((s.camera.width, s.camera.height), (640, 480));
    // The sun points down.
    assert_eq!(s.lights.len(), 1);
    assert!(
        (s.lights[0].direction - glam::Vec3::new(0.0, -1.0, 0.0)).length() < 1e-5,
        "{:?}",
        s.lights[0]
    );
    // It renders: the translucent leaf's shadow is partial under the reference and the
    // transparency map.
    let (ok, text) = cli(&[
        "render",
        path.to_str().unwrap(),
        "--technique",
        "transparency-map",
        "--reps",
        "1",
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(
        dir.join("out").join("leaf_transparency-map_visibility.exr").exists(),
        "{text}"
    );
    // A scene file may take the glTF as the whole scene, or as one object's mesh.
    std::fs::write(
        dir.join("wrap.toml"),
        "# wrapped\ngltf = \"leaf.gltf\"\n[[light]]\ntype = \"point\"\nposition = [0, 4, 0]\n",
    )
    .unwrap();
    let w = penumbra::scene::file::load(&dir.join("wrap.toml")).unwrap();
    assert_eq!(
        (w.objects.len(), w.lights[0].kind),
        (2, penumbra::scene::LightKind::Point)
    );
    std::fs::write(
        dir.join("mesh.toml"),
        "# as a mesh\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\n[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\n[[object]]\nmesh = \"leaf.gltf\"\ntranslate = [0, 1, 0]\n",
    )
    .unwrap();
    let m = penumbra::scene::file::load(&dir.join("mesh.toml")).unwrap();
    assert_eq!((m.objects.len(), m.triangles()), (1, 3));
}

#[test]
fn bad_gltf_files_name_the_file_and_what_is_wrong() {
    let dir = temp_dir("gltf-bad");
    let cases: [(&str, String, &str); 4] = [
        (
            "index.gltf",
            common::gltf_text(&[0, 2, 9], 4),
            "index 9 beyond the 4 positions",
        ),
        ("lines.gltf", common::gltf_text(&[0, 1], 1), "only TRIANGLES"),
        ("junk.gltf", "{ not json".into(), "not valid glTF JSON"),
        (
            "partial.gltf",
            common::gltf_text(&[0, 2, 1, 0], 4),
            "not whole triangles",
        ),
    ];
    for (name, body, want) in cases {
        let p = dir.join(name);
        std::fs::write(&p, body).unwrap();
        let e = penumbra::scene::file::load(&p)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains(name) && e.contains(want), "{name}: {e}");
        let (ok, text) = cli(&["render", p.to_str().unwrap(), "--technique", "shadow-map"]);
        assert!(!ok && text.contains(want), "{text}");
    }
    let e = penumbra::scene::file::load(&dir.join("missing.glb"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.glb"), "{e}");
    // Through a scene file, the error names the scene's line and field too.
    std::fs::write(dir.join("s.toml"), "# s\ngltf = \"index.gltf\"\n").unwrap();
    let e = penumbra::scene::file::load(&dir.join("s.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.toml:2") && e.contains("`gltf`") && e.contains("index 9"),
        "{e}"
    );
}

#[test]
fn export_writes_materials_and_structured_json() {
    let dir = temp_dir("export");
    let scene = dir.join("x.toml");
    std::fs::write(
        &scene,
        "# glass over a floor\n[camera]\nposition = [0, 3, 5]\ntarget = [0, 0, 0]\nresolution = [32, 24]\n[[light]]\ntype = \"disk\"\nposition = [0, 4, 0]\nradius = 0.35\n[[material]]\nname = \"glass\"\nopacity = 0.5\ntransmittance = [1, 0.2, 0.2]\ntwo_sided = true\n[[object]]\nmesh = \"plane\"\nsize = 4\nname = \"floor\\nv 1 2 3\"\n[[object]]\nmesh = \"box\"\nmaterial = \"glass\"\ntranslate = [0, 1, 0]\n",
    )
    .unwrap();
    let out = dir.join("out");
    let (ok, text) = cli(&["export", scene.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(ok, "{text}");
    let mtl = std::fs::read_to_string(out.join("x.mtl")).unwrap();
    assert!(
        mtl.contains("newmtl glass\nKd 0.8 0.8 0.8\nd 0.5\nTf 1 0.2 0.2"),
        "{mtl}"
    );
    let obj = std::fs::read_to_string(out.join("x.obj")).unwrap();
    assert!(obj.contains("mtllib x.mtl") && obj.contains("usemtl glass"));
    // A newline in an object's name cannot add statements (here a vertex) to the OBJ.
    assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), 4 + 24, "{obj}");
    let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("x.json")).unwrap()).unwrap();
    assert_eq!(j["lights"][0]["type"], "disk");
    assert!((j["lights"][0]["radius"].as_f64().unwrap() - 0.35).abs() < 1e-6);
    assert_eq!(j["materials"][1]["two_sided"], true);
    assert!(j["reference_sampling"].as_str().unwrap().contains("stratified"));
    // A scene file whose name and object names carry quotes, commas and newlines: the JSON
    // still parses and keeps them.
    let hostile = dir.join("q\"uote, a\\b.toml");
    std::fs::write(
        &hostile,
        std::fs::read_to_string(&scene)
            .unwrap()
            .replace("name = \"floor\\nv 1 2 3\"", "name = \"a \\\"b\\\" <c>\""),
    )
    .unwrap();
    let out2 = dir.join("out2");
    let (ok, text) = cli(&["export", hostile.to_str().unwrap(), "--out", out2.to_str().unwrap()]);
    assert!(ok, "{text}");
    let json_file = std::fs::read_dir(&out2)
        .unwrap()
        .flatten()
        .find(|e| e.path().extension().is_some_and(|x| x == "json"))
        .unwrap();
    let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(json_file.path()).unwrap()).unwrap();
    assert_eq!(j["scene"], "q\"uote, a\\b");
    assert_eq!(j["objects"][0]["name"], "a_\"b\"_<c>");
}

#[test]
fn a_technique_left_out_of_a_scene_is_skipped_not_missing() {
    // Terrain occlusion height needs a heightfield: the sweep skips it on `contact`, lists it as
    // skipped, and the merge of shards accepts its absence.
    let dir = temp_dir("skipped");
    let scenes = ["fixtures/scenes/contact.toml", "fixtures/scenes/terrain.toml"];
    let sweep = |extra: &[&str], out: &Path| {
        let mut args = vec![
            "sweep",
            scenes[0],
            scenes[1],
            "--techniques",
            "reference,terrain-height",
        ];
        args.extend(["--reps", "1", "--out", out.to_str().unwrap()]);
        args.extend(extra);
        let (ok, text) = cli(&args);
        assert!(ok, "{text}");
    };
    let whole = dir.join("whole");
    sweep(&[], &whole);
    let rows = rows_without_timings(&whole.join("results.csv"));
    let terrain_rows = rows.iter().filter(|r| r.iter().any(|c| c == "terrain-height")).count();
    let sets = penumbra::shadow::registry::registry()
        .into_iter()
        .find(|t| t.name == "terrain-height")
        .unwrap()
        .sweep
        .len();
    assert_eq!(terrain_rows, sets, "terrain-height runs on `terrain` only: {rows:?}");
    let summary = std::fs::read_to_string(whole.join("summary.md")).unwrap();
    assert!(summary.contains("terrain-height (on 1 of 2 scenes)"), "{summary}");
    let mut parts = Vec::new();
    for i in 0..2 {
        let out = dir.join(format!("part{i}"));
        sweep(&["--shard", &format!("{i}/2")], &out);
        parts.push(out.to_str().unwrap().to_string());
    }
    let merged = merge_shards(&dir, &parts);
    assert_eq!(rows, rows_without_timings(&merged.join("results.csv")));
}

/// `sweep --merge` reads only regular files inside the shards' folders and writes only inside
/// `--out`, never through a link; each row it merges must be one the sweep could have
/// written, and each error names the folder, the file and the row.
#[test]
fn merge_refuses_links_devices_and_rows_no_sweep_wrote() {
    let dir = temp_dir("merge-hostile");
    let scene = dir.join("hard.toml");
    std::fs::write(&scene, HARD).unwrap();
    let mut parts = Vec::new();
    for i in 0..2 {
        let out = dir.join(format!("part{i}"));
        let (ok, text) = cli(&[
            "sweep",
            scene.to_str().unwrap(),
            "--techniques",
            "reference,shadow-map,planar",
            "--reps",
            "1",
            "--shard",
            &format!("{i}/2"),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
        parts.push(out);
    }
    let merged = dir.join("merged");
    let merge = |p0: &Path| {
        let (p1, out) = (parts[1].to_str().unwrap(), merged.to_str().unwrap());
        cli(&["sweep", "--out", out, "--merge", p0.to_str().unwrap(), p1])
    };
    assert!(merge(&parts[0]).0);
    // A copy of shard 0 that each case spoils in one way.
    let spoiled = dir.join("spoiled");
    let fresh = || {
        let _ = std::fs::remove_dir_all(&spoiled);
        std::fs::create_dir_all(spoiled.join("images")).unwrap();
        for name in ["results.csv", "sweep.json"] {
            std::fs::copy(parts[0].join(name), spoiled.join(name)).unwrap();
        }
        std::fs::read_to_string(spoiled.join("results.csv")).unwrap()
    };
    let csv = fresh();
    let (head, rows) = csv.split_once('\n').unwrap();
    let first = rows.lines().next().unwrap();
    let field = |k: usize| first.split(',').nth(k).unwrap().to_string();
    let with_first = |from: &str, to: &str| {
        let row = first.replacen(from, to, 1);
        assert_ne!(row, first, "{from}");
        csv.replacen(first, &row, 1)
    };
    let ms = format!(",{},", field(6));
    let cases: Vec<(String, String)> = vec![
        (String::new(), "results.csv: empty".into()),
        (format!("{head}\n"), "spoiled: shard 0/2 should hold runs 0..".into()),
        (
            format!(
                "{head},extra\n{}",
                rows.lines().map(|l| format!("{l},1\n")).collect::<String>()
            ),
            "columns not in it: [\"extra\"]".into(),
        ),
        (with_first(&ms, ",NaN,"), "run 0: column ms: NaN".into()),
        (with_first(&ms, ",-3,"), "run 0: column ms: -3".into()),
        (
            with_first("0,hard,", "999,hard,"),
            "row 1 (run 999): the run is not in this folder's shard 0/2".into(),
        ),
        (
            with_first(",reference,reference,", ",nope,reference,"),
            "row 1 (run 0): is 'nope' on scene 'hard' (hard), but the sweep's run 0 is 'reference'".into(),
        ),
        (
            with_first("0,hard,", "0,other,"),
            "is 'reference' on scene 'other'".into(),
        ),
        (
            format!("{csv}{first}\n"),
            "(run 0): the same run as row 1 of the same file".into(),
        ),
    ];
    for (body, want) in cases {
        fresh();
        std::fs::write(spoiled.join("results.csv"), &body).unwrap();
        let (ok, text) = merge(&spoiled);
        assert!(
            !ok && text.contains(want.as_str()) && text.contains("spoiled"),
            "{want}: {text}"
        );
    }
    // An unknown technique in the manifest.
    fresh();
    let json = std::fs::read_to_string(spoiled.join("sweep.json")).unwrap();
    std::fs::write(spoiled.join("sweep.json"), json.replacen("\"planar\"", "\"nope\"", 1)).unwrap();
    let (ok, text) = merge(&spoiled);
    assert!(
        !ok && text.contains("technique 'nope', which penumbra does not have"),
        "{text}"
    );
    #[cfg(unix)]
    {
        use std::os::unix::fs::symlink;
        let secret = dir.join("secret.txt");
        std::fs::write(&secret, "not for the report").unwrap();
        // A link in a shard's images/ is not followed (it would copy any file on the machine).
        fresh();
        symlink(&secret, spoiled.join("images/hard_reference.png")).unwrap();
        let (ok, text) = merge(&spoiled);
        assert!(
            !ok && text.contains("hard_reference.png") && text.contains("symbolic link"),
            "{text}"
        );
        // A linked results.csv is not read either.
        fresh();
        std::fs::remove_file(spoiled.join("results.csv")).unwrap();
        symlink(parts[0].join("results.csv"), spoiled.join("results.csv")).unwrap();
        let (ok, text) = merge(&spoiled);
        assert!(!ok && text.contains("symbolic link"), "{text}");
        // A FIFO as results.csv is refused before it is opened (a read would hang).
        fresh();
        std::fs::remove_file(spoiled.join("results.csv")).unwrap();
        let made = std::process::Command::new("mkfifo")
            .arg(spoiled.join("results.csv"))
            .status();
        if made.is_ok_and(|s| s.success()) {
            let (ok, text) = merge(&spoiled);
            assert!(!ok && text.contains("not a regular file"), "{text}");
        }
        // An output whose images/ links elsewhere is not written through.
        let outside = dir.join("outside");
        std::fs::create_dir_all(&outside).unwrap();
        let _ = std::fs::remove_dir_all(&merged);
        std::fs::create_dir_all(&merged).unwrap();
        symlink(&outside, merged.join("images")).unwrap();
        let (ok, text) = merge(&parts[0]);
        assert!(!ok && text.contains("not a folder"), "{text}");
        assert_eq!(std::fs::read_dir(&outside).unwrap().count(), 0);
        // Nor a report file that is a link.
        let _ = std::fs::remove_dir_all(&merged);
        std::fs::create_dir_all(&merged).unwrap();
        symlink(&secret, merged.join("report.md")).unwrap();
        let (ok, text) = merge(&parts[0]);
        assert!(
            !ok && text.contains("report.md") && text.contains("not written through"),
            "{text}"
        );
        assert_eq!(std::fs::read_to_string(&secret).unwrap(), "not for the report");
    }
}

/// A sweep whose stderr is not a terminal (a CI log, a batch job) prints plain progress lines
/// (done/total, elapsed, what is at work) when it starts and at a fixed interval, instead of
/// nothing for its whole run.
#[test]
fn a_piped_sweep_prints_progress_lines() {
    let dir = temp_dir("progress");
    let scene = dir.join("hard.toml");
    std::fs::write(&scene, HARD).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["sweep", scene.to_str().unwrap(), "--techniques", "reference,shadow-map"])
        .args(["--reps", "3", "--out", dir.join("out").to_str().unwrap()])
        .env("PENUMBRA_PROGRESS_SECS", "0.001")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("sweep: ")).collect();
    assert!(
        lines[0].starts_with("sweep: 0/") && lines[0].contains(" runs, "),
        "{err}"
    );
    assert!(
        lines.len() >= 2 && lines.iter().any(|l| l.contains(", at hard / ")),
        "{err}"
    );
}

/// `penumbra random` writes a seed's scene (and the OBJ files it names) so that it renders
/// like any fixture; the same seed writes the same files.
#[test]
fn random_writes_a_scene_that_renders() {
    let dir = temp_dir("random");
    let mut texts = Vec::new();
    for run in 0..2 {
        let out = dir.join(format!("r{run}"));
        // Seed 11 has a knot (an OBJ beside the scene).
        let (ok, text) = cli(&["random", "--seed", "11", "--out", out.to_str().unwrap()]);
        assert!(ok, "{text}");
        let scene = text.lines().next().unwrap().to_string();
        assert!(scene.ends_with("random_11.toml") && text.contains(".obj"), "{text}");
        texts.push(std::fs::read_to_string(&scene).unwrap());
        let (ok, text) = cli(&[
            "render",
            &scene,
            "--technique",
            "shadow-map",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
    }
    assert_eq!(texts[0], texts[1]);
    let (ok, text) = cli(&[
        "random",
        "--seed",
        "1",
        "--light",
        "laser",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("one of directional, spot"), "{text}");
    let (ok, text) = cli(&["random", "--seed", "-1"]);
    assert!(!ok && text.contains("-1 is outside"), "{text}");
}

/// `penumbra choose`: on an opaque scene under the sun no volumetric and no penumbra technique
/// runs (each is listed as skipped, with why); the pick meets the error bound and no faster
/// run of the same call does; an unreachable goal names the closest setting; bad goals are
/// refused with the number and the flag.
#[test]
fn choose_picks_the_cheapest_setting_within_the_goal() {
    let dir = temp_dir("choose");
    let scene = dir.join("hard.toml");
    std::fs::write(&scene, HARD).unwrap();
    let s = scene.to_str().unwrap();
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    let (ok, text) = cli(&["choose", s, "--max-error", "2", "--reps", "1", "--json", "--out", o]);
    assert!(ok, "{text}");
    // stdout (the JSON object) comes first, stderr's progress lines after it.
    let json = &text[text.find('{').unwrap()..=text.find("\n}").unwrap() + 1];
    let doc: serde_json::Value = serde_json::from_str(json).unwrap();
    let runs = doc["runs"].as_array().unwrap();
    let skipped: Vec<&str> = doc["skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["technique"].as_str().unwrap())
        .collect();
    // Under the sun, with every object opaque, a technique runs when it models nothing more
    // than a hard shadow (and works on the scene); the others are listed as skipped.
    let parsed = penumbra::scene::file::parse(HARD, &scene).unwrap();
    for t in penumbra::shadow::registry::registry()
        .iter()
        .filter(|t| t.name != "reference")
    {
        let ran = runs.iter().any(|r| r["technique"] == t.name);
        assert_eq!(ran, t.models.is_empty() && t.applies_to(&parsed), "{}", t.name);
        assert_eq!(skipped.contains(&t.name), !ran, "{}", t.name);
    }
    for t in ["avsm", "deep-shadow-map", "pcss", "pvm"] {
        assert!(skipped.contains(&t), "{t}: {skipped:?}");
    }
    let pick = &doc["pick"];
    let (err, ms) = (pick["error"].as_f64().unwrap(), pick["ms"].as_f64().unwrap());
    assert!(err <= 2.0, "{pick}");
    for r in runs {
        let (e, t) = (r["error"].as_f64().unwrap(), r["ms"].as_f64().unwrap());
        assert!(
            !(e <= 2.0 && t < ms),
            "{r} is within the bound and faster than the pick {pick}"
        );
    }
    assert!(out.join("hard.svg").is_file());
    // An unreachable goal: no pick, the closest named.
    let (ok, text) = cli(&["choose", s, "--budget-ms", "0.000001", "--reps", "0", "--out", o]);
    assert!(
        ok && text.contains("nothing runs within 0.000001 ms; the fastest is "),
        "{text}"
    );
    let (ok, text) = cli(&["choose", s, "--max-error", "0", "--reps", "0", "--out", o]);
    assert!(
        ok && (text.contains("pick (") || text.contains("nothing within 0; the most accurate is ")),
        "{text}"
    );
    for (flag, value, says) in [
        ("--max-error", "-1", "--max-error -1: an error is a finite number"),
        ("--max-error", "NaN", "--max-error NaN"),
        ("--budget-ms", "0", "--budget-ms 0: a time budget"),
        ("--budget-ms", "inf", "--budget-ms inf"),
        ("--budget-ms", "soon", "'soon' is not a number"),
        ("--scale", "0", "'0' is not a scale in (0, 4]"),
    ] {
        let (ok, text) = cli(&["choose", s, flag, value, "--out", o]);
        assert!(!ok && text.contains(says), "{flag} {value}: {text}");
    }
}

/// A scene file's name reaches the reports only through their escaping: its images' links
/// are file-safe stems, so a name made of HTML, a `javascript:` link or a table's `|` makes
/// no live HTML, link or broken row in `report.md` or `report.html`, also after `--merge`.
#[test]
fn hostile_scene_names_stay_text_in_the_reports() {
    let dir = temp_dir("hostile-names");
    let scene = dir.join("<img src=x onerror=alert(1)>|javascript:alert(2).toml");
    std::fs::write(&scene, HARD).unwrap();
    let out = dir.join("out");
    let (ok, text) = cli(&[
        "sweep",
        scene.to_str().unwrap(),
        "--techniques",
        "shadow-map",
        "--reps",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let merged = merge_shards(&dir, &[out.to_str().unwrap().to_string()]);
    for folder in [&out, &merged] {
        let md = std::fs::read_to_string(folder.join("report.md")).unwrap();
        let html = std::fs::read_to_string(folder.join("report.html")).unwrap();
        // Markdown escapes with backslashes: no `<` or `|` of the name is left bare.
        let bare = |c: char| md.match_indices(c).any(|(i, _)| !md[..i].ends_with('\\'));
        assert!(!bare('<'), "{md}");
        assert!(!html.contains("<img src=x"), "{html}");
        for page in [&md, &html] {
            assert!(
                !page.contains("](javascript:") && !page.contains("\"javascript:"),
                "{page}"
            );
        }
        // Every image the Markdown links exists, and each table row keeps its ten cells.
        for link in md.split("](").skip(1).map(|l| &l[..l.find(')').unwrap()]) {
            assert!(
                folder.join(link).is_file(),
                "{link} is not a file in {}",
                folder.display()
            );
        }
        for row in md.lines().filter(|l| l.starts_with("| shadow-map")) {
            assert_eq!(row.matches(" | ").count(), 8, "{row}");
        }
    }
}
