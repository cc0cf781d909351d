//! Sample distribution shadow maps' light side (Lauritzen, Salvi and Lefohn 2011; RTR 7.4.1):
//! the cascades' range and splits set from the depths the camera actually sees instead of
//! its near and far planes.
//!
//! - [`reduce`]: the G-buffer's depth reduced in parallel to its least and greatest covered
//!   value ([`compute::min_max`]), linearised to view depths (`d = f n / (f - z (f - n))`),
//!   and, for [`Partition::Histogram`], a histogram of the linear view depths over that range
//!   ([`compute::histogram_of`], [`BINS`] bins).
//! - [`Partition::Minmax`]: the splits (uniform, log or practical) over the tight range
//!   instead of the camera's planes: the paper's "log" partitioning on tight bounds.
//! - [`Partition::Histogram`]: the same splits, and each cascade fitted to the part of its
//!   slice where samples are: its depth range tightened to the first and last occupied bins
//!   within it (a slice with a gap in the sample distribution, such as open sky between a
//!   near wall and the horizon, spends no texels on the gap; the paper's "adaptive"
//!   partitioning). Selection still uses the slices' full ranges, so no point falls between
//!   cascades.
//! - Latency ([`super::cascades::Cascades::latency`]): real engines read the reduction back
//!   a frame late; with `latency=1` the cascades use the previous frame's samples, so after a
//!   sudden view change (a cut, or turning from a near wall to the horizon) the new frame's
//!   far points lie beyond every cascade and their shadows are lost for one frame.

use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::{compute, Pipeline};
use crate::Error;
use glam::Vec4;

choice_enum! {
    /// Where the cascades' range and splits come from.
    pub enum Partition {
        /// The camera's near and far planes clamped to the scene box (cascaded shadow maps).
        View = "view",
        /// The least and greatest view depth the camera sees (SDSM's reduction).
        Minmax = "minmax",
        /// The reduction's range, each cascade fitted to the occupied part of its slice by a
        /// depth histogram (SDSM's adaptive partitioning).
        Histogram = "histogram",
    }
}

/// Bins of the view-depth histogram.
pub const BINS: usize = 256;

/// The view depths one frame's camera sees: their range and (for [`Partition::Histogram`])
/// their histogram over it.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthSamples {
    /// Least view depth of a covered pixel.
    pub near: f32,
    /// Greatest view depth of a covered pixel.
    pub far: f32,
    /// Covered pixels per bin of `[near, far]` ([`BINS`] equal bins; empty unless asked).
    pub histogram: Vec<u64>,
    /// The frame the samples were taken from (its index on the camera path).
    pub frame: usize,
}

impl DepthSamples {
    /// The part of view-depth range `[a, b]` that holds samples: from the lower edge of the
    /// first occupied bin that meets it to the upper edge of the last, clamped to `[a, b]`;
    /// `None` without a histogram or without samples there.
    pub fn occupied(&self, a: f32, b: f32) -> Option<(f32, f32)> {
        let n = self.histogram.len();
        if n == 0 || self.far <= self.near {
            return None;
        }
        // The histogram's bins span [near, far.next_up()) (`reduce`).
        let w = (self.far.next_up() - self.near) / n as f32;
        let bin = |d: f32| (((d - self.near) / w).floor().max(0.0) as usize).min(n - 1);
        let (i0, i1) = (bin(a), bin(b));
        let first = (i0..=i1).find(|&i| self.histogram[i] > 0)?;
        let last = (i0..=i1).rev().find(|&i| self.histogram[i] > 0)?;
        let lo = (self.near + first as f32 * w).max(a);
        let hi = (self.near + (last + 1) as f32 * w).min(b);
        (hi > lo).then_some((lo, hi))
    }
}

/// The view depths `frame`'s camera sees ([`DepthSamples`]), with a histogram when
/// `histogram`; `None` where no pixel is covered.
pub fn reduce(p: &Pipeline, frame: &Frame, histogram: bool) -> Result<Option<DepthSamples>, Error> {
    let cam = &frame.camera;
    let (n, f) = (cam.near, cam.far);
    let linear = move |z: f32| f * n / (f - z * (f - n));
    // Four at a time for the histogram (the same operations per lane); background texels
    // (depth 1) are NaN, not counted.
    let linear4 = move |z: Vec4| {
        let d = Vec4::splat(f * n) / (Vec4::splat(f) - z * Vec4::splat(f - n));
        Vec4::select(z.cmplt(Vec4::ONE), d, Vec4::NAN)
    };
    let depth = &frame.gbuffer.depth;
    let Some((z0, z1)) = compute::min_max(p, depth, |z| z < 1.0) else {
        return Ok(None);
    };
    let (near, far) = (linear(z0), linear(z1));
    let histogram = if histogram && far > near {
        compute::histogram_of(p, depth, BINS, near, far.next_up(), linear4)?
    } else {
        Vec::new()
    };
    Ok(Some(DepthSamples {
        near,
        far,
        histogram,
        frame: frame.index,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn occupied_keeps_the_bins_with_samples() {
        // Samples at 2-3 m and 40-50 m of a 2..100 m range: a slice over the gap shrinks to
        // the samples' bins, a slice without samples has none.
        let (near, far) = (2.0f32, 100.0f32);
        let w = (far.next_up() - near) / BINS as f32;
        let mut histogram = vec![0u64; BINS];
        for d in [2.0f32, 2.5, 3.0, 40.0, 45.0, 50.0] {
            histogram[((d - near) / w) as usize] += 1;
        }
        let s = DepthSamples {
            near,
            far,
            histogram,
            frame: 0,
        };
        let (a, b) = s.occupied(2.0, 30.0).unwrap();
        assert!(a == 2.0 && (3.0..3.0 + w).contains(&b), "{a} {b}");
        let (a, b) = s.occupied(10.0, 60.0).unwrap();
        assert!(
            (40.0 - w..=40.0).contains(&a) && (50.0..=50.0 + w).contains(&b),
            "{a} {b}"
        );
        assert_eq!(s.occupied(5.0, 35.0), None);
        let none = DepthSamples {
            histogram: Vec::new(),
            ..s
        };
        assert_eq!(none.occupied(2.0, 30.0), None);
    }
}
