//! The sweep's CSV (written and read back, so that shards merge into the file one run would
//! have written) and a camera path's CSV. Quoting is the `csv` crate's; numbers are written
//! in their shortest exact form, so reading a row back gives the same bits.

use crate::error::quoted;
use crate::error::Reason;
use crate::metrics::Errors;
use crate::run::{PathFrame, RunResult};
use crate::scene::SceneClass;
use crate::shadow::Family;
use crate::Error;
use serde::{Deserialize, Serialize};

/// One row of `results.csv`.
#[derive(Serialize, Deserialize)]
struct Row {
    run: usize,
    scene: String,
    class: String,
    technique: String,
    family: String,
    settings: String,
    ms: f64,
    threads: usize,
    rmse: f64,
    mae: f64,
    wrong_pct: f64,
    penumbra_rmse: f64,
    pixels: u64,
    penumbra_pixels: u64,
    transparent_rmse: f64,
    transparent_mae: f64,
    transparent_wrong_pct: f64,
    transparent_penumbra_rmse: f64,
    transparent_pixels: u64,
    transparent_penumbra_pixels: u64,
    flicker: f64,
    discontinuity: f64,
    banding: f64,
    texel_px: f64,
    texel_px_p99: f64,
    path_chart: bool,
    passes_ms: String,
    counters: String,
}

/// The columns of `results.csv`, in order: [`Row`]'s fields (a test checks that they agree).
/// Written even when a shard has no rows, so that every results.csv starts with them.
const COLUMNS: [&str; 28] = [
    "run",
    "scene",
    "class",
    "technique",
    "family",
    "settings",
    "ms",
    "threads",
    "rmse",
    "mae",
    "wrong_pct",
    "penumbra_rmse",
    "pixels",
    "penumbra_pixels",
    "transparent_rmse",
    "transparent_mae",
    "transparent_wrong_pct",
    "transparent_penumbra_rmse",
    "transparent_pixels",
    "transparent_penumbra_pixels",
    "flicker",
    "discontinuity",
    "banding",
    "texel_px",
    "texel_px_p99",
    "path_chart",
    "passes_ms",
    "counters",
];

fn pairs(v: &[(String, f64)]) -> String {
    v.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(";")
}

fn parse_pairs(s: &str, what: &str) -> Result<Vec<(String, f64)>, Reason> {
    s.split(';')
        .filter(|p| !p.is_empty())
        .map(|p| {
            let (k, v) = p
                .rsplit_once('=')
                .ok_or_else(|| Reason(format!("column {what}: '{p}' is not name=value")))?;
            let v = v
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| Reason(format!("column {what}: '{v}' is not a finite number >= 0")))?;
            Ok((k.to_string(), v))
        })
        .collect()
}

/// A text cell as written to the CSV: one that a spreadsheet would take for a formula
/// (starting with `=`, `+`, `-`, `@`, a tab or a carriage return, OWASP's list) gets a
/// leading `'`, and so does one that already starts with `'`, so that [`uncell`] gives back
/// exactly the text.
fn cell(text: &str) -> String {
    match text.chars().next() {
        Some('=' | '+' | '-' | '@' | '\t' | '\r' | '\'') => format!("'{text}"),
        _ => text.to_string(),
    }
}

/// The text of a cell [`cell`] wrote.
fn uncell(text: String) -> String {
    match text.strip_prefix('\'') {
        Some(rest) => rest.to_string(),
        None => text,
    }
}

/// The sweep's CSV (one row per technique setting and scene, in run order).
pub fn csv(results: &[RunResult]) -> String {
    let mut w = ::csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
    w.write_record(COLUMNS).expect("writing CSV to memory");
    for r in results {
        let (e, t) = (&r.errors, &r.transparent);
        w.serialize(Row {
            run: r.index,
            scene: cell(&r.scene),
            class: r.class.key().into(),
            technique: cell(&r.technique),
            family: r.family.key().into(),
            settings: cell(&r.settings),
            ms: r.ms,
            threads: r.threads,
            rmse: e.rmse,
            mae: e.mae,
            wrong_pct: e.wrong_pct,
            penumbra_rmse: e.penumbra_rmse,
            pixels: e.pixels,
            penumbra_pixels: e.penumbra_pixels,
            transparent_rmse: t.rmse,
            transparent_mae: t.mae,
            transparent_wrong_pct: t.wrong_pct,
            transparent_penumbra_rmse: t.penumbra_rmse,
            transparent_pixels: t.pixels,
            transparent_penumbra_pixels: t.penumbra_pixels,
            flicker: r.flicker,
            discontinuity: r.discontinuity,
            banding: r.banding,
            texel_px: r.texel_px,
            texel_px_p99: r.texel_px_p99,
            path_chart: r.counted_path,
            passes_ms: pairs(&r.passes),
            counters: pairs(&r.counters),
        })
        .expect("writing CSV to memory");
    }
    String::from_utf8(w.into_inner().expect("writing CSV to memory")).expect("CSV of UTF-8 fields")
}

