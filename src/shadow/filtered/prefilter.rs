//! The filtered maps' one prefiltering module: what is done to the stored planes between the
//! light pass and the lookups, and the lookup that matches it. Every filter is one of the
//! pipeline's compute helpers ([`crate::pipeline::compute`]): parallel over rows and
//! deterministic.
//!
//! - `none`: the stored planes, read bilinearly (hardware filtering only).
//! - `box`, `gaussian`: a separable blur `2 radius + 1` taps wide (Gaussian sigma `radius /
//!   2`), then bilinear reads; in log space for exponential maps (Salvi 2008), so their
//!   exponentials are never formed.
//! - `mips`: a mip chain (2x2 averages; in log space for exponential maps) read trilinearly,
//!   the level chosen from the filter width, at least the kernel's and the pixel's footprint
//!   (as a GPU's derivatives give it).
//! - `sat`: a summed-area table (Crow 1984; Lauritzen 2007 for VSM) and a box of any width at
//!   each lookup, its corners interpolated bilinearly so the width is continuous. Precision:
//!   the sums are `f64` ([`SatSums::F64`], the care chosen here of the three Lauritzen names:
//!   offset depths, wider sums, compensated sums) or plain `f32` ([`SatSums::F32`]), to show
//!   that at 4096² the `f32` sums lose the shadow.

use super::Storage;
use crate::choice_enum;
use crate::math;
use crate::pipeline::compute::{
    box_weights, gaussian_weights, log_mix, log_space_blur, separable_blur, summed_area_table, summed_area_table_f32,
};
use crate::pipeline::sampler::{footprint, sample_bilinear, Address};
use crate::pipeline::surface::average_vec4;
use crate::pipeline::*;
use crate::Error;
use glam::{DVec4, Vec2, Vec4};

choice_enum! {
    /// How a filtered map is prefiltered.
    pub enum Prefilter {
        /// No prefilter: bilinear lookups only.
        None = "none",
        /// A separable box blur.
        Box = "box",
        /// A separable Gaussian blur.
        Gaussian = "gaussian",
        /// A mip chain read trilinearly.
        Mips = "mips",
        /// A summed-area table read as a box of any width.
        Sat = "sat",
    }
}

choice_enum! {
    /// What a summed-area table sums in.
    pub enum SatSums {
        /// 64-bit floats.
        F64 = "f64",
        /// 32-bit floats, naively.
        F32 = "f32",
    }
}

/// A view's planes after the prefilter.
pub enum Prefiltered {
    /// Blurred (or stored) planes, read bilinearly.
    Plain(Vec<Surface<Vec4>>),
    /// Mip chains, read trilinearly.
    Mips(Vec<MipChain<Vec4>>),
    /// Summed-area tables, read as boxes.
    Sat(Vec<Surface<DVec4>>),
}

/// What one lookup read.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SampleInfo {
    /// The mip level (mip chains).
    pub level: Option<f32>,
    /// The box's width in texels (summed-area tables).
    pub width: Option<f32>,
}

impl SampleInfo {
    /// What the lookup did, in words.
    pub fn what(&self) -> &'static str {
        match (self.level, self.width) {
            (Some(_), _) => "two mip levels read bilinearly and blended at the level of the filter width (trilinear)",
            (_, Some(_)) => "a box of the filter width from the summed-area table (four corners, each bilinear)",
            _ => "the prefiltered planes read bilinearly at the point",
        }
    }
}

