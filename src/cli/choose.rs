//! `penumbra choose SCENE`: which technique should this scene use? What the scene has, the
//! techniques that model it run against the reference ([`penumbra::choose`]), the Pareto
//! front, the pick and its next two alternatives; a chart like the sweep's.

use super::scene::{cache, grouped, load, pipeline, reference_rays};
use super::sweep::Progress;
use crate::error::CliError;
use penumbra::choose::{analyse, choose, fmt_error, Goal, NoPick};
use penumbra::error::for_terminal;
use penumbra::report::chart::class_chart_svg;
use penumbra::report::files::{create_folder, write_plain};
use penumbra::run::{self, RunResult};
use penumbra::Error;
use std::path::PathBuf;

/// Options of `penumbra choose`.
pub struct ChooseOpts {
    /// The scene file.
    pub scene: PathBuf,
    /// The goal (`None`: [`Goal::default_for`] the scene's class).
    pub goal: Option<Goal>,
    /// The camera's resolution times this.
    pub scale: f64,
    /// Also the techniques' extended option sets.
    pub all: bool,
    /// Timed repetitions after one warm-up.
    pub reps: usize,
    /// Worker threads.
    pub threads: usize,
    /// Print one JSON object instead of text.
    pub json: bool,
    /// Output folder (the chart, the reference cache).
    pub out: PathBuf,
}

/// `--scale`: a factor in (0, 4].
pub fn parse_scale(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 4.0 => Ok(v),
        _ => Err(format!(
            "'{s}' is not a scale in (0, 4] (0.5: half the scene's resolution)"
        )),
    }
}

/// `--max-error` and `--budget-ms`: any number, checked with the goal ([`Goal::check`]).
pub fn parse_number(s: &str) -> Result<f64, String> {
    s.trim().parse::<f64>().map_err(|_| format!("'{s}' is not a number"))
}

