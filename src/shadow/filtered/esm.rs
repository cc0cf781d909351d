//! Exponential shadow maps (Salvi 2008; Annen et al. 2008; RTR 7.7).
//!
//! The depth test `H(z - t)` (lit when the occluder depth `z` is at or beyond the receiver's
//! `t`) is replaced by `e^(c (z - t))`, clamped to 1, which is exact when the receiver is
//! behind every occluder of the kernel (`t >= z`) and factors into a stored `e^(c z)` and a
//! per-pixel `e^(-c t)`: so the stored `e^(c z)` can be filtered. Depth is linear in `[0, 1]`.
//!
//! - Log-space filtering (`log=true`, Salvi 2008): the map stores `c z` and every filter
//!   computes `ln(sum w e^(c z))` with the largest term taken out, so nothing overflows
//!   whatever `c`; the visibility is `e^(filtered - c t)`. Summed-area tables cannot sum
//!   logarithms: with `prefilter=sat` the map must store the exponentials (`log=false`).
//! - Without it (`log=false`) the map stores `e^(c z)`: `c z` must stay below the storage's
//!   limit, `ln(f32::MAX) = 88.72` for f32 and `ln(65504) = 11.09` for f16. Past it the stored
//!   value overflows; the pass clamps it to the storage's largest value and says so in
//!   `notes()`, so no infinity reaches the image (the shadow there is wrong: too light).
//!
//! Known failure: receivers close to their occluder (`t` just past `z`) get
//! `e^(-c (t - z))`, close to 1: too much light near contact (the reason for CESM), on the
//! `contact` fixture at the box's foot; a larger `c` narrows it.

use super::{build, FilteredPass, Filtering, Moments, Prefilter, Storage};
use crate::math;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::options::within;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;
use glam::{Vec2, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "esm",
    family: Family::Filtered,
    summary: "exponential shadow map (Salvi 2008; Annen et al. 2008): e^(c z) prefiltered in log space: too much light near contact",
    sweep: &[&[], &[("exponent", "30")], &[("log", "false"), ("prefilter", "sat")]],
    extended: &[&[("prefilter", "mips")], &[("storage", "f16"), ("exponent", "10"), ("log", "false")]],
    ..Entry::BASE
};

/// The largest exponent `c` whose `e^c` a 32-bit float holds (`ln(f32::MAX)`): past it no
/// exponential map exists in any storage.
pub const F32_LIMIT: f32 = 88.72;

/// The largest `c` whose `e^c` a 16-bit float holds (`ln(65504)`).
pub const F16_LIMIT: f32 = 11.09;

/// Options of the exponential shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass, the prefilter and the channel storage (f32 or f16). Default: their
    /// defaults (512 texels, 9x9 Gaussian, f32).
    pub filtering: Filtering,
    /// The exponent `c`. Default: 80.
    pub exponent: f32,
    /// Filter in log space. Default: true.
    pub log: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            filtering: Filtering::default(),
            exponent: 80.0,
            log: true,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(Filtering::fields(), |o: &mut Options| &mut o.filtering);
    fields.extend([
        Field::range(
            "exponent",
            "the exponent c of e^(c z), z linear depth in [0, 1] (at most ln(f32::MAX) = 88.72)",
            0.01,
            F32_LIMIT,
            |o: &mut Options| &mut o.exponent,
        ),
        Field::new(
            "log",
            "filter in log space (store c z; never overflows; not with prefilter=sat)",
            |o: &mut Options| &mut o.log,
        ),
    ]);
    Declaration::new("esm", fields)
}

/// The exponential representation.
#[derive(Clone, Debug, PartialEq)]
pub struct Exponential {
    storage: Storage,
    c: f32,
    log: bool,
}

impl Moments for Exponential {
    const STORAGES: &'static [Storage] = &[Storage::F32, Storage::F16];

    fn planes(&self) -> usize {
        1
    }

    fn channels(&self) -> Vec<String> {
        vec![if self.log { "cz".into() } else { "exp_cz".into() }]
    }

    fn storage(&self) -> Storage {
        self.storage
    }

    fn log_space(&self) -> bool {
        self.log
    }

    fn encode(&self, t: f32, _: Vec2, out: &mut [Vec4]) {
        let v = if self.log { self.c * t } else { math::exp(self.c * t) };
        out[0] = Vec4::new(v, 0.0, 0.0, 0.0);
    }

    fn visibility(&self, m: &[Vec4], t: f32, tr: &mut impl Trace) -> f32 {
        // ln of the filtered e^(c z), so that e^(ln - c t) never overflows.
        let ln = if self.log { m[0].x } else { math::ln(m[0].x) };
        let v = math::exp(ln - self.c * t).min(1.0);
        tr.step(|| {
            Step::new(
                "exponential test",
                "e^(c z) filtered over the kernel, times e^(-c t) of the receiver, at most 1",
            )
            .num("c", self.c)
            .num("ln of filtered e^(c z)", ln)
            .num("c t", self.c * t)
            .num("e^(c (z - t))", v)
        });
        v
    }
}

/// The exponential shadow map (see the module docs).
pub type Esm = PassTechnique<FilteredPass<Exponential>>;

impl Esm {
    /// An exponential shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Esm, Error> {
        build(declaration(), &opts, &opts.filtering, None, |d| {
            if opts.log && opts.filtering.prefilter == Prefilter::Sat {
                return Err(d.error(
                    "log",
                    "true",
                    "cannot be used with prefilter=sat: a summed-area table sums the exponentials themselves (set log=false)",
                ));
            }
            Ok(Exponential {
                storage: opts.filtering.storage,
                c: opts.exponent,
                log: opts.log,
            })
        })
    }
}
