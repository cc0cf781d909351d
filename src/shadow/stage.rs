//! What `penumbra dump` shows of a technique: its intermediate buffers, each a [`Stage`].

use crate::frame::Frame;
use crate::pipeline::{Rgba8, Surface};
use crate::Error;

/// An intermediate buffer of a technique, for `dump`.
pub enum Stage {
    /// Scalar data (depth, counts...) shown in false colour from `lo` to `hi`.
    Scalar {
        /// File-friendly name.
        name: String,
        /// The data.
        data: Surface<f32>,
        /// Value shown black.
        lo: f32,
        /// Value shown white.
        hi: f32,
    },
    /// A colour image.
    Color {
        /// File-friendly name.
        name: String,
        /// The image.
        data: Surface<Rgba8>,
    },
}

impl Stage {
    /// The stage's name.
    pub fn name(&self) -> &str {
        match self {
            Stage::Scalar { name, .. } | Stage::Color { name, .. } => name,
        }
    }

    /// A scalar stage of values in `[0, 1]` (depths, visibilities, masks), shown over that
    /// range.
    pub fn unit(name: impl Into<String>, data: Surface<f32>) -> Stage {
        Stage::Scalar {
            name: name.into(),
            data,
            lo: 0.0,
            hi: 1.0,
        }
    }

    /// Per-pixel values of `frame` (row-major) as a scalar stage shown from `lo` to `hi`.
    pub fn pixels(frame: &Frame, name: &str, data: Vec<f32>, lo: f32, hi: f32) -> Result<Stage, Error> {
        Ok(Stage::Scalar {
            name: name.into(),
            data: Surface::from_vec(frame.width(), frame.height(), data)?,
            lo,
            hi,
        })
    }
}
