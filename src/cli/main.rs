//! The `penumbra` command line.

use clap::{Args, Parser, Subcommand};
use penumbra::bench::{FrameMode, FRAME_CAMERA_CULL};
use penumbra::error::for_terminal;
use penumbra::pipeline::{CullMode, Shading, MAX_DIMENSION};
use std::path::PathBuf;
use std::process::ExitCode;

mod bench;
mod choose;
mod defaults;
mod error;
mod explore;
mod export;
mod scene;
mod sweep;

#[derive(Parser)]
#[command(
    name = "penumbra",
    version,
    about = "A deterministic CPU rasterizer and shadow-algorithm lab"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Option<Cmd>,
    /// Memory budget of all render targets, maps and buffers alive at once (bytes, or with a
    /// K, M or G suffix). A surface past it is refused, before it is allocated, with an error
    /// that says how large it was. Default: 4G.
    #[arg(long, global = true, allow_hyphen_values = true, value_parser = parse_bytes, value_name = "BYTES")]
    max_memory: Option<u64>,
}

/// The sweep's timed repetitions per run (after one warm-up) by default.
const DEFAULT_SWEEP_REPS: usize = 1;

/// Largest `--reps`: repetitions of a measurement that a 2-core machine finishes.
const MAX_REPS: usize = 100;

/// A whole-number option in `lo..=hi`. Negative, fractional and out-of-range values get a
/// message with the range (clap alone calls `-1` an unknown argument); clap names the option.
fn count<T: TryFrom<u64>>(lo: u64, hi: u64) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let range = || format!("a whole number in {lo}..={hi}");
        match s.trim().parse::<i128>() {
            Ok(v) if v >= lo as i128 && v <= hi as i128 => T::try_from(v as u64).map_err(|_| range()),
            Ok(v) => Err(format!("{v} is outside {lo}..={hi}")),
            Err(_) => Err(format!("'{s}' is not {}", range())),
        }
    }
}

/// `--reps`: 0..=[`MAX_REPS`].
fn parse_reps(s: &str) -> Result<usize, String> {
    count(0, MAX_REPS as u64)(s)
}

/// `--triangles` of the benchmarks: 2..=[`bench::MAX_BENCH_TRIANGLES`] (larger meshes take
/// more than a few GB).
fn parse_triangles(s: &str) -> Result<usize, String> {
    count(2, bench::MAX_BENCH_TRIANGLES as u64)(s)
}

/// A side of a surface (`--map`, `--width`, `--height`): 1..=[`MAX_DIMENSION`].
fn parse_side(s: &str) -> Result<u32, String> {
    count(1, MAX_DIMENSION as u64)(s)
}

/// Parses `4G`, `512M`, `64K` or a byte count.
fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let (num, mul) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 1u64 << 10),
        Some('M') => (&t[..t.len() - 1], 1 << 20),
        Some('G') => (&t[..t.len() - 1], 1 << 30),
        _ => (t, 1),
    };
    let n: u64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a size (bytes, or a whole number with K, M or G: 4G)"))?;
    n.checked_mul(mul)
        .filter(|&b| b > 0)
        .ok_or_else(|| format!("'{s}' must be above 0 and below 16 EiB"))
}

#[derive(Subcommand)]
enum Cmd {
    /// Render a scene with a technique: final image, visibility, error against the reference, timings.
    Render(RenderArgs),
    /// Write every intermediate stage of a technique (PNG, false colour) and the G-buffer and visibility (PFM).
    Dump(RenderArgs),
    /// Explain one pixel step by step: the surface point, what the technique read, compared and
    /// filtered there, and the reference's value.
    Inspect(InspectArgs),
    /// Compute (or read from the cache) the ray-traced ground truth of a scene.
    Reference(SceneArgs),
    /// Step through a technique in the browser: a local server (127.0.0.1) and one page with
    /// the images, every stage, one pixel's steps on a click, a technique and option picker,
    /// and two techniques side by side.
    Explore(ExploreArgs),
    /// Every technique (and each option set it declares) on every scene: CSV, charts, report.
    Sweep(SweepArgs),
    /// Which technique for this scene? Names what the scene has, runs the techniques that model
    /// it against the reference, prints the Pareto front and picks: the cheapest within
    /// --max-error, or the most accurate within --budget-ms.
    Choose(ChooseArgs),
    /// The soft and volumetric techniques' option sets across many generated scenes: mean,
    /// median, 90th percentile and worst error and median time per setting.
    Defaults(DefaultsArgs),
    /// Write a scene in world space as OBJ plus a JSON of camera and lights.
    Export(SceneArgs),
    /// List techniques with their options and defaults, and the built-in scenes.
    List,
    /// Write a random scene (seeded, reproducible): a scene file and the OBJ files it names.
    Random(RandomArgs),
    /// Benchmarks: the shadow-mapped spheres frame, or random triangles.
    Bench {
        #[command(subcommand)]
        which: BenchCmd,
    },
}

