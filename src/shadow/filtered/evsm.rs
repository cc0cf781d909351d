//! Exponential variance shadow maps (Lauritzen and McCool 2008; RTR 7.7).
//!
//! The linear depth is rescaled to `d = 2 t - 1` in `[-1, 1]` and warped by `w+ = e^(c+ d)`
//! and `w- = -e^(-c- d)`, both increasing in `d`; each warp's first two moments are stored
//! (four channels; two with `components=2`, the positive warp only) and filtered, and the
//! visibility is the smaller of the two warps' Chebyshev bounds (RTR eq. 7.8). The warps
//! shrink the variance of distant occluders relative to the receiver's distance from them,
//! which is where VSM bleeds.
//!
//! - The least variance is the VSM's, carried through each warp's slope at the receiver
//!   (`min_variance * (dw/dt)^2`), so it means the same depth spread in either warp.
//! - Exponent limits: a warp's second moment is `e^(2 c)`, so `c` must stay below
//!   `ln(max) / 2` of the storage: 44.36 for f32, 5.54 for f16 (Lauritzen and McCool; MJP's
//!   sample clamps at 42 and 5.54). An exponent past it overflows the stored second moment;
//!   the pass clamps it to the storage's largest value and says so in `notes()`, so no
//!   infinity reaches the image. Defaults as MJP's: 40 and 5 in f32.
//!
//! Known failure: less bleeding than VSM, but not none: where occluders overlap at depths
//! the warp does not separate, light still leaks (`overlap`).

use super::{bleeding_field, build, chebyshev, reduce_bleeding, FilteredPass, Filtering, Moments, Storage};
use crate::math;
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::options::within;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;
use glam::{Vec2, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "evsm",
    family: Family::Filtered,
    summary: "exponential variance shadow map (Lauritzen and McCool 2008): VSM of two exponential warps: less bleeding, exponent limits of the storage",
    sweep: &[&[], &[("components", "2")], &[("storage", "f16"), ("positive", "5.54")]],
    extended: &[&[("positive", "80")]],
    ..Entry::BASE
};

/// Options of the exponential variance shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass, the prefilter and the channel storage (f32 or f16). Default: their
    /// defaults (512 texels, 9x9 Gaussian, f32).
    pub filtering: Filtering,
    /// Warps stored: 2 (the positive one) or 4 (both). Default: 4.
    pub components: u32,
    /// The positive warp's exponent `c+`. Default: 40.
    pub positive: f32,
    /// The negative warp's exponent `c-`. Default: 5.
    pub negative: f32,
    /// Least variance (in linear depth squared, carried through each warp: a spread of 0.001 of the depth range by default, far below the VSM's, since the warps, not the variance, keep flat receivers lit). Default: 0.000001.
    pub min_variance: f32,
    /// Light-bleeding reduction amount (0: none). Default: 0.
    pub bleeding: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            filtering: Filtering::default(),
            components: 4,
            positive: 40.0,
            negative: 5.0,
            min_variance: 0.000001,
            bleeding: 0.0,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(Filtering::fields(), |o: &mut Options| &mut o.filtering);
    fields.extend([
        Field::range(
            "components",
            "channels stored: 2 (the positive warp) or 4 (both warps)",
            2,
            4,
            |o: &mut Options| &mut o.components,
        ),
        Field::range(
            "positive",
            "exponent of the positive warp e^(c d) (limits of the stored square: 44.36 in f32, 5.54 in f16)",
            0.01,
            88.72,
            |o: &mut Options| &mut o.positive,
        ),
        Field::range(
            "negative",
            "exponent of the negative warp -e^(-c d)",
            0.01,
            88.72,
            |o: &mut Options| &mut o.negative,
        ),
        Field::range(
            "min_variance",
            "least variance, in linear depth squared (scaled by each warp's slope)",
            0.0,
            1.0,
            |o: &mut Options| &mut o.min_variance,
        ),
        bleeding_field(|o: &mut Options| &mut o.bleeding),
    ]);
    Declaration::new("evsm", fields)
}

/// The two exponential warps and their moments.
#[derive(Clone, Debug, PartialEq)]
pub struct Warped {
    storage: Storage,
    both: bool,
    cp: f32,
    cn: f32,
    min_variance: f32,
    bleeding: f32,
}

impl Warped {
    /// The warps of linear depth `t`: `(e^(c+ d), -e^(-c- d))` with `d = 2 t - 1`.
    #[inline(always)]
    fn warp(&self, t: f32) -> (f32, f32) {
        let d = 2.0 * t - 1.0;
        (math::exp(self.cp * d), -math::exp(-self.cn * d))
    }
}

impl Moments for Warped {
    const STORAGES: &'static [Storage] = &[Storage::F32, Storage::F16];

    fn planes(&self) -> usize {
        1
    }

    fn channels(&self) -> Vec<String> {
        let mut c: Vec<String> = vec!["pos".into(), "pos2".into()];
        if self.both {
            c.extend(["neg".into(), "neg2".into()]);
        }
        c
    }

    fn storage(&self) -> Storage {
        self.storage
    }

    fn encode(&self, t: f32, _: Vec2, out: &mut [Vec4]) {
        let (p, n) = self.warp(t);
        out[0] = if self.both {
            Vec4::new(p, p * p, n, n * n)
        } else {
            Vec4::new(p, p * p, 0.0, 0.0)
        };
    }

    fn visibility(&self, m: &[Vec4], t: f32, tr: &mut impl Trace) -> f32 {
        let (wp, wn) = self.warp(t);
        // The warps' slopes dw/dt at the receiver: 2 c+ w+ and 2 c- |w-|.
        let (sp, sn) = (2.0 * self.cp * wp, 2.0 * self.cn * wn.abs());
        let (pp, vp) = chebyshev(m[0].x, m[0].y, wp, self.min_variance * sp * sp);
        let (pn, vn) = if self.both {
            chebyshev(m[0].z, m[0].w, wn, self.min_variance * sn * sn)
        } else {
            (1.0, 0.0)
        };
        let v = reduce_bleeding(pp.min(pn), self.bleeding);
        tr.step(|| {
            Step::new(
                "warped chebyshev",
                "the receiver's warps against each warp's filtered moments (RTR eq. 7.8); the smaller bound, then the bleeding reduction",
            )
            .num("positive warp", wp)
            .num("positive variance", vp)
            .num("positive bound", pp)
            .num("negative warp", wn)
            .num("negative variance", vn)
            .num("negative bound", pn)
        });
        v
    }
}

/// The exponential variance shadow map (see the module docs).
pub type Evsm = PassTechnique<FilteredPass<Warped>>;

impl Evsm {
    /// An exponential variance shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Evsm, Error> {
        build(declaration(), &opts, &opts.filtering, None, |d| {
            if opts.components != 2 && opts.components != 4 {
                let v = opts.components.to_string();
                return Err(d.error("components", &v, "is neither 2 nor 4"));
            }
            Ok(Warped {
                storage: opts.filtering.storage,
                both: opts.components == 4,
                cp: opts.positive,
                cn: opts.negative,
                min_variance: opts.min_variance,
                bleeding: opts.bleeding,
            })
        })
    }
}