/// Reads a CSV that [`csv()`] wrote back into results; errors name `source` and the line.
/// The header must be [`csv()`]'s exactly (no column more or less), every row as long as it,
/// every time, error and count a finite number >= 0.
pub fn read_csv(text: &str, source: &str) -> Result<Vec<RunResult>, Error> {
    if text.trim().is_empty() {
        return Err(Error::input(format!(
            "{source}: empty (a results.csv starts with its header line: run,scene,...)"
        )));
    }
    let mut r = ::csv::Reader::from_reader(text.as_bytes());
    let head = r
        .headers()
        .map_err(|e| Error::input(format!("{source}:1: not the header of penumbra's results.csv: {e}")))?;
    if head.iter().ne(COLUMNS) {
        let extra: Vec<&str> = head.iter().filter(|h| !COLUMNS.contains(h)).collect();
        let missing: Vec<&str> = COLUMNS.into_iter().filter(|c| !head.iter().any(|h| h == *c)).collect();
        return Err(Error::input(format!(
            "{source}:1: not the header of penumbra's results.csv (columns not in it: {extra:?}; missing: {missing:?}; or out of order)"
        )));
    }
    let mut out = Vec::new();
    for row in r.deserialize::<Row>() {
        let row = row.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            Error::input(format!("{source}:{line}: not a row of penumbra's results.csv: {e}"))
        })?;
        let at = |what: String| Error::input(format!("{source}: run {}: {what}", row.run));
        let numbers = [
            ("ms", row.ms),
            ("rmse", row.rmse),
            ("mae", row.mae),
            ("wrong_pct", row.wrong_pct),
            ("penumbra_rmse", row.penumbra_rmse),
            ("transparent_rmse", row.transparent_rmse),
            ("transparent_mae", row.transparent_mae),
            ("transparent_wrong_pct", row.transparent_wrong_pct),
            ("transparent_penumbra_rmse", row.transparent_penumbra_rmse),
            ("flicker", row.flicker),
            ("discontinuity", row.discontinuity),
            ("banding", row.banding),
        ];
        if let Some((name, v)) = numbers.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
            return Err(at(format!("column {name}: {v} is not a finite number >= 0")));
        }
        // The texel footprint: NaN for techniques without maps.
        for (name, v) in [("texel_px", row.texel_px), ("texel_px_p99", row.texel_px_p99)] {
            if !(v.is_nan() || (v.is_finite() && v >= 0.0)) {
                return Err(at(format!("column {name}: {v} is not NaN or a finite number >= 0")));
            }
        }
        out.push(RunResult {
            index: row.run,
            class: SceneClass::from_key(&row.class)
                .ok_or_else(|| at(format!("unknown scene class {}", quoted(&row.class))))?,
            family: Family::from_key(&row.family)
                .ok_or_else(|| at(format!("unknown family {}", quoted(&row.family))))?,
            errors: Errors {
                rmse: row.rmse,
                mae: row.mae,
                wrong_pct: row.wrong_pct,
                penumbra_rmse: row.penumbra_rmse,
                pixels: row.pixels,
                penumbra_pixels: row.penumbra_pixels,
            },
            transparent: Errors {
                rmse: row.transparent_rmse,
                mae: row.transparent_mae,
                wrong_pct: row.transparent_wrong_pct,
                penumbra_rmse: row.transparent_penumbra_rmse,
                pixels: row.transparent_pixels,
                penumbra_pixels: row.transparent_penumbra_pixels,
            },
            passes: parse_pairs(&row.passes_ms, "passes_ms").map_err(|r| at(r.0))?,
            counters: parse_pairs(&row.counters, "counters").map_err(|r| at(r.0))?,
            scene: uncell(row.scene),
            technique: uncell(row.technique),
            settings: uncell(row.settings),
            ms: row.ms,
            threads: row.threads,
            flicker: row.flicker,
            discontinuity: row.discontinuity,
            banding: row.banding,
            texel_px: row.texel_px,
            texel_px_p99: row.texel_px_p99,
            counted_path: row.path_chart,
        });
    }
    Ok(out)
}

