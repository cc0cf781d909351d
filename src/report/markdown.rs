//! The sweep's summary table (the README's technique table) and the report page in Markdown.

use crate::metrics;
use crate::run::RunResult;
use std::fmt::Write as _;

/// One row per technique and settings across all scenes: median time, mean RMSE, mean and
/// worst wrong % (with the scene), mean penumbra RMSE. The README's technique table.
pub fn summary_markdown(results: &[RunResult]) -> String {
    let mut labels: Vec<String> = Vec::new();
    for r in results {
        if !labels.contains(&r.label()) {
            labels.push(r.label());
        }
    }
    let mut s = String::from(
        "| technique [settings] | median ms | mean RMSE | mean wrong % | worst wrong % (scene) | mean penumbra RMSE |\n| --- | --- | --- | --- | --- | --- |\n",
    );
    for label in labels {
        let rs: Vec<&RunResult> = results.iter().filter(|r| r.label() == label).collect();
        let n = rs.len() as f64;
        let mean = |f: &dyn Fn(&RunResult) -> f64| rs.iter().map(|r| f(r)).sum::<f64>() / n;
        let worst = rs
            .iter()
            .max_by(|a, b| a.errors.wrong_pct.total_cmp(&b.errors.wrong_pct))
            .expect("at least one run");
        let _ = writeln!(
            s,
            "| {label} | {:.1} | {:.4} | {:.2} | {:.2} ({}) | {:.3} |",
            metrics::median(rs.iter().map(|r| r.ms).collect()),
            mean(&|r| r.errors.rmse),
            mean(&|r| r.errors.wrong_pct),
            worst.errors.wrong_pct,
            worst.scene,
            {
                // Over the scenes that have a penumbra (area lights) only.
                let soft: Vec<f64> = rs
                    .iter()
                    .filter(|r| r.errors.penumbra_pixels > 0)
                    .map(|r| r.errors.penumbra_rmse)
                    .collect();
                soft.iter().sum::<f64>() / soft.len().max(1) as f64
            },
        );
    }
    s
}

/// The report page in Markdown: per scene a chart and a table with thumbnails.
pub fn report_markdown(
    results: &[RunResult],
    scenes: &[(String, String)],
    thumbs: &dyn Fn(&RunResult) -> Option<String>,
    paths: &dyn Fn(&RunResult) -> Option<String>,
) -> String {
    let mut s = String::from("# penumbra sweep\n\nEvery technique on every scene against the ray-traced reference. Time is the median of the technique's visibility pass; errors are over pixels covered by geometry and facing the light. Errors of different kinds do not average, so the charts are per scene class.\n\n");
    for c in crate::scene::SceneClass::ALL {
        if results.iter().any(|r| r.class == c) {
            let _ = write!(s, "![{}](chart_{}.svg)\n\n", c.title(), c.key());
        }
    }
    for (name, desc) in scenes {
        let _ = write!(s, "## {name}\n\n{desc}\n\n![{name}](charts/{}.svg)\n\n| technique | ms | RMSE | MAE | wrong % | penumbra RMSE | transparent RMSE | flicker | image |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n", super::file_safe(name));
        for r in results.iter().filter(|r| &r.scene == name) {
            let e = &r.errors;
            let img = thumbs(r).map(|t| format!("![]({t})")).unwrap_or_default();
            let _ = writeln!(
                s,
                "| {} | {:.2} | {:.4} | {:.4} | {:.3} | {:.4} | {} | {:.4} | {img} |",
                r.label(),
                r.ms,
                e.rmse,
                e.mae,
                e.wrong_pct,
                e.penumbra_rmse,
                if r.transparent.pixels > 0 {
                    format!("{:.4}", r.transparent.rmse)
                } else {
                    "-".into()
                },
                r.flicker
            );
        }
        s.push('\n');
        // Time and work counters along the camera path, for techniques with counters to show.
        let charts: Vec<(String, String)> = results
            .iter()
            .filter(|r| &r.scene == name)
            .filter_map(|r| paths(r).map(|p| (r.label(), p)))
            .collect();
        if !charts.is_empty() {
            let _ = writeln!(
                s,
                "### {name}: along the camera path
"
            );
            for (label, p) in charts {
                let _ = writeln!(
                    s,
                    "![{label}]({p})
"
                );
            }
        }
    }
    s
}
