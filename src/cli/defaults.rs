//! `penumbra defaults`: the soft and volumetric techniques' option sets across many generated
//! scenes ([`penumbra::scene::random`]), so that a default is chosen on scenes nobody picked:
//! per setting the mean, median, 90th percentile and worst of its class's error and its median
//! time ([`penumbra::report::across`]).

use super::scene::{cache, check_techniques, grouped, pipeline};
use super::sweep::Progress;
use crate::error::CliError;
use penumbra::reference::ReferenceOptions;
use penumbra::report::across::across_markdown;
use penumbra::report::files::{create_folder, write_plain};
use penumbra::run::{self, RunResult};
use penumbra::scene::random::{generate, Params};
use penumbra::scene::SceneClass;
use penumbra::shadow::{self, Effect};
use std::path::PathBuf;
use std::time::Instant;

/// Options of `penumbra defaults`.
pub struct DefaultsOpts {
    /// Generated scenes per class.
    pub scenes: usize,
    /// Whether a job past the stated limits ([`MAX_SCENES`]) was asked for.
    pub long: bool,
    /// The first seed.
    pub first_seed: u64,
    /// `soft,volumetric`-style technique names (empty: every technique that models an area
    /// light or transmittance).
    pub techniques: Vec<String>,
    /// Camera resolution.
    pub width: u32,
    /// Camera resolution.
    pub height: u32,
    /// Timed repetitions after one warm-up.
    pub reps: usize,
    /// Worker threads.
    pub threads: usize,
    /// Output folder.
    pub out: PathBuf,
}

/// Settings to run: a technique and its `key=value` settings.
/// Scenes a class that `defaults` runs without `--long`.
pub const MAX_SCENES: usize = 1000;

type Jobs<'a> = Vec<(&'a str, Vec<(String, String)>)>;

/// `penumbra defaults`.
pub fn defaults(o: DefaultsOpts) -> Result<(), CliError> {
    let reg = shadow::registry::registry();
    check_techniques(&o.techniques.join(","), &o.techniques)?;
    let wanted = |name: &str, models: &[Effect]| {
        if o.techniques.is_empty() {
            !models.is_empty()
        } else {
            o.techniques.iter().any(|t| t == name)
        }
    };
    // Per class: the scenes' parameters and the settings (the hard map as the baseline).
    let mut plans: Vec<(SceneClass, Params, Jobs)> = Vec::new();
    for (class, effect, params) in [
        (
            SceneClass::Area,
            Effect::AreaLight,
            Params {
                width: o.width,
                height: o.height,
                translucent: false,
                lights: vec!["disk", "sphere", "rectangle"],
                ..Params::default()
            },
        ),
        (
            SceneClass::Transparent,
            Effect::Transmittance,
            Params {
                width: o.width,
                height: o.height,
                translucent: true,
                ..Params::default()
            },
        ),
    ] {
        let mut jobs: Jobs = vec![("shadow-map", Vec::new())];
        for t in reg
            .iter()
            .filter(|t| t.models.contains(&effect) && wanted(t.name, t.models))
        {
            for set in t.sweep.iter().chain(t.extended) {
                jobs.push((t.name, shadow::registry::owned_sets(set)));
            }
        }
        if jobs.len() > 1 {
            plans.push((class, params, jobs));
        }
    }
    if plans.is_empty() {
        let modelling: Vec<&str> = reg.iter().filter(|t| !t.models.is_empty()).map(|t| t.name).collect();
        return Err(format!(
            "--techniques {}: none of them models an area light or transmittance, and `defaults` compares the option sets of those that do ({})",
            o.techniques.join(","),
            modelling.join(", ")
        )
        .into());
    }
    let total: usize = plans.iter().map(|(_, _, j)| j.len() * o.scenes).sum();
    if o.scenes > MAX_SCENES && !o.long {
        return Err(format!(
            "--scenes {}: {} runs, past the limit of {MAX_SCENES} scenes a class ({} runs); ask for it with --long",
            o.scenes,
            grouped(total as u64),
            grouped((total / o.scenes * MAX_SCENES) as u64)
        )
        .into());
    }
    eprintln!(
        "defaults: {} runs: {} scenes a class x {} settings over {} class{} at {}x{}; each scene's reference traces up to {} rays",
        grouped(total as u64),
        o.scenes,
        plans.iter().map(|(_, _, j)| j.len().to_string()).collect::<Vec<_>>().join(" and "),
        plans.len(),
        if plans.len() == 1 { "" } else { "es" },
        o.width,
        o.height,
        grouped(o.width as u64 * o.height as u64 * (1 + 32 + ReferenceOptions::default().area_samples as u64)),
    );
    let p = pipeline(o.threads)?;
    create_folder(&o.out)?;
    let dir_cache = cache(&o.out);
    let bar = Progress::new("defaults", total);
    let t0 = Instant::now();
    let mut results: Vec<RunResult> = Vec::new();
    for (class, params, jobs) in &plans {
        // Seeds in order from the first, keeping the scenes of the class (translucent casters
        // are drawn on some scenes only), at most 8 seeds per scene wanted.
        let mut found = 0;
        let mut seed = o.first_seed;
        while found < o.scenes && seed < o.first_seed + 8 * o.scenes as u64 {
            let r = generate(seed, params);
            seed += 1;
            let s = r.scene()?;
            if s.class() != *class {
                continue;
            }
            found += 1;
            bar.set_message(format!("{} / reference", s.name));
            let prepared = run::Prepared::new(&p, &s, &r.text, Some(&dir_cache))?;
            for (name, sets) in jobs {
                bar.set_message(format!("{} / {}", s.name, run::label(name, &run::settings_text(sets))));
                let out = run::render_prepared(&p, &prepared, name, sets, o.reps)?;
                results.push(RunResult {
                    index: results.len(),
                    ..out.result
                });
                bar.inc();
            }
        }
    }
    bar.finish();
    let mut md = format!(
        "Settings across generated scenes: `penumbra defaults --scenes {} --first-seed {}` at {}x{}, {} threads, {:.0} s. The defaults are in bold.\n",
        o.scenes,
        o.first_seed,
        o.width,
        o.height,
        p.threads(),
        t0.elapsed().as_secs_f64()
    );
    for (class, _, _) in &plans {
        let n = results
            .iter()
            .filter(|r| r.class == *class && r.technique == "shadow-map")
            .count();
        md += &format!(
            "\n### {} scenes ({n}: {})\n\n",
            class.key(),
            match class {
                SceneClass::Area => "opaque casters under a disk, sphere or rectangle light",
                SceneClass::Transparent => "some casters translucent or coloured, any light",
                SceneClass::Hard => "hard lights",
            }
        );
        md += &across_markdown(&results, *class);
    }
    write_plain(&o.out.join("defaults.md"), md.as_bytes())?;
    write_plain(&o.out.join("results.csv"), penumbra::report::csv(&results).as_bytes())?;
    println!("{md}");
    println!("table: {}", o.out.join("defaults.md").display());
    println!("data:  {}", o.out.join("results.csv").display());
    Ok(())
}
