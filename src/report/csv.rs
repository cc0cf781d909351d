//! The sweep's CSV and a camera path's CSV.

use crate::run::{PathFrame, RunResult};
use std::fmt::Write as _;

/// The sweep's CSV (one row per technique setting and scene).
pub fn csv(results: &[RunResult]) -> String {
    let mut s = String::from(
        "scene,technique,settings,ms,threads,rmse,mae,wrong_pct,penumbra_rmse,transparent_rmse,flicker,discontinuity,banding,pixels,penumbra_pixels,transparent_pixels,passes_ms,counters\n",
    );
    for r in results {
        let e = &r.errors;
        let _ = writeln!(
            s,
            "{},{},\"{}\",{:.4},{},{:.6},{:.6},{:.4},{:.6},{:.6},{:.6},{:.6},{:.6},{},{},{},\"{}\",\"{}\"",
            r.scene,
            r.technique,
            r.settings,
            r.ms,
            r.threads,
            e.rmse,
            e.mae,
            e.wrong_pct,
            e.penumbra_rmse,
            r.transparent.rmse,
            r.flicker,
            r.discontinuity,
            r.banding,
            e.pixels,
            e.penumbra_pixels,
            r.transparent.pixels,
            r.passes
                .iter()
                .map(|(k, v)| format!("{k}={v:.3}"))
                .collect::<Vec<_>>()
                .join(";"),
            r.counters
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(";")
        );
    }
    s
}

/// CSV of a camera path: frame, ms, then one column per counter.
pub fn path_csv(frames: &[PathFrame]) -> String {
    let mut s = String::from("frame,ms");
    for (name, _) in frames.first().map(|f| f.counters.as_slice()).unwrap_or_default() {
        let _ = write!(s, ",{}", name.replace(' ', "_"));
    }
    s.push('\n');
    for (i, f) in frames.iter().enumerate() {
        let _ = write!(s, "{i},{:.4}", f.ms);
        for (_, v) in &f.counters {
            let _ = write!(s, ",{v}");
        }
        s.push('\n');
    }
    s
}
