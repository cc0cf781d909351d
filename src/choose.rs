//! `penumbra choose`: which technique should a scene use? "Model no more than a scene needs":
//! [`analyse`] names what the scene has (the light's kind and size, translucent or coloured
//! materials, thin objects, a camera path, the depth range the camera sees) and leaves out the
//! techniques that model what it lacks ([`crate::shadow::TechniqueInfo::models`]: no penumbra
//! technique under a point light, no volumetric one where nothing transmits light); the CLI runs
//! the rest against the reference, and [`choose`] picks from the measured settings: the cheapest
//! within an error, or the most accurate within a time budget, with the Pareto front and the
//! next alternatives.

use crate::frame::Frame;
use crate::report::chart::pareto;
use crate::run::RunResult;
use crate::scene::{AreaShape, LightKind, Scene, SceneClass};
use crate::shadow;
use crate::Error;

/// A technique setting to run: the technique and its `key=value` settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Technique name.
    pub technique: &'static str,
    /// Its settings (empty: the defaults).
    pub sets: Vec<(String, String)>,
}

/// What [`analyse`] found in a scene and what it will run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Analysis {
    /// What the scene has, one line each (light, materials, thin objects, camera path, depth
    /// range).
    pub facts: Vec<String>,
    /// The settings to run, in registry order.
    pub runs: Vec<Candidate>,
    /// The techniques left out, each with why.
    pub skipped: Vec<(&'static str, String)>,
}

/// An object is thin when its bounding box's shortest side is below this fraction of its
/// longest (sheets, planes, wires): where a map's bias lets light through and penumbra volumes
/// degenerate.
const THIN: f32 = 0.02;

/// What `scene` has and which technique settings model it: every technique's sweep sets
/// (and, with `all`, its extended sets) except those of techniques that do not work on the
/// scene or model only effects it lacks. `frame` (the camera's G-buffer of the scene) gives
/// the depth range the camera sees. The reference is never a candidate: it is the truth the
/// others are measured against.
pub fn analyse(scene: &Scene, frame: Option<&Frame>, all: bool) -> Analysis {
    let mut a = Analysis {
        facts: facts(scene, frame),
        ..Analysis::default()
    };
    for t in shadow::registry::registry() {
        if t.name == "reference" {
            continue;
        }
        if !t.applies_to(scene) {
            a.skipped
                .push((t.name, "does not work on this scene (see `penumbra list`)".into()));
            continue;
        }
        if !t.models.is_empty() && !t.models.iter().any(|e| e.in_scene(scene)) {
            let what: Vec<&str> = t.models.iter().map(|e| e.describe()).collect();
            a.skipped
                .push((t.name, format!("models {}, which the scene lacks", what.join(" and "))));
            continue;
        }
        let extended: &[&[(&str, &str)]] = if all { t.extended } else { &[] };
        for set in t.sweep.iter().chain(extended) {
            a.runs.push(Candidate {
                technique: t.name,
                sets: shadow::registry::owned_sets(set),
            });
        }
    }
    a
}

