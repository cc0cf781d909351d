//! The sweep's summary table (the README's technique table) and the report page in Markdown.

use crate::metrics;
use crate::run::RunResult;
use crate::scene::SceneClass;
use std::fmt::Write as _;

/// Text from a scene file as Markdown that shows it literally: every character Markdown or
/// HTML would act on is escaped (no images, links, raw HTML or table cells from a scene's
/// comment), and line breaks become spaces.
pub fn md(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\\' | '`' | '*' | '_' | '{' | '}' | '[' | ']' | '(' | ')' | '#' | '+' | '-' | '.' | '!' | '|' | '<'
            | '>' | '&' | '~' => {
                out.push('\\');
                out.push(c);
            }
            '\n' | '\r' => out.push(' '),
            c if c.is_control() => {}
            c => out.push(c),
        }
    }
    out
}

/// One row per technique and settings across all scenes: median time, and per scene class its
/// own error averaged over the class's scenes (hard-light: wrong %, area-light: penumbra RMSE,
/// transparent: transmittance RMSE; errors of different kinds are never averaged together),
/// and the worst wrong % with its scene. The README's technique table.
pub fn summary_markdown(results: &[RunResult]) -> String {
    let mut labels: Vec<String> = Vec::new();
    for r in results {
        if !labels.contains(&r.label()) {
            labels.push(r.label());
        }
    }
    let count = |c: SceneClass| {
        let mut names: Vec<&str> = results
            .iter()
            .filter(|r| r.class == c)
            .map(|r| r.scene.as_str())
            .collect();
        names.sort();
        names.dedup();
        names.len()
    };
    let mut s = format!(
        "| technique [settings] | median ms | hard-light: wrong % ({} scenes) | area-light: penumbra RMSE ({}) | transparent: transmittance RMSE ({}) | worst wrong % (scene) |\n| --- | --- | --- | --- | --- | --- |\n",
        count(SceneClass::Hard),
        count(SceneClass::Area),
        count(SceneClass::Transparent)
    );
    for label in labels {
        let rs: Vec<&RunResult> = results.iter().filter(|r| r.label() == label).collect();
        let class_mean = |c: SceneClass, digits: usize| -> String {
            let v: Vec<f64> = rs.iter().filter(|r| r.class == c).map(|r| r.class_error()).collect();
            if v.is_empty() {
                "-".into()
            } else {
                format!("{:.digits$}", v.iter().sum::<f64>() / v.len() as f64)
            }
        };
        let worst = rs
            .iter()
            .max_by(|a, b| a.errors.wrong_pct.total_cmp(&b.errors.wrong_pct))
            .expect("at least one run");
        let _ = writeln!(
            s,
            "| {label} | {:.1} | {} | {} | {} | {:.2} ({}) |",
            metrics::median(rs.iter().map(|r| r.ms).collect()),
            class_mean(SceneClass::Hard, 3),
            class_mean(SceneClass::Area, 3),
            class_mean(SceneClass::Transparent, 3),
            worst.errors.wrong_pct,
            worst.scene,
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
        let (name_md, desc) = (md(name), md(desc));
        let _ = write!(s, "## {name_md}\n\n{desc}\n\n![{name_md}](charts/{}.svg)\n\n| technique | ms | RMSE | MAE | wrong % | penumbra RMSE | transparent RMSE | flicker | image |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n", super::file_safe(name));
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
                "### {name_md}: along the camera path
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_text_shows_literally_in_markdown() {
        let m = md("![x](javascript:alert(1)) <img src=x> | cell\nline");
        assert_eq!(
            m,
            "\\!\\[x\\]\\(javascript:alert\\(1\\)\\) \\<img src=x\\> \\| cell line"
        );
        let page = report_markdown(
            &[],
            &[("s".into(), "![x](javascript:alert(1))".into())],
            &|_| None,
            &|_| None,
        );
        assert!(!page.contains("![x]"), "{page}");
    }
}