impl Prefiltered {
    /// Prefilters `planes` with `kind` of `radius` (summed-area tables in `sums`; in log
    /// space where `log`), the result rounded to `storage` as its target would store it
    /// (a summed-area table keeps its sums' precision). Returns the planes and the texels
    /// the filter read.
    pub fn build(
        p: &Pipeline,
        planes: &[Surface<Vec4>],
        kind: Prefilter,
        radius: u32,
        sums: SatSums,
        log: bool,
        storage: Storage,
    ) -> Result<(Prefiltered, u64), Error> {
        let r = radius as usize;
        let texels: u64 = planes.iter().map(|s| s.data().len() as u64).sum();
        let store = |s: Surface<Vec4>| match storage {
            // Every f32 is stored as it is.
            Storage::F32 => s,
            _ => s.map(|v| Vec4::from_array(v.to_array().map(|c| storage.store(c)))),
        };
        Ok(match kind {
            Prefilter::None => (Prefiltered::Plain(planes.to_vec()), 0),
            Prefilter::Box | Prefilter::Gaussian => {
                let w = if kind == Prefilter::Box {
                    box_weights(r)
                } else {
                    gaussian_weights(r)
                };
                let out = planes
                    .iter()
                    .map(|s| {
                        let b = if log {
                            // Only the first channel holds a logarithm (ESM).
                            let x = log_space_blur(p, &s.map(|v| v.x), &w)?;
                            x.map(|x| Vec4::new(x, 0.0, 0.0, 0.0))
                        } else {
                            separable_blur(p, s, &w)?
                        };
                        Ok(store(b))
                    })
                    .collect::<Result<Vec<_>, PipelineError>>()?;
                (Prefiltered::Plain(out), texels * 2 * w.len() as u64)
            }
            Prefilter::Mips => {
                let chains: Vec<MipChain<Vec4>> = planes
                    .iter()
                    .map(|s| {
                        if log {
                            MipChain::build(s.clone(), |t| {
                                let wt = 1.0 / t.len() as f32;
                                let x = t.iter().fold(f32::NEG_INFINITY, |a, v| log_mix(a, 1.0, v.x, wt));
                                Vec4::new(storage.store(x), 0.0, 0.0, 0.0)
                            })
                        } else {
                            MipChain::build(s.clone(), |t| {
                                let a = average_vec4(t);
                                Vec4::from_array(a.to_array().map(|c| storage.store(c)))
                            })
                        }
                    })
                    .collect();
                (Prefiltered::Mips(chains), texels * 4 / 3)
            }
            Prefilter::Sat => {
                let tables = planes
                    .iter()
                    .map(|s| match sums {
                        SatSums::F64 => summed_area_table(p, s),
                        SatSums::F32 => summed_area_table_f32(p, s),
                    })
                    .collect();
                (Prefiltered::Sat(tables), texels * 2)
            }
        })
    }

    /// The blurred or stored planes (`None` for mip chains and summed-area tables).
    pub fn plain(&self) -> Option<&[Surface<Vec4>]> {
        match self {
            Prefiltered::Plain(v) => Some(v),
            _ => None,
        }
    }

    /// The filtered planes at `uv` into `out` (one entry per plane), with a filter `width`
    /// texels wide where the kind has a width (mips, summed-area tables); blurred planes read
    /// bilinearly (in log space where `log`).
    pub fn sample(&self, uv: Vec2, width: f32, log: bool, out: &mut [Vec4]) -> SampleInfo {
        match self {
            Prefiltered::Plain(planes) => {
                for (o, s) in out.iter_mut().zip(planes) {
                    *o = bilinear(s, uv, log);
                }
                SampleInfo {
                    level: None,
                    width: None,
                }
            }
            Prefiltered::Mips(chains) => {
                let n = chains[0].level_count();
                let level = math::log2(width.max(1.0)).clamp(0.0, (n - 1) as f32);
                let (l0, f) = (level.floor() as usize, level.fract());
                let l1 = (l0 + 1).min(n - 1);
                for (o, c) in out.iter_mut().zip(chains) {
                    let a = bilinear(&c.levels()[l0], uv, log);
                    let b = bilinear(&c.levels()[l1], uv, log);
                    *o = if log {
                        Vec4::new(log_mix(a.x, 1.0 - f, b.x, f), 0.0, 0.0, 0.0)
                    } else {
                        a * (1.0 - f) + b * f
                    };
                }
                SampleInfo {
                    level: Some(level),
                    width: None,
                }
            }
            Prefiltered::Sat(tables) => {
                for (o, s) in out.iter_mut().zip(tables) {
                    *o = sat_average(s, uv, width);
                }
                SampleInfo {
                    level: None,
                    width: Some(width),
                }
            }
        }
    }
}

/// Bilinear read of `s` at `uv` (edges clamped); in log space (first channel) where `log`.
#[inline(always)]
fn bilinear(s: &Surface<Vec4>, uv: Vec2, log: bool) -> Vec4 {
    if !log {
        return sample_bilinear(s, uv, Address::Clamp);
    }
    let (_, _, fx, fy) = footprint((s.width(), s.height()), uv);
    let [a, b, c, d] = crate::pipeline::sampler::gather(s, uv, Address::Clamp);
    let top = log_mix(a.x, 1.0 - fx, b.x, fx);
    let bottom = log_mix(c.x, 1.0 - fx, d.x, fx);
    Vec4::new(log_mix(top, 1.0 - fy, bottom, fy), 0.0, 0.0, 0.0)
}

