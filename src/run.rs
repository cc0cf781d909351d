//! Running techniques against the reference: the reference (through a cache the caller
//! provides), timing with warm-up and median, metrics, camera paths frame by frame. Returns
//! data and writes no files: the report ([`crate::report`]) and the CLI do that.

use crate::frame::{self, Frame};
use crate::hash::{fnv1a, FNV_OFFSET};
use crate::metrics::{self, Errors};
use crate::pipeline::{Pipeline, Rgba8, Surface};
use crate::reference::{Reference, ReferenceOptions};
use crate::scene::{Scene, SceneClass};
use crate::shadow::{self, Family};
use crate::visibility::Visibility;
use crate::Error;
use std::borrow::Cow;
use std::time::Instant;

/// Bump when the reference's algorithm changes, so caches made before do not match.
const REFERENCE_REVISION: u32 = 3;

/// Key of a cached reference: the scene file's bytes, the geometry and the shading points
/// actually built from it (so a change to a mesh generator or to the G-buffer cannot reuse a
/// stale file), the frame, the light and the options.
pub fn reference_key(scene_text: &str, frame: &Frame, light: usize, opts: &ReferenceOptions) -> u64 {
    let mut h = fnv1a(FNV_OFFSET, scene_text.as_bytes());
    let words = |h: u64, it: &mut dyn Iterator<Item = u32>| it.fold(h, |h, w| fnv1a(h, &w.to_le_bytes()));
    for o in &frame.scene.objects {
        h = words(
            h,
            &mut o.mesh.positions.iter().flat_map(|p| p.to_array().map(f32::to_bits)),
        );
        h = words(h, &mut o.mesh.indices.iter().copied());
    }
    h = words(
        h,
        &mut frame
            .gbuffer
            .position
            .data()
            .iter()
            .zip(frame.gbuffer.normal.data())
            .flat_map(|(p, n)| [p.to_array(), n.to_array()].concat().into_iter().map(f32::to_bits)),
    );
    // Materials and lights (a glTF scene's come from the glTF file, not the scene text).
    h = fnv1a(h, format!("{:?}", frame.scene.materials).as_bytes());
    h = fnv1a(h, format!("{:?}", frame.scene.lights).as_bytes());
    // The frame's own light: a light path moves it from frame to frame under one G-buffer.
    h = fnv1a(h, format!("{:?}", frame.light).as_bytes());
    h = fnv1a(
        h,
        format!(
            "{light}/{}/{opts:?}/{}/{REFERENCE_REVISION}",
            frame.index,
            env!("CARGO_PKG_VERSION")
        )
        .as_bytes(),
    );
    h
}

/// Where reference images are kept between runs (keyed by [`reference_key`]).
pub trait ReferenceCache {
    /// The cached image of `pixels` pixels under `key`, if any.
    fn get(&self, key: u64, pixels: usize) -> Option<Visibility>;
    /// Stores an image under `key`.
    fn put(&self, key: u64, v: &Visibility) -> Result<(), Error>;
}

/// Reference visibility of a frame, from `cache` when it has it (`None`: no caching).
/// Returns the visibility, the seconds spent computing it and the rays traced (0 when cached).
pub fn reference(
    p: &Pipeline,
    frame: &Frame,
    key: u64,
    cache: Option<&dyn ReferenceCache>,
) -> Result<(Visibility, f64, u64), Error> {
    let n = (frame.width() * frame.height()) as usize;
    if let Some(v) = cache.and_then(|c| c.get(key, n)) {
        return Ok((v, 0.0, 0));
    }
    let t = Instant::now();
    let r = p.install(|| Reference::new(frame.scene));
    let pts = frame.points();
    let v = p.install(|| r.visibility(pts, frame.width() as usize, &frame.light, &ReferenceOptions::default()));
    let secs = t.elapsed().as_secs_f64();
    if let Some(c) = cache {
        c.put(key, &v)?;
    }
    Ok((v, secs, r.rays_traced()))
}

