//! What penumbra writes for users and other tools: the sweep's files (sharded and merged
//! equal to one run), the report page, exports, float images and glTF scenes.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs the CLI; returns (success, stdout + stderr).
fn cli(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!text.contains("panicked"), "the CLI panicked on {args:?}:\n{text}");
    (out.status.success(), text)
}

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
    let whole = dir.join("whole");
    let (ok, text) = cli(&[
        "sweep",
        a,
        b,
        "--techniques",
        techniques,
        "--reps",
        "1",
        "--threads",
        "2",
        "--out",
        whole.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let mut parts = Vec::new();
    for i in 0..3 {
        let out = dir.join(format!("part{i}"));
        let (ok, text) = cli(&[
            "sweep",
            a,
            b,
            "--techniques",
            techniques,
            "--reps",
            "1",
            "--threads",
            "1",
            "--shard",
            &format!("{i}/3"),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
        parts.push(out.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged");
    let mut args = vec!["sweep", "--out", merged.to_str().unwrap(), "--merge"];
    args.extend(parts.iter().map(String::as_str));
    let (ok, text) = cli(&args);
    assert!(ok, "{text}");
    let rows = rows_without_timings(&whole.join("results.csv"));
    assert!(rows.len() > 8, "{rows:?}");
    let merged_rows = rows_without_timings(&merged.join("results.csv"));
    assert_eq!(rows.len(), merged_rows.len());
    for (a, b) in rows.iter().zip(&merged_rows) {
        assert_eq!(a, b);
    }
    assert_eq!(files(&whole), files(&merged));
    // Missing and doubled shards are errors that say so.
    let (ok, text) = cli(&[
        "sweep",
        "--out",
        merged.to_str().unwrap(),
        "--merge",
        &parts[0],
        &parts[2],
    ]);
    assert!(!ok && text.contains("in none of the folders"), "{text}");
    let (ok, text) = cli(&[
        "sweep",
        "--out",
        merged.to_str().unwrap(),
        "--merge",
        &parts[0],
        &parts[0],
        &parts[1],
        &parts[2],
    ]);
    assert!(!ok && text.contains("in two shards"), "{text}");
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
