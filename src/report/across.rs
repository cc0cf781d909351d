//! Settings measured across many scenes (`penumbra defaults`): per technique setting, the mean,
//! median, worst decile and worst of its class's error ([`RunResult::class_error`]) and its
//! median time, as a Markdown table per scene class.

use super::markdown::md_cell;
use crate::metrics;
use crate::run::RunResult;
use crate::scene::SceneClass;
use std::fmt::Write as _;

/// One setting's numbers across the scenes it ran on.
#[derive(Clone, Debug, PartialEq)]
pub struct Across {
    /// `technique [settings]`.
    pub label: String,
    /// Whether the setting is the technique's defaults.
    pub default: bool,
    /// Scenes it ran on.
    pub scenes: usize,
    /// Mean error.
    pub mean: f64,
    /// Median error.
    pub median: f64,
    /// The worst decile's lower edge: 90 % of the scenes had at most this error.
    pub p90: f64,
    /// The worst error, and its scene.
    pub worst: (f64, String),
    /// Median milliseconds.
    pub ms: f64,
}

/// The `q`-quantile (0..=1) of `v` by the nearest rank.
fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[k - 1]
}

/// The settings of `results` on scenes of `class`, in first-seen order.
pub fn across(results: &[RunResult], class: SceneClass) -> Vec<Across> {
    let mut labels: Vec<String> = Vec::new();
    for r in results.iter().filter(|r| r.class == class) {
        let l = r.label();
        if !labels.contains(&l) {
            labels.push(l);
        }
    }
    labels
        .into_iter()
        .map(|label| {
            let runs: Vec<&RunResult> = results
                .iter()
                .filter(|r| r.class == class && r.label() == label)
                .collect();
            let mut errors: Vec<f64> = runs
                .iter()
                .map(|r| {
                    if r.class_error().is_finite() {
                        r.class_error()
                    } else {
                        f64::INFINITY
                    }
                })
                .collect();
            let worst = runs
                .iter()
                .zip(&errors)
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map(|(r, &e)| (e, r.scene.clone()))
                .unwrap_or((f64::NAN, String::new()));
            Across {
                default: runs[0].settings.is_empty(),
                scenes: runs.len(),
                mean: errors.iter().sum::<f64>() / errors.len() as f64,
                median: quantile(&mut errors, 0.5),
                p90: quantile(&mut errors, 0.9),
                worst,
                ms: metrics::median(runs.iter().map(|r| r.ms).collect()),
                label,
            }
        })
        .collect()
}

/// The Markdown table of [`across`] for `class`: a row per setting, the defaults in bold.
pub fn across_markdown(results: &[RunResult], class: SceneClass) -> String {
    let rows = across(results, class);
    let mut s = format!(
        "| setting | scenes | mean {m} | median | 90th percentile | worst (scene) | median ms |\n|---|---:|---:|---:|---:|---:|---:|\n",
        m = class.metric()
    );
    for a in rows {
        let label = if a.default {
            format!("**{}**", md_cell(&a.label))
        } else {
            md_cell(&a.label)
        };
        let _ = writeln!(
            s,
            "| {label} | {} | {:.4} | {:.4} | {:.4} | {:.4} ({}) | {:.2} |",
            a.scenes,
            a.mean,
            a.median,
            a.p90,
            a.worst.0,
            md_cell(&a.worst.1),
            a.ms
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_by_nearest_rank() {
        let mut v: Vec<f64> = (1..=10).map(f64::from).collect();
        assert_eq!(quantile(&mut v, 0.5), 5.0);
        assert_eq!(quantile(&mut v, 0.9), 9.0);
        assert_eq!(quantile(&mut v, 1.0), 10.0);
        assert!(quantile(&mut [], 0.5).is_nan());
    }

    #[test]
    fn a_setting_across_scenes() {
        let run = |scene: &str, settings: &str, e: f64, ms: f64| {
            let mut r = RunResult {
                scene: scene.into(),
                class: SceneClass::Area,
                technique: "pcss".into(),
                settings: settings.into(),
                ms,
                ..RunResult::default()
            };
            r.errors.penumbra_rmse = e;
            r
        };
        let rs = vec![
            run("a", "", 0.1, 1.0),
            run("b", "", 0.3, 3.0),
            run("a", "size=512", 0.2, 0.5),
            run("c", "", f64::NAN, 2.0),
        ];
        let a = across(&rs, SceneClass::Area);
        assert_eq!(a.len(), 2);
        assert_eq!((a[0].scenes, a[0].default, a[0].ms), (3, true, 2.0));
        assert_eq!(a[0].worst, (f64::INFINITY, "c".to_string()));
        assert_eq!(a[1].label, "pcss [size=512]");
        assert!(across(&rs, SceneClass::Hard).is_empty());
        assert!(across_markdown(&rs, SceneClass::Area).contains("| **pcss** | 3 |"));
    }
}