/// The facts [`analyse`] reports.
fn facts(scene: &Scene, frame: Option<&Frame>) -> Vec<String> {
    let mut facts = Vec::new();
    facts.push(match scene.lights.first().map(|l| l.kind) {
        None => "light: none".into(),
        Some(LightKind::Directional) => "light: directional (hard shadows, no penumbra)".into(),
        Some(LightKind::Point) => "light: point (hard shadows, no penumbra)".into(),
        Some(LightKind::Spot { angle_deg }) => format!("light: spot of {angle_deg}° (hard shadows, no penumbra)"),
        Some(LightKind::Area(shape)) => format!(
            "light: {} (penumbrae)",
            match shape {
                AreaShape::Disk { radius } => format!("disk of radius {radius}"),
                AreaShape::Sphere { radius } => format!("sphere of radius {radius}"),
                AreaShape::Rectangle { width, height } => format!("rectangle {width} x {height}"),
            }
        ),
    });
    let n = scene.objects.len();
    let translucent: Vec<&str> = scene
        .objects
        .iter()
        .filter(|o| scene.materials.get(o.material).is_some_and(|m| m.is_transparent()))
        .map(|o| o.name.as_str())
        .collect();
    let coloured = scene
        .objects
        .iter()
        .filter(|o| {
            scene.materials.get(o.material).is_some_and(|m| {
                m.is_transparent()
                    && m.transmittance
                        .is_some_and(|t| t.max_element() - t.min_element() > 1e-3)
            })
        })
        .count();
    facts.push(if translucent.is_empty() {
        format!("materials: all {n} objects opaque")
    } else {
        format!(
            "materials: {} of {n} objects transmit light ({coloured} coloured): {}",
            translucent.len(),
            names(&translucent)
        )
    });
    let thin: Vec<&str> = scene
        .objects
        .iter()
        .filter(|o| {
            let (lo, hi) = o.mesh.positions.iter().fold(
                (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), &p| (lo.min(p), hi.max(p)),
            );
            let e = hi - lo;
            e.max_element() > 0.0 && e.min_element() < THIN * e.max_element()
        })
        .map(|o| o.name.as_str())
        .collect();
    facts.push(if thin.is_empty() {
        "thin or flat objects: none".into()
    } else {
        format!(
            "thin or flat objects (shortest side under {}% of the longest; a map's bias can let light through them): {}",
            THIN * 100.0,
            names(&thin)
        )
    });
    if !scene.light_path.is_empty() {
        facts.push(format!(
            "light: a path of {} keyframes (flicker is measured along the path)",
            scene.light_path.len()
        ));
    }
    facts.push(if scene.camera_path.is_empty() {
        "camera: still".into()
    } else {
        format!(
            "camera: a path of {} keyframes (times are the first frame's; flicker is measured along the path)",
            scene.camera_path.len()
        )
    });
    if let Some(f) = frame {
        let eye = scene.camera.position;
        let mask = f.metric_mask();
        let (near, far) = f
            .gbuffer
            .position
            .data()
            .iter()
            .zip(&mask)
            .filter(|(_, &m)| m)
            .map(|(p, _)| (*p - eye).length())
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), d| (lo.min(d), hi.max(d)));
        facts.push(if near.is_finite() && near > 0.0 {
            format!(
                "depth range seen: {near:.3} to {far:.3} from the eye (1:{:.0}; wide ranges are where a map's texels per pixel vary most)",
                far / near
            )
        } else {
            "depth range seen: no lit-facing surface in view".into()
        });
    }
    facts
}

/// Up to four names, then how many more.
fn names(list: &[&str]) -> String {
    let mut s = list.iter().take(4).copied().collect::<Vec<_>>().join(", ");
    if list.len() > 4 {
        s += &format!(" and {} more", list.len() - 4);
    }
    s
}

/// What a pick must meet.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Goal {
    /// The cheapest setting whose error (the scene's metric) is at most this.
    MaxError(f64),
    /// The most accurate setting whose median time is at most this many milliseconds.
    BudgetMs(f64),
}

impl Goal {
    /// The goal when none is given: the cheapest setting within an error a viewer would
    /// accept on the scene's class (0.5 % wrong pixels for hard shadows, 0.05 penumbra RMSE
    /// under area lights, 0.05 transmittance RMSE where light passes through casters).
    pub fn default_for(class: SceneClass) -> Goal {
        Goal::MaxError(match class {
            SceneClass::Hard => 0.5,
            SceneClass::Area | SceneClass::Transparent => 0.05,
        })
    }

