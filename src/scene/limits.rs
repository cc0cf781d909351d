//! What a scene may hold: the largest image, coordinates, fields of view, depth ratio,
//! file sizes, triangles and keyframes that every scene source (TOML, OBJ, glTF, code)
//! is checked against.

/// Largest image side a scene may ask for.
pub const MAX_RESOLUTION: u32 = 8192;

/// Largest absolute world coordinate (camera, lights, translations, vertices after their
/// transforms): beyond it products of coordinates overflow `f32` in the techniques' and the
/// ray tracer's arithmetic.
pub const MAX_COORDINATE: f32 = 1e7;

/// The fields of view (a camera's `fov`, a spot light's `angle`) a scene may use, in degrees:
/// narrower ones overflow the projection (a tangent of 1e-32), wider ones are not a frustum.
pub const FOV_DEGREES: std::ops::RangeInclusive<f32> = 0.01..=179.9;
/// [`FOV_DEGREES`] as errors print it.
pub const FOV_TEXT: &str = "[0.01, 179.9]";

/// The largest far / near a camera may have: beyond it the depth buffer cannot tell
/// surfaces apart (a `near` of 1e-38 made a flat image).
pub const MAX_DEPTH_RATIO: f32 = 1e6;

/// Largest scene file read (bytes): scene files are short; a larger "scene" is not one.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Default scene-wide triangle budget, counted from the objects' parameters before any is
/// tessellated; the environment variable `PENUMBRA_MAX_TRIANGLES` raises or lowers it.
pub const MAX_TRIANGLES: u64 = 20_000_000;

/// Largest camera path.
pub const MAX_KEYFRAMES: usize = 1000;

/// The triangle budget in force ([`MAX_TRIANGLES`] or `PENUMBRA_MAX_TRIANGLES`).
pub fn triangle_budget() -> u64 {
    std::env::var("PENUMBRA_MAX_TRIANGLES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(MAX_TRIANGLES)
}
