//! The sweep's summary table (the README's technique table) and the report page in Markdown.

use crate::metrics;
use crate::run::RunResult;
use crate::scene::SceneClass;
use std::fmt::Write as _;

/// Text from a scene file as Markdown that shows it literally: every character Markdown or
/// HTML would act on is escaped (no images, links, raw HTML or table cells from a scene's
/// comment), and line breaks become spaces.
pub fn md(text: &str) -> String {
    escape(text, "\\`*_{}[]()#+-.!|<>&~")
}

/// `text` with every character of `special` escaped by a backslash, line breaks made spaces
/// and other control characters dropped.
fn escape(text: &str, special: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\n' | '\r' => out.push(' '),
            c if c.is_control() => {}
            c if special.contains(c) => {
                out.push('\\');
                out.push(c);
            }
            c => out.push(c),
        }
    }
    out
}

/// A name (a scene's, a technique label) in a Markdown table cell: the characters that make
/// HTML, links, images, code or new cells (`\ | < > & [ ] ( ) ! \``) escaped and line breaks
/// made spaces, the rest left as it is so that `eye_in_volume` stays readable as text.
pub fn md_cell(text: &str) -> String {
    escape(text, "\\|<>&[]()!`")
}

/// Which rows a summary table has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rows {
    /// One per technique: its default settings where the sweep ran them (a set whose every
    /// setting is the option's default counts), else its first set (the README's table).
    PerTechnique,
    /// One per technique and settings (docs/techniques.md's table).
    PerSetting,
}

/// One row per technique and settings across all scenes (or one per technique, [`Rows`]):
/// median time, and per scene class its own error averaged over the class's scenes
/// (hard-light: wrong %, area-light: penumbra RMSE, transparent: transmittance RMSE; errors
/// of different kinds are never averaged together), and the worst wrong % with its scene.
pub fn summary_markdown(results: &[RunResult], rows: Rows) -> String {
    let mut labels: Vec<String> = Vec::new();
    for r in results {
        if !labels.contains(&r.label()) {
            labels.push(r.label());
        }
    }
    if rows == Rows::PerTechnique {
        let registry = crate::shadow::registry::registry();
        // A run of the technique's defaults: every setting it names has its default value.
        let is_default = |r: &RunResult| {
            let Some(info) = registry.iter().find(|t| t.name == r.technique) else {
                return r.settings.is_empty();
            };
            r.settings.split(';').filter(|kv| !kv.is_empty()).all(|kv| {
                kv.split_once('=')
                    .is_some_and(|(k, v)| info.options.iter().any(|o| o.key == k && o.default == v))
            })
        };
        let mut kept: Vec<(String, String, bool)> = Vec::new(); // technique, label, default
        for l in &labels {
            let r = results.iter().find(|r| &r.label() == l).expect("a run of every label");
            let d = is_default(r);
            match kept.iter_mut().find(|k| k.0 == r.technique) {
                None => kept.push((r.technique.clone(), l.clone(), d)),
                Some(k) if d && !k.2 => *k = (r.technique.clone(), l.clone(), d),
                Some(_) => {}
            }
        }
        labels = kept.into_iter().map(|k| k.1).collect();
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
    let scenes_of = |rs: &[&RunResult]| {
        let mut v: Vec<&str> = rs.iter().map(|r| r.scene.as_str()).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    let all_scenes = scenes_of(&results.iter().collect::<Vec<_>>());
    for label in labels {
        let rs: Vec<&RunResult> = results.iter().filter(|r| r.label() == label).collect();
        // A technique that works on some scenes only (terrain occlusion height) says so.
        let ran = scenes_of(&rs);
        let label = if ran < all_scenes {
            format!("{label} (on {ran} of {all_scenes} scenes)")
        } else {
            label
        };
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
            md_cell(&worst.scene),
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
                md_cell(&r.label()),
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
                    "![{}]({p})
",
                    md_cell(&label)
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

    /// Scene names and labels in table cells: no HTML, link, image, code or extra cell from a
    /// hostile name, and a plain name stays as it is.
    #[test]
    fn names_in_table_cells_show_literally() {
        assert_eq!(md_cell("eye_in_volume"), "eye_in_volume");
        let m = md_cell("<img src=x onerror=alert(1)>|[click](javascript:alert(1))`x`\nnext");
        assert_eq!(
            m,
            "\\<img src=x onerror=alert\\(1\\)\\>\\|\\[click\\]\\(javascript:alert\\(1\\)\\)\\`x\\` next"
        );
        assert!(!m.contains('\n') && m.matches('|').count() == m.matches("\\|").count());
    }
}