    /// Checks the goal's number: finite and above 0 (a budget) or at least 0 (an error). The
    /// error is an [`Error::Option`] whose key is `max-error` or `budget-ms` and whose message
    /// says what the number must be.
    pub fn check(self) -> Result<Goal, Error> {
        match self {
            Goal::MaxError(e) if e.is_finite() && e >= 0.0 => Ok(self),
            Goal::MaxError(e) => Err(Error::option("max-error", e, "an error is a finite number, 0 or more")),
            Goal::BudgetMs(t) if t.is_finite() && t > 0.0 => Ok(self),
            Goal::BudgetMs(t) => Err(Error::option(
                "budget-ms",
                t,
                "a time budget is a finite number of milliseconds above 0",
            )),
        }
    }
}

/// Why [`choose`] picked nothing: no run meets the goal. It says so, naming the closest run.
#[derive(Clone, Debug, PartialEq)]
pub struct NoPick(pub String);

impl std::fmt::Display for NoPick {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// What [`choose`] picked from a scene's runs (indices into them).
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// The Pareto front (no other run both faster and more accurate), fastest first.
    pub front: Vec<usize>,
    /// The pick, or why there is none (nothing meets the goal: the closest run named).
    pub pick: Result<usize, NoPick>,
    /// The next two runs that meet the goal, best first after the pick.
    pub alternatives: Vec<usize>,
    /// The runs that met an error goal at a time within [`TIME_TIE`] of the cheapest, passed
    /// over for the pick because it is more accurate (a tie in time is broken by error).
    pub tied: Vec<usize>,
}

/// Times within this fraction of each other are a tie: the spread of one setting's median
/// time between two back-to-back `choose` runs on a shared two-core machine (the 70 settings
/// of `choose fixtures/scenes/contact.toml`: median 5.5 %, 90th percentile 32 %, largest
/// 73 %, all on settings under 70 ms; docs/performance.md).
pub const TIME_TIE: f64 = 0.35;