/// One technique run on one scene.
#[derive(Clone, Debug, Default)]
pub struct RunResult {
    /// Position in the sweep's run list (0 outside a sweep): the order of the CSV's rows,
    /// which merging shards restores.
    pub index: usize,
    /// Scene name.
    pub scene: String,
    /// The scene's class (which error judges it on the charts).
    pub class: SceneClass,
    /// Technique name.
    pub technique: String,
    /// The technique's family.
    pub family: Family,
    /// Its settings, `k=v;k=v` (empty: defaults).
    pub settings: String,
    /// Errors against the reference.
    pub errors: Errors,
    /// Errors over the pixels whose visible surface is transparent
    /// ([`Frame::transparent_mask`]): the transmittance on the transparent objects themselves
    /// (0 pixels in scenes without visible transparent surfaces).
    pub transparent: Errors,
    /// Median milliseconds of the technique's visibility call.
    pub ms: f64,
    /// Worker threads.
    pub threads: usize,
    /// Flicker along the camera path (0 without a path).
    pub flicker: f64,
    /// Visibility discontinuities in the penumbra ([`metrics::discontinuity`]).
    pub discontinuity: f64,
    /// Plateaus of one partial visibility in the penumbra ([`metrics::banding`]).
    pub banding: f64,
    /// Median footprint of the light's map texels in camera pixels over the metric's pixels
    /// ([`shadow::light::texel_footprint`]; 1 is ideal, above 1 the map is magnified); NaN
    /// for techniques without maps.
    pub texel_px: f64,
    /// The footprint's 99th percentile (NaN without maps).
    pub texel_px_p99: f64,
    /// Whether the technique reported work counters on the path's frames (their chart is
    /// worth showing).
    pub counted_path: bool,
    /// The technique's own pass times (ms) of its last run on the first frame.
    pub passes: Vec<(String, f64)>,
    /// The technique's work counters on the first frame.
    pub counters: Vec<(String, f64)>,
}

impl RunResult {
    /// Label for charts and tables.
    pub fn label(&self) -> String {
        label(&self.technique, &self.settings)
    }

    /// The error that judges this run on its scene class's chart ([`SceneClass::metric`]).
    pub fn class_error(&self) -> f64 {
        match self.class {
            SceneClass::Hard => self.errors.wrong_pct,
            SceneClass::Area => self.errors.penumbra_rmse,
            SceneClass::Transparent => self.errors.rmse,
        }
    }
}

/// Settings as the CSV and labels write them: `k=v;k=v` (empty: the defaults).
pub fn settings_text(sets: &[(String, String)]) -> String {
    sets.iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(";")
}

/// A technique setting's label for charts and tables: `technique [settings]`, or the name
/// alone for the defaults.
pub fn label(technique: &str, settings: &str) -> String {
    if settings.is_empty() {
        technique.to_string()
    } else {
        format!("{technique} [{settings}]")
    }
}

/// Runs `t` on `frame`: after one warm-up call when `warm_up`, `reps` timed calls (at least
/// one); returns the last visibility and the median time in milliseconds.
pub fn time_technique(
    p: &Pipeline,
    frame: &Frame,
    t: &mut dyn shadow::ShadowTechnique,
    warm_up: bool,
    reps: usize,
) -> Result<(Visibility, f64), Error> {
    if warm_up {
        t.visibility(p, frame)?;
    }
    let mut v = Visibility::Scalar(Vec::new());
    let mut times = Vec::new();
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        v = t.visibility(p, frame)?;
        times.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    if v.len() != (frame.width() * frame.height()) as usize {
        return Err(Error::input(format!(
            "technique '{}' returned {} values for a {}x{} frame",
            t.name(),
            v.len(),
            frame.width(),
            frame.height()
        )));
    }
    Ok((v, metrics::median(times)))
}