/// `penumbra choose`.
pub fn choose_cmd(o: ChooseOpts) -> Result<(), CliError> {
    if let Some(g) = o.goal {
        // The goal's option is this command's flag of the same name.
        g.check().map_err(|e| match e {
            Error::Option {
                key, value, message, ..
            } => CliError(format!("--{key} {value}: {message}")),
            e => CliError::from(e),
        })?;
    }
    let (mut s, text) = load(&o.scene)?;
    let scaled = |v: u32| ((v as f64 * o.scale).round() as u32).clamp(1, penumbra::pipeline::MAX_DIMENSION);
    s.camera.width = scaled(s.camera.width);
    s.camera.height = scaled(s.camera.height);
    let goal = o.goal.unwrap_or(Goal::default_for(s.class()));
    let p = pipeline(o.threads)?;
    let first = penumbra::frame::frame(&p, &s, 0, 0)?;
    let a = analyse(&s, Some(&first), o.all);
    drop(first);
    let say = |line: String| {
        if !o.json {
            println!("{}", for_terminal(&line));
        }
    };
    say(format!(
        "scene {} at {}x{} ({}; judged by {})",
        s.name,
        s.camera.width,
        s.camera.height,
        s.class().key(),
        s.class().metric()
    ));
    for f in &a.facts {
        say(format!("  {f}"));
    }
    for (t, why) in &a.skipped {
        say(format!("  skipped {t}: {why}"));
    }
    say(format!(
        "choose: {} runs of {} techniques on {} ({} triangles, {} frame{} at {}x{}); the reference traces up to {} rays a frame first",
        a.runs.len(),
        a.runs.iter().map(|c| c.technique).collect::<std::collections::BTreeSet<_>>().len(),
        s.name,
        grouped(s.triangles() as u64),
        s.frame_count(),
        if s.frame_count() == 1 { "" } else { "s" },
        s.camera.width,
        s.camera.height,
        grouped(reference_rays(&s, s.camera.width, s.camera.height)),
    ));
    create_folder(&o.out)?;
    let dir_cache = cache(&o.out);
    let bar = Progress::new("choose", a.runs.len() + 1);
    bar.set_message(format!("{} / reference", s.name));
    let prepared = run::Prepared::new(&p, &s, &text, Some(&dir_cache))?;
    bar.inc();
    let mut results: Vec<RunResult> = Vec::new();
    let mut failed: Vec<(String, String)> = Vec::new();
    for c in &a.runs {
        let label = run::label(c.technique, &run::settings_text(&c.sets));
        bar.set_message(format!("{} / {label}", s.name));
        match run::render_prepared(&p, &prepared, c.technique, &c.sets, o.reps) {
            Ok(r) => results.push(r.result),
            Err(e) => failed.push((label, e.to_string())),
        }
        bar.inc();
    }
    bar.finish();
    let choice = choose(&results, goal);
    let chart = o.out.join(format!("{}.svg", penumbra::report::file_safe(&s.name)));
    write_plain(
        &chart,
        class_chart_svg(&format!("{}: {}", s.name, s.class().metric()), s.class(), &results).as_bytes(),
    )?;
    let goal_text = match goal {
        Goal::MaxError(e) => format!("the cheapest within {e} {}", s.class().metric()),
        Goal::BudgetMs(t) => format!("the most accurate within {t} ms"),
    };
    if o.json {
        let entry = |i: usize| {
            let r = &results[i];
            serde_json::json!({
                "label": r.label(),
                "technique": r.technique,
                "settings": r.settings,
                "error": r.class_error(),
                "ms": r.ms,
            })
        };
        let doc = serde_json::json!({
            "scene": s.name,
            "width": s.camera.width,
            "height": s.camera.height,
            "class": s.class().key(),
            "metric": s.class().metric(),
            "goal": match goal {
                Goal::MaxError(e) => serde_json::json!({ "max_error": e }),
                Goal::BudgetMs(t) => serde_json::json!({ "budget_ms": t }),
            },
            "facts": a.facts,
            "skipped": a.skipped.iter().map(|(t, why)| serde_json::json!({ "technique": t, "why": why })).collect::<Vec<_>>(),
            "failed": failed.iter().map(|(t, why)| serde_json::json!({ "setting": t, "error": why })).collect::<Vec<_>>(),
            "reference_ms": prepared.reference_secs * 1e3,
            "runs": (0..results.len()).map(entry).collect::<Vec<_>>(),
            "front": choice.front.iter().map(|&i| entry(i)).collect::<Vec<_>>(),
            "pick": choice.pick.as_ref().ok().map(|&i| entry(i)),
            "why_no_pick": choice.pick.as_ref().err().map(|e| &e.0),
            "alternatives": choice.alternatives.iter().map(|&i| entry(i)).collect::<Vec<_>>(),
            "tied": choice.tied.iter().map(|&i| entry(i)).collect::<Vec<_>>(),
            "time_tie": penumbra::choose::TIME_TIE,
            "chart": chart.display().to_string(),
        });
        println!("{}", serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?);
        return Ok(());
    }
    for (t, e) in &failed {
        println!("  failed {t}: {}", for_terminal(&e.to_string()));
    }
    println!(
        "{} settings run against the reference (traced in {:.1} s{}).",
        results.len(),
        prepared.reference_secs,
        if prepared.reference_secs == 0.0 {
            ", from the cache"
        } else {
            ""
        }
    );
    println!("Pareto front (no other setting both faster and more accurate):");
    print_rows(&results, &choice.front, &choice.pick);
    match &choice.pick {
        Ok(i) => {
            let r = &results[*i];
            println!(
                "pick ({goal_text}): {}: {} {}, {:.3} ms",
                r.label(),
                fmt_error(r.class_error()),
                s.class().metric(),
                r.ms
            );
            if !choice.tied.is_empty() {
                let names: Vec<String> = choice
                    .tied
                    .iter()
                    .map(|&j| format!("{} ({:.3} ms)", results[j].label(), results[j].ms))
                    .collect();
                println!(
                    "  a tie in time (within {:.0} %, the timing noise) with {}: the more accurate wins",
                    penumbra::choose::TIME_TIE * 100.0,
                    names.join(", ")
                );
            }
            for (k, &j) in choice.alternatives.iter().enumerate() {
                let r = &results[j];
                println!(
                    "  {}: {}: {}, {:.3} ms",
                    if k == 0 { "next" } else { "then" },
                    r.label(),
                    fmt_error(r.class_error()),
                    r.ms
                );
            }
        }
        Err(why) => println!("no pick ({goal_text}): {why}"),
    }
    println!("chart: {}", chart.display());
    Ok(())
}

/// The front's rows: error, time, and `<- pick` beside the pick.
fn print_rows(results: &[RunResult], rows: &[usize], pick: &Result<usize, NoPick>) {
    let width = rows.iter().map(|&i| results[i].label().len()).max().unwrap_or(0);
    for &i in rows {
        let r = &results[i];
        println!(
            "  {:width$}  {:>10}  {:>9.3} ms{}",
            r.label(),
            fmt_error(r.class_error()),
            r.ms,
            if pick.as_ref() == Ok(&i) { "  <- pick" } else { "" }
        );
    }
}