/// Picks from `runs` (one scene's, each with its [`RunResult::class_error`] and median `ms`):
/// for [`Goal::MaxError`] the cheapest run within the error, where runs within [`TIME_TIE`]
/// of the cheapest time are a tie that the more accurate wins (so that timing noise does not
/// flip the pick between runs of the same command); for [`Goal::BudgetMs`] the most accurate
/// run within the time (ties: the faster). Runs with a non-finite error or time never meet a
/// goal.
pub fn choose(runs: &[RunResult], goal: Goal) -> Choice {
    let points: Vec<(f64, f64)> = runs.iter().map(|r| (r.ms, r.class_error())).collect();
    let front = pareto(&points);
    let finite: Vec<usize> = (0..runs.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    // By time then error (cheapest first), or by error then time (most accurate first).
    let order = |a: usize, b: usize, by_time: bool| {
        let (p, q) = (points[a], points[b]);
        if by_time {
            p.0.total_cmp(&q.0).then(p.1.total_cmp(&q.1))
        } else {
            p.1.total_cmp(&q.1).then(p.0.total_cmp(&q.0))
        }
    };
    let (by_time, limit) = match goal {
        Goal::MaxError(e) => (true, e),
        Goal::BudgetMs(t) => (false, t),
    };
    let meets = |i: usize| {
        if by_time {
            points[i].1 <= limit
        } else {
            points[i].0 <= limit
        }
    };
    let mut ok: Vec<usize> = finite.iter().copied().filter(|&i| meets(i)).collect();
    ok.sort_by(|&a, &b| order(a, b, by_time));
    // Nothing meets the goal: the closest to it is the most accurate (an error bound) or the
    // fastest (a budget).
    let closest = finite.iter().copied().min_by(|&a, &b| order(a, b, !by_time));
    let why_not = match (closest, goal) {
        (None, _) => "nothing was measured".to_string(),
        (Some(i), Goal::MaxError(e)) => format!(
            "nothing within {e}; the most accurate is {} at {} ({:.3} ms)",
            runs[i].label(),
            fmt_error(points[i].1),
            points[i].0
        ),
        (Some(i), Goal::BudgetMs(t)) => format!(
            "nothing runs within {t} ms; the fastest is {} at {:.3} ms (error {})",
            runs[i].label(),
            points[i].0,
            fmt_error(points[i].1)
        ),
    };
    if ok.is_empty() {
        return Choice {
            front,
            pick: Err(NoPick(why_not)),
            alternatives: Vec::new(),
            tied: Vec::new(),
        };
    }
    // An error goal: the runs as cheap as the cheapest within the timing noise, the most
    // accurate of them first (then the faster).
    let mut tied: Vec<usize> = Vec::new();
    if by_time {
        let cheapest = points[ok[0]].0;
        let n = ok
            .iter()
            .take_while(|&&i| points[i].0 <= cheapest * (1.0 + TIME_TIE))
            .count();
        ok[..n].sort_by(|&a, &b| order(a, b, false));
        tied = ok[1..n].to_vec();
    }
    let pick = ok.remove(0);
    ok.truncate(2);
    Choice {
        front,
        pick: Ok(pick),
        alternatives: ok,
        tied,
    }
}

/// An error as the tables write it (4 significant decimals).
pub fn fmt_error(e: f64) -> String {
    format!("{e:.4}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(label: &str, ms: f64, wrong: f64) -> RunResult {
        let mut r = RunResult {
            technique: label.into(),
            ms,
            ..RunResult::default()
        };
        r.errors.wrong_pct = wrong;
        r
    }

    #[test]
    fn the_pick_meets_the_goal_and_nothing_cheaper_or_better_does() {
        let runs = vec![
            run("a", 1.0, 5.0),
            run("b", 2.0, 1.0),
            run("c", 3.0, 0.4),
            run("d", 4.5, 0.2),
            run("e", 5.0, 0.4),
            run("f", 0.5, f64::NAN),
        ];
        let c = choose(&runs, Goal::MaxError(0.5));
        assert_eq!(c.pick, Ok(2));
        assert_eq!(c.alternatives, vec![3, 4]);
        assert!(c.tied.is_empty());
        assert_eq!(c.front, vec![0, 1, 2, 3]);
        let c = choose(&runs, Goal::BudgetMs(3.5));
        assert_eq!(c.pick, Ok(2));
        assert_eq!(c.alternatives, vec![1, 0]);
        let c = choose(&runs, Goal::MaxError(0.001));
        assert_eq!(
            c.pick,
            Err(NoPick(
                "nothing within 0.001; the most accurate is d at 0.2000 (4.500 ms)".into()
            ))
        );
        let c = choose(&runs, Goal::BudgetMs(0.1));
        assert!(c
            .pick
            .unwrap_err()
            .0
            .starts_with("nothing runs within 0.1 ms; the fastest is a at 1.000 ms"));
    }

    #[test]
    fn times_within_the_noise_are_a_tie_the_more_accurate_wins() {
        // Regression: the pick flipped between two runs of one command when two settings'
        // times were within the timing noise of each other.
        for (fast, slow) in [(10.0, 10.5), (10.5, 10.0), (10.0, 13.49)] {
            let runs = vec![run("rough", fast, 0.4), run("fine", slow, 0.1), run("slow", 30.0, 0.05)];
            let c = choose(&runs, Goal::MaxError(0.5));
            assert_eq!(c.pick, Ok(1), "{fast} {slow}");
            assert_eq!(c.tied, vec![0]);
            assert_eq!(c.alternatives, vec![0, 2]);
        }
        // Past the noise, the cheaper wins and nothing is tied.
        let runs = vec![run("rough", 10.0, 0.4), run("fine", 13.6, 0.1)];
        let c = choose(&runs, Goal::MaxError(0.5));
        assert_eq!((c.pick, c.tied), (Ok(0), vec![]));
    }

    #[test]
    fn bad_goals_are_refused() {
        for g in [
            Goal::MaxError(-1.0),
            Goal::MaxError(f64::NAN),
            Goal::BudgetMs(0.0),
            Goal::BudgetMs(f64::INFINITY),
            Goal::BudgetMs(-3.0),
        ] {
            assert!(g.check().is_err(), "{g:?}");
        }
        assert!(Goal::MaxError(0.0).check().is_ok());
    }
}
