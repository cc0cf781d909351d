//! Convolution shadow maps (Annen et al. 2007; RTR 7.7).
//!
//! The depth test `H(z - t)` (lit when the occluder depth `z` is at or beyond the receiver's
//! `t`, both linear in `[0, 1]`) is expanded as the Fourier series of a square wave of period
//! 2, truncated after `M` terms (Annen et al. 2007, eqs. 5-6):
//!
//! `H(z - t) ~ 1/2 + 2 sum_k (1 / c_k) sin(c_k (z - t))`, `c_k = pi (2k - 1)`, `k = 1..M`,
//!
//! and `sin(c_k (z - t)) = sin(c_k z) cos(c_k t) - cos(c_k z) sin(c_k t)` separates the
//! occluder from the receiver: the map stores the `2M` basis values `sin(c_k z)` and
//! `cos(c_k z)` (`M/2` planes of four channels), which filter linearly, and the lookup
//! weighs the filtered values with the receiver's `cos(c_k t)` and `sin(c_k t)`.
//!
//! - `damping`: each term's weight times `e^(-damping (k / M)^2)`, Annen et al.'s
//!   attenuation against ringing (0: none), which widens the step.
//! - `offset`: the truncated step rises over about `1 / M` of depth around `z = t`, so a
//!   receiver on its own occluder would be half lit; the receiver is moved toward the light by
//!   `offset / M` (in linear depth, the series' own transition width, not a scene's).
//!
//! Known failure: ringing. The truncated series overshoots and undershoots around the step
//! (the Gibbs phenomenon), so receivers just behind an occluder get some light back, and the
//! error falls slowly as `M` grows (on `overlap`).

use super::{build, FilteredPass, Filtering, Moments, Storage, MAX_PLANES};
use crate::math;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::options::within;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;
use glam::{Vec2, Vec4};
use std::f32::consts::PI;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "convolution",
    family: Family::Filtered,
    summary: "convolution shadow map (Annen et al. 2007): the depth test as a Fourier series, filtered: rings around the step",
    sweep: &[&[], &[("terms", "4")]],
    extended: &[&[("terms", "16")], &[("damping", "2")]],
    ..Entry::BASE
};

/// Options of the convolution shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass, the prefilter and the channel storage (f32 or f16). Default: their
    /// defaults (512 texels, 9x9 Gaussian, f32; the map holds `2 terms` channels).
    pub filtering: Filtering,
    /// Fourier terms `M` (1 to 16; an even number fills the planes). Default: 8.
    pub terms: u32,
    /// Attenuation of the higher terms against ringing (0: none). Default: 0.
    pub damping: f32,
    /// The receiver moved toward the light by `offset / terms` of linear depth. Default: 1.
    pub offset: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            filtering: Filtering::default(),
            terms: 8,
            damping: 0.0,
            offset: 1.0,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(Filtering::fields(), |o: &mut Options| &mut o.filtering);
    fields.extend([
        Field::range(
            "terms",
            "Fourier terms M of the depth test (2M channels a texel)",
            1,
            2 * MAX_PLANES as u32,
            |o: &mut Options| &mut o.terms,
        ),
        Field::range(
            "damping",
            "attenuation e^(-damping (k/M)^2) of term k against ringing",
            0.0,
            100.0,
            |o: &mut Options| &mut o.damping,
        ),
        Field::range(
            "offset",
            "receiver moved toward the light by offset / M of linear depth",
            0.0,
            100.0,
            |o: &mut Options| &mut o.offset,
        ),
    ]);
    Declaration::new("convolution", fields)
}

/// The Fourier basis of the depth test.
#[derive(Clone, Debug, PartialEq)]
pub struct Fourier {
    storage: Storage,
    terms: usize,
    /// Per term: the weight `2 / c_k` (times the damping).
    weights: Vec<f32>,
    offset: f32,
}