/// The average of the texels under a `width`-texel box centred at `uv`, from summed-area
/// table `sat`: the integral of the map up to each corner (bilinear between the table's
/// entries, which are the integrals up to whole texel edges), the box clipped to the map and
/// divided by its clipped area.
fn sat_average(sat: &Surface<DVec4>, uv: Vec2, width: f32) -> Vec4 {
    let (w, h) = (sat.width() as f64, sat.height() as f64);
    let half = width.max(1.0) as f64 * 0.5;
    let (cx, cy) = (uv.x as f64 * w, uv.y as f64 * h);
    let (x0, x1) = ((cx - half).clamp(0.0, w), (cx + half).clamp(0.0, w));
    let (y0, y1) = ((cy - half).clamp(0.0, h), (cy + half).clamp(0.0, h));
    let area = (x1 - x0) * (y1 - y0);
    if area <= 0.0 {
        // A box wholly off the map: its nearest texel.
        let (tx, ty) = ((cx.clamp(0.0, w - 1.0)) as u32, (cy.clamp(0.0, h - 1.0)) as u32);
        return sat_box(sat, tx as i64, ty as i64, tx as i64, ty as i64).as_vec4();
    }
    // The integral up to edge coordinates (X, Y): I(i, j) = sat(i - 1, j - 1), 0 at edge 0.
    let edge = |i: i64, j: i64| {
        if i <= 0 || j <= 0 {
            DVec4::ZERO
        } else {
            sat.at((i - 1) as u32, (j - 1) as u32)
        }
    };
    let integral = |x: f64, y: f64| {
        let (i, j) = (x.floor() as i64, y.floor() as i64);
        let (fx, fy) = (x - i as f64, y - j as f64);
        let (i1, j1) = ((i + 1).min(w as i64), (j + 1).min(h as i64));
        let top = edge(i, j) * (1.0 - fx) + edge(i1, j) * fx;
        let bottom = edge(i, j1) * (1.0 - fx) + edge(i1, j1) * fx;
        top * (1.0 - fy) + bottom * fy
    };
    let sum = integral(x1, y1) - integral(x0, y1) - integral(x1, y0) + integral(x0, y0);
    (sum / area).as_vec4()
}

use crate::pipeline::compute::sat_box;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_summed_area_box_of_whole_texels_is_their_average() {
        let p = Pipeline::new(2).unwrap();
        let data: Vec<Vec4> = (0..64).map(|i| Vec4::splat(i as f32)).collect();
        let s = Surface::from_vec(8, 8, data).unwrap();
        let sat = summed_area_table(&p, &s);
        // A 3-texel box centred on texel (4, 2): texels 3..=5 of rows 1..=3.
        let uv = Vec2::new(4.5 / 8.0, 2.5 / 8.0);
        let want: f32 = (1..=3)
            .flat_map(|y| (3..=5).map(move |x| (y * 8 + x) as f32))
            .sum::<f32>()
            / 9.0;
        let got = sat_average(&sat, uv, 3.0);
        assert!((got.x - want).abs() < 1e-5, "{} vs {want}", got.x);
        // A box past the map's corner averages what is on the map.
        let corner = sat_average(&sat, Vec2::new(0.0, 0.0), 2.0);
        assert!((corner.x - 0.0).abs() < 1e-6);
        // Widths between whole texels change the average continuously.
        let (a, b) = (sat_average(&sat, uv, 3.0), sat_average(&sat, uv, 3.01));
        assert!((a.x - b.x).abs() < 0.05);
    }

    #[test]
    fn mips_and_blurs_keep_a_constant_map_constant() {
        let p = Pipeline::new(2).unwrap();
        let s = Surface::new(16, 16, Vec4::new(0.25, 0.0625, 1.0, 1.0)).unwrap();
        for kind in [
            Prefilter::None,
            Prefilter::Box,
            Prefilter::Gaussian,
            Prefilter::Mips,
            Prefilter::Sat,
        ] {
            let (f, _) =
                Prefiltered::build(&p, std::slice::from_ref(&s), kind, 2, SatSums::F64, false, Storage::F32).unwrap();
            let mut out = [Vec4::ZERO];
            f.sample(Vec2::new(0.37, 0.81), 5.0, false, &mut out);
            assert!((out[0] - s.at(0, 0)).abs().max_element() < 1e-5, "{kind:?}: {}", out[0]);
        }
    }
}
