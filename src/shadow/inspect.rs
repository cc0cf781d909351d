//! One pixel, step by step: what `penumbra inspect --pixel X,Y` prints. A technique answers
//! with a list of named [`Step`]s, each holding named [`Value`]s (structured data, never
//! text printed from inside the technique); the CLI prints them or emits them as JSON.

use glam::{Vec2, Vec3};

/// A value shown at one step.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "cli", derive(serde::Serialize))]
#[cfg_attr(feature = "cli", serde(untagged))]
pub enum Value {
    /// A number.
    Num(f64),
    /// A whole number (texel coordinates, counts, indices).
    Int(i64),
    /// Yes or no (a comparison's outcome).
    Bool(bool),
    /// A vector (positions, texture coordinates).
    Vec(Vec<f64>),
    /// Words (a face name, a mode).
    Text(String),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Num(x) => write!(f, "{x:.6}"),
            Value::Int(i) => write!(f, "{i}"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Vec(v) => {
                let parts: Vec<String> = v.iter().map(|x| format!("{x:.6}")).collect();
                write!(f, "({})", parts.join(", "))
            }
            Value::Text(s) => write!(f, "{s}"),
        }
    }
}

/// One step of a technique at one pixel: a name, a sentence of what happened, values.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "cli", derive(serde::Serialize))]
pub struct Step {
    /// Short name ("light-space position", "texel", "comparison").
    pub name: String,
    /// What the step did, in words (may be empty).
    pub what: String,
    /// Named values, in order.
    pub values: Vec<(String, Value)>,
}

impl Step {
    /// A step with no values yet.
    pub fn new(name: impl Into<String>, what: impl Into<String>) -> Step {
        Step {
            name: name.into(),
            what: what.into(),
            values: Vec::new(),
        }
    }

    /// Adds a number.
    pub fn num(mut self, key: &str, v: impl Into<f64>) -> Step {
        self.values.push((key.into(), Value::Num(v.into())));
        self
    }

    /// Adds a whole number.
    pub fn int(mut self, key: &str, v: impl TryInto<i64>) -> Step {
        self.values
            .push((key.into(), Value::Int(v.try_into().unwrap_or(i64::MAX))));
        self
    }

    /// Adds a yes/no.
    pub fn flag(mut self, key: &str, v: bool) -> Step {
        self.values.push((key.into(), Value::Bool(v)));
        self
    }

    /// Adds a 2D vector.
    pub fn vec2(mut self, key: &str, v: Vec2) -> Step {
        self.values.push((key.into(), Value::Vec(vec![v.x as f64, v.y as f64])));
        self
    }

    /// Adds a 3D vector.
    pub fn vec3(mut self, key: &str, v: Vec3) -> Step {
        self.values
            .push((key.into(), Value::Vec(vec![v.x as f64, v.y as f64, v.z as f64])));
        self
    }

    /// Adds words.
    pub fn text(mut self, key: &str, v: impl Into<String>) -> Step {
        self.values.push((key.into(), Value::Text(v.into())));
        self
    }
}

/// The step every technique's answer ends with: the visibility it returned at the pixel.
pub fn result(v: f32) -> Step {
    Step::new("result", "the visibility the technique returned here").num("visibility", v)
}

/// `inspect`'s answer from a technique's per-pixel function, the one its image comes from:
/// `f` runs with a recording trace, and its value closes the steps as the [`result`].
pub fn explain(f: impl FnOnce(&mut Steps) -> f32) -> Vec<Step> {
    let mut t = Steps::default();
    let v = f(&mut t);
    t.0.push(result(v));
    t.0
}

/// [`explain`] of a per-pixel function that may have nothing to say (`None`: no run, or no
/// geometry at the pixel, and no steps): its steps, closed by its value as the [`result`]
/// where there is one.
pub fn closed(f: impl FnOnce(&mut Steps) -> Option<f32>) -> Vec<Step> {
    let mut t = Steps::default();
    if let Some(v) = f(&mut t) {
        t.0.push(result(v));
    }
    t.0
}

/// Where a technique's per-pixel code reports its steps: [`Steps`] records them (for
/// `inspect`), [`NoTrace`] drops them at no cost (the timed pass), so one function computes
/// both and the explanation can never disagree with the image.
pub trait Trace {
    /// Records the step `f` builds (not called at all by [`NoTrace`]).
    fn step(&mut self, f: impl FnOnce() -> Step);

    /// Whether steps are recorded: a loop keeps what its step will show only then (false
    /// for [`NoTrace`], where the check compiles away).
    #[inline(always)]
    fn records(&self) -> bool {
        true
    }
}

/// Drops every step.
pub struct NoTrace;

impl Trace for NoTrace {
    #[inline(always)]
    fn step(&mut self, _: impl FnOnce() -> Step) {}

    #[inline(always)]
    fn records(&self) -> bool {
        false
    }
}

/// Records every step.
#[derive(Default)]
pub struct Steps(pub Vec<Step>);

impl Trace for Steps {
    fn step(&mut self, f: impl FnOnce() -> Step) {
        self.0.push(f());
    }
}