impl Fourier {
    fn new(storage: Storage, terms: u32, damping: f32, offset: f32) -> Fourier {
        let m = terms as f32;
        let weights = (1..=terms)
            .map(|k| {
                let ck = PI * (2 * k - 1) as f32;
                let att = math::exp(-damping * (k as f32 / m) * (k as f32 / m));
                2.0 / ck * att
            })
            .collect();
        Fourier {
            storage,
            terms: terms as usize,
            weights,
            offset: offset / m,
        }
    }
}

/// `f(k, sin(c_k x), cos(c_k x))` for the series' `n` frequencies `c_k = pi (2k - 1)`: one
/// `sin_cos` of `pi x`, then the angle-addition steps by `2 pi x` in f64 (an error of a few
/// units of the f64's last place per term, far below the f32 results' rounding), so a texel
/// or pixel costs one transcendental call instead of one per term.
#[inline]
fn odd_harmonics(x: f32, n: usize, mut f: impl FnMut(usize, f32, f32)) {
    let (s1, c1) = math::sin_cos_f64(std::f64::consts::PI * x as f64);
    // sin and cos of the step 2 pi x.
    let (s2, c2) = (2.0 * s1 * c1, c1 * c1 - s1 * s1);
    let (mut s, mut c) = (s1, c1);
    for k in 0..n {
        f(k, s as f32, c as f32);
        (s, c) = (s * c2 + c * s2, c * c2 - s * s2);
    }
}

impl Moments for Fourier {
    const STORAGES: &'static [Storage] = &[Storage::F32, Storage::F16];

    fn planes(&self) -> usize {
        self.terms.div_ceil(2)
    }

    fn channels(&self) -> Vec<String> {
        (1..=self.terms)
            .flat_map(|k| [format!("sin{k}"), format!("cos{k}")])
            .collect()
    }

    fn storage(&self) -> Storage {
        self.storage
    }

    fn encode(&self, t: f32, _: Vec2, out: &mut [Vec4]) {
        for o in out.iter_mut() {
            *o = Vec4::ZERO;
        }
        odd_harmonics(t, self.terms, |k, s, c| {
            let (p, l) = (k / 2, (k % 2) * 2);
            out[p][l] = s;
            out[p][l + 1] = c;
        });
    }

    fn visibility(&self, m: &[Vec4], t: f32, tr: &mut impl Trace) -> f32 {
        // Annen et al. 2007, eq. 6: 1/2 + sum_k w_k (E[sin c_k z] cos c_k t - E[cos c_k z] sin c_k t).
        let d = t - self.offset;
        let mut v = 0.5f32;
        odd_harmonics(d, self.terms, |k, s, c| {
            let (p, l) = (k / 2, (k % 2) * 2);
            v += self.weights[k] * (m[p][l] * c - m[p][l + 1] * s);
        });
        tr.step(|| {
            Step::new(
                "fourier series",
                "1/2 plus the terms' filtered basis weighed by the receiver's (Annen et al. 2007, eq. 6), then clamped to [0, 1]",
            )
            .int("terms", self.terms)
            .num("receiver depth (moved by the offset)", d)
            .num("series", v)
        });
        v
    }
}

/// The convolution shadow map (see the module docs).
pub type Convolution = PassTechnique<FilteredPass<Fourier>>;

impl Convolution {
    /// A convolution shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Convolution, Error> {
        build(declaration(), &opts, &opts.filtering, None, |_| {
            Ok(Fourier::new(
                opts.filtering.storage,
                opts.terms,
                opts.damping,
                opts.offset,
            ))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The recurrence gives each term's sine and cosine as a direct call would, to within
    /// the f32 results' rounding, over the whole depth range and all 16 terms.
    #[test]
    fn odd_harmonics_are_the_terms_sines_and_cosines() {
        let mut worst = 0f64;
        for i in 0..=1000 {
            let x = i as f32 / 1000.0 - 0.1;
            odd_harmonics(x, 16, |k, s, c| {
                let a = std::f64::consts::PI * (2 * k + 1) as f64 * x as f64;
                let (ws, wc) = math::sin_cos_f64(a);
                worst = worst.max((s as f64 - ws).abs()).max((c as f64 - wc).abs());
            });
        }
        assert!(worst < 1.2e-7, "largest difference {worst}");
    }
}