#[derive(Args)]
struct RandomArgs {
    /// The seed: the same seed is the same scene on every machine.
    #[arg(long, allow_hyphen_values = true, value_parser = count::<u64>(0, u64::MAX))]
    seed: u64,
    /// Output folder (the scene is `random_<seed>.toml` in it).
    #[arg(long, default_value = "out/random")]
    out: PathBuf,
    /// Only opaque materials (for the hard techniques' exactness).
    #[arg(long)]
    opaque: bool,
    /// Only these kinds of light, comma-separated: directional, spot, point, disk, sphere,
    /// rectangle (the properties of `tests/random.rs` draw from `directional,spot,point` or
    /// `disk,sphere,rectangle`).
    #[arg(long, value_delimiter = ',')]
    light: Vec<String>,
    /// Camera resolution.
    #[arg(long, default_value_t = 160, allow_hyphen_values = true, value_parser = count::<u32>(1, 8192))]
    width: u32,
    /// Camera resolution.
    #[arg(long, default_value_t = 90, allow_hyphen_values = true, value_parser = count::<u32>(1, 8192))]
    height: u32,
}

#[derive(Args)]
struct ChooseArgs {
    /// Scene file (TOML, glTF).
    scene: PathBuf,
    /// Pick the cheapest setting whose error is at most E, on the scene's metric (wrong
    /// pixels in % for hard shadows, penumbra RMSE under an area light, transmittance RMSE
    /// where light passes through casters). Default: 0.5 % wrong, or an RMSE of 0.05.
    #[arg(long, value_name = "E", allow_hyphen_values = true, value_parser = choose::parse_number, conflicts_with = "budget_ms")]
    max_error: Option<f64>,
    /// Pick the most accurate setting whose median time is at most T milliseconds.
    #[arg(long, value_name = "T", allow_hyphen_values = true, value_parser = choose::parse_number)]
    budget_ms: Option<f64>,
    /// Run at the scene's resolution times this, in (0, 4] (0.5 for a quick answer).
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = choose::parse_scale)]
    scale: f64,
    /// Also every technique's extended option sets.
    #[arg(long)]
    all: bool,
    /// Timed repetitions after one warm-up (the median is reported).
    #[arg(long, default_value_t = 2, allow_hyphen_values = true, value_parser = parse_reps)]
    reps: usize,
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Print one JSON object (facts, runs, front, pick, alternatives) instead of text.
    #[arg(long)]
    json: bool,
    /// Output folder: the chart (`<scene>.svg`) and the reference cache.
    #[arg(long, default_value = "out/choose")]
    out: PathBuf,
}

#[derive(Args)]
struct DefaultsArgs {
    /// Generated scenes per class (area-light scenes for the soft techniques, scenes with
    /// translucent casters for the volumetric ones).
    #[arg(long, default_value_t = 200, allow_hyphen_values = true, value_parser = count::<usize>(1, 100_000))]
    scenes: usize,
    /// Run a job past the stated limits (more than 1000 scenes a class).
    #[arg(long)]
    long: bool,
    /// The first seed (scenes are the seeds from it on, those of the class kept).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = count::<u64>(0, u64::MAX / 2))]
    first_seed: u64,
    /// A comma-separated list of technique names (default: every technique that models an
    /// area light or transmittance).
    #[arg(long, value_delimiter = ',')]
    techniques: Vec<String>,
    /// Camera resolution of the generated scenes.
    #[arg(long, default_value_t = 160, allow_hyphen_values = true, value_parser = count::<u32>(1, 8192))]
    width: u32,
    /// Camera resolution of the generated scenes.
    #[arg(long, default_value_t = 90, allow_hyphen_values = true, value_parser = count::<u32>(1, 8192))]
    height: u32,
    /// Timed repetitions after one warm-up (the median is reported).
    #[arg(long, default_value_t = 1, allow_hyphen_values = true, value_parser = parse_reps)]
    reps: usize,
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Output folder: defaults.md, results.csv and the reference cache.
    #[arg(long, default_value = "out/defaults")]
    out: PathBuf,
}

#[derive(Args)]
struct SceneArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Output folder.
    #[arg(long, default_value = "out")]
    out: PathBuf,
}

