//! The sweep's CSV (written and read back, so that shards merge into the file one run would
//! have written) and a camera path's CSV. Quoting is the `csv` crate's; numbers are written
//! in their shortest exact form, so reading a row back gives the same bits.

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
    path_chart: bool,
    passes_ms: String,
    counters: String,
}

fn pairs(v: &[(String, f64)]) -> String {
    v.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(";")
}

fn parse_pairs(s: &str, what: &str) -> Result<Vec<(String, f64)>, String> {
    s.split(';')
        .filter(|p| !p.is_empty())
        .map(|p| {
            let (k, v) = p
                .rsplit_once('=')
                .ok_or_else(|| format!("column {what}: '{p}' is not name=value"))?;
            let v = v
                .parse::<f64>()
                .map_err(|_| format!("column {what}: '{v}' is not a number"))?;
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
    let mut w = ::csv::Writer::from_writer(Vec::new());
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
            path_chart: r.counted_path,
            passes_ms: pairs(&r.passes),
            counters: pairs(&r.counters),
        })
        .expect("writing CSV to memory");
    }
    String::from_utf8(w.into_inner().expect("writing CSV to memory")).expect("CSV of UTF-8 fields")
}

/// Reads a CSV that [`csv()`] wrote back into results; errors name `source` and the line.
pub fn read_csv(text: &str, source: &str) -> Result<Vec<RunResult>, Error> {
    let mut r = ::csv::Reader::from_reader(text.as_bytes());
    let mut out = Vec::new();
    for row in r.deserialize::<Row>() {
        let row = row.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            Error::input(format!("{source}:{line}: not a row of penumbra's results.csv: {e}"))
        })?;
        let at = |what: String| Error::input(format!("{source}: run {}: {what}", row.run));
        out.push(RunResult {
            index: row.run,
            class: SceneClass::from_key(&row.class)
                .ok_or_else(|| at(format!("unknown scene class '{}'", row.class)))?,
            family: Family::from_key(&row.family).ok_or_else(|| at(format!("unknown family '{}'", row.family)))?,
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
            passes: parse_pairs(&row.passes_ms, "passes_ms").map_err(at)?,
            counters: parse_pairs(&row.counters, "counters").map_err(at)?,
            scene: uncell(row.scene),
            technique: uncell(row.technique),
            settings: uncell(row.settings),
            ms: row.ms,
            threads: row.threads,
            flicker: row.flicker,
            discontinuity: row.discontinuity,
            banding: row.banding,
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
            counted_path: true,
            passes: vec![("light pass".into(), 1.25)],
            counters: vec![("taps".into(), 123456.0), ("a=b".into(), 1.0)],
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