/// CSV of a camera path: frame, ms, then one column per counter.
pub fn path_csv(frames: &[PathFrame]) -> String {
    let mut w = ::csv::Writer::from_writer(Vec::new());
    let mut head = vec!["frame".to_string(), "ms".to_string()];
    head.extend(
        frames
            .first()
            .map(|f| f.counters.as_slice())
            .unwrap_or_default()
            .iter()
            .map(|(n, _)| n.replace(' ', "_")),
    );
    w.write_record(&head).expect("writing CSV to memory");
    for (i, f) in frames.iter().enumerate() {
        let mut rec = vec![i.to_string(), format!("{:.4}", f.ms)];
        rec.extend(f.counters.iter().map(|(_, v)| v.to_string()));
        w.write_record(&rec).expect("writing CSV to memory");
    }
    String::from_utf8(w.into_inner().expect("writing CSV to memory")).expect("CSV of UTF-8 fields")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(scene: &str, settings: &str) -> RunResult {
        RunResult {
            index: 3,
            scene: scene.into(),
            class: SceneClass::Area,
            technique: "pcss".into(),
            family: Family::Map,
            settings: settings.into(),
            errors: Errors {
                rmse: 0.1 + 0.2,
                mae: 1.0 / 3.0,
                wrong_pct: 2.5,
                penumbra_rmse: 0.07,
                pixels: 1000,
                penumbra_pixels: 30,
            },
            transparent: Errors::default(),
            ms: 12.345678901,
            threads: 2,
            flicker: 0.0,
            discontinuity: 1e-7,
            banding: 0.5,
            texel_px: 2.5,
            texel_px_p99: f64::NAN,
            counted_path: true,
            passes: vec![("light pass".into(), 1.25)],
            counters: vec![("taps".into(), 123456.0), ("a=b".into(), 1.0)],
        }
    }

    /// The written header is the one serde would write for [`Row`], and a CSV without rows
    /// still has it.
    #[test]
    fn the_header_is_the_rows_fields() {
        let mut w = ::csv::Writer::from_writer(Vec::new());
        let one = csv(&[result("s", "")]);
        let row = read_csv(&one, "t.csv").unwrap();
        assert_eq!(row.len(), 1);
        let r = ::csv::Reader::from_reader(one.as_bytes())
            .deserialize::<Row>()
            .next()
            .unwrap()
            .unwrap();
        w.serialize(r).unwrap();
        let serde_text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert_eq!(serde_text.lines().next(), one.lines().next());
        assert_eq!(csv(&[]).trim_end(), COLUMNS.join(","));
        assert!(read_csv(&csv(&[]), "t.csv").unwrap().is_empty());
    }

    /// Rows that no sweep writes are errors naming the file and the line or run: an extra
    /// column, a NaN, negative or infinite time or error, an empty file.
    #[test]
    fn rows_no_sweep_writes_are_refused() {
        let good = csv(&[result("s", "")]);
        let (head, row) = good.split_once('\n').unwrap();
        for (text, want) in [
            (String::new(), "t.csv: empty"),
            (
                format!("{head},extra\n{}", row.trim_end().to_string() + ",1\n"),
                "columns not in it: [\"extra\"]",
            ),
            (
                format!("{head}\n{}", row.trim_end().to_string() + ",1\n"),
                "t.csv:2: not a row",
            ),
            (good.replacen(",12.345678901,", ",NaN,", 1), "run 3: column ms: NaN"),
            (good.replacen(",12.345678901,", ",-1,", 1), "run 3: column ms: -1"),
            (good.replacen(",12.345678901,", ",inf,", 1), "run 3: column ms: inf"),
            (good.replacen(",0.07,", ",-0.07,", 1), "column penumbra_rmse: -0.07"),
            (good.replacen("taps=123456", "taps=NaN", 1), "column counters: 'NaN'"),
        ] {
            let e = read_csv(&text, "t.csv")
                .err()
                .unwrap_or_else(|| panic!("read: {text}"))
                .to_string();
            assert!(e.contains(want), "{want}: {e}");
        }
    }

    #[test]
    fn rows_read_back_bit_for_bit_with_hostile_names() {
        let rs = vec![result("a,b", "disk=rotated;taps=64"), result("q\"uote\nline", "")];
        let text = csv(&rs);
        let back = read_csv(&text, "t.csv").unwrap();
        assert_eq!(csv(&back), text);
        assert_eq!(back[1].scene, "q\"uote\nline");
        assert_eq!(back[0].errors.mae.to_bits(), (1.0f64 / 3.0).to_bits());
        assert_eq!(back[0].counters[1], ("a=b".to_string(), 1.0));
        // Every row has the header's column count however the names are quoted.
        let mut r = ::csv::Reader::from_reader(text.as_bytes());
        let n = r.headers().unwrap().len();
        assert!(r.records().all(|x| x.unwrap().len() == n));
    }

    /// Names a spreadsheet would run as formulas are written with a leading `'` (OWASP's
    /// CSV injection advice) and read back exactly, and so is a name that starts with `'`.
    #[test]
    fn formula_names_are_quoted_in_cells_and_read_back_exactly() {
        let names = [
            "=HYPERLINK(\"http://x\")",
            "+1",
            "-2",
            "@SUM(A1)",
            "\tx",
            "'=quoted",
            "plain",
        ];
        let rs: Vec<RunResult> = names.iter().map(|n| result(n, n)).collect();
        let text = csv(&rs);
        let mut r = ::csv::Reader::from_reader(text.as_bytes());
        for (rec, n) in r.records().zip(names) {
            let rec = rec.unwrap();
            for field in [1, 5] {
                let f = &rec[field];
                assert!(
                    !f.starts_with(['=', '+', '-', '@', '\t', '\r']),
                    "{n}: cell {f:?} would be a formula"
                );
            }
        }
        let back = read_csv(&text, "t.csv").unwrap();
        for (b, n) in back.iter().zip(names) {
            assert_eq!((b.scene.as_str(), b.settings.as_str()), (n, n));
        }
    }

    #[test]
    fn bad_rows_name_the_file_and_line() {
        let e = read_csv("run,scene\nx,y\n", "shard0/results.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("shard0/results.csv:"), "{e}");
    }
}