#[derive(Args)]
struct RenderArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Technique name (see `penumbra list`).
    #[arg(long, default_value = "shadow-map")]
    technique: String,
    /// Technique option, key=value (repeatable).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Timed repetitions after one warm-up (the median is reported).
    #[arg(long, default_value_t = 3, allow_hyphen_values = true, value_parser = parse_reps)]
    reps: usize,
    /// Output folder.
    #[arg(long, default_value = "out")]
    out: PathBuf,
}

#[derive(Args)]
struct InspectArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Technique name (see `penumbra list`).
    #[arg(long, default_value = "shadow-map")]
    technique: String,
    /// Technique option, key=value (repeatable).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// The pixel, X,Y (column, row from the top-left).
    #[arg(long, allow_hyphen_values = true)]
    pixel: String,
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Print the steps as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct ExploreArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// The technique shown first (see `penumbra list`).
    #[arg(long, default_value = "shadow-map")]
    technique: String,
    /// Its options, key=value (repeatable).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// The port on 127.0.0.1 (0: a free one; the URL is printed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = count::<u16>(0, 65535))]
    port: u16,
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Output folder of the reference cache (`OUT/cache`, shared with `render`).
    #[arg(long, default_value = "out")]
    out: PathBuf,
}

#[derive(Args)]
struct SweepArgs {
    /// Scene files (default: every file in fixtures/scenes).
    scenes: Vec<PathBuf>,
    /// all, or a comma-separated list of technique names.
    #[arg(long, default_value = "all")]
    techniques: String,
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Timed repetitions after one warm-up (the median is reported; 1 by default, so the
    /// default sweep stays within minutes on two cores).
    #[arg(long, default_value_t = DEFAULT_SWEEP_REPS, allow_hyphen_values = true, value_parser = parse_reps)]
    reps: usize,
    /// Output folder.
    #[arg(long, default_value = "out/sweep")]
    out: PathBuf,
    /// Also run every technique's extended option sets (variants and slow settings).
    #[arg(long)]
    all: bool,
    /// Run only the I-th of N deterministic slices of the run list (0-based, `I/N`) and
    /// write its partial results.csv; combine the slices' folders with --merge.
    #[arg(long, allow_hyphen_values = true, value_parser = sweep::parse_shard, conflicts_with = "merge")]
    shard: Option<(usize, usize)>,
    /// Combine the output folders of shards into --out: the CSV, charts and report one
    /// unsharded run writes. Takes no scenes.
    #[arg(long, num_args = 1.., value_name = "DIR")]
    merge: Vec<PathBuf>,
}

#[derive(Subcommand)]
enum BenchCmd {
    /// The spheres frame: light depth pass + 1920x1080 camera pass with PCF.
    Frame(FrameArgs),
    /// Random triangles of about AREA pixels each at 1920x1080.
    Raster(RasterArgs),
    /// Shadow rays per second of the reference ray tracer on the spheres scene (one ray per
    /// pixel of the 1920x1080 camera view towards the light).
    Rays(RaysArgs),
    /// A shadow technique on the spheres scene (ground + 64 spheres, 1920x1080 camera):
    /// median time per pass, counters, triangles/s.
    Technique(TechniqueArgs),
}

#[derive(Args)]
struct TechniqueArgs {
    /// Technique name (see `penumbra list`).
    #[arg(long, default_value = "shadow-volume")]
    technique: String,
    /// Technique options as key=value (repeatable).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// Target triangle count of the spheres scene.
    #[arg(long, default_value_t = 100_000, allow_hyphen_values = true, value_parser = parse_triangles)]
    triangles: usize,
    /// A scene file to run instead of the spheres scene.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// The camera's resolution, WIDTHxHEIGHT (default: the scene's; the spheres scene's is
    /// 1920x1080).
    #[arg(long)]
    resolution: Option<String>,
    /// Replace the scene's light by a disk light of this radius at the light's position,
    /// facing its direction (for the soft techniques on the spheres scene, whose light is a
    /// sun).
    #[arg(long)]
    disk: Option<f32>,
    #[command(flatten)]
    common: Common,
}

#[derive(Args)]
struct Common {
    /// Worker threads (0: all cores; at most 4x the cores, and at least 4 allowed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: usize,
    /// Timed repetitions after the warm-up (the median is reported).
    #[arg(long, default_value_t = 10, allow_hyphen_values = true, value_parser = parse_reps)]
    reps: usize,
    /// Print one JSON object on the last line.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct FrameArgs {
    /// Target triangle count of the scene.
    #[arg(long, default_value_t = 100_000, allow_hyphen_values = true, value_parser = parse_triangles)]
    triangles: usize,
    /// depth | pcf2 | pcf5 | pcss (the classic PCSS shader: 16 blocker-search taps, 16 filter
    /// taps) | vsm (moments, a 5x5 box blur, Chebyshev's bound)
    #[arg(long, default_value = "pcf2")]
    mode: FrameMode,
    /// Shadow-map size S (S x S).
    #[arg(long, default_value_t = 2048, allow_hyphen_values = true, value_parser = parse_side)]
    map: u32,
    /// Image width.
    #[arg(long, default_value_t = 1920, allow_hyphen_values = true, value_parser = parse_side)]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 1080, allow_hyphen_values = true, value_parser = parse_side)]
    height: u32,
    /// Write the image (and the shadow map) as PNG into this folder.
    #[arg(long)]
    out: Option<PathBuf>,
    /// deferred (hidden surface removal before shading) | immediate
    #[arg(long, default_value = "deferred")]
    shading: Shading,
    /// Face culling of the camera pass: back | none | front (the light pass culls nothing)
    #[arg(long, default_value_t = FRAME_CAMERA_CULL)]
    cull: CullMode,
    /// Also write the workload (mesh, matrices) into this folder for another renderer
    /// (`tools/llvmpipe_bench.py` runs it on Mesa's llvmpipe).
    #[arg(long)]
    export: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
}

#[derive(Args)]
struct RaysArgs {
    /// Target triangle count of the spheres scene.
    #[arg(long, default_value_t = 100_000, allow_hyphen_values = true, value_parser = parse_triangles)]
    triangles: usize,
    /// Rays per repetition (1000..=100000000: about 10 s per repetition on two cores at the
    /// top).
    #[arg(long, default_value_t = 4_000_000, allow_hyphen_values = true, value_parser = count::<usize>(1000, 100_000_000))]
    rays: usize,
    /// Incoherent rays instead of the camera's shadow rays: origins uniform in the scene's
    /// bounds, directions uniform on the sphere (SplitMix64, seed 1), unbounded.
    #[arg(long)]
    random: bool,
    /// Trace consecutive rays (neighbouring pixels) in packets of 8 (`Reference::
    /// transmittance_packet`), as the reference does, instead of one at a time.
    #[arg(long)]
    packets: bool,
    /// Write the triangles and the rays to this folder (`triangles.f32`: 9 floats per
    /// triangle; `rays.f32`: origin, direction and tmax, 7 floats per ray; little-endian) and
    /// `rays.txt` (counts and the occluded count), for another tracer to run the same rays
    /// (`tools/compare_embree.py`).
    #[arg(long)]
    export: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
}

#[derive(Args)]
struct RasterArgs {
    /// Number of triangles.
    #[arg(long, default_value_t = 100_000, allow_hyphen_values = true, value_parser = parse_triangles)]
    triangles: usize,
    /// Approximate area of each triangle in pixels.
    #[arg(long, default_value_t = 50.0, allow_hyphen_values = true)]
    area: f32,
    /// depth | color
    #[arg(long, default_value = "color")]
    mode: String,
    /// deferred (hidden surface removal before shading) | immediate
    #[arg(long, default_value = "deferred")]
    shading: Shading,
    /// Also write the workload (triangles) into this folder for another renderer
    /// (`tools/llvmpipe_bench.py` runs it on Mesa's llvmpipe).
    #[arg(long)]
    export: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
}

fn main() -> ExitCode {
    penumbra::alloc::keep_freed_memory();
    // Output piped into `head` and closed early: exit quietly like other command-line tools,
    // instead of panicking on the failed write.
    #[cfg(target_os = "linux")]
    // SAFETY: restoring the default disposition of a signal at start-up.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    if let Some(bytes) = cli.max_memory {
        penumbra::pipeline::set_memory_limit(bytes);
    }
    let result = match cli.cmd {
        None => {
            println!(
                "penumbra: no command given; running the default sweep over fixtures/scenes (see `penumbra --help`)."
            );
            sweep::sweep(sweep::SweepOpts {
                scenes: vec![],
                techniques: "all".into(),
                threads: 0,
                // The sweep command's default (`--reps`).
                reps: DEFAULT_SWEEP_REPS,
                out: PathBuf::from("out/sweep"),
                all: false,
                shard: (0, 1),
            })
        }
        Some(Cmd::Render(a)) => scene::render(&a.scene, &a.technique, &a.sets, a.threads, a.reps, &a.out),
        Some(Cmd::Dump(a)) => scene::dump(&a.scene, &a.technique, &a.sets, a.threads, &a.out),
        Some(Cmd::Inspect(a)) => scene::inspect(&a.scene, &a.technique, &a.sets, &a.pixel, a.threads, a.json),
        Some(Cmd::Reference(a)) => scene::reference(&a.scene, a.threads, &a.out),
        Some(Cmd::Explore(a)) => explore::explore(explore::ExploreOpts {
            scene: a.scene,
            technique: a.technique,
            sets: a.sets,
            port: a.port,
            threads: a.threads,
            out: a.out,
        }),
        Some(Cmd::Sweep(a)) if !a.merge.is_empty() => {
            if a.scenes.is_empty() {
                sweep::merge(&a.merge, &a.out)
            } else {
                Err("sweep --merge combines finished shards and takes no scene files".into())
            }
        }
        Some(Cmd::Sweep(a)) => sweep::sweep(sweep::SweepOpts {
            scenes: a.scenes,
            techniques: a.techniques,
            threads: a.threads,
            reps: a.reps,
            out: a.out,
            all: a.all,
            shard: a.shard.unwrap_or((0, 1)),
        }),
        Some(Cmd::Choose(a)) => choose::choose_cmd(choose::ChooseOpts {
            scene: a.scene,
            goal: match (a.max_error, a.budget_ms) {
                (Some(e), _) => Some(penumbra::choose::Goal::MaxError(e)),
                (None, Some(t)) => Some(penumbra::choose::Goal::BudgetMs(t)),
                (None, None) => None,
            },
            scale: a.scale,
            all: a.all,
            reps: a.reps,
            threads: a.threads,
            json: a.json,
            out: a.out,
        }),
        Some(Cmd::Defaults(a)) => defaults::defaults(defaults::DefaultsOpts {
            scenes: a.scenes,
            long: a.long,
            first_seed: a.first_seed,
            techniques: a.techniques,
            width: a.width,
            height: a.height,
            reps: a.reps,
            threads: a.threads,
            out: a.out,
        }),
        Some(Cmd::Export(a)) => export::export(&a.scene, &a.out),
        Some(Cmd::List) => export::list(),
        Some(Cmd::Random(a)) => random(a),
        Some(Cmd::Bench {
            which: BenchCmd::Frame(a),
        }) => bench::frame(a),
        Some(Cmd::Bench {
            which: BenchCmd::Raster(a),
        }) => bench::raster(a),
        Some(Cmd::Bench {
            which: BenchCmd::Rays(a),
        }) => bench::rays(a),
        Some(Cmd::Bench {
            which: BenchCmd::Technique(a),
        }) => bench::technique(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("penumbra: error: {}", for_terminal(&e.to_string()));
            ExitCode::FAILURE
        }
    }
}