/// One frame of a camera path: the technique's time and its work counters.
#[derive(Clone, Debug)]
pub struct PathFrame {
    /// Milliseconds of the technique's visibility call.
    pub ms: f64,
    /// The technique's counters (name, value).
    pub counters: Vec<(&'static str, f64)>,
}

/// The first frame of a run, kept for images.
pub struct FirstFrame {
    /// Frame size.
    pub width: u32,
    /// Frame size.
    pub height: u32,
    /// The technique's visibility.
    pub visibility: Visibility,
    /// The reference's.
    pub reference: Visibility,
    /// The metric mask.
    pub mask: Vec<bool>,
    /// The final shaded image.
    pub shaded: Surface<Rgba8>,
}

/// Everything one [`render`] measures.
pub struct RenderOutput {
    /// Metrics and time.
    pub result: RunResult,
    /// Seconds the reference took (0 when cached).
    pub reference_secs: f64,
    /// Shadow rays the reference traced (0 when cached).
    pub reference_rays: u64,
    /// The technique's own pass times of its last run on the first frame (ms).
    pub pass_times: Vec<(&'static str, f64)>,
    /// The technique's counters on the first frame.
    pub counters: Vec<(&'static str, f64)>,
    /// The technique's notes on the first frame (irregular input and how it was handled).
    pub notes: Vec<String>,
    /// Time and counters of every frame of the camera path (one entry without a path).
    pub path: Vec<PathFrame>,
    /// The first frame's images' data.
    pub first: FirstFrame,
}

/// A scene's frames (one per camera-path keyframe, or one) with their references and metric
/// masks: built once and shared by every technique run on the scene.
pub struct Prepared<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Per frame: kept (the frame, its reference and its metric mask), or streamed (rebuilt on
    /// use, its reference from the cache or traced again; see [`Prepared::new`]).
    frames: Vec<PreparedFrame<'a>>,
    /// Where streamed frames' references are read back from.
    cache: Option<&'a dyn ReferenceCache>,
    /// Seconds the references took (0 when cached).
    pub reference_secs: f64,
    /// Shadow rays the references traced (0 when cached).
    pub reference_rays: u64,
}

enum PreparedFrame<'a> {
    Kept(Box<(Frame<'a>, Visibility, Vec<bool>)>),
    Streamed { key: u64 },
}

/// Frames kept by [`Prepared`] at most, in pixels summed over the path: beyond it no frame is
/// kept (each is rebuilt for each run, its reference read from the cache), so that a long path
/// of large frames holds one frame at a time.
const KEPT_FRAME_PIXELS: u64 = 16 << 20;

/// Told of long work as it goes: `(what, done, total)`.
pub type Progress<'p> = &'p dyn Fn(&str, usize, usize);

impl<'a> Prepared<'a> {
    /// Builds `scene`'s frames and their references (through `cache`).
    pub fn new(
        p: &Pipeline,
        scene: &'a Scene,
        scene_text: &str,
        cache: Option<&'a dyn ReferenceCache>,
    ) -> Result<Prepared<'a>, Error> {
        Self::new_with_progress(p, scene, scene_text, cache, &|_, _, _| {})
    }

    /// [`Prepared::new`], telling `progress` of each frame's reference.
    pub fn new_with_progress(
        p: &Pipeline,
        scene: &'a Scene,
        scene_text: &str,
        cache: Option<&'a dyn ReferenceCache>,
        progress: Progress,
    ) -> Result<Prepared<'a>, Error> {
        let count = scene.frame_count();
        let pixels = scene.camera.width as u64 * scene.camera.height as u64 * count as u64;
        let keep = pixels <= KEPT_FRAME_PIXELS;
        let mut frames = Vec::with_capacity(count);
        let (mut secs, mut rays) = (0.0, 0);
        for i in 0..count {
            progress("reference", i, count);
            let f = frame::frame(p, scene, 0, i)?;
            let key = reference_key(scene_text, &f, 0, &ReferenceOptions::default());
            let (r, s, n) = reference(p, &f, key, cache)?;
            secs += s;
            rays += n;
            if keep {
                let mask = f.metric_mask();
                frames.push(PreparedFrame::Kept(Box::new((f, r, mask))));
            } else {
                frames.push(PreparedFrame::Streamed { key });
            }
        }
        Ok(Prepared {
            scene,
            frames,
            cache,
            reference_secs: secs,
            reference_rays: rays,
        })
    }
}

/// Renders `scene` with a technique against the reference: metrics of the first frame, and
/// for camera paths every frame (for the flicker metric and the path's time and counters).
#[allow(clippy::too_many_arguments)]
pub fn render(
    p: &Pipeline,
    scene: &Scene,
    scene_text: &str,
    name: &str,
    sets: &[(String, String)],
    reps: usize,
    cache: Option<&dyn ReferenceCache>,
) -> Result<RenderOutput, Error> {
    let prepared = Prepared::new(p, scene, scene_text, cache)?;
    render_prepared(p, &prepared, name, sets, reps)
}

/// [`render`] on a scene's [`Prepared`] frames; the output's reference time and rays are the
/// preparation's.
pub fn render_prepared(
    p: &Pipeline,
    prepared: &Prepared,
    name: &str,
    sets: &[(String, String)],
    reps: usize,
) -> Result<RenderOutput, Error> {
    render_prepared_with_progress(p, prepared, name, sets, reps, &|_, _, _| {})
}

/// [`render_prepared`], telling `progress` of each frame of the camera path.
pub fn render_prepared_with_progress(
    p: &Pipeline,
    prepared: &Prepared,
    name: &str,
    sets: &[(String, String)],
    reps: usize,
    progress: Progress,
) -> Result<RenderOutput, Error> {
    let scene = prepared.scene;
    let mut first = None;
    let mut pass_times = Vec::new();
    let mut notes = Vec::new();
    let mut path = Vec::new();
    let mut t = shadow::registry::create(name, sets)?;
    let mut flicker = metrics::Flicker::default();
    // The previous frame's technique, reference and mask (for flicker): one frame is kept.
    // (Kept frames' reference and mask are borrowed; a streamed frame's are moved in.)
    let mut prev: Option<(Visibility, Cow<Visibility>, Cow<[bool]>)> = None;
    for (i, pf) in prepared.frames.iter().enumerate() {
        progress(name, i, prepared.frames.len());
        let built;
        let (f, r, mask): (&Frame, Cow<Visibility>, Cow<[bool]>) = match pf {
            PreparedFrame::Kept(k) => (&k.0, Cow::Borrowed(&k.1), Cow::Borrowed(&k.2[..])),
            PreparedFrame::Streamed { key } => {
                built = frame::frame(p, scene, 0, i)?;
                let (r, _, _) = reference(p, &built, *key, prepared.cache)?;
                let mask = built.metric_mask();
                (&built, Cow::Owned(r), Cow::Owned(mask))
            }
        };
        let (r_ref, mask_ref): (&Visibility, &[bool]) = (&r, &mask);
        // Frame 0: a warm-up and `reps` timed calls (`reps` 0: one call, as the reference
        // needs); later path frames: one call each, the technique already warm.
        let (v, ms) = time_technique(p, f, t.as_mut(), i == 0 && reps > 0, if i == 0 { reps } else { 1 })?;
        if i == 0 {
            pass_times = t.timings();
            notes = t.notes();
        }
        path.push(PathFrame {
            ms,
            counters: t.counters(),
        });
        if i == 0 {
            first = Some((
                metrics::compare(&v, r_ref, mask_ref),
                metrics::compare(&v, r_ref, &f.transparent_mask()),
                (
                    ms,
                    metrics::discontinuity(&v, r_ref, mask_ref, f.gbuffer.object.data(), f.width() as usize),
                    metrics::banding(&v, r_ref, mask_ref, f.gbuffer.object.data(), f.width() as usize),
                    match t.light_views() {
                        views if views.is_empty() => (f64::NAN, f64::NAN),
                        views => metrics::footprint(&shadow::light::texel_footprint(f, &views), mask_ref),
                    },
                ),
                FirstFrame {
                    width: f.width(),
                    height: f.height(),
                    shaded: frame::shade(f, &v),
                    visibility: v.clone(),
                    reference: r_ref.clone(),
                    mask: mask_ref.to_vec(),
                },
            ));
        }
        if let Some((pv, pr, pm)) = &prev {
            flicker.add((pv, pr, pm), (&v, r_ref, mask_ref));
        }
        if prepared.frames.len() > 1 {
            prev = Some((v, r, mask));
        }
    }
    let (errors, transparent, (ms, discontinuity, banding, (texel_px, texel_px_p99)), first) =
        first.expect("at least one frame");
    let settings = settings_text(sets);
    let result = RunResult {
        index: 0,
        scene: scene.name.clone(),
        class: scene.class(),
        technique: name.into(),
        family: Family::of(name).unwrap_or(Family::Reference),
        settings,
        errors,
        transparent,
        ms,
        threads: p.threads(),
        flicker: flicker.value(),
        discontinuity,
        banding,
        texel_px,
        texel_px_p99,
        counted_path: path.len() > 1 && path.iter().any(|f| !f.counters.is_empty()),
        passes: pass_times.iter().map(|&(k, v)| (k.to_string(), v)).collect(),
        counters: path
            .first()
            .map(|f| f.counters.iter().map(|&(k, v)| (k.to_string(), v)).collect())
            .unwrap_or_default(),
    };
    Ok(RenderOutput {
        result,
        reference_secs: prepared.reference_secs,
        reference_rays: prepared.reference_rays,
        pass_times,
        counters: path.first().map(|f| f.counters.clone()).unwrap_or_default(),
        notes,
        path,
        first,
    })
}