/// `--threads`: a whole number of threads, 0 for all cores. Negative and fractional values get
/// a message that says so (clap alone would call `-1` an unknown argument); at most 4x the
/// cores (at least 4).
fn parse_threads(s: &str) -> Result<usize, String> {
    let n = s.trim().parse::<usize>().map_err(|_| match s.trim().parse::<f64>() {
        Ok(v) if v < 0.0 => format!("{s} is negative: 0 (all cores) or a number of threads"),
        Ok(v) if v.is_finite() && v.fract() == 0.0 => format!("{s}: write the number of threads in digits"),
        Ok(_) => format!("{s} is not a whole number of threads"),
        Err(_) => format!("{s} is not a number: 0 (all cores) or a number of threads"),
    })?;
    // Many more workers than cores only add scheduling (1000 workers on a small frame ran for
    // minutes); the output is the same for any count.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let most = (4 * cores).max(4);
    if n > most {
        return Err(format!(
            "{n} is more than {most} threads (4x this machine's {cores} cores): the output is the same for any count, so use 0 (all cores) or fewer"
        ));
    }
    Ok(n)
}

/// `penumbra random`: writes the scene of a seed.
fn random(a: RandomArgs) -> Result<(), error::CliError> {
    use penumbra::scene::random::{generate, Params, LIGHT_KINDS};
    let mut lights = Vec::new();
    for k in a.light.iter().map(|k| k.trim()) {
        match LIGHT_KINDS.iter().find(|&&l| l == k) {
            Some(&l) => lights.push(l),
            None => return Err(format!("--light '{k}': one of {}", LIGHT_KINDS.join(", ")).into()),
        }
    }
    if lights.is_empty() {
        lights = LIGHT_KINDS.to_vec();
    }
    let params = Params {
        width: a.width,
        height: a.height,
        translucent: !a.opaque,
        lights,
        ..Params::default()
    };
    let r = generate(a.seed, &params);
    // Checked as any scene is before it is written.
    r.scene()?;
    let path = r.write(&a.out)?;
    println!("{}", path.display());
    for (name, _) in &r.meshes {
        println!("{}", a.out.join(name).display());
    }
    Ok(())
}
